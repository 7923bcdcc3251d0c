//! Horizon and distance maps (seed 000, Onoue, Max & Nishita), baked in `O(N·D)`.
//!
//! For texel `p` and azimuth `φ_k = 2πk/D` (texel space, from +u toward +v), the horizon slope
//! is `tan β = max (h(q) − h(p)) / t` over the points `q` of the ray from the texel centre
//! where it crosses a grid line of the bilinear surface, `0 < t ≤ max_distance` (world units),
//! and `d` is the `t` that attains it (DESIGN.md "Horizon and distance maps").
//!
//! Design, chosen to meet the accuracy gates on rough terrain at line-sweep speed:
//! - near field (`near`): the first `near_field` texels of every ray exactly, at every
//!   grid-line crossing, as a vectorised stencil over whole rows;
//! - far field (`sweep`): the rest from a line sweep with convex-hull stacks, each of the two
//!   lines around a texel queried by a tangent from the texel's own height; the texel's own ray
//!   is then sampled exactly around the two tangent columns (`steps`), so a far horizon is
//!   always a real sample. On axis and diagonal directions the line through a texel is its ray
//!   and the tangent is already exact.
//!
//! The near field is encoded into the output first; the sweep finishes each texel as soon as
//! both of its lines have answered and overwrites the texel when the far field is steeper. So
//! the working memory is one padded, oriented copy of the heights (`grid`) plus `O(W)` per
//! thread. (An 8-bit slope is too coarse to tell which is steeper when both round to the same
//! code; that texel's near field is then traced again.) Direction 0 is baked last, after the
//! last copy is freed, from bands of rows: its slice is not resident while a copy is.
//!
//! Edges: `Wrap` continues rays on the torus (tileable bump maps) for one map length along the
//! ray's major axis unless `max_distance` is set; `Clamp` stops rays at the map edge. A ray with
//! no sample at all (a texel on the edge looking out) stores the open-sky value:
//! slope [`OPEN_SKY_SLOPE`], distance 0 — far below any light, so the texel is lit.

mod grid;
mod hull;
mod near;
pub mod reference;
mod rg8;
mod schedule;
mod steps;
mod sweep;

use std::sync::atomic::{AtomicU64, Ordering};

use hikage_bundle::{Supercompression, TextureData, TextureDesc, TextureDimension, TextureFormat};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::heightfield::Heightfield;
use grid::{Grid, Orientation};

/// Slope stored for a ray that has no sample (clamp mode, at the edge looking out). It is the
/// most negative half float, so it survives every storage format (rg8 stores β = −90°).
pub const OPEN_SKY_SLOPE: f32 = -65504.0;

/// Version of the horizon baker; part of the input hash.
pub const ALGORITHM_VERSION: u32 = 3;

/// What happens to rays at the map edge (the bundle's [`hikage_bundle::EdgeMode`]).
pub use hikage_bundle::EdgeMode as Edge;

/// Storage of the horizon texture: channel 0 is `tan β`, channel 1 is `d`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum HorizonFormat {
    /// Half floats (default): one fetch gives both, 4 bytes per texel-direction.
    #[default]
    Rg16Float,
    /// 32-bit floats, exact.
    Rg32Float,
    /// 8-bit, the paper's memory: channel 0 is `β / π + 0.5` (β in radians, so ±90° map to
    /// 0 and 1, a step of 0.71°), channel 1 is `d / distance_scale`.
    Rg8Unorm,
}

impl HorizonFormat {
    /// The texture format.
    pub fn texture_format(self) -> TextureFormat {
        match self {
            HorizonFormat::Rg16Float => TextureFormat::Rg16Float,
            HorizonFormat::Rg32Float => TextureFormat::Rg32Float,
            HorizonFormat::Rg8Unorm => TextureFormat::Rg8Unorm,
        }
    }
}

/// Settings of a horizon bake.
#[derive(Clone, Debug, PartialEq)]
pub struct HorizonSettings {
    /// Number of azimuths `D` (1–256); direction `k` has `φ = 2πk/D`.
    pub directions: u32,
    /// Edge behaviour.
    pub edge: Edge,
    /// Largest horizon distance in world units (`None`: see [`Edge`]).
    pub max_distance: Option<f32>,
    /// Texels along each ray traced exactly before the line sweep takes over.
    pub near_field: u32,
    /// Storage format.
    pub format: HorizonFormat,
}

impl Default for HorizonSettings {
    fn default() -> Self {
        HorizonSettings {
            directions: 32,
            edge: Edge::Wrap,
            max_distance: None,
            near_field: DEFAULT_NEAR_FIELD,
            format: HorizonFormat::Rg16Float,
        }
    }
}

/// Default near field: enough for the accuracy gates on rough terrain (see the README).
pub const DEFAULT_NEAR_FIELD: u32 = 16;

impl HorizonSettings {
    /// Checks ranges; the message says what is accepted.
    pub fn check(&self) -> Result<(), String> {
        if !(1..=256).contains(&self.directions) {
            return Err(format!("directions must be 1 to 256, found {}", self.directions));
        }
        if let Some(d) = self.max_distance {
            if !(d.is_finite() && d > 0.0) {
                return Err(format!("max_distance must be finite and above 0, found {d}"));
            }
        }
        if self.near_field > 64 {
            return Err(format!("near_field must be 0 to 64 texels, found {}", self.near_field));
        }
        Ok(())
    }
}

/// A baked horizon texture with the values the runtime needs to decode it.
#[derive(Clone, Debug, PartialEq)]
pub struct HorizonTexture {
    /// The 3D texture, `W×H×D`, φ on the depth axis.
    pub texture: TextureData,
    /// For `Rg8Unorm`: distance = channel 1 × `distance_scale`; 1 for float formats.
    pub distance_scale: f32,
}

/// Bakes the horizon texture of `hf`. `progress(done, total)` is called once per direction.
pub fn bake(
    hf: &Heightfield,
    settings: &HorizonSettings,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<HorizonTexture, String> {
    settings.check()?;
    let (w, h, d) = (hf.width as usize, hf.height as usize, settings.directions as usize);
    let (sx, sy) = (hf.texel_size.0 as f64, hf.texel_size.1 as f64);
    let format = settings.format;
    let texel_bytes = format.texture_format().texel_bytes();

    // The largest distance any horizon can have, for the 8-bit distance scale.
    let diag = ((w as f64 * sx).powi(2) + (h as f64 * sy).powi(2)).sqrt();
    let distance_scale = match format {
        HorizonFormat::Rg8Unorm => settings.max_distance.map_or(diag * 2.0, |m| m as f64).max(1e-6) as f32,
        _ => 1.0,
    };

    // Zeroed pages are not resident until written, so the output grows as it is filled.
    let mut bytes = vec![0u8; w * h * d * texel_bytes];
    let done = AtomicU64::new(0);
    let pad = settings.near_field as usize + 2;
    let wrap = settings.edge == Edge::Wrap;
    let slice_len = w * h * texel_bytes;
    // Directions grouped by orientation, so each canonical grid is built once per group.
    // Direction 0 is held back: see below.
    let orientation_of = |k: usize| Orientation::for_azimuth(std::f64::consts::TAU * k as f64 / d as f64).0;
    let mut work: Vec<Vec<(usize, &mut [u8])>> = Orientation::ALL.iter().map(|_| Vec::new()).collect();
    for (k, slice) in bytes.chunks_mut(slice_len).enumerate().skip(1) {
        work[orientation_of(k).index()].push((k, slice));
    }
    let build = |g: usize| Orientation::ALL[g].grid((w, h), &hf.samples, hf.height_scale, (sx, sy), pad, wrap);
    schedule::run(work, &build, &|g, (k, slice): (usize, &mut [u8]), grid| {
        let (_, m) = Orientation::for_azimuth(std::f64::consts::TAU * k as f64 / d as f64);
        direction(grid, Orientation::ALL[g], (w, h), m, settings, format, distance_scale, slice);
        progress(done.fetch_add(1, Ordering::Relaxed) + 1, d as u64);
    });
    // Direction 0 (φ = 0) comes last, after the last whole-map copy is gone: its rays are the
    // map's rows, so a band of rows is a map of its own and needs only a band-sized copy. Its
    // slice is untouched, hence not resident, while a whole-map copy is alive, so the bake's
    // peak stays near the output plus the input.
    let (orientation, m) = Orientation::for_azimuth(0.0);
    let band = ROW_BAND.min(h);
    bytes[..slice_len].par_chunks_mut(band * w * texel_bytes).enumerate().for_each(|(b, out)| {
        let rows = out.len() / (w * texel_bytes);
        let samples = &hf.samples[b * band * w..(b * band + rows) * w];
        let grid = orientation.grid((w, rows), samples, hf.height_scale, (sx, sy), pad, wrap);
        direction(&grid, orientation, (w, rows), m, settings, format, distance_scale, out);
    });
    progress(done.fetch_add(1, Ordering::Relaxed) + 1, d as u64);
    let desc = TextureDesc {
        format: format.texture_format(),
        dimension: TextureDimension::D3,
        width: hf.width,
        height: hf.height,
        depth: settings.directions,
        layers: 1,
        levels: 1,
        supercompression: Supercompression::None,
        channels: vec!["slope".into(), "distance".into()],
    };
    Ok(HorizonTexture { texture: TextureData { desc, levels: vec![bytes] }, distance_scale })
}

/// One direction, encoded into `out` (the direction's slice, original layout): first the near
/// field per row, then the far field, which replaces a texel's value when it is steeper.
#[allow(clippy::too_many_arguments)]
fn direction(
    g: &Grid,
    orientation: Orientation,
    (width, height): (usize, usize),
    m: f64,
    settings: &HorizonSettings,
    format: HorizonFormat,
    distance_scale: f32,
    out: &mut [u8],
) {
    let step_len = (g.sx * g.sx + (m * g.sy).powi(2)).sqrt();
    // Reach in columns (real for traces, whole columns for the sweep). Rays on a torus are
    // followed for at most 4 map lengths along their major axis.
    let cap = 4.0 * g.w as f64;
    let reach = match (settings.max_distance, settings.edge) {
        (Some(md), Edge::Wrap) => Some((md as f64 / step_len).min(cap)),
        (Some(md), Edge::Clamp) => Some((md as f64 / step_len).min(g.w as f64)),
        (None, Edge::Wrap) => Some(g.w as f64),
        (None, Edge::Clamp) => None,
    };
    let near_cols = settings.near_field as usize;
    let near_reach = reach.map_or(near_cols as f64, |r| r.min(near_cols as f64));
    let taps = near::stencil(m, step_len, near_reach);
    let wrap = settings.edge == Edge::Wrap;
    let cols = g.w + reach.map_or(0, |r| r.ceil() as usize) + 1;
    let steps = steps::Steps::new(m, step_len, cols, g.stride);
    let near_f = near_cols as f64;
    let end = reach.unwrap_or(f64::INFINITY);
    let texel_bytes = format.texture_format().texel_bytes();
    let at = |col: usize, row: usize| orientation.original(width, height, col, row) * texel_bytes;

    // A clamped ray leaving through a row edge within EXIT_TRACE columns is traced exactly: the
    // lines around such a texel leave the map at other columns than its ray.
    let exit = |row: usize| match (wrap, m) {
        (false, m) if m > 0.0 => (g.h - 1 - row) as f64 / m,
        (false, m) if m < 0.0 => row as f64 / -m,
        _ => f64::INFINITY,
    };
    let traced = |exit: f64, col: usize| exit <= EXIT_TRACE && exit < (g.w - 1 - col) as f64;
    let steeper = |best: &mut (f32, f32), c: Option<(f32, f32)>| {
        if let Some((s, t)) = c {
            if s > best.0 {
                *best = (s, t);
            }
        }
    };

    // Near field, and the exact traces that stand in for the far field.
    let mut best_s = vec![0.0f32; g.w];
    let mut best_t = vec![0.0f32; g.w];
    // A transposed orientation's rows are columns of the output: they are encoded into a tile of
    // TILE rows first and written out a column run at a time, not a texel per cache line.
    let mut tile = vec![0u8; if orientation.transpose { TILE * g.w * texel_bytes } else { 0 }];
    let mut halves = Vec::new();
    for row in 0..g.h {
        near::row(g, &taps, row, &mut best_s, &mut best_t);
        let exit = exit(row);
        if end > near_f {
            for col in 0..g.w {
                let mut best = (best_s[col], best_t[col]);
                let trace = |lo: f64, hi: f64| steps.trace(g, wrap, row, col, lo, hi);
                if traced(exit, col) {
                    steeper(&mut best, trace(near_f, end.min(exit)));
                } else if end.is_finite() && end.fract() > 0.0 {
                    // Row crossings past the last whole column of a fractional reach.
                    steeper(&mut best, trace(end.floor().max(near_f), end));
                } else {
                    continue;
                }
                (best_s[col], best_t[col]) = best;
            }
        }
        // The row's texels are consecutive in the tile, or in the output (right to left when the
        // orientation mirrors columns).
        let row_bytes = g.w * texel_bytes;
        let reversed = tile.is_empty() && orientation.flip;
        let dst = if tile.is_empty() {
            let o = at(0, row).min(at(g.w - 1, row));
            &mut out[o..o + row_bytes]
        } else {
            &mut tile[(row % TILE) * row_bytes..][..row_bytes]
        };
        encode_row(format, &mut best_s, &mut best_t, distance_scale, dst, reversed, &mut halves);
        if !tile.is_empty() && (row % TILE == TILE - 1 || row + 1 == g.h) {
            let first = row - row % TILE;
            // (col, first + k) is `k` texels after (col, first) in the output.
            let untile = match format {
                HorizonFormat::Rg8Unorm => untile::<2>,
                HorizonFormat::Rg16Float => untile::<4>,
                HorizonFormat::Rg32Float => untile::<8>,
            };
            untile(&tile, g.w, row + 1 - first, out, &|col| at(col, first));
        }
    }
    if end <= near_f {
        return;
    }

    // Far field: around each line's tangent column, the texel's own ray, exactly.
    let line = sweep::Line { steps: &steps, near: near_cols, reach: reach.map(|r| (r + 1e-9).floor() as usize), wrap };
    // Axis and diagonal directions: every crossing of a ray is a column crossing and the line
    // through a texel is its ray, so the hull's tangent is already the exact answer.
    let exact_lines = m == 0.0 || m.abs() == 1.0;
    let end_cols = if end.is_finite() { end.floor() as usize } else { usize::MAX };
    // The texels a line will finish a few columns on are fetched early: along a line they are
    // a row apart in the output, which a power-of-two width maps to few cache sets.
    let out_addr = out.as_ptr() as usize;
    let fetch_texel = |row: usize, col: usize| prefetch(out_addr + at(col, row));
    let mut finish = |row: usize, col: usize, hits: [Option<sweep::Hit>; 2]| {
        if traced(exit(row), col) {
            return;
        }
        let mut best = (f32::NEG_INFINITY, 0.0);
        if exact_lines {
            if let [Some(hit), None] = hits {
                steeper(&mut best, steps.slope((hit.rise, hit.run)));
            }
        } else {
            let run = |h: Option<sweep::Hit>| h.map_or(0, |h| h.run as u32);
            let (lo, hi) = match (run(hits[0]), run(hits[1])) {
                (0, 0) => return,
                (0, c) | (c, 0) => (c, c),
                (a, b) => (a.min(b), a.max(b)),
            };
            // Columns (c - 2, c + 1] around each candidate c, within (near field, reach].
            let window = |lo: u32, hi: u32| {
                let lo = (lo as usize).saturating_sub(2).max(near_cols);
                let hi = (hi as usize + 1).min(end_cols);
                steps.window(g, wrap, row, col, lo, hi)
            };
            if hi - lo <= 3 {
                steeper(&mut best, window(lo, hi));
            } else {
                for c in [lo, hi] {
                    steeper(&mut best, window(c, c));
                }
            }
        }
        let o = at(col, row);
        let texel = &mut out[o..o + texel_bytes];
        // Rounding is monotonic, so comparing with the near-field slope as stored in half (or
        // full) precision picks the same slope as comparing before rounding.
        let replace = match format {
            HorizonFormat::Rg16Float => best.0 > half::f16::from_le_bytes([texel[0], texel[1]]).to_f32(),
            HorizonFormat::Rg32Float => best.0 > f32::from_le_bytes([texel[0], texel[1], texel[2], texel[3]]),
            // An 8-bit slope cannot tell a tie: then the near pass is traced again for this texel.
            HorizonFormat::Rg8Unorm => match rg8::compare(best.0, texel[0]) {
                std::cmp::Ordering::Greater => true,
                std::cmp::Ordering::Less => false,
                // The same slope byte and the same distance byte: either way, the same texel.
                std::cmp::Ordering::Equal if rg8::unorm(best.1 / distance_scale) == texel[1] => false,
                std::cmp::Ordering::Equal => {
                    let trace = |lo: f64, hi: f64| steps.trace(g, wrap, row, col, lo, hi);
                    let mut near = trace(0.0, near_reach).unwrap_or((f32::NEG_INFINITY, 0.0));
                    if end.is_finite() && end.fract() > 0.0 {
                        steeper(&mut near, trace(end.floor().max(near_f), end));
                    }
                    best.0 > near.0
                }
            },
        };
        if replace {
            encode(format, best.0, best.1, distance_scale, texel);
        }
    };
    sweep::far_field(g, &line, &mut finish, &fetch_texel);
}

/// Writes the first `rows` rows of a transposed orientation's `tile` (rows of `w` texels of `B`
/// bytes) to `out`, where texel `k` of column `col` goes `k` texels after `start(col)`. The texel
/// size is a constant so that each texel is a move, not a call to `memmove`.
fn untile<const B: usize>(tile: &[u8], w: usize, rows: usize, out: &mut [u8], start: &dyn Fn(usize) -> usize) {
    for col in 0..w {
        let o = start(col);
        for (k, texel) in out[o..o + rows * B].chunks_exact_mut(B).enumerate() {
            let from = (k * w + col) * B;
            texel.copy_from_slice(&tile[from..from + B]);
        }
    }
}

/// Asks the processor to bring the cache line at `addr` closer; no effect on results.
#[inline(always)]
fn prefetch(addr: usize) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch never faults and has no effect on memory, whatever the address.
    unsafe {
        std::arch::x86_64::_mm_prefetch(addr as *const i8, std::arch::x86_64::_MM_HINT_T0)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = addr;
}

/// Rows of a transposed orientation encoded before they are written out together.
const TILE: usize = 16;

/// Rows per band of direction 0, baked band by band from the input.
const ROW_BAND: usize = 64;

/// Columns within which a ray leaving a clamped map through a row edge is traced exactly: there
/// the lines around the texel leave the map at other columns than its ray (up to `1/|m|`
/// columns apart), so their tangent columns are poor candidates.
const EXIT_TRACE: f64 = 64.0;

/// Writes a row of texels (`tan β`, `d`) in `format` into `out` (exactly `s.len()` texels), in
/// reverse order when `reversed`. A slope of `-∞` (no sample) becomes the open-sky value. Half
/// floats are converted a row at a time (F16C where the processor has it); `halves` is scratch.
fn encode_row(
    format: HorizonFormat,
    s: &mut [f32],
    t: &mut [f32],
    distance_scale: f32,
    out: &mut [u8],
    reversed: bool,
    halves: &mut Vec<half::f16>,
) {
    for (s, t) in s.iter_mut().zip(t.iter_mut()) {
        if *s < -1.0e20 {
            (*s, *t) = (OPEN_SKY_SLOPE, 0.0);
        }
    }
    let (tb, n) = (format.texture_format().texel_bytes(), s.len());
    if format != HorizonFormat::Rg16Float {
        for (i, (&s, &t)) in s.iter().zip(t.iter()).enumerate() {
            let j = if reversed { n - 1 - i } else { i };
            encode(format, s, t, distance_scale, &mut out[j * tb..(j + 1) * tb]);
        }
        return;
    }
    use half::slice::HalfFloatSliceExt;
    s.iter_mut().zip(t.iter_mut()).for_each(|(s, t)| (*s, *t) = f16_range(*s, *t));
    halves.resize(2 * n, half::f16::ZERO);
    let (hs, ht) = halves.split_at_mut(n);
    hs.convert_from_f32_slice(s);
    ht.convert_from_f32_slice(t);
    let texels = out.chunks_exact_mut(4);
    let write = |(o, (&s, &t)): (&mut [u8], (&half::f16, &half::f16))| put_f16(o, s, t);
    if reversed {
        texels.rev().zip(hs.iter().zip(ht.iter())).for_each(write);
    } else {
        texels.zip(hs.iter().zip(ht.iter())).for_each(write);
    }
}

/// Writes one texel (`tan β`, `d`) in `format` into `out` (exactly one texel long).
fn encode(format: HorizonFormat, slope: f32, dist: f32, distance_scale: f32, out: &mut [u8]) {
    match format {
        HorizonFormat::Rg8Unorm => {
            out[0] = rg8::code(slope);
            out[1] = rg8::unorm(dist / distance_scale);
        }
        HorizonFormat::Rg16Float => {
            let (s, d) = f16_range(slope, dist);
            put_f16(out, half::f16::from_f32(s), half::f16::from_f32(d));
        }
        HorizonFormat::Rg32Float => {
            out[..4].copy_from_slice(&slope.to_le_bytes());
            out[4..8].copy_from_slice(&dist.to_le_bytes());
        }
    }
}

/// A texel clamped to what an rg16f texel holds: slopes within ±`-OPEN_SKY_SLOPE`, distances
/// at most `-OPEN_SKY_SLOPE` (f16 would round larger values to infinity).
#[inline(always)]
fn f16_range(slope: f32, dist: f32) -> (f32, f32) {
    (slope.clamp(OPEN_SKY_SLOPE, -OPEN_SKY_SLOPE), dist.min(-OPEN_SKY_SLOPE))
}

/// Writes an rg16f texel into `out` (exactly one texel long).
#[inline(always)]
fn put_f16(out: &mut [u8], slope: half::f16, dist: half::f16) {
    out[..2].copy_from_slice(&slope.to_le_bytes());
    out[2..4].copy_from_slice(&dist.to_le_bytes());
}

/// Decodes texel `(k, row, col)` of a horizon texture to `(tan β, d)`.
pub fn decode(texture: &HorizonTexture, k: usize, row: usize, col: usize) -> (f32, f32) {
    let desc = &texture.texture.desc;
    let tb = desc.format.texel_bytes();
    let i = ((k * desc.height as usize + row) * desc.width as usize + col) * tb;
    let bytes = &texture.texture.levels[0][i..i + tb];
    let (a, b) = (desc.format.decode_channel(bytes, 0), desc.format.decode_channel(bytes, 1));
    hikage_bundle::manifest::decode_horizon_texel(desc.format, a, b, texture.distance_scale, OPEN_SKY_SLOPE)
}

/// Ambient occlusion from horizons: per texel, the occluded share of the cosine-weighted
/// hemisphere, `mean over directions of sin² β⁺` (β⁺ = max(β, 0)). A one-level R16Float 2D
/// texture, channel `occlusion` (0 open, 1 fully occluded).
pub fn ambient_occlusion(texture: &HorizonTexture) -> TextureData {
    let desc = &texture.texture.desc;
    let (w, h, d) = (desc.width as usize, desc.height as usize, desc.depth as usize);
    let mut occlusion = vec![0.0f32; w * h];
    for k in 0..d {
        for row in 0..h {
            for col in 0..w {
                let (s, _) = decode(texture, k, row, col);
                if s > 0.0 {
                    occlusion[row * w + col] += s * s / (1.0 + s * s);
                }
            }
        }
    }
    occlusion.iter_mut().for_each(|o| *o /= d as f32);
    let ao_desc = TextureDesc {
        format: TextureFormat::R16Float,
        dimension: TextureDimension::D2,
        width: desc.width,
        height: desc.height,
        depth: 1,
        layers: 1,
        levels: 1,
        supercompression: Supercompression::None,
        channels: vec!["occlusion".into()],
    };
    TextureData::from_f32(ao_desc, &occlusion).expect("sizes match by construction")
}
