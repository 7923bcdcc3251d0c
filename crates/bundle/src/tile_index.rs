//! [`TileIndex`]: the tiles of a bundle's maps, opened for a streaming reader — the manifest
//! and tile tables read once (as `Bundle::open` reads them), then any tile found by binary
//! search and its payload read and checked on demand.

use std::path::Path;

use crate::asset::Asset;
use crate::error::BundleError;
use crate::tiles::{TileSet, find_in_table, tile_id};

/// The tiles of a bundle's maps, found one at a time: what a game streaming a large terrain
/// opens instead of [`crate::Bundle::open`], which lists every tile as an asset. Opening reads
/// `bundle.ron` and each tile table whole (its size, BLAKE3 and every record's part checked),
/// and builds an entry only for the tiles asked for.
///
/// ```no_run
/// use hikage_bundle::tile_index::TileIndex;
/// let index = TileIndex::open("bundle".as_ref())?;
/// // The heights of the tile at column 3, row 5 of level 1, and their texels.
/// if let Some(tile) = index.tile("terrain.height", 1, (3, 5)) {
///     let heights = index.read_texture(&tile)?;
///     println!("{}×{} heights at {:?}", heights.desc.width, heights.desc.height, tile.settings.tile());
/// }
/// # Ok::<(), hikage_bundle::BundleError>(())
/// ```
#[derive(Clone, Debug)]
pub struct TileIndex {
    dir: std::path::PathBuf,
    limits: crate::Limits,
    sets: Vec<(TileSet, Vec<u8>)>,
}

impl TileIndex {
    /// Opens the tile sets of the bundle in `dir` with the default [`crate::Limits`].
    pub fn open(dir: &Path) -> Result<TileIndex, BundleError> {
        TileIndex::open_with_limits(dir, crate::Limits::default())
    }

    /// Opens the tile sets of the bundle in `dir`: the manifest and tables within `limits`.
    pub fn open_with_limits(dir: &Path, limits: crate::Limits) -> Result<TileIndex, BundleError> {
        let path = dir.join(crate::MANIFEST_FILE);
        let text = crate::files::read_limited(&path, limits.max_manifest_bytes, "manifest size")?;
        let text = String::from_utf8_lossy(&text);
        let read = &mut |set: &TileSet, length: u64| {
            crate::files::read_in_bundle(&dir.join(&set.table), length, "tile table size")
        };
        let (_, sets) = crate::Manifest::read_tables(&text, &path, &limits, read)?;
        for (set, bytes) in &sets {
            // Each part as a reader of the full manifest checks it, its first tile standing for
            // the rest (they differ only in numbers `read_tables` checked).
            let mut manifest = crate::Manifest::new();
            manifest.assets = crate::tiles::first_tiles(set, bytes);
            if let Some((asset, message)) = crate::bundle::manifest_problems(&manifest, &limits).into_iter().next() {
                return Err(BundleError::InvalidAsset { path: path.clone(), asset, message });
            }
        }
        Ok(TileIndex { dir: dir.to_path_buf(), limits, sets })
    }

    /// The tile sets, one per map baked in tiles, in map order.
    pub fn sets(&self) -> impl Iterator<Item = &TileSet> {
        self.sets.iter().map(|(set, _)| set)
    }

    /// The entry of the tile payload `part` (a tile's id less its suffix, e.g.
    /// `terrain.horizon`) at `level`, column and row `index`; `None` when there is none.
    pub fn tile(&self, part: &str, level: u32, index: (u32, u32)) -> Option<Asset> {
        let id = tile_id(part, level, index);
        self.sets.iter().find_map(|(set, bytes)| find_in_table(set, bytes, &id))
    }

    /// Reads and decodes a tile's texture (from [`TileIndex::tile`]), its size, BLAKE3 and
    /// KTX2 header checked against the entry.
    pub fn read_texture(&self, tile: &Asset) -> Result<crate::TextureData, BundleError> {
        let bytes = crate::bundle::read_payload_in(&self.dir, tile, &self.limits)?;
        crate::bundle::decode_texture(tile, &bytes, &self.dir.join(&tile.file), &self.limits)
    }
}
