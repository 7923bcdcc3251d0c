//! The fit in the camera's post-perspective space (PSM): a virtual camera pulled back until
//! every caster lies in front of it, the light fitted in its clip space, inverted when the light
//! lies behind its plane.

use glam::{Mat4, Vec3, Vec4};

use super::world::{bounding_sphere, fit_directional, fit_point, up_for};
use super::{Camera, Fit, FitKind, FitOptions, Light, PullBack, Sphere};
use glam::camera::rh::view::look_to_mat4;

/// The fit in post-perspective space: the camera pulled back until every caster is in front of
/// its near plane, receivers, casters and the light through that camera's projection, a light
/// frustum fitted there — inverted when the light is behind the camera's plane — composed with
/// the camera's matrix.
pub(super) fn fit_psm(
    light: Light,
    camera: &Camera,
    (receivers, casters): (&[Vec3], &[Vec3]),
    pull: PullBack,
    o: &FitOptions,
) -> Fit {
    let (near, _) = camera.depth_range();
    let depth = |p: &Vec3| -camera.view.transform_point3(*p).z;
    let closest = receivers.iter().chain(casters).map(depth).fold(f32::INFINITY, f32::min);
    let mut pull_back = (near - closest).max(0.0);
    if pull == PullBack::Balanced {
        let (zn, zf) = receivers.iter().map(depth).fold((f32::INFINITY, 0.0f32), |(a, b), d| (a.min(d), b.max(d)));
        pull_back = pull_back.max((zn.max(near) * zf.max(near)).sqrt());
    }
    let virtual_camera = camera.pulled_back(pull_back);
    let pps: Vec<Vec3> = receivers.iter().map(|&p| virtual_camera.project_point3(p)).collect();
    let sphere = bounding_sphere(&pps).expect("receivers are not empty");
    let sphere = Sphere { centre: sphere.centre, radius: sphere.radius.max(1e-4) };
    let all: Vec<Vec3> = pps.iter().copied().chain(casters.iter().map(|&p| virtual_camera.project_point3(p))).collect();
    let everything = bounding_sphere(&all).expect("receivers are not empty");
    let h = match light {
        Light::Point(p) => virtual_camera * p.extend(1.0),
        // A directional light is a point at infinity opposite its travel direction.
        Light::Directional(d) => virtual_camera * (-d).extend(0.0),
    };
    let pps_options = FitOptions { near: 1e-3, scene: everything, ..o.plain() };
    let (m, kind) = if h.w.abs() <= 1e-4 * h.truncate().length() {
        // On the camera's plane: at infinity in post-perspective space, its light travelling
        // along −h (toward the light's image when it lies behind, away from it in front).
        (fit_directional(-h.truncate(), sphere, &pps_options), FitKind::Visible)
    } else if h.w > 0.0 {
        // The near plane just before the nearest receiver or caster: post-perspective space is
        // small and the light's image may be far from it, so a fixed near plane would leave the
        // map no depth precision.
        let l = h.truncate() / h.w;
        let forward = (sphere.centre - l).normalize_or_zero();
        let nearest = all.iter().map(|p| forward.dot(*p - l)).fold(f32::INFINITY, f32::min);
        let near = (0.9 * nearest).max(1e-4 * (sphere.centre - l).length()).max(1e-6);
        fit_point(l, sphere, &FitOptions { near, ..pps_options })
    } else {
        (inverted_point(h.truncate() / h.w, sphere, &all, &pps_options), FitKind::InvertedPsm)
    };
    Fit { view_proj: m * virtual_camera, sphere, kind, pull_back }
}

/// The inverted perspective frustum of a light whose post-perspective image `light` lies
/// behind the camera's plane: its rays arrive from beyond the receivers and run toward
/// `light`, so a caster lies farther from `light` than what it shades. The frustum looks from
/// `light` through `sphere` and its depth falls from 1 at the receivers' nearest point to 0 at
/// the farthest of `points`, so the depth test keeps the point nearest the real light.
fn inverted_point(light: Vec3, sphere: Sphere, points: &[Vec3], o: &FitOptions) -> Mat4 {
    let max_fov = o.max_fov_degrees.to_radians().clamp(0.01, 3.0);
    let to_centre = sphere.centre - light;
    let dist = to_centre.length();
    let forward = if dist > 1e-6 { to_centre / dist } else { Vec3::NEG_Z };
    let fov = if dist > sphere.radius * 1.0001 { (2.0 * (sphere.radius / dist).asin()).min(max_fov) } else { max_fov };
    let d_near = (dist - sphere.radius).max(o.near.max(1e-4));
    let d_far = points.iter().map(|p| forward.dot(*p - light)).fold(dist + sphere.radius, f32::max).max(d_near * 2.0);
    let view = look_to_mat4(light, forward, up_for(forward));
    let s = 1.0 / (0.5 * fov).tan();
    // Depth d along the axis (view z = −d): ndc z = a + b / d, 1 at d_near, 0 at d_far.
    let b = d_near * d_far / (d_far - d_near);
    let a = -d_near / (d_far - d_near);
    let projection = Mat4::from_cols(
        Vec4::new(s, 0.0, 0.0, 0.0),
        Vec4::new(0.0, s, 0.0, 0.0),
        Vec4::new(0.0, 0.0, -a, -1.0),
        Vec4::new(0.0, 0.0, b, 0.0),
    );
    projection * view
}
