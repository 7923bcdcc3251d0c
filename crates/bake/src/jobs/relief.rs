//! The `Relief` job: a heightfield image → relief depth maps and the max-mip pyramid they were
//! traced on.

use std::path::{Path, PathBuf};

use hikage_bundle::{MaxMipSettings, ReliefSettings, Settings};
use serde::{Deserialize, Serialize};

use super::heightfield::HeightfieldJob;
use super::{BakedAsset, BakedPayload, Baker, JobContext};
use crate::error::BakeError;
use crate::heightfield::{HeightSource, LoadOptions};
use crate::relief::{self, ReliefFormat, ReliefParams};

/// Version of the relief job; part of the input hash.
pub const ALGORITHM_VERSION: u32 = relief::ALGORITHM_VERSION;

/// Settings of a relief bake. Asset ids: `<id>.relief` (depth maps) and `<id>.maxmip`.
///
/// With the `clap` feature it is also the `hikage relief` command line (the id comes from
/// `--id` or the input's file stem).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
#[serde(deny_unknown_fields)]
pub struct ReliefJob {
    /// Prefix of the asset ids.
    #[cfg_attr(feature = "clap", arg(skip))]
    pub id: String,
    /// Heightfield image (PNG 8/16-bit or OpenEXR) with samples in [0, 1] and power-of-two sides.
    pub input: PathBuf,
    /// Channel of the input to take: R, G, B, A, Y or an EXR channel name (default: a grayscale
    /// PNG's luma; an EXR's Y, else R, else its only channel).
    #[serde(default)]
    #[cfg_attr(feature = "clap", arg(long))]
    pub channel: Option<String>,
    /// Rows of zenith angle θ, 1–128; θ_i = (i + ½)·90°/theta.
    #[serde(default = "default_theta")]
    #[cfg_attr(feature = "clap", arg(long, default_value_t = default_theta()))]
    pub theta: u32,
    /// Azimuths φ per row, 1–128; φ_j = 360°·j/phi.
    #[serde(default = "default_phi")]
    #[cfg_attr(feature = "clap", arg(long, default_value_t = default_phi()))]
    pub phi: u32,
    /// Width of the stored maps: a power of two up to the map width (MIN-downscaled); none: 32,
    /// or the map width when smaller.
    #[serde(default = "default_size")]
    #[cfg_attr(feature = "clap", arg(long))]
    pub size: Option<u32>,
    /// Relief thickness as a share of the map width.
    #[serde(default = "default_depth_scale")]
    #[cfg_attr(feature = "clap", arg(long, default_value_t = default_depth_scale()))]
    pub depth_scale: f32,
    /// Storage of the depth maps: r8 (the paper's memory) or r16f; both rounded down.
    #[serde(default)]
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = ReliefFormat::R8Unorm))]
    pub format: ReliefFormat,
    /// A configuration of seed 003 by name; it sets theta, phi, size and format, which are then
    /// left at their defaults.
    #[serde(default)]
    #[cfg_attr(feature = "clap", arg(long, value_enum))]
    pub preset: Option<ReliefPreset>,
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

fn default_theta() -> u32 {
    ReliefParams::default().theta
}
fn default_phi() -> u32 {
    ReliefParams::default().phi
}
fn default_size() -> Option<u32> {
    ReliefParams::default().size
}
fn default_depth_scale() -> f32 {
    ReliefParams::default().depth_scale
}

impl ReliefJob {
    /// A job with every setting at its default.
    pub fn new(id: &str, input: PathBuf) -> ReliefJob {
        let d = ReliefParams::default();
        ReliefJob {
            id: id.to_string(),
            input,
            channel: None,
            theta: d.theta,
            phi: d.phi,
            size: d.size,
            depth_scale: d.depth_scale,
            format: d.format,
            preset: None,
        }
    }

    /// The baker's parameters: the preset's, if any, with this job's depth scale.
    pub fn params(&self) -> ReliefParams {
        match self.preset {
            Some(preset) => ReliefParams { depth_scale: self.depth_scale, ..preset.params() },
            None => ReliefParams {
                theta: self.theta,
                phi: self.phi,
                size: self.size,
                depth_scale: self.depth_scale,
                format: self.format,
            },
        }
    }

    fn heightfield_job(&self) -> HeightfieldJob {
        HeightfieldJob { channel: self.channel.clone(), ..HeightfieldJob::new(&self.max_mip_id(), self.input.clone()) }
    }

    /// Id of the depth-map asset.
    pub fn relief_id(&self) -> String {
        format!("{}.relief", self.id)
    }
    /// Id of the max-mip asset.
    pub fn max_mip_id(&self) -> String {
        format!("{}.maxmip", self.id)
    }

    /// Loads the input and checks it can carry relief maps with these settings.
    fn load(&self, ctx: &JobContext) -> Result<crate::Heightfield, BakeError> {
        let hf = self.heightfield_job().load(ctx)?;
        let path = ctx.base_dir.join(&self.input);
        self.params().check_for(hf.width, hf.height).map_err(|m| BakeError::input(&path, None, m))?;
        relief::stored_heights(&hf).map_err(|m| BakeError::input(&path, None, m))?;
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
        vec![base_dir.join(&self.input)]
    }

    fn outputs(&self) -> Vec<String> {
        vec![self.max_mip_id(), self.relief_id()]
    }

    fn canonical_settings(&self) -> String {
        // The text the parameters' derived `Debug` gave under their first name: kept word for
        // word so bundles baked before keep their input hashes.
        let p = self.params();
        format!(
            "{:?};ReliefSettings {{ theta: {}, phi: {}, size: {:?}, depth_scale: {:?}, format: {:?} }}",
            self.channel, p.theta, p.phi, p.size, p.depth_scale, p.format
        )
    }

    fn check(&self) -> Result<(), String> {
        if let Some(preset) = self.preset {
            let d = ReliefParams::default();
            if (self.theta, self.phi, self.size, self.format) != (d.theta, d.phi, d.size, d.format) {
                return Err(format!(
                    "preset {preset:?} sets theta, phi, size and format; leave them out or drop the preset"
                ));
            }
        }
        self.params().check()
    }

    fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        // A block of the file at a time, with the checks `load` makes.
        let path = ctx.base_dir.join(&self.input);
        let options =
            LoadOptions { channel: self.channel.clone(), max_dimension: ctx.limits.max_dimension, raw_size: None };
        let mut source = HeightSource::open(&path, &options)?;
        let (w, h) = source.size();
        self.params().check_for(w, h).map_err(|m| BakeError::input(&path, None, m))?;
        source.scan(&|v| {
            if (0.0..=1.0).contains(&v) {
                Ok(())
            } else {
                Err(format!("relief heights must lie in [0, 1] (depth = 1 − height); the sample is {v}"))
            }
        })
    }

    fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        let hf = self.load(ctx)?;
        let path = ctx.base_dir.join(&self.input);
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
                payload: BakedPayload::Texture(baked.max_mip),
            },
            BakedAsset {
                id: self.relief_id(),
                settings: Settings::Relief(settings),
                payload: BakedPayload::Texture(baked.depth),
            },
        ])
    }
}
