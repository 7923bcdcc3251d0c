//! The Bevy vertex attributes of hikage's mesh streams: the standard ones where a stream is one
//! (`position`, `normal`, `uv`, a 4-component `tangent` or `color`, loaded as floats whatever
//! their stored type), a custom
//! [`MeshVertexAttribute`] named `hikage_<stream>` otherwise, in the format the stream is
//! stored in (a strands record's `tangent` and `shape` are `Unorm16x2`, its `color` `Unorm8x4`,
//! its `strand` `Uint16x2`, its `strand_id` `Uint32`).

use bevy_mesh::{Mesh, MeshVertexAttribute, VertexFormat};

/// A strand record's octahedral tangent.
pub const STRAND_TANGENT: MeshVertexAttribute =
    MeshVertexAttribute::new("hikage_strand_tangent", 0x6869_6b61_0001, VertexFormat::Unorm16x2);
/// A strand record's shading width (share of `max_width`) and opacity.
pub const STRAND_SHAPE: MeshVertexAttribute =
    MeshVertexAttribute::new("hikage_strand_shape", 0x6869_6b61_0002, VertexFormat::Unorm16x2);
/// A strand record's sRGB colour bytes.
pub const STRAND_COLOR: MeshVertexAttribute =
    MeshVertexAttribute::new("hikage_strand_color", 0x6869_6b61_0003, VertexFormat::Unorm8x4);
/// A strand record's index in its strand and the strand's segment count.
pub const STRAND_INDEX: MeshVertexAttribute =
    MeshVertexAttribute::new("hikage_strand", 0x6869_6b61_0004, VertexFormat::Uint16x2);
/// A strand's index in its source file.
pub const STRAND_ID: MeshVertexAttribute =
    MeshVertexAttribute::new("hikage_strand_id", 0x6869_6b61_0005, VertexFormat::Uint32);
/// A curvature mesh's principal curvatures (κ1 ≥ κ2).
pub const CURVATURE: MeshVertexAttribute =
    MeshVertexAttribute::new("hikage_curvature", 0x6869_6b61_0010, VertexFormat::Float32x2);
/// A curvature mesh's first principal direction in the texture frame.
pub const PRINCIPAL1: MeshVertexAttribute =
    MeshVertexAttribute::new("hikage_principal1", 0x6869_6b61_0011, VertexFormat::Float32x2);
/// A curvature mesh's second principal direction in the texture frame.
pub const PRINCIPAL2: MeshVertexAttribute =
    MeshVertexAttribute::new("hikage_principal2", 0x6869_6b61_0012, VertexFormat::Float32x2);
/// `∂P/∂u` of a curvature mesh.
pub const TANGENT_U: MeshVertexAttribute =
    MeshVertexAttribute::new("hikage_tangent_u", 0x6869_6b61_0013, VertexFormat::Float32x3);
/// `∂P/∂v` of a curvature mesh.
pub const TANGENT_V: MeshVertexAttribute =
    MeshVertexAttribute::new("hikage_tangent_v", 0x6869_6b61_0014, VertexFormat::Float32x3);
/// A ribbon vertex's strand id (as a float).
pub const RIBBON_STRAND_ID: MeshVertexAttribute =
    MeshVertexAttribute::new("hikage_ribbon_strand_id", 0x6869_6b61_0020, VertexFormat::Float32);

/// The attribute a stream of a mesh of `strands` kind (or not) is loaded as, if hikage writes
/// such a stream.
pub fn for_stream(name: &str, components: u8, strands: bool) -> Option<MeshVertexAttribute> {
    Some(match (name, components, strands) {
        ("position", 3, _) => Mesh::ATTRIBUTE_POSITION,
        ("tangent", 2, true) => STRAND_TANGENT,
        ("shape", 2, true) => STRAND_SHAPE,
        ("color", 4, true) => STRAND_COLOR,
        ("strand", 2, true) => STRAND_INDEX,
        ("strand_id", 1, true) => STRAND_ID,
        ("normal", 3, false) => Mesh::ATTRIBUTE_NORMAL,
        ("uv", 2, false) => Mesh::ATTRIBUTE_UV_0,
        ("tangent", 4, false) => Mesh::ATTRIBUTE_TANGENT,
        ("color", 4, false) => Mesh::ATTRIBUTE_COLOR,
        ("curvature", 2, false) => CURVATURE,
        ("principal1", 2, false) => PRINCIPAL1,
        ("principal2", 2, false) => PRINCIPAL2,
        ("tangent_u", 3, false) => TANGENT_U,
        ("tangent_v", 3, false) => TANGENT_V,
        ("strand_id", 1, false) => RIBBON_STRAND_ID,
        _ => return None,
    })
}
