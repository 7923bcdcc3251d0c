//! TIFF and GeoTIFF elevation grids (unsigned or signed 16-bit, or 32-bit float; strips or
//! tiles, any of the common compressions), read with the `tiff` crate. Heights are taken as
//! stored. GDAL's no-data value (tag 42113) marks voids, which are filled with the lowest valid
//! height as SRTM voids are; the georeferencing tags are not needed for a bake and are ignored.

use std::path::Path;

use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;

use super::{LoadOptions, Samples, check_dimensions, fill_voids};
use crate::error::BakeError;

/// Whether `magic` starts a TIFF file (either byte order; BigTIFF too).
pub(super) fn is_tiff(magic: &[u8]) -> bool {
    magic.starts_with(b"II*\0")
        || magic.starts_with(b"MM\0*")
        || magic.starts_with(b"II+\0")
        || magic.starts_with(b"MM\0+")
}

/// Reads the first image of a TIFF: its size checked from the header before any sample is
/// decoded, one channel of u16, i16 or f32 samples.
pub(super) fn load(path: &Path, options: &LoadOptions) -> Result<Samples, BakeError> {
    let bad = |e: tiff::TiffError| BakeError::input(path, None, format!("cannot decode TIFF: {e}"));
    let file = std::fs::File::open(path).map_err(|e| BakeError::io(path, e))?;
    let mut limits = Limits::default();
    // Room for the largest map the limits allow, in f32 (the widest sample read).
    limits.decoding_buffer_size = (options.max_dimension as usize).pow(2).saturating_mul(4);
    let mut decoder = Decoder::new(std::io::BufReader::new(file)).map_err(bad)?.with_limits(limits);
    let (w, h) = decoder.dimensions().map_err(bad)?;
    check_dimensions(path, w as u64, h as u64, options.max_dimension)?;
    let samples_per_pixel = decoder.find_tag_unsigned::<u32>(Tag::SamplesPerPixel).map_err(bad)?.unwrap_or(1);
    if samples_per_pixel != 1 {
        return Err(BakeError::input(
            path,
            Some("header".into()),
            format!("expected one sample per pixel (an elevation grid), found {samples_per_pixel}"),
        ));
    }
    if options.channel.as_deref().is_some_and(|c| !c.eq_ignore_ascii_case("height")) {
        return Err(BakeError::input(path, None, "an elevation TIFF has one channel, `height`"));
    }
    let no_data = match decoder.find_tag(Tag::GdalNodata).map_err(bad)? {
        Some(v) => {
            let text = v.into_string().map_err(bad)?;
            let trimmed = text.trim_end_matches('\0').trim();
            Some(trimmed.parse::<f64>().map_err(|_| {
                BakeError::input(
                    path,
                    Some("tag 42113 (GDAL_NODATA)".into()),
                    format!("expected a number, found {trimmed:?}"),
                )
            })?)
        }
        None => None,
    };
    let values: Vec<f32> = match decoder.read_image().map_err(bad)? {
        DecodingResult::U16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::I16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::F32(v) => v,
        DecodingResult::U8(v) => v.into_iter().map(f32::from).collect(),
        _ => {
            return Err(BakeError::input(
                path,
                Some("header".into()),
                "expected 8- or 16-bit integer or 32-bit float samples",
            ));
        }
    };
    let values = match no_data {
        Some(nd) => fill_voids(path, values, nd as f32)?,
        None => values,
    };
    Ok(Samples { width: w, height: h, values, normalized: false, channel: "height".into() })
}
