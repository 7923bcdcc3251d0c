//! Where a canonical ray crosses grid lines, tabulated once per direction.
//!
//! A canonical ray from a texel centre steps one column and `m` rows per step. Because rays
//! start at texel centres, the crossings of every ray of a direction sit at the same offsets:
//! column crossing `du` is `floor(m·du)` rows down and `frac(m·du)` of the way to the next row;
//! row crossing `dv` is at column displacement `dv / |m|`. The tables hold those offsets so the
//! sweep and the exact traces do no floor or division per sample.

use super::grid::{Grid, OUTSIDE};
use super::near::split;

/// Column and row crossings a window may hold to be sampled as fixed slots ([`Steps::window`]):
/// the common window around one candidate column is three columns with one or two row
/// crossings. (Four of each measured 3–5% slower than the loops; three and two, 1–3% faster.)
const COL_SLOTS: usize = 3;
const ROW_SLOTS: usize = 2;

pub(crate) struct Steps {
    /// World units per column step.
    pub step_len: f64,
    /// Column crossing `du`: whole rows below (`floor(m·du)`) and the fraction to the next row.
    pub col_r: Vec<i32>,
    pub col_f: Vec<f32>,
    /// Row length of the grid the offsets below are for.
    stride: usize,
    /// Column crossing `du`: offset in the grid's storage from the texel to its first sample.
    col_off: Vec<isize>,
    /// The row crossings that fall between two columns (a row crossing on a column is that
    /// column's crossing), in order.
    between: Vec<RowCrossing>,
    /// Per column displacement `du`: how many of `between` lie at or before it, so those in
    /// `(lo, hi]` are `between[col_rows[lo]..col_rows[hi]]`.
    col_rows: Vec<u32>,
}

/// A row crossing between two columns: `lerp(G[i], G[i + 1], f)` with `i` the texel's storage
/// index plus `off`, at column displacement `du`; the first sample is `rows` rows and `c` columns
/// from the texel.
#[derive(Clone, Copy, Debug)]
struct RowCrossing {
    off: isize,
    rows: i32,
    c: u32,
    f: f32,
    du: f32,
    /// `du` exactly, to compare with the bounds of a trace.
    du64: f64,
}

impl Steps {
    /// Tables for column displacements `0..=cols`, with offsets for a grid of row length
    /// `stride`.
    pub fn new(m: f64, step_len: f64, cols: usize, stride: usize) -> Steps {
        let mut col_r = Vec::with_capacity(cols + 1);
        let mut col_f = Vec::with_capacity(cols + 1);
        for du in 0..=cols {
            let (r, f) = split(m * du as f64);
            col_r.push(r as i32);
            col_f.push(f);
        }
        let col_off = col_r.iter().enumerate().map(|(du, &r)| r as isize * stride as isize + du as isize).collect();
        // Row crossing `dv` is `dv / |m|` columns on; one that falls on a column is left out.
        let (am, sign) = (m.abs(), if m < 0.0 { -1 } else { 1 });
        let last_row = if am > 0.0 { (am * cols as f64).floor() as i32 + 1 } else { 0 };
        let between: Vec<RowCrossing> = (1..=last_row)
            .filter_map(|dv| {
                let du = dv as f64 / am;
                let (c, f) = split(du);
                (f > 0.0).then(|| RowCrossing {
                    off: (sign * dv) as isize * stride as isize + c as isize,
                    rows: sign * dv,
                    c: c as u32,
                    f,
                    du: du as f32,
                    du64: du,
                })
            })
            .collect();
        let mut col_rows = Vec::with_capacity(cols + 1);
        let mut n = 0usize;
        for du in 0..=cols {
            while n < between.len() && between[n].du64 <= du as f64 + 1e-9 {
                n += 1;
            }
            col_rows.push(n as u32);
        }
        // The sentinel an empty row slot reads: the texel itself, never in a range.
        let mut between = between;
        between.push(RowCrossing { off: 0, rows: 0, c: 0, f: 0.0, du: 1.0, du64: f64::INFINITY });
        Steps { step_len, col_r, col_f, stride, col_off, between, col_rows }
    }

    /// Traces the ray from canonical texel (`row`, `col`) exactly over column displacements
    /// `(lo, hi]`: every grid-line crossing on the map (wrapped on the torus, or only inside a
    /// clamped map). Returns the steepest `(tan β, d)`, or `None` when no crossing is on the map.
    #[inline]
    pub fn trace(&self, g: &Grid, wrap: bool, row: usize, col: usize, lo: f64, hi: f64) -> Option<(f32, f32)> {
        if lo >= hi {
            return None;
        }
        let last = (hi + 1e-9).min((self.col_r.len() - 1) as f64) as usize;
        let first = (super::near::floor_i(lo) + 1).max(1) as usize;
        let span = if hi <= last as f64 + 1.0 { self.padded_span(g, row, col, lo, last) } else { None };
        let best = match span {
            Some(base) => self.best_padded(g, base, first..last + 1, self.rows_between(lo, hi, last), !wrap, false),
            None => self.trace_anywhere(g, wrap, row, col, first..last + 1, self.rows_between(lo, hi, last)),
        };
        self.slope(best)
    }

    /// The row crossings in `(lo, hi]`, as a range of `between`: from the table of whole
    /// columns (up to `last`), then the fractions.
    #[inline(always)]
    fn rows_between(&self, lo: f64, hi: f64, last: usize) -> std::ops::Range<usize> {
        let xs = &self.between;
        let mut r0 = self.col_rows[(lo.max(0.0) as usize).min(last)] as usize;
        while r0 < xs.len() && xs[r0].du64 <= lo + 1e-9 {
            r0 += 1;
        }
        let mut r1 = (self.col_rows[last] as usize).max(r0);
        while r1 < xs.len() && xs[r1].du64 <= hi + 1e-9 {
            r1 += 1;
        }
        r0..r1
    }

    /// [`trace`](Self::trace) over whole column displacements `(lo, hi]`, the window around a
    /// far-field candidate: the same crossings in the same order, with the row crossings read
    /// off the table of whole columns.
    #[inline]
    pub fn window(&self, g: &Grid, wrap: bool, row: usize, col: usize, lo: usize, hi: usize) -> Option<(f32, f32)> {
        if lo < hi
            && hi < self.col_r.len()
            && let Some(base) = self.padded_columns(g, row, col, lo, hi)
        {
            let (cols, rows) = (lo + 1..hi + 1, self.col_rows[lo] as usize..self.col_rows[hi] as usize);
            // Wrapped padding holds real heights; a window inside a clamped map reads none of
            // its padding. Either way no sample can be off the map.
            let off_map = !wrap && !self.on_map(g, row, col, lo, hi);
            let slotted = hi - lo <= COL_SLOTS && rows.len() <= ROW_SLOTS;
            return self.slope(self.best_padded(g, base, cols, rows, off_map, slotted));
        }
        self.trace(g, wrap, row, col, lo as f64, hi as f64)
    }

    /// True when every crossing of the ray from texel (`row`, `col`) over `(lo, hi]` reads only
    /// texels of the map (`lo < hi < col_r.len()`).
    #[inline(always)]
    fn on_map(&self, g: &Grid, row: usize, col: usize, lo: usize, hi: usize) -> bool {
        let (ra, rb) = (self.col_r[lo] as i64, self.col_r[hi] as i64);
        row as i64 + ra.min(rb) >= 0 && row as i64 + ra.max(rb) + 1 < g.h as i64 && col + hi < g.w
    }

    /// `(tan β, d)` of the best (rise, run in columns), `None` when there was no crossing.
    #[inline(always)]
    pub fn slope(&self, (rise, run): (f32, f32)) -> Option<(f32, f32)> {
        (rise > f32::NEG_INFINITY).then(|| {
            let t = run as f64 * self.step_len;
            ((rise as f64 / t) as f32, t as f32)
        })
    }

    /// The storage index of texel (`row`, `col`) when every crossing of its ray over
    /// `(lo, last + 1)` reads inside the padded grid, whose padding holds exactly what a wrapped
    /// or clamped read gives; `None` otherwise.
    #[inline(always)]
    fn padded_span(&self, g: &Grid, row: usize, col: usize, lo: f64, last: usize) -> Option<usize> {
        let last = last.min(self.col_r.len() - 1);
        self.padded_columns(g, row, col, (lo.max(0.0) as usize).min(last), last)
    }

    /// [`padded_span`](Self::padded_span) from whole column `first ≤ last < col_r.len()`.
    #[inline(always)]
    fn padded_columns(&self, g: &Grid, row: usize, col: usize, first: usize, last: usize) -> Option<usize> {
        let (ra, rb) = (self.col_r[first] as i64, self.col_r[last] as i64);
        let (r_lo, r_hi) = (row as i64 + ra.min(rb) - 2, row as i64 + ra.max(rb) + 3);
        let fits = r_lo >= -(g.pad as i64) && r_hi < (g.h + g.pad) as i64 && col + last + 2 < g.stride;
        fits.then(|| g.index(row, col))
    }

    /// [`trace_padded`](Self::trace_padded), testing each sample for being off the map only
    /// when `off_map` says some may be, and as fixed slots when `slotted` (at most
    /// [`COL_SLOTS`] columns and [`ROW_SLOTS`] row crossings).
    #[inline(always)]
    fn best_padded(
        &self,
        g: &Grid,
        base: usize,
        cols: std::ops::Range<usize>,
        rows: std::ops::Range<usize>,
        off_map: bool,
        slotted: bool,
    ) -> (f32, f32) {
        let data = g.data();
        match (off_map, slotted) {
            (true, false) => self.trace_padded::<true, false>(data, base, cols, rows),
            (false, false) => self.trace_padded::<false, false>(data, base, cols, rows),
            (true, true) => self.trace_padded::<true, true>(data, base, cols, rows),
            (false, true) => self.trace_padded::<false, true>(data, base, cols, rows),
        }
    }

    /// Column crossings `cols` and the row crossings `between[rows]`, read straight from the
    /// padded storage at `base`, the texel's index (see [`padded_span`](Self::padded_span)),
    /// with no wrapping or edge test per sample. `CHECK`: samples may be off a clamped map and
    /// are then left out. Best as (rise, run in columns).
    ///
    /// `SLOTTED`: at most [`COL_SLOTS`] columns and [`ROW_SLOTS`] row crossings, taken as a
    /// fixed number of samples. A window's length varies from texel to texel, and loops of
    /// varying trip count cost a mispredicted exit each. Unused column slots repeat the last
    /// column and unused row slots read the sentinel, masked out, so the result is the same.
    #[inline(always)]
    fn trace_padded<const CHECK: bool, const SLOTTED: bool>(
        &self,
        data: &[f32],
        base: usize,
        cols: std::ops::Range<usize>,
        rows: std::ops::Range<usize>,
    ) -> (f32, f32) {
        let mut best = Steepest::new(data[base]);
        let mut column = |du: usize| {
            let i = base.wrapping_add_signed(self.col_off[du]);
            best.consider::<CHECK>(true, data[i], data[i + self.stride], self.col_f[du], du as f32);
        };
        if SLOTTED {
            // A repeat of the last column cannot win again (the comparison is strict).
            (0..COL_SLOTS).for_each(|k| column((cols.start + k).min(cols.end - 1)));
        } else {
            cols.for_each(column);
        }
        let mut row = |valid: bool, x: &RowCrossing| {
            let i = base.wrapping_add_signed(x.off);
            best.consider::<CHECK>(valid, data[i], data[i + 1], x.f, x.du);
        };
        if SLOTTED {
            let sentinel = self.between.len() - 1;
            for k in 0..ROW_SLOTS {
                let valid = rows.start + k < rows.end;
                row(valid, &self.between[if valid { rows.start + k } else { sentinel }]);
            }
        } else {
            self.between[rows].iter().for_each(|x| row(true, x));
        }
        (best.rise, best.run)
    }

    /// Column crossings `cols` and the row crossings `between[rows]` anywhere on the torus or
    /// the clamped map, each read with its own wrapping or edge test. Best as (rise, run in
    /// columns).
    fn trace_anywhere(
        &self,
        g: &Grid,
        wrap: bool,
        row: usize,
        col: usize,
        cols: std::ops::Range<usize>,
        rows: std::ops::Range<usize>,
    ) -> (f32, f32) {
        let h0 = g.at(row, col);
        let (mut rise, mut run) = (f32::NEG_INFINITY, 1.0f32);
        let mut consider = |v: f32, du: f32| {
            if v > OUTSIDE && (v - h0) * run > rise * du {
                rise = v - h0;
                run = du;
            }
        };
        for du in cols {
            let r = row as i64 + self.col_r[du] as i64;
            let c = col as i64 + du as i64;
            consider(lerp_at(g, wrap, r, c, r + 1, c, self.col_f[du]), du as f32);
        }
        for x in &self.between[rows] {
            let r = row as i64 + x.rows as i64;
            let c = col as i64 + x.c as i64;
            consider(lerp_at(g, wrap, r, c, r, c + 1, x.f), x.du);
        }
        (rise, run)
    }
}

/// The steepest crossing so far from a texel of height `h0`, as (rise, run in columns); the
/// first of equally steep crossings stays.
struct Steepest {
    h0: f32,
    rise: f32,
    run: f32,
}

impl Steepest {
    #[inline(always)]
    fn new(h0: f32) -> Steepest {
        Steepest { h0, rise: f32::NEG_INFINITY, run: 1.0 }
    }

    /// Takes the crossing `lerp(a, b, f)` at column displacement `du` if `valid` and steeper.
    /// `CHECK`: it may be off a clamped map ([`OUTSIDE`]) and is then left out; its second
    /// sample does not count where the crossing is on a knot (`f` = 0).
    #[inline(always)]
    fn consider<const CHECK: bool>(&mut self, valid: bool, a: f32, b: f32, f: f32, du: f32) {
        let r = a + f * (b - a) - self.h0;
        let on_map = !CHECK || ((a > OUTSIDE) & ((f == 0.0) | (b > OUTSIDE)));
        let better = valid & on_map & (r * self.run > self.rise * du);
        self.rise = if better { r } else { self.rise };
        self.run = if better { du } else { self.run };
    }
}

/// `lerp(G[ra][ca], G[rb][cb], f)`, wrapped or clamped; [`OUTSIDE`] when a needed sample is off
/// a clamped map (the second sample is not needed when `f` is 0).
#[inline(always)]
pub(crate) fn lerp_at(g: &Grid, wrap: bool, ra: i64, ca: i64, rb: i64, cb: i64, f: f32) -> f32 {
    let a = get(g, wrap, ra, ca);
    if f > 0.0 {
        let b = get(g, wrap, rb, cb);
        if a <= OUTSIDE || b <= OUTSIDE { OUTSIDE } else { a + f * (b - a) }
    } else {
        a
    }
}

/// Height at (r, c), wrapped, or [`OUTSIDE`] off a clamped map.
#[inline(always)]
fn get(g: &Grid, wrap: bool, r: i64, c: i64) -> f32 {
    let (w, h) = (g.w as i64, g.h as i64);
    if wrap {
        g.at(wrap_index(r, h), wrap_index(c, w))
    } else if r >= 0 && r < h && c >= 0 && c < w {
        g.at(r as usize, c as usize)
    } else {
        OUTSIDE
    }
}

#[inline(always)]
pub(crate) fn wrap_index(i: i64, n: i64) -> usize {
    // Rays are followed a few map lengths at most: one period either way needs no division.
    if i >= 0 && i < n {
        i as usize
    } else if i >= n && i < 2 * n {
        (i - n) as usize
    } else if i < 0 && i >= -n {
        (i + n) as usize
    } else {
        i.rem_euclid(n) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::super::grid::Orientation;
    use super::{Steps, wrap_index};

    /// The fixed-slot windows must give exactly what the looped trace gives over the same
    /// columns, near the edges of a clamped map and on a torus, for short and long windows.
    #[test]
    fn windows_equal_the_trace_over_the_same_columns() {
        let (w, h) = (40usize, 30usize);
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) as f64 / (1u64 << 31) as f64
        };
        let samples: Vec<f32> = (0..w * h).map(|_| next() as f32).collect();
        let mut compared = 0;
        for wrap in [false, true] {
            let g = Orientation::ALL[0].grid((w, h), &samples, 3.0, (1.0, 1.0), 10, wrap);
            for &m in &[0.0, 0.3, -0.45, 0.999, -1.0, 1.0 / 3.0, 0.07] {
                let steps = Steps::new(m, (1.0 + m * m).sqrt(), 2 * w, g.stride);
                for _ in 0..400 {
                    let (row, col) = ((next() * h as f64) as usize, (next() * w as f64) as usize);
                    let lo = (next() * 30.0) as usize;
                    let hi = lo + 1 + (next() * 6.0) as usize;
                    let window = steps.window(&g, wrap, row, col, lo, hi);
                    let trace = steps.trace(&g, wrap, row, col, lo as f64, hi as f64);
                    assert_eq!(window, trace, "wrap {wrap}, m {m}, texel ({row}, {col}), columns ({lo}, {hi}]");
                    compared += window.is_some() as usize;
                }
            }
        }
        assert!(compared > 2000, "only {compared} windows had a sample");
    }

    #[test]
    fn wrap_index_is_the_euclidean_remainder() {
        for n in [1i64, 2, 7, 64] {
            for i in -5 * n - 3..5 * n + 3 {
                assert_eq!(wrap_index(i, n), i.rem_euclid(n) as usize, "{i} mod {n}");
            }
        }
    }
}
