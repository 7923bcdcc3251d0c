//! Curvature-corrected horizon shadows (seed 000): the WGSL module and its CPU reference.
//!
//! [`HORIZON_WGSL`] holds `horizon_local_curvature` (eq. 1), `horizon_corrected_slope`
//! (eq. 2–3), `horizon_is_lit`, `horizon_fetch` and `horizon_shadow_lit`. Each has a CPU
//! function of the same name and argument order here; tests compare the two on a device.
//! Conventions are in the WGSL file's header.

use glam::{Vec2, Vec3};
use hikage_bundle::{TextureData, TextureDimension};

/// WGSL source of the horizon-shadow functions; include it in a shader module.
pub const HORIZON_WGSL: &str = include_str!("shaders/horizon.wgsl");

/// The sampler the horizon texture wants: linear filtering, `Repeat` on every axis (on `w` so
/// that directions interpolate and wrap 2π → 0; on `u`, `v` for tiling bump maps).
pub fn horizon_sampler(device: &wgpu::Device) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("hikage horizon"),
        address_mode_u: wgpu::AddressMode::Repeat,
        address_mode_v: wgpu::AddressMode::Repeat,
        address_mode_w: wgpu::AddressMode::Repeat,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    })
}

/// Eq. (1): normal curvature along the light's azimuth; `(cos_phi, sin_phi)` is measured from
/// the first principal direction.
pub fn horizon_local_curvature(k1: f32, k2: f32, cos_phi: f32, sin_phi: f32) -> f32 {
    k1 * cos_phi * cos_phi + k2 * sin_phi * sin_phi
}

/// Eq. (2)–(3): horizon slope seen from height `h` above a base surface of curvature `kappa`;
/// unchanged for `kappa ≤ 0`.
pub fn horizon_corrected_slope(tan_beta: f32, d: f32, kappa: f32, h: f32) -> f32 {
    if kappa <= 0.0 {
        return tan_beta;
    }
    let kh = kappa * h;
    let bump = tan_beta * (1.0 - kh) - 0.5 * kappa * d;
    let base = -(kh * (2.0 + kh)).max(0.0).sqrt();
    bump.max(base)
}

/// Lit when the light (surface frame `(P_u, P_v, N)`) is above the horizon; light from behind
/// the surface is not culled.
pub fn horizon_is_lit(light: Vec3, tan_beta: f32) -> bool {
    light.z > tan_beta * light.truncate().length()
}

/// A horizon texture on the CPU, sampled as the GPU does with a linear, Repeat sampler.
pub struct HorizonMap {
    width: usize,
    height: usize,
    directions: usize,
    texels: Vec<[f32; 2]>,
}

impl HorizonMap {
    /// Level 0 of a two-channel 3D texture (values as stored: `tan β`, `d` for float formats).
    pub fn new(texture: &TextureData) -> Option<HorizonMap> {
        let d = &texture.desc;
        if d.dimension != TextureDimension::D3 || d.format.channels() != 2 {
            return None;
        }
        let values = texture.to_f32(0);
        Some(HorizonMap {
            width: d.width as usize,
            height: d.height as usize,
            directions: d.depth as usize,
            texels: values.chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
        })
    }

    /// Trilinear sample at normalised coordinates with Repeat on every axis.
    pub fn sample(&self, coord: Vec3) -> [f32; 2] {
        let axis = |x: f32, n: usize| {
            let p = x * n as f32 - 0.5;
            let i = p.floor();
            let f = p - i;
            let i0 = (i as i64).rem_euclid(n as i64) as usize;
            (i0, (i0 + 1) % n, f)
        };
        let (x0, x1, fx) = axis(coord.x, self.width);
        let (y0, y1, fy) = axis(coord.y, self.height);
        let (z0, z1, fz) = axis(coord.z, self.directions);
        let at = |x: usize, y: usize, z: usize| self.texels[(z * self.height + y) * self.width + x];
        let mut out = [0.0; 2];
        for (c, o) in out.iter_mut().enumerate() {
            let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
            let plane = |z| {
                lerp(lerp(at(x0, y0, z)[c], at(x1, y0, z)[c], fx), lerp(at(x0, y1, z)[c], at(x1, y1, z)[c], fx), fy)
            };
            *o = lerp(plane(z0), plane(z1), fz);
        }
        out
    }
}

/// `(tan β, d)` at texture coordinate `uv` for texel-space azimuth `phi` (radians).
pub fn horizon_fetch(map: &HorizonMap, uv: Vec2, phi: f32) -> [f32; 2] {
    let w = phi / std::f32::consts::TAU + 0.5 / map.directions as f32;
    map.sample(uv.extend(w))
}

/// The whole test, as `horizon_shadow_lit` in WGSL.
#[allow(clippy::too_many_arguments)]
pub fn horizon_shadow_lit(map: &HorizonMap, uv: Vec2, light: Vec3, k1: f32, k2: f32, principal: Vec2, h: f32) -> bool {
    let flat_len = light.truncate().length();
    if flat_len <= 0.0 {
        return light.z > 0.0;
    }
    let dir = light.truncate() / flat_len;
    let p = principal.normalize();
    let kappa = horizon_local_curvature(k1, k2, dir.dot(p), dir.x * p.y - dir.y * p.x);
    let [tan_beta, d] = horizon_fetch(map, uv, light.y.atan2(light.x));
    horizon_is_lit(light, horizon_corrected_slope(tan_beta, d, kappa, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corrected_slope_follows_the_equations() {
        // Concave or flat: unchanged.
        assert_eq!(horizon_corrected_slope(0.5, 10.0, 0.0, 2.0), 0.5);
        assert_eq!(horizon_corrected_slope(0.5, 10.0, -0.1, 2.0), 0.5);
        // Eq. 2 by hand: 0.5 (1 - 0.015·2) - 0.015·10/2 = 0.485 - 0.075 = 0.41.
        assert!((horizon_corrected_slope(0.5, 10.0, 0.015, 2.0) - 0.41).abs() < 1e-6);
        // Eq. 3 wins for a low bump horizon: -sqrt(0.03·2.03) = -0.24678…
        assert!((horizon_corrected_slope(-1.0, 10.0, 0.015, 2.0) + (0.03f32 * 2.03).sqrt()).abs() < 1e-6);
        // Curvature along principal directions.
        assert_eq!(horizon_local_curvature(0.2, 0.05, 1.0, 0.0), 0.2);
        assert_eq!(horizon_local_curvature(0.2, 0.05, 0.0, 1.0), 0.05);
        // Lit exactly above the horizon, also from below the tangent plane.
        assert!(horizon_is_lit(Vec3::new(1.0, 0.0, 0.6), 0.5));
        assert!(!horizon_is_lit(Vec3::new(1.0, 0.0, 0.4), 0.5));
        assert!(horizon_is_lit(Vec3::new(1.0, 0.0, -0.2), -0.3));
    }
}
