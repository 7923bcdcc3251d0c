//! SRTM `.hgt` elevation tiles: a square grid of big-endian signed 16-bit metres, row 0 the
//! northern edge, its side given only by the file's length (1201² for 3″ tiles, 3601² for 1″).
//! Voids (−32768) carry no height; they are filled with the lowest elevation of the tile, so a
//! void never casts a shadow it has no terrain for, and the count is part of the error when a
//! tile is all voids.

use std::path::Path;

use super::{LoadOptions, Samples, check_dimensions};
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
    let side = (len / 2).isqrt();
    if len % 2 != 0 || side * side * 2 != len || side < 2 {
        return Err(BakeError::input(
            path,
            Some("file length".into()),
            format!("expected a square grid of 16-bit samples (2·N² bytes, N ≥ 2), found {len} bytes"),
        ));
    }
    check_dimensions(path, side, side, options.max_dimension)?;
    if options.channel.as_deref().is_some_and(|c| !c.eq_ignore_ascii_case("elevation")) {
        return Err(BakeError::input(path, None, "an SRTM tile has one channel, `elevation`"));
    }
    let bytes = std::fs::read(path).map_err(|e| BakeError::io(path, e))?;
    let raw: Vec<i16> = bytes.chunks_exact(2).map(|b| i16::from_be_bytes([b[0], b[1]])).collect();
    let lowest = raw.iter().copied().filter(|&v| v != VOID).min().ok_or_else(|| {
        BakeError::input(path, None, format!("every one of the {side}×{side} samples is a void (−32768)"))
    })?;
    let values = raw.into_iter().map(|v| if v == VOID { lowest } else { v } as f32).collect();
    Ok(Samples { width: side as u32, height: side as u32, values, normalized: false, channel: "elevation".into() })
}
