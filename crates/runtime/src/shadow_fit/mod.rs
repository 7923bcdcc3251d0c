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
//! Options: the same fit in the camera's post-perspective space ([`FitSpace::PostPerspective`], Stamminger
//! & Drettakis 2002), fitted to the visible geometry or, as plain PSM, to the whole view
//! frustum ([`FitTarget::ViewFrustum`]); and snapping of the fitted size and centre to the
//! shadow-map texel grid ([`Snap::TexelGrid`]) so shadow edges do not shimmer as the camera
//! moves.
//!
//! PSM follows Stamminger & Drettakis where the light or a caster sits behind the viewer: the
//! casters that can shade a receiver are found (the geometry inside the plain fit's light
//! volume whose shadow ray reaches the receivers' box inside the view), and a virtual camera
//! pulled back along the view axis until all of them lie in front of its near plane defines the
//! post-perspective space ([`Fit::pull_back`]); by default it is pulled back further, to
//! `√(z_near · z_far)` of the receivers, so the texels are not all spent near the camera
//! ([`PullBack::Balanced`]). A light behind that camera's plane maps to a point whose rays
//! run backwards — away from the light's image toward the scene — so it gets an inverted
//! projection, whose depth decreases away from the light's image ([`FitKind::InvertedPsm`]).
//! Post-perspective depth is very uneven across the scene: compare distances to the light (or
//! another world-space quantity) in the shadow test rather than the map's clip depth.
//!
//! Defined results where the fit has no answer: nothing visible gives the fixed frustum around
//! the whole scene ([`FitKind::NothingVisible`]); a positional light inside the sphere aims at
//! its centre with the widest allowed field of view ([`FitKind::LightInside`]). Never NaN.

//!
//! The code is in three parts: [`clip`] (what the camera sees), the world-space fit (`world`),
//! and the post-perspective fit (`psm`).

pub mod clip;
mod psm;
mod world;

use glam::{Mat4, Vec3, Vec4};

pub use clip::visible_points;
pub use world::bounding_sphere;
use world::fit_world;

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
    pub(super) fn depth_range(&self) -> (f32, f32) {
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
    pub(super) fn pulled_back(&self, pull_back: f32) -> Mat4 {
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
    /// What the fit bounds.
    pub target: FitTarget,
    /// The space the fit is made in.
    pub space: FitSpace,
    /// Whether the fitted size and centre keep to the texel grid.
    pub snap: Snap,
    /// Bounds of every caster in the scene: the directional box reaches them, and nothing
    /// visible falls back to a frustum around them.
    pub scene: Sphere,
}

/// What the fit bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitTarget {
    /// The geometry the camera sees (the seed's method), found by `VisibleTest`.
    Visible(VisibleTest),
    /// The camera's whole view frustum (with [`FitSpace::PostPerspective`], plain perspective
    /// shadow maps).
    ViewFrustum,
}

/// How the geometry the camera sees is found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VisibleTest {
    /// Vertices inside the view volume, and the corners of the triangles crossing its boundary
    /// clipped to it (a ground plane whose vertices all lie outside still counts).
    ClippedTriangles,
    /// The paper's vertex test alone: for comparison.
    VerticesOnly,
}

/// The space the fit is made in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitSpace {
    /// World space: the seed's fit.
    World,
    /// The camera's post-perspective space (Stamminger & Drettakis 2002), its virtual camera
    /// pulled back as [`PullBack`] says.
    PostPerspective(PullBack),
}

/// How far PSM's virtual camera is pulled back along the view axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PullBack {
    /// At least `√(z_near · z_far)` of the receivers' depths (Wimmer et al.'s optimal parameter
    /// for light-space perspective), so the map's texels are shared between near and far
    /// receivers instead of crowding at the near plane.
    Balanced,
    /// Only as far as the casters require (Stamminger & Drettakis).
    CastersOnly,
}

/// Whether the fitted size and centre keep to the shadow map's texel grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Snap {
    /// Fitted exactly each frame (shadow edges shimmer as the camera moves).
    Off,
    /// Size on a ladder of 1.1× steps and centre on the texel grid: still edges.
    TexelGrid,
}

impl FitOptions {
    /// The defaults for a scene bounded by `scene`: near plane 1, at most 120° of field of view,
    /// 1024² texels, the seed's fit to the visible geometry with triangle clipping, in world
    /// space, no snapping. Set the fields that differ with struct update syntax.
    pub fn new(scene: Sphere) -> FitOptions {
        FitOptions {
            near: 1.0,
            max_fov_degrees: 120.0,
            resolution: 1024,
            target: FitTarget::Visible(VisibleTest::ClippedTriangles),
            space: FitSpace::World,
            snap: Snap::Off,
            scene,
        }
    }

    /// The options of the plain world-space fit, for the fixed frustum and the fit inside PSM.
    fn plain(&self) -> FitOptions {
        FitOptions { snap: Snap::Off, space: FitSpace::World, ..*self }
    }

    fn snapping(&self) -> bool {
        self.snap == Snap::TexelGrid
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
    let FitSpace::PostPerspective(pull) = o.space else {
        return Fit { view_proj, sphere, kind, pull_back: 0.0 };
    };
    // Every caster that can shade a receiver lies in the plain fit's light volume. Those in
    // front of the camera's near plane are kept as they are; of those behind it, which decide
    // how far the camera moves back, only the ones whose shadow reaches the receivers' box
    // inside the view (a ground plane running on behind the camera shades nothing in view).
    // Vertices are enough: they only decide the pull-back and the post-perspective bounds.
    let Scratch { clip, codes, casters, .. } = scratch;
    clip::points_inside(view_proj, meshes, VisibleTest::VerticesOnly, (clip, codes), casters);
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
        clip::shadow_enters(q, away, reach, (lo, hi), camera_view_proj)
    });
    psm::fit_psm(light, camera, (points, casters), pull, o)
}

/// The fit of the light to what `camera` sees of `meshes` (or, with
/// [`FitTarget::ViewFrustum`], to its whole view frustum).
pub fn fit(light: Light, camera: &Camera, meshes: &[MeshRef], o: &FitOptions, scratch: &mut Scratch) -> Fit {
    let view_proj = camera.view_proj();
    if let FitTarget::Visible(test) = o.target {
        visible_points(view_proj, meshes, test, scratch);
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
    fit_world(light, o.scene, &o.plain()).0
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::camera::rh::proj::directx;
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
        let vertex_only =
            FitOptions { target: FitTarget::Visible(VisibleTest::VerticesOnly), ..FitOptions::new(scene) };
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
                let o = FitOptions {
                    space: if psm { FitSpace::PostPerspective(PullBack::Balanced) } else { FitSpace::World },
                    target: if to_visible {
                        FitTarget::Visible(VisibleTest::ClippedTriangles)
                    } else {
                        FitTarget::ViewFrustum
                    },
                    ..FitOptions::new(scene)
                };
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
            let o = FitOptions { space: FitSpace::PostPerspective(PullBack::Balanced), ..FitOptions::new(scene) };
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
        let o = FitOptions { snap: Snap::TexelGrid, ..FitOptions::new(scene) };
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
