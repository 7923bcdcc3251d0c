//! Seed 000's sphere (Fig. 4/5) drawn analytically: the exact sphere `data/sphere.obj` samples
//! (radius R, `u = tiles·φ/2π`, `v = (tiles/2)·θ/π`, as `synth::uv_sphere_obj` writes it), seen
//! by the orthographic camera of [`AnalyticSphere::view_proj`]. Every pixel's inputs — point,
//! normal, texture frame, curvature — are exact, and go through the same CPU reference as the
//! mesh ([`SurfaceReference::lit`]): the figure the baked curvature of the mesh is held to.

use glam::camera::rh::proj::directx;
use glam::camera::rh::view::look_at_mat4;
use glam::{Mat4, Vec2, Vec3};
use hikage_runtime::horizon::reference::SurfaceReference;

/// A sphere and its texture mapping.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnalyticSphere {
    /// Radius (1/κ).
    pub radius: f32,
    /// Bump-map tiles around the equator (half as many pole to pole).
    pub tiles: f32,
}

impl AnalyticSphere {
    /// The sphere of `data/sphere.obj`: κ = 0.015, three tiles around.
    pub const SAMPLE: AnalyticSphere = AnalyticSphere { radius: 1.0 / 0.015, tiles: 3.0 };

    /// The half-width of the view: the sphere with 5% of margin.
    fn extent(&self) -> f32 {
        self.radius * 1.05
    }

    /// The camera the pictures and tests use: orthographic, looking along −z at the sphere.
    pub fn view_proj(&self) -> Mat4 {
        let e = self.extent();
        directx::orthographic(-e, e, -e, e, 0.5 * self.radius, 3.5 * self.radius)
            * look_at_mat4(Vec3::new(0.0, 0.0, 2.0 * self.radius), Vec3::ZERO, Vec3::Y)
    }

    /// Per pixel of a `size`² image: 0 shadowed, 1 lit, 2 background, by `reference` under
    /// `light` (unit, toward the light).
    pub fn flags(&self, reference: &SurfaceReference, light: Vec3, corrected: bool, size: u32) -> Vec<u32> {
        let (r, tau) = (self.radius, std::f32::consts::TAU);
        let scale = tau / self.tiles;
        (0..size * size)
            .map(|i| {
                let (px, py) = (i % size, i / size);
                let x = ((px as f32 + 0.5) / size as f32 * 2.0 - 1.0) * self.extent();
                let y = (1.0 - (py as f32 + 0.5) / size as f32 * 2.0) * self.extent();
                if x * x + y * y >= r * r {
                    return 2;
                }
                let z = (r * r - x * x - y * y).sqrt();
                let theta = (y / r).clamp(-1.0, 1.0).acos();
                let phi = (-z).atan2(x).rem_euclid(tau);
                let uv = Vec2::new(self.tiles * phi / tau, self.tiles * 0.5 * theta / std::f32::consts::PI);
                let (st, ct, sp, cp) = (theta.sin(), theta.cos(), phi.sin(), phi.cos());
                let pu = Vec3::new(-sp, 0.0, -cp) * (scale * r * st);
                let pv = Vec3::new(ct * cp, -st, -ct * sp) * (scale * r);
                let n = Vec3::new(x, y, z) / r;
                let k = Vec2::splat(1.0 / r);
                // The principal directions of a sphere: any orthogonal pair; the texture axes.
                reference.lit(light, corrected, uv, n, k, Vec2::X, Vec2::Y, pu, pv) as u32
            })
            .collect()
    }
}

/// Shadowed share of the pixels that are not background (flags 0 shadowed, 1 lit, 2
/// background).
pub fn shadowed_fraction(flags: &[u32]) -> f64 {
    let on = flags.iter().filter(|&&f| f != 2).count();
    flags.iter().filter(|&&f| f == 0).count() as f64 / on.max(1) as f64
}
