//! The `Heightfield` job: import an image as a `heightfield` asset.

use std::path::{Path, PathBuf};

use hikage_bundle::{HeightfieldSettings, Settings, TextureFormat};
use serde::{Deserialize, Serialize};

use super::{BakedAsset, BakedPayload, Baker, JobContext};
use crate::error::BakeError;
use crate::heightfield::{HeightSource, Heightfield, LoadOptions, load_samples};

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
}

/// Settings of a heightfield import.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeightfieldJob {
    /// Asset id.
    pub id: String,
    /// PNG (8/16-bit), OpenEXR, TIFF/GeoTIFF, SRTM `.hgt` or raw `.r16`/`.r32` file.
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
    /// Width and height of a raw `.r16`/`.r32` input (none: a square map's side from its length).
    #[serde(default)]
    pub raw_size: Option<(u32, u32)>,
}

/// Parses a raw heightmap's size written `WxH` (the command line's `--raw-size`).
#[cfg(feature = "clap")]
pub fn parse_raw_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("expected WxH")?;
    let num = |p: &str| p.trim().parse::<u32>().map_err(|e| format!("{p:?}: {e}"));
    Ok((num(w)?, num(h)?))
}

/// Parses a texel size written `SX` or `SX,SY` (the command line's `--texel-size`).
#[cfg(feature = "clap")]
pub fn parse_texel_size(s: &str) -> Result<(f32, f32), String> {
    let num = |p: &str| p.trim().parse::<f32>().map_err(|e| format!("{p:?}: {e}"));
    match s.split(',').collect::<Vec<_>>().as_slice() {
        [x] => num(x).map(|x| (x, x)),
        [x, y] => Ok((num(x)?, num(y)?)),
        _ => Err("expected SX or SX,SY".into()),
    }
}

pub(crate) fn unit_texel() -> (f32, f32) {
    (1.0, 1.0)
}

pub(crate) fn one() -> f32 {
    1.0
}

impl HeightfieldJob {
    /// A job with every setting at its default.
    pub fn new(id: &str, input: PathBuf) -> HeightfieldJob {
        HeightfieldJob {
            id: id.to_string(),
            input,
            channel: None,
            texel_size: unit_texel(),
            height_scale: 1.0,
            height_offset: 0.0,
            format: HeightFormat::R32Float,
            raw_size: None,
        }
    }

    /// How the input is read.
    fn load_options(&self, ctx: &JobContext) -> LoadOptions {
        LoadOptions { channel: self.channel.clone(), max_dimension: ctx.limits.max_dimension, raw_size: self.raw_size }
    }

    /// Checks every sample of the input as [`load`](Self::load) would, a block of the file at
    /// a time: finite, storable in the job's format, a finite world height.
    pub fn scan(&self, ctx: &JobContext) -> Result<(), BakeError> {
        let path = ctx.base_dir.join(&self.input);
        let mut source = HeightSource::open(&path, &self.load_options(ctx))?;
        let (w, h) = source.size();
        self.check_extent(&path, w, h)?;
        source.scan(&|v| self.check_sample(v))
    }

    /// A sample's storage and world height.
    pub(super) fn check_sample(&self, v: f32) -> Result<(), String> {
        self.format.check(v)?;
        let world = self.height_offset + self.height_scale * v;
        if !world.is_finite() {
            return Err(format!(
                "sample {v} gives world height {world} (height_offset + height_scale × sample): expected a finite one"
            ));
        }
        Ok(())
    }

    /// The map's world extent, which horizon distances are measured in, must be finite.
    pub(super) fn check_extent(&self, path: &Path, w: u32, h: u32) -> Result<(), BakeError> {
        let (sx, sy) = self.texel_size;
        if !((w as f32 * sx).is_finite() && (h as f32 * sy).is_finite()) {
            return Err(BakeError::input(
                path,
                None,
                format!("a {w}×{h} map of texel_size ({sx}, {sy}) spans no finite world extent"),
            ));
        }
        Ok(())
    }

    /// Loads the input with the job's world units attached, every sample checked as
    /// [`scan`](Self::scan) checks it.
    pub fn load(&self, ctx: &JobContext) -> Result<Heightfield, BakeError> {
        let path = ctx.base_dir.join(&self.input);
        let s = load_samples(&path, &self.load_options(ctx))?;
        self.check_extent(&path, s.width, s.height)?;
        if let Some((i, message)) =
            s.values.iter().enumerate().find_map(|(i, &v)| self.check_sample(v).err().map(|m| (i, m)))
        {
            let (x, y) = (i % s.width as usize, i / s.width as usize);
            return Err(BakeError::input(&path, Some(format!("pixel ({x}, {y})")), message));
        }
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

    /// The asset of a loaded heightfield, stored in `format`.
    pub(crate) fn asset(&self, hf: &Heightfield) -> Result<BakedAsset, BakeError> {
        Ok(BakedAsset {
            id: self.id.clone(),
            settings: Settings::Heightfield(settings_of(hf)),
            payload: BakedPayload::Texture(hf.to_texture(self.format.texture_format())?),
        })
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
        vec![base_dir.join(&self.input)]
    }

    fn outputs(&self) -> Vec<String> {
        vec![self.id.clone()]
    }

    fn canonical_settings(&self) -> String {
        // A raw size is appended only when given, so the inputs hashed before it keep their hash.
        let raw = self.raw_size.map(|(w, h)| format!(";raw_size=({w},{h})")).unwrap_or_default();
        format!(
            "channel={:?};texel_size=({:?},{:?});height_scale={:?};height_offset={:?};format={:?}{raw}",
            self.channel, self.texel_size.0, self.texel_size.1, self.height_scale, self.height_offset, self.format
        )
    }

    fn check(&self) -> Result<(), String> {
        check_world_units(self.texel_size, self.height_scale, self.height_offset)
    }

    fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        self.scan(ctx)
    }

    fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        (ctx.progress)(0, 1);
        let hf = self.load(ctx)?;
        let asset = self.asset(&hf)?;
        (ctx.progress)(1, 1);
        Ok(vec![asset])
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
        tile: None,
    }
}

/// Checks texel size, height scale and offset (see [`crate::heightfield`] on world units).
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
