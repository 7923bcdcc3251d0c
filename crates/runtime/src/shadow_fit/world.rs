//! The world-space fit: a perspective frustum from a positional light through the sphere, or an
//! orthographic box around it along a directional light, each optionally snapped to the texel
//! grid.

use glam::camera::rh::proj::directx;
use glam::camera::rh::view::look_to_mat4;
use glam::{Mat4, Vec3};

use super::{FitKind, FitOptions, Light, Sphere};

/// The sphere of a point set: the centre of its axis-aligned box and the largest distance from
/// it. `None` for no points.
pub fn bounding_sphere(points: &[Vec3]) -> Option<Sphere> {
    let first = *points.first()?;
    let (lo, hi) = points.iter().fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let centre = 0.5 * (lo + hi);
    let r2 = points.iter().fold(0.0f32, |m, &p| m.max(p.distance_squared(centre)));
    Some(Sphere { centre, radius: r2.sqrt() })
}

/// An up vector not parallel to `forward`.
pub(super) fn up_for(forward: Vec3) -> Vec3 {
    if forward.normalize_or_zero().y.abs() > 0.99 { Vec3::Z } else { Vec3::Y }
}

/// Rounds `r` up to the ladder `1.1^k` so small changes of the fitted size change nothing.
fn snap_size(r: f32) -> f32 {
    if r <= 0.0 {
        return r;
    }
    1.1f32.powf((r.ln() / 1.1f32.ln()).ceil())
}

fn snap(v: f32, step: f32) -> f32 {
    if step > 0.0 { (v / step).round() * step } else { v }
}

/// The perspective frustum from a positional light through `sphere`.
pub(super) fn fit_point(light: Vec3, sphere: Sphere, o: &FitOptions) -> (Mat4, FitKind) {
    let max_fov = o.max_fov_degrees.to_radians().clamp(0.01, 3.0);
    let to_centre = sphere.centre - light;
    let dist = to_centre.length();
    let (forward, fov, kind) = if dist <= sphere.radius * 1.0001 {
        let f = if dist > 1e-6 { to_centre / dist } else { Vec3::NEG_Z };
        (f, max_fov, FitKind::LightInside)
    } else {
        (to_centre / dist, (2.0 * (sphere.radius / dist).asin()).min(max_fov), FitKind::Visible)
    };
    let radius = sphere.radius.max(1e-6);
    let near = o.near.max(1e-4);
    let far = (dist + radius).max(near * 2.0);
    if o.snapping()
        && kind == FitKind::Visible
        && dist > radius * 1.8
        && let Some(m) = snapped_point(light, sphere, forward, (near, far), o)
    {
        return (m, kind);
    }
    let view = look_to_mat4(light, forward, up_for(forward));
    (directx::perspective(fov, 1.0, near, far) * view, kind)
}

/// Angular step the aim of a snapped point-light frustum moves in.
const AIM_STEP: f32 = 0.05;

/// The snapped perspective frustum: the aim quantised to a coarse angular grid (so the view
/// rotation rarely changes), and an off-centre window on the image plane whose size follows the
/// size ladder and whose corner sits on its own texel grid — the perspective analogue of
/// snapping an orthographic box. A static point then keeps its place within its texel until
/// the size steps or the aim moves a grid step.
fn snapped_point(light: Vec3, sphere: Sphere, forward: Vec3, (near, far): (f32, f32), o: &FitOptions) -> Option<Mat4> {
    let azimuth = snap(forward.z.atan2(forward.x), AIM_STEP);
    let elevation = snap(forward.y.clamp(-1.0, 1.0).asin(), AIM_STEP);
    let aim = Vec3::new(elevation.cos() * azimuth.cos(), elevation.sin(), elevation.cos() * azimuth.sin());
    let view = look_to_mat4(light, aim, up_for(aim));
    // The sphere's exact extent on the image plane z = −1, one axis at a time: the planes
    // through the other axis tangent to the sphere.
    let c = view.transform_point3(sphere.centre);
    let extent = |a: f32| {
        let d = (a * a + c.z * c.z).sqrt();
        if d <= sphere.radius * 1.0001 || c.z >= 0.0 {
            return None;
        }
        let (mid, half) = (a.atan2(-c.z), (sphere.radius / d).asin());
        if (mid.abs() + half) >= 1.5 {
            return None; // the window would reach the horizon
        }
        Some(((mid - half).tan(), (mid + half).tan()))
    };
    let ((x0, x1), (y0, y1)) = (extent(c.x)?, extent(c.y)?);
    let (lo, hi) = (glam::Vec2::new(x0, y0), glam::Vec2::new(x1, y1));
    let size = snap_size((hi - lo).max_element());
    // The window is `resolution` texels wide, one spare on each side: snapping the corner to
    // the grid moves it by at most half a texel, and the sphere stays inside.
    let texel = size / (o.resolution.max(4) - 2) as f32;
    let centre = 0.5 * (lo + hi);
    let corner = glam::Vec2::new(snap(centre.x - 0.5 * size, texel), snap(centre.y - 0.5 * size, texel));
    let (l, b) = (corner.x - texel, corner.y - texel);
    let span = texel * o.resolution.max(4) as f32;
    let (r, t) = (l + span, b + span);
    // The far plane on the size ladder too, so an unchanged window gives identical depths.
    Some(directx::frustum(l * near, r * near, b * near, t * near, near, snap_size(far)) * view)
}

/// The orthographic box around `sphere` along `dir`, reaching back to the scene's bounds.
pub(super) fn fit_directional(dir: Vec3, sphere: Sphere, o: &FitOptions) -> Mat4 {
    let dir = dir.normalize_or(Vec3::NEG_Y);
    // The rotation depends on the light only, so snapping in its frame is stable.
    let view = look_to_mat4(Vec3::ZERO, dir, up_for(dir));
    let c = view.transform_point3(sphere.centre);
    let mut r = sphere.radius.max(1e-6);
    let (mut cx, mut cy, mut cz) = (c.x, c.y, c.z);
    if o.snapping() {
        r = snap_size(r);
        let texel = 2.0 * r / o.resolution.max(1) as f32;
        (cx, cy, cz) = (snap(cx, texel), snap(cy, texel), snap(c.z, r / 4.0));
    }
    // View space looks along −z: toward the light is +z. Reach the scene's casters.
    let scene_z = view.transform_point3(o.scene.centre).z + o.scene.radius;
    // Snapping moved the centre's depth by at most r/8: the far side keeps that margin.
    let margin = if o.snapping() { r / 8.0 } else { 0.0 };
    let z_near = scene_z.max(cz + r + margin);
    let z_far = cz - r - margin;
    directx::orthographic(cx - r, cx + r, cy - r, cy + r, -z_near, -z_far) * view
}

/// The plain fit (world space) of `light` to `sphere`.
pub(super) fn fit_world(light: Light, sphere: Sphere, o: &FitOptions) -> (Mat4, FitKind) {
    match light {
        Light::Point(p) => fit_point(p, sphere, o),
        Light::Directional(d) => (fit_directional(d, sphere, o), FitKind::Visible),
    }
}
