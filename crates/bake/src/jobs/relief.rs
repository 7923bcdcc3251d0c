//! The `Relief` job: a heightfield image → relief depth maps and the max-mip pyramid they were
//! traced on.

use std::path::PathBuf;

use hikage_bundle::{AssetKind, MaxMipSettings, ReliefSettings as ReliefInfo, Settings};
use serde::{Deserialize, Serialize};

use super::heightfield::{HeightfieldJob, unit_texel};
use super::{BakedAsset, BakedPayload, JobContext};
use crate::error::BakeError;
use crate::relief::{self, ReliefFormat, ReliefSettings};

/// Version of the relief job; part of the input hash.
pub const ALGORITHM_VERSION: u32 = relief::ALGORITHM_VERSION;

/// Settings of a relief bake. Asset ids: `<id>.relief` (depth maps) and `<id>.maxmip`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReliefJob {
    /// Prefix of the asset ids.
    pub id: String,
    /// PNG (8/16-bit) or OpenEXR heightfield with samples in [0, 1], power-of-two sides.
    pub input: PathBuf,
    /// Channel to take (see [`crate::heightfield`]).
    #[serde(default)]
    pub channel: Option<String>,
    /// Rows of zenith angle (1–128).
    #[serde(default = "default_theta")]
    pub theta: u32,
    /// Azimuths per row (1–128).
    #[serde(default = "default_phi")]
    pub phi: u32,
    /// Width of the stored maps (power of two ≤ map width); absent: 32, or the map width if
    /// smaller.
    #[serde(default = "default_size")]
    pub size: Option<u32>,
    /// Relief thickness as a share of the map width.
    #[serde(default = "default_depth_scale")]
    pub depth_scale: f32,
    /// Storage of the depth maps.
    #[serde(default)]
    pub format: ReliefFormat,
}

fn default_theta() -> u32 {
    ReliefSettings::default().theta
}
fn default_phi() -> u32 {
    ReliefSettings::default().phi
}
fn default_size() -> Option<u32> {
    ReliefSettings::default().size
}
fn default_depth_scale() -> f32 {
    ReliefSettings::default().depth_scale
}

impl ReliefJob {
    /// A job with every setting at its default.
    pub fn new(id: &str, input: PathBuf) -> ReliefJob {
        let d = ReliefSettings::default();
        ReliefJob {
            id: id.to_string(),
            input,
            channel: None,
            theta: d.theta,
            phi: d.phi,
            size: d.size,
            depth_scale: d.depth_scale,
            format: d.format,
        }
    }

    /// The baker's settings.
    pub fn settings(&self) -> ReliefSettings {
        ReliefSettings {
            theta: self.theta,
            phi: self.phi,
            size: self.size,
            depth_scale: self.depth_scale,
            format: self.format,
        }
    }

    fn heightfield_job(&self) -> HeightfieldJob {
        HeightfieldJob {
            id: self.max_mip_id(),
            input: self.input.clone(),
            channel: self.channel.clone(),
            texel_size: unit_texel(),
            height_scale: 1.0,
            height_offset: 0.0,
            format: Default::default(),
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

    pub(crate) fn outputs(&self) -> Vec<String> {
        vec![self.max_mip_id(), self.relief_id()]
    }

    pub(crate) fn canonical_settings(&self) -> String {
        format!("{:?};{:?}", self.channel, self.settings())
    }

    pub(crate) fn check(&self) -> Result<(), String> {
        self.settings().check()
    }

    /// Loads the input and checks it can carry relief maps with these settings.
    fn load(&self, ctx: &JobContext) -> Result<crate::Heightfield, BakeError> {
        let hf = self.heightfield_job().load(ctx)?;
        let path = ctx.base_dir.join(&self.input);
        self.settings().check_for(hf.width, hf.height).map_err(|m| BakeError::input(&path, None, m))?;
        relief::stored_heights(&hf).map_err(|m| BakeError::input(&path, None, m))?;
        Ok(hf)
    }

    pub(crate) fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        self.load(ctx).map(|_| ())
    }

    pub(crate) fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        let hf = self.load(ctx)?;
        let path = ctx.base_dir.join(&self.input);
        let settings = self.settings();
        let baked = relief::bake(&hf, &settings, ctx.progress).map_err(|m| BakeError::input(&path, None, m))?;
        let info = ReliefInfo {
            max_mip: self.max_mip_id(),
            theta: self.theta,
            phi: self.phi,
            depth_scale: self.depth_scale,
            source_size: (hf.width, hf.height),
            // Degrees from exact fractions, so the table reads 120.0, not 120.00001.
            directions: (0..self.theta * self.phi)
                .map(|l| {
                    let (i, j) = (l / self.phi, l % self.phi);
                    ((90.0 * (i as f64 + 0.5) / self.theta as f64) as f32, (360.0 * j as f64 / self.phi as f64) as f32)
                })
                .collect(),
        };
        Ok(vec![
            BakedAsset {
                id: self.max_mip_id(),
                kind: AssetKind::MaxMip,
                settings: Settings::MaxMip(MaxMipSettings { source_channel: hf.source_channel.clone() }),
                payload: BakedPayload::Texture(baked.max_mip),
            },
            BakedAsset {
                id: self.relief_id(),
                kind: AssetKind::Relief,
                settings: Settings::Relief(info),
                payload: BakedPayload::Texture(baked.depth),
            },
        ])
    }
}
