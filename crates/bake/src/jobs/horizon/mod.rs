//! The `Horizon` job: a heightfield image → the heightfield asset, the horizon texture and,
//! optionally, an ambient-occlusion map derived from it; whole, or in tiles (`tile: Some(SIZE)`, each tile a job of its own).

mod tile;

use std::path::{Path, PathBuf};

use hikage_bundle::{AmbientOcclusionSettings, EdgeMode, HorizonSettings, Settings, TilePlacement};
use serde::{Deserialize, Deserializer, Serialize};

use super::heightfield::{HeightFormat, canonical};
use super::source::{HeightSource, deserialize_flat};
use super::{BakedAsset, Baker, JobContext};
use crate::error::BakeError;
use crate::heightfield::Heightfield;
use crate::horizon::{self, DEFAULT_NEAR_FIELD, HorizonFormat, HorizonParams, OPEN_SKY_SLOPE};

/// A horizon bake. Asset ids: `<id>.height`, `<id>.horizon`, and `<id>.ao` with `ao: true`.
///
/// With the `clap` feature it is also the `hikage horizon` command line (the id comes from
/// `--id` or the input's file stem).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct HorizonJob {
    /// Prefix of the asset ids.
    #[cfg_attr(feature = "clap", arg(skip))]
    pub id: String,
    /// The input and its world units.
    #[cfg_attr(feature = "clap", command(flatten))]
    pub source: HeightSource,
    /// The job's own settings.
    #[cfg_attr(feature = "clap", command(flatten))]
    pub options: HorizonOptions,
}

/// The `Horizon` job's own settings (beside its [`HeightSource`]). Each default is the one of
/// [`HorizonOptions::default`], which `pipeline.ron`, the command line and
/// [`HorizonJob::new`] all take.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct HorizonOptions {
    /// Storage of the heightfield asset.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = HorizonOptions::default().height_format))]
    pub height_format: HeightFormat,
    /// Azimuths D, 1–256; direction k has φ = 2πk/D.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = HorizonOptions::default().directions))]
    pub directions: u32,
    /// Wrap: rays continue on the torus (tileable maps); clamp: rays stop at the edge.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = HorizonOptions::default().edge))]
    pub edge: EdgeMode,
    /// Largest horizon distance in world units (none: to the edge, or one map length on a torus).
    #[cfg_attr(feature = "clap", arg(long, allow_negative_numbers = true))]
    pub max_distance: Option<f32>,
    /// Texels per ray traced exactly before the line sweep takes over, 0–64.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = HorizonOptions::default().near_field))]
    pub near_field: u32,
    /// Storage of the horizon texture: rg16f, rg32f, rg8 (the paper's memory; β step 0.71°), or
    /// bc5 (a quarter of rg16f; rounded toward shadow, never lighter than the exact bake).
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = HorizonOptions::default().format))]
    pub format: HorizonFormat,
    /// Also write the ambient-occlusion map derived from the horizons.
    #[cfg_attr(feature = "clap", arg(long))]
    pub ao: bool,
    /// Bake in square tiles of this many texels, each tile its own assets
    /// (`<id>.height.<tx>_<ty>`, `<id>.horizon.<tx>_<ty>`, `<id>.ao.<tx>_<ty>`) with its place in
    /// the map, read from a window of the input around it; needs max_distance.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "clap", arg(long, value_name = "SIZE"))]
    pub tile: Option<u32>,
    /// Levels of detail of a tiled bake, level 0 included: level `k` is the map reduced by
    /// `2^k` (each coarse node the mean height within `2^(k-1)` texels of it), baked in
    /// tiles of the same size with the same max_distance; ids `<id>.horizon.L<k>.<tx>_<ty>`.
    /// Levels past the one that fits in a single tile are not made (a large number gives
    /// every level). None: level 0 only.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "clap", arg(long, value_name = "N", requires = "tile"))]
    pub levels: Option<u32>,
    /// Payload compression: `Auto` (a zstd level per kind of payload, `--zstd auto`), `Zstd(level)`
    /// (1–22), or `None` (`--zstd 0`).
    #[cfg_attr(
        feature = "clap",
        arg(long = "zstd", value_name = "LEVEL", value_parser = crate::compression::parse_level, default_value = "auto")
    )]
    pub compression: crate::Compression,
}

impl Default for HorizonOptions {
    fn default() -> Self {
        HorizonOptions {
            height_format: HeightFormat::R32Float,
            directions: 32,
            edge: EdgeMode::Wrap,
            max_distance: None,
            near_field: DEFAULT_NEAR_FIELD,
            format: HorizonFormat::Rg16Float,
            ao: false,
            tile: None,
            levels: None,
            compression: crate::Compression::default(),
        }
    }
}

impl<'de> Deserialize<'de> for HorizonJob {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (id, source, options) = deserialize_flat(d, "Horizon")?;
        Ok(HorizonJob { id, source, options })
    }
}

/// Version of the horizon job (the baker's algorithm version and the job's own layout).
pub const ALGORITHM_VERSION: u32 = horizon::ALGORITHM_VERSION;

impl HorizonJob {
    /// A job with every setting at its default.
    pub fn new(id: &str, input: PathBuf) -> HorizonJob {
        HorizonJob { id: id.to_string(), source: HeightSource::new(input), options: HorizonOptions::default() }
    }

    /// The baker's parameters.
    pub fn params(&self) -> HorizonParams {
        let o = &self.options;
        HorizonParams {
            directions: o.directions,
            edge: o.edge,
            max_distance: o.max_distance,
            near_field: o.near_field,
            format: o.format,
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

    /// What each height sample must pass: storable in the height format.
    fn sample_check(&self) -> impl Fn(f32) -> Result<(), String> + '_ {
        |v| self.options.height_format.check(v)
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
        vec![self.source.path(base_dir)]
    }

    fn outputs(&self) -> Vec<String> {
        let mut out = vec![self.height_id(), self.horizon_id()];
        if self.options.ao {
            out.push(self.ao_id());
        }
        out
    }

    fn canonical_settings(&self) -> String {
        let o = &self.options;
        // The tile size is appended only when given, so untiled jobs keep their hash's form.
        let tile = o.tile.map(|t| format!(";tile={t}")).unwrap_or_default()
            + &o.levels.map(|n| format!(";levels={n}")).unwrap_or_default();
        format!(
            "{};directions={};edge={:?};max_distance={:?};near_field={};format={:?};ao={}{tile}",
            canonical(&self.source, o.height_format),
            o.directions,
            o.edge,
            o.max_distance,
            o.near_field,
            o.format,
            o.ao
        )
    }

    fn check(&self) -> Result<(), String> {
        self.source.check()?;
        self.params().check()?;
        if let Some(t) = self.options.tile {
            if t == 0 {
                return Err("tile must be at least 1 texel".into());
            }
            horizon::halo(&self.params(), self.source.texel_size).map(|_| ())?;
        }
        match (self.options.levels, self.options.tile) {
            (Some(0), _) => return Err("levels must be at least 1 (level 0, the map itself)".into()),
            (Some(_), None) => return Err("levels are baked in tiles: set tile too".into()),
            _ => {}
        }
        Ok(())
    }

    fn parts(&self, ctx: &JobContext) -> Result<Option<Vec<Box<dyn Baker>>>, BakeError> {
        match self.options.tile {
            Some(size) => tile::tiles(self, size, ctx).map(Some),
            None => Ok(None),
        }
    }

    fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        // A block of the file at a time, tiled or not: the map may not fit in memory.
        self.source.scan(ctx, self.options.tile.is_none(), &self.sample_check()).map(|_| ())
    }

    fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        if self.options.tile.is_some() {
            // Tiles are jobs of their own (`parts`), baked one by one by the runner.
            return Err(ctx.setting(&self.id, "a tiled job is baked by the runner, a tile at a time (see `parts`)"));
        }
        let hf = self.source.load(ctx, &self.sample_check())?;
        let baked = horizon::bake(&hf, &self.params(), ctx.progress).map_err(|m| ctx.setting(&self.id, m))?;
        self.assets(&hf, baked, None)
    }
}

impl HorizonJob {
    /// The assets of baked horizons and the heights they came from: `<id>.height`, `<id>.ao`
    /// with `ao`, and `<id>.horizon`; for a tile, each id followed by `.<tx>_<ty>` (`.L<k>.<tx>_<ty>`
    /// at level `k`) and the heights and horizons placed in the map.
    fn assets(
        &self,
        hf: &Heightfield,
        baked: horizon::HorizonTexture,
        tile: Option<&TilePlacement>,
    ) -> Result<Vec<BakedAsset>, BakeError> {
        let o = &self.options;
        // A tile's ids are its parts' with its suffix.
        let id = |part: String| match tile {
            Some(t) => hikage_bundle::tiles::tile_id(&part, t.level, t.index),
            None => part,
        };
        let horizon_id = id(self.horizon_id());
        let mut height = o.height_format.asset(&id(self.height_id()), hf)?;
        if let Settings::Heightfield(s) = &mut height.settings {
            s.tile = tile.cloned();
        }
        let settings = HorizonSettings {
            heightfield: height.id.clone(),
            directions: o.directions,
            edge: o.edge,
            max_distance: o.max_distance,
            near_field: o.near_field,
            texel_size: hf.texel_size,
            height_scale: hf.height_scale,
            open_sky_slope: OPEN_SKY_SLOPE,
            distance_scale: baked.distance_scale,
            tile: tile.cloned(),
        };
        let mut assets = vec![height];
        if o.ao {
            assets.push(BakedAsset {
                id: id(self.ao_id()),
                settings: Settings::AmbientOcclusion(AmbientOcclusionSettings {
                    horizon: horizon_id.clone(),
                    directions: o.directions,
                    tile: tile.cloned(),
                }),
                payload: horizon::ambient_occlusion(&baked).into(),
            });
        }
        assets.push(BakedAsset {
            id: horizon_id,
            settings: Settings::Horizon(settings),
            payload: baked.texture.into(),
        });
        Ok(assets)
    }
}
