//! The hikage bundle: a directory holding a `bundle.ron` manifest and the payload files it
//! describes.
//!
//! A bundle is what the baker (`hikage-bake`) writes and what the runtime (`hikage-runtime`)
//! loads. Everything here is plain data and file handling, with no GPU and no baker code, so a
//! game links only this crate and the runtime.
//!
//! - [`Manifest`] is the schema of `bundle.ron`: a format version ([`FormatVersion`]; readers
//!   refuse an unknown major), the generator, and one [`Asset`] per payload with its kind,
//!   file, byte length, BLAKE3, format, dimensions, the settings it was baked with and the
//!   input hash that lets the baker skip unchanged work.
//! - Textures are standard KTX2 files ([`ktx2_file`]): 2D, 2D-array and 3D, optionally zstd
//!   supercompressed, readable by any KTX2 reader.
//! - Meshes are little-endian buffers described by glTF-like accessors ([`mesh`]); hair strands
//!   are one 32-byte record per point ([`strands`]).
//! - [`BundleWriter`] writes payloads under content-derived names and replaces the manifest
//!   atomically, so a bake killed at any point leaves the previous bundle valid.
//! - [`Bundle::open`] reads a bundle back with every payload's size and hash checked;
//!   [`validate()`] checks everything a reader relies on and reports each problem.
//!
//! Its modules, each named after what it holds:
//!
//! - the manifest and its parts: [`manifest`] (the schema), [`asset`] (one asset: its kind,
//!   payload layout and streams), [`settings`] (each kind's settings), [`tiles`] (a tiled map's
//!   tile table), [`tile_index`] (the tile reader both streams use), [`budget`] (a pipeline's
//!   byte budgets), [`files`] (reading and writing inside a bundle);
//! - payloads: [`texture`], [`ktx2_file`], [`zstd`], [`bc`] (BC4/BC5 blocks), [`mesh`],
//!   [`strands`], [`binding`] (hair bound to a skinned scalp), [`relief`] (the max-mip pyramid);
//! - reading back: [`validate`](mod@validate), [`inspect`] (sizes on disk and on the GPU),
//!   [`diff`] (two bundles compared in each method's terms).
//!
//! ```no_run
//! let bundle = hikage_bundle::Bundle::open("bundle".as_ref())?;
//! for asset in &bundle.manifest().assets {
//!     println!("{} ({:?})", asset.id, asset.kind);
//! }
//! # Ok::<(), hikage_bundle::BundleError>(())
//! ```

pub mod asset;
pub mod bc;
pub mod binding;
pub mod budget;
mod bundle;
pub mod diff;
mod error;
pub mod files;
pub mod inspect;
pub mod ktx2_file;
mod limits;
pub mod manifest;
pub mod mesh;
mod names;
mod parallel;
pub mod relief;
pub mod settings;
pub mod strands;
pub mod texture;
pub mod tile_index;
pub mod tiles;
pub mod validate;
mod version;
mod writer;
pub mod zstd;

pub use asset::{
    Asset, AssetKind, BINDING_STREAMS, CURVATURE_STREAMS, Payload, SCALP_STREAMS, STRANDS_RECORD_BYTES,
    STRANDS_STREAMS, Stream,
};
pub use binding::{Scalp, StrandBinding};
pub use budget::{Budget, Limit as BudgetLimit, Weight};
pub use bundle::{Bundle, READERS_LOCK_FILE, decode_mesh};
pub use error::BundleError;
pub use limits::Limits;
pub use manifest::{MANIFEST_FILE, Manifest};
pub use mesh::{Accessor, ComponentType, MAX_VERTEX_STRIDE, MeshData, MeshDesc, VertexFetch};
pub use names::{check_asset_id, is_payload_file_of, is_valid_asset_id, payload_file_name};
pub use settings::{
    AmbientOcclusionSettings, CurvatureSettings, EdgeMode, HairBindingSettings, HeightfieldSettings, HorizonSettings,
    MaxMipSettings, ReliefSettings, ScalpSettings, Settings, StrandsSettings, TilePlacement, world_height,
};
pub use strands::{StrandPoint, read_strand_points, strands_desc};
pub use texture::{Supercompression, TextureData, TextureDesc, TextureDimension, TextureFormat};

/// A payload's data in memory: what a baker hands the writer and a reader gets back.
#[derive(Clone, Debug, PartialEq)]
pub enum PayloadData {
    /// Uncompressed texture levels.
    Texture(TextureData),
    /// A mesh buffer with its accessors.
    Mesh(MeshData),
}

impl PayloadData {
    /// The texture, when the payload is one.
    pub fn texture(&self) -> Option<&TextureData> {
        match self {
            PayloadData::Texture(t) => Some(t),
            PayloadData::Mesh(_) => None,
        }
    }

    /// The mesh, when the payload is one.
    pub fn mesh(&self) -> Option<&MeshData> {
        match self {
            PayloadData::Mesh(m) => Some(m),
            PayloadData::Texture(_) => None,
        }
    }
}

impl From<TextureData> for PayloadData {
    fn from(t: TextureData) -> Self {
        PayloadData::Texture(t)
    }
}

impl From<MeshData> for PayloadData {
    fn from(m: MeshData) -> Self {
        PayloadData::Mesh(m)
    }
}
pub use validate::{Problem, Report, check_payload, validate};
pub use version::FormatVersion;
pub use writer::{BundleWriter, CommitSummary, LOCK_FILE, OWNER_FILE, WriteMode};

/// The generator string written into manifests by this version of hikage.
pub const GENERATOR: &str = concat!("hikage ", env!("CARGO_PKG_VERSION"));
