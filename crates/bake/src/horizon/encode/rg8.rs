//! The 8-bit slope code of `Rg8Unorm` horizons, `β / π + 0.5` as a unorm, without an `atan` per
//! texel.
//!
//! The code is a step function of the slope `tan β`: a table indexed by the slope's top bits
//! gives a candidate, checked against the slopes where the code steps. Those are computed once,
//! in `f64`, and kept as a guard band around each step (±1e-5 rad of β, far wider than the
//! `f32` rounding of the formula): a slope inside a band is settled by the formula itself, so
//! every code is exactly what the formula gives.

use std::cmp::Ordering;
use std::sync::LazyLock;

/// `x` in [0, 1] as an 8-bit unorm (clamped, rounded half away from zero).
#[inline]
pub(crate) fn unorm(x: f32) -> u8 {
    round_byte(x.clamp(0.0, 1.0) * 255.0)
}

/// `y.round() as u8` for `y` in [0, 255] (0 for NaN), without the library call `round` is on
/// baseline x86-64: the fraction `y - trunc(y)` is exact there.
#[inline(always)]
fn round_byte(y: f32) -> u8 {
    let t = y as u32;
    (t + (y - t as f32 >= 0.5) as u32) as u8
}

/// The smallest 8-bit code whose slope is not below `tan β`: `⌈255 (β / π + 0.5)⌉`, and 0 (open
/// sky) for the open-sky slope. A stored code never lets more light in than the slope.
pub(crate) fn code_up(slope: f32) -> u8 {
    if slope <= super::OPEN_SKY_SLOPE {
        return 0;
    }
    let x = ((slope as f64).atan() / std::f64::consts::PI + 0.5) * 255.0;
    x.ceil().clamp(0.0, 255.0) as u8
}

/// `x` in [0, 1] as an 8-bit unorm rounded down (never above `x`).
pub(crate) fn unorm_down(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) as f64 * 255.0).floor() as u8
}

/// The 8-bit code of slope `tan β` by its definition, `unorm(β / π + 0.5)`.
fn by_formula(slope: f32) -> u8 {
    unorm(slope.atan() / std::f32::consts::PI + 0.5)
}

/// Per code `c`, the slopes safely below (`below[c]`) and above (`above[c]`) every slope whose
/// code is `c`; and per bucket of slopes (see [`bucket`]), the code of its lowest slope.
struct CodeTable {
    below: [f32; 256],
    above: [f32; 256],
    first: Vec<u8>,
}

/// Buckets of 1/64 of an octave: codes step at least 2.4% apart in slope, so a bucket holds at
/// most one step.
const BUCKET_SHIFT: u32 = 17;

/// The bucket of `slope`: the top bits of a key that orders like the slope does.
#[inline(always)]
fn bucket(slope: f32) -> usize {
    (key(slope) >> BUCKET_SHIFT) as usize
}

/// A key that orders like the slope: negative slopes' bits flipped, positive ones' sign set.
#[inline(always)]
fn key(slope: f32) -> u32 {
    let bits = slope.to_bits();
    if bits >> 31 == 1 { !bits } else { bits | 0x8000_0000 }
}

/// The slope of a [`key`].
fn from_key(key: u32) -> f32 {
    f32::from_bits(if key >> 31 == 1 { key & 0x7fff_ffff } else { !key })
}

static TABLE: LazyLock<CodeTable> = LazyLock::new(|| {
    // Code c holds β/π + 0.5 within half a step of c/255; widened by 1e-5 rad for rounding.
    let edge = |c: f64, pad: f64| (((c / 255.0) - 0.5) * std::f64::consts::PI + pad).tan() as f32;
    let mut below = [f32::NEG_INFINITY; 256];
    let mut above = [f32::INFINITY; 256];
    for c in 0..256 {
        if c > 0 {
            below[c] = edge(c as f64 - 0.5, -1e-5);
        }
        if c < 255 {
            above[c] = edge(c as f64 + 0.5, 1e-5);
        }
    }
    let first = (0..1u32 << (32 - BUCKET_SHIFT)).map(|b| by_formula(from_key(b << BUCKET_SHIFT))).collect();
    CodeTable { below, above, first }
});

/// The 8-bit code of slope `tan β` (equal to [`by_formula`]).
#[inline]
pub(crate) fn code(slope: f32) -> u8 {
    let g = &*TABLE;
    // A candidate from the slope's bucket, settled when the slope lies clear of the bands of
    // the steps below and above it.
    let c0 = g.first[bucket(slope)] as usize;
    let c = c0 + (slope > g.above[c0]) as usize;
    let clear = (c == 0 || slope > g.above[c - 1]) && (c == 255 || slope < g.below[c + 1]);
    if clear { c as u8 } else { by_formula(slope) }
}

/// `code(slope).cmp(&stored)`, usually without computing the code.
#[inline]
pub(crate) fn compare(slope: f32, stored: u8) -> Ordering {
    let g = &*TABLE;
    if slope > g.above[stored as usize] {
        Ordering::Greater
    } else if slope < g.below[stored as usize] {
        Ordering::Less
    } else {
        by_formula(slope).cmp(&stored)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_round_as_round_does() {
        let mut ys = vec![0.0f32, 255.0, f32::NAN, 0.5f32.next_down(), 254.5f32.next_up()];
        for k in 0..255 {
            let mut half = k as f32 + 0.5;
            let mut below = half;
            for _ in 0..16 {
                ys.extend([half, below]);
                half = half.next_up();
                below = below.next_down();
            }
        }
        ys.extend((0..=2_550_000).map(|i| i as f32 * 1e-4));
        for y in ys {
            assert_eq!(round_byte(y), y.round() as u8, "{y}");
        }
    }

    #[test]
    fn codes_equal_the_formula() {
        // Every code step, approached from both sides in single ulps, and a sweep of slopes
        // spread over all angles and magnitudes.
        let mut slopes = vec![f32::MIN, -65504.0, -1e9, 0.0, -0.0, 1e-30, 1e9, f32::MAX];
        for c in 0..255 {
            let step = (((c as f64 + 0.5) / 255.0 - 0.5) * std::f64::consts::PI).tan() as f32;
            let mut lo = step;
            let mut hi = step;
            for _ in 0..64 {
                slopes.extend([lo, hi]);
                lo = lo.next_down();
                hi = hi.next_up();
            }
        }
        slopes.extend((-200_000..200_000).map(|i| (i as f32 * 1e-5).tan() * (i as f32 * 1e-5).abs().exp()));
        // The format's definition, written out here with the standard library's rounding.
        let want = |s: f32| ((s.atan() / std::f32::consts::PI + 0.5).clamp(0.0, 1.0) * 255.0).round() as u8;
        for s in slopes {
            assert!(key(s) >= key(s.next_down()), "key order at {s}");
            assert_eq!(from_key(key(s)).to_bits(), s.to_bits(), "key round trip at {s}");
            assert_eq!(code(s), want(s), "slope {s}");
            for stored in [0u8, 1, 127, 128, 200, 254, 255, want(s)] {
                assert_eq!(compare(s, stored), want(s).cmp(&stored), "slope {s} vs {stored}");
            }
        }
    }
}
