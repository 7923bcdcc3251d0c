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
//! & Drettakis 2002), fitted to the visible geometry or, as plain PSM, to the whole view
//! frustum ([`FitOptions::to_visible`]); and snapping of the fitted size and centre to the
//! shadow-map texel grid ([`FitOptions::snap`]) so shadow edges do not shimmer as the camera
//! moves.
//!
//! PSM follows Stamminger & Drettakis where the light or a caster sits behind the viewer: the
//! casters that can shade a receiver are found (the geometry inside the plain fit's light
//! volume whose shadow ray reaches the receivers' box inside the view), and a virtual camera
//! pulled back along the view axis until all of them lie in front of its near plane defines the
//! post-perspective space ([`Fit::pull_back`]); by default it is pulled back further, to
//! `√(z_near · z_far)` of the receivers, so the texels are not all spent near the camera
//! ([`FitOptions::psm_balance`]). A light behind that camera's plane maps to a point whose rays
//! run backwards — away from the light's image toward the scene — so it gets an inverted
//! projection, whose depth decreases away from the light's image ([`FitKind::InvertedPsm`]).
//! Post-perspective depth is very uneven across the scene: compare distances to the light (or
//! another world-space quantity) in the shadow test rather than the map's clip depth.
//!
//! Defined results where the fit has no answer: nothing visible gives the fixed frustum around
//! the whole scene ([`FitKind::NothingVisible`]); a positional light inside the sphere aims at
//! its centre with the widest allowed field of view ([`FitKind::LightInside`]). Never NaN.

use glam::camera::rh::proj::directx;
use glam::camera::rh::view::look_to_mat4;
use glam::{Mat4, Vec3, Vec4};

/// The camera the frame is drawn with, as the game has it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// World → view (right-handed, looking along −z).
    pub view: Mat4,
    /// View → clip (wgpu: depth 0..1).
    pub projection: Mat4,
}

impl Camera {
    /// World → clip.
    pub fn view_proj(&self) -> Mat4 {
        self.projection * self.view
    }

    /// Distances along the view axis of the near and far planes (where clip depth is 0 and 1,
    /// in either order, so reversed depth works too; an infinite far plane stays infinite).
    fn depth_range(&self) -> (f32, f32) {
        let inv = self.projection.inverse();
        let depth = |z: f32| {
            let p = inv * Vec4::new(0.0, 0.0, z, 1.0);
            if p.w.abs() > 1e-12 { (-p.z / p.w).abs() } else { f32::INFINITY }
        };
        let (a, b) = (depth(0.0), depth(1.0));
        let (near, far) = (a.min(b), a.max(b));
        (if near.is_finite() && near > 0.0 { near } else { 1e-3 }, far)
    }

    /// The camera moved back `pull_back` along its view axis with its near and far planes
    /// where they were in the world (Stamminger & Drettakis' virtual camera): world → clip.
    fn pulled_back(&self, pull_back: f32) -> Mat4 {
        let (near, far) = self.depth_range();
        let (n, f) = (near + pull_back, far + pull_back);
        let mut projection = self.projection;
        // Row 2 (depth) for [n, f], wgpu's 0..1; the x, y and w rows are kept.
        projection.x_axis.z = 0.0;
        projection.y_axis.z = 0.0;
        if f.is_finite() {
            projection.z_axis.z = f / (n - f);
            projection.w_axis.z = n * f / (n - f);
        } else {
            projection.z_axis.z = -1.0;
            projection.w_axis.z = -n;
        }
        projection * Mat4::from_translation(Vec3::new(0.0, 0.0, -pull_back)) * self.view
    }
}

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
    /// Fit to the geometry the camera sees (the seed's method); `false` fits to the whole view
    /// frustum (with `psm`, plain perspective shadow maps).
    pub to_visible: bool,
    /// With `psm`: pull the virtual camera back at least `√(z_near · z_far)` of the receivers'
    /// depths (Wimmer et al.'s optimal parameter for light-space perspective), so the map's
    /// texels are shared between near and far receivers instead of crowding at the near plane.
    /// Off, it moves back only as far as the casters require (Stamminger & Drettakis).
    pub psm_balance: bool,
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
            to_visible: true,
            psm_balance: true,
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
    /// PSM with the light behind the (virtual) camera's plane: the inverted projection.
    InvertedPsm,
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
    /// PSM: how far the virtual camera was pulled back along the view axis to put every caster
    /// in front of its near plane (world units; 0 without PSM).
    pub pull_back: f32,
}

/// Reusable buffers for [`visible_points`] and [`fit`] (no allocation per frame once warm).
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    clip: Vec<Vec4>,
    codes: Vec<u8>,
    /// The visible points of the last call (world space): the receivers the fit was made for.
    pub points: Vec<Vec3>,
    /// PSM: the caster points found inside the plain fit's light volume (world space).
    pub casters: Vec<Vec3>,
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
    let Scratch { clip, codes, points, .. } = scratch;
    points_inside(camera_view_proj, meshes, vertex_test_only, (clip, codes), points);
}

/// [`visible_points`] into `out`, with `buffers` for the clip-space corners and outcodes.
fn points_inside(
    view_proj: Mat4,
    meshes: &[MeshRef],
    vertex_test_only: bool,
    (clip, codes): (&mut Vec<Vec4>, &mut Vec<u8>),
    out: &mut Vec<Vec3>,
) {
    out.clear();
    for mesh in meshes {
        let m = view_proj * mesh.world;
        clip.clear();
        codes.clear();
        for &p in mesh.positions {
            let c = m * p.extend(1.0);
            let code = outcode(c);
            clip.push(c);
            codes.push(code);
            if code == 0 {
                out.push(mesh.world.transform_point3(p));
            }
        }
        if vertex_test_only {
            continue;
        }
        for tri in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
            let (Some(&ca), Some(&cb), Some(&cc)) = (codes.get(a), codes.get(b), codes.get(c)) else {
                continue; // an index out of range names no vertex
            };
            // Entirely inside (its corners are kept already) or entirely beyond one plane.
            if ca | cb | cc == 0 || ca & cb & cc != 0 {
                continue;
            }
            let corner = |i: usize| (clip[i], mesh.world.transform_point3(mesh.positions[i]));
            clip_polygon(vec![corner(a), corner(b), corner(c)], out);
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

/// The plain fit (world space) of `light` to `sphere`.
fn fit_world(light: Light, sphere: Sphere, o: &FitOptions) -> (Mat4, FitKind) {
    match light {
        Light::Point(p) => fit_point(p, sphere, o),
        Light::Directional(d) => (fit_directional(d, sphere, o), FitKind::Visible),
    }
}

/// The light fit for the receivers in `points` (world space), seen by `camera`; `scratch`
/// receives the casters PSM looks for among `meshes` (see the module docs).
pub fn fit_to_points(
    light: Light,
    camera: &Camera,
    points: &[Vec3],
    meshes: &[MeshRef],
    o: &FitOptions,
    scratch: &mut Scratch,
) -> Fit {
    let Some(sphere) = bounding_sphere(points) else {
        return Fit { view_proj: fixed(light, o), sphere: o.scene, kind: FitKind::NothingVisible, pull_back: 0.0 };
    };
    let (view_proj, kind) = fit_world(light, sphere, o);
    if !o.psm {
        return Fit { view_proj, sphere, kind, pull_back: 0.0 };
    }
    // Every caster that can shade a receiver lies in the plain fit's light volume. Those in
    // front of the camera's near plane are kept as they are; of those behind it, which decide
    // how far the camera moves back, only the ones whose shadow reaches the receivers' box
    // inside the view (a ground plane running on behind the camera shades nothing in view).
    // Vertices are enough: they only decide the pull-back and the post-perspective bounds.
    let Scratch { clip, codes, casters, .. } = scratch;
    points_inside(view_proj, meshes, true, (clip, codes), casters);
    let (lo, hi) = points.iter().fold((points[0], points[0]), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let camera_view_proj = camera.view_proj();
    let (near, _) = camera.depth_range();
    let reach = 4.0 * (o.scene.radius + sphere.radius + (sphere.centre - o.scene.centre).length());
    casters.retain(|&q| {
        if -camera.view.transform_point3(q).z >= near {
            return true;
        }
        let away = match light {
            Light::Point(l) => (q - l).normalize_or_zero(),
            Light::Directional(d) => d.normalize_or_zero(),
        };
        shadow_enters(q, away, reach, (lo, hi), camera_view_proj)
    });
    fit_psm(light, camera, points, casters, o)
}

/// Whether the shadow ray from `q` along `away` (unit), from just past `q` to `reach`, passes
/// through the box `[lo, hi]` inside the view volume of `view_proj`: only then can `q` shade
/// something the camera sees.
fn shadow_enters(q: Vec3, away: Vec3, reach: f32, (lo, hi): (Vec3, Vec3), view_proj: Mat4) -> bool {
    let (mut t0, mut t1) = (1e-3 * reach.max(1e-3) / 4.0, reach);
    for axis in 0..3 {
        if away[axis].abs() < 1e-12 {
            if q[axis] < lo[axis] || q[axis] > hi[axis] {
                return false;
            }
            continue;
        }
        let (a, b) = ((lo[axis] - q[axis]) / away[axis], (hi[axis] - q[axis]) / away[axis]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    if t0 > t1 {
        return false;
    }
    // The segment left, clipped to the view volume in clip space (Liang–Barsky).
    let (c0, c1) = (view_proj * (q + away * t0).extend(1.0), view_proj * (q + away * t1).extend(1.0));
    let (mut s0, mut s1) = (0.0f32, 1.0f32);
    for k in 0..6 {
        let (d0, d1) = (plane_distance(c0, k), plane_distance(c1, k));
        if d0 < 0.0 && d1 < 0.0 {
            return false;
        }
        if d0 < 0.0 {
            s0 = s0.max(d0 / (d0 - d1));
        } else if d1 < 0.0 {
            s1 = s1.min(d0 / (d0 - d1));
        }
    }
    s0 <= s1
}

/// The fit of the light to what `camera` sees of `meshes` (or, with `to_visible` off, to its
/// whole view frustum).
pub fn fit(light: Light, camera: &Camera, meshes: &[MeshRef], o: &FitOptions, scratch: &mut Scratch) -> Fit {
    let view_proj = camera.view_proj();
    if o.to_visible {
        visible_points(view_proj, meshes, o.vertex_test_only, scratch);
    } else {
        scratch.points.clear();
        let inv = view_proj.inverse();
        for k in 0..8 {
            let ndc =
                Vec3::new(if k & 1 == 0 { -1.0 } else { 1.0 }, if k & 2 == 0 { -1.0 } else { 1.0 }, (k >> 2) as f32);
            scratch.points.push(inv.project_point3(ndc));
        }
    }
    let points = std::mem::take(&mut scratch.points);
    let f = fit_to_points(light, camera, &points, meshes, o, scratch);
    scratch.points = points;
    f
}

/// The fixed frustum around the whole scene (the baseline, and the fit when nothing is seen).
pub fn fixed(light: Light, o: &FitOptions) -> Mat4 {
    let plain = FitOptions { snap: false, psm: false, ..*o };
    fit_world(light, o.scene, &plain).0
}

/// The fit in post-perspective space: the camera pulled back until every caster is in front of
/// its near plane, receivers, casters and the light through that camera's projection, a light
/// frustum fitted there — inverted when the light is behind the camera's plane — composed with
/// the camera's matrix.
fn fit_psm(light: Light, camera: &Camera, receivers: &[Vec3], casters: &[Vec3], o: &FitOptions) -> Fit {
    let (near, _) = camera.depth_range();
    let depth = |p: &Vec3| -camera.view.transform_point3(*p).z;
    let closest = receivers.iter().chain(casters).map(depth).fold(f32::INFINITY, f32::min);
    let mut pull_back = (near - closest).max(0.0);
    if o.psm_balance {
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
    let pps_options = FitOptions { near: 1e-3, snap: false, psm: false, scene: everything, ..*o };
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::camera::rh::view::look_at_mat4;

    /// A camera 2 units above the ground at the origin looking along −z, slightly down; 60°,
    /// far plane at 40.
    fn camera() -> Camera {
        Camera {
            view: look_at_mat4(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 0.0, -10.0), Vec3::Y),
            projection: directx::perspective(60f32.to_radians(), 1.0, 0.1, 40.0),
        }
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
    fn seen_ground(cam: &Camera) -> Vec<Vec3> {
        let inv = cam.view_proj().inverse();
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
        let f = fit(Light::Point(Vec3::new(60.0, 150.0, -40.0)), &cam, &[mesh], &vertex_only, &mut scratch);
        assert_eq!(f.kind, FitKind::NothingVisible);
        // Clipping finds the visible part; every ground point seen lies inside the light volume.
        let seen = seen_ground(&cam);
        assert!(seen.len() > 500);
        for light in [Light::Point(Vec3::new(60.0, 150.0, -40.0)), Light::Directional(Vec3::new(0.3, -1.0, -0.2))] {
            let f = fit(light, &cam, &[mesh], &FitOptions::new(scene), &mut scratch);
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
        assert!(!inside(cam.view_proj(), caster));
        assert!(inside(cam.view_proj(), shadow));
        let scene = Sphere { centre: Vec3::ZERO, radius: 1500.0 };
        let mut scratch = Scratch::default();
        let f = fit(Light::Directional(dir), &cam, &[mesh], &FitOptions::new(scene), &mut scratch);
        assert!(inside(f.view_proj, shadow) && inside(f.view_proj, caster));
        // Without the extension toward the light (the box only around the visible sphere), the
        // caster is cut off: what the extension is for.
        let tight = FitOptions { scene: f.sphere, ..FitOptions::new(scene) };
        let t = fit(Light::Directional(dir), &cam, &[mesh], &tight, &mut scratch);
        assert!(!inside(t.view_proj, caster));
        // A point light above and behind the caster: the cone through the sphere holds it.
        let light = caster - dir * 30.0;
        let shadow = light + (caster - light) * (light.y / (light.y - caster.y));
        assert!(inside(cam.view_proj(), shadow), "{shadow}");
        assert!(inside(f.view_proj, caster) && inside(f.view_proj, shadow));
    }

    #[test]
    fn nothing_visible_gives_the_fixed_frustum() {
        let (positions, indices) = ground();
        let mesh = MeshRef { world: Mat4::IDENTITY, positions: &positions, indices: &indices };
        let sky = Camera {
            view: look_at_mat4(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 50.0, -1.0), Vec3::Y),
            projection: directx::perspective(1.0, 1.0, 0.1, 100.0),
        };
        let scene = Sphere { centre: Vec3::ZERO, radius: 1500.0 };
        let mut scratch = Scratch::default();
        for light in [Light::Point(Vec3::new(0.0, 3000.0, 0.0)), Light::Directional(Vec3::NEG_Y)] {
            let f = fit(light, &sky, &[mesh], &FitOptions::new(scene), &mut scratch);
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
        let seen = fit(Light::Directional(Vec3::NEG_Y), &camera(), &[mesh], &FitOptions::new(scene), &mut scratch);
        for light in [seen.sphere.centre, seen.sphere.centre + Vec3::new(1.0, 0.5, 0.0)] {
            let f = fit(Light::Point(light), &camera(), &[mesh], &FitOptions::new(scene), &mut scratch);
            assert_eq!(f.kind, FitKind::LightInside);
            assert!(f.view_proj.is_finite(), "{:?}", f.view_proj);
        }
    }

    /// The fit holds every visible point and every caster that shades one, plain and in
    /// post-perspective space, fitted to the visible geometry or to the whole view frustum.
    /// Casters: specks (degenerate triangles) added on the segments from visible points toward
    /// the light, some of them behind the camera.
    #[test]
    fn fits_hold_the_visible_points_and_their_casters() {
        let (positions, indices) = ground();
        let mut boxes = positions.clone();
        let mut idx = indices.clone();
        for k in 0..20 {
            let base = boxes.len() as u32;
            let o = Vec3::new(-10.0 + k as f32, 0.0, -5.0 - 2.0 * k as f32);
            boxes.extend([o, o + Vec3::new(1.0, 0.0, 0.0), o + Vec3::new(1.0, 3.0, 0.0), o + Vec3::new(0.0, 3.0, 0.0)]);
            idx.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
        let scene = Sphere { centre: Vec3::ZERO, radius: 1500.0 };
        let mut scratch = Scratch::default();
        for (psm, to_visible) in [(false, true), (true, true), (true, false)] {
            let lights = [
                Light::Point(Vec3::new(60.0, 150.0, -30.0)),
                Light::Point(Vec3::new(60.0, 150.0, 30.0)), // behind the camera plane
                Light::Directional(Vec3::new(0.2, -1.0, 0.4)), // from in front of the camera
                Light::Directional(Vec3::new(0.2, -1.0, -0.4)), // from behind it
            ];
            for (k, light) in lights.into_iter().enumerate() {
                let o = FitOptions { psm, to_visible, ..FitOptions::new(scene) };
                let mesh = MeshRef { world: Mat4::IDENTITY, positions: &boxes, indices: &idx };
                fit(light, &camera(), &[mesh], &o, &mut scratch);
                // Receivers a little inside the hull of the points (the frustum's corners, when
                // fitting to the whole frustum, are on its boundary).
                let mid = scratch.points.iter().copied().sum::<Vec3>() / scratch.points.len() as f32;
                let receivers: Vec<Vec3> = scratch.points.iter().step_by(5).map(|&p| p + (mid - p) * 0.05).collect();
                let (mut with_specks, mut speck_idx) = (boxes.clone(), idx.clone());
                let mut specks = Vec::new();
                for p in &receivers {
                    for t in [0.1f32, 0.3, 0.5, 0.7, 0.9] {
                        specks.push(match light {
                            Light::Point(l) => l + (*p - l) * t,
                            Light::Directional(d) => *p - d.normalize() * 60.0 * t,
                        });
                    }
                }
                for q in &specks {
                    let base = with_specks.len() as u32;
                    with_specks.push(*q);
                    speck_idx.extend([base, base, base]);
                }
                let mesh = MeshRef { world: Mat4::IDENTITY, positions: &with_specks, indices: &speck_idx };
                let f = fit(light, &camera(), &[mesh], &o, &mut scratch);
                let behind = k == 1 || k == 3;
                let expected = if psm && behind { FitKind::InvertedPsm } else { FitKind::Visible };
                assert_eq!(f.kind, expected, "{light:?} psm {psm}");
                assert!(f.view_proj.is_finite());
                let behind_camera = specks.iter().filter(|q| camera().view.transform_point3(**q).z > 0.0).count();
                assert!(!behind || behind_camera > 0, "{light:?}: no caster behind the camera to test");
                for p in scratch.points.iter().chain(&specks) {
                    assert!(inside(f.view_proj, *p), "{light:?} psm {psm} to_visible {to_visible}: {p}");
                }
            }
        }
    }

    /// Seed 001 with PSM, the case plain PSM loses: a light behind and above the viewer, a
    /// caster behind the camera's plane whose shadow falls on ground in view. The virtual
    /// camera is pulled back to hold the caster; caster and shadow land on the same shadow-map
    /// texel, the caster nearer the light (smaller depth), so the shadow test finds it.
    #[test]
    fn psm_keeps_a_caster_behind_the_camera() {
        let cam = camera();
        let light = Vec3::new(3.0, 40.0, 60.0);
        let shadow = Vec3::new(1.0, 0.0, -12.0);
        assert!(inside(cam.view_proj(), shadow));
        // On the segment from the light to the shadow, 1.5 units behind the camera (z = +1.5).
        let t = (1.5 - light.z) / (shadow.z - light.z);
        let caster = light + (shadow - light) * t;
        assert!(-cam.view.transform_point3(caster).z < 0.0, "the caster is behind the camera plane");
        // A small quad around the caster point, and the ground.
        let (mut positions, mut indices) = ground();
        let base = positions.len() as u32;
        positions
            .extend([-0.3f32, 0.3].iter().flat_map(|&dx| [-0.3f32, 0.3].map(|dz| caster + Vec3::new(dx, 0.0, dz))));
        indices.extend([base, base + 1, base + 3, base, base + 3, base + 2]);
        let mesh = MeshRef { world: Mat4::IDENTITY, positions: &positions, indices: &indices };
        let scene = Sphere { centre: Vec3::ZERO, radius: 1500.0 };
        let mut scratch = Scratch::default();
        for (light, what) in [(Light::Point(light), "point"), (Light::Directional(shadow - light), "directional")] {
            let o = FitOptions { psm: true, ..FitOptions::new(scene) };
            let f = fit(light, &cam, &[mesh], &o, &mut scratch);
            assert_eq!(f.kind, FitKind::InvertedPsm, "{what}");
            assert!(f.pull_back > 1.5, "{what}: pulled back only {}", f.pull_back);
            assert!(inside(f.view_proj, caster) && inside(f.view_proj, shadow), "{what}: caster or shadow outside");
            let (c, s) = (f.view_proj.project_point3(caster), f.view_proj.project_point3(shadow));
            let texels = (c - s).truncate() * o.resolution as f32 / 2.0;
            assert!(texels.length() < 0.5, "{what}: caster {texels} texels from its shadow");
            assert!(c.z < s.z, "{what}: caster depth {} not in front of the shadow's {}", c.z, s.z);
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
        let at = |x: f32| Camera {
            view: look_at_mat4(Vec3::new(x, 2.0, 0.0), Vec3::new(x, 0.0, -10.0), Vec3::Y),
            projection: directx::perspective(60f32.to_radians(), 1.0, 0.1, 40.0),
        };
        let light = Light::Directional(Vec3::new(0.3, -1.0, -0.2));
        let a = fit(light, &at(0.0), &[mesh], &o, &mut scratch);
        let b = fit(light, &at(0.37), &[mesh], &o, &mut scratch);
        let p = Vec3::new(3.0, 0.0, -20.0);
        let (pa, pb) = (a.view_proj.project_point3(p), b.view_proj.project_point3(p));
        let texels = (pb - pa) * o.resolution as f32 / 2.0;
        for t in [texels.x, texels.y] {
            assert!((t - t.round()).abs() < 0.01, "moved {t} texels");
        }
        // A point light: the same, through the off-centre window on the image plane, except
        // when the move takes the aim across a step of its coarse grid (rare: a rotation).
        let point = Light::Point(Vec3::new(60.0, 150.0, -40.0));
        let mut a = fit(point, &at(0.0), &[mesh], &o, &mut scratch);
        let mut whole = 0;
        for k in 1..=20 {
            // Consecutive frames of a camera moving 2 cm a frame.
            let b = fit(point, &at(0.02 * k as f32), &[mesh], &o, &mut scratch);
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
            fit(light, &at(0.0), &[mesh], &FitOptions::new(scene), &mut scratch),
            fit(light, &at(0.37), &[mesh], &FitOptions::new(scene), &mut scratch),
        );
        let moved = (ub.view_proj.project_point3(p) - ua.view_proj.project_point3(p)) * o.resolution as f32 / 2.0;
        assert!((moved.x - moved.x.round()).abs() > 0.01 || (moved.y - moved.y.round()).abs() > 0.01);
    }
}
