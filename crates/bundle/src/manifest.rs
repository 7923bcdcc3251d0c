//! The schema of `bundle.ron`.
//!
//! The manifest is RON, written with assets sorted by id and no timestamps, so the same inputs
//! give a byte-identical file. A minor version bump only adds optional fields (older readers
//! ignore them); a major bump changes meaning, and readers refuse a major they do not know.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::asset::Asset;
use crate::budget::Budget;
use crate::error::BundleError;
use crate::limits::Limits;
use crate::tiles::TileSet;
use crate::version::FormatVersion;

/// File name of the manifest inside a bundle directory.
pub const MANIFEST_FILE: &str = "bundle.ron";

/// The whole manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Format version of this manifest.
    pub format: FormatVersion,
    /// Program that wrote the bundle, e.g. `hikage 0.1.0`.
    pub generator: String,
    /// The byte budgets the bundle was baked under, checked again by `validate` (since 1.8).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub budget: Option<Budget>,
    /// The assets, sorted by id.
    pub assets: Vec<Asset>,
}

impl Manifest {
    /// An empty manifest of the current version.
    pub fn new() -> Self {
        Manifest {
            format: FormatVersion::CURRENT,
            generator: crate::GENERATOR.to_string(),
            budget: None,
            assets: Vec::new(),
        }
    }

    /// Every asset as a [`Budget`] weighs it: `budget.overruns(&manifest.weights())`.
    pub fn weights(&self) -> Vec<crate::budget::Weight<'_>> {
        self.assets.iter().map(Asset::weight).collect()
    }

    /// The asset with this id.
    pub fn asset(&self, id: &str) -> Option<&Asset> {
        // Manifests read or written are sorted by id; one built by hand may not be.
        match self.assets.binary_search_by(|a| a.id.as_str().cmp(id)) {
            Ok(i) => Some(&self.assets[i]),
            Err(_) => self.assets.iter().find(|a| a.id == id),
        }
    }

    /// Parses a manifest that has no tile sets, checking the version first so that a newer
    /// major is reported as such rather than as a schema mismatch. `path` is only used in error
    /// messages. A manifest with tile sets needs its tables: [`Manifest::parse_with_tables`].
    pub fn parse(text: &str, path: &Path) -> Result<Manifest, BundleError> {
        Manifest::parse_with_tables(text, path, &Limits::default(), &mut |set| {
            Err(BundleError::Lookup {
                path: path.to_path_buf(),
                message: format!("the tile table `{}` of map `{}` was not given to the parser", set.table, set.map),
            })
        })
    }

    /// Parses a manifest, reading each tile set's table with `read_table` (given the set, with
    /// its size checked against `limits` before it is asked for) and listing every tile as an
    /// asset. Assets are sorted by id.
    pub fn parse_with_tables(
        text: &str,
        path: &Path,
        limits: &Limits,
        read_table: &mut dyn FnMut(&TileSet) -> Result<Vec<u8>, BundleError>,
    ) -> Result<Manifest, BundleError> {
        let (file, tables) = Manifest::read_tables(text, path, limits, &mut |set, _| read_table(set))?;
        let mut assets = file.assets;
        for (set, bytes) in &tables {
            assets.extend(crate::tiles::tile_assets(set, bytes));
        }
        if !tables.is_empty() {
            assets.sort_by(|a, b| a.id.cmp(&b.id));
        }
        Ok(Manifest { format: file.format, generator: file.generator, budget: file.budget, assets })
    }

    /// The one reading of a manifest's tile tables, for [`Manifest::parse_with_tables`] and
    /// [`crate::tile_index::TileIndex`] alike: each table's name inside the bundle, its records
    /// counted with the plain assets against `limits.max_assets` (a limit error past it), its
    /// length checked before `read_table(set, length)` is asked for it, then its size, hash,
    /// header and records as the tile reader relies on them.
    pub(crate) fn read_tables(
        text: &str,
        path: &Path,
        limits: &Limits,
        read_table: &mut TableReader<'_>,
    ) -> Result<(ManifestFile, Vec<TableBytes>), BundleError> {
        let mut file = Manifest::parse_file(text, path)?;
        let mut room = (limits.max_assets as u64).saturating_sub(file.assets.len() as u64);
        let mut tables = Vec::new();
        for set in std::mem::take(&mut file.tile_sets) {
            let table_path = path.with_file_name(&set.table);
            let bad = |message: String| BundleError::Payload {
                path: table_path.clone(),
                asset: set.map.clone(),
                message: format!("tile table: {message}"),
            };
            if !crate::names::is_safe_file_name(&set.table) {
                return Err(bad(format!("{:?} is not a plain file name inside the bundle directory", set.table)));
            }
            if set.records > room {
                return Err(BundleError::Limit {
                    path: table_path.clone(),
                    what: "asset count with the tiles".into(),
                    value: limits.max_assets as u64 - room + set.records,
                    limit: limits.max_assets as u64,
                });
            }
            let length = crate::tiles::expected_bytes(&set, room).map_err(bad)?;
            let bytes = read_table(&set, length)?;
            crate::tiles::check(&set, &bytes, room).map_err(bad)?;
            room -= set.records;
            tables.push((set, bytes));
        }
        Ok((file, tables))
    }

    /// The tile sets `bundle.ron`'s `text` lists, its tables not read: what a reader needs to
    /// find one tile with [`crate::tiles::find_tile`] (or to fetch the tables itself).
    pub fn tile_sets(text: &str, path: &Path) -> Result<Vec<TileSet>, BundleError> {
        Ok(Manifest::parse_file(text, path)?.tile_sets)
    }

    fn parse_file(text: &str, path: &Path) -> Result<ManifestFile, BundleError> {
        #[derive(Deserialize)]
        struct VersionOnly {
            format: FormatVersion,
        }
        // Read the version alone first: its fields are stable across majors.
        let version = ron::Options::default().from_str::<VersionOnly>(text).map(|v| v.format).ok();
        if let Some(found) = version
            && found.major != FormatVersion::CURRENT.major
        {
            return Err(BundleError::UnsupportedVersion {
                path: path.to_path_buf(),
                found,
                supported: FormatVersion::CURRENT,
            });
        }
        ron::Options::default().from_str::<ManifestFile>(text).map_err(|e| BundleError::ManifestSyntax {
            path: path.to_path_buf(),
            line: e.span.start.line,
            col: e.span.start.col,
            message: e.code.to_string(),
        })
    }

    /// The payload files and tile tables the manifest names.
    pub fn files(&self) -> std::collections::BTreeSet<String> {
        let (_, tables) = self.encode();
        self.assets.iter().map(|a| a.file.clone()).chain(tables.into_iter().map(|(name, _)| name)).collect()
    }

    /// Serialises the manifest: pretty RON with assets sorted by id, ending in a newline. Tiles
    /// are written as tile sets ([`crate::tiles`]); [`Manifest::encode`] also gives the tables.
    pub fn to_ron(&self) -> String {
        self.encode().0
    }

    /// The `bundle.ron` text and the tile tables it names (file name, bytes): the same
    /// manifest always gives the same bytes.
    pub fn encode(&self) -> (String, crate::tiles::TableFiles) {
        let (mut assets, sets) = crate::tiles::pack(&self.assets);
        assets.sort_by(|a, b| a.id.cmp(&b.id));
        let (tile_sets, tables): (Vec<TileSet>, crate::tiles::TableFiles) =
            sets.into_iter().map(|(set, bytes)| (set.clone(), (set.table, bytes))).unzip();
        let file = ManifestFile {
            format: self.format,
            generator: self.generator.clone(),
            budget: self.budget.clone(),
            assets,
            tile_sets,
        };
        let config = ron::ser::PrettyConfig::new().indentor("    ").struct_names(false).compact_arrays(false);
        let mut text = ron::ser::to_string_pretty(&file, config).expect("manifest types always serialise");
        text.push('\n');
        (text, tables)
    }
}

/// How [`Manifest::read_tables`] gets a table's bytes: given the set and the length it must have.
pub(crate) type TableReader<'a> = dyn FnMut(&TileSet, u64) -> Result<Vec<u8>, BundleError> + 'a;

/// A tile set and its table's bytes, checked.
pub(crate) type TableBytes = (TileSet, Vec<u8>);

/// `bundle.ron` as written: the plain entries, and the maps baked in tiles as tile sets.
#[derive(Serialize, Deserialize)]
pub(crate) struct ManifestFile {
    format: FormatVersion,
    generator: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    budget: Option<Budget>,
    pub(crate) assets: Vec<Asset>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    tile_sets: Vec<TileSet>,
}

impl Default for Manifest {
    fn default() -> Self {
        Manifest::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_major_is_named() {
        let text = "(format: (major: 7, minor: 2), generator: \"x\", assets: [], later: 1)";
        let err = Manifest::parse(text, Path::new("b/bundle.ron")).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("7.2") && msg.contains(&FormatVersion::CURRENT.to_string()), "{msg}");
    }

    #[test]
    fn syntax_errors_have_line_and_column() {
        let text = "(\n  format: (major: 1, minor: 0),\n  generator: 5,\n  assets: [],\n)";
        match Manifest::parse(text, Path::new("bundle.ron")).unwrap_err() {
            BundleError::ManifestSyntax { line, col, .. } => {
                assert_eq!(line, 3);
                assert!(col > 1);
            }
            e => panic!("unexpected {e}"),
        }
    }
}
