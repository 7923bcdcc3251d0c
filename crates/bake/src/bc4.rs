//! BC4 blocks (one unorm channel, 4×4 texels in 8 bytes; BC5 is two of them): the encoder of
//! the block-compressed formats, plain or conservative toward one side.
//!
//! A block stores two endpoints `r0 > r1` and a 3-bit index per texel into the eight values
//! `r0`, `r1` and the six between (`(r0·(7−k) + r1·k) / 7`, k = 1…6), which a GPU decodes
//! without rounding them to 8 bits. The plain encoder takes each texel's nearest value; a
//! conservative one never crosses the texel's true value on its side — [`Side::Below`] for relief
//! depth maps (a decoded depth above the true first hit would report a hit too deep),
//! [`Side::Above`] for horizon angles (a decoded horizon below the true one leaks light) — with
//! a step of 1/255 to spare on the interpolated values, for decoders that round them to 8 bits
//! in fixed point (lavapipe's come back up to 1.3 steps toward an endpoint).

use hikage_bundle::{TextureData, TextureDesc, TextureFormat};
use rayon::prelude::*;

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
///
/// The plain encoder puts the endpoints at the block's extremes. A conservative one needs only
/// the endpoint on its far side there (the largest texel must have a value at or above it for
/// [`Side::Above`]); the near endpoint may move inward, texels beyond it taking the endpoint
/// itself, which is on their safe side. It is searched (up to 32 places, evenly spaced) for the
/// least total error.
pub fn encode(texels: &[u8; 16], side: Side) -> [u8; 8] {
    let (lo, hi) = (*texels.iter().min().expect("16 texels"), *texels.iter().max().expect("16 texels"));
    // A flat block is stored with r0 = r1 + 1 (the eight-value mode needs r0 > r1).
    let extremes = if hi > lo {
        (hi, lo)
    } else if hi < 255 {
        (hi + 1, hi)
    } else {
        (255, 254)
    };
    let span = hi.saturating_sub(lo) as u32;
    let candidates = if side == Side::Nearest { 0 } else { span.min(32) };
    let moved = |n: u32| (span * n / candidates.max(1)) as u8;
    let best = (0..candidates)
        .map(|n| match side {
            Side::Above => (hi, lo + moved(n)),
            _ => (hi - moved(n), lo),
        })
        .map(|(r0, r1)| (r0, r1, indices(texels, r0, r1, side)))
        .min_by(|a, b| a.2.1.total_cmp(&b.2.1));
    let (r0, r1, (bits, _)) =
        best.unwrap_or_else(|| (extremes.0, extremes.1, indices(texels, extremes.0, extremes.1, side)));
    let mut out = [0u8; 8];
    out[0] = r0;
    out[1] = r1;
    out[2..].copy_from_slice(&bits.to_le_bytes()[..6]);
    out
}

/// Each texel's index into the eight values of endpoints `r0 > r1` — the nearest one allowed on
/// `side` — packed as a block stores them, and the total error.
fn indices(texels: &[u8; 16], r0: u8, r1: u8, side: Side) -> (u64, f32) {
    let p = palette(r0, r1);
    let (mut bits, mut error) = (0u64, 0f32);
    for (i, &t) in texels.iter().enumerate() {
        let t = t as f32;
        // Endpoints decode exactly everywhere; the six values between them may come back a step
        // of 1/255 off, rounded toward either endpoint (lavapipe interpolates in 8-bit fixed
        // point and is off by up to 1.3), so a conservative side keeps them a whole step clear.
        let ok = |k: usize| {
            let margin = if k < 2 { 0.0 } else { 1.0 };
            match side {
                Side::Nearest => true,
                Side::Below => p[k] <= t - margin,
                Side::Above => p[k] >= t + margin,
            }
        };
        let best = (0..8)
            .filter(|&k| ok(k))
            .min_by(|&a, &b| (p[a] - t).abs().total_cmp(&(p[b] - t).abs()))
            .expect("the far endpoint is on every texel's side, the near one past it");
        bits |= (best as u64) << (3 * i);
        error += (p[best] - t).abs();
    }
    (bits, error)
}

/// Decodes one block to its 16 values, in units of 1/255, as a GPU decodes them (both modes).
pub use hikage_bundle::bc::decode_block as decode;

/// Encodes an `R8Unorm` or `Rg8Unorm` texture (every level, slice and layer) as BC4 or BC5,
/// channel `c` off only toward `sides[c]`. Blocks past an edge repeat the edge's texels.
/// Slices are encoded in parallel; the output does not depend on the thread count.
pub fn compress(texture: &TextureData, sides: &[Side]) -> TextureData {
    let channels = texture.desc.format.channels();
    debug_assert!(texture.desc.format.is_unorm() && !texture.desc.format.is_block_compressed());
    debug_assert_eq!(sides.len(), channels);
    let format = if channels == 1 { TextureFormat::Bc4RUnorm } else { TextureFormat::Bc5RgUnorm };
    let desc = TextureDesc { format, ..texture.desc.clone() };
    let levels = (0..desc.levels)
        .map(|l| {
            let (w, h, _) = desc.level_extent(l);
            let (w, h) = (w as usize, h as usize);
            let slice_blocks = w.div_ceil(4) * h.div_ceil(4) * 8 * channels;
            let texels = &texture.levels[l as usize];
            let mut out = vec![0u8; desc.level_bytes(l).expect("the texture's own size") as usize];
            out.par_chunks_mut(slice_blocks).zip(texels.par_chunks(w * h * channels)).for_each(|(out, slice)| {
                let mut blocks = out.chunks_exact_mut(8 * channels);
                for by in (0..h).step_by(4) {
                    for bx in (0..w).step_by(4) {
                        let block = blocks.next().expect("one block per 4×4 square");
                        for (c, &side) in sides.iter().enumerate() {
                            let at = |i: usize| {
                                let (x, y) = ((bx + i % 4).min(w - 1), (by + i / 4).min(h - 1));
                                slice[(y * w + x) * channels + c]
                            };
                            block[8 * c..8 * c + 8].copy_from_slice(&encode(&std::array::from_fn(at), side));
                        }
                    }
                }
            });
            out
        })
        .collect();
    TextureData { desc, levels }
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
    /// encoders never cross their side (their values between the endpoints a step clear of it)
    /// and stay within a palette step and that spare step per texel on the whole, the plain one
    /// within half a step of each texel, and a
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
            let (below_block, above_block) = (encode(b, Side::Below), encode(b, Side::Above));
            let (below, above) = (decode(&below_block), decode(&above_block));
            let nearest = decode(&encode(b, Side::Nearest));
            // An endpoint may meet the texel; a value between the endpoints keeps a step clear.
            let endpoint = |block: &[u8; 8], v: f32| v == block[0] as f32 || v == block[1] as f32;
            let (mut below_error, mut above_error) = (0.0, 0.0);
            for i in 0..16 {
                let t = b[i] as f32;
                let clear = |v: f32, block: &[u8; 8]| endpoint(block, v) || (v - t).abs() >= 1.0;
                assert!(below[i] <= t && clear(below[i], &below_block), "{b:?}: {} for {t}", below[i]);
                assert!(above[i] >= t && clear(above[i], &above_block), "{b:?}: {} for {t}", above[i]);
                assert!((nearest[i] - t).abs() <= step / 2.0 + 1e-3, "{b:?}: {} for {t}", nearest[i]);
                (below_error, above_error) = (below_error + t - below[i], above_error + above[i] - t);
            }
            // The endpoint search never does worse than the block's extremes, whose values are
            // a palette step apart: each texel within that step and the spare one.
            assert!(below_error <= 16.0 * (step + 1.0) + 1e-2, "{b:?}: total {below_error}");
            assert!(above_error <= 16.0 * (step + 1.0) + 1e-2, "{b:?}: total {above_error}");
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
