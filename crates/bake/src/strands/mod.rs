//! Hair and fur strands: polylines with optional per-point thickness, transparency and colour,
//! read from Cem Yuksel's `.hair` format ([`cyhair`]), OBJ polylines ([`obj`]), Alembic curves
//! ([`alembic`]) or, with the `usd` feature, USD `BasisCurves` ([`usd`]).

pub mod alembic;
pub mod auto;
pub mod bind;
mod curves;
pub mod cyhair;
pub mod obj;
pub mod ribbons;
pub mod strips;
#[cfg(feature = "usd")]
pub mod usd;

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

/// A file's up axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum UpAxis {
    /// +Y up: the bundle's frame, glTF's, Maya's and Houdini's default.
    Y,
    /// +Z up: Blender's frame, and USD stages that say so; turned to Y up as
    /// `(x, y, z) → (x, z, −y)`.
    Z,
}

/// How a file places its strands, as far as it says: metres per unit of its coordinates and
/// widths, and its up axis. `.hair` and OBJ files say neither.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FileFrame {
    /// Metres per unit (USD `metersPerUnit`).
    pub meters_per_unit: Option<f32>,
    /// Up axis (USD `upAxis`).
    pub up: Option<UpAxis>,
}

/// What a job reads of a groom file beyond its strands (USD and Alembic; `.hair` and OBJ hold
/// one time and no groups).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GroomRead {
    /// The time to read, seconds: Alembic's sample nearest it, USD's value at it (interpolated
    /// between samples); `None`: the file's default time, or its first sample.
    pub time: Option<f64>,
    /// Keep only the strands of this group (Unreal's `groom_group_id`; strands without one are
    /// group 0); `None`: every group.
    pub group: Option<i32>,
}

/// Whether `path` names a USD file (by its extension: USD files may be text or binary).
pub fn is_usd(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| ["usd", "usda", "usdc", "usdz"].iter().any(|u| e.eq_ignore_ascii_case(u)))
}

/// Reads strands and the frame the file states: USD and Alembic by their extensions, a `.hair`
/// file by its `HAIR`/`hair` signature, OBJ polylines otherwise.
pub fn load_groom(path: &Path, read: &GroomRead) -> Result<(Strands, FileFrame), BakeError> {
    if is_usd(path) {
        return load_usd(path, read);
    }
    if path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("abc")) {
        return alembic::load(path, read, &HairLimits::default());
    }
    load(path).map(|s| (s, FileFrame::default()))
}

#[cfg(feature = "usd")]
fn load_usd(path: &Path, read: &GroomRead) -> Result<(Strands, FileFrame), BakeError> {
    let limits = HairLimits::default();
    // The parser reads the whole file: its size is bounded first, like a `.hair` file's.
    let (size, limit) = (
        hikage_bundle::files::regular_metadata(path).map_err(|e| BakeError::io(path, e))?.len(),
        limits.max_file_bytes(),
    );
    if size > limit {
        return Err(BakeError::Limit { path: path.into(), what: "strand file size".into(), value: size, limit });
    }
    usd::load(path, read, &limits)
}

#[cfg(not(feature = "usd"))]
fn load_usd(path: &Path, _: &GroomRead) -> Result<(Strands, FileFrame), BakeError> {
    Err(BakeError::input(
        path,
        None,
        "a USD file, but this build of hikage-bake reads no USD: enable its `usd` feature",
    ))
}

/// Reads strands: a `.hair` file when it starts with `HAIR`/`hair`, OBJ polylines otherwise.
pub fn load(path: &Path) -> Result<Strands, BakeError> {
    let limits = HairLimits::default();
    let bytes = hikage_bundle::files::read_limited(path, limits.max_file_bytes(), "strand file size")?;
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
