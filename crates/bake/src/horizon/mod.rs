//! Horizon and distance maps (seed 000, Onoue, Max & Nishita), baked in `O(N·D)`.
//!
//! For texel `p` and azimuth `φ_k = 2πk/D` (texel space, from +u toward +v), the horizon slope
//! is `tan β = max (h(q) − h(p)) / t` over the points `q` of the ray from the texel centre
//! where it crosses a grid line of the bilinear surface, `0 < t ≤ max_distance` (world units),
//! and `d` is the `t` that attains it (the conventions are in `docs/conventions.md`).
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

mod ao;
mod direction;
mod encode;
mod grid;
mod hull;
mod near;
mod params;
pub mod pyramid;
mod schedule;
mod steps;
mod sweep;
mod tile;

use std::sync::atomic::{AtomicU64, Ordering};

use hikage_bundle::{EdgeMode, Supercompression, TextureData, TextureDesc, TextureDimension};
use rayon::prelude::*;

use crate::heightfield::Heightfield;
use direction::Direction;
use grid::{Frame, Orientation};

pub use ao::ambient_occlusion;
pub use encode::{HorizonFormat, OPEN_SKY_SLOPE, decode};
pub use params::{DEFAULT_NEAR_FIELD, HorizonParams};
pub use tile::{Rect, TileWindow, bake_tile, halo};

/// Version of the horizon baker; part of the input hash.
pub const ALGORITHM_VERSION: u32 = 4;

/// Rows per band of direction 0, baked band by band from the input.
const ROW_BAND: usize = 64;

/// A baked horizon texture with the values the runtime needs to decode it.
#[derive(Clone, Debug, PartialEq)]
pub struct HorizonTexture {
    /// The 3D texture, `W×H×D`, φ on the depth axis.
    pub texture: TextureData,
    /// For `Rg8Unorm` and `Bc5RgUnorm`: distance = channel 1 × `distance_scale`; 1 for float
    /// formats.
    pub distance_scale: f32,
}

/// Bakes the horizon texture of `hf`. `progress(done, total)` is called once per direction.
pub fn bake(
    hf: &Heightfield,
    params: &HorizonParams,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<HorizonTexture, String> {
    params.check()?;
    let (w, h, d) = (hf.width as usize, hf.height as usize, params.directions as usize);
    let (sx, sy) = (hf.texel_size.0 as f64, hf.texel_size.1 as f64);
    let texel_bytes = params.format.working().texture_format().texel_bytes();
    let distance_scale = distance_scale(params, (w, h), hf.texel_size);

    // Zeroed pages are not resident until written, so the output grows as it is filled.
    let mut bytes = vec![0u8; w * h * d * texel_bytes];
    let done = AtomicU64::new(0);
    let pad = params.near_field as usize + 2;
    let wrap = params.edge == EdgeMode::Wrap;
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
        let frame = Frame::whole(grid.w, grid.h, wrap);
        Direction::new(grid, frame, Orientation::ALL[g], (w, h), m, params, distance_scale).bake(slice);
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
        let frame = Frame::whole(w, rows, wrap);
        Direction::new(&grid, frame, orientation, (w, rows), m, params, distance_scale).bake(out);
    });
    progress(done.fetch_add(1, Ordering::Relaxed) + 1, d as u64);
    let desc = TextureDesc { width: hf.width, height: hf.height, ..texture_desc(params) };
    let baked = HorizonTexture { texture: TextureData { desc, levels: vec![bytes] }, distance_scale };
    Ok(encode::finish(params.format, baked))
}

/// For the 8-bit formats, the distance a stored 1 stands for: the largest any horizon of a `map`-sized
/// field can have; 1 for float formats.
fn distance_scale(params: &HorizonParams, (w, h): (usize, usize), (sx, sy): (f32, f32)) -> f32 {
    let diag = ((w as f64 * sx as f64).powi(2) + (h as f64 * sy as f64).powi(2)).sqrt();
    if params.format.scales_distance() {
        params.max_distance.map_or(diag * 2.0, |m| m as f64).max(1e-6) as f32
    } else {
        1.0
    }
}

/// The description of a horizon texture of `params`, its width and height 0 for the caller.
fn texture_desc(params: &HorizonParams) -> TextureDesc {
    TextureDesc {
        format: params.format.working().texture_format(),
        dimension: TextureDimension::D3,
        width: 0,
        height: 0,
        depth: params.directions,
        layers: 1,
        levels: 1,
        supercompression: Supercompression::None,
        channels: vec!["slope".into(), "distance".into()],
    }
}
