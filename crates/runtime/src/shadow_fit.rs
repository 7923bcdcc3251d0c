//! Per-frame shadow-map fitting (seed 001, Iwao, Kanbara & Yokoya): the light's view and
//! projection fitted each frame to the bounding sphere of the geometry the camera sees.
//!
//! [`visible_points`] transforms every vertex to the camera's clip space (`P·C·W`) and keeps
//! those inside `-w ≤ x, y ≤ w, 0 ≤ z ≤ w` (wgpu's depth range, as the paper's Direct3D). That
//! vertex test alone — the paper's — misses a triangle whose vertices all lie outside the view
//! but which covers it (a ground plane), so triangles crossing the view's boundary are also
//! clipped against it and the clipped polygon's corners kept. [`fit`] takes the centre of their
//! axis-aligned box and the largest distance from it as a sphere and builds the light's
//! matrices:
//! - point and spot lights: a perspective frustum from the light through the sphere,
//!   `far = |light − centre| + r`, field of view `2·asin(r / |light − centre|)`, near from the
//!   options. Everything between the light and the sphere inside that cone is in the frustum,
//!   so casters outside the view that shade visible geometry are kept.
//! - directional lights: an orthographic box around the sphere, extended toward the light to
//!   the scene's bounds so off-screen casters are kept.
//!
//! Options: the same fit in the camera's post-perspective space ([`FitOptions::psm`], Stamminger
//! & Drettakis 2002), and snapping of the fitted size and centre to the shadow-map texel grid
//! ([`FitOptions::snap`]) so shadow edges do not shimmer as the camera moves.
//!
//! Defined results where the fit has no answer: nothing visible gives the fixed frustum around
//! the whole scene ([`FitKind::NothingVisible`]); a positional light inside the sphere aims at
//! its centre with the widest allowed field of view ([`FitKind::LightInside`]). Never NaN.

use glam::camera::rh::proj::directx;
use glam::camera::rh::view::look_to_mat4;
use glam::{Mat4, Vec3, Vec4};

/// A light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// A point or spot light at a position (one perspective shadow map toward the view).
    Point(Vec3),
    /// A directional light; the vector is the direction its light travels.
    Directional(Vec3),
}

/// A sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub centre: Vec3,
    /// Radius.
    pub radius: f32,
}

/// Geometry for the visibility test: world matrix, positions and a triangle list.
#[derive(Clone, Copy, Debug)]
pub struct MeshRef<'a> {
    /// Object → world.
    pub world: Mat4,
    /// Object-space positions.
    pub positions: &'a [Vec3],
    /// Triangle list (three indices per triangle).
    pub indices: &'a [u32],
}

/// How to fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    /// Near plane of point/spot light frusta (world units).
    pub near: f32,
    /// Widest field of view used, degrees (a light inside the sphere gets this).
    pub max_fov_degrees: f32,
    /// Shadow-map texels per side (for snapping).
    pub resolution: u32,
    /// Snap size and centre to the texel grid.
    pub snap: bool,
    /// Fit in the camera's post-perspective space.
    pub psm: bool,
    /// Keep only the paper's vertex test (no triangle clipping): for comparison.
    pub vertex_test_only: bool,
    /// Bounds of every caster in the scene: the directional box reaches them, and nothing
    /// visible falls back to a frustum around them.
    pub scene: Sphere,
}

impl FitOptions {
    /// The defaults for a scene bounded by `scene`: near plane 1, at most 120° of field of view,
    /// 1024² texels, the seed's fit with triangle clipping, no snapping, no PSM. Set the fields
    /// that differ with struct update syntax.
    pub fn new(scene: Sphere) -> FitOptions {
        FitOptions {
            near: 1.0,
            max_fov_degrees: 120.0,
            resolution: 1024,
            snap: false,
            psm: false,
            vertex_test_only: false,
            scene,
        }
    }
}

/// Which case the fit took.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitKind {
    /// Fitted to the visible geometry.
    Visible,
    /// Nothing is visible: the fixed frustum around the whole scene.
    NothingVisible,
    /// A positional light inside the sphere: aimed at its centre, widest field of view.
    LightInside,
    /// PSM was asked for but the light lies behind the camera plane (its post-perspective image
    /// inverts): the plain fit was used.
    PsmFallback,
}

/// A fitted light projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// World → light clip space (wgpu conventions: depth 0..1). With PSM this includes the
    /// camera's view-projection.
    pub view_proj: Mat4,
    /// The sphere fitted (world space; post-perspective space with PSM).
    pub sphere: Sphere,
    /// The case taken.
    pub kind: FitKind,
}

/// Reusable buffers for [`visible_points`] (no allocation per frame once warm).
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    clip: Vec<Vec4>,
    codes: Vec<u8>,
    /// The visible points of the last call (world space).
    pub points: Vec<Vec3>,
}

fn outcode(c: Vec4) -> u8 {
    (c.x < -c.w) as u8
        | ((c.x > c.w) as u8) << 1
        | ((c.y < -c.w) as u8) << 2
        | ((c.y > c.w) as u8) << 3
        | ((c.z < 0.0) as u8) << 4
        | ((c.z > c.w) as u8) << 5
}

/// Signed distance of a clip-space point to boundary plane `k` (≥ 0 inside).
fn plane_distance(c: Vec4, k: usize) -> f32 {
    match k {
        0 => c.w + c.x,
        1 => c.w - c.x,
        2 => c.w + c.y,
        3 => c.w - c.y,
        4 => c.z,
        _ => c.w - c.z,
    }
}

/// Clips a polygon (clip-space and world-space corners together) against the view volume,
/// Sutherland–Hodgman, and appends the corners it creates on the boundary to `out`.
fn clip_polygon(mut poly: Vec<(Vec4, Vec3)>, out: &mut Vec<Vec3>) {
    for k in 0..6 {
        if poly.is_empty() {
            return;
        }
        let mut next = Vec::with_capacity(poly.len() + 2);
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let (da, db) = (plane_distance(a.0, k), plane_distance(b.0, k));
            if da >= 0.0 {
                next.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                let t = da / (da - db);
                next.push((a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t));
            }
        }
        poly = next;
    }
    out.extend(poly.into_iter().map(|(_, w)| w));
}

/// World positions of the geometry `camera_view_proj` sees: vertices inside the view volume,
/// and, unless `vertex_test_only`, the corners of every triangle crossing its boundary clipped
/// to it. Left in `scratch.points`.
pub fn visible_points(camera_view_proj: Mat4, meshes: &[MeshRef], vertex_test_only: bool, scratch: &mut Scratch) {
    scratch.points.clear();
    for mesh in meshes {
        let m = camera_view_proj * mesh.world;
        scratch.clip.clear();
        scratch.codes.clear();
        for &p in mesh.positions {
            let c = m * p.extend(1.0);
            let code = outcode(c);
            scratch.clip.push(c);
            scratch.codes.push(code);
            if code == 0 {
                scratch.points.push(mesh.world.transform_point3(p));
            }
        }
        if vertex_test_only {
            continue;
        }
        for tri in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
            let (Some(&ca), Some(&cb), Some(&cc)) = (scratch.codes.get(a), scratch.codes.get(b), scratch.codes.get(c))
            else {
                continue; // an index out of range names no vertex
            };
            // Entirely inside (its corners are kept already) or entirely beyond one plane.
            if ca | cb | cc == 0 || ca & cb & cc != 0 {
                continue;
            }
            let corner = |i: usize| (scratch.clip[i], mesh.world.transform_point3(mesh.positions[i]));
            clip_polygon(vec![corner(a), corner(b), corner(c)], &mut scratch.points);
        }
    }
}

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
fn up_for(forward: Vec3) -> Vec3 {
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
fn fit_point(light: Vec3, sphere: Sphere, o: &FitOptions) -> (Mat4, FitKind) {
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
    if o.snap
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
fn fit_directional(dir: Vec3, sphere: Sphere, o: &FitOptions) -> Mat4 {
    let dir = dir.normalize_or(Vec3::NEG_Y);
    // The rotation depends on the light only, so snapping in its frame is stable.
    let view = look_to_mat4(Vec3::ZERO, dir, up_for(dir));
    let c = view.transform_point3(sphere.centre);
    let mut r = sphere.radius.max(1e-6);
    let (mut cx, mut cy, mut cz) = (c.x, c.y, c.z);
    if o.snap {
        r = snap_size(r);
        let texel = 2.0 * r / o.resolution.max(1) as f32;
        (cx, cy, cz) = (snap(cx, texel), snap(cy, texel), snap(c.z, r / 4.0));
    }
    // View space looks along −z: toward the light is +z. Reach the scene's casters.
    let scene_z = view.transform_point3(o.scene.centre).z + o.scene.radius;
    // Snapping moved the centre's depth by at most r/8: the far side keeps that margin.
    let margin = if o.snap { r / 8.0 } else { 0.0 };
    let z_near = scene_z.max(cz + r + margin);
    let z_far = cz - r - margin;
    directx::orthographic(cx - r, cx + r, cy - r, cy + r, -z_near, -z_far) * view
}

/// The light fit for the points in `points` (see the module docs).
pub fn fit_to_points(light: Light, camera_view_proj: Mat4, points: &[Vec3], o: &FitOptions) -> Fit {
    let Some(sphere) = bounding_sphere(points) else {
        return Fit { view_proj: fixed(light, o), sphere: o.scene, kind: FitKind::NothingVisible };
    };
    if o.psm {
        if let Some(fit) = fit_psm(light, camera_view_proj, points, o) {
            return fit;
        }
        let plain = fit_to_points(light, camera_view_proj, points, &FitOptions { psm: false, ..*o });
        return Fit { kind: FitKind::PsmFallback, ..plain };
    }
    match light {
        Light::Point(p) => {
            let (view_proj, kind) = fit_point(p, sphere, o);
            Fit { view_proj, sphere, kind }
        }
        Light::Directional(d) => Fit { view_proj: fit_directional(d, sphere, o), sphere, kind: FitKind::Visible },
    }
}

/// The fit of the light to what `camera_view_proj` sees of `meshes`.
pub fn fit(light: Light, camera_view_proj: Mat4, meshes: &[MeshRef], o: &FitOptions, scratch: &mut Scratch) -> Fit {
    visible_points(camera_view_proj, meshes, o.vertex_test_only, scratch);
    fit_to_points(light, camera_view_proj, &scratch.points, o)
}

/// The fixed frustum around the whole scene (the baseline, and the fit when nothing is seen).
pub fn fixed(light: Light, o: &FitOptions) -> Mat4 {
    let plain = FitOptions { snap: false, psm: false, ..*o };
    match light {
        Light::Point(p) => fit_point(p, o.scene, &plain).0,
        Light::Directional(d) => fit_directional(d, o.scene, &plain),
    }
}

/// The fit in post-perspective space: visible points and the light through the camera's
/// projection, a light frustum fitted there, composed with the camera's matrix. `None` when
/// the light's image lies behind the camera plane (the projection inverts it).
fn fit_psm(light: Light, camera_view_proj: Mat4, points: &[Vec3], o: &FitOptions) -> Option<Fit> {
    let ndc: Vec<Vec3> = points.iter().map(|&p| camera_view_proj.project_point3(p)).collect();
    let sphere = bounding_sphere(&ndc)?;
    let h = match light {
        Light::Point(p) => camera_view_proj * p.extend(1.0),
        // A directional light is a point at infinity opposite its travel direction.
        Light::Directional(d) => camera_view_proj * (-d).extend(0.0),
    };
    // In post-perspective space the view volume is a box of size ~2; the scene sphere there.
    let pps = FitOptions {
        near: 1e-3,
        snap: false,
        psm: false,
        scene: Sphere { centre: sphere.centre, radius: sphere.radius.max(1e-4) },
        ..*o
    };
    let (m, kind) = if h.w > 1e-6 {
        fit_point(h.truncate() / h.w, sphere, &pps)
    } else if h.w.abs() <= 1e-6 {
        (fit_directional(-h.truncate(), sphere, &pps), FitKind::Visible)
    } else {
        return None;
    };
    Some(Fit { view_proj: m * camera_view_proj, sphere, kind })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::camera::rh::view::look_at_mat4;

    /// A camera 2 units above the ground at the origin looking along −z, slightly down; 60°,
    /// far plane at 40.
    fn camera() -> Mat4 {
        directx::perspective(60f32.to_radians(), 1.0, 0.1, 40.0)
            * look_at_mat4(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 0.0, -10.0), Vec3::Y)
    }

    fn ground() -> (Vec<Vec3>, Vec<u32>) {
        let h = 1000.0;
        (
            vec![Vec3::new(-h, 0.0, -h), Vec3::new(h, 0.0, -h), Vec3::new(h, 0.0, h), Vec3::new(-h, 0.0, h)],
            vec![0, 1, 2, 0, 2, 3],
        )
    }

    fn inside(m: Mat4, p: Vec3) -> bool {
        let c = m * p.extend(1.0);
        let e = 1e-4 * c.w.abs();
        c.w > 0.0 && c.x.abs() <= c.w + e && c.y.abs() <= c.w + e && c.z >= -e && c.z <= c.w + e
    }

    /// Ground points the camera sees: rays through a grid of pixels meeting y = 0 before the
    /// far plane.
    fn seen_ground(cam: Mat4) -> Vec<Vec3> {
        let inv = cam.inverse();
        let mut out = Vec::new();
        for j in 0..40 {
            for i in 0..40 {
                let (x, y) = (i as f32 / 39.0 * 2.0 - 1.0, j as f32 / 39.0 * 2.0 - 1.0);
                let (a, b) = (inv.project_point3(Vec3::new(x, y, 0.0)), inv.project_point3(Vec3::new(x, y, 1.0)));
                if (a.y > 0.0) == (b.y > 0.0) {
                    continue;
                }
                out.push(a + (b - a) * (a.y / (a.y - b.y)));
            }
        }
        out
    }

    #[test]
    fn a_ground_plane_with_every_vertex_outside_the_view_is_still_fitted() {
        let (positions, indices) = ground();
        let mesh = MeshRef { world: Mat4::IDENTITY, positions: &positions, indices: &indices };
        let cam = camera();
        let scene = Sphere { centre: Vec3::ZERO, radius: 1500.0 };
        let mut scratch = Scratch::default();
        // The seed's vertex test sees nothing at all.
        let vertex_only = FitOptions { vertex_test_only: true, ..FitOptions::new(scene) };
        let f = fit(Light::Point(Vec3::new(60.0, 150.0, -40.0)), cam, &[mesh], &vertex_only, &mut scratch);
        assert_eq!(f.kind, FitKind::NothingVisible);
        // Clipping finds the visible part; every ground point seen lies inside the light volume.
        let seen = seen_ground(cam);
        assert!(seen.len() > 500);
        for light in [Light::Point(Vec3::new(60.0, 150.0, -40.0)), Light::Directional(Vec3::new(0.3, -1.0, -0.2))] {
            let f = fit(light, cam, &[mesh], &FitOptions::new(scene), &mut scratch);
            assert_eq!(f.kind, FitKind::Visible);
            assert!(f.sphere.radius < 200.0, "{:?}", f.sphere);
            for p in &seen {
                assert!(inside(f.view_proj, *p), "{light:?}: {p} outside the light volume");
            }
        }
    }

    #[test]
    fn a_caster_outside_the_view_stays_inside_the_light_volume() {
        let (positions, indices) = ground();
        let mesh = MeshRef { world: Mat4::IDENTITY, positions: &positions, indices: &indices };
        let cam = camera();
        // High above the view; light travelling (1, −1, 0) puts its shadow on the ground at
        // (6, 0, −12), in view.
        let dir = Vec3::new(1.0, -1.0, 0.0).normalize();
        let shadow = Vec3::new(6.0, 0.0, -12.0);
        let caster = shadow - dir * (60.0 / -dir.y);
        assert!(!inside(cam, caster));
        assert!(inside(cam, shadow));
        let scene = Sphere { centre: Vec3::ZERO, radius: 1500.0 };
        let mut scratch = Scratch::default();
        let f = fit(Light::Directional(dir), cam, &[mesh], &FitOptions::new(scene), &mut scratch);
        assert!(inside(f.view_proj, shadow) && inside(f.view_proj, caster));
        // Without the extension toward the light (the box only around the visible sphere), the
        // caster is cut off: what the extension is for.
        let tight = FitOptions { scene: f.sphere, ..FitOptions::new(scene) };
        let t = fit(Light::Directional(dir), cam, &[mesh], &tight, &mut scratch);
        assert!(!inside(t.view_proj, caster));
        // A point light above and behind the caster: the cone through the sphere holds it.
        let light = caster - dir * 30.0;
        let shadow = light + (caster - light) * (light.y / (light.y - caster.y));
        assert!(inside(cam, shadow), "{shadow}");
        assert!(inside(f.view_proj, caster) && inside(f.view_proj, shadow));
    }

    #[test]
    fn nothing_visible_gives_the_fixed_frustum() {
        let (positions, indices) = ground();
        let mesh = MeshRef { world: Mat4::IDENTITY, positions: &positions, indices: &indices };
        let sky = directx::perspective(1.0, 1.0, 0.1, 100.0)
            * look_at_mat4(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 50.0, -1.0), Vec3::Y);
        let scene = Sphere { centre: Vec3::ZERO, radius: 1500.0 };
        let mut scratch = Scratch::default();
        for light in [Light::Point(Vec3::new(0.0, 3000.0, 0.0)), Light::Directional(Vec3::NEG_Y)] {
            let f = fit(light, sky, &[mesh], &FitOptions::new(scene), &mut scratch);
            assert_eq!(f.kind, FitKind::NothingVisible);
            assert_eq!(f.view_proj, fixed(light, &FitOptions::new(scene)));
            assert!(f.view_proj.is_finite());
        }
    }

    #[test]
    fn a_light_inside_the_sphere_gets_a_defined_frustum() {
        let (positions, indices) = ground();
        let mesh = MeshRef { world: Mat4::IDENTITY, positions: &positions, indices: &indices };
        let scene = Sphere { centre: Vec3::ZERO, radius: 1500.0 };
        let mut scratch = Scratch::default();
        let seen = fit(Light::Directional(Vec3::NEG_Y), camera(), &[mesh], &FitOptions::new(scene), &mut scratch);
        for light in [seen.sphere.centre, seen.sphere.centre + Vec3::new(1.0, 0.5, 0.0)] {
            let f = fit(Light::Point(light), camera(), &[mesh], &FitOptions::new(scene), &mut scratch);
            assert_eq!(f.kind, FitKind::LightInside);
            assert!(f.view_proj.is_finite(), "{:?}", f.view_proj);
        }
    }

    /// The fit holds every visible point, plain and in post-perspective space.
    #[test]
    fn fits_hold_the_visible_points() {
        let (positions, indices) = ground();
        let mut boxes = positions.clone();
        let mut idx = indices.clone();
        for k in 0..20 {
            let base = boxes.len() as u32;
            let o = Vec3::new(-10.0 + k as f32, 0.0, -5.0 - 2.0 * k as f32);
            boxes.extend([o, o + Vec3::new(1.0, 0.0, 0.0), o + Vec3::new(1.0, 3.0, 0.0), o + Vec3::new(0.0, 3.0, 0.0)]);
            idx.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
        let mesh = MeshRef { world: Mat4::IDENTITY, positions: &boxes, indices: &idx };
        let scene = Sphere { centre: Vec3::ZERO, radius: 1500.0 };
        let mut scratch = Scratch::default();
        for psm in [false, true] {
            let lights = [
                Light::Point(Vec3::new(60.0, 150.0, -30.0)),
                Light::Point(Vec3::new(60.0, 150.0, 30.0)), // behind the camera plane
                Light::Directional(Vec3::new(0.2, -1.0, 0.4)), // from in front of the camera
                Light::Directional(Vec3::new(0.2, -1.0, -0.4)), // from behind it
            ];
            for (k, light) in lights.into_iter().enumerate() {
                let o = FitOptions { psm, ..FitOptions::new(scene) };
                let f = fit(light, camera(), &[mesh], &o, &mut scratch);
                let behind = k == 1 || k == 3;
                let expected = if psm && behind { FitKind::PsmFallback } else { FitKind::Visible };
                assert_eq!(f.kind, expected, "{light:?} psm {psm}");
                for p in &scratch.points {
                    assert!(inside(f.view_proj, *p), "{light:?} psm {psm}: {p}");
                }
            }
        }
    }

    /// Snapped fits of two nearby cameras: the same size, and a world point moves across the
    /// shadow map by whole texels.
    #[test]
    fn snapping_moves_the_map_by_whole_texels() {
        let (positions, indices) = ground();
        let mesh = MeshRef { world: Mat4::IDENTITY, positions: &positions, indices: &indices };
        let scene = Sphere { centre: Vec3::ZERO, radius: 1500.0 };
        let o = FitOptions { snap: true, ..FitOptions::new(scene) };
        let mut scratch = Scratch::default();
        let at = |x: f32| {
            directx::perspective(60f32.to_radians(), 1.0, 0.1, 40.0)
                * look_at_mat4(Vec3::new(x, 2.0, 0.0), Vec3::new(x, 0.0, -10.0), Vec3::Y)
        };
        let light = Light::Directional(Vec3::new(0.3, -1.0, -0.2));
        let a = fit(light, at(0.0), &[mesh], &o, &mut scratch);
        let b = fit(light, at(0.37), &[mesh], &o, &mut scratch);
        let p = Vec3::new(3.0, 0.0, -20.0);
        let (pa, pb) = (a.view_proj.project_point3(p), b.view_proj.project_point3(p));
        let texels = (pb - pa) * o.resolution as f32 / 2.0;
        for t in [texels.x, texels.y] {
            assert!((t - t.round()).abs() < 0.01, "moved {t} texels");
        }
        // A point light: the same, through the off-centre window on the image plane, except
        // when the move takes the aim across a step of its coarse grid (rare: a rotation).
        let point = Light::Point(Vec3::new(60.0, 150.0, -40.0));
        let mut a = fit(point, at(0.0), &[mesh], &o, &mut scratch);
        let mut whole = 0;
        for k in 1..=20 {
            // Consecutive frames of a camera moving 2 cm a frame.
            let b = fit(point, at(0.02 * k as f32), &[mesh], &o, &mut scratch);
            let texels = (b.view_proj.project_point3(p) - a.view_proj.project_point3(p)) * o.resolution as f32 / 2.0;
            whole += [texels.x, texels.y].iter().all(|t| (t - t.round()).abs() < 0.01) as u32;
            for q in &scratch.points {
                assert!(inside(b.view_proj, *q), "snapped point-light fit lost {q}");
            }
            a = b;
        }
        assert!(whole >= 17, "only {whole} of 20 frames kept the texel grid");
        // Unsnapped, the same move shifts the map by a fraction of a texel.
        let (ua, ub) = (
            fit(light, at(0.0), &[mesh], &FitOptions::new(scene), &mut scratch),
            fit(light, at(0.37), &[mesh], &FitOptions::new(scene), &mut scratch),
        );
        let moved = (ub.view_proj.project_point3(p) - ua.view_proj.project_point3(p)) * o.resolution as f32 / 2.0;
        assert!((moved.x - moved.x.round()).abs() > 0.01 || (moved.y - moved.y.round()).abs() > 0.01);
    }
}
