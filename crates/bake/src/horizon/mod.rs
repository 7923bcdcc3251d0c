//! Horizon and distance maps (seed 000, Onoue, Max & Nishita), baked in `O(N·D)`.
//!
//! For texel `p` and azimuth `φ_k = 2πk/D` (texel space, from +u toward +v), the horizon slope
//! is `tan β = max (h(q) − h(p)) / t` over the points `q` of the ray from the texel centre
//! where it crosses a grid line of the bilinear surface, `0 < t ≤ max_distance` (world units),
//! and `d` is the `t` that attains it (DESIGN.md "Horizon and distance maps").
//!
//! Design, chosen to meet the accuracy gates on rough terrain at line-sweep speed:
//! - near field ([`near`]): the first `near_field` texels of every ray exactly, at every
//!   grid-line crossing, as a vectorised stencil over whole rows;
//! - far field ([`sweep`]): the rest from a line sweep with convex-hull stacks, queried by a
//!   tangent from the texel's own height, lerped between the two lines around the texel.
//!
//! Edges: `Wrap` continues rays on the torus (tileable bump maps) for one map length along the
//! ray's major axis unless `max_distance` is set; `Clamp` stops rays at the map edge. A ray with
//! no sample at all (a texel on the edge looking out) stores the open-sky value:
//! slope [`OPEN_SKY_SLOPE`], distance 0 — far below any light, so the texel is lit.

mod grid;
mod hull;
mod near;
pub mod reference;
mod steps;
mod sweep;

use std::sync::atomic::{AtomicU64, Ordering};

use hikage_bundle::{Supercompression, TextureData, TextureDesc, TextureDimension, TextureFormat};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::heightfield::Heightfield;
use grid::{Grid, Orientation};
use near::Padded;

/// Slope stored for a ray that has no sample (clamp mode, at the edge looking out). It is the
/// most negative half float, so it survives every storage format (rg8 stores β = −90°).
pub const OPEN_SKY_SLOPE: f32 = -65504.0;

/// Version of the horizon baker; part of the input hash.
pub const ALGORITHM_VERSION: u32 = 1;

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
    let world: Vec<f32> = hf.samples.iter().map(|s| s * hf.height_scale).collect();
    let (sx, sy) = (hf.texel_size.0 as f64, hf.texel_size.1 as f64);
    let format = settings.format;
    let texel_bytes = format.texture_format().texel_bytes();

    // The largest distance any horizon can have, for the 8-bit distance scale.
    let diag = ((w as f64 * sx).powi(2) + (h as f64 * sy).powi(2)).sqrt();
    let distance_scale = match format {
        HorizonFormat::Rg8Unorm => settings.max_distance.map_or(diag * 2.0, |m| m as f64).max(1e-6) as f32,
        _ => 1.0,
    };

    let mut bytes = vec![0u8; w * h * d * texel_bytes];
    let done = AtomicU64::new(0);
    // Directions grouped by orientation, so each canonical grid is built once per group.
    for orientation in Orientation::ALL {
        let dirs: Vec<usize> = (0..d)
            .filter(|&k| Orientation::for_azimuth(std::f64::consts::TAU * k as f64 / d as f64).0 == orientation)
            .collect();
        if dirs.is_empty() {
            continue;
        }
        let grid = orientation.grid(w, h, &world, sx, sy);
        let pad = settings.near_field as usize + 2;
        let padded = Padded::new(&grid, pad, settings.edge == Edge::Wrap);
        let slices: Vec<(usize, &mut [u8])> =
            bytes.chunks_mut(w * h * texel_bytes).enumerate().filter(|(k, _)| dirs.contains(k)).collect();
        slices.into_par_iter().for_each(|(k, slice)| {
            let phi = std::f64::consts::TAU * k as f64 / d as f64;
            let (_, m) = Orientation::for_azimuth(phi);
            direction(&grid, &padded, orientation, (w, h), m, settings, format, distance_scale, slice);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, d as u64);
        });
    }
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

/// One direction: near field per row, far field by sweep, combined and encoded into `out`
/// (the direction's slice, original layout).
#[allow(clippy::too_many_arguments)]
fn direction(
    g: &Grid,
    padded: &Padded,
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
    // followed for at most 4 map lengths.
    let cap = 4.0 * (g.w + g.h) as f64;
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
    let steps = steps::Steps::new(m, step_len, cols);
    let line = sweep::Line { steps: &steps, near: near_cols, reach: reach.map(|r| (r + 1e-9).floor() as usize), wrap };
    let far = sweep::far_field(g, &line);
    let near_f = near_cols as f64;
    let end = reach.unwrap_or(f64::INFINITY);

    let texel_bytes = format.texture_format().texel_bytes();
    let mut best_s = vec![0.0f32; g.w];
    let mut best_t = vec![0.0f32; g.w];
    for row in 0..g.h {
        near::row(g, padded, &taps, row, &mut best_s, &mut best_t);
        // A clamped ray leaving through a row edge within EXIT_TRACE columns is traced exactly.
        let exit = match (wrap, m) {
            (false, m) if m > 0.0 => (g.h - 1 - row) as f64 / m,
            (false, m) if m < 0.0 => row as f64 / -m,
            _ => f64::INFINITY,
        };
        for col in 0..g.w {
            let idx = row * g.w + col;
            let mut best = (best_s[col], best_t[col]);
            let mut take = |c: Option<(f32, f32)>| {
                if let Some((s, t)) = c {
                    if s > best.0 {
                        best = (s, t);
                    }
                }
            };
            if end > near_f {
                let trace = |lo: f64, hi: f64| steps.trace(g, wrap, row, col, lo, hi);
                if exit <= EXIT_TRACE && exit < (g.w - 1 - col) as f64 {
                    take(trace(near_f, end.min(exit)));
                } else {
                    // Around each line's tangent column, the texel's own ray, exactly.
                    let [a, b] = far.candidates[idx];
                    let (lo, hi) = match (a, b) {
                        (0, 0) => (0, 0),
                        (0, c) | (c, 0) => (c, c),
                        (a, b) => (a.min(b), a.max(b)),
                    };
                    if hi > 0 {
                        if hi - lo <= 3 {
                            take(trace((lo as f64 - 2.0).max(near_f), (hi as f64 + 1.0).min(end)));
                        } else {
                            for c in [lo, hi] {
                                take(trace((c as f64 - 2.0).max(near_f), (c as f64 + 1.0).min(end)));
                            }
                        }
                    }
                    // Row crossings past the last whole column of a fractional reach.
                    if end.is_finite() && end.fract() > 0.0 {
                        take(trace(end.floor().max(near_f), end));
                    }
                }
            }
            let (mut s, mut t) = best;
            if s < -1.0e20 {
                s = OPEN_SKY_SLOPE;
                t = 0.0;
            }
            let o = orientation.original(width, height, col, row) * texel_bytes;
            encode(format, s, t, distance_scale, &mut out[o..o + texel_bytes]);
        }
    }
}

/// Columns within which a ray leaving a clamped map through a row edge is traced exactly: there
/// the lines around the texel leave the map at other columns than its ray (up to `1/|m|`
/// columns apart), so their tangent columns are poor candidates.
const EXIT_TRACE: f64 = 64.0;

/// Writes one texel (`tan β`, `d`) in `format` into `out` (exactly one texel long).
fn encode(format: HorizonFormat, slope: f32, dist: f32, distance_scale: f32, out: &mut [u8]) {
    match format {
        HorizonFormat::Rg8Unorm => {
            let unorm = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
            out[0] = unorm(slope.atan() / std::f32::consts::PI + 0.5);
            out[1] = unorm(dist / distance_scale);
        }
        HorizonFormat::Rg16Float => {
            let s = half::f16::from_f32(slope.clamp(OPEN_SKY_SLOPE, -OPEN_SKY_SLOPE));
            let d = half::f16::from_f32(dist.min(-OPEN_SKY_SLOPE));
            out[..2].copy_from_slice(&s.to_le_bytes());
            out[2..4].copy_from_slice(&d.to_le_bytes());
        }
        HorizonFormat::Rg32Float => {
            out[..4].copy_from_slice(&slope.to_le_bytes());
            out[4..8].copy_from_slice(&dist.to_le_bytes());
        }
    }
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
