//! The schema of `bundle.ron`.
//!
//! The manifest is RON, written with assets sorted by id and no timestamps, so the same inputs
//! give a byte-identical file. A minor version bump only adds optional fields (older readers
//! ignore them); a major bump changes meaning, and readers refuse a major they do not know.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::BundleError;
use crate::limits::Limits;
use crate::mesh::{ComponentType, MeshDesc};
use crate::settings::Settings;
use crate::texture::TextureDesc;
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
    pub budget: Option<crate::budget::Budget>,
    /// The assets, sorted by id.
    pub assets: Vec<Asset>,
}

/// What an asset is for; decides which [`Settings`] and [`Payload`] it must carry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum AssetKind {
    /// A heightfield: a one-channel 2D texture of samples; world height is
    /// `height_offset + height_scale × sample`.
    Heightfield,
    /// Horizon and distance maps (seed 000): a two-channel 3D texture `W×H×D` with the azimuth
    /// `φ_k = 2πk/D` on the depth axis; channel 0 `tan β`, channel 1 `d` (world units).
    Horizon,
    /// Ambient occlusion derived from horizons: a one-channel 2D texture, the occluded share of
    /// the cosine-weighted hemisphere (0 open, 1 closed). Sky visibility, the factor ambient
    /// light is multiplied by, is `1 − ao`.
    AmbientOcclusion,
    /// Per-vertex principal curvatures of a mesh (seed 000 §3.1): a mesh with F32 streams
    /// `position` (3), `uv` (2), `normal` (3), `curvature` (κ1 ≥ κ2, 1/world units), `principal1`
    /// and `principal2` (2 each: the principal directions in the vertex's texture frame, as
    /// their dot products with the unit tangents of +u and +v), since format 1.3 `tangent_u`
    /// and `tangent_v` (3 each: `P_u = ∂P/∂u`, `P_v = ∂P/∂v`, world units per texture unit), and
    /// U32 triangle indices.
    Curvature,
    /// Relief-mapping depth maps (seed 003): a one-channel 2D-array texture, one layer per
    /// hemisphere direction ([`crate::relief::ReliefDirections`]), each texel the normalised
    /// depth of the first hit of the ray entering the top plane there, MIN-downscaled so it never
    /// lies deeper than a hit.
    Relief,
    /// A max-mip pyramid of a heightfield: a one-channel 2D texture whose level 0 holds the
    /// samples and each further mip level the largest of the 2×2 texels below.
    MaxMip,
    /// Hair strips (seed 004), since format 1.5: one 32-byte record per strand point (no
    /// indices), drawn as one instanced quad per segment that the vertex shader widens into a
    /// view-facing strip. Streams ([`STRANDS_STREAMS`], interleaved): `position` (F32 × 3, the
    /// centre line), `tangent` (U16 × 2, octahedral unit vector, averaged at joints), `shape` (U16
    /// × 2 unorm: shading width as a share of [`StrandsSettings::max_width`](crate::StrandsSettings::max_width), shading opacity),
    /// `color` (U8 × 4: sRGB-encoded RGB, 255), `strand` (U16 × 2: the point's index in its
    /// strand, the strand's segment count; `param` = index / segments) and `strand_id` (U32, the
    /// strand's index in the source file). Strands are stored in a fixed shuffled order so the
    /// first strands of [`StrandsSettings::levels`](crate::StrandsSettings::levels) are an even thinning (levels of detail).
    Strands,
    /// Where each strand of a `Strands` asset is rooted on a skinned scalp (since format 1.11):
    /// one element per strand, in strand-id order (the source file's), streams
    /// ([`BINDING_STREAMS`]) `triangle` (U32, a triangle of the [`AssetKind::Scalp`] its
    /// settings name) and `barycentric` (U16 × 2 unorm: the weights of the triangle's second
    /// and third vertex; the first's is 1 − both). 8 bytes a strand.
    HairBinding,
    /// The skinned triangles hair is bound to (since format 1.11): the bind-pose scalp, in the
    /// hair's own frame, with U32 triangle indices and streams ([`SCALP_STREAMS`]) `position`
    /// (F32 × 3), `joints` (U16 × 4, integers: indices into [`ScalpSettings::joints`](crate::ScalpSettings::joints)),
    /// `weights` (U16 × 4 unorm, summing to 1) and `reach` (F32: the farthest any strip bound
    /// to a triangle of this vertex lies from its root's surface point, for the light's box).
    Scalp,
    /// A texture with no hikage-specific meaning (tests, user data).
    Texture,
    /// A mesh with no hikage-specific meaning.
    Mesh,
}

impl Settings {
    /// The kind of asset these settings describe: each kind has its own settings, and generic
    /// settings take the kind from the payload (a texture or a mesh).
    pub fn kind(&self, payload: &Payload) -> AssetKind {
        match self {
            Settings::Generic => match payload {
                Payload::Texture(_) => AssetKind::Texture,
                Payload::Mesh(_) => AssetKind::Mesh,
            },
            Settings::Heightfield(_) => AssetKind::Heightfield,
            Settings::Horizon(_) => AssetKind::Horizon,
            Settings::AmbientOcclusion(_) => AssetKind::AmbientOcclusion,
            Settings::Curvature(_) => AssetKind::Curvature,
            Settings::Relief(_) => AssetKind::Relief,
            Settings::MaxMip(_) => AssetKind::MaxMip,
            Settings::Strands(_) => AssetKind::Strands,
            Settings::HairBinding(_) => AssetKind::HairBinding,
            Settings::Scalp(_) => AssetKind::Scalp,
        }
    }
}

impl AssetKind {
    /// True when assets of this kind carry a mesh payload; the others carry a texture.
    pub fn is_mesh(self) -> bool {
        matches!(
            self,
            AssetKind::Curvature | AssetKind::Strands | AssetKind::HairBinding | AssetKind::Scalp | AssetKind::Mesh
        )
    }

    /// The vertex streams a mesh of this kind is written with, in payload order: the one table
    /// every writer and reader of the kind takes its names and layouts from.
    pub fn streams(self) -> &'static [Stream] {
        match self {
            AssetKind::Curvature => &CURVATURE_STREAMS,
            AssetKind::Strands => &STRANDS_STREAMS,
            AssetKind::HairBinding => &BINDING_STREAMS,
            AssetKind::Scalp => &SCALP_STREAMS,
            _ => &[],
        }
    }

    /// The streams a mesh of this kind must have in a bundle of `format` (a `Curvature` mesh
    /// from before format 1.3 has no `tangent_u` and `tangent_v`).
    pub fn required_streams(self, format: FormatVersion) -> impl Iterator<Item = &'static Stream> {
        self.streams().iter().filter(move |s| s.since <= (format.major as u16, format.minor as u16))
    }

    /// Lower-case name used by the CLI and JSON output.
    pub fn name(self) -> &'static str {
        match self {
            AssetKind::Heightfield => "heightfield",
            AssetKind::Horizon => "horizon",
            AssetKind::AmbientOcclusion => "ambient_occlusion",
            AssetKind::Curvature => "curvature",
            AssetKind::Relief => "relief",
            AssetKind::MaxMip => "max_mip",
            AssetKind::Strands => "strands",
            AssetKind::HairBinding => "hair_binding",
            AssetKind::Scalp => "scalp",
            AssetKind::Texture => "texture",
            AssetKind::Mesh => "mesh",
        }
    }
}

/// A vertex stream of a kind's meshes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stream {
    /// The accessor's name in the manifest.
    pub name: &'static str,
    /// Scalar type of its components (integer types are read as unorm or uint as the kind's
    /// documentation says).
    pub component: ComponentType,
    /// Components per vertex.
    pub components: u8,
    /// The format version that added it (older bundles may lack it).
    pub since: (u16, u16),
}

const fn stream(name: &'static str, components: u8) -> Stream {
    Stream { name, component: ComponentType::F32, components, since: (1, 0) }
}

const fn strand_stream(name: &'static str, component: ComponentType, components: u8) -> Stream {
    Stream { name, component, components, since: (1, 5) }
}

/// The streams of a `Curvature` mesh ([`AssetKind::Curvature`]), in payload order.
pub const CURVATURE_STREAMS: [Stream; 8] = [
    stream("position", 3),
    stream("uv", 2),
    stream("normal", 3),
    stream("curvature", 2),
    stream("principal1", 2),
    stream("principal2", 2),
    Stream { since: (1, 3), ..stream("tangent_u", 3) },
    Stream { since: (1, 3), ..stream("tangent_v", 3) },
];

/// The streams of a `Strands` mesh ([`AssetKind::Strands`]), in record order: one interleaved
/// record of [`STRANDS_RECORD_BYTES`] per strand point.
pub const STRANDS_STREAMS: [Stream; 6] = [
    strand_stream("position", ComponentType::F32, 3),
    strand_stream("tangent", ComponentType::U16, 2),
    strand_stream("shape", ComponentType::U16, 2),
    strand_stream("color", ComponentType::U8, 4),
    strand_stream("strand", ComponentType::U16, 2),
    strand_stream("strand_id", ComponentType::U32, 1),
];

const fn binding_stream(name: &'static str, component: ComponentType, components: u8) -> Stream {
    Stream { name, component, components, since: (1, 11) }
}

/// The streams of a `HairBinding` mesh ([`AssetKind::HairBinding`]): one element per strand.
pub const BINDING_STREAMS: [Stream; 2] =
    [binding_stream("triangle", ComponentType::U32, 1), binding_stream("barycentric", ComponentType::U16, 2)];

/// The streams of a `Scalp` mesh ([`AssetKind::Scalp`]).
pub const SCALP_STREAMS: [Stream; 4] = [
    binding_stream("position", ComponentType::F32, 3),
    binding_stream("joints", ComponentType::U16, 4),
    binding_stream("weights", ComponentType::U16, 4),
    binding_stream("reach", ComponentType::F32, 1),
];

/// Bytes of one strand point's record in a `Strands` mesh (the streams of [`STRANDS_STREAMS`]
/// one after another).
pub const STRANDS_RECORD_BYTES: u32 = 32;

/// One payload file and everything needed to trust and use it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Asset {
    /// Unique id inside the bundle (`A–Z a–z 0–9 _ - .`).
    pub id: String,
    /// What the asset is.
    pub kind: AssetKind,
    /// Payload file name, relative to the bundle directory; never contains a separator.
    pub file: String,
    /// Size of the payload file in bytes.
    pub byte_length: u64,
    /// BLAKE3 of the payload file, lower-case hex.
    pub blake3: String,
    /// BLAKE3 (hex) of the inputs, canonical settings and baker algorithm version; the baker
    /// skips a job whose input hash matches.
    pub input_hash: String,
    /// Format and dimensions of the payload.
    pub payload: Payload,
    /// The settings the asset was baked with.
    pub settings: Settings,
}

impl Asset {
    /// Bytes the asset takes in GPU memory uploaded as stored: a texture's texels (or blocks)
    /// over every level, slice and layer, after any supercompression is undone; a mesh's
    /// streams and indices.
    pub fn gpu_bytes(&self) -> u64 {
        match &self.payload {
            Payload::Texture(t) => t.total_bytes().unwrap_or(u64::MAX),
            Payload::Mesh(m) => match m.supercompression {
                crate::Supercompression::None => self.byte_length,
                crate::Supercompression::Zstd => m.buffer_bytes(),
            },
        }
    }
}

/// Bytes on disk of the payload files `(file, bytes)`, a file shared by identical payloads
/// counted once.
pub fn disk_bytes<'a>(files: impl Iterator<Item = (&'a str, u64)>) -> u64 {
    let files: std::collections::BTreeMap<&str, u64> = files.collect();
    files.values().fold(0u64, |sum, &b| sum.saturating_add(b))
}

/// How the payload file is laid out.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Payload {
    /// A KTX2 texture.
    Texture(TextureDesc),
    /// A little-endian buffer described by accessors.
    Mesh(MeshDesc),
}

impl Payload {
    /// The extension of the payload's file: `ktx2` for a texture, `bin` for a mesh buffer.
    pub fn file_extension(&self) -> &'static str {
        match self {
            Payload::Texture(_) => "ktx2",
            Payload::Mesh(_) => "bin",
        }
    }

    /// The texture description, when the payload is a texture.
    pub fn texture(&self) -> Option<&TextureDesc> {
        match self {
            Payload::Texture(t) => Some(t),
            Payload::Mesh(_) => None,
        }
    }

    /// The mesh description, when the payload is a mesh.
    pub fn mesh(&self) -> Option<&MeshDesc> {
        match self {
            Payload::Mesh(m) => Some(m),
            Payload::Texture(_) => None,
        }
    }
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
    budget: Option<crate::budget::Budget>,
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
