//! Relief-mapping depth maps (seed 003, Suzuki): for every hemisphere direction and every texel
//! of the top plane, the normalised depth of the first hit of the ray entering there, MIN-
//! downscaled (eq. 2) so a coarse map never lies deeper than a hit.
//!
//! Geometry (directions, the box surface, the max-mip pyramid) is
//! [`hikage_bundle::relief`], shared with the runtime so both trace the same surface. Each bake
//! ray is traced through the max-mip pyramid, `O(log N)` reads per ray rather than a march over
//! every texel it crosses; the pyramid is written as its own asset for the runtime.
//!
//! The surface is traced on the heights as stored in the max-mip asset (half floats), so the
//! maps describe exactly the surface a shader reads.

use std::sync::atomic::{AtomicU64, Ordering};

use hikage_bundle::relief::{MaxMip, ReliefDirections, ReliefRay, first_hit_maxmip};
use hikage_bundle::{Supercompression, TextureData, TextureDesc, TextureDimension, TextureFormat};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::heightfield::Heightfield;

/// Version of the relief baker; part of the input hash.
pub const ALGORITHM_VERSION: u32 = 2;

/// Largest count of zenith rows or azimuths accepted.
pub const MAX_ANGLE_COUNT: u32 = 128;
/// Largest number of directions (texture array layers; wgpu guarantees 256 by default,
/// desktop devices 2048).
pub const MAX_DIRECTIONS: u32 = 2048;

/// Default width of the stored maps (the paper's 32², 192 KB).
pub const DEFAULT_SIZE: u32 = 32;

/// Storage of the depth maps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum ReliefFormat {
    /// 8-bit depth, rounded down (the paper's memory).
    #[default]
    #[cfg_attr(feature = "clap", value(name = "r8"))]
    R8Unorm,
    /// Half-float depth, rounded down.
    #[cfg_attr(feature = "clap", value(name = "r16f"))]
    R16Float,
    /// BC4 blocks (0.5× r8): the 8-bit depths rounded down, block-encoded never deeper than
    /// them, so the maps keep their promise of never reporting a hit past the first.
    #[cfg_attr(feature = "clap", value(name = "bc4"))]
    Bc4RUnorm,
}

impl ReliefFormat {
    /// The texture format.
    pub fn texture_format(self) -> TextureFormat {
        match self {
            ReliefFormat::R8Unorm => TextureFormat::R8Unorm,
            ReliefFormat::R16Float => TextureFormat::R16Float,
            ReliefFormat::Bc4RUnorm => TextureFormat::Bc4RUnorm,
        }
    }

    /// The largest stored value not above `depth` (a stored depth must never overshoot a hit).
    pub fn round_down(self, depth: f32) -> f32 {
        match self {
            ReliefFormat::R8Unorm | ReliefFormat::Bc4RUnorm => (depth * 255.0).floor().clamp(0.0, 255.0) / 255.0,
            ReliefFormat::R16Float => f16_round_down(depth),
        }
    }
}

/// The largest half float not above `x` (for `x` in `[0, 1]`), as f32.
pub fn f16_round_down(x: f32) -> f32 {
    let h = half::f16::from_f32(x);
    if h.to_f32() > x {
        let below = half::f16::from_bits(h.to_bits() - 1);
        if h.to_bits() & 0x7fff == 0 { 0.0 } else { below.to_f32() }
    } else {
        h.to_f32()
    }
}

/// Parameters of a relief bake.
#[derive(Clone, Debug, PartialEq)]
pub struct ReliefParams {
    /// Rows of zenith angle (1–128).
    pub theta: u32,
    /// Azimuths per row (1–128); `theta × phi` at most [`MAX_DIRECTIONS`].
    pub phi: u32,
    /// Width of the stored maps (a power of two, at most the map width); `None` is the paper's
    /// 32, or the map width when that is smaller. The height follows the map's aspect.
    pub size: Option<u32>,
    /// Relief thickness as a share of the map width.
    pub depth_scale: f32,
    /// Storage.
    pub format: ReliefFormat,
}

impl Default for ReliefParams {
    fn default() -> Self {
        ReliefParams { theta: 32, phi: 16, size: None, depth_scale: 0.1, format: ReliefFormat::R8Unorm }
    }
}

impl ReliefParams {
    /// Checks the settings on their own (no map needed).
    pub fn check(&self) -> Result<(), String> {
        for (name, n) in [("theta", self.theta), ("phi", self.phi)] {
            if n == 0 || n > MAX_ANGLE_COUNT {
                return Err(format!("{name} must be 1–{MAX_ANGLE_COUNT}, found {n}"));
            }
        }
        if self.theta * self.phi > MAX_DIRECTIONS {
            return Err(format!(
                "theta × phi must be at most {MAX_DIRECTIONS} directions (texture array layers), found {}",
                self.theta * self.phi
            ));
        }
        if !(self.depth_scale.is_finite() && self.depth_scale > 0.0 && self.depth_scale <= 16.0) {
            return Err(format!("depth_scale must be finite, above 0 and at most 16, found {}", self.depth_scale));
        }
        if let Some(s) = self.size
            && !s.is_power_of_two()
        {
            return Err(format!("size must be a power of two, found {s}"));
        }
        Ok(())
    }

    /// Checks the settings against a `width × height` map: sides powers of two, size within.
    pub fn check_for(&self, width: u32, height: u32) -> Result<(), String> {
        self.check()?;
        if !width.is_power_of_two() || !height.is_power_of_two() {
            return Err(format!(
                "relief maps tile, so the heightfield needs power-of-two sides, found {width}×{height}"
            ));
        }
        if let Some(s) = self.size
            && (s > width || height * s / width == 0)
        {
            return Err(format!(
                "size {s} must be at most the map width {width} and leave at least one row of {height}"
            ));
        }
        Ok(())
    }

    /// Width of the stored maps for a map `width` texels wide.
    pub fn output_width(&self, width: u32) -> u32 {
        self.size.unwrap_or(DEFAULT_SIZE.min(width))
    }

    /// The direction table.
    pub fn directions(&self) -> ReliefDirections {
        ReliefDirections { theta: self.theta, phi: self.phi }
    }
}

/// The result of a relief bake.
#[derive(Clone, Debug, PartialEq)]
pub struct BakedRelief {
    /// Depth maps: one layer per direction, `size × size·H/W`.
    pub depth: TextureData,
    /// The max-mip pyramid of the heights (R16Float, full mip chain).
    pub max_mip: TextureData,
    /// Thickness of the relief in texels of the source map.
    pub thickness: f32,
}

/// A relief height must lie in `[0, 1]` (depth = 1 − height).
pub fn check_height(v: f32) -> Result<(), String> {
    if (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        Err(format!("relief heights must lie in [0, 1] (depth = 1 − height); the sample is {v}"))
    }
}

/// Heights as the max-mip asset stores them (half floats), checked to lie in `[0, 1]`.
pub fn stored_heights(hf: &Heightfield) -> Result<Vec<f32>, String> {
    if let Some((i, m)) = hf.samples.iter().enumerate().find_map(|(i, &v)| check_height(v).err().map(|m| (i, m))) {
        return Err(format!("sample ({}, {}): {m}", i % hf.width as usize, i / hf.width as usize));
    }
    Ok(hf.samples.iter().map(|&v| half::f16::from_f32(v).to_f32()).collect())
}

/// Level a bake ray's traversal starts at: rays start on the top plane, where the coarse
/// blocks of any map with a peak near 1 are entered at once, so starting higher only adds reads;
/// the traversal climbs when the ray crosses empty space.
const BAKE_START_LEVEL: u32 = 3;

/// Squares of entry points at least this wide get their own floor ([`block_floor`]) before
/// their rays are traced; smaller ones are traced ray by ray.
const FLOOR_MIN_SIDE: u32 = 4;

/// First-hit depths of one direction, MIN-downscaled by `factor` (1 keeps every texel),
/// row-major. Only a hit shallower than a block's current minimum can change it, so each ray is
/// traced no deeper than that; and no ray starts above the depth its square of neighbours can
/// first meet the relief ([`block_floor`]). The result is that of tracing every ray from the
/// top plane to its hit, at a fraction of the reads.
pub fn trace_layer(mm: &MaxMip, dir: [f32; 3], thickness: f32, factor: u32) -> Vec<f32> {
    let (w, h) = (mm.width(), mm.height());
    let (ow, oh) = (w / factor, h / factor);
    let mut out = Vec::with_capacity(ow as usize * oh as usize);
    for bj in 0..oh {
        for bi in 0..ow {
            let mut block_min = 1.0f32;
            trace_square(
                mm,
                &Square { dir, thickness, corner: (bi * factor, bj * factor), side: factor },
                0.0,
                &mut block_min,
            );
            out.push(block_min);
        }
    }
    out
}

/// The rays entering at the texel centres of a square of the top plane.
#[derive(Clone, Copy)]
struct Square {
    dir: [f32; 3],
    thickness: f32,
    /// Texel of the square's first corner.
    corner: (u32, u32),
    /// Side, texels.
    side: u32,
}

/// Lowers `block_min` to the shallowest hit of the square's rays when it is shallower; none of
/// them hits above `floor`. Wide squares find their own floor, then split in four by four.
fn trace_square(mm: &MaxMip, sq: &Square, floor: f32, block_min: &mut f32) {
    if floor >= *block_min {
        return;
    }
    let (i0, j0) = sq.corner;
    if sq.side >= FLOOR_MIN_SIDE {
        let corner = [i0 as f32 + 0.5, j0 as f32 + 0.5];
        let floor = block_floor(mm, sq.dir, sq.thickness, corner, (sq.side - 1) as f32, floor);
        let sub = sq.side / 4;
        for j in (j0..j0 + sq.side).step_by(sub as usize) {
            for i in (i0..i0 + sq.side).step_by(sub as usize) {
                trace_square(mm, &Square { corner: (i, j), side: sub, ..*sq }, floor, block_min);
            }
        }
        return;
    }
    let start = BAKE_START_LEVEL.min(mm.levels() - 1);
    let dz = sq.dir[2] / sq.thickness;
    for j in j0..j0 + sq.side {
        for i in i0..i0 + sq.side {
            if floor >= *block_min {
                return;
            }
            let ray = ReliefRay { origin: [i as f32 + 0.5, j as f32 + 0.5], dir: sq.dir, thickness: sq.thickness };
            let stop = *block_min / dz;
            let mut reads = 0;
            let s = first_hit_maxmip(mm, &ray, (floor / dz, stop), (start, 0), &mut reads);
            if s < stop {
                *block_min = block_min.min(s * dz);
            }
        }
    }
}

/// A depth no ray of a block can hit above: the rays enter the top plane at the points of the
/// square `[corner, corner + side]²` and travel along `dir`, and none hits above depth `from`;
/// the square is swept down from there in steps
/// of one max-mip block of the block's own size, and the first step whose swept area holds a
/// height reaching the step's depth bounds the block's shallowest hit from above the true one.
pub fn block_floor(mm: &MaxMip, dir: [f32; 3], thickness: f32, corner: [f32; 2], side: f32, from: f32) -> f32 {
    let level = (side + 1.0).log2().floor().clamp(0.0, (mm.levels() - 1) as f32) as u32;
    let size = (1u32 << level) as f32;
    let horizontal = (dir[0] * dir[0] + dir[1] * dir[1]).sqrt();
    // Horizontal texels travelled per unit of depth, and the depth of one step.
    let run = horizontal * thickness / dir[2];
    let step = if run * size > 0.0 { size / run } else { 1.0 };
    let (ux, uy) = if horizontal > 0.0 { (dir[0] / horizontal, dir[1] / horizontal) } else { (0.0, 0.0) };
    let mut z0 = from;
    while z0 < 1.0 {
        let z1 = (z0 + step).min(1.0);
        // The square swept from depth z0 to z1, in blocks of `level`.
        let (ax, bx) = (corner[0] + z0 * run * ux, corner[0] + z1 * run * ux);
        let (ay, by) = (corner[1] + z0 * run * uy, corner[1] + z1 * run * uy);
        let (x0, x1) = ((ax.min(bx) / size).floor() as i64, ((ax.max(bx) + side) / size).floor() as i64);
        let (y0, y1) = ((ay.min(by) / size).floor() as i64, ((ay.max(by) + side) / size).floor() as i64);
        let mut top = 0.0f32;
        for y in y0..=y1 {
            for x in x0..=x1 {
                top = top.max(mm.max_height(level, x, y));
            }
        }
        if 1.0 - top <= z1 {
            return z0.max(1.0 - top);
        }
        z0 = z1;
    }
    1.0
}

/// MIN-downscales a row-major `w × h` map by `factor` in both directions (eq. 2 applied
/// `log2 factor` times).
pub fn min_downscale(values: &[f32], w: u32, h: u32, factor: u32) -> Vec<f32> {
    let (ow, oh) = ((w / factor) as usize, (h / factor) as usize);
    let f = factor as usize;
    let mut out = vec![f32::INFINITY; ow * oh];
    for (j, row) in values.chunks_exact(w as usize).enumerate() {
        let orow = &mut out[(j / f) * ow..(j / f + 1) * ow];
        for (i, &v) in row.iter().enumerate() {
            let o = &mut orow[i / f];
            *o = o.min(v);
        }
    }
    out
}

/// Bakes the depth maps and the max-mip pyramid. `progress` gets (layers done, layers).
pub fn bake(hf: &Heightfield, s: &ReliefParams, progress: &(dyn Fn(u64, u64) + Sync)) -> Result<BakedRelief, String> {
    s.check_for(hf.width, hf.height)?;
    let heights = stored_heights(hf)?;
    let mm = MaxMip::new(hf.width, hf.height, heights)?;
    let dirs = s.directions();
    let thickness = s.depth_scale * hf.width as f32;
    let out_w = s.output_width(hf.width);
    let factor = hf.width / out_w;
    let out_h = hf.height / factor;
    let layers = dirs.layers();
    let done = AtomicU64::new(0);
    progress(0, layers as u64);
    let maps: Vec<Vec<f32>> = (0..layers)
        .into_par_iter()
        .map(|layer| {
            let small = trace_layer(&mm, dirs.direction(layer), thickness, factor);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, layers as u64);
            small.into_iter().map(|d| s.format.round_down(d)).collect()
        })
        .collect();
    let values: Vec<f32> = maps.concat();
    let depth = TextureData::from_f32(
        TextureDesc {
            format: s.format.texture_format().decoded(),
            dimension: TextureDimension::D2Array,
            width: out_w,
            height: out_h,
            depth: 1,
            layers,
            levels: 1,
            supercompression: Supercompression::None,
            channels: vec!["depth".into()],
        },
        &values,
    )
    .map_err(|e| e.to_string())?;
    let depth = match s.format {
        ReliefFormat::Bc4RUnorm => crate::bc4::compress(&depth, &[crate::bc4::Side::Below]),
        _ => depth,
    };
    Ok(BakedRelief { depth, max_mip: max_mip_texture(&mm), thickness })
}

/// The pyramid as an R16Float texture with one mip level per pyramid level.
pub fn max_mip_texture(mm: &MaxMip) -> TextureData {
    let levels: Vec<Vec<u8>> = (0..mm.levels())
        .map(|l| mm.level(l).iter().flat_map(|&v| half::f16::from_f32(v).to_le_bytes()).collect())
        .collect();
    TextureData {
        desc: TextureDesc {
            format: TextureFormat::R16Float,
            dimension: TextureDimension::D2,
            width: mm.width(),
            height: mm.height(),
            depth: 1,
            layers: 1,
            levels: mm.levels(),
            supercompression: Supercompression::None,
            channels: vec!["height".into()],
        },
        levels,
    }
}
