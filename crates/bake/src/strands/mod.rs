//! Hair and fur strands: polylines with optional per-point thickness, transparency and colour,
//! read from Cem Yuksel's `.hair` format ([`cyhair`]) or OBJ polylines ([`obj`]).

pub mod auto;
pub mod bind;
pub mod cyhair;
pub mod obj;
pub mod ribbons;
pub mod strips;

use std::path::Path;

use crate::error::BakeError;
use cyhair::HairLimits;

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

/// Reads strands: a `.hair` file when it starts with `HAIR`/`hair`, OBJ polylines otherwise.
pub fn load(path: &Path) -> Result<Strands, BakeError> {
    let limits = HairLimits::default();
    // The largest file the limits allow: header, segments, and every per-point array.
    let max_bytes = 128 + 2 * limits.max_strands + 32 * limits.max_points;
    let bytes = hikage_bundle::files::read_limited(path, max_bytes, "strand file size")?;
    if bytes.starts_with(b"HAIR") || bytes.starts_with(b"hair") {
        return cyhair::decode(&bytes, &limits).map_err(|e| match e.over_limit {
            Some((value, limit)) => {
                BakeError::Limit { path: path.into(), what: format!("{} in the header", e.message), value, limit }
            }
            None => BakeError::input(path, Some(e.place), e.message),
        });
    }
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        BakeError::input(path, Some(format!("byte {}", e.valid_up_to())), "expected a .hair signature or OBJ text")
    })?;
    obj::parse(text, limits.max_points).map_err(|(place, message)| BakeError::input(path, Some(place), message))
}
