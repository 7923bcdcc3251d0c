//! What one asset of a bundle is: its kind, the payload file that holds it and how that file is
//! laid out, and the vertex streams each mesh kind is written with.

use serde::{Deserialize, Serialize};

use crate::budget::Weight;
use crate::mesh::{ComponentType, MeshDesc};
use crate::settings::Settings;
use crate::texture::{Supercompression, TextureDesc};
use crate::version::FormatVersion;

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
    /// What the asset weighs against a [`Budget`](crate::Budget): its file, its bytes on disk
    /// and [`Asset::gpu_bytes`].
    pub fn weight(&self) -> Weight<'_> {
        Weight { id: &self.id, file: &self.file, disk: self.byte_length, gpu: self.gpu_bytes() }
    }

    /// Bytes the asset takes in GPU memory uploaded as stored: a texture's texels (or blocks)
    /// over every level, slice and layer, after any supercompression is undone; a mesh's
    /// streams and indices.
    pub fn gpu_bytes(&self) -> u64 {
        match &self.payload {
            Payload::Texture(t) => t.total_bytes().unwrap_or(u64::MAX),
            Payload::Mesh(m) => match m.supercompression {
                Supercompression::None => self.byte_length,
                Supercompression::Zstd => m.buffer_bytes(),
            },
        }
    }
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
