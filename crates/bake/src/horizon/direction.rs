//! One azimuth of the bake: the near field of every texel written into the direction's slice of
//! the output, then the far field, which replaces a texel when it is steeper.
//!
//! The grid is in canonical orientation (a ray steps one column right and `m` rows per step);
//! [`Orientation::original`] maps a grid texel back to its place in the output.

use hikage_bundle::EdgeMode;

use super::encode::{self, HorizonFormat, rg8};
use super::grid::{Frame, Grid, Orientation, Region};
use super::near::split;
use super::steps::Steps;
use super::{HorizonParams, near, sweep};

/// Rows of a transposed orientation encoded before they are written out together.
const TILE: usize = 16;

/// Columns within which a ray leaving a clamped map through a row edge is traced exactly: there
/// the lines around the texel leave the map at other columns than its ray (up to `1/|m|`
/// columns apart), so their tangent columns are poor candidates.
const EXIT_TRACE: f64 = 64.0;

/// What both passes of one direction share: where its rays reach, its step table and where its
/// texels go in the output.
pub(super) struct Direction<'a> {
    g: &'a Grid,
    orientation: Orientation,
    /// Width and height of the output slice (the original map's, or a band's).
    size: (usize, usize),
    m: f64,
    format: HorizonFormat,
    distance_scale: f32,
    /// Where the grid lies in the map.
    frame: Frame,
    /// The texels computed; the rest of the output is left as it is.
    region: Region,
    /// Rays stop at the map's edges (clamp) rather than continue on the torus.
    clamped: bool,
    /// Reach in columns (real for traces, whole columns for the sweep); `None`: to the edge.
    reach: Option<f64>,
    /// Columns traced exactly by the near pass.
    near_cols: usize,
    /// The near pass's reach: the near field, or less when the whole reach is shorter.
    near_reach: f64,
    /// The reach as a number (infinite when unbounded).
    end: f64,
    steps: Steps,
    /// Per grid column `c`, where a sweep line through row 0 of map column `c + col0` is: whole
    /// rows and the fraction (`split(m · (c + col0))`); the step table's own columns when the
    /// frame starts at column 0.
    line_rows: Option<(Vec<i32>, Vec<f32>)>,
    texel_bytes: usize,
}

impl<'a> Direction<'a> {
    /// The direction of slope `m` (rows per column) on grid `g`, placed in the map by `frame`,
    /// whose texels go into an output slice of `size` texels in `format`.
    pub(super) fn new(
        g: &'a Grid,
        frame: Frame,
        orientation: Orientation,
        size: (usize, usize),
        m: f64,
        params: &HorizonParams,
        distance_scale: f32,
    ) -> Direction<'a> {
        let step_len = (g.sx * g.sx + (m * g.sy).powi(2)).sqrt();
        let map_w = frame.map_w as f64;
        // Rays on a torus are followed for at most 4 map lengths along their major axis.
        let reach = match (params.max_distance, params.edge) {
            (Some(md), EdgeMode::Wrap) => Some((md as f64 / step_len).min(4.0 * map_w)),
            (Some(md), EdgeMode::Clamp) => Some((md as f64 / step_len).min(map_w)),
            (None, EdgeMode::Wrap) => Some(map_w),
            (None, EdgeMode::Clamp) => None,
        };
        let near_cols = params.near_field as usize;
        let cols = g.w + reach.map_or(0, |r| r.ceil() as usize) + 1;
        let line_rows = (frame.col0 != 0).then(|| {
            (0..=cols)
                .map(|c| {
                    let (r, f) = split(m * (c as i64 + frame.col0) as f64);
                    (r as i32, f)
                })
                .unzip()
        });
        Direction {
            g,
            orientation,
            size,
            m,
            format: params.format.working(),
            distance_scale,
            frame,
            region: Region::whole(g.w, g.h),
            clamped: params.edge == EdgeMode::Clamp,
            reach,
            near_cols,
            near_reach: reach.map_or(near_cols as f64, |r| r.min(near_cols as f64)),
            end: reach.unwrap_or(f64::INFINITY),
            steps: Steps::new(m, step_len, cols, g.stride),
            line_rows,
            texel_bytes: params.format.working().texture_format().texel_bytes(),
        }
    }

    /// Computes only the texels of `region` (a tile inside its window of heights): its rows,
    /// and only the sweep lines that cross it, from a block of the reach beyond it.
    pub(super) fn within(mut self, region: Region) -> Direction<'a> {
        debug_assert!(region.cols.end <= self.g.w && region.rows.end <= self.g.h && !region.cols.is_empty());
        self.region = region;
        self
    }

    /// Both passes, into `out` (the direction's slice, original layout).
    pub(super) fn bake(&self, out: &mut [u8]) {
        self.near_pass(out);
        if self.end > self.near_cols as f64 {
            self.far_pass(out);
        }
    }

    /// Byte offset in the output of grid texel (`col`, `row`).
    #[inline(always)]
    fn at(&self, col: usize, row: usize) -> usize {
        self.orientation.original(self.size.0, self.size.1, col, row) * self.texel_bytes
    }

    /// Columns until a clamped ray from `row` leaves the map through a row edge.
    #[inline(always)]
    fn exit(&self, row: usize) -> f64 {
        let row = row as i64 + self.frame.row0;
        match (self.clamped, self.m) {
            (true, m) if m > 0.0 => (self.frame.map_h as i64 - 1 - row) as f64 / m,
            (true, m) if m < 0.0 => row as f64 / -m,
            _ => f64::INFINITY,
        }
    }

    /// True when the ray of texel `col` leaves through a row edge within [`EXIT_TRACE`] columns
    /// (and before the map's right edge): it is traced exactly instead of swept.
    #[inline(always)]
    fn traced(&self, exit: f64, col: usize) -> bool {
        exit <= EXIT_TRACE && exit < (self.frame.map_w as i64 - 1 - (col as i64 + self.frame.col0)) as f64
    }

    /// `(tan β, t)` of texel (`col`, `row`)'s own ray over columns `(lo, hi]`, exactly.
    #[inline(always)]
    fn trace(&self, row: usize, col: usize, lo: f64, hi: f64) -> Option<(f32, f32)> {
        self.steps.trace(self.g, self.frame.torus, row, col, lo, hi)
    }

    /// The near field of every texel, and the exact traces that stand in for the far field,
    /// encoded into `out` a row at a time.
    fn near_pass(&self, out: &mut [u8]) {
        let (g, texel_bytes) = (self.g, self.texel_bytes);
        let Region { cols, rows } = self.region.clone();
        let taps = near::stencil(self.m, self.steps.step_len, self.near_reach);
        let near_f = self.near_cols as f64;
        let end = self.end;
        let mut best_s = vec![0.0f32; g.w];
        let mut best_t = vec![0.0f32; g.w];
        // A transposed orientation's rows are columns of the output: they are encoded into a tile
        // of TILE rows first and written out a column run at a time, not a texel per cache line.
        let row_bytes = cols.len() * texel_bytes;
        let mut tile = vec![0u8; if self.orientation.transpose { TILE * row_bytes } else { 0 }];
        let mut halves = Vec::new();
        for row in rows.clone() {
            near::row(g, &taps, row, cols.clone(), &mut best_s, &mut best_t);
            let exit = self.exit(row);
            if end > near_f {
                for col in cols.clone() {
                    let mut best = (best_s[col], best_t[col]);
                    if self.traced(exit, col) {
                        steeper(&mut best, self.trace(row, col, near_f, end.min(exit)));
                    } else if end.is_finite() && end.fract() > 0.0 {
                        // Row crossings past the last whole column of a fractional reach.
                        steeper(&mut best, self.trace(row, col, end.floor().max(near_f), end));
                    } else {
                        continue;
                    }
                    (best_s[col], best_t[col]) = best;
                }
            }
            // The row's texels are consecutive in the tile, or in the output (right to left when
            // the orientation mirrors columns).
            let reversed = tile.is_empty() && self.orientation.flip;
            let in_tile = (row - rows.start) % TILE;
            let dst = if tile.is_empty() {
                let o = self.at(cols.start, row).min(self.at(cols.end - 1, row));
                &mut out[o..o + row_bytes]
            } else {
                &mut tile[in_tile * row_bytes..][..row_bytes]
            };
            let (s, t) = (&mut best_s[cols.clone()], &mut best_t[cols.clone()]);
            encode::encode_row(self.format, s, t, self.distance_scale, dst, reversed, &mut halves);
            if !tile.is_empty() && (in_tile == TILE - 1 || row + 1 == rows.end) {
                let first = row - in_tile;
                // (col, first + k) is `k` texels after (col, first) in the output.
                let untile = match self.format {
                    HorizonFormat::Rg8Unorm => untile::<2>,
                    HorizonFormat::Rg16Float => untile::<4>,
                    HorizonFormat::Rg32Float | HorizonFormat::Bc5RgUnorm => untile::<8>,
                };
                untile(&tile, cols.len(), in_tile + 1, out, &|i| self.at(cols.start + i, first));
            }
        }
    }

    /// The far field: the line sweep's tangent columns, and around each the texel's own ray,
    /// exactly; a texel is overwritten where that is steeper than its near field.
    fn far_pass(&self, out: &mut [u8]) {
        let (g, texel_bytes, format, distance_scale) = (self.g, self.texel_bytes, self.format, self.distance_scale);
        let (near_cols, near_f, end) = (self.near_cols, self.near_cols as f64, self.end);
        let (rows, fracs) = match &self.line_rows {
            Some((r, f)) => (r.as_slice(), f.as_slice()),
            None => (self.steps.col_r.as_slice(), self.steps.col_f.as_slice()),
        };
        let line = sweep::Line {
            m: self.m,
            rows,
            fracs,
            near: near_cols,
            reach: self.reach.map(|r| (r + 1e-9).floor() as usize),
            wrap: self.frame.torus,
            col0: self.frame.col0,
            restart: usize::try_from(self.frame.map_w as i64 - 1 - self.frame.col0).unwrap_or(usize::MAX),
            region: &self.region,
        };
        // Axis and diagonal directions: every crossing of a ray is a column crossing and the line
        // through a texel is its ray, so the hull's tangent is already the exact answer.
        let exact_lines = self.m == 0.0 || self.m.abs() == 1.0;
        let end_cols = if end.is_finite() { end.floor() as usize } else { usize::MAX };
        // The texels a line will finish a few columns on are fetched early: along a line they are
        // a row apart in the output, which a power-of-two width maps to few cache sets.
        let out_addr = out.as_ptr() as usize;
        let fetch_texel = |row: usize, col: usize| prefetch(out_addr + self.at(col, row));
        let Region { cols, rows } = &self.region;
        let mut finish = |row: usize, col: usize, hits: [Option<sweep::Hit>; 2]| {
            if !rows.contains(&row) || !cols.contains(&col) || self.traced(self.exit(row), col) {
                return;
            }
            let mut best = (f32::NEG_INFINITY, 0.0);
            if exact_lines {
                if let [Some(hit), None] = hits {
                    steeper(&mut best, self.steps.slope((hit.rise, hit.run)));
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
                    self.steps.window(g, self.frame.torus, row, col, lo, hi)
                };
                if hi - lo <= 3 {
                    steeper(&mut best, window(lo, hi));
                } else {
                    for c in [lo, hi] {
                        steeper(&mut best, window(c, c));
                    }
                }
            }
            let o = self.at(col, row);
            let texel = &mut out[o..o + texel_bytes];
            // Rounding is monotonic, so comparing with the near-field slope as stored in half (or
            // full) precision picks the same slope as comparing before rounding.
            let replace = match format {
                HorizonFormat::Rg16Float => best.0 > half::f16::from_le_bytes([texel[0], texel[1]]).to_f32(),
                HorizonFormat::Rg32Float | HorizonFormat::Bc5RgUnorm => {
                    best.0 > f32::from_le_bytes([texel[0], texel[1], texel[2], texel[3]])
                }
                // An 8-bit slope cannot tell a tie: then the near pass is traced again for this texel.
                HorizonFormat::Rg8Unorm => match rg8::compare(best.0, texel[0]) {
                    std::cmp::Ordering::Greater => true,
                    std::cmp::Ordering::Less => false,
                    // The same slope byte and the same distance byte: either way, the same texel.
                    std::cmp::Ordering::Equal if rg8::unorm(best.1 / distance_scale) == texel[1] => false,
                    std::cmp::Ordering::Equal => {
                        let mut near = self.trace(row, col, 0.0, self.near_reach).unwrap_or((f32::NEG_INFINITY, 0.0));
                        if end.is_finite() && end.fract() > 0.0 {
                            steeper(&mut near, self.trace(row, col, end.floor().max(near_f), end));
                        }
                        best.0 > near.0
                    }
                },
            };
            if replace {
                encode::encode(format, best.0, best.1, distance_scale, texel);
            }
        };
        sweep::far_field(g, &line, &mut finish, &fetch_texel);
    }
}

/// Keeps the steeper of `best` and candidate `c`; a tie keeps `best` (the nearer sample).
#[inline(always)]
fn steeper(best: &mut (f32, f32), c: Option<(f32, f32)>) {
    if let Some((s, t)) = c
        && s > best.0
    {
        *best = (s, t);
    }
}

/// Writes the first `rows` rows of a transposed orientation's `tile` (rows of `w` texels of `B`
/// bytes) to `out`, where texel `k` of the tile's column `col` goes `k` texels after
/// `start(col)`. The texel
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
