//! Raw heightmaps as engines export them (Unity, Unreal): `*.r16`, little-endian unsigned 16-bit,
//! and `*.r32`, little-endian 32-bit floats, row 0 first, with no header. Values are taken as
//! stored (not normalised), then world units apply. The size is the job's `raw_size`, or, for
//! a square map, the side the file's length gives.

use std::path::Path;

use super::{LoadOptions, check_dimensions, square_side};
use crate::error::BakeError;

/// Bytes per sample of a raw heightmap, by its extension; `None` for other files.
pub(super) fn bytes_per_sample(path: &Path) -> Option<u64> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "r16" => Some(2),
        "r32" => Some(4),
        _ => None,
    }
}

/// The samples of little-endian bytes, `bytes` (2 or 4) per sample.
pub(super) fn decode(data: &[u8], bytes: u64) -> Vec<f32> {
    if bytes == 2 {
        data.chunks_exact(2).map(|b| u16::from_le_bytes([b[0], b[1]]) as f32).collect()
    } else {
        data.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect()
    }
}

/// The width and height of a raw heightmap of `bytes` per sample, checked against the file's
/// length, the limits and the channel asked for; nothing is read.
pub(super) fn dimensions(path: &Path, options: &LoadOptions, bytes: u64) -> Result<(u32, u32), BakeError> {
    let len = hikage_bundle::files::regular_metadata(path).map_err(|e| BakeError::io(path, e))?.len();
    let (w, h) = match options.raw_size {
        Some((w, h)) => (w as u64, h as u64),
        None => {
            let side = square_side(len, bytes).ok_or_else(|| {
                BakeError::input(
                    path,
                    Some("file length".into()),
                    format!("{len} bytes is not a square map of {bytes}-byte samples; give raw_size (W, H)"),
                )
            })?;
            (side, side)
        }
    };
    check_dimensions(path, w, h, options.max_dimension)?;
    if w * h * bytes != len {
        return Err(BakeError::input(
            path,
            Some("file length".into()),
            format!("expected {w}×{h} samples of {bytes} bytes = {} bytes, found {len}", w * h * bytes),
        ));
    }
    if options.channel.as_deref().is_some_and(|c| !c.eq_ignore_ascii_case("height")) {
        return Err(BakeError::input(path, None, "a raw heightmap has one channel, `height`"));
    }
    Ok((w as u32, h as u32))
}
