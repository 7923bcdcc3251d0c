//! Where a canonical ray crosses grid lines, tabulated once per direction.
//!
//! A canonical ray from a texel centre steps one column and `m` rows per step. Because rays
//! start at texel centres, the crossings of every ray of a direction sit at the same offsets:
//! column crossing `du` is `floor(m·du)` rows down and `frac(m·du)` of the way to the next row;
//! row crossing `dv` is at column displacement `dv / |m|`. The tables hold those offsets so the
//! sweep and the exact traces do no floor or division per sample.

use super::grid::Grid;
use super::near::{OUTSIDE, split};

pub(crate) struct Steps {
    /// Rows per column step.
    pub m: f64,
    /// World units per column step.
    pub step_len: f64,
    /// Column crossing `du`: whole rows below (`floor(m·du)`) and the fraction to the next row.
    pub col_r: Vec<i32>,
    pub col_f: Vec<f32>,
    /// Row crossing `dv` (index `dv`, entry 0 unused): column displacement, whole columns and
    /// fraction (0 where it coincides with a column crossing).
    pub row_du: Vec<f64>,
    pub row_c: Vec<i32>,
    pub row_f: Vec<f32>,
}

impl Steps {
    /// Tables for column displacements `0..=cols`.
    pub fn new(m: f64, step_len: f64, cols: usize) -> Steps {
        let mut col_r = Vec::with_capacity(cols + 1);
        let mut col_f = Vec::with_capacity(cols + 1);
        for du in 0..=cols {
            let (r, f) = split(m * du as f64);
            col_r.push(r as i32);
            col_f.push(f);
        }
        let am = m.abs();
        let rows = (am * cols as f64).floor() as usize + 1;
        let (mut row_du, mut row_c, mut row_f) = (vec![f64::INFINITY], vec![0], vec![0.0]);
        if am > 0.0 {
            for dv in 1..=rows {
                let du = dv as f64 / am;
                let (c, f) = split(du);
                row_du.push(du);
                row_c.push(c as i32);
                row_f.push(f);
            }
        }
        row_du.push(f64::INFINITY);
        Steps { m, step_len, col_r, col_f, row_du, row_c, row_f }
    }

    /// Traces the ray from canonical texel (`row`, `col`) exactly over column displacements
    /// `(lo, hi]`: every grid-line crossing on the map (wrapped on the torus, or only inside a
    /// clamped map). Returns the steepest `(tan β, d)`, or `None` when no crossing is on the map.
    #[inline]
    pub fn trace(&self, g: &Grid, wrap: bool, row: usize, col: usize, lo: f64, hi: f64) -> Option<(f32, f32)> {
        let h0 = g.at(row, col);
        // Best as (rise, run in columns), compared by cross-multiplication.
        let (mut rise, mut run) = (f32::NEG_INFINITY, 1.0f32);
        let mut consider = |v: f32, du: f32| {
            let r = v - h0;
            if r * run > rise * du {
                rise = r;
                run = du;
            }
        };
        let last = (hi + 1e-9).min((self.col_r.len() - 1) as f64) as usize;
        let first = super::near::floor_i(lo) + 1;
        for du in first.max(1) as usize..=last {
            let r = row as i64 + self.col_r[du] as i64;
            let c = col as i64 + du as i64;
            let v = lerp_at(g, wrap, r, c, r + 1, c, self.col_f[du]);
            if v > OUTSIDE {
                consider(v, du as f32);
            }
        }
        if self.m != 0.0 {
            let down = self.m < 0.0;
            let mut dv = super::near::floor_i(lo.max(0.0) * self.m.abs()).max(0) as usize + 1;
            while dv < self.row_du.len() && self.row_du[dv] <= hi + 1e-9 {
                let du = self.row_du[dv];
                if self.row_f[dv] > 0.0 && du > lo + 1e-9 {
                    let r = if down { row as i64 - dv as i64 } else { row as i64 + dv as i64 };
                    let c = col as i64 + self.row_c[dv] as i64;
                    let v = lerp_at(g, wrap, r, c, r, c + 1, self.row_f[dv]);
                    if v > OUTSIDE {
                        consider(v, du as f32);
                    }
                }
                dv += 1;
            }
        }
        (rise > f32::NEG_INFINITY).then(|| {
            let t = run as f64 * self.step_len;
            ((rise as f64 / t) as f32, t as f32)
        })
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
    if i >= 0 && i < n { i as usize } else { i.rem_euclid(n) as usize }
}
