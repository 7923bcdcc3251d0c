//! Tiled bakes: one tile of the horizon texture from a window of the heights around it.
//!
//! With a `max_distance`, no ray of a texel reads heights farther than `max_distance` (plus a
//! texel for interpolation), so a tile needs only its own texels and a halo of that reach:
//! its memory is bounded by the tile and its halo, not by the map. The bake of a window places
//! it in the map ([`Frame`]) so that every decision the whole-map bake makes by position is made
//! the same way; a tile's texels are then byte for byte the whole-map bake's.
//!
//! A tile computes only its own texels: the near field over its rows and columns, and the far
//! field from the sweep lines that cross it, each swept from a block of the reach to the tile's
//! right (where the whole map's sweep restarts its hulls too). So a tile costs about
//! `1 + max_distance / tile side` times its own texels, not its whole window's.
//!
//! Without `max_distance` a ray may run to the map's edge (or around a torus), so every tile's
//! halo would be the whole map: tiling is refused rather than silently reading everything.

use std::sync::atomic::{AtomicU64, Ordering};

use hikage_bundle::{EdgeMode, TextureData, TextureDesc};

use super::direction::Direction;
use super::grid::{Frame, Orientation, Region};
use super::{HorizonParams, HorizonTexture, schedule, texture_desc};
use crate::heightfield::Heightfield;

/// A rectangle of texels: its first column `x` and row `y` (negative for a window reaching left
/// of or above a torus), its width and height.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect<T> {
    /// First column.
    pub x: T,
    /// First row.
    pub y: T,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

impl<T> Rect<T> {
    /// The rectangle at `(x, y)` of `width` × `height`.
    pub fn new(x: T, y: T, width: u32, height: u32) -> Rect<T> {
        Rect { x, y, width, height }
    }
}

/// Where a tile lies in the whole map, and the window of heights its bake reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileWindow {
    /// The whole map's width and height in texels.
    pub map: (u32, u32),
    /// The tile's texels in the map.
    pub tile: Rect<u32>,
    /// The window's texels in the map. On a torus (`EdgeMode::Wrap`) it may start left of or
    /// above the map, or end past it: its texels are then read around the torus. A clamped
    /// map's window stays inside the map.
    pub window: Rect<i64>,
}

impl TileWindow {
    /// The window of `tile` in a `map`: the tile grown by `halo` = (columns, rows) on every
    /// side, kept inside a clamped map.
    pub fn new(map: (u32, u32), tile: Rect<u32>, halo: (u32, u32), edge: EdgeMode) -> TileWindow {
        let Rect { x, y, width: w, height: h } = tile;
        let axis = |start: u32, len: u32, halo: u32, size: u32| -> (i64, u32) {
            let (lo, hi) = (start as i64 - halo as i64, (start + len) as i64 + halo as i64);
            let (lo, hi) = match edge {
                EdgeMode::Wrap => (lo, hi),
                EdgeMode::Clamp => (lo.max(0), hi.min(size as i64)),
            };
            (lo, (hi - lo) as u32)
        };
        let (wx, ww) = axis(x, w, halo.0, map.0);
        let (wy, wh) = axis(y, h, halo.1, map.1);
        TileWindow { map, tile, window: Rect::new(wx, wy, ww, wh) }
    }
}

/// The halo a tile needs on each side, in texels (columns, rows): every texel a ray within
/// `max_distance` reads, with a texel each way for interpolation and for the sweep lines on
/// either side of a ray. An error when the bake has no `max_distance`.
pub fn halo(params: &HorizonParams, texel_size: (f32, f32)) -> Result<(u32, u32), String> {
    let md = params.max_distance.ok_or_else(|| {
        "a tiled horizon bake needs max_distance: without it a ray may cross the whole map, so \
         every tile would read all of it; set max_distance (world units) or bake the map whole"
            .to_string()
    })?;
    let texels = |s: f32| -> Result<u32, String> {
        let n = (md as f64 / s as f64).ceil() + 3.0;
        if n > u32::MAX as f64 / 4.0 {
            return Err(format!("max_distance {md} is {n} texels of {s}: too far to tile"));
        }
        Ok(n as u32)
    };
    Ok((texels(texel_size.0)?, texels(texel_size.1)?))
}

/// Bakes one tile of the horizon texture of a map from `window`, the heights of
/// `place.window` with the map's world units. The result is the tile's texels only, equal byte
/// for byte to the same region of [`super::bake`] of the whole map. `progress(done, total)` is
/// called once per direction.
pub fn bake_tile(
    window: &Heightfield,
    place: &TileWindow,
    params: &HorizonParams,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<HorizonTexture, String> {
    params.check()?;
    let halo = halo(params, window.texel_size)?;
    let Rect { x: wx, y: wy, width: ww, height: wh } = place.window;
    let Rect { x: tx, y: ty, width: tw, height: th } = place.tile;
    if (window.width, window.height) != (ww, wh) {
        return Err(format!("the window holds {}×{} heights, expected {ww}×{wh}", window.width, window.height));
    }
    let clamped = params.edge == EdgeMode::Clamp;
    if !covers((tx, tw), (wx, ww), halo.0, place.map.0, clamped)
        || !covers((ty, th), (wy, wh), halo.1, place.map.1, clamped)
    {
        return Err(format!(
            "tile {:?} of a {}×{} map needs its window to cover it and a halo of {halo:?} texels, found window {:?}",
            place.tile, place.map.0, place.map.1, place.window
        ));
    }
    let (map, size) = ((place.map.0 as usize, place.map.1 as usize), (ww as usize, wh as usize));
    let d = params.directions as usize;
    let format = params.format;
    let texel_bytes = format.working().texture_format().texel_bytes();
    let distance_scale = super::distance_scale(params, map, window.texel_size);
    let (sx, sy) = (window.texel_size.0 as f64, window.texel_size.1 as f64);
    let pad = params.near_field as usize + 2;

    let tile_len = tw as usize * th as usize * texel_bytes;
    let mut bytes = vec![0u8; tile_len * d];
    let mut work: Vec<Vec<(usize, &mut [u8])>> = Orientation::ALL.iter().map(|_| Vec::new()).collect();
    let for_azimuth = |k: usize| Orientation::for_azimuth(std::f64::consts::TAU * k as f64 / d as f64);
    for (k, slice) in bytes.chunks_mut(tile_len).enumerate() {
        work[for_azimuth(k).0.index()].push((k, slice));
    }
    let build = |g: usize| Orientation::ALL[g].grid(size, &window.samples, window.height_scale, (sx, sy), pad, false);
    let done = AtomicU64::new(0);
    let (ox, oy) = ((tx as i64 - wx) as usize, (ty as i64 - wy) as usize);
    schedule::run(work, &build, &|_, (k, slice): (usize, &mut [u8]), grid| {
        let (orientation, m) = for_azimuth(k);
        let frame = Frame::window(orientation, map, (wx, wy, size.0, size.1));
        let mut whole = vec![0u8; size.0 * size.1 * texel_bytes];
        let region = Region::tile(orientation, size, (ox, oy, tw as usize, th as usize));
        Direction::new(grid, frame, orientation, size, m, params, distance_scale).within(region).bake(&mut whole);
        let row_bytes = tw as usize * texel_bytes;
        for (r, out) in slice.chunks_exact_mut(row_bytes).enumerate() {
            let from = ((oy + r) * size.0 + ox) * texel_bytes;
            out.copy_from_slice(&whole[from..from + row_bytes]);
        }
        progress(done.fetch_add(1, Ordering::Relaxed) + 1, d as u64);
    });
    let desc = TextureDesc { width: tw, height: th, ..texture_desc(params) };
    let baked = HorizonTexture { texture: TextureData { desc, levels: vec![bytes] }, distance_scale };
    Ok(super::encode::finish(format, baked))
}

/// Whether, along one axis of a `map`-texel map, the window (start, length) holds the tile
/// (start, length) and `halo` texels on either side of it; on a clamped map the window may stop
/// at the map's edge instead.
fn covers((t, len): (u32, u32), (w, wlen): (i64, u32), halo: u32, map: u32, clamped: bool) -> bool {
    let (t, end, w_end) = (t as i64, t as i64 + len as i64, w + wlen as i64);
    let (halo, map) = (halo as i64, map as i64);
    let before = w <= t - halo || (clamped && w == 0);
    let after = end + halo <= w_end || (clamped && w_end == map);
    len > 0 && end <= map && before && after
}
