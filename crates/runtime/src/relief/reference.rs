//! The CPU reference of the relief WGSL: [`ReliefMaps`] runs every tracer, the shadow test and
//! the ambient occlusion line by line as [`super::RELIEF_WGSL`] does, counting each height-map
//! and depth-map read; [`relief_material_shade`] is the material's fragment stage; and
//! [`fine_march`] is the independent ground truth the tracers are judged against.

use glam::{Vec2, Vec3, Vec4};
use hikage_bundle::relief::{DirectionRule, MaxMip, ReliefDirections, ReliefRay, first_hit_maxmip};
use hikage_bundle::{AssetKind, ReliefSettings, Settings, TextureData};

use super::{ReliefMaterialUniform, ReliefUniform, Tracer, VisibilityPath};
use crate::error::RuntimeError;
use crate::load::CpuBundle;

/// A relief asset pair in memory: the max-mip pyramid (its level 0 is the surface) and the depth
/// maps with their direction table.
#[derive(Clone, Debug, PartialEq)]
pub struct ReliefMaps {
    /// The heights and their max-mip pyramid.
    pub max_mip: MaxMip,
    /// Depth maps, `[layer][row][col]`.
    pub depth: Vec<f32>,
    /// Width and height of each depth map.
    pub depth_size: (u32, u32),
    /// The direction table.
    pub dirs: ReliefDirections,
    /// Relief thickness in texels of the heightfield.
    pub thickness: f32,
    /// Which row a ray's estimate is read from.
    pub rule: DirectionRule,
    /// How shadows and ambient occlusion decide visibility.
    pub visibility: VisibilityPath,
}

/// Reads a tracer made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Reads {
    /// Height-map reads (any max-mip level).
    pub height: u32,
    /// Depth-map reads.
    pub depth: u32,
}

impl Reads {
    /// All reads.
    pub fn total(&self) -> u32 {
        self.height + self.depth
    }
}

impl ReliefMaps {
    /// The tracer uniform for these maps and `tracer`.
    pub fn uniform(&self, tracer: Tracer) -> ReliefUniform {
        ReliefUniform {
            size: [self.max_mip.width(), self.max_mip.height()],
            depth_size: [self.depth_size.0, self.depth_size.1],
            levels: self.max_mip.levels(),
            theta_rows: self.dirs.theta,
            phi_cols: self.dirs.phi,
            thickness: self.thickness,
            ..ReliefUniform::default()
        }
        .with_tracer(tracer)
        .with_reads(self.rule, self.visibility)
    }

    /// The shading normal at a point of the relief (texels, `z` up): central differences of
    /// the heights around its texel, as `relief_normal` in the WGSL.
    pub fn normal(&self, p: [f32; 3]) -> [f32; 3] {
        let (i, j) = (p[0].floor() as i64, p[1].floor() as i64);
        let h = |i: i64, j: i64| self.max_mip.max_height(0, i, j);
        let k = 0.5 * self.thickness;
        let n = [(h(i - 1, j) - h(i + 1, j)) * k, (h(i, j - 1) - h(i, j + 1)) * k, 1.0];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        [n[0] / l, n[1] / l, n[2] / l]
    }

    /// Reads a relief asset and the max-mip pyramid it names from a loaded bundle.
    pub fn from_bundle(bundle: &CpuBundle, relief_id: &str) -> Result<ReliefMaps, RuntimeError> {
        let bad = |id: &str, m: String| RuntimeError::Unsupported { asset: id.to_string(), message: m };
        let relief = bundle.asset(relief_id).ok_or_else(|| bad(relief_id, "no such asset".into()))?;
        let (settings, depth) = match (&relief.asset.settings, relief.texture()) {
            (Settings::Relief(s), Some(t)) if relief.asset.kind == AssetKind::Relief => (s, t),
            _ => return Err(bad(relief_id, "not a relief asset".into())),
        };
        let mm = bundle.asset(&settings.max_mip).and_then(|a| a.texture());
        let mm = mm.ok_or_else(|| bad(relief_id, format!("its max-mip texture `{}` is missing", settings.max_mip)))?;
        ReliefMaps::from_textures(settings, depth, mm).map_err(|m| bad(relief_id, m))
    }

    /// Builds the maps from the two textures and the relief asset's settings.
    pub fn from_textures(
        settings: &ReliefSettings,
        depth: &TextureData,
        max_mip: &TextureData,
    ) -> Result<ReliefMaps, String> {
        let levels = (0..max_mip.desc.levels).map(|l| max_mip.channel_f32(l, 0)).collect();
        let max_mip = MaxMip::from_levels(max_mip.desc.width, max_mip.desc.height, levels)?;
        let dirs = settings.table();
        if depth.desc.layers != dirs.layers() {
            return Err(format!("{} depth layers for {} directions", depth.desc.layers, dirs.layers()));
        }
        Ok(ReliefMaps {
            thickness: settings.depth_scale * max_mip.width() as f32,
            max_mip,
            depth: depth.channel_f32(0, 0),
            depth_size: (depth.desc.width, depth.desc.height),
            dirs,
            rule: DirectionRule::default(),
            visibility: VisibilityPath::default(),
        })
    }

    /// Depth-map texel of `layer` under the top-plane point `(u, v)` (texels of the heightfield;
    /// nearest texel, wrapping).
    pub fn depth_at(&self, layer: u32, u: f32, v: f32) -> f32 {
        let (dw, dh) = self.depth_size;
        let i = (u * dw as f32 / self.max_mip.width() as f32).floor() as i64;
        let j = (v * dh as f32 / self.max_mip.height() as f32).floor() as i64;
        let (i, j) = (i.rem_euclid(dw as i64) as usize, j.rem_euclid(dh as i64) as usize);
        self.depth[layer as usize * (dw * dh) as usize + j * dw as usize + i]
    }

    /// A ray entering the top plane at `origin` along the unit `dir` (`z` down).
    pub fn ray(&self, origin: [f32; 2], dir: [f32; 3]) -> ReliefRay {
        ReliefRay { origin, dir, thickness: self.thickness }
    }

    /// The seed's estimate of the hit length: the stored hit of the direction [`Self::rule`]
    /// picks, projected onto the view ray. One depth-map read.
    pub fn estimate(&self, ray: &ReliefRay, reads: &mut Reads) -> f32 {
        let layer = self.dirs.pick(ray.dir, self.rule);
        let k = self.dirs.direction(layer);
        reads.depth += 1;
        let d = self.depth_at(layer, ray.origin[0], ray.origin[1]);
        let along_sample = d * self.thickness / k[2];
        let cos = k[0] * ray.dir[0] + k[1] * ray.dir[1] + k[2] * ray.dir[2];
        (along_sample * cos).clamp(0.0, ray.s_bottom())
    }

    fn inside(&self, ray: &ReliefRay, s: f32, reads: &mut Reads) -> bool {
        reads.height += 1;
        ray.inside(&self.max_mip, s)
    }

    /// Halves `[lo, hi]` (`lo` outside, `hi` inside) `n` times; returns the midpoint.
    fn bisect(&self, ray: &ReliefRay, mut lo: f32, mut hi: f32, n: u32, reads: &mut Reads) -> f32 {
        for _ in 0..n {
            let mid = 0.5 * (lo + hi);
            if self.inside(ray, mid, reads) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        0.5 * (lo + hi)
    }

    /// The seed's search from an estimate `s0`: backward toward the entry point while inside
    /// the solid, forward while outside, in steps of `1/steps` of the depth, then `binary`
    /// halvings.
    fn search(&self, ray: &ReliefRay, s0: f32, steps: u32, binary: u32, reads: &mut Reads) -> f32 {
        let bottom = ray.s_bottom();
        let ds = bottom / steps.max(1) as f32;
        let (mut lo, mut hi);
        if self.inside(ray, s0, reads) {
            // Backward: step toward the entry point until outside.
            hi = s0;
            lo = 0.0;
            while hi > 0.0 {
                let s = (hi - ds).max(0.0);
                if s <= 0.0 || !self.inside(ray, s, reads) {
                    lo = s;
                    break;
                }
                hi = s;
            }
        } else {
            // Forward: step on until inside (the bottom plane always is).
            lo = s0;
            hi = bottom;
            loop {
                let s = lo + ds;
                if s >= bottom {
                    break;
                }
                if self.inside(ray, s, reads) {
                    hi = s;
                    break;
                }
                lo = s;
            }
        }
        self.bisect(ray, lo, hi, binary, reads)
    }

    /// The hit length the tracer finds for `ray`, counting reads.
    pub fn trace(&self, tracer: Tracer, ray: &ReliefRay, reads: &mut Reads) -> f32 {
        let bottom = ray.s_bottom();
        match tracer {
            Tracer::Linear { steps, binary } => {
                let ds = bottom / steps.max(1) as f32;
                let mut lo = 0.0;
                let mut hi = bottom;
                for k in 1..steps {
                    let s = k as f32 * ds;
                    if self.inside(ray, s, reads) {
                        hi = s;
                        break;
                    }
                    lo = s;
                }
                self.bisect(ray, lo, hi, binary, reads)
            }
            Tracer::DepthMap { steps, binary } => {
                let s0 = self.estimate(ray, reads);
                self.search(ray, s0, steps, binary, reads)
            }
            Tracer::MaxMip { start_level, stop_level } => {
                first_hit_maxmip(&self.max_mip, ray, (0.0, f32::INFINITY), (start_level, stop_level), &mut reads.height)
            }
            Tracer::Combined { margin, start_level } => {
                let s0 = self.estimate(ray, reads) * (1.0 - margin);
                first_hit_maxmip(&self.max_mip, ray, (s0, f32::INFINITY), (start_level, 0), &mut reads.height)
            }
        }
    }

    /// Whether the surface point at `uvz` (texels, normalised depth) sees the light along `light`
    /// (unit, `z` up toward the light), by [`Self::visibility`]: a hit on the way from the top
    /// plane no more than `bias` (a depth) above the point still counts as the point.
    pub fn lit(&self, uvz: [f32; 3], light: [f32; 3], bias: f32, reads: &mut Reads) -> bool {
        if light[2] <= 0.0 {
            return false;
        }
        let (entry, dir) = self.entry_toward(uvz, light);
        let ray = self.ray(entry, dir);
        match self.visibility {
            VisibilityPath::MaxMip => {
                let layer = self.dirs.pick(dir, self.rule);
                reads.depth += 1;
                let stored = self.depth_at(layer, entry[0], entry[1]);
                self.open_after(&ray, stored, uvz[2] - bias, reads)
            }
            VisibilityPath::Seed { steps, binary } => {
                let s0 = self.estimate(&ray, reads);
                self.search(&ray, s0, steps, binary, reads) * ray.dz() >= uvz[2] - bias
            }
        }
    }

    /// The max-mip path's decision for a ray whose stored hit is `stored`: open when the stored
    /// hit is not above `depth`; otherwise open when a max-mip traversal from the stored depth
    /// (pulled back 10%: it was stored for a nearby direction or entry point) down to `depth`
    /// meets nothing.
    fn open_after(&self, ray: &ReliefRay, stored: f32, depth: f32, reads: &mut Reads) -> bool {
        if stored >= depth {
            return true;
        }
        let dz = ray.dz();
        let s_point = depth.max(0.0) / dz;
        let s_start = stored / dz * 0.9;
        first_hit_maxmip(&self.max_mip, ray, (s_start, s_point), (2, 0), &mut reads.height) >= s_point
    }

    /// The exact answer [`Self::lit`] approximates: no hit on the full-resolution surface
    /// between the top plane and `bias` above the point (a max-mip traversal from the top).
    pub fn lit_exact(&self, uvz: [f32; 3], light: [f32; 3], bias: f32) -> bool {
        if light[2] <= 0.0 {
            return false;
        }
        let (entry, dir) = self.entry_toward(uvz, light);
        let ray = self.ray(entry, dir);
        let s_point = (uvz[2] - bias).max(0.0) / ray.dz();
        first_hit_maxmip(&self.max_mip, &ray, (0.0, s_point), (self.max_mip.levels(), 0), &mut 0) >= s_point
    }

    /// Where the ray from the top plane along `-toward` (unit, `z` up) reaching `uvz` enters,
    /// and its travel direction (`z` down).
    fn entry_toward(&self, uvz: [f32; 3], toward: [f32; 3]) -> ([f32; 2], [f32; 3]) {
        let back = uvz[2] * self.thickness / toward[2];
        ([uvz[0] + back * toward[0], uvz[1] + back * toward[1]], [-toward[0], -toward[1], toward[2]])
    }

    /// Cosine-weighted share of the hemisphere above `uvz` that is open, over every `stride`-th
    /// sample direction, each decided by [`Self::visibility`] as [`Self::lit`] does (the
    /// direction is the layer's own, so its stored hit is the estimate).
    pub fn ambient_occlusion(&self, uvz: [f32; 3], stride: u32, bias: f32, reads: &mut Reads) -> f32 {
        self.occlusion_by(uvz, stride, |layer, entry, k| {
            reads.depth += 1;
            let stored = self.depth_at(layer, entry[0], entry[1]);
            let ray = self.ray(entry, k);
            match self.visibility {
                VisibilityPath::MaxMip => self.open_after(&ray, stored, uvz[2] - bias, reads),
                VisibilityPath::Seed { steps, binary } => {
                    let dz = ray.dz();
                    self.search(&ray, stored / dz, steps, binary, reads) * dz >= uvz[2] - bias
                }
            }
        })
    }

    /// The exact answer [`Self::ambient_occlusion`] approximates: each direction decided on the
    /// full-resolution surface as [`Self::lit_exact`].
    pub fn ambient_occlusion_exact(&self, uvz: [f32; 3], stride: u32, bias: f32) -> f32 {
        self.occlusion_by(uvz, stride, |_, _, k| self.lit_exact(uvz, [-k[0], -k[1], k[2]], bias))
    }

    /// Cosine-weighted open share over every `stride`-th direction, `open(layer, entry, travel
    /// direction)` deciding each.
    fn occlusion_by(&self, uvz: [f32; 3], stride: u32, mut open: impl FnMut(u32, [f32; 2], [f32; 3]) -> bool) -> f32 {
        let (mut seen, mut total) = (0.0, 0.0);
        let mut layer = 0;
        while layer < self.dirs.layers() {
            let k = self.dirs.direction(layer);
            let up = [-k[0], -k[1], k[2]];
            // cos θ for the cosine lobe, sin θ for the band's solid angle.
            let w = k[2] * (k[0] * k[0] + k[1] * k[1]).sqrt();
            let (entry, _) = self.entry_toward(uvz, up);
            if open(layer, entry, k) {
                seen += w;
            }
            total += w;
            layer += stride.max(1);
        }
        if total > 0.0 { seen / total } else { 1.0 }
    }
}

/// Ground truth for evaluating tracers: a march in steps of 1/16 texel (3D length), then 12
/// halvings. Independent of the max-mip code.
pub fn fine_march(mm: &MaxMip, ray: &ReliefRay) -> f32 {
    let step = 1.0 / 16.0;
    let bottom = ray.s_bottom();
    let mut lo = 0.0;
    let mut s = step;
    while s < bottom {
        if ray.inside(mm, s) {
            let mut hi = s;
            for _ in 0..12 {
                let mid = 0.5 * (lo + hi);
                if ray.inside(mm, mid) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return hi;
        }
        lo = s;
        s += step;
    }
    bottom
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wall (columns 16..20 at height 1) on a floor at height 0, relief 8 texels deep, maps at
    /// full resolution with depths computed analytically: the floor behind the wall, seen from
    /// the light, is in shadow for exactly the wall's shadow length (8 texels × tan θ_light).
    fn wall() -> ReliefMaps {
        let n = 32u32;
        let heights: Vec<f32> = (0..n * n).map(|k| if (16..20).contains(&(k % n)) { 1.0 } else { 0.0 }).collect();
        let max_mip = MaxMip::new(n, n, heights).unwrap();
        let dirs = ReliefDirections { theta: 4, phi: 4 };
        let thickness = 8.0;
        let mut depth = Vec::new();
        for layer in 0..dirs.layers() {
            let dir = dirs.direction(layer);
            for j in 0..n {
                for i in 0..n {
                    let ray = ReliefRay { origin: [i as f32 + 0.5, j as f32 + 0.5], dir, thickness };
                    depth.push(fine_march(&max_mip, &ray) * ray.dz());
                }
            }
        }
        ReliefMaps {
            max_mip,
            depth,
            depth_size: (n, n),
            dirs,
            thickness,
            rule: DirectionRule::Nearest,
            visibility: VisibilityPath::MaxMip,
        }
    }

    /// Both visibility paths, and the exact answer they approximate.
    #[test]
    fn wall_shadow_has_its_analytic_length() {
        let mut maps = wall();
        // Light from −u (it travels toward +u): θ of row 1 = 33.75°, φ = 180°: toward the
        // light is (−sin θ, 0, cos θ). The floor (depth 1) east of the wall (u ≥ 20) is shadowed
        // up to u = 20 + 8·tan θ.
        let (theta, _) = maps.dirs.angles(maps.dirs.phi + 2); // row 1, φ = 180°
        let light = [-theta.sin(), 0.0, theta.cos()];
        let end = 20.0 + 8.0 * theta.tan();
        for path in [VisibilityPath::MaxMip, VisibilityPath::Seed { steps: 64, binary: 6 }] {
            maps.visibility = path;
            let mut reads = Reads::default();
            for k in 0..40 {
                let u = 20.05 + k as f32 * 0.25;
                let lit = maps.lit([u, 5.5, 1.0], light, 0.01, &mut reads);
                if (u - end).abs() > 0.6 {
                    assert_eq!(lit, u > end, "{path:?}: u {u}, shadow ends at {end}");
                    assert_eq!(maps.lit_exact([u, 5.5, 1.0], light, 0.01), u > end, "exact: u {u}");
                }
            }
            // West of the wall, facing the light, everything is lit; the wall top too.
            assert!(maps.lit([10.5, 5.5, 1.0], light, 0.01, &mut reads), "{path:?}");
            assert!(maps.lit([17.5, 5.5, 0.0], light, 0.01, &mut reads), "{path:?}");
        }
    }

    #[test]
    fn occlusion_is_lower_beside_the_wall_than_on_open_floor() {
        let mut maps = wall();
        for path in [VisibilityPath::MaxMip, VisibilityPath::Seed { steps: 64, binary: 6 }] {
            maps.visibility = path;
            let mut reads = Reads::default();
            let open_floor = maps.ambient_occlusion([4.5, 5.5, 1.0], 1, 0.01, &mut reads);
            let beside = maps.ambient_occlusion([20.5, 5.5, 1.0], 1, 0.01, &mut reads);
            let top = maps.ambient_occlusion([17.5, 5.5, 0.0], 1, 0.01, &mut reads);
            assert_eq!(top, 1.0, "{path:?}");
            assert!(beside < open_floor && open_floor < 1.0, "{path:?}: beside {beside} open {open_floor}");
            // Beside the wall one azimuth of four looks into it at every zenith row (and rows
            // that wrap around the 32-texel tile may meet it again): a little under ¾ open.
            assert!((0.65..=0.75).contains(&beside), "{path:?}: {beside}");
            assert_eq!(beside, maps.ambient_occlusion_exact([20.5, 5.5, 1.0], 1, 0.01), "{path:?}");
            assert_eq!(reads.depth, 3 * maps.dirs.layers());
            assert!(reads.height > 0, "{path:?}: closed-looking directions are traced");
        }
    }

    /// Every tracer on the wall map against the fine march, at a generous setting: any ray for
    /// the searches that need no depth map, and for the two that start from it, rays from texel
    /// centres along table directions (where the stored hit is exact at full resolution).
    #[test]
    fn tracers_find_the_wall() {
        let maps = wall();
        let cases = [
            (Tracer::Linear { steps: 256, binary: 8 }, false),
            (Tracer::MaxMip { start_level: 5, stop_level: 0 }, false),
            (Tracer::DepthMap { steps: 128, binary: 8 }, true),
            (Tracer::Combined { margin: 0.0, start_level: 0 }, true),
        ];
        for (tracer, on_table) in cases {
            for k in 0..64u32 {
                let ray = if on_table {
                    let origin = [(3 + k % 29) as f32 + 0.5, (k % 7) as f32 + 0.5];
                    maps.ray(origin, maps.dirs.direction(k % maps.dirs.layers()))
                } else {
                    let (phi, theta) = (k as f32 * 0.1, 0.2 + 0.02 * k as f32);
                    let dir = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
                    maps.ray([3.3 + k as f32 * 0.37, 7.9], dir)
                };
                let truth = fine_march(&maps.max_mip, &ray);
                let mut reads = Reads::default();
                let s = maps.trace(tracer, &ray, &mut reads);
                assert!((s - truth).abs() < 0.5, "{tracer:?} ray {k}: {s} vs {truth}");
                assert!(reads.total() > 0);
            }
        }
    }
}

/// What the material computes at one pixel, from [`relief_material_shade`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReliefPixel {
    /// The view ray's hit, its length in texels (`None`: viewed from below the surface).
    pub s: Option<f32>,
    /// The hit's depth (0 top, 1 bottom).
    pub depth: f32,
    /// Lit by the light.
    pub lit: bool,
    /// Ambient occlusion's open share.
    pub ao: f32,
}

/// The CPU reference of `relief_material_shade`: the material at a point of the mesh (world
/// position, interpolated normal, tangent and uv) with `maps` and the material uniform. The
/// maps' `rule` and `visibility` stand for the frame's.
pub fn relief_material_shade(
    maps: &ReliefMaps,
    tracer: Tracer,
    material: &ReliefMaterialUniform,
    world: Vec3,
    normal: Vec3,
    tangent: Vec4,
    uv: Vec2,
) -> ReliefPixel {
    let n = normal.normalize();
    let t = (tangent.truncate() - n * tangent.truncate().dot(n)).normalize();
    let b = tangent.w * n.cross(t);
    let eye = Vec4::from(material.eye);
    let d = if eye.w > 0.5 { (world - eye.truncate()).normalize() } else { eye.truncate() };
    let size = Vec2::new(maps.max_mip.width() as f32, maps.max_mip.height() as f32);
    let tile = Vec2::from(material.tile);
    let scale = Vec3::new(size.x / tile.x, size.y / tile.y, size.x / tile.x);
    let dir = (Vec3::new(d.dot(t), d.dot(b), -d.dot(n)) * scale).normalize();
    if dir.z <= 1e-4 {
        return ReliefPixel { s: None, depth: 0.0, lit: false, ao: 1.0 };
    }
    let origin = uv * size;
    let ray = maps.ray(origin.to_array(), dir.to_array());
    let mut reads = Reads::default();
    let s = maps.trace(tracer, &ray, &mut reads);
    let p = [origin.x + s * dir.x, origin.y + s * dir.y, s * ray.dz()];
    let l = Vec3::from_slice(&material.scene.light[..3]);
    let lt = (Vec3::new(l.dot(t), l.dot(b), l.dot(n)) * scale).normalize();
    let mut lit = lt.z > 0.0;
    if material.shadows == 1 && lit {
        lit = maps.lit(p, lt.to_array(), material.bias, &mut reads);
    }
    let ao = if material.ao_stride > 0 {
        maps.ambient_occlusion(p, material.ao_stride, material.bias, &mut reads)
    } else {
        1.0
    };
    ReliefPixel { s: Some(s), depth: p[2], lit, ao }
}
