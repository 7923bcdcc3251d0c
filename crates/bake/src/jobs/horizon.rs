//! The `Horizon` job: a heightfield image → the heightfield asset, the horizon texture and,
//! optionally, an ambient-occlusion map derived from it.

use std::path::{Path, PathBuf};

use hikage_bundle::{AmbientOcclusionSettings, EdgeMode, HorizonSettings, Settings, TilePlacement};
use serde::{Deserialize, Serialize};

use super::heightfield::{HeightFormat, HeightfieldJob, check_world_units, one, unit_texel};
use super::{BakedAsset, BakedPayload, Baker, JobContext};
use crate::error::BakeError;
use crate::heightfield::Heightfield;
use crate::horizon::{self, DEFAULT_NEAR_FIELD, HorizonFormat, HorizonParams, OPEN_SKY_SLOPE};

/// Settings of a horizon bake. Asset ids: `<id>.height`, `<id>.horizon`, and `<id>.ao` with
/// `ao: true`.
///
/// With the `clap` feature it is also the `hikage horizon` command line (the id comes from
/// `--id` or the input's file stem).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
#[serde(deny_unknown_fields)]
pub struct HorizonJob {
    /// Prefix of the asset ids.
    #[cfg_attr(feature = "clap", arg(skip))]
    pub id: String,
    /// Heightfield: PNG (8/16-bit), OpenEXR, TIFF/GeoTIFF, SRTM .hgt, or raw .r16/.r32.
    pub input: PathBuf,
    /// Width and height of a raw .r16/.r32 input, WxH (none: a square map's side from its
    /// length).
    #[serde(default)]
    #[cfg_attr(feature = "clap", arg(long, value_name = "WxH", value_parser = super::heightfield::parse_raw_size))]
    pub raw_size: Option<(u32, u32)>,
    /// Channel of the input to take: R, G, B, A, Y or an EXR channel name (default: a grayscale
    /// PNG's luma; an EXR's Y, else R, else its only channel).
    #[serde(default)]
    #[cfg_attr(feature = "clap", arg(long))]
    pub channel: Option<String>,
    /// World units per texel along u (columns) and v (rows): SX, or SX,SY.
    #[serde(default = "unit_texel")]
    #[cfg_attr(feature = "clap", arg(long, value_name = "SX[,SY]", value_parser = super::heightfield::parse_texel_size, default_value = "1"))]
    pub texel_size: (f32, f32),
    /// World height = height_offset + height_scale × sample (integer images normalised to [0, 1]
    /// first).
    #[serde(default = "one")]
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1.0, allow_negative_numbers = true))]
    pub height_scale: f32,
    /// Added to every world height; see height_scale.
    #[serde(default)]
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 0.0, allow_negative_numbers = true))]
    pub height_offset: f32,
    /// Storage of the heightfield asset.
    #[serde(default)]
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = HeightFormat::R32Float))]
    pub height_format: HeightFormat,
    /// Azimuths D, 1–256; direction k has φ = 2πk/D.
    #[serde(default = "default_directions")]
    #[cfg_attr(feature = "clap", arg(long, default_value_t = default_directions()))]
    pub directions: u32,
    /// Wrap: rays continue on the torus (tileable maps); clamp: rays stop at the edge.
    #[serde(default)]
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = EdgeMode::Wrap))]
    pub edge: EdgeMode,
    /// Largest horizon distance in world units (none: to the edge, or one map length on a torus).
    #[serde(default)]
    #[cfg_attr(feature = "clap", arg(long, allow_negative_numbers = true))]
    pub max_distance: Option<f32>,
    /// Texels per ray traced exactly before the line sweep takes over, 0–64.
    #[serde(default = "default_near_field")]
    #[cfg_attr(feature = "clap", arg(long, default_value_t = DEFAULT_NEAR_FIELD))]
    pub near_field: u32,
    /// Storage of the horizon texture: rg16f, rg32f, or rg8 (the paper's memory; β step 0.71°).
    #[serde(default)]
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = HorizonFormat::Rg16Float))]
    pub format: HorizonFormat,
    /// Also write the ambient-occlusion map derived from the horizons.
    #[serde(default)]
    #[cfg_attr(feature = "clap", arg(long))]
    pub ao: bool,
    /// Bake in square tiles of this many texels, each tile its own assets
    /// (`<id>.height.<tx>_<ty>`, `<id>.horizon.<tx>_<ty>`, `<id>.ao.<tx>_<ty>`) with its place in
    /// the map, read from a window of the input around it; needs max_distance.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "clap", arg(long, value_name = "SIZE"))]
    pub tile: Option<u32>,
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
            raw_size: None,
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
            tile: None,
        }
    }

    pub(super) fn heightfield_job(&self) -> HeightfieldJob {
        HeightfieldJob {
            id: self.height_id(),
            input: self.input.clone(),
            channel: self.channel.clone(),
            texel_size: self.texel_size,
            height_scale: self.height_scale,
            height_offset: self.height_offset,
            format: self.height_format,
            raw_size: self.raw_size,
        }
    }

    /// The baker's parameters.
    pub fn params(&self) -> HorizonParams {
        HorizonParams {
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
}

impl Baker for HorizonJob {
    fn id(&self) -> &str {
        &self.id
    }

    fn kind(&self) -> &'static str {
        "horizon"
    }

    fn algorithm_version(&self) -> u32 {
        ALGORITHM_VERSION
    }

    fn inputs(&self, base_dir: &Path) -> Vec<PathBuf> {
        vec![base_dir.join(&self.input)]
    }

    fn outputs(&self) -> Vec<String> {
        let mut out = vec![self.height_id(), self.horizon_id()];
        if self.ao {
            out.push(self.ao_id());
        }
        out
    }

    fn canonical_settings(&self) -> String {
        // The tile size is appended only when given, so untiled jobs keep their hash's form.
        let tile = self.tile.map(|t| format!(";tile={t}")).unwrap_or_default();
        format!(
            "{};directions={};edge={:?};max_distance={:?};near_field={};format={:?};ao={}{tile}",
            self.heightfield_job().canonical_settings(),
            self.directions,
            self.edge,
            self.max_distance,
            self.near_field,
            self.format,
            self.ao
        )
    }

    fn check(&self) -> Result<(), String> {
        check_world_units(self.texel_size, self.height_scale, self.height_offset)?;
        self.params().check()?;
        if let Some(t) = self.tile {
            if t == 0 {
                return Err("tile must be at least 1 texel".into());
            }
            horizon::halo(&self.params(), self.texel_size).map(|_| ())?;
        }
        Ok(())
    }

    fn parts(&self, ctx: &JobContext) -> Result<Option<Vec<Box<dyn Baker>>>, BakeError> {
        match self.tile {
            Some(size) => super::horizon_tile::tiles(self, size, ctx).map(Some),
            None => Ok(None),
        }
    }

    fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        // A block of the file at a time, tiled or not: the map may not fit in memory.
        self.heightfield_job().scan(ctx)
    }

    fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        if let Some(parts) = self.parts(ctx)? {
            // The runner bakes the parts one by one; baked here, every tile is held at once.
            let mut assets = Vec::new();
            for part in parts {
                assets.extend(part.bake(ctx)?);
            }
            return Ok(assets);
        }
        let hf = self.heightfield_job().load(ctx)?;
        let baked = horizon::bake(&hf, &self.params(), ctx.progress).map_err(|m| ctx.setting(&self.id, m))?;
        self.assets(&hf, baked, None)
    }
}

impl HorizonJob {
    /// The assets of baked horizons and the heights they came from: `<id>.height`, `<id>.ao`
    /// with `ao`, and `<id>.horizon`; for a tile, each id followed by `.<tx>_<ty>` and the
    /// heights and horizons placed in the map.
    pub(super) fn assets(
        &self,
        hf: &Heightfield,
        baked: horizon::HorizonTexture,
        tile: Option<&TilePlacement>,
    ) -> Result<Vec<BakedAsset>, BakeError> {
        let suffix = tile.map(|t| format!(".{}_{}", t.index.0, t.index.1)).unwrap_or_default();
        let horizon_id = format!("{}{suffix}", self.horizon_id());
        let mut height = self.heightfield_job().asset(hf)?;
        height.id.push_str(&suffix);
        if let Settings::Heightfield(s) = &mut height.settings {
            s.tile = tile.cloned();
        }
        let settings = HorizonSettings {
            heightfield: height.id.clone(),
            directions: self.directions,
            edge: self.edge,
            max_distance: self.max_distance,
            near_field: self.near_field,
            texel_size: hf.texel_size,
            height_scale: hf.height_scale,
            open_sky_slope: OPEN_SKY_SLOPE,
            distance_scale: baked.distance_scale,
            tile: tile.cloned(),
        };
        let mut assets = vec![height];
        if self.ao {
            assets.push(BakedAsset {
                id: format!("{}{suffix}", self.ao_id()),
                settings: Settings::AmbientOcclusion(AmbientOcclusionSettings {
                    horizon: horizon_id.clone(),
                    directions: self.directions,
                }),
                payload: BakedPayload::Texture(horizon::ambient_occlusion(&baked)),
            });
        }
        assets.push(BakedAsset {
            id: horizon_id,
            settings: Settings::Horizon(settings),
            payload: BakedPayload::Texture(baked.texture),
        });
        Ok(assets)
    }
}
