//! Texture descriptions and in-memory texel data.
//!
//! Texel layout follows KTX2 and wgpu: level → layer → z slice → row (`v`) → column (`u`) →
//! channel, little-endian. Row 0 is the first row in memory (see `docs/conventions.md`).

use serde::{Deserialize, Serialize};

use crate::error::BundleError;

/// Texel formats hikage writes. Each maps to one Vulkan format (KTX2 `vkFormat`) and one
/// wgpu format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TextureFormat {
    /// One 8-bit unsigned normalised channel.
    R8Unorm,
    /// Two 8-bit unsigned normalised channels.
    Rg8Unorm,
    /// One half-float channel.
    R16Float,
    /// Two half-float channels.
    Rg16Float,
    /// Four half-float channels.
    Rgba16Float,
    /// One 32-bit float channel.
    R32Float,
    /// Two 32-bit float channels.
    Rg32Float,
    /// Four 32-bit float channels.
    Rgba32Float,
    /// One unsigned normalised channel in BC4 blocks: 4×4 texels in 8 bytes (half of `R8Unorm`).
    Bc4RUnorm,
    /// Two unsigned normalised channels in BC5 blocks: 4×4 texels in 16 bytes (half of
    /// `Rg8Unorm`), each channel a BC4 block.
    Bc5RgUnorm,
}

impl TextureFormat {
    /// Every format, for tests and argument parsing.
    pub const ALL: [TextureFormat; 10] = [
        TextureFormat::R8Unorm,
        TextureFormat::Rg8Unorm,
        TextureFormat::R16Float,
        TextureFormat::Rg16Float,
        TextureFormat::Rgba16Float,
        TextureFormat::R32Float,
        TextureFormat::Rg32Float,
        TextureFormat::Rgba32Float,
        TextureFormat::Bc4RUnorm,
        TextureFormat::Bc5RgUnorm,
    ];

    /// Channels per texel.
    pub fn channels(self) -> usize {
        use TextureFormat::*;
        match self {
            R8Unorm | R16Float | R32Float | Bc4RUnorm => 1,
            Rg8Unorm | Rg16Float | Rg32Float | Bc5RgUnorm => 2,
            Rgba16Float | Rgba32Float => 4,
        }
    }

    /// Bytes per channel (the KTX2 `typeSize`; 1 for the block formats, whose channels decode to
    /// 8-bit unorm).
    pub fn channel_bytes(self) -> usize {
        use TextureFormat::*;
        match self {
            R8Unorm | Rg8Unorm | Bc4RUnorm | Bc5RgUnorm => 1,
            R16Float | Rg16Float | Rgba16Float => 2,
            R32Float | Rg32Float | Rgba32Float => 4,
        }
    }

    /// Bytes per texel; for a block format, per texel of its [`decoded`](Self::decoded) format.
    pub fn texel_bytes(self) -> usize {
        self.channels() * self.channel_bytes()
    }

    /// True for the float formats (their texels must be finite).
    pub fn is_float(self) -> bool {
        self.channel_bytes() > 1
    }

    /// True for the block-compressed formats (BC4, BC5).
    pub fn is_block_compressed(self) -> bool {
        matches!(self, TextureFormat::Bc4RUnorm | TextureFormat::Bc5RgUnorm)
    }

    /// Texels along each side of a block: 4 for the block formats, 1 otherwise.
    pub fn block_side(self) -> u32 {
        if self.is_block_compressed() { 4 } else { 1 }
    }

    /// Bytes per block (per texel for the uncompressed formats).
    pub fn block_bytes(self) -> usize {
        match self {
            TextureFormat::Bc4RUnorm => 8,
            TextureFormat::Bc5RgUnorm => 16,
            f => f.texel_bytes(),
        }
    }

    /// The uncompressed format a block format decodes to (`R8Unorm`, `Rg8Unorm`); itself for
    /// the others.
    pub fn decoded(self) -> TextureFormat {
        match self {
            TextureFormat::Bc4RUnorm => TextureFormat::R8Unorm,
            TextureFormat::Bc5RgUnorm => TextureFormat::Rg8Unorm,
            f => f,
        }
    }

    /// True when channels read back as unsigned normalised values in [0, 1]: the 8-bit formats
    /// and the block formats that decode to them.
    pub fn is_unorm(self) -> bool {
        self.decoded().channel_bytes() == 1
    }

    /// The Vulkan `VkFormat` value stored in the KTX2 header.
    pub fn vk_format(self) -> u32 {
        use TextureFormat::*;
        match self {
            R8Unorm => 9,
            Rg8Unorm => 16,
            R16Float => 76,
            Rg16Float => 83,
            Rgba16Float => 97,
            R32Float => 100,
            Rg32Float => 103,
            Rgba32Float => 109,
            Bc4RUnorm => 139,
            Bc5RgUnorm => 141,
        }
    }

    /// The format with this `VkFormat` value, if hikage reads it.
    pub fn from_vk_format(vk: u32) -> Option<TextureFormat> {
        TextureFormat::ALL.into_iter().find(|f| f.vk_format() == vk)
    }

    /// Lower-case short name (`r32f`, `rg16f`, `r8`, …) used on the command line.
    pub fn short_name(self) -> &'static str {
        use TextureFormat::*;
        match self {
            R8Unorm => "r8",
            Rg8Unorm => "rg8",
            R16Float => "r16f",
            Rg16Float => "rg16f",
            Rgba16Float => "rgba16f",
            R32Float => "r32f",
            Rg32Float => "rg32f",
            Rgba32Float => "rgba32f",
            Bc4RUnorm => "bc4",
            Bc5RgUnorm => "bc5",
        }
    }

    /// Decodes channel `c` of the texel starting at `bytes[0]` to f32 (unorm formats map to
    /// [0, 1]).
    pub fn decode_channel(self, bytes: &[u8], c: usize) -> f32 {
        let o = c * self.channel_bytes();
        match self.channel_bytes() {
            1 => bytes[o] as f32 / 255.0,
            2 => half::f16::from_le_bytes([bytes[o], bytes[o + 1]]).to_f32(),
            _ => f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]),
        }
    }

    /// Encodes `value` as one channel, appending little-endian bytes (unorm formats clamp to
    /// [0, 1] and round to nearest; half floats round to nearest even).
    pub fn encode_channel(self, value: f32, out: &mut Vec<u8>) {
        match self.channel_bytes() {
            1 => out.push((value.clamp(0.0, 1.0) * 255.0).round() as u8),
            2 => out.extend_from_slice(&half::f16::from_f32(value).to_le_bytes()),
            _ => out.extend_from_slice(&value.to_le_bytes()),
        }
    }
}

/// Shape of a texture.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TextureDimension {
    /// A 2D texture (`depth` = 1, `layers` = 1).
    D2,
    /// An array of 2D layers (`depth` = 1).
    D2Array,
    /// A 3D texture (`layers` = 1); hikage puts the azimuth φ on the depth axis.
    D3,
}

/// Optional KTX2 supercompression of the level data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Supercompression {
    /// Levels stored as they are (KTX2 scheme 0).
    #[serde(rename = "none")]
    None,
    /// Each level compressed with Zstandard (KTX2 scheme 2).
    #[serde(rename = "zstd")]
    Zstd,
}

impl Supercompression {
    /// [`Supercompression::None`] (serde's default for mesh payloads).
    pub fn none() -> Supercompression {
        Supercompression::None
    }

    /// Whether nothing is compressed.
    pub fn is_none(&self) -> bool {
        *self == Supercompression::None
    }
}

/// Format and dimensions of a texture, as recorded in the manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TextureDesc {
    /// Texel format.
    pub format: TextureFormat,
    /// 2D, 2D array or 3D.
    pub dimension: TextureDimension,
    /// Texels along `u` at level 0.
    pub width: u32,
    /// Texels along `v` at level 0.
    pub height: u32,
    /// Slices along the depth axis at level 0 (1 unless 3D).
    pub depth: u32,
    /// Array layers (1 unless a 2D array).
    pub layers: u32,
    /// Mip levels stored (≥ 1); each halves width, height (and depth for 3D), rounding down,
    /// never below 1.
    pub levels: u32,
    /// Supercompression of the stored levels.
    pub supercompression: Supercompression,
    /// One name per channel (`height`, `slope`, `distance`, …), used by export and inspect.
    pub channels: Vec<String>,
}

impl TextureDesc {
    /// Width, height and depth of mip `level`.
    pub fn level_extent(&self, level: u32) -> (u32, u32, u32) {
        let shrink = |x: u32| (x >> level).max(1);
        let depth = match self.dimension {
            TextureDimension::D3 => shrink(self.depth),
            _ => 1,
        };
        (shrink(self.width), shrink(self.height), depth)
    }

    /// Uncompressed byte size of mip `level` (all layers and slices), or `None` on overflow. A
    /// block format's level is whole blocks: its width and height round up to multiples of 4.
    pub fn level_bytes(&self, level: u32) -> Option<u64> {
        let (w, h, d) = self.level_extent(level);
        let side = self.format.block_side();
        (w.div_ceil(side) as u64)
            .checked_mul(h.div_ceil(side) as u64)?
            .checked_mul(d as u64)?
            .checked_mul(self.layers as u64)?
            .checked_mul(self.format.block_bytes() as u64)
    }

    /// This description with a block format replaced by the format it decodes to.
    pub fn decoded(&self) -> TextureDesc {
        TextureDesc { format: self.format.decoded(), ..self.clone() }
    }

    /// Uncompressed byte size of all levels, or `None` on overflow.
    pub fn total_bytes(&self) -> Option<u64> {
        (0..self.levels).try_fold(0u64, |acc, l| acc.checked_add(self.level_bytes(l)?))
    }

    /// Slices of a level: depth slices for 3D, layers for arrays, 1 for 2D.
    pub fn slices(&self) -> u32 {
        match self.dimension {
            TextureDimension::D3 => self.depth,
            TextureDimension::D2Array => self.layers,
            TextureDimension::D2 => 1,
        }
    }

    /// Checks the description against itself and `limits`: shape-consistent depth and layer
    /// counts, non-zero sizes, levels within the mip chain, channel names matching the format.
    pub fn check(&self, limits: &crate::Limits) -> Result<(), String> {
        let max_dim = self.width.max(self.height).max(self.depth);
        if self.width == 0 || self.height == 0 || self.depth == 0 || self.layers == 0 {
            return Err(format!(
                "expected non-zero dimensions, found {}×{}×{} with {} layers",
                self.width, self.height, self.depth, self.layers
            ));
        }
        if max_dim > limits.max_texture_dimension {
            return Err(format!("dimension {max_dim} is above the limit of {}", limits.max_texture_dimension));
        }
        if self.layers > limits.max_texture_layers {
            return Err(format!("{} layers is above the limit of {}", self.layers, limits.max_texture_layers));
        }
        match self.dimension {
            TextureDimension::D2 if self.depth != 1 || self.layers != 1 => {
                return Err("a D2 texture must have depth 1 and 1 layer".into());
            }
            TextureDimension::D2Array if self.depth != 1 => {
                return Err("a D2Array texture must have depth 1".into());
            }
            TextureDimension::D3 if self.layers != 1 => {
                return Err("a D3 texture must have 1 layer".into());
            }
            _ => {}
        }
        let chain = 32 - max_dim.leading_zeros();
        if self.levels == 0 || self.levels > chain {
            return Err(format!("expected 1 to {chain} mip levels for size {max_dim}, found {}", self.levels));
        }
        if self.channels.len() != self.format.channels() {
            return Err(format!(
                "format {:?} has {} channels but {} channel names are given",
                self.format,
                self.format.channels(),
                self.channels.len()
            ));
        }
        match self.total_bytes() {
            Some(b) if b <= limits.max_texture_bytes => Ok(()),
            Some(b) => Err(format!("{b} bytes of texels is above the limit of {}", limits.max_texture_bytes)),
            None => Err("texel byte count overflows".into()),
        }
    }
}

/// A texture in memory: its description and the uncompressed bytes of each level.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureData {
    /// Format and dimensions.
    pub desc: TextureDesc,
    /// Level 0 first; each exactly [`TextureDesc::level_bytes`] long.
    pub levels: Vec<Vec<u8>>,
}

impl TextureData {
    /// Builds a single-level texture from f32 values in `[slice][row][col][channel]` order,
    /// encoding them in `desc.format`.
    pub fn from_f32(desc: TextureDesc, values: &[f32]) -> Result<TextureData, BundleError> {
        if desc.format.is_block_compressed() {
            return Err(BundleError::InvalidData(format!(
                "{:?} texels are blocks: encode the {:?} texture into blocks instead",
                desc.format,
                desc.format.decoded()
            )));
        }
        let texels = desc.level_bytes(0).unwrap_or(u64::MAX) / desc.format.texel_bytes() as u64;
        let expected = texels.saturating_mul(desc.format.channels() as u64);
        if values.len() as u64 != expected || desc.levels != 1 {
            return Err(BundleError::InvalidData(format!(
                "expected {expected} values for one level of {}×{}×{}×{} {:?}, found {} (levels {})",
                desc.width,
                desc.height,
                desc.depth,
                desc.layers,
                desc.format,
                values.len(),
                desc.levels
            )));
        }
        let mut bytes = Vec::with_capacity(expected as usize * desc.format.channel_bytes());
        for &v in values {
            desc.format.encode_channel(v, &mut bytes);
        }
        Ok(TextureData { desc, levels: vec![bytes] })
    }

    /// The texture with block-compressed levels decoded to their 8-bit format (as a GPU decodes
    /// them, rounded to the nearest 1/255); an uncompressed texture as it is.
    pub fn decoded(&self) -> std::borrow::Cow<'_, TextureData> {
        if !self.desc.format.is_block_compressed() {
            return std::borrow::Cow::Borrowed(self);
        }
        let levels = (0..self.desc.levels).map(|l| crate::bc::decode_level(&self.desc, l, &self.levels[l as usize]));
        std::borrow::Cow::Owned(TextureData { desc: self.desc.decoded(), levels: levels.collect() })
    }

    /// Channel `channel` of every texel of `level`, decoded to f32, in
    /// `[slice][row][col]` order.
    pub fn channel_f32(&self, level: u32, channel: usize) -> Vec<f32> {
        if self.desc.format.is_block_compressed() {
            return self.decoded().channel_f32(level, channel);
        }
        let format = self.desc.format;
        let tb = format.texel_bytes();
        self.levels[level as usize].chunks_exact(tb).map(|t| format.decode_channel(t, channel)).collect()
    }

    /// Every channel of `level` decoded to f32, in `[slice][row][col][channel]` order.
    pub fn to_f32(&self, level: u32) -> Vec<f32> {
        if self.desc.format.is_block_compressed() {
            return self.decoded().to_f32(level);
        }
        let format = self.desc.format;
        let cb = format.channel_bytes();
        self.levels[level as usize].chunks_exact(cb).map(|c| format.decode_channel(c, 0)).collect()
    }

    /// Position (level, slice, row, col, channel) of the first non-finite float texel, if any.
    pub fn first_non_finite(&self) -> Option<(u32, u32, u32, u32, usize)> {
        if !self.desc.format.is_float() {
            return None;
        }
        for level in 0..self.levels.len() {
            let (w, h, _) = self.desc.level_extent(level as u32);
            let values = self.to_f32(level as u32);
            let channels = self.desc.format.channels();
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                let texel = i / channels;
                let (w, h) = (w as usize, h as usize);
                return Some((
                    level as u32,
                    (texel / (w * h)) as u32,
                    (texel / w % h) as u32,
                    (texel % w) as u32,
                    i % channels,
                ));
            }
        }
        None
    }
}
