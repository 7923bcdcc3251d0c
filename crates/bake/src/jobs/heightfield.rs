//! The `Heightfield` job: import an image as a `heightfield` asset.

use std::path::PathBuf;

use hikage_bundle::{AssetKind, HeightfieldSettings, Settings, TextureFormat};
use serde::{Deserialize, Serialize};

use super::{BakedAsset, BakedPayload, JobContext};
use crate::error::BakeError;
use crate::heightfield::{Heightfield, LoadOptions, load_samples};

/// Version of the import; part of the input hash.
pub const ALGORITHM_VERSION: u32 = 1;

/// Storage format of a heightfield texture.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum HeightFormat {
    /// 32-bit float samples (exact).
    #[default]
    R32Float,
    /// Half-float samples (11-bit mantissa; enough for normalised 8-bit sources).
    R16Float,
}

impl HeightFormat {
    /// The texture format.
    pub fn texture_format(self) -> TextureFormat {
        match self {
            HeightFormat::R32Float => TextureFormat::R32Float,
            HeightFormat::R16Float => TextureFormat::R16Float,
        }
    }
}

/// Settings of a heightfield import.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeightfieldJob {
    /// Asset id.
    pub id: String,
    /// PNG (8/16-bit) or OpenEXR file.
    pub input: PathBuf,
    /// Channel to take; see [`crate::heightfield`] for the rule when absent.
    #[serde(default)]
    pub channel: Option<String>,
    /// World units per texel along `u` and `v`.
    #[serde(default = "unit_texel")]
    pub texel_size: (f32, f32),
    /// World height = `height_offset + height_scale × sample`.
    #[serde(default = "one")]
    pub height_scale: f32,
    /// See `height_scale`.
    #[serde(default)]
    pub height_offset: f32,
    /// Storage format.
    #[serde(default)]
    pub format: HeightFormat,
}

pub(crate) fn unit_texel() -> (f32, f32) {
    (1.0, 1.0)
}

pub(crate) fn one() -> f32 {
    1.0
}

impl HeightfieldJob {
    pub(crate) fn canonical_settings(&self) -> String {
        format!(
            "channel={:?};texel_size=({:?},{:?});height_scale={:?};height_offset={:?};format={:?}",
            self.channel, self.texel_size.0, self.texel_size.1, self.height_scale, self.height_offset, self.format
        )
    }

    pub(crate) fn check(&self) -> Result<(), String> {
        check_world_units(self.texel_size, self.height_scale, self.height_offset)
    }

    /// Loads the input with the job's world units attached.
    pub fn load(&self, ctx: &JobContext) -> Result<Heightfield, BakeError> {
        let path = ctx.base_dir.join(&self.input);
        let options = LoadOptions { channel: self.channel.clone(), max_dimension: ctx.limits.max_dimension };
        let s = load_samples(&path, &options)?;
        Ok(Heightfield {
            width: s.width,
            height: s.height,
            samples: s.values,
            texel_size: self.texel_size,
            height_scale: self.height_scale,
            height_offset: self.height_offset,
            normalized: s.normalized,
            source_channel: s.channel,
        })
    }

    pub(crate) fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        (ctx.progress)(0, 1);
        let hf = self.load(ctx)?;
        let texture = hf.to_texture(self.format.texture_format())?;
        (ctx.progress)(1, 1);
        Ok(vec![BakedAsset {
            id: self.id.clone(),
            kind: AssetKind::Heightfield,
            settings: Settings::Heightfield(settings_of(&hf)),
            payload: BakedPayload::Texture(texture),
        }])
    }
}

/// The manifest settings describing a heightfield's world units.
pub fn settings_of(hf: &Heightfield) -> HeightfieldSettings {
    HeightfieldSettings {
        texel_size: hf.texel_size,
        height_scale: hf.height_scale,
        height_offset: hf.height_offset,
        source_channel: hf.source_channel.clone(),
        normalized: hf.normalized,
    }
}

/// Checks texel size, height scale and offset (DESIGN.md "World units").
pub fn check_world_units(texel_size: (f32, f32), height_scale: f32, height_offset: f32) -> Result<(), String> {
    let (sx, sy) = texel_size;
    if !(sx.is_finite() && sy.is_finite() && sx > 0.0 && sy > 0.0) {
        return Err(format!("texel_size must be finite and above 0, found ({sx}, {sy})"));
    }
    if !height_scale.is_finite() || !height_offset.is_finite() {
        return Err(format!("height_scale and height_offset must be finite, found {height_scale} and {height_offset}"));
    }
    Ok(())
}
