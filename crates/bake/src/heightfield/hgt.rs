//! SRTM `.hgt` elevation tiles: a square grid of big-endian signed 16-bit metres, row 0 the
//! northern edge, its side given only by the file's length (1201² for 3″ tiles, 3601² for 1″).
//! Voids (−32768) carry no height; they take the tile's lowest elevation (the no-data rule of
//! every elevation format).

use std::path::Path;

use super::{LoadOptions, check_dimensions, square_side};
use crate::error::BakeError;

/// The value SRTM uses for a void.
pub const VOID: i16 = i16::MIN;

/// Whether `path` names an SRTM tile (by its extension: the format has no signature).
pub(super) fn is_hgt(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("hgt"))
}

/// The samples of big-endian 16-bit bytes.
pub(super) fn decode(bytes: &[u8]) -> Vec<f32> {
    bytes.chunks_exact(2).map(|b| f32::from(i16::from_be_bytes([b[0], b[1]]))).collect()
}

/// The side of an SRTM tile from its length, checked against the limits and the channel asked
/// for; nothing is read.
pub(super) fn side(path: &Path, options: &LoadOptions) -> Result<u32, BakeError> {
    let len = hikage_bundle::files::regular_metadata(path).map_err(|e| BakeError::io(path, e))?.len();
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
    Ok(side as u32)
}
