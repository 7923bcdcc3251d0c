//! The `Heightfield` job: import an image as a `heightfield` asset.

use std::path::{Path, PathBuf};

use hikage_bundle::{HeightfieldSettings, Settings, TextureFormat};
use serde::{Deserialize, Deserializer, Serialize};

use super::source::{HeightSource, deserialize_flat};
use super::{BakedAsset, Baker, JobContext};
use crate::error::BakeError;
use crate::heightfield::Heightfield;

/// Version of the import; part of the input hash.
pub const ALGORITHM_VERSION: u32 = 1;

/// Storage format of a heightfield texture.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum HeightFormat {
    /// 32-bit float samples (exact).
    #[default]
    #[cfg_attr(feature = "clap", value(name = "r32f"))]
    R32Float,
    /// Half-float samples (11-bit mantissa; enough for normalised 8-bit sources).
    #[cfg_attr(feature = "clap", value(name = "r16f"))]
    R16Float,
}

impl HeightFormat {
    /// Whether a sample can be stored in this format without becoming infinite: a half float
    /// holds at most ±65504 (a `.r32` in centimetres does not fit; store it as `R32Float`).
    pub fn check(self, sample: f32) -> Result<(), String> {
        const HALF_MAX: f32 = 65504.0;
        match self {
            HeightFormat::R16Float if sample.abs() > HALF_MAX => Err(format!(
                "sample {sample} does not fit format R16Float (at most ±{HALF_MAX}): store heights as R32Float"
            )),
            _ => Ok(()),
        }
    }

    /// The texture format.
    pub fn texture_format(self) -> TextureFormat {
        match self {
            HeightFormat::R32Float => TextureFormat::R32Float,
            HeightFormat::R16Float => TextureFormat::R16Float,
        }
    }

    /// The `heightfield` asset `id` of the loaded `hf`, stored in this format.
    pub(crate) fn asset(self, id: &str, hf: &Heightfield) -> Result<BakedAsset, BakeError> {
        Ok(BakedAsset {
            id: id.to_string(),
            settings: Settings::Heightfield(settings_of(hf)),
            payload: hf.to_texture(self.texture_format())?.into(),
        })
    }
}

/// A heightfield import: the source, stored as `format`.
#[derive(Clone, Debug, PartialEq)]
pub struct HeightfieldJob {
    /// Asset id.
    pub id: String,
    /// The input and its world units.
    pub source: HeightSource,
    /// The job's own settings.
    pub options: HeightfieldOptions,
}

/// The `Heightfield` job's own settings (beside its [`HeightSource`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HeightfieldOptions {
    /// Storage format.
    pub format: HeightFormat,
    /// Payload compression: `Auto` (the default: a zstd level per kind of payload), `Zstd(level)`
    /// (1–22), or `None`.
    pub compression: crate::Compression,
}

impl<'de> Deserialize<'de> for HeightfieldJob {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (id, source, options) = deserialize_flat(d, "Heightfield")?;
        Ok(HeightfieldJob { id, source, options })
    }
}

impl HeightfieldJob {
    /// A job with every setting at its default.
    pub fn new(id: &str, input: PathBuf) -> HeightfieldJob {
        HeightfieldJob { id: id.to_string(), source: HeightSource::new(input), options: HeightfieldOptions::default() }
    }

    /// Loads the input with the job's world units attached, every sample checked.
    pub fn load(&self, ctx: &JobContext) -> Result<Heightfield, BakeError> {
        self.source.load(ctx, &|v| self.options.format.check(v))
    }
}

impl Baker for HeightfieldJob {
    fn id(&self) -> &str {
        &self.id
    }

    fn kind(&self) -> &'static str {
        "heightfield"
    }

    fn algorithm_version(&self) -> u32 {
        ALGORITHM_VERSION
    }

    fn inputs(&self, base_dir: &Path) -> Vec<PathBuf> {
        vec![self.source.path(base_dir)]
    }

    fn outputs(&self) -> Vec<String> {
        vec![self.id.clone()]
    }

    fn canonical_settings(&self) -> String {
        canonical(&self.source, self.options.format)
    }

    fn check(&self) -> Result<(), String> {
        self.source.check()
    }

    fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        self.source.scan(ctx, true, &|v| self.options.format.check(v)).map(|_| ())
    }

    fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        (ctx.progress)(0, 1);
        let asset = self.options.format.asset(&self.id, &self.load(ctx)?)?;
        (ctx.progress)(1, 1);
        Ok(vec![asset])
    }
}

/// The canonical settings of heights read from `source` and stored as `format` (part of every
/// heightfield-reading job's input hash). A raw size is appended only when given, so the inputs
/// hashed before it keep their hash.
pub(crate) fn canonical(source: &HeightSource, format: HeightFormat) -> String {
    let raw = source.raw_size.map(|(w, h)| format!(";raw_size=({w},{h})")).unwrap_or_default();
    format!(
        "channel={:?};texel_size=({:?},{:?});height_scale={:?};height_offset={:?};format={:?}{raw}",
        source.channel, source.texel_size.0, source.texel_size.1, source.height_scale, source.height_offset, format
    )
}

/// The manifest settings describing a heightfield's world units.
pub fn settings_of(hf: &Heightfield) -> HeightfieldSettings {
    HeightfieldSettings {
        texel_size: hf.texel_size,
        height_scale: hf.height_scale,
        height_offset: hf.height_offset,
        source_channel: hf.source_channel.clone(),
        normalized: hf.normalized,
        tile: None,
    }
}
