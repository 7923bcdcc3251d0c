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
    /// × 2 unorm: shading width as a share of [`StrandsSettings::max_width`], shading opacity),
    /// `color` (U8 × 4: sRGB-encoded RGB, 255), `strand` (U16 × 2: the point's index in its
    /// strand, the strand's segment count; `param` = index / segments) and `strand_id` (U32, the
    /// strand's index in the source file). Strands are stored in a fixed shuffled order so the
    /// first strands of [`StrandsSettings::levels`] are an even thinning (levels of detail).
    Strands,
    /// Where each strand of a `Strands` asset is rooted on a skinned scalp (since format 1.11):
    /// one element per strand, in strand-id order (the source file's), streams
    /// ([`BINDING_STREAMS`]) `triangle` (U32, a triangle of the [`AssetKind::Scalp`] its
    /// settings name) and `barycentric` (U16 × 2 unorm: the weights of the triangle's second
    /// and third vertex; the first's is 1 − both). 8 bytes a strand.
    HairBinding,
    /// The skinned triangles hair is bound to (since format 1.11): the bind-pose scalp, in the
    /// hair's own frame, with U32 triangle indices and streams ([`SCALP_STREAMS`]) `position`
    /// (F32 × 3), `joints` (U16 × 4, integers: indices into [`ScalpSettings::joints`]),
    /// `weights` (U16 × 4 unorm, summing to 1) and `reach` (F32: the farthest any strip bound
    /// to a triangle of this vertex lies from its root's surface point, for the light's box).
    Scalp,
    /// A texture with no hikage-specific meaning (tests, user data).
    Texture,
    /// A mesh with no hikage-specific meaning.
    Mesh,
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

/// Settings an asset was baked with, by kind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Settings {
    /// No hikage-specific settings (generic textures and meshes).
    Generic,
    /// A heightfield import.
    Heightfield(HeightfieldSettings),
    /// A horizon bake.
    Horizon(HorizonSettings),
    /// Ambient occlusion from horizons.
    AmbientOcclusion(AmbientOcclusionSettings),
    /// Curvature of a mesh.
    Curvature(CurvatureSettings),
    /// Relief depth maps.
    Relief(ReliefSettings),
    /// A max-mip pyramid.
    MaxMip(MaxMipSettings),
    /// Hair strips.
    Strands(StrandsSettings),
    /// Strand roots bound to a scalp.
    HairBinding(HairBindingSettings),
    /// A skinned scalp.
    Scalp(ScalpSettings),
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

    /// Ids of the other assets these settings name and a reader needs with them: a horizon's
    /// heightfield, an ambient-occlusion map's horizon, relief maps' max-mip pyramid, a hair
    /// binding's strands and scalp.
    pub fn depends_on(&self) -> Vec<&str> {
        match self {
            Settings::Horizon(h) => vec![h.heightfield.as_str()],
            Settings::AmbientOcclusion(a) => vec![a.horizon.as_str()],
            Settings::Relief(r) => vec![r.max_mip.as_str()],
            Settings::HairBinding(b) => vec![b.strands.as_str(), b.scalp.as_str()],
            _ => Vec::new(),
        }
    }

    /// Where the asset lies in a map baked in tiles: a tile's heights, horizons or occlusion.
    /// `None` for whole maps and other kinds.
    pub fn tile(&self) -> Option<&TilePlacement> {
        match self {
            Settings::Horizon(h) => h.tile.as_ref(),
            Settings::Heightfield(h) => h.tile.as_ref(),
            Settings::AmbientOcclusion(a) => a.tile.as_ref(),
            _ => None,
        }
    }
}

/// `Settings::heightfield()` and its siblings: the settings of one kind, or `None`.
macro_rules! settings_accessors {
    ($($name:ident => $variant:ident($ty:ty)),* $(,)?) => {
        impl Settings {
            $(
                #[doc = concat!("The settings of a `", stringify!($variant), "` asset, or `None` for another kind.")]
                pub fn $name(&self) -> Option<&$ty> {
                    match self {
                        Settings::$variant(s) => Some(s),
                        _ => None,
                    }
                }
            )*
        }
    };
}

settings_accessors! {
    heightfield => Heightfield(HeightfieldSettings),
    horizon => Horizon(HorizonSettings),
    ambient_occlusion => AmbientOcclusion(AmbientOcclusionSettings),
    curvature => Curvature(CurvatureSettings),
    relief => Relief(ReliefSettings),
    max_mip => MaxMip(MaxMipSettings),
    strands => Strands(StrandsSettings),
    hair_binding => HairBinding(HairBindingSettings),
    scalp => Scalp(ScalpSettings),
}

/// How a hair's strands were bound to a skinned scalp: each root to the nearest point of the
/// scalp's triangles. At run time a strand moves rigidly with its triangle: its points keep
/// their place in the frame of the deformed triangle (origin at the bound point, axes from the
/// first edge and the face normal).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HairBindingSettings {
    /// Id of the `Strands` asset whose strands are bound (one binding element per strand id).
    pub strands: String,
    /// Id of the `Scalp` asset the triangles belong to.
    pub scalp: String,
    /// The farthest any root lies from its bound surface point (world units).
    pub max_distance: f32,
}

/// A skinned scalp: the triangles of a glTF skin's mesh that hair roots were bound to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScalpSettings {
    /// The skin's joints, in the skin's order (a vertex's `joints` index this list): the glTF
    /// nodes' names, `node N` for a node without one. A game's joint matrices come in this order.
    pub joints: Vec<String>,
    /// Triangles of the source mesh (those kept are the ones a root is bound to).
    pub source_triangles: u32,
}

/// How hair strips were baked (seed 004). Widths and opacities are those of a strand with the
/// source's default thickness and transparency; each point's record carries its own shading
/// width and opacity, and its opacity-set values are those times `opacity / shading`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StrandsSettings {
    /// Strands.
    pub strands: u32,
    /// Points (one record each).
    pub points: u32,
    /// Shading set: full width (world units) and opacity.
    pub shading: (f32, f32),
    /// Opacity set: full width (world units) and opacity.
    pub opacity: (f32, f32),
    /// Width at the tip as a share lost: width × (1 − taper × param). The renderer applies it
    /// (and may override it); the records hold untapered widths.
    pub taper: f32,
    /// Opacity-map resolution the opacity set was chosen for (`auto`), if it was.
    pub auto_resolution: Option<u32>,
    /// Light-independent bounds: the box around every strip of the wider set.
    pub bounds_min: [f32; 3],
    /// See `bounds_min`.
    pub bounds_max: [f32; 3],
    /// The widest shading width of any point before taper (world units): a record's
    /// `shape.x` is its width as a share of this (since format 1.5).
    #[serde(default)]
    pub max_width: f32,
    /// Levels of detail, finest first: `[strands, points]` of the first strands in the
    /// records that level draws, each level about half the strands of the one before
    /// (since format 1.5).
    #[serde(default)]
    pub levels: Vec<[u32; 2]>,
    /// The shading set's area weighted by opacity: Σ over segments of length × width ×
    /// opacity (world units², since format 1.5), the hair's density for the camera blend.
    #[serde(default)]
    pub opacity_area: f32,
}

/// How a set of relief depth maps was baked (seed 003).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReliefSettings {
    /// Id of the max-mip pyramid baked from the same heightfield (its level 0 is the surface).
    pub max_mip: String,
    /// Rows of zenith angle; layer `i × phi + j` is `θ_i = (i + ½)·90°/theta`.
    pub theta: u32,
    /// Azimuths per row; `φ_j = 360°·j/phi`, texel space from +u toward +v.
    pub phi: u32,
    /// Relief thickness as a share of the map width (depth 1 lies `depth_scale × width` texels
    /// below the top plane).
    pub depth_scale: f32,
    /// Width and height of the heightfield the maps were traced on.
    pub source_size: (u32, u32),
    /// `(θ, φ)` of every layer in degrees, in layer order: the table a shader indexes.
    pub directions: Vec<(f32, f32)>,
}

impl ReliefSettings {
    /// The direction table as the shared geometry type.
    pub fn table(&self) -> crate::relief::ReliefDirections {
        crate::relief::ReliefDirections { theta: self.theta, phi: self.phi }
    }
}

/// What a max-mip pyramid was built from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaxMipSettings {
    /// The heightfield samples' source channel, as in [`HeightfieldSettings`].
    pub source_channel: String,
}

/// How a curvature mesh was computed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurvatureSettings {
    /// Distinct positions in the source mesh (curvature is computed per position and shared
    /// by the vertices that split it at UV seams).
    pub positions: u32,
    /// Neighbourhood of the quadric fit, in rings of edges.
    pub rings: u32,
}

/// What rays do at the edge of a heightfield.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum EdgeMode {
    /// Rays continue on the torus (tileable bump maps).
    #[default]
    Wrap,
    /// Rays stop at the map edge (terrain).
    Clamp,
}

/// How a horizon texture was baked and how to decode it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HorizonSettings {
    /// Id of the heightfield asset baked from the same input.
    pub heightfield: String,
    /// Number of azimuths `D`; direction `k` has `φ = 2πk/D`, measured in texel space from +u
    /// toward +v.
    pub directions: u32,
    /// Edge behaviour.
    pub edge: EdgeMode,
    /// Largest horizon distance searched, world units (`None`: to the edge for `Clamp`, one map
    /// length along the ray's major axis for `Wrap`).
    pub max_distance: Option<f32>,
    /// Texels per ray traced exactly before the line sweep.
    pub near_field: u32,
    /// World units per texel along `u` and `v`.
    pub texel_size: (f32, f32),
    /// Height scale of the heightfield (world = offset + scale × sample).
    pub height_scale: f32,
    /// `tan β` stored for a ray with no sample (open sky).
    pub open_sky_slope: f32,
    /// For `Rg8Unorm`: `tan β = tan((c0 − 0.5) π)`, `d = c1 × distance_scale`; 1 otherwise.
    pub distance_scale: f32,
    /// Where this texture lies in a map baked in tiles (`None`: it is the whole map).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tile: Option<TilePlacement>,
}

/// The place of one tile of a map baked in tiles. A tile's texture covers texels
/// `origin .. origin + (its width, its height)` of the whole map at its level; at level 0 its
/// texels are those the whole map's bake would have there.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TilePlacement {
    /// The tiled map's name (the job id): every tile of one map has the same.
    pub map: String,
    /// Column and row of the tile in the grid of tiles.
    pub index: (u32, u32),
    /// Column and row of the tile's first texel in the whole map.
    pub origin: (u32, u32),
    /// The whole map's width and height in texels, at this tile's level of detail.
    pub map_size: (u32, u32),
    /// Level of detail: 0 is the map as baked, level `k` the map reduced by `2^k` (since format
    /// 1.9; older tiles are all level 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub level: u32,
}

fn is_zero(v: &u32) -> bool {
    *v == 0
}

impl TilePlacement {
    /// Where the tile's frame starts in the whole map's, in world units along `u` and `v`:
    /// its origin times the texel size. A game draws the tile translated by it.
    ///
    /// ```
    /// use hikage_bundle::TilePlacement;
    /// let t = TilePlacement { map: "dem".into(), index: (3, 1), origin: (3072, 1024), map_size: (8192, 8192), level: 0 };
    /// assert_eq!(t.offset((2.0, 0.5)), (6144.0, 512.0));
    /// ```
    pub fn offset(&self, (sx, sy): (f32, f32)) -> (f32, f32) {
        (self.origin.0 as f32 * sx, self.origin.1 as f32 * sy)
    }
}

impl HorizonSettings {
    /// Decodes a stored texel `(c0, c1)` (as the texture format returns it) to `(tan β, d)`.
    pub fn decode(&self, format: crate::TextureFormat, c0: f32, c1: f32) -> (f32, f32) {
        decode_horizon_texel(format, c0, c1, self.distance_scale, self.open_sky_slope)
    }
}

/// Decodes a stored horizon texel `(c0, c1)` (as the texture format returns it) to
/// `(tan β, d)`: float formats store them as they are; `Rg8Unorm` and `Bc5RgUnorm` store
/// `β/π + 0.5` (0 is open sky) and `d / distance_scale`. The one definition the baker's decoder
/// and export share.
pub fn decode_horizon_texel(
    format: crate::TextureFormat,
    c0: f32,
    c1: f32,
    distance_scale: f32,
    open_sky_slope: f32,
) -> (f32, f32) {
    if format.is_unorm() {
        let slope = if c0 <= 0.0 { open_sky_slope } else { ((c0 - 0.5) * std::f32::consts::PI).tan() };
        (slope, c1 * distance_scale)
    } else {
        (c0, c1)
    }
}

/// How an ambient-occlusion map was derived.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AmbientOcclusionSettings {
    /// Id of the horizon asset it was derived from.
    pub horizon: String,
    /// Directions averaged.
    pub directions: u32,
    /// Where this map lies in a map baked in tiles (`None`: the whole map; since format 1.9,
    /// older tiles say it only by their id).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tile: Option<TilePlacement>,
}

/// How a heightfield's samples map to world space (see `docs/conventions.md`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeightfieldSettings {
    /// World units per texel along `u` (columns) and `v` (rows); may differ.
    pub texel_size: (f32, f32),
    /// World height = `height_offset + height_scale × sample`.
    pub height_scale: f32,
    /// See `height_scale`.
    pub height_offset: f32,
    /// Channel taken from the source image (`Y`, `R`, … or `luma` for grayscale PNG).
    pub source_channel: String,
    /// True when the source held integers normalised to [0, 1] before scaling.
    pub normalized: bool,
    /// Where these heights lie in a map baked in tiles (`None`: the whole map).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tile: Option<TilePlacement>,
}

impl HeightfieldSettings {
    /// The world height of stored sample `v`: `height_offset + height_scale × v` (a normalised
    /// integer sample as its 0–1 value).
    pub fn world_height(&self, v: f32) -> f32 {
        self.height_offset + self.height_scale * v
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
    /// [`crate::tiles::TileIndex`] alike: each table's name inside the bundle, its records
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
