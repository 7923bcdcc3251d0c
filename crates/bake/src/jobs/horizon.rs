//! The `Horizon` job: a heightfield image → the heightfield asset, the horizon texture and,
//! optionally, an ambient-occlusion map derived from it.

use std::path::PathBuf;

use hikage_bundle::{AmbientOcclusionSettings, AssetKind, EdgeMode, HorizonSettings as HorizonInfo, Settings};
use serde::{Deserialize, Serialize};

use super::heightfield::{HeightFormat, HeightfieldJob, check_world_units, one, settings_of, unit_texel};
use super::{BakedAsset, BakedPayload, JobContext};
use crate::error::BakeError;
use crate::horizon::{self, DEFAULT_NEAR_FIELD, HorizonFormat, HorizonSettings, OPEN_SKY_SLOPE};

/// Settings of a horizon bake. Asset ids: `<id>.height`, `<id>.horizon`, and `<id>.ao` with
/// `ao: true`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HorizonJob {
    /// Prefix of the asset ids.
    pub id: String,
    /// PNG (8/16-bit) or OpenEXR heightfield.
    pub input: PathBuf,
    /// Channel to take (see [`crate::heightfield`]).
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
    /// Storage of the heightfield asset.
    #[serde(default)]
    pub height_format: HeightFormat,
    /// Azimuths, 1–256.
    #[serde(default = "default_directions")]
    pub directions: u32,
    /// Edge behaviour.
    #[serde(default)]
    pub edge: EdgeMode,
    /// Largest horizon distance, world units.
    #[serde(default)]
    pub max_distance: Option<f32>,
    /// Texels per ray traced exactly (0–64).
    #[serde(default = "default_near_field")]
    pub near_field: u32,
    /// Storage of the horizon texture.
    #[serde(default)]
    pub format: HorizonFormat,
    /// Also write the ambient-occlusion map.
    #[serde(default)]
    pub ao: bool,
}

/// Version of the horizon job (the baker's algorithm version and the job's own layout).
pub const ALGORITHM_VERSION: u32 = horizon::ALGORITHM_VERSION;

fn default_directions() -> u32 {
    32
}
fn default_near_field() -> u32 {
    DEFAULT_NEAR_FIELD
}

impl HorizonJob {
    /// A job with every setting at its default.
    pub fn new(id: &str, input: PathBuf) -> HorizonJob {
        HorizonJob {
            id: id.to_string(),
            input,
            channel: None,
            texel_size: unit_texel(),
            height_scale: 1.0,
            height_offset: 0.0,
            height_format: HeightFormat::R32Float,
            directions: default_directions(),
            edge: EdgeMode::Wrap,
            max_distance: None,
            near_field: DEFAULT_NEAR_FIELD,
            format: HorizonFormat::Rg16Float,
            ao: false,
        }
    }

    fn heightfield_job(&self) -> HeightfieldJob {
        HeightfieldJob {
            id: self.height_id(),
            input: self.input.clone(),
            channel: self.channel.clone(),
            texel_size: self.texel_size,
            height_scale: self.height_scale,
            height_offset: self.height_offset,
            format: self.height_format,
        }
    }

    fn settings(&self) -> HorizonSettings {
        HorizonSettings {
            directions: self.directions,
            edge: self.edge,
            max_distance: self.max_distance,
            near_field: self.near_field,
            format: self.format,
        }
    }

    /// Id of the heightfield asset.
    pub fn height_id(&self) -> String {
        format!("{}.height", self.id)
    }
    /// Id of the horizon asset.
    pub fn horizon_id(&self) -> String {
        format!("{}.horizon", self.id)
    }
    /// Id of the ambient-occlusion asset.
    pub fn ao_id(&self) -> String {
        format!("{}.ao", self.id)
    }

    pub(crate) fn outputs(&self) -> Vec<String> {
        let mut out = vec![self.height_id(), self.horizon_id()];
        if self.ao {
            out.push(self.ao_id());
        }
        out
    }

    pub(crate) fn canonical_settings(&self) -> String {
        format!(
            "{};directions={};edge={:?};max_distance={:?};near_field={};format={:?};ao={}",
            self.heightfield_job().canonical_settings(),
            self.directions,
            self.edge,
            self.max_distance,
            self.near_field,
            self.format,
            self.ao
        )
    }

    pub(crate) fn check(&self) -> Result<(), String> {
        check_world_units(self.texel_size, self.height_scale, self.height_offset)?;
        self.settings().check()
    }

    pub(crate) fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        self.heightfield_job().load(ctx).map(|_| ())
    }

    pub(crate) fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        let hf = self.heightfield_job().load(ctx)?;
        let settings = self.settings();
        let baked = horizon::bake(&hf, &settings, ctx.progress).map_err(|message| BakeError::Setting {
            path: ctx.base_dir.join("pipeline.ron"),
            job: self.id.clone(),
            message,
        })?;
        let info = HorizonInfo {
            heightfield: self.height_id(),
            directions: self.directions,
            edge: self.edge,
            max_distance: self.max_distance,
            near_field: self.near_field,
            texel_size: hf.texel_size,
            height_scale: hf.height_scale,
            open_sky_slope: OPEN_SKY_SLOPE,
            distance_scale: baked.distance_scale,
        };
        let mut assets = vec![BakedAsset {
            id: self.height_id(),
            kind: AssetKind::Heightfield,
            settings: Settings::Heightfield(settings_of(&hf)),
            payload: BakedPayload::Texture(hf.to_texture(self.height_format.texture_format())?),
        }];
        if self.ao {
            assets.push(BakedAsset {
                id: self.ao_id(),
                kind: AssetKind::AmbientOcclusion,
                settings: Settings::AmbientOcclusion(AmbientOcclusionSettings {
                    horizon: self.horizon_id(),
                    directions: self.directions,
                }),
                payload: BakedPayload::Texture(horizon::ambient_occlusion(&baked)),
            });
        }
        assets.push(BakedAsset {
            id: self.horizon_id(),
            kind: AssetKind::Horizon,
            settings: Settings::Horizon(info),
            payload: BakedPayload::Texture(baked.texture),
        });
        Ok(assets)
    }
}
