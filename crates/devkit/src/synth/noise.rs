//! Tileable value noise built on an integer hash.

/// A hash of three integers to [0, 1) (a few rounds of multiply-xorshift).
pub fn hash01(x: i32, y: i32, seed: u32) -> f32 {
    let mut h =
        (x as u32).wrapping_mul(0x8da6_b343) ^ (y as u32).wrapping_mul(0xd816_3841) ^ seed.wrapping_mul(0xcb1a_b31f);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^= h >> 12;
    h = h.wrapping_mul(0x297a_2d39);
    h ^= h >> 15;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// Smooth value noise at `(x, y)` (lattice units), repeating every `period` lattice cells on
/// both axes (`period` 0: no repetition).
pub fn value_noise(x: f32, y: f32, period: i32, seed: u32) -> f32 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (sx, sy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
    let wrap = |i: i32| if period > 0 { i.rem_euclid(period) } else { i };
    let (ix, iy) = (x0 as i32, y0 as i32);
    let c = |dx: i32, dy: i32| hash01(wrap(ix + dx), wrap(iy + dy), seed);
    let top = c(0, 0) + (c(1, 0) - c(0, 0)) * sx;
    let bottom = c(0, 1) + (c(1, 1) - c(0, 1)) * sx;
    top + (bottom - top) * sy
}

/// Fractional Brownian motion: `octaves` of value noise, each of twice the frequency and
/// `gain` times the amplitude of the previous, normalised to [0, 1]. `base_period` lattice
/// cells span the tile at the first octave (0: not tileable).
pub fn fbm(x: f32, y: f32, octaves: u32, gain: f32, base_period: i32, seed: u32) -> f32 {
    let (mut sum, mut amp, mut norm, mut freq) = (0.0, 1.0, 0.0, 1.0);
    for o in 0..octaves {
        let period = if base_period > 0 { base_period << o } else { 0 };
        sum += amp * value_noise(x * freq, y * freq, period, seed.wrapping_add(o * 1013));
        norm += amp;
        amp *= gain;
        freq *= 2.0;
    }
    sum / norm
}
