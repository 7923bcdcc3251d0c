//! How a horizon texel is stored: the three formats, the open-sky value, and the one encoder
//! and decoder of `(tan β, d)` every part of the baker uses.

pub(super) mod rg8;

use hikage_bundle::settings::decode_horizon_texel;
use hikage_bundle::{TextureData, TextureDesc, TextureFormat, bc};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::HorizonTexture;
use crate::bc4::Side;

/// Slope stored for a ray that has no sample (clamp mode, at the edge looking out). It is the
/// most negative half float, so it survives every storage format (rg8 stores β = −90°).
pub const OPEN_SKY_SLOPE: f32 = -65504.0;

/// Storage of the horizon texture: channel 0 is `tan β`, channel 1 is `d`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum HorizonFormat {
    /// Half floats (default): one fetch gives both, 4 bytes per texel-direction.
    #[default]
    #[cfg_attr(feature = "clap", value(name = "rg16f"))]
    Rg16Float,
    /// 32-bit floats, exact.
    #[cfg_attr(feature = "clap", value(name = "rg32f"))]
    Rg32Float,
    /// 8-bit, the paper's memory: channel 0 is `β / π + 0.5` (β in radians, so ±90° map to
    /// 0 and 1, a step of 0.71°), channel 1 is `d / distance_scale`.
    #[cfg_attr(feature = "clap", value(name = "rg8"))]
    Rg8Unorm,
    /// BC5 blocks, 1 byte per texel-direction (0.25× rg16f): rg8's two codes, each rounded
    /// toward shadow (slope up, distance down) and block-encoded never past that side, so no
    /// texel is lit that the exact bake shadows. Baked as rg32f, then encoded.
    #[cfg_attr(feature = "clap", value(name = "bc5"))]
    Bc5RgUnorm,
}

impl HorizonFormat {
    /// The texture format.
    pub fn texture_format(self) -> TextureFormat {
        match self {
            HorizonFormat::Rg16Float => TextureFormat::Rg16Float,
            HorizonFormat::Rg32Float => TextureFormat::Rg32Float,
            HorizonFormat::Rg8Unorm => TextureFormat::Rg8Unorm,
            HorizonFormat::Bc5RgUnorm => TextureFormat::Bc5RgUnorm,
        }
    }

    /// The format texels are baked in before any block encoding: itself, or rg32f for BC5.
    pub(crate) fn working(self) -> HorizonFormat {
        match self {
            HorizonFormat::Bc5RgUnorm => HorizonFormat::Rg32Float,
            f => f,
        }
    }

    /// Whether channel 1 is stored over a distance scale (the 8-bit formats).
    pub(crate) fn scales_distance(self) -> bool {
        matches!(self, HorizonFormat::Rg8Unorm | HorizonFormat::Bc5RgUnorm)
    }
}

/// A texture baked in rg32f encoded as `format`'s blocks (BC5: the conservative codes of
/// [`rg8::code_up`] and [`rg8::unorm_down`], block-encoded toward the same sides); any other
/// format as it is.
pub(super) fn finish(format: HorizonFormat, mut baked: HorizonTexture) -> HorizonTexture {
    if format != HorizonFormat::Bc5RgUnorm {
        return baked;
    }
    let distance_scale = baked.distance_scale;
    let codes: Vec<u8> = baked.texture.levels[0]
        .par_chunks_exact(8)
        .flat_map_iter(|t| {
            let slope = f32::from_le_bytes([t[0], t[1], t[2], t[3]]);
            let dist = f32::from_le_bytes([t[4], t[5], t[6], t[7]]);
            [rg8::code_up(slope), rg8::unorm_down(dist / distance_scale)]
        })
        .collect();
    let rg8 = TextureData {
        desc: TextureDesc { format: TextureFormat::Rg8Unorm, ..baked.texture.desc.clone() },
        levels: vec![codes],
    };
    baked.texture = crate::bc4::compress(&rg8, &[Side::Above, Side::Below]);
    baked
}

/// Writes a row of texels (`tan β`, `d`) in `format` into `out` (exactly `s.len()` texels), in
/// reverse order when `reversed`. A slope of `-∞` (no sample) becomes the open-sky value. Half
/// floats are converted a row at a time (F16C where the processor has it); `halves` is scratch.
pub(super) fn encode_row(
    format: HorizonFormat,
    s: &mut [f32],
    t: &mut [f32],
    distance_scale: f32,
    out: &mut [u8],
    reversed: bool,
    halves: &mut Vec<half::f16>,
) {
    for (s, t) in s.iter_mut().zip(t.iter_mut()) {
        if *s < -1.0e20 {
            (*s, *t) = (OPEN_SKY_SLOPE, 0.0);
        }
    }
    let (tb, n) = (format.texture_format().texel_bytes(), s.len());
    if format != HorizonFormat::Rg16Float {
        for (i, (&s, &t)) in s.iter().zip(t.iter()).enumerate() {
            let j = if reversed { n - 1 - i } else { i };
            encode(format, s, t, distance_scale, &mut out[j * tb..(j + 1) * tb]);
        }
        return;
    }
    use half::slice::HalfFloatSliceExt;
    s.iter_mut().zip(t.iter_mut()).for_each(|(s, t)| (*s, *t) = f16_range(*s, *t));
    halves.resize(2 * n, half::f16::ZERO);
    let (hs, ht) = halves.split_at_mut(n);
    hs.convert_from_f32_slice(s);
    ht.convert_from_f32_slice(t);
    let texels = out.chunks_exact_mut(4);
    let write = |(o, (&s, &t)): (&mut [u8], (&half::f16, &half::f16))| put_f16(o, s, t);
    if reversed {
        texels.rev().zip(hs.iter().zip(ht.iter())).for_each(write);
    } else {
        texels.zip(hs.iter().zip(ht.iter())).for_each(write);
    }
}

/// Writes one texel (`tan β`, `d`) in `format` into `out` (exactly one texel long).
pub(super) fn encode(format: HorizonFormat, slope: f32, dist: f32, distance_scale: f32, out: &mut [u8]) {
    match format {
        HorizonFormat::Rg8Unorm => {
            out[0] = rg8::code(slope);
            out[1] = rg8::unorm(dist / distance_scale);
        }
        HorizonFormat::Rg16Float => {
            let (s, d) = f16_range(slope, dist);
            put_f16(out, half::f16::from_f32(s), half::f16::from_f32(d));
        }
        // BC5 is baked in rg32f (`working`), then encoded.
        HorizonFormat::Rg32Float | HorizonFormat::Bc5RgUnorm => {
            // A slope past f32 (heights far apart over tiny texels) is vertical: it saturates.
            out[..4].copy_from_slice(&slope.clamp(-f32::MAX, f32::MAX).to_le_bytes());
            out[4..8].copy_from_slice(&dist.to_le_bytes());
        }
    }
}

/// A texel clamped to what an rg16f texel holds: slopes within ±`-OPEN_SKY_SLOPE`, distances
/// at most `-OPEN_SKY_SLOPE` (f16 would round larger values to infinity).
#[inline(always)]
fn f16_range(slope: f32, dist: f32) -> (f32, f32) {
    (slope.clamp(OPEN_SKY_SLOPE, -OPEN_SKY_SLOPE), dist.min(-OPEN_SKY_SLOPE))
}

/// Writes an rg16f texel into `out` (exactly one texel long).
#[inline(always)]
fn put_f16(out: &mut [u8], slope: half::f16, dist: half::f16) {
    out[..2].copy_from_slice(&slope.to_le_bytes());
    out[2..4].copy_from_slice(&dist.to_le_bytes());
}

/// Decodes texel `(k, row, col)` of a horizon texture to `(tan β, d)` (a BC5 texel as its block
/// decodes, rounded to 8 bits).
pub fn decode(texture: &HorizonTexture, k: usize, row: usize, col: usize) -> (f32, f32) {
    let desc = &texture.texture.desc;
    if desc.format.is_block_compressed() {
        let levels = &texture.texture.levels[0];
        let [a, b] = bc::decode_texel(desc.format, levels, (desc.width, desc.height), (k, row, col));
        let (a, b) = (a.round() / 255.0, b.round() / 255.0);
        return decode_horizon_texel(desc.format, a, b, texture.distance_scale, OPEN_SKY_SLOPE);
    }
    let tb = desc.format.texel_bytes();
    let i = ((k * desc.height as usize + row) * desc.width as usize + col) * tb;
    let bytes = &texture.texture.levels[0][i..i + tb];
    let (a, b) = (desc.format.decode_channel(bytes, 0), desc.format.decode_channel(bytes, 1));
    decode_horizon_texel(desc.format, a, b, texture.distance_scale, OPEN_SKY_SLOPE)
}
