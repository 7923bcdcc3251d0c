//! The near field: the first `K` texels of every ray, exactly, at every grid-line crossing.
//!
//! Rays start at texel centres, so in canonical orientation the crossings of every ray of one
//! direction sit at the same offsets: the near field is a fixed stencil of taps, each a linear
//! interpolation between two texels on one grid line. A row is taken 16 texels at a time, every
//! tap applied to them while their best values stay in registers: a straight, branch-free loop
//! the compiler vectorises; an AVX2 build of it is chosen at run time where the processor has it
//! (results are identical: Rust never fuses multiply-adds, and each texel sees the taps in order).
//!
//! Cost: `O(N · K · (1 + |m|))` per direction, `O(W + H)` extra memory beyond the padded grid.

use std::ops::Range;

use super::grid::Grid;

/// One crossing of the stencil: `lerp(A, B, f)` with `A` at (row + `ra`, col + `ca`) and `B` at
/// (row + `rb`, col + `cb`), at world distance `t`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tap {
    pub ra: isize,
    pub ca: usize,
    pub rb: isize,
    pub cb: usize,
    pub f: f32,
    pub t: f32,
    /// `1 / t`.
    pub inv_t: f32,
}

/// The stencil of a canonical direction with row slope `m`: every crossing with column
/// displacement in `(0, reach]`, sorted by distance.
pub(crate) fn stencil(m: f64, step_len: f64, reach: f64) -> Vec<Tap> {
    let mut taps = Vec::new();
    // Column crossings: one column further each time.
    let mut du = 1usize;
    while du as f64 <= reach + 1e-9 {
        let (r, f) = split(m * du as f64);
        let t = (du as f64 * step_len) as f32;
        taps.push(Tap { ra: r as isize, ca: du, rb: r as isize + 1, cb: du, f, t, inv_t: 1.0 / t });
        du += 1;
    }
    // Row crossings: one row further each time.
    if m != 0.0 {
        let mut dv = 1usize;
        loop {
            let du = dv as f64 / m.abs();
            if du > reach + 1e-9 {
                break;
            }
            let (c, f) = split(du);
            if f > 0.0 {
                let row = if m > 0.0 { dv as isize } else { -(dv as isize) };
                let t = (du * step_len) as f32;
                taps.push(Tap { ra: row, ca: c as usize, rb: row, cb: c as usize + 1, f, t, inv_t: 1.0 / t });
            }
            dv += 1;
        }
    }
    taps.sort_by(|a, b| a.t.total_cmp(&b.t));
    taps
}

/// Applies the stencil to the texels `cols` of canonical row `row`: `best_s`/`best_t` receive,
/// per texel, the greatest slope over the taps and the distance where it occurs. A texel's
/// result does not depend on which others are computed with it.
pub(crate) fn row(g: &Grid, taps: &[Tap], row: usize, cols: Range<usize>, best_s: &mut [f32], best_t: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            unsafe { row_avx2(g, taps, row, cols, best_s, best_t) };
            return;
        }
    }
    row_generic(g, taps, row, cols, best_s, best_t);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn row_avx2(g: &Grid, taps: &[Tap], row: usize, cols: Range<usize>, best_s: &mut [f32], best_t: &mut [f32]) {
    row_generic(g, taps, row, cols, best_s, best_t);
}

/// Texels of a row whose best values stay in registers while every tap is applied to them: with
/// a tap at a time over the whole row, each tap reloaded and stored both best values per texel.
const CHUNK: usize = 16;

#[inline(always)]
fn row_generic(g: &Grid, taps: &[Tap], row: usize, cols: Range<usize>, best_s: &mut [f32], best_t: &mut [f32]) {
    // Whole chunks, then the rest of the row a texel at a time: the same steps either way.
    let whole = cols.end - cols.len() % CHUNK;
    for col in (cols.start..whole).step_by(CHUNK) {
        chunk::<CHUNK>(g, taps, row, col, best_s, best_t);
    }
    for col in whole..cols.end {
        chunk::<1>(g, taps, row, col, best_s, best_t);
    }
}

/// Applies every tap, in stencil order, to the `N` texels of canonical row `row` from column
/// `col`, writing their best slopes and distances to `best_s`/`best_t` at the same columns.
#[inline(always)]
fn chunk<const N: usize>(g: &Grid, taps: &[Tap], row: usize, col: usize, best_s: &mut [f32], best_t: &mut [f32]) {
    let chunk_of = |r: isize, c: usize| -> [f32; N] {
        g.padded_row(row as isize + r, c + col, N).try_into().expect("padded_row gives N heights")
    };
    let o = chunk_of(0, 0);
    let mut bs = [f32::NEG_INFINITY; N];
    let mut bt = [0.0f32; N];
    for tap in taps {
        let (a, b) = (chunk_of(tap.ra, tap.ca), chunk_of(tap.rb, tap.cb));
        // Whole arrays by value and the tap's numbers in locals: so the best values stay in
        // registers (through references, they were kept in memory, a masked store per tap).
        let (f, t, inv_t) = (tap.f, tap.t, tap.inv_t);
        let v: [f32; N] = std::array::from_fn(|i| slope(a[i], b[i], o[i], f, inv_t));
        bt = std::array::from_fn(|i| if v[i] > bs[i] { t } else { bt[i] });
        bs = std::array::from_fn(|i| if v[i] > bs[i] { v[i] } else { bs[i] });
    }
    best_s[col..col + N].copy_from_slice(&bs);
    best_t[col..col + N].copy_from_slice(&bt);
}

/// `tan β` of a tap (fraction `f`, distance `1 / inv_t`) from a texel of height `o`, where the
/// tap's two heights are `x` and `y`.
#[inline(always)]
fn slope(x: f32, y: f32, o: f32, f: f32, inv_t: f32) -> f32 {
    (x + f * (y - x) - o) * inv_t
}

/// `floor` as an integer without a libm call (baseline x86-64 has no rounding instruction).
#[inline(always)]
pub(crate) fn floor_i(x: f64) -> i64 {
    let t = x as i64;
    t - ((x < t as f64) as i64)
}

/// Splits a coordinate into a knot and a fraction, snapping within 1e-9 of a knot onto it.
#[inline]
pub(crate) fn split(y: f64) -> (f64, f32) {
    let r = floor_i(y) as f64;
    let f = y - r;
    if f > 1.0 - 1e-9 {
        (r + 1.0, 0.0)
    } else if f < 1e-9 {
        (r, 0.0)
    } else {
        (r, f as f32)
    }
}
