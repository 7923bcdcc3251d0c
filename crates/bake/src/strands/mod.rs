//! Hair and fur strands: polylines with optional per-point thickness, transparency and colour,
//! read from Cem Yuksel's `.hair` format ([`cyhair`]) or OBJ polylines ([`obj`]).

pub mod auto;
pub mod cyhair;
pub mod obj;
pub mod ribbons;
pub mod strips;

/// A set of strands. Strand `s` owns `segments[s] + 1` consecutive points.
#[derive(Clone, Debug, PartialEq)]
pub struct Strands {
    /// Segments per strand.
    pub segments: Vec<u16>,
    /// All points, strand after strand (world units).
    pub points: Vec<[f32; 3]>,
    /// Per-point thickness (world units), or `None` for `default_thickness` everywhere.
    pub thickness: Option<Vec<f32>>,
    /// Per-point transparency (0 opaque … 1 invisible), or `None` for the default.
    pub transparency: Option<Vec<f32>>,
    /// Per-point colour, or `None` for the default.
    pub color: Option<Vec<[f32; 3]>>,
    /// Thickness where no per-point value is stored.
    pub default_thickness: f32,
    /// Transparency where no per-point value is stored.
    pub default_transparency: f32,
    /// Colour where no per-point value is stored.
    pub default_color: [f32; 3],
}
