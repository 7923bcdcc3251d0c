//! Triangle meshes with texture coordinates (OBJ or glTF input), for per-vertex curvature.

pub mod gltf;
pub mod obj;

use std::path::Path;

use glam::{DVec2, DVec3};

use crate::error::BakeError;

/// Limits of the mesh readers, checked before the file is read.
#[derive(Clone, Copy, Debug)]
pub struct MeshLimits {
    /// Largest input accepted, bytes (for glTF, the file and its buffer files together).
    pub max_bytes: u64,
}

impl Default for MeshLimits {
    fn default() -> Self {
        MeshLimits { max_bytes: 512 << 20 }
    }
}

/// Reads a mesh file, glTF (`.gltf`, `.glb`, or a binary glTF under any name) or else OBJ.
pub fn load(path: &Path, limits: MeshLimits) -> Result<Mesh, BakeError> {
    let gltf_name = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"));
    let glb_magic = || {
        let mut head = [0u8; 4];
        hikage_bundle::files::open_regular(path).and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head)).is_ok()
            && gltf::is_glb(&head)
    };
    if gltf_name || glb_magic() { gltf::load(path, limits) } else { obj::load(path, limits) }
}

/// The bytes of `path`, refused by name (`what`) when the file is larger than `max_bytes`.
fn read_limited(path: &Path, max_bytes: u64, what: &str) -> Result<Vec<u8>, BakeError> {
    Ok(hikage_bundle::files::read_limited(path, max_bytes, what)?)
}

/// A triangle mesh whose vertices are unique (position, texture coordinate) pairs, with the
/// position each vertex came from, so surface quantities can be computed per position and
/// shared across UV seams.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Distinct positions.
    pub positions: Vec<DVec3>,
    /// Per vertex: index into `positions`.
    pub vertex_position: Vec<u32>,
    /// Per vertex: texture coordinate `(u, v)`.
    pub vertex_uv: Vec<DVec2>,
    /// Triangles over vertices (counter-clockwise seen from outside).
    pub triangles: Vec<[u32; 3]>,
}
