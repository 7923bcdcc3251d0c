//! One tile of a tiled `Horizon` job: a part of its own, baked from a window of the input.
//!
//! A job with `tile: Some(size)` is split into square tiles, one every `size` texels, numbered
//! by column and row in the grid of tiles; with `levels`, each level of detail
//! ([`horizon::pyramid`]) is split the same way in its own texels. Each holds `size + 1` texels a side (fewer at the
//! map's right and bottom edges): its last column and row are the next tile's first, so meshes
//! drawn through texel centres meet without a crack. Each tile reads
//! its window of the input (the tile and a halo of `max_distance`) and writes the tile's
//! heights, horizon texture and, with `ao`, occlusion, each with a [`TilePlacement`]. Its
//! texels are those the whole-map bake has there (`horizon::bake_tile`).
//!
//! A tile's input hash covers the job's settings, the tile's index and the samples it reads:
//! its window (the tile, its halo and the interpolation border) at its level, level 0's as read
//! and a coarser level's as reduced, voids filled. Only those: an edit rebakes exactly the tiles
//! whose windows hold a changed sample, and the coarser tiles whose reduced windows change. The
//! windows are read and hashed when the job is split, through the same reads the bake makes
//! (raw, TIFF and `.hgt` grids a window at a time; PNG and EXR decoded once).

use std::path::{Path, PathBuf};

use hikage_bundle::TilePlacement;
use rayon::prelude::*;

use super::HorizonJob;
use crate::error::BakeError;
use crate::heightfield::{HeightFile, Heightfield};
use crate::horizon::{self, Rect, TileWindow};
use crate::jobs::{BakedAsset, Baker, JobContext};

/// One tile of a tiled horizon job.
#[derive(Clone, Debug)]
pub struct HorizonTileJob {
    /// `<job id>.<tx>_<ty>`, or `<job id>.L<k>.<tx>_<ty>` at level `k`.
    id: String,
    job: HorizonJob,
    /// Level of detail: the map reduced by `2^level` ([`horizon::pyramid`]).
    level: u32,
    /// Column and row in the level's grid of tiles.
    index: (u32, u32),
    /// The tile and its window, in the level's texels.
    place: TileWindow,
    /// The input's size (level 0).
    map: (u32, u32),
    /// BLAKE3 of the samples the tile reads (its window at its level), which its input hash
    /// stands on.
    input_digest: String,
    /// The value the input's voids take (its lowest valid sample), found once for all tiles.
    void_fill: Option<f32>,
}

/// Splits `job` into its tiles of `size` texels, reading the input's header, finding the value
/// of its voids, and hashing each tile's window.
pub(super) fn tiles(job: &HorizonJob, size: u32, ctx: &JobContext) -> Result<Vec<Box<dyn Baker>>, BakeError> {
    let limits = ctx.limits;
    let setting = |message: String| ctx.setting(&job.id, message);
    let mut source = job.source.open(ctx)?;
    let map = source.size();
    let void_fill = source.void_fill()?;
    // Tiles start every `size` texels and hold one more, the next tile's first column and row:
    // a mesh through texel centres then meets its neighbour's without a crack.
    let count = |n: u32| (n.saturating_sub(1)).div_ceil(size).max(1);
    let mut places = Vec::new();
    for level in 0..job.options.levels.unwrap_or(1) {
        let (w, h) = horizon::pyramid::level_size(map, level, job.options.edge).map_err(setting)?;
        let s = (1u32 << level) as f32;
        let texel = (job.source.texel_size.0 * s, job.source.texel_size.1 * s);
        let halo = horizon::halo(&job.params(), texel).map_err(setting)?;
        for ty in 0..count(h) {
            for tx in 0..count(w) {
                let (x, y) = (tx * size, ty * size);
                let rect = Rect::new(x, y, size.saturating_add(1).min(w - x), size.saturating_add(1).min(h - y));
                let place = TileWindow::new((w, h), rect, halo, job.options.edge);
                let (ww, wh) = (place.window.width, place.window.height);
                if ww.max(wh) > limits.max_dimension {
                    return Err(setting(format!(
                        "a {}×{} tile with a halo of {halo:?} texels (max_distance {:?}) reads a {ww}×{wh} window of \
                         heights, above the limit of {}: lower tile or max_distance",
                        rect.width, rect.height, job.options.max_distance, limits.max_dimension
                    )));
                }
                places.push((level, (tx, ty), place));
            }
        }
        if count(w) == 1 && count(h) == 1 {
            break;
        }
    }
    let (normalized, channel) = source.channel();
    let digest = |file: &mut HeightFile, &(level, _, place): &(u32, (u32, u32), TileWindow)| {
        let samples = read_window(file, (map, level, job.options.edge), place.window, void_fill)?;
        let mut digest = blake3::Hasher::new();
        digest.update(format!("map={map:?};normalized={normalized};channel={channel};").as_bytes());
        let mut bytes = vec![0u8; 4 << 16];
        for chunk in samples.chunks(1 << 16) {
            let bytes = &mut bytes[..4 * chunk.len()];
            bytes.chunks_exact_mut(4).zip(chunk).for_each(|(b, v)| b.copy_from_slice(&v.to_le_bytes()));
            digest.update(bytes);
        }
        Ok::<_, BakeError>(digest.finalize().to_hex().to_string())
    };
    // Windows of formats read by seeking are read on every thread, each with its own reader.
    let parallel = source.readers().map(|reader| places.par_iter().map_init(reader, |f, p| digest(f, p)).collect());
    let digests: Vec<Result<String, BakeError>> =
        parallel.unwrap_or_else(|| places.iter().map(|p| digest(&mut source, p)).collect());
    let mut parts: Vec<Box<dyn Baker>> = Vec::new();
    for ((level, index, place), input_digest) in places.into_iter().zip(digests) {
        parts.push(Box::new(HorizonTileJob {
            id: hikage_bundle::tiles::tile_id(&job.id, level, index),
            job: job.clone(),
            level,
            index,
            place,
            map,
            input_digest: input_digest?,
            void_fill,
        }));
    }
    Ok(parts)
}

/// The samples of `window` (in the level's texels) at `level` of the map of `file`: level 0's as
/// read, a coarser level's reduced from them; voids take `fill`.
fn read_window(
    file: &mut HeightFile,
    (map, level, edge): ((u32, u32), u32, hikage_bundle::EdgeMode),
    window: Rect<i64>,
    fill: Option<f32>,
) -> Result<Vec<f32>, BakeError> {
    if level == 0 {
        file.read_window((window.x, window.y), (window.width, window.height), fill)
    } else {
        horizon::pyramid::read_reduced(file, map, level, edge, window, fill)
    }
}

impl HorizonTileJob {
    fn suffix(&self) -> String {
        hikage_bundle::tiles::tile_suffix(self.level, self.index)
    }

    fn placement(&self) -> TilePlacement {
        TilePlacement {
            map: self.job.id.clone(),
            index: self.index,
            origin: (self.place.tile.x, self.place.tile.y),
            map_size: self.place.map,
            level: self.level,
        }
    }

    /// The tile's texels of the window's heights.
    fn tile_heights(&self, window: &Heightfield) -> Heightfield {
        let Rect { x: tx, y: ty, width: tw, height: th } = self.place.tile;
        let (x0, y0) = ((tx as i64 - self.place.window.x) as usize, (ty as i64 - self.place.window.y) as usize);
        let ww = window.width as usize;
        let samples = (0..th as usize)
            .flat_map(|r| window.samples[(y0 + r) * ww + x0..][..tw as usize].iter().copied())
            .collect();
        Heightfield { width: tw, height: th, samples, ..window.clone() }
    }
}

impl Baker for HorizonTileJob {
    fn id(&self) -> &str {
        &self.id
    }

    fn kind(&self) -> &'static str {
        "horizon"
    }

    fn algorithm_version(&self) -> u32 {
        self.job.algorithm_version()
    }

    /// None: the samples the tile reads are hashed when the job is split, their BLAKE3 part of
    /// the settings.
    fn inputs(&self, _base_dir: &Path) -> Vec<PathBuf> {
        Vec::new()
    }

    fn outputs(&self) -> Vec<String> {
        self.job.outputs().into_iter().map(|id| format!("{id}{}", self.suffix())).collect()
    }

    fn canonical_settings(&self) -> String {
        // The level only when above 0, so level-0 tiles keep their hash's form.
        let level = if self.level > 0 { format!(";level={}", self.level) } else { String::new() };
        format!(
            "{};tile_index=({},{}){level};window_blake3={}",
            self.job.canonical_settings(),
            self.index.0,
            self.index.1,
            self.input_digest
        )
    }

    fn check(&self) -> Result<(), String> {
        self.job.check()
    }

    fn tile_area(&self) -> Option<crate::jobs::TileArea> {
        let Rect { x, y, width, height } = self.place.tile;
        Some(crate::jobs::TileArea { map: self.job.id.clone(), level: self.level, rect: (x, y, width, height) })
    }

    fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        self.job.check_inputs(ctx)
    }

    fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        let path = self.job.source.path(ctx.base_dir);
        let mut source = self.job.source.open(ctx)?;
        if source.size() != self.map {
            let (w, h) = self.map;
            let (fw, fh) = source.size();
            return Err(BakeError::input(
                &path,
                None,
                format!("expected the {w}×{h} map the job was split for, found {fw}×{fh}"),
            ));
        }
        let Rect { x: wx, y: wy, width: ww, height: wh } = self.place.window;
        let heights = &self.job.source;
        let edge = self.job.options.edge;
        let samples = read_window(&mut source, (self.map, self.level, edge), self.place.window, self.void_fill)?;
        if self.level == 0 {
            // The checks a whole-map load makes, on the samples this tile reads (level 0
            // reads every sample a coarser level reduces).
            heights.check_samples(&path, &samples, ((wx, wy), ww, self.map), &self.job.sample_check())?;
        }
        let (normalized, source_channel) = source.channel();
        let s = (1u32 << self.level) as f32;
        let window = Heightfield {
            width: ww,
            height: wh,
            samples,
            texel_size: (heights.texel_size.0 * s, heights.texel_size.1 * s),
            height_scale: heights.height_scale,
            height_offset: heights.height_offset,
            normalized,
            source_channel,
        };
        let params = self.job.params();
        let baked =
            horizon::bake_tile(&window, &self.place, &params, ctx.progress).map_err(|m| ctx.setting(&self.id, m))?;
        self.job.assets(&self.tile_heights(&window), baked, Some(&self.placement()))
    }
}
