//! The CPU references of the horizon WGSL: every function of [`super::HORIZON_WGSL`] under the
//! same name with the same arguments, a horizon texture sampled as the GPU samples it
//! ([`HorizonMap`]), and [`SurfaceReference`], the lit test of [`super::SurfaceShadows`] per
//! pixel. The tests hold the shaders to them; tools can shadow without a device.

use glam::{Vec2, Vec3};
use hikage_bundle::{EdgeMode, HorizonSettings, TextureData, TextureDimension, world_height};

use super::{HorizonEncoding, SurfaceUniform};
use crate::error::RuntimeError;
use crate::load::CpuBundle;

/// Eq. (1): the normal curvature along `v` from the principal curvatures and directions `v1`,
/// `v2` (any lengths, orthogonal on the surface): `κ1 cos²φ + κ2 sin²φ` with
/// `cos φ = v·v1/(|v||v1|)`, `sin φ = v·v2/(|v||v2|)`.
pub fn horizon_local_curvature(k1: f32, k2: f32, v: Vec3, v1: Vec3, v2: Vec3) -> f32 {
    let vv = v.dot(v);
    if vv <= 0.0 {
        return 0.0;
    }
    let c = v.dot(v1);
    let s = v.dot(v2);
    k1 * c * c / (vv * v1.dot(v1).max(1e-30)) + k2 * s * s / (vv * v2.dot(v2).max(1e-30))
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

/// Lit when `light` (bump frame) rises above `tan_beta`; light from behind is not culled.
pub fn horizon_is_lit(light: Vec3, tan_beta: f32) -> bool {
    light.z > tan_beta * light.truncate().length()
}

/// The texel-space azimuth (radians, from +u toward +v) of a bump-frame direction.
pub fn horizon_texel_azimuth(light: Vec3, texel_size: Vec2) -> f32 {
    (light.y / texel_size.y).atan2(light.x / texel_size.x)
}

/// Share of a light disc of angular `radius` (radians) above a horizon, its centre `above`
/// radians over it (a circular segment's area; all or nothing for `radius` 0).
pub fn horizon_disc_visible(above: f32, radius: f32) -> f32 {
    if radius <= 0.0 {
        return if above > 0.0 { 1.0 } else { 0.0 };
    }
    let t = (above / radius).clamp(-1.0, 1.0);
    ((-t).acos() + t * (1.0 - t * t).sqrt()) / std::f32::consts::PI
}

/// The principal directions in mesh space (not normalised), rebuilt from their dot products
/// `d1`, `d2` with the unit tangents of +u and +v, which need not be orthogonal.
pub fn horizon_principal_directions(pu: Vec3, pv: Vec3, n: Vec3, d1: Vec2, d2: Vec2) -> (Vec3, Vec3) {
    let eu = (pu - n * pu.dot(n)).normalize();
    let ev = (pv - n * pv.dot(n)).normalize();
    let c = eu.dot(ev);
    ((d1.x - c * d1.y) * eu + (d1.y - c * d1.x) * ev, (d2.x - c * d2.y) * eu + (d2.y - c * d2.x) * ev)
}

/// A light on a curved surface in the bump frame, as [`horizon_surface_light`] gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HorizonSurfaceLight {
    /// The light in the bump frame (not normalised).
    pub light: Vec3,
    /// Eq. (1)'s curvature along the light, 1/bump-world units.
    pub kappa: f32,
}

/// Takes light `l` into the bump frame of a surface point (see the WGSL function of the same
/// name for every argument).
#[expect(clippy::too_many_arguments, reason = "mirrors a WGSL function argument for argument")]
pub fn horizon_surface_light(
    l: Vec3,
    pu: Vec3,
    pv: Vec3,
    n: Vec3,
    k1: f32,
    k2: f32,
    d1: Vec2,
    d2: Vec2,
    tile: Vec2,
) -> HorizonSurfaceLight {
    let hs = (pu.cross(pv).length() / (tile.x * tile.y)).sqrt();
    let au = pu / tile.x;
    let av = pv / tile.y;
    let an = n * hs;
    let det = au.dot(av.cross(an));
    let lb = Vec3::new(l.dot(av.cross(an)), au.dot(l.cross(an)), au.dot(av.cross(l))) / det;
    let (v1, v2) = horizon_principal_directions(pu, pv, n, d1, d2);
    let kappa = horizon_local_curvature(k1, k2, l - n * l.dot(n), v1, v2);
    let across = lb.truncate().length();
    let g = if across > 0.0 { (au * (lb.x / across) + av * (lb.y / across)).length() } else { 1.0 };
    HorizonSurfaceLight { light: lb, kappa: kappa * g * g / hs }
}

/// The whole test at a surface point, as `horizon_surface_lit` in WGSL.
pub fn horizon_surface_lit(
    map: &HorizonMap,
    uv: Vec2,
    s: HorizonSurfaceLight,
    h: f32,
    texel_size: Vec2,
    corrected: bool,
) -> bool {
    let [tan_beta, d] = horizon_fetch(map, uv, horizon_texel_azimuth(s.light, texel_size));
    let kappa = if corrected { s.kappa } else { 0.0 };
    horizon_is_lit(s.light, horizon_corrected_slope(tan_beta, d, kappa, h))
}

/// Sun visibility on a heightfield drawn as geometry, as `horizon_sun_visible` in WGSL.
pub fn horizon_sun_visible(map: &HorizonMap, uv: Vec2, sun: Vec3, texel_size: Vec2, radius: f32) -> f32 {
    let [tan_beta, _] = horizon_fetch(map, uv, horizon_texel_azimuth(sun, texel_size));
    let elevation = sun.z.atan2(sun.truncate().length());
    horizon_disc_visible(elevation - tan_beta.atan(), radius)
}

/// Horizon points a raised point's walk visits at most ([`horizon_raised_sun_visible`]).
pub const RAISED_HOPS: u32 = 8;

/// Sun visibility of a point `height` above the heightfield at `uv` (bump-world units), from the
/// horizons alone, as `horizon_raised_sun_visible` in WGSL. A texel's horizon point, then that
/// point's own horizon point, and so on, are the vertices of the upper convex hull of the
/// terrain's profile in that direction; a raised point's horizon is the vertex it sees highest,
/// where the slope from it stops rising ([`horizon_raised_angle`]). So a farther ridge that the
/// ground's near occluder hides still shadows a point above it. The walk runs in the two baked
/// directions either side of the sun, on stored texels (a blend of two texels' occluders is no
/// point of the terrain), and its angles are blended as the sampler blends the ground's.
/// `reach` bounds it (the bake's `max_distance`, or the map's extent); `height` 0 is the ground.
pub fn horizon_raised_sun_visible(
    map: &HorizonMap,
    uv: Vec2,
    sun: Vec3,
    texel_size: Vec2,
    height: f32,
    reach: f32,
    radius: f32,
) -> f32 {
    let directions = map.directions as f32;
    let f = (horizon_texel_azimuth(sun, texel_size) / std::f32::consts::TAU * directions).rem_euclid(directions);
    let k0 = f.floor();
    let at = uv * Vec2::new(map.width as f32, map.height as f32);
    let angle = |k: f32| horizon_raised_angle(map, at, k.rem_euclid(directions) as u32, texel_size, height, reach);
    let horizon = angle(k0) + (angle(k0 + 1.0) - angle(k0)) * (f - k0);
    let elevation = sun.z.atan2(sun.truncate().length());
    horizon_disc_visible(elevation - horizon, radius)
}

/// The horizon angle (radians) of a point `height` above the heightfield at texel coordinates
/// `at`, in baked direction `k`: the walk of [`horizon_raised_sun_visible`] over the stored
/// texels under each horizon point (at most [`RAISED_HOPS`], none past `reach`, none off the
/// map), as `horizon_raised_angle` in WGSL; −π/2 with no occluder.
pub fn horizon_raised_angle(map: &HorizonMap, at: Vec2, k: u32, texel_size: Vec2, height: f32, reach: f32) -> f32 {
    let phi = std::f32::consts::TAU * k as f32 / map.directions as f32;
    let along = Vec2::new(phi.cos(), phi.sin());
    // Texels per world unit along the direction.
    let step = along / (along * texel_size).length();
    let (mut t, mut z, mut best) = (0.0f32, 0.0f32, -1e30f32);
    for _ in 0..RAISED_HOPS {
        let p = (at + step * t).floor();
        if p.x < 0.0 || p.y < 0.0 || p.x >= map.width as f32 || p.y >= map.height as f32 {
            break;
        }
        let [tan_beta, d] = horizon_load(map, (p.x as u32, p.y as u32), k);
        if d <= 0.0 || t + d > reach {
            break;
        }
        let (t1, z1) = (t + d, z + d * tan_beta);
        let slope = (z1 - height) / t1;
        if slope <= best {
            break;
        }
        (t, z, best) = (t1, z1, slope);
    }
    best.atan()
}

/// `(tan β, d)` of texel `texel` in direction `k`, decoded, as `horizon_load` in WGSL.
pub fn horizon_load(map: &HorizonMap, (x, y): (u32, u32), k: u32) -> [f32; 2] {
    let i = (k as usize * map.height + y as usize) * map.width + x as usize;
    decode(map, map.texels[i])
}

/// Stored channels `[c0, c1]` as `(tan β, d)`, as `horizon_decode` in WGSL.
fn decode(map: &HorizonMap, [c0, c1]: [f32; 2]) -> [f32; 2] {
    if map.encoding.format == 1 {
        let slope = if c0 > 0.0 { ((c0 - 0.5) * std::f32::consts::PI).tan() } else { map.encoding.open_sky_slope };
        return [slope, c1 * map.encoding.distance_scale];
    }
    [c0, c1]
}

/// `(tan β, d)` at texture coordinate `uv` for texel-space azimuth `phi` (radians), decoded.
pub fn horizon_fetch(map: &HorizonMap, uv: Vec2, phi: f32) -> [f32; 2] {
    let w = phi / std::f32::consts::TAU + 0.5 / map.directions as f32;
    decode(map, map.sample(uv.extend(w)))
}

/// A horizon texture on the CPU, sampled as the GPU does with [`super::horizon_sampler`]: trilinear
/// (or nearest), `Repeat` on `w`, and `Repeat` or `ClampToEdge` on `u`, `v` by edge mode.
#[derive(Clone, Debug, PartialEq)]
pub struct HorizonMap {
    width: usize,
    height: usize,
    directions: usize,
    edge: EdgeMode,
    filtered: bool,
    encoding: HorizonEncoding,
    texels: Vec<[f32; 2]>,
}

impl HorizonMap {
    /// Level 0 of a horizon asset's texture with the settings it was baked with; `filtered`
    /// as [`super::horizon_filterable`] says for the device compared with.
    pub fn new(texture: &TextureData, settings: &HorizonSettings, filtered: bool) -> Option<HorizonMap> {
        let d = &texture.desc;
        if d.dimension != TextureDimension::D3 || d.format.channels() != 2 {
            return None;
        }
        let values = texture.to_f32(0);
        Some(HorizonMap {
            width: d.width as usize,
            height: d.height as usize,
            directions: d.depth as usize,
            edge: settings.edge,
            filtered,
            encoding: HorizonEncoding::new(d.format, settings),
            texels: values.chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
        })
    }

    /// Sample at normalised coordinates, channels as stored.
    pub fn sample(&self, coord: Vec3) -> [f32; 2] {
        let wrap = |i: i64, n: usize| i.rem_euclid(n as i64) as usize;
        let clamp = |i: i64, n: usize| i.clamp(0, n as i64 - 1) as usize;
        let uv_index = |i: i64, n: usize| if self.edge == EdgeMode::Wrap { wrap(i, n) } else { clamp(i, n) };
        let at = |x: usize, y: usize, z: usize| self.texels[(z * self.height + y) * self.width + x];
        if !self.filtered {
            let pick = |x: f32, n: usize| (x * n as f32).floor() as i64;
            let (x, y, z) = (pick(coord.x, self.width), pick(coord.y, self.height), pick(coord.z, self.directions));
            return at(uv_index(x, self.width), uv_index(y, self.height), wrap(z, self.directions));
        }
        let axis = |x: f32, n: usize, index: &dyn Fn(i64, usize) -> usize| {
            let p = x * n as f32 - 0.5;
            let i = p.floor();
            (index(i as i64, n), index(i as i64 + 1, n), p - i)
        };
        let (x0, x1, fx) = axis(coord.x, self.width, &uv_index);
        let (y0, y1, fy) = axis(coord.y, self.height, &uv_index);
        let (z0, z1, fz) = axis(coord.z, self.directions, &wrap);
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        std::array::from_fn(|c| {
            let plane = |z| {
                lerp(lerp(at(x0, y0, z)[c], at(x1, y0, z)[c], fx), lerp(at(x0, y1, z)[c], at(x1, y1, z)[c], fx), fy)
            };
            lerp(plane(z0), plane(z1), fz)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A profile along +u (one row, one direction, 1 m texels, clamped): flat ground, a 10 m
    /// bump at 5 m and a 60 m ridge at 40 m, its horizons found by trying every sample ahead.
    fn ridge_map() -> (Vec<f32>, HorizonMap) {
        let heights: Vec<f32> = (0..64)
            .map(|x| match x {
                5 => 10.0,
                40 => 60.0,
                _ => 0.0,
            })
            .collect();
        let texels: Vec<f32> = (0..64usize)
            .flat_map(|x| {
                let ahead = (x + 1..64).map(|y| ((heights[y] - heights[x]) / (y - x) as f32, (y - x) as f32));
                let (slope, d) = ahead.fold((-1e9f32, 0.0f32), |b, c| if c.0 > b.0 { c } else { b });
                [slope, d]
            })
            .collect();
        let desc = hikage_bundle::TextureDesc {
            format: hikage_bundle::TextureFormat::Rg32Float,
            dimension: TextureDimension::D3,
            width: 64,
            height: 1,
            depth: 1,
            layers: 1,
            levels: 1,
            supercompression: hikage_bundle::Supercompression::None,
            channels: vec!["slope".into(), "distance".into()],
        };
        let texture = TextureData::from_f32(desc, &texels).unwrap();
        let settings = HorizonSettings {
            heightfield: "h".into(),
            directions: 1,
            edge: EdgeMode::Clamp,
            max_distance: None,
            near_field: 16,
            texel_size: (1.0, 1.0),
            height_scale: 1.0,
            open_sky_slope: -1e9,
            distance_scale: 1.0,
            tile: None,
        };
        (heights, HorizonMap::new(&texture, &settings, false).unwrap())
    }

    /// From 9 m above the foot of the bump the ridge behind it rises highest (51 m over 40 m),
    /// not the bump (1 m over 5 m): the walk over the horizon points finds it, where the
    /// bump's horizon seen from the raised point would light it under a 30° sun; on the ground the
    /// walk is the ground's test.
    #[test]
    fn a_raised_point_sees_the_ridge_behind_the_near_occluder() {
        let (_, map) = ridge_map();
        let at = |elevation: f32| Vec3::new(elevation.to_radians().cos(), 0.0, elevation.to_radians().sin());
        let uv = Vec2::new(0.5 / 64.0, 0.5);
        let raised = |elevation: f32, h: f32| {
            horizon_raised_sun_visible(&map, uv, at(elevation), Vec2::ONE, h, f32::INFINITY, 0.0)
        };
        // 51/40 = tan 51.9°.
        assert_eq!((raised(30.0, 9.0), raised(51.0, 9.0), raised(53.0, 9.0)), (0.0, 0.0, 1.0));
        // The bump alone, seen from the raised point: (10 − 9) / 5 = tan 11.3°.
        let [tan_beta, d] = horizon_fetch(&map, uv, 0.0);
        assert_eq!((tan_beta, d), (2.0, 5.0));
        assert!(((d * tan_beta - 9.0) / d).atan().to_degrees() < 30.0);
        // On the ground: the bump, tan β = 2 (63.4°), as the ground's own test.
        for elevation in [30.0, 63.0, 64.0] {
            let ground = horizon_sun_visible(&map, uv, at(elevation), Vec2::ONE, 0.0);
            assert_eq!(raised(elevation, 0.0), ground, "{elevation}°");
        }
        // A reach short of the ridge leaves the bump: lit at 30° from 9 m up.
        assert_eq!(horizon_raised_sun_visible(&map, uv, at(30.0), Vec2::ONE, 9.0, 39.0, 0.0), 1.0);
    }

    #[test]
    fn corrected_slope_follows_the_equations() {
        // Concave or flat: unchanged.
        assert_eq!(horizon_corrected_slope(0.5, 10.0, 0.0, 2.0), 0.5);
        assert_eq!(horizon_corrected_slope(0.5, 10.0, -0.1, 2.0), 0.5);
        // Eq. 2 by hand: 0.5 (1 - 0.015·2) - 0.015·10/2 = 0.485 - 0.075 = 0.41.
        assert!((horizon_corrected_slope(0.5, 10.0, 0.015, 2.0) - 0.41).abs() < 1e-6);
        // Eq. 3 wins for a low bump horizon: -sqrt(0.03·2.03) = -0.24678…
        assert!((horizon_corrected_slope(-1.0, 10.0, 0.015, 2.0) + (0.03f32 * 2.03).sqrt()).abs() < 1e-6);
        // Lit exactly above the horizon, also from below the tangent plane.
        assert!(horizon_is_lit(Vec3::new(1.0, 0.0, 0.6), 0.5));
        assert!(!horizon_is_lit(Vec3::new(1.0, 0.0, 0.4), 0.5));
        assert!(horizon_is_lit(Vec3::new(1.0, 0.0, -0.2), -0.3));
    }

    #[test]
    fn disc_visibility_is_a_circular_segment() {
        assert_eq!(horizon_disc_visible(0.01, 0.0), 1.0);
        assert_eq!(horizon_disc_visible(-0.01, 0.0), 0.0);
        assert!((horizon_disc_visible(0.0, 0.01) - 0.5).abs() < 1e-6);
        assert_eq!(horizon_disc_visible(0.02, 0.01), 1.0);
        assert_eq!(horizon_disc_visible(-0.02, 0.01), 0.0);
        // Half a radius up: area of the segment below the chord at −r/2, by hand:
        // 1 − (acos(1/2) − (1/2)·sqrt(3/4)) / π = 0.80450…
        assert!((horizon_disc_visible(0.005, 0.01) - 0.804_498).abs() < 1e-5);
    }

    /// Eq. (1) against Euler's formula on a frame whose texture axes meet at 60°: the principal
    /// directions rebuilt from their stored dot products, with both used, give the exact normal
    /// curvature for every light azimuth; the single-direction form (sin φ from a 2D cross
    /// product with V1 in the (u, v) plane) does not.
    #[test]
    fn local_curvature_uses_both_principal_directions_on_a_sheared_frame() {
        let n = Vec3::Z;
        let pu = Vec3::new(1.0, 0.0, 0.0);
        let pv = Vec3::new(60f32.to_radians().cos(), 60f32.to_radians().sin(), 0.0) * 1.5;
        let (eu, ev) = (pu.normalize(), pv.normalize());
        // Principal directions at 20° and 110° from +x, orthogonal on the surface.
        let v1 = Vec3::new(20f32.to_radians().cos(), 20f32.to_radians().sin(), 0.0);
        let v2 = n.cross(v1);
        let (k1, k2) = (0.04f32, 0.01f32);
        // As the Curvature asset stores them: dot products with the unit tangents.
        let (d1, d2) = (Vec2::new(v1.dot(eu), v1.dot(ev)), Vec2::new(v2.dot(eu), v2.dot(ev)));
        let (r1, r2) = horizon_principal_directions(pu, pv, n, d1, d2);
        assert!(r1.normalize().dot(v1) > 1.0 - 1e-6 && r2.normalize().dot(v2) > 1.0 - 1e-6, "{r1} {r2}");
        let mut worst_single = 0.0f32;
        for k in 0..72 {
            let az = k as f32 * 5f32.to_radians();
            let v = Vec3::new(az.cos(), az.sin(), 0.0);
            let euler = k1 * v.dot(v1).powi(2) + k2 * v.dot(v2).powi(2);
            let ours = horizon_local_curvature(k1, k2, v * 3.0, r1, r2);
            assert!((ours - euler).abs() < 1e-6, "azimuth {k}: {ours} vs Euler {euler}");
            // The single-direction form, in (u, v) components of the light and of V1.
            let to_uv = |w: Vec3| {
                let det = pu.x * pv.y - pu.y * pv.x;
                Vec2::new(w.x * pv.y - w.y * pv.x, pu.x * w.y - pu.y * w.x) / det
            };
            let (luv, p) = (to_uv(v).normalize(), to_uv(v1).normalize());
            let single = k1 * luv.dot(p).powi(2) + k2 * (luv.x * p.y - luv.y * p.x).powi(2);
            worst_single = worst_single.max((single - euler).abs());
        }
        assert!(worst_single > 0.005, "the single-direction form should err on a sheared frame: {worst_single}");
    }

    /// The frame takes a light along the surface's own texture axes to the bump frame's axes,
    /// whatever the handedness of (P_u, P_v, N).
    #[test]
    fn surface_light_lands_on_the_bump_axes() {
        let (pu, pv) = (Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -2.0));
        let n = Vec3::Y; // pu × pv points −Y: a mirrored mapping, as sphere.obj's.
        let tile = Vec2::splat(2.0);
        let flat = |l: Vec3| horizon_surface_light(l, pu, pv, n, 0.0, 0.0, Vec2::X, Vec2::Y, tile).light;
        assert!((flat(Vec3::X) - Vec3::X).length() < 1e-6);
        assert!((flat(Vec3::NEG_Z) - Vec3::Y).length() < 1e-6);
        assert!((flat(Vec3::Y) - Vec3::Z).length() < 1e-6);
    }
}

/// The CPU reference of [`super::SurfaceShadows`]' lit test: the same math per pixel on the same
/// maps, for tests and for tools that want the shadow without a device.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceReference {
    map: HorizonMap,
    heights: Vec<f32>,
    size: (usize, usize),
    statics: SurfaceUniform,
}

impl SurfaceReference {
    /// The reference for the bump map of `horizon` in `cpu` (which must hold its heightfield
    /// too); `filtered` as [`super::horizon_filterable`] says for the device compared with.
    pub fn new(cpu: &CpuBundle, horizon: &str, filtered: bool) -> Result<SurfaceReference, RuntimeError> {
        let missing = |id: &str| RuntimeError::Asset { asset: id.to_string(), message: "not read".into() };
        let map_asset = cpu.asset(horizon).ok_or_else(|| missing(horizon))?;
        let settings = map_asset.asset.settings.horizon().ok_or_else(|| missing(horizon))?;
        let texture = map_asset.texture().ok_or_else(|| missing(horizon))?;
        let heights_asset = cpu.asset(&settings.heightfield).ok_or_else(|| missing(&settings.heightfield))?;
        let hf = heights_asset.asset.settings.heightfield().ok_or_else(|| missing(&settings.heightfield))?;
        let heights = heights_asset.texture().ok_or_else(|| missing(&settings.heightfield))?;
        let map = HorizonMap::new(texture, settings, filtered).ok_or_else(|| missing(horizon))?;
        let (w, h) = (heights.desc.width, heights.desc.height);
        let (sx, sy) = settings.texel_size;
        let statics = SurfaceUniform {
            tile: [w as f32 * sx, h as f32 * sy],
            texel_size: [sx, sy],
            height_scale: hf.height_scale,
            height_offset: hf.height_offset,
            size: [w, h],
            ..bytemuck::Zeroable::zeroed()
        };
        Ok(SurfaceReference { map, heights: heights.to_f32(0), size: (w as usize, h as usize), statics })
    }

    /// `surface_lit` of the WGSL: is the point lit by `light` (mesh space, unit)? The other
    /// arguments are the Curvature asset's streams interpolated at the point.
    #[expect(clippy::too_many_arguments, reason = "mirrors a WGSL function argument for argument")]
    pub fn lit(
        &self,
        light: Vec3,
        corrected: bool,
        uv: Vec2,
        normal: Vec3,
        k: Vec2,
        d1: Vec2,
        d2: Vec2,
        pu: Vec3,
        pv: Vec3,
    ) -> bool {
        let tile = Vec2::from(self.statics.tile);
        let s = horizon_surface_light(light, pu, pv, normal, k.x, k.y, d1, d2, tile);
        let f = uv - uv.floor();
        let (w, h) = self.size;
        let (i, j) = (((f.x * w as f32).floor() as usize).min(w - 1), ((f.y * h as f32).floor() as usize).min(h - 1));
        let height = world_height(self.statics.height_offset, self.statics.height_scale, self.heights[j * w + i]);
        horizon_surface_lit(&self.map, uv, s, height, Vec2::from(self.statics.texel_size), corrected)
    }
}
