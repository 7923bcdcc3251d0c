//! Triangle meshes with texture coordinates (OBJ input), for per-vertex curvature.

pub mod obj;

use glam::{DVec2, DVec3};

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
