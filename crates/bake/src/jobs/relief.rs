//! The `Relief` job: a heightfield image → relief depth maps and the max-mip pyramid they were
//! traced on.

use std::path::{Path, PathBuf};

use hikage_bundle::{MaxMipSettings, ReliefSettings, Settings, world_height};
use serde::{Deserialize, Deserializer, Serialize};

use super::source::{HeightSource, deserialize_flat};
use super::{BakedAsset, Baker, JobContext};
use crate::error::BakeError;
use crate::relief::{self, ReliefFormat, ReliefParams};

/// Version of the relief job; part of the input hash.
pub const ALGORITHM_VERSION: u32 = relief::ALGORITHM_VERSION;

/// A relief bake. Asset ids: `<id>.relief` (depth maps) and `<id>.maxmip`. Relief heights are
/// the source's `height_offset + height_scale × sample`, which must lie in [0, 1] (depth =
/// 1 − height): a raw `.r16` reads with `height_scale: 1.5259e-5` (1/65535).
///
/// With the `clap` feature it is also the `hikage relief` command line (the id comes from
/// `--id` or the input's file stem).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct ReliefJob {
    /// Prefix of the asset ids.
    #[cfg_attr(feature = "clap", arg(skip))]
    pub id: String,
    /// The input and its heights.
    #[cfg_attr(feature = "clap", command(flatten))]
    pub source: HeightSource,
    /// The job's own settings.
    #[cfg_attr(feature = "clap", command(flatten))]
    pub options: ReliefOptions,
}

/// The `Relief` job's own settings (beside its [`HeightSource`]); every default is
/// [`ReliefOptions::default`]'s.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct ReliefOptions {
    /// Rows of zenith angle θ, 1–128; θ_i = (i + ½)·90°/theta.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = ReliefOptions::default().theta))]
    pub theta: u32,
    /// Azimuths φ per row, 1–128; φ_j = 360°·j/phi.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = ReliefOptions::default().phi))]
    pub phi: u32,
    /// Width of the stored maps: a power of two up to the map width (MIN-downscaled); none: 32,
    /// or the map width when smaller.
    #[cfg_attr(feature = "clap", arg(long))]
    pub size: Option<u32>,
    /// Relief thickness as a share of the map width.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = ReliefOptions::default().depth_scale))]
    pub depth_scale: f32,
    /// Storage of the depth maps: r8 (the paper's memory) or r16f; both rounded down.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = ReliefOptions::default().format))]
    pub format: ReliefFormat,
    /// A configuration of seed 003 by name; it sets theta, phi, size and format, which are then
    /// left at their defaults.
    #[cfg_attr(feature = "clap", arg(long, value_enum))]
    pub preset: Option<ReliefPreset>,
    /// Payload compression: `Auto` (a zstd level per kind of payload, `--zstd auto`), `Zstd(level)`
    /// (1–22), or `None` (`--zstd 0`).
    #[cfg_attr(
        feature = "clap",
        arg(long = "zstd", value_name = "LEVEL", value_parser = crate::compression::parse_level, default_value = "auto")
    )]
    pub compression: crate::Compression,
}

impl Default for ReliefOptions {
    fn default() -> Self {
        let d = ReliefParams::default();
        ReliefOptions {
            theta: d.theta,
            phi: d.phi,
            size: d.size,
            depth_scale: d.depth_scale,
            format: d.format,
            preset: None,
            compression: crate::Compression::default(),
        }
    }
}

impl<'de> Deserialize<'de> for ReliefJob {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (id, source, options) = deserialize_flat(d, "Relief")?;
        Ok(ReliefJob { id, source, options })
    }
}

/// Named relief settings that reproduce a configuration of seed 003.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum ReliefPreset {
    /// The paper's stated direction table: 32 zenith rows × 16 azimuths of 32² 8-bit maps,
    /// 512 KiB (the defaults).
    #[cfg_attr(feature = "clap", value(name = "paper-table"))]
    PaperTable,
    /// The paper's stated memory, 192 KB — one 256×256 RGB8 texture, i.e. 192 one-byte 32²
    /// maps — as 12 zenith rows × 16 azimuths.
    #[cfg_attr(feature = "clap", value(name = "paper-192k"))]
    Paper192K,
}

impl ReliefPreset {
    /// The preset's parameters at the default depth scale.
    pub fn params(self) -> ReliefParams {
        let d = ReliefParams::default();
        match self {
            ReliefPreset::PaperTable => ReliefParams { theta: 32, phi: 16, size: Some(32), ..d },
            ReliefPreset::Paper192K => ReliefParams { theta: 12, phi: 16, size: Some(32), ..d },
        }
    }
}

impl ReliefJob {
    /// A job with every setting at its default.
    pub fn new(id: &str, input: PathBuf) -> ReliefJob {
        ReliefJob { id: id.to_string(), source: HeightSource::new(input), options: ReliefOptions::default() }
    }

    /// The baker's parameters: the preset's, if any, with this job's depth scale.
    pub fn params(&self) -> ReliefParams {
        let o = &self.options;
        match o.preset {
            Some(preset) => ReliefParams { depth_scale: o.depth_scale, ..preset.params() },
            None => {
                ReliefParams { theta: o.theta, phi: o.phi, size: o.size, depth_scale: o.depth_scale, format: o.format }
            }
        }
    }

    /// Id of the depth-map asset.
    pub fn relief_id(&self) -> String {
        format!("{}.relief", self.id)
    }
    /// Id of the max-mip asset.
    pub fn max_mip_id(&self) -> String {
        format!("{}.maxmip", self.id)
    }

    /// Loads the input and checks it can carry relief maps with these settings: its heights
    /// (world units applied) in [0, 1], its sides powers of two.
    fn load(&self, ctx: &JobContext) -> Result<crate::Heightfield, BakeError> {
        let source = &self.source;
        let mut hf =
            source.load(ctx, &|v| relief::check_height(world_height(source.height_offset, source.height_scale, v)))?;
        let path = source.path(ctx.base_dir);
        self.params().check_for(hf.width, hf.height).map_err(|m| BakeError::input(&path, None, m))?;
        // Relief maps are in texture space: the heights are what the baker reads.
        if (source.height_scale, source.height_offset) != (1.0, 0.0) {
            hf.samples.iter_mut().for_each(|v| *v = world_height(source.height_offset, source.height_scale, *v));
            (hf.height_scale, hf.height_offset) = (1.0, 0.0);
        }
        Ok(hf)
    }
}

impl Baker for ReliefJob {
    fn id(&self) -> &str {
        &self.id
    }

    fn kind(&self) -> &'static str {
        "relief"
    }

    fn algorithm_version(&self) -> u32 {
        ALGORITHM_VERSION
    }

    fn inputs(&self, base_dir: &Path) -> Vec<PathBuf> {
        vec![self.source.path(base_dir)]
    }

    fn outputs(&self) -> Vec<String> {
        vec![self.max_mip_id(), self.relief_id()]
    }

    fn canonical_settings(&self) -> String {
        // The text the parameters' derived `Debug` gave under their first name: kept word for
        // word so bundles baked before keep their input hashes.
        let (p, s) = (self.params(), &self.source);
        // The source's other fields are appended only when given, so bundles baked before they
        // existed keep their hashes.
        let raw = s.raw_size.map(|(w, h)| format!(";raw_size=({w},{h})")).unwrap_or_default();
        let world = if (s.height_scale, s.height_offset) != (1.0, 0.0) {
            format!(";height_scale={:?};height_offset={:?}", s.height_scale, s.height_offset)
        } else {
            String::new()
        };
        format!(
            "{:?};ReliefSettings {{ theta: {}, phi: {}, size: {:?}, depth_scale: {:?}, format: {:?} }}{raw}{world}",
            s.channel, p.theta, p.phi, p.size, p.depth_scale, p.format
        )
    }

    fn check(&self) -> Result<(), String> {
        self.source.check()?;
        if self.source.texel_size != HeightSource::new("").texel_size {
            return Err("texel_size has no meaning for relief maps (they are in texture space): leave it out".into());
        }
        let o = &self.options;
        if let Some(preset) = o.preset {
            let d = ReliefOptions::default();
            if (o.theta, o.phi, o.size, o.format) != (d.theta, d.phi, d.size, d.format) {
                return Err(format!(
                    "preset {preset:?} sets theta, phi, size and format; leave them out or drop the preset"
                ));
            }
        }
        self.params().check()
    }

    fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        // A block of the file at a time, with the checks `load` makes.
        let s = &self.source;
        let file = s.scan(ctx, true, &|v| relief::check_height(world_height(s.height_offset, s.height_scale, v)))?;
        let (w, h) = file.size();
        self.params().check_for(w, h).map_err(|m| BakeError::input(s.path(ctx.base_dir), None, m))
    }

    fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        let hf = self.load(ctx)?;
        let path = self.source.path(ctx.base_dir);
        let p = self.params();
        let baked = relief::bake(&hf, &p, ctx.progress).map_err(|m| BakeError::input(&path, None, m))?;
        let settings = ReliefSettings {
            max_mip: self.max_mip_id(),
            theta: p.theta,
            phi: p.phi,
            depth_scale: p.depth_scale,
            source_size: (hf.width, hf.height),
            // Degrees from exact fractions, so the table reads 120.0, not 120.00001.
            directions: (0..p.theta * p.phi)
                .map(|l| {
                    let (i, j) = (l / p.phi, l % p.phi);
                    ((90.0 * (i as f64 + 0.5) / p.theta as f64) as f32, (360.0 * j as f64 / p.phi as f64) as f32)
                })
                .collect(),
        };
        Ok(vec![
            BakedAsset {
                id: self.max_mip_id(),
                settings: Settings::MaxMip(MaxMipSettings { source_channel: hf.source_channel.clone() }),
                payload: baked.max_mip.into(),
            },
            BakedAsset { id: self.relief_id(), settings: Settings::Relief(settings), payload: baked.depth.into() },
        ])
    }
}
