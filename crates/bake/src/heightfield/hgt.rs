//! SRTM `.hgt` elevation tiles: a square grid of big-endian signed 16-bit metres, row 0 the
//! northern edge, its side given only by the file's length (1201² for 3″ tiles, 3601² for 1″).
//! Voids (−32768) carry no height; they take the tile's lowest elevation (the no-data rule of
//! every elevation format, `fill_voids`).

use std::path::Path;

use super::{LoadOptions, Samples, check_dimensions, fill_voids, square_side};
use crate::error::BakeError;

/// The value SRTM uses for a void.
pub const VOID: i16 = i16::MIN;

/// Whether `path` names an SRTM tile (by its extension: the format has no signature).
pub(super) fn is_hgt(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("hgt"))
}

/// Reads an SRTM tile; the side comes from the length, checked before anything is allocated.
pub(super) fn load(path: &Path, options: &LoadOptions) -> Result<Samples, BakeError> {
    let len = std::fs::metadata(path).map_err(|e| BakeError::io(path, e))?.len();
    let Some(side) = square_side(len, 2).filter(|&n| n >= 2) else {
        return Err(BakeError::input(
            path,
            Some("file length".into()),
            format!("expected a square grid of 16-bit samples (2·N² bytes, N ≥ 2), found {len} bytes"),
        ));
    };
    check_dimensions(path, side, side, options.max_dimension)?;
    if options.channel.as_deref().is_some_and(|c| !c.eq_ignore_ascii_case("elevation")) {
        return Err(BakeError::input(path, None, "an SRTM tile has one channel, `elevation`"));
    }
    let bytes = std::fs::read(path).map_err(|e| BakeError::io(path, e))?;
    let raw = bytes.chunks_exact(2).map(|b| f32::from(i16::from_be_bytes([b[0], b[1]]))).collect();
    let values = fill_voids(path, raw, f32::from(VOID))?;
    Ok(Samples { width: side as u32, height: side as u32, values, normalized: false, channel: "elevation".into() })
}
