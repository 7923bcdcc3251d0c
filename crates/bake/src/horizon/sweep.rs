//! The far field: horizons beyond the near field from a line sweep with convex-hull stacks.
//!
//! Seed 000 stores the horizon `tan β` and its distance `d` per texel and direction; computing
//! them by marching every ray costs `O(N·D·R)`. Here, for one canonical direction (one column
//! right, `m` rows per step), lines parallel to the direction are laid one row apart; each line
//! samples the bilinear surface where it crosses texel columns. Swept right to left, a line's
//! samples ahead of the current column form an upper convex hull (Dozier 1981; Timonen &
//! Westerholm 2010), and the horizon from any origin left of them is the tangent to that hull.
//!
//! Each texel lies between two lines; it asks both for the tangent from its *own* centre and
//! height (not the line's), over the samples at column distance `K+1 ..= R` (`K`: near field,
//! traced exactly elsewhere; `R`: reach). The two tangent columns are candidates: the texel's own
//! ray is then sampled exactly around them (see `mod.rs`), so a far-field horizon is always a
//! real sample of the ray, never an interpolation between two lines' answers.
//! A finite reach is a sliding window: columns are cut into blocks of the window length, and the
//! window is the suffix of one block (a hull built right to left, reset per block) plus a
//! shrinking prefix of the next (a hull built left to right and undone one sample at a time).
//!
//! Cost: `O(N)` per direction, amortised, with a tangent walk per texel and line that starts from
//! the previous answer; memory `O(W)`: a texel is finished as soon as its second line has
//! answered, so no per-texel buffer is needed.

use super::grid::{Grid, Region};
pub(crate) use super::hull::Hit;
use super::hull::{PrefixHull, Pt, SuffixHull};
use super::steps::wrap_index;

/// Parameters of one canonical direction.
///
/// The sweep is laid out in map columns, not grid columns: line `k` passes row `k` of the grid
/// at map column 0, the blocks of a finite reach start at multiples of the block length in map
/// columns, and every walk along a hull starts afresh where the whole map's sweep starts, at
/// each block and on each line. So a texel meets the same lines, hulls and walks whether its
/// grid is the whole map or a window of it (a tile with its halo), and gets the same bytes.
pub(crate) struct Line<'a> {
    /// Rows per column step.
    pub m: f64,
    /// Per grid column `c` (covering `w + reach`), where line 0 is: whole rows and the fraction
    /// to the next row, `split(m · (c + col0))`.
    pub rows: &'a [i32],
    pub fracs: &'a [f32],
    /// Columns covered exactly by the near field.
    pub near: usize,
    /// Largest column displacement a horizon may have (`None`: to the map edge).
    pub reach: Option<usize>,
    /// Rays continue on the torus (the grid is the whole map).
    pub wrap: bool,
    /// Map column of grid column 0.
    pub col0: i64,
    /// Grid column of the map's last column, where the whole map's sweep starts.
    pub restart: usize,
    /// The texels wanted: the whole grid, or (with a finite reach, off the torus) a tile inside
    /// its window, for which only the lines that cross it are swept, each from a block of the
    /// reach to the tile's right. Texels of those lines outside it are still queried, so that
    /// every walk along a hull is the whole grid's, and finished too: the caller skips them.
    pub region: &'a Region,
}

/// Runs the far field of one direction. `finish(row, col, [below, above])` is called once per
/// texel that some line brackets, with the tangent vertices found on the line below and above
/// it, as soon as both are known. `prefetch(row, col)` is told, [`AHEAD`] columns early, of a
/// texel a line is about to reach, so that whatever `finish` reads for it can be fetched.
pub(crate) fn far_field(
    g: &Grid,
    line: &Line,
    finish: &mut impl FnMut(usize, usize, [Option<Hit>; 2]),
    prefetch: &impl Fn(usize, usize),
) {
    if line.reach.is_some_and(|r| r <= line.near) {
        return;
    }
    let mut sweeper = Sweeper { pending: vec![Pending::NONE; g.w], ..Default::default() };
    if line.wrap {
        debug_assert_eq!(*line.region, Region::whole(g.w, g.h), "a torus is baked whole");
        // The lines form a cycle on the torus: line -1 (= h - 1) opens it, querying only the
        // texels above it, and line h - 1 closes it, querying only those below.
        for k in -1..g.h as i64 {
            sweeper.run(g, line, k, [k < g.h as i64 - 1, k >= 0], finish, prefetch);
        }
    } else {
        // Every line that passes within a row of the region somewhere along it.
        let Region { cols, rows } = line.region;
        let (first, last) = (line.rows[cols.start] as i64, line.rows[cols.end - 1] as i64);
        let lo = rows.start as i64 - first.max(last) - 2;
        let hi = rows.end as i64 - first.min(last) + 1;
        for k in lo..=hi {
            sweeper.run(g, line, k, [true, true], finish, prefetch);
        }
    }
    for (col, p) in sweeper.pending.iter().enumerate() {
        if p.row != u32::MAX {
            finish(p.row as usize, col, [p.hit, None]);
        }
    }
}

/// How many columns ahead of the sweep texels are announced to `prefetch`.
const AHEAD: usize = 8;

/// A texel whose line below has answered and whose line above has not yet.
#[derive(Clone, Copy, Debug)]
struct Pending {
    /// The texel's row (`u32::MAX`: none).
    row: u32,
    /// The tangent vertex found on the line below.
    hit: Option<Hit>,
}

impl Pending {
    const NONE: Pending = Pending { row: u32::MAX, hit: None };
}

#[derive(Default)]
struct Sweeper {
    suffix: SuffixHull,
    prefix: PrefixHull,
    /// Walk hints per slot (texel above / below the line), for the suffix and prefix hulls.
    hints: [[usize; 2]; 2],
    /// Per column, the texel waiting for the next line.
    pending: Vec<Pending>,
}

impl Sweeper {
    /// The sample of line `k` at (unwrapped) column `c`, if it lies on the map.
    #[inline(always)]
    fn point(g: &Grid, line: &Line, k: i64, c: usize) -> Option<Pt> {
        let r = k + line.rows[c] as i64;
        let f = line.fracs[c];
        let (r0, r1, col) = if line.wrap {
            let h = g.h as i64;
            (wrap_index(r, h), wrap_index(r + 1, h), wrap_index(c as i64, g.w as i64))
        } else {
            if c >= g.w || r < 0 || r >= g.h as i64 || (r + 1 >= g.h as i64 && f > 0.0) {
                return None;
            }
            (r as usize, (r as usize + 1).min(g.h - 1), c)
        };
        let a = g.at(r0, col);
        let h = if f > 0.0 { a + f * (g.at(r1, col) - a) } else { a };
        Some(Pt { x: c as f32, h })
    }

    /// Columns `i` at which line `k` brackets a texel of a clamped map (its row `k + m·i` lies
    /// within a row of the map), or `None`.
    fn columns_near_map(g: &Grid, m: f64, k: i64) -> Option<(usize, usize)> {
        let (lo_y, hi_y) = (-1.5 - k as f64, g.h as f64 + 0.5 - k as f64);
        let (lo, hi) = if m > 0.0 {
            (lo_y / m, hi_y / m)
        } else if m < 0.0 {
            (hi_y / m, lo_y / m)
        } else if lo_y < 0.0 && hi_y > 0.0 {
            (0.0, g.w as f64)
        } else {
            return None;
        };
        let lo = lo.floor().max(0.0);
        let hi = hi.ceil().min(g.w as f64 - 1.0);
        (lo <= hi).then_some((lo as usize, hi as usize))
    }

    fn run(
        &mut self,
        g: &Grid,
        line: &Line,
        k: i64,
        slots: [bool; 2],
        finish: &mut impl FnMut(usize, usize, [Option<Hit>; 2]),
        prefetch: &impl Fn(usize, usize),
    ) {
        let (w, near) = (g.w, line.near);
        self.suffix.clear();
        self.prefix.clear();
        self.hints = [[0; 2]; 2];
        match line.reach {
            None => {
                debug_assert_eq!(*line.region, Region::whole(w, g.h), "an unbounded reach is baked whole");
                // Clamped: only the columns where the line is near the map matter. Past `i_hi`
                // the line is half a row or more off the map, so it has no samples there and
                // the hull starts empty.
                let Some((i_lo, i_hi)) = Self::columns_near_map(g, line.m, k) else { return };
                debug_assert!((i_hi + 1..w).all(|c| Self::point(g, line, k, c).is_none()));
                for i in (i_lo..=i_hi).rev() {
                    let a = i + near + 1;
                    if a < w
                        && let Some(p) = Self::point(g, line, k, a)
                    {
                        self.suffix.push_front(p);
                    }
                    Self::ahead(g, line, k, i, prefetch);
                    self.texels(g, line, k, i, slots, finish);
                }
            }
            Some(reach) => {
                // Blocks start at multiples of `block` in map columns; `start(b)` is block `b`'s
                // first grid column (negative for blocks left of the grid).
                let block = (reach - near) as i64;
                let start = |b: i64| b * block - line.col0;
                // The sweep starts past a block boundary to the region's right (or at the grid's
                // right edge): hulls and walks restart there, so from the boundary on they are
                // what a sweep of the whole grid has.
                let cols = &line.region.cols;
                let last = (cols.end + block as usize).min(w - 1);
                let a0 = last + 1 + near;
                let mut b = (a0 as i64 + line.col0).div_euclid(block);
                let next = start(b + 1) as usize;
                for c in (a0..next).rev() {
                    if let Some(p) = Self::point(g, line, k, c) {
                        self.suffix.push_front(p);
                    }
                }
                for c in next..next + (a0 as i64 - start(b)) as usize {
                    self.prefix.push_back(Self::point(g, line, k, c));
                }
                for i in (cols.start..=last).rev() {
                    let a = i + near + 1;
                    if i == line.restart {
                        self.hints = [[0; 2]; 2];
                    }
                    if a != a0 {
                        if (a as i64) < start(b) {
                            b -= 1;
                            self.suffix.clear();
                            self.prefix.clear();
                            self.hints = [[0; 2]; 2];
                            let next = start(b + 1) as usize;
                            for c in next..next + block as usize - 1 {
                                self.prefix.push_back(Self::point(g, line, k, c));
                            }
                        } else {
                            self.prefix.undo();
                        }
                        if let Some(p) = Self::point(g, line, k, a) {
                            self.suffix.push_front(p);
                        }
                    }
                    Self::ahead(g, line, k, i, prefetch);
                    self.texels(g, line, k, i, slots, finish);
                }
            }
        }
    }

    /// Announces the texel line `k` will reach [`AHEAD`] columns from now.
    #[inline(always)]
    fn ahead(g: &Grid, line: &Line, k: i64, i: usize, prefetch: &impl Fn(usize, usize)) {
        let Some(c) = i.checked_sub(AHEAD) else { return };
        if let Some(j) = Self::map_row(g, line, k + line.rows[c] as i64) {
            prefetch(j, c);
        }
    }

    /// Row `j` of the map: wrapped on the torus, or `None` off a clamped map.
    #[inline(always)]
    fn map_row(g: &Grid, line: &Line, j: i64) -> Option<usize> {
        if line.wrap { Some(wrap_index(j, g.h as i64)) } else { (0..g.h as i64).contains(&j).then_some(j as usize) }
    }

    /// Queries line `k` at column `i` for the two texels it brackets, each from its own centre
    /// and height: the texel above the line (slot 0, then waiting for the next line) and the
    /// texel below (slot 1, which the previous line has answered). A texel the line passes
    /// through has only slot 0 and is finished at once. `slots` says which slots to query.
    #[inline(always)]
    fn texels(
        &mut self,
        g: &Grid,
        line: &Line,
        k: i64,
        i: usize,
        slots: [bool; 2],
        finish: &mut impl FnMut(usize, usize, [Option<Hit>; 2]),
    ) {
        let on_line = line.fracs[i] == 0.0;
        let ja = k + line.rows[i] as i64 + (!on_line) as i64;
        for (j, slot) in [(ja - 1, 1usize), (ja, 0usize)] {
            if !slots[slot] || (slot == 1 && on_line) {
                continue;
            }
            let Some(j) = Self::map_row(g, line, j) else { continue };
            let o = Pt { x: i as f32, h: g.at(j, i) };
            let [hs, hp] = &mut self.hints[slot];
            let suffix = self.suffix.tangent(o, hs);
            // Only a window of limited reach has a prefix hull.
            let best = match (suffix, line.reach.and_then(|_| self.prefix.tangent(o, hp))) {
                (Some(s), Some(p)) => Some(if p.steeper_than(&s) { p } else { s }),
                (s, p) => s.or(p),
            };
            let pending = &mut self.pending[i];
            if slot == 1 {
                if pending.row == j as u32 {
                    finish(j, i, [pending.hit, best]);
                    *pending = Pending::NONE;
                } else {
                    finish(j, i, [None, best]);
                }
            } else if on_line {
                finish(j, i, [best, None]);
            } else {
                if pending.row != u32::MAX {
                    finish(pending.row as usize, i, [pending.hit, None]);
                }
                *pending = Pending { row: j as u32, hit: best };
            }
        }
    }
}
