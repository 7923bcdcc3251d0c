//! The near field: the first `K` texels of every ray, exactly, at every grid-line crossing.
//!
//! Rays start at texel centres, so in canonical orientation the crossings of every ray of one
//! direction sit at the same offsets: the near field is a fixed stencil of taps, each a linear
//! interpolation between two texels on one grid line. Applying a tap to a whole row at once is a
//! straight, branch-free loop the compiler vectorises; an AVX2 build of the loop is chosen at run
//! time where the processor has it (results are identical: Rust never fuses multiply-adds).
//!
//! Cost: `O(N · K · (1 + |m|))` per direction, `O(W + H)` extra memory beyond the padded grid.

use super::grid::Grid;

/// Height used outside a clamped map: far below anything real, yet finite so that
/// `a + 0 · (OUTSIDE - a)` stays `a`.
pub(crate) const OUTSIDE: f32 = -1.0e30;

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
}

/// The stencil of a canonical direction with row slope `m`: every crossing with column
/// displacement in `(0, reach]`, sorted by distance.
pub(crate) fn stencil(m: f64, step_len: f64, reach: f64) -> Vec<Tap> {
    let mut taps = Vec::new();
    // Column crossings: one column further each time.
    let mut du = 1usize;
    while du as f64 <= reach + 1e-9 {
        let (r, f) = split(m * du as f64);
        taps.push(Tap { ra: r as isize, ca: du, rb: r as isize + 1, cb: du, f, t: (du as f64 * step_len) as f32 });
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
                taps.push(Tap { ra: row, ca: c as usize, rb: row, cb: c as usize + 1, f, t: (du * step_len) as f32 });
            }
            dv += 1;
        }
    }
    taps.sort_by(|a, b| a.t.total_cmp(&b.t));
    taps
}

/// Applies the stencil to canonical row `row`: `best_s`/`best_t` receive, per texel, the
/// greatest slope over the taps and the distance where it occurs.
pub(crate) fn row(g: &Grid, taps: &[Tap], row: usize, best_s: &mut [f32], best_t: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            unsafe { row_avx2(g, taps, row, best_s, best_t) };
            return;
        }
    }
    row_generic(g, taps, row, best_s, best_t);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn row_avx2(g: &Grid, taps: &[Tap], row: usize, best_s: &mut [f32], best_t: &mut [f32]) {
    row_generic(g, taps, row, best_s, best_t);
}

#[inline(always)]
fn row_generic(g: &Grid, taps: &[Tap], row: usize, best_s: &mut [f32], best_t: &mut [f32]) {
    let w = g.w;
    let h0 = g.padded_row(row as isize, 0, w);
    best_s.fill(f32::NEG_INFINITY);
    best_t.fill(0.0);
    for tap in taps {
        let a = g.padded_row(row as isize + tap.ra, tap.ca, w);
        let b = g.padded_row(row as isize + tap.rb, tap.cb, w);
        let (f, t, inv_t) = (tap.f, tap.t, 1.0 / tap.t);
        for ((((bs, bt), &o), &x), &y) in best_s.iter_mut().zip(best_t.iter_mut()).zip(h0).zip(a).zip(b) {
            let v = (x + f * (y - x) - o) * inv_t;
            let better = v > *bs;
            *bs = if better { v } else { *bs };
            *bt = if better { t } else { *bt };
        }
    }
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
