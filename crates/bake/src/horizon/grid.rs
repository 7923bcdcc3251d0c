//! Canonical orientation: every azimuth is handled as a ray stepping one column to the right
//! per step and `m ∈ [-1, 1]` rows, on a transposed and/or mirrored copy of the heightfield.

use std::ops::Range;

/// Height used outside a clamped map: far below anything real, yet finite so that
/// `a + 0 · (OUTSIDE - a)` stays `a`.
pub(crate) const OUTSIDE: f32 = -1.0e30;

/// A heightfield in world height units (`height_scale × sample`; the offset cancels in every
/// slope), in canonical orientation, stored with `pad` extra rows above and below and `pad`
/// extra columns on the right so the near-field stencil never tests an edge. The padding holds
/// the torus continuation (wrap) or [`OUTSIDE`] (clamp). It is the baker's
/// only copy of the heights.
#[derive(Clone, Debug)]
pub(crate) struct Grid {
    pub w: usize,
    pub h: usize,
    /// World units per texel along columns and rows of this grid.
    pub sx: f64,
    pub sy: f64,
    /// Padding rows above and below, and columns on the right.
    pub pad: usize,
    /// Row length of `data` (`w + pad`).
    pub stride: usize,
    data: Vec<f32>,
}

impl Grid {
    /// Index in the storage of map texel (`row`, `col`).
    #[inline(always)]
    pub fn index(&self, row: usize, col: usize) -> usize {
        (row + self.pad) * self.stride + col
    }

    /// Height of map texel (`row`, `col`).
    #[inline(always)]
    pub fn at(&self, row: usize, col: usize) -> f32 {
        self.data[self.index(row, col)]
    }

    /// The storage (map and padding); see [`index`](Self::index).
    #[inline(always)]
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// `len` heights of padded row `r` (`-pad ≤ r < h + pad`) from column `col`
    /// (`col + len ≤ w + pad`).
    #[inline(always)]
    pub fn padded_row(&self, r: isize, col: usize, len: usize) -> &[f32] {
        let start = (r + self.pad as isize) as usize * self.stride + col;
        &self.data[start..start + len]
    }
}

/// An empty vector with room for `len` heights whose memory goes back to the system when it is
/// dropped. glibc serves blocks below its mmap threshold from the heap and keeps them resident
/// after they are freed; it raises that threshold (up to 32 MiB) as large blocks are freed, so a
/// 16 MiB grid freed before the bake's last slice is written would still count in its peak. A
/// capacity above the largest threshold is always mapped on its own; capacity never written is
/// never resident. Grids under 512 KiB keep their exact size: there it does not matter.
fn returnable(len: usize) -> Vec<f32> {
    const FLOOR: usize = (32 << 20) / std::mem::size_of::<f32>() + 1024;
    Vec::with_capacity(if len >= FLOOR / 64 { len.max(FLOOR) } else { len })
}

/// Where a grid lies in the whole map, in the grid's canonical orientation: a whole map is its
/// own frame; a tile's window of heights is a part of it. Everything a bake decides by position
/// (where rays leave a clamped map, how far a ray may go, which sweep line passes where) follows
/// the frame, so a window gives the same texels as the whole map where its halo covers the rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Frame {
    /// Map column and row of the grid's texel (0, 0); negative or past the map on a torus.
    pub col0: i64,
    pub row0: i64,
    /// The whole map's columns and rows.
    pub map_w: usize,
    pub map_h: usize,
    /// Reads wrap around the grid (a whole map on a torus); a window reads nothing past itself.
    pub torus: bool,
}

impl Frame {
    /// A whole `w`×`h` canonical grid.
    pub fn whole(w: usize, h: usize, torus: bool) -> Frame {
        Frame { col0: 0, row0: 0, map_w: w, map_h: h, torus }
    }

    /// The frame, in orientation `o`, of a `window` = (column, row, width, height) of a `map`
    /// = (width, height) in the original layout.
    pub fn window(o: Orientation, map: (usize, usize), window: (i64, i64, usize, usize)) -> Frame {
        let (x, y, w, h) = window;
        let (cx, cw, mw, ry, mh) = if o.transpose { (y, h, map.1, x, map.0) } else { (x, w, map.0, y, map.1) };
        let col0 = if o.flip { mw as i64 - (cx + cw as i64) } else { cx };
        Frame { col0, row0: ry, map_w: mw, map_h: mh, torus: false }
    }
}

/// The texels of a grid a bake computes, in canonical orientation: every texel of a whole map,
/// or a tile's inside the window of heights around it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Region {
    pub cols: Range<usize>,
    pub rows: Range<usize>,
}

impl Region {
    /// Every texel of a `w`×`h` canonical grid.
    pub fn whole(w: usize, h: usize) -> Region {
        Region { cols: 0..w, rows: 0..h }
    }

    /// In orientation `o`, the `tile` = (column, row, width, height) of a window of `size` =
    /// (width, height) texels, both in the original layout.
    pub fn tile(o: Orientation, size: (usize, usize), tile: (usize, usize, usize, usize)) -> Region {
        let (x, y, w, h) = tile;
        let (c, cw, r, rh, gw) = if o.transpose { (y, h, x, w, size.1) } else { (x, w, y, h, size.0) };
        let c = if o.flip { gw - (c + cw) } else { c };
        Region { cols: c..c + cw, rows: r..r + rh }
    }
}

/// How a canonical grid maps to the original: `transpose` swaps `u` and `v`, then `flip`
/// mirrors the (new) columns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Orientation {
    pub transpose: bool,
    pub flip: bool,
}

impl Orientation {
    pub const ALL: [Orientation; 4] = [
        Orientation { transpose: false, flip: false },
        Orientation { transpose: false, flip: true },
        Orientation { transpose: true, flip: false },
        Orientation { transpose: true, flip: true },
    ];

    /// Position in [`ALL`](Self::ALL).
    pub fn index(self) -> usize {
        2 * self.transpose as usize + self.flip as usize
    }

    /// The orientation and row slope `m` for azimuth `phi` (radians, texel space, from +u
    /// toward +v): the canonical ray steps `(+1 column, m rows)`.
    pub fn for_azimuth(phi: f64) -> (Orientation, f64) {
        let snap = |x: f64| if x.abs() < 1e-12 { 0.0 } else { x };
        // Exact 0 and ±1 for axis and diagonal directions, so their samples fall on texels.
        let snap_m = |m: f64| if (m.abs() - 1.0).abs() < 1e-12 { m.signum() } else { snap(m) };
        let (c, s) = (snap(phi.cos()), snap(phi.sin()));
        if c.abs() >= s.abs() {
            (Orientation { transpose: false, flip: c < 0.0 }, snap_m(s / c.abs()))
        } else {
            (Orientation { transpose: true, flip: s < 0.0 }, snap_m(c / s.abs()))
        }
    }

    /// Builds the canonical grid of a `width`×`height` field of `samples` × `scale`, padded by
    /// `pad` (see [`Grid`]).
    pub fn grid(
        self,
        (width, height): (usize, usize),
        samples: &[f32],
        scale: f32,
        (sx, sy): (f64, f64),
        pad: usize,
        wrap: bool,
    ) -> Grid {
        let (w, h, gsx, gsy) = if self.transpose { (height, width, sy, sx) } else { (width, height, sx, sy) };
        let stride = w + pad;
        let mut data = returnable(stride * (h + 2 * pad));
        data.resize(stride * (h + 2 * pad), OUTSIDE);
        for (r, out) in data.chunks_exact_mut(stride).enumerate() {
            let row = r as isize - pad as isize;
            if !(0..h as isize).contains(&row) && !wrap {
                continue;
            }
            let row = row.rem_euclid(h as isize) as usize;
            for (c, o) in out.iter_mut().enumerate() {
                if c < w || wrap {
                    *o = samples[self.original(width, height, c % w, row)] * scale;
                }
            }
        }
        Grid { w, h, sx: gsx, sy: gsy, pad, stride, data }
    }

    /// Index in the original row-major field of canonical `(col, row)`.
    #[inline]
    pub fn original(self, width: usize, height: usize, col: usize, row: usize) -> usize {
        let (w, _) = if self.transpose { (height, width) } else { (width, height) };
        let col = if self.flip { w - 1 - col } else { col };
        if self.transpose { col * width + row } else { row * width + col }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_is_the_position_in_all() {
        for (i, o) in Orientation::ALL.into_iter().enumerate() {
            assert_eq!(o.index(), i, "{o:?}");
        }
    }

    #[test]
    fn a_tiles_region_is_its_texels_in_every_orientation() {
        // A 3×2 tile at (4, 1) of a 9×5 window: the region's canonical texels, mapped back, are
        // exactly the tile's.
        let (size, tile) = ((9usize, 5usize), (4usize, 1usize, 3usize, 2usize));
        let mut want: Vec<usize> =
            (tile.1..tile.1 + tile.3).flat_map(|y| (tile.0..tile.0 + tile.2).map(move |x| y * size.0 + x)).collect();
        want.sort();
        for o in Orientation::ALL {
            let region = Region::tile(o, size, tile);
            let mut got: Vec<usize> = region
                .rows
                .clone()
                .flat_map(|row| region.cols.clone().map(move |col| o.original(size.0, size.1, col, row)))
                .collect();
            got.sort();
            assert_eq!(got, want, "{o:?}");
        }
    }

    #[test]
    fn canonical_ray_matches_the_azimuth() {
        // For each azimuth, one canonical step (+1 column, m rows) must map back to a step along
        // (cos φ, sin φ) in the original texel space.
        let (width, height) = (7usize, 5usize);
        for k in 0..32 {
            let phi = std::f64::consts::TAU * k as f64 / 32.0;
            let (o, m) = Orientation::for_azimuth(phi);
            assert!(m.abs() <= 1.0 + 1e-12);
            let (w, _) = if o.transpose { (height, width) } else { (width, height) };
            let orig = |col: usize, row: usize| {
                let i = o.original(width, height, col, row);
                ((i % width) as f64, (i / width) as f64)
            };
            // A step of one column at row 0, and one row at column 0.
            let (u0, v0) = orig(1, 1);
            let (u1, v1) = orig(2, 1);
            let (u2, v2) = orig(1, 2);
            let col_step = (u1 - u0, v1 - v0);
            let row_step = (u2 - u0, v2 - v0);
            let step = (col_step.0 + m * row_step.0, col_step.1 + m * row_step.1);
            let norm = (step.0 * step.0 + step.1 * step.1).sqrt();
            assert!((step.0 / norm - phi.cos()).abs() < 1e-9 && (step.1 / norm - phi.sin()).abs() < 1e-9, "k={k}");
            assert!(w > 0);
        }
    }
}
