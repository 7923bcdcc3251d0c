//! Ambient occlusion derived from baked horizons, for free.

use hikage_bundle::{Supercompression, TextureData, TextureDesc, TextureDimension, TextureFormat};

use super::{HorizonTexture, decode};

/// Ambient occlusion from horizons: per texel, the occluded share of the cosine-weighted
/// hemisphere, `mean over directions of sin² β⁺` (β⁺ = max(β, 0)). A one-level R16Float 2D
/// texture, channel `occlusion` (0 open, 1 fully occluded).
pub fn ambient_occlusion(texture: &HorizonTexture) -> TextureData {
    let desc = &texture.texture.desc;
    let (w, h, d) = (desc.width as usize, desc.height as usize, desc.depth as usize);
    let mut occlusion = vec![0.0f32; w * h];
    for k in 0..d {
        for row in 0..h {
            for col in 0..w {
                let (s, _) = decode(texture, k, row, col);
                if s > 0.0 {
                    // sin² β = s² / (1 + s²), which is 1 for a slope whose square overflows.
                    let s2 = s * s;
                    occlusion[row * w + col] += if s2.is_finite() { s2 / (1.0 + s2) } else { 1.0 };
                }
            }
        }
    }
    occlusion.iter_mut().for_each(|o| *o /= d as f32);
    let ao_desc = TextureDesc {
        format: TextureFormat::R16Float,
        dimension: TextureDimension::D2,
        width: desc.width,
        height: desc.height,
        depth: 1,
        layers: 1,
        levels: 1,
        supercompression: Supercompression::None,
        channels: vec!["occlusion".into()],
    };
    TextureData::from_f32(ao_desc, &occlusion).expect("sizes match by construction")
}
