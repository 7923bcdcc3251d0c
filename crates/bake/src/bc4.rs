//! BC4 blocks (one unorm channel, 4×4 texels in 8 bytes; BC5 is two of them): the encoder the
//! block-compressed formats will use, plain or conservative toward one side.
//!
//! A block stores two endpoints `r0 > r1` and a 3-bit index per texel into the eight values
//! `r0`, `r1` and the six between (`(r0·(7−k) + r1·k) / 7`, k = 1…6), which a GPU decodes
//! without rounding them to 8 bits. The plain encoder takes each texel's nearest value; a
//! conservative one never crosses the texel's true value on its side — [`Side::Below`] for relief
//! depth maps (a decoded depth above the true first hit would report a hit too deep),
//! [`Side::Above`] for horizon angles (a decoded horizon below the true one leaks light).

/// Which way a texel may be off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The nearest value either way.
    Nearest,
    /// Never above the true value.
    Below,
    /// Never below the true value.
    Above,
}

/// The eight values of a block with endpoints `r0 > r1`, in units of 1/255 (exact sevenths).
fn palette(r0: u8, r1: u8) -> [f32; 8] {
    let (a, b) = (r0 as f32, r1 as f32);
    let mut p = [a, b, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    for k in 1..=6 {
        p[k + 1] = (a * (7 - k) as f32 + b * k as f32) / 7.0;
    }
    p
}

/// Encodes 16 texels (row-major 4×4, 8-bit unorm) as one BC4 block, off only toward `side`.
pub fn encode(texels: &[u8; 16], side: Side) -> [u8; 8] {
    let (lo, hi) = (*texels.iter().min().expect("16 texels"), *texels.iter().max().expect("16 texels"));
    // Endpoints at the block's extremes, so every texel has a value on either side of it; a
    // flat block is stored with r0 = r1 + 1 (the eight-value mode needs r0 > r1).
    let (r0, r1) = if hi > lo {
        (hi, lo)
    } else if hi < 255 {
        (hi + 1, hi)
    } else {
        (255, 254)
    };
    let p = palette(r0, r1);
    let mut bits = 0u64;
    for (i, &t) in texels.iter().enumerate() {
        let t = t as f32;
        let ok = |v: f32| match side {
            Side::Nearest => true,
            Side::Below => v <= t,
            Side::Above => v >= t,
        };
        let best = (0..8).filter(|&k| ok(p[k])).min_by(|&a, &b| (p[a] - t).abs().total_cmp(&(p[b] - t).abs()));
        bits |= (best.expect("the endpoints bracket every texel") as u64) << (3 * i);
    }
    let mut out = [0u8; 8];
    out[0] = r0;
    out[1] = r1;
    out[2..].copy_from_slice(&bits.to_le_bytes()[..6]);
    out
}

/// Decodes one block to its 16 values, in units of 1/255, as a GPU does (both modes).
pub fn decode(block: &[u8; 8]) -> [f32; 16] {
    let (r0, r1) = (block[0], block[1]);
    let p = if r0 > r1 {
        palette(r0, r1)
    } else {
        let (a, b) = (r0 as f32, r1 as f32);
        let mut p = [a, b, 0.0, 0.0, 0.0, 0.0, 0.0, 255.0];
        for k in 1..=4 {
            p[k + 1] = (a * (5 - k) as f32 + b * k as f32) / 5.0;
        }
        p
    };
    let mut bits = [0u8; 8];
    bits[..6].copy_from_slice(&block[2..]);
    let bits = u64::from_le_bytes(bits);
    std::array::from_fn(|i| p[((bits >> (3 * i)) & 7) as usize])
}

/// Encodes and decodes a whole `w × h` single-channel image (`texels`, row-major, at least
/// `w × h` of them) block by block: what a BC4 texture of it reads back as, in units of 1/255.
/// Blocks past an edge repeat the edge's texels, as texture encoders pad them.
pub fn round_trip(texels: &[u8], w: usize, h: usize, side: Side) -> Vec<f32> {
    let mut out = vec![0f32; w * h];
    let at = |x: usize, y: usize| texels[y.min(h - 1) * w + x.min(w - 1)];
    for by in (0..h).step_by(4) {
        for bx in (0..w).step_by(4) {
            let block: [u8; 16] = std::array::from_fn(|i| at(bx + i % 4, by + i / 4));
            let decoded = decode(&encode(&block, side));
            for (i, v) in decoded.into_iter().enumerate() {
                let (x, y) = (bx + i % 4, by + i / 4);
                if x < w && y < h {
                    out[y * w + x] = v;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks of every shape (flat, two values, ramps, noise, the extremes): the conservative
    /// encoders never cross their side, the plain one is within half a palette step, and a
    /// decoded block agrees with the BC4 layout written by hand for a known block.
    #[test]
    fn sides_hold_and_errors_stay_within_a_step() {
        let mut state = 0x2545_f491_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state as u8
        };
        let mut blocks: Vec<[u8; 16]> = vec![[0; 16], [255; 16], [7; 16], std::array::from_fn(|i| (i * 17) as u8)];
        blocks.push(std::array::from_fn(|i| if i % 2 == 0 { 3 } else { 250 }));
        for _ in 0..2000 {
            let (base, spread) = (next(), next() % 64 + 1);
            blocks.push(std::array::from_fn(|_| base.saturating_add(next() % spread)));
        }
        for b in &blocks {
            let (lo, hi) = (*b.iter().min().unwrap() as f32, *b.iter().max().unwrap() as f32);
            let step = ((hi - lo) / 7.0).max(1.0);
            let below = decode(&encode(b, Side::Below));
            let above = decode(&encode(b, Side::Above));
            let nearest = decode(&encode(b, Side::Nearest));
            for i in 0..16 {
                let t = b[i] as f32;
                assert!(below[i] <= t && t - below[i] <= step + 1e-3, "{b:?}: {} for {t}", below[i]);
                assert!(above[i] >= t && above[i] - t <= step + 1e-3, "{b:?}: {} for {t}", above[i]);
                assert!((nearest[i] - t).abs() <= step / 2.0 + 1e-3, "{b:?}: {} for {t}", nearest[i]);
            }
        }
        // r0 = 200, r1 = 60; texel 0 takes index 0 (200), texel 1 index 1 (60), texel 2 index 2
        // ((6·200 + 60)/7 = 180), the rest index 7 ((200 + 6·60)/7 = 80).
        let mut bits = 0u64;
        for i in 0..16u64 {
            bits |= [0, 1, 2].get(i as usize).copied().unwrap_or(7) << (3 * i);
        }
        let mut block = [200, 60, 0, 0, 0, 0, 0, 0];
        block[2..].copy_from_slice(&bits.to_le_bytes()[..6]);
        let d = decode(&block);
        assert_eq!(&d[..4], &[200.0, 60.0, 180.0, 80.0]);
        // An image of 6 × 5 (partial blocks at the right and bottom) keeps its size and sides.
        let image: Vec<u8> = (0..30).map(|i| (i * 37 % 256) as u8).collect();
        let below = round_trip(&image, 6, 5, Side::Below);
        assert_eq!(below.len(), 30);
        assert!(below.iter().zip(&image).all(|(&d, &t)| d <= t as f32));
    }
}
