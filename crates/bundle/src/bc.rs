//! BC4 and BC5 blocks as a GPU decodes them: for the readers that need texel values (export,
//! validation, CPU references) and for devices that cannot sample block formats, which get the
//! decoded 8-bit texture instead.
//!
//! A BC4 block is 8 bytes for 4×4 texels of one channel: two endpoint bytes `r0`, `r1`, then a
//! 3-bit index per texel (row-major, little-endian) into eight values. When `r0 > r1` they are
//! `r0`, `r1` and the six between, `(r0·(7−k) + r1·k) / 7` for k = 1…6; otherwise `r0`, `r1`, the
//! four between, `(r0·(5−k) + r1·k) / 5` for k = 1…4, then 0 and 255. A BC5 block is two BC4
//! blocks, red then green. Blocks cover whole 4×4 squares; texels past a level's edge are not
//! read.

use crate::texture::{TextureDesc, TextureFormat};

/// The 16 values of a BC4 block (row-major), in units of 1/255, unrounded as a GPU decodes them.
pub fn decode_block(block: &[u8; 8]) -> [f32; 16] {
    let (a, b) = (block[0] as f32, block[1] as f32);
    let mut p = [a, b, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    if block[0] > block[1] {
        for k in 1..=6 {
            p[k + 1] = (a * (7 - k) as f32 + b * k as f32) / 7.0;
        }
    } else {
        for k in 1..=4 {
            p[k + 1] = (a * (5 - k) as f32 + b * k as f32) / 5.0;
        }
        p[7] = 255.0;
    }
    let mut bits = [0u8; 8];
    bits[..6].copy_from_slice(&block[2..]);
    let bits = u64::from_le_bytes(bits);
    std::array::from_fn(|i| p[((bits >> (3 * i)) & 7) as usize])
}

/// The values of one texel of a BC4 or BC5 level of `width` × `height` texels (`blocks`, its
/// bytes), unrounded, in units of 1/255: channel 0, and channel 1 for BC5 (0 for BC4).
pub fn decode_texel(
    format: TextureFormat,
    blocks: &[u8],
    (width, height): (u32, u32),
    (slice, row, col): (usize, usize, usize),
) -> [f32; 2] {
    let (bw, bh) = ((width as usize).div_ceil(4), (height as usize).div_ceil(4));
    let at = ((slice * bh + row / 4) * bw + col / 4) * format.block_bytes();
    let i = row % 4 * 4 + col % 4;
    let half = |c: usize| decode_block(blocks[at + 8 * c..at + 8 * c + 8].try_into().expect("8 bytes"))[i];
    [half(0), if format.channels() == 2 { half(1) } else { 0.0 }]
}

/// Level `level` of a BC4 or BC5 texture (`blocks`, exactly [`TextureDesc::level_bytes`] long)
/// decoded to `R8Unorm` or `Rg8Unorm` texels, each value rounded to the nearest byte. Rounding
/// keeps a conservative encoding's side: a value never above (or below) an integer stays so.
pub fn decode_level(desc: &TextureDesc, level: u32, blocks: &[u8]) -> Vec<u8> {
    let channels = desc.format.channels();
    let block_bytes = desc.format.block_bytes();
    debug_assert!(matches!(desc.format, TextureFormat::Bc4RUnorm | TextureFormat::Bc5RgUnorm));
    let (w, h, d) = desc.level_extent(level);
    let (w, h) = (w as usize, h as usize);
    let (bw, bh) = (w.div_ceil(4), h.div_ceil(4));
    let slices = d as usize * desc.layers as usize;
    let mut out = vec![0u8; w * h * slices * channels];
    for (b, block) in blocks.chunks_exact(block_bytes).enumerate().take(bw * bh * slices) {
        let (slice, by, bx) = (b / (bw * bh), b / bw % bh, b % bw);
        for c in 0..channels {
            let values = decode_block(block[8 * c..8 * c + 8].try_into().expect("8-byte half"));
            for (i, v) in values.into_iter().enumerate() {
                let (x, y) = (bx * 4 + i % 4, by * 4 + i / 4);
                if x < w && y < h {
                    out[((slice * h + y) * w + x) * channels + c] = v.round() as u8;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::{Supercompression, TextureDimension};

    /// A block written by hand in both modes decodes to the values the layout gives.
    #[test]
    fn hand_written_blocks_decode_in_both_modes() {
        let block = |r0: u8, r1: u8, indices: [u64; 16]| {
            let bits = indices.iter().enumerate().fold(0u64, |acc, (i, &k)| acc | k << (3 * i));
            let mut b = [r0, r1, 0, 0, 0, 0, 0, 0];
            b[2..].copy_from_slice(&bits.to_le_bytes()[..6]);
            b
        };
        let idx: [u64; 16] = std::array::from_fn(|i| (i % 8) as u64);
        // r0 > r1: 200, 60, then (6·200 + 60)/7 = 180 … (200 + 6·60)/7 = 80.
        let d = decode_block(&block(200, 60, idx));
        assert_eq!(&d[..8], &[200.0, 60.0, 180.0, 160.0, 140.0, 120.0, 100.0, 80.0]);
        // r0 ≤ r1: 50, 100, then (4·50 + 100)/5 = 60 … 90, then 0 and 255.
        let d = decode_block(&block(50, 100, idx));
        assert_eq!(&d[..8], &[50.0, 100.0, 60.0, 70.0, 80.0, 90.0, 0.0, 255.0]);
    }

    /// A 6 × 5 BC5 level (partial blocks at the right and bottom) decodes each channel from
    /// its own half, in place, whole or a texel at a time.
    #[test]
    fn levels_decode_blocks_into_place() {
        let desc = TextureDesc {
            format: TextureFormat::Bc5RgUnorm,
            dimension: TextureDimension::D2,
            width: 6,
            height: 5,
            depth: 1,
            layers: 1,
            levels: 1,
            supercompression: Supercompression::None,
            channels: vec!["r".into(), "g".into()],
        };
        assert_eq!(desc.level_bytes(0), Some(4 * 16));
        // Every red half is flat at its block's number × 10, every green half flat at 255 − that
        // (r0 = r1 in the six-value mode: index 0 everywhere).
        let blocks: Vec<u8> = (0..4u8)
            .flat_map(|b| [b * 10, b * 10, 0, 0, 0, 0, 0, 0, 255 - b * 10, 255 - b * 10, 0, 0, 0, 0, 0, 0])
            .collect();
        let texels = decode_level(&desc, 0, &blocks);
        assert_eq!(texels.len(), 6 * 5 * 2);
        for y in 0..5 {
            for x in 0..6 {
                let b = (y / 4 * 2 + x / 4) as u8;
                let want = [b * 10, 255 - b * 10];
                assert_eq!(&texels[(y * 6 + x) * 2..][..2], &want, "texel ({x}, {y})");
                let one = decode_texel(desc.format, &blocks, (6, 5), (0, y, x));
                assert_eq!(one, want.map(f32::from), "texel ({x}, {y}) alone");
            }
        }
    }
}
