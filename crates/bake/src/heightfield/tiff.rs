//! TIFF and GeoTIFF elevation grids (8-, 16- or 32-bit integers, signed or not, or 32- or
//! 64-bit floats; strips or tiles, any of the common compressions), read with the `tiff`
//! crate. Heights are taken as stored. GDAL's no-data value (tag 42113, `nan` included) marks
//! voids, which are filled with the lowest valid height as SRTM voids are; the georeferencing
//! tags are not needed for a bake and are ignored. The header is checked before any sample is
//! decoded: size within the limits, one sample per pixel of a depth listed above.

use std::io::Seek;
use std::path::Path;

use tiff::decoder::{ChunkType, Decoder, DecodingResult, Limits};
use tiff::tags::Tag;

use super::{LoadOptions, check_dimensions};
use crate::error::BakeError;

/// The most samples one strip or tile may hold (a 4096² chunk): each is decoded whole, so this
/// bounds the memory of a read that holds one chunk (`validate PIPELINE`, a tile's window) at
/// 128 MiB of 64-bit samples plus their heights in f32, whatever the chunk's compression.
pub(super) const MAX_CHUNK_SAMPLES: u64 = 1 << 24;

/// The first image of a TIFF, opened: its header read and checked, no sample decoded yet.
pub(super) struct TiffFile {
    decoder: Decoder<std::io::BufReader<std::fs::File>>,
    /// Columns and rows.
    pub width: u32,
    pub height: u32,
    /// GDAL's no-data value, if the file has one.
    pub no_data: Option<f32>,
}

/// Width and height from the first image directory of a classic or Big TIFF, read entry by
/// entry with positioned reads (at most 4,096 entries); `None` where the header is not one the
/// decoder would read either (it then says why).
fn header_dimensions(file: &std::fs::File) -> Option<(u64, u64)> {
    use std::io::{Read, SeekFrom};
    let read = |at: u64, n: usize| -> Option<Vec<u8>> {
        let mut b = vec![0; n];
        let mut f = file;
        f.seek(SeekFrom::Start(at)).ok()?;
        f.read_exact(&mut b).ok()?;
        Some(b)
    };
    let head = read(0, 16)?;
    let little = match &head[..2] {
        b"II" => true,
        b"MM" => false,
        _ => return None,
    };
    let uint = |b: &[u8]| -> u64 {
        let mut v = 0u64;
        for k in 0..b.len() {
            let byte = if little { b[b.len() - 1 - k] } else { b[k] };
            v = v << 8 | u64::from(byte);
        }
        v
    };
    // Classic: 2-byte counts, 12-byte entries, 4-byte values; Big (43): 8, 20 and 8.
    let (count_bytes, entry_bytes, value_bytes, ifd) = match uint(&head[2..4]) {
        42 => (2, 12, 4, uint(&head[4..8])),
        43 => (8, 20, 8, uint(&head[8..16])),
        _ => return None,
    };
    let count = uint(&read(ifd, count_bytes)?).min(4096) as usize;
    let entries = read(ifd + count_bytes as u64, count * entry_bytes)?;
    let (mut w, mut h) = (None, None);
    for e in entries.chunks_exact(entry_bytes) {
        let (tag, kind) = (uint(&e[..2]), uint(&e[2..4]));
        let value = &e[entry_bytes - value_bytes..];
        let v = match kind {
            3 => uint(&value[..2]),
            4 => uint(&value[..4]),
            16 => uint(&value[..8]),
            _ => continue,
        };
        match tag {
            256 => w = Some(v),
            257 => h = Some(v),
            _ => {}
        }
    }
    Some((w?, h?))
}

fn bad(path: &Path, e: tiff::TiffError) -> BakeError {
    BakeError::input(path, None, format!("cannot decode TIFF: {e}"))
}

/// Opens a TIFF and checks its header: size within the limits, one sample per pixel, the
/// channel asked for, a readable no-data tag.
pub(super) fn open(path: &Path, options: &LoadOptions) -> Result<TiffFile, BakeError> {
    let bad = |e| bad(path, e);
    let file = hikage_bundle::files::open_regular(path).map_err(|e| BakeError::io(path, e))?;
    // The size first, from the header alone: the decoder checks a huge grid's strip or tile
    // tables before it says its size, and would refuse it for those instead.
    if let Some((w, h)) = header_dimensions(&file) {
        check_dimensions(path, w, h, options.max_dimension)?;
    }
    (&file).rewind().map_err(|e| BakeError::io(path, e))?;
    let mut limits = Limits::default();
    // Room for the largest chunk read (checked against the header below), in the widest sample.
    limits.decoding_buffer_size = MAX_CHUNK_SAMPLES as usize * 8;
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
    let bits = decoder.find_tag_unsigned::<u32>(Tag::BitsPerSample).map_err(bad)?.unwrap_or(1);
    let format = decoder.find_tag_unsigned::<u32>(Tag::SampleFormat).map_err(bad)?.unwrap_or(1);
    if !matches!((bits, format), (8 | 16 | 32, 1 | 2) | (32 | 64, 3)) {
        let kind = match format {
            1 => "unsigned integer",
            2 => "signed integer",
            3 => "floating-point",
            _ => "undefined",
        };
        return Err(BakeError::input(
            path,
            Some("header".into()),
            format!(
                "expected 8-, 16- or 32-bit integer or 32- or 64-bit float samples, found {bits}-bit {kind} samples"
            ),
        ));
    }
    // A strip or tile is decoded whole: its size, from the header, bounds what one read holds.
    let (cw, ch) = decoder.chunk_dimensions();
    let (kind, rows) = match decoder.get_chunk_type() {
        ChunkType::Strip => ("strip", ch.min(h)),
        ChunkType::Tile => ("tile", ch),
    };
    let chunk = u64::from(cw) * u64::from(rows);
    if chunk > MAX_CHUNK_SAMPLES {
        return Err(BakeError::Limit {
            path: path.to_path_buf(),
            what: format!(
                "one {kind}'s samples ({cw}×{rows}; a strip or tile is decoded whole, so save the grid tiled or in \
                 smaller strips, as `gdal_translate -co TILED=YES` does)"
            ),
            value: chunk,
            limit: MAX_CHUNK_SAMPLES,
        });
    }
    if options.channel.as_deref().is_some_and(|c| !c.eq_ignore_ascii_case("height")) {
        return Err(BakeError::input(path, None, "an elevation TIFF has one channel, `height`"));
    }
    // The tag is text of any claimed length: bound it before the decoder reads it.
    let no_data_len = match decoder.ifd_pointer() {
        Some(ifd) => decoder.read_directory(ifd).map_err(bad)?.get(Tag::GdalNodata).map(|e| e.count()),
        None => None,
    };
    if let Some(len) = no_data_len.filter(|&n| n > 64) {
        return Err(BakeError::input(
            path,
            Some("tag 42113 (GDAL_NODATA)".into()),
            format!("expected a number of at most 64 characters, found {len} bytes"),
        ));
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
            })? as f32)
        }
        None => None,
    };
    Ok(TiffFile { decoder, width: w, height: h, no_data })
}

impl TiffFile {
    /// The size of a full chunk (a strip spans the width) and how many chunks lie across.
    pub fn chunk_grid(&self) -> ((u32, u32), u32) {
        let (cw, ch) = self.decoder.chunk_dimensions();
        let (cw, ch) = (cw.max(1), ch.max(1));
        let across = match self.decoder.get_chunk_type() {
            ChunkType::Strip => 1,
            ChunkType::Tile => self.width.div_ceil(cw),
        };
        ((if across == 1 { self.width } else { cw }, ch), across)
    }

    /// Decodes chunk `index` (row-major over the chunk grid): its width, height and samples.
    pub fn read_chunk(&mut self, path: &Path, index: u32) -> Result<(u32, u32, Vec<f32>), BakeError> {
        let (w, h) = self.decoder.chunk_data_dimensions(index);
        let values = samples(path, self.decoder.read_chunk(index).map_err(|e| bad(path, e))?)?;
        if values.len() < w as usize * h as usize {
            return Err(BakeError::input(
                path,
                Some(format!("chunk {index}")),
                format!("expected {w}×{h} samples, found {}", values.len()),
            ));
        }
        Ok((w, h, values))
    }
}

/// Decoded samples as heights, taken as stored.
fn samples(path: &Path, decoded: DecodingResult) -> Result<Vec<f32>, BakeError> {
    Ok(match decoded {
        DecodingResult::U8(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::I8(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::U16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::I16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::U32(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::I32(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::F32(v) => v,
        DecodingResult::F64(v) => v.into_iter().map(|x| x as f32).collect(),
        _ => {
            return Err(BakeError::input(
                path,
                Some("header".into()),
                "expected 8-, 16- or 32-bit integer or 32- or 64-bit float samples",
            ));
        }
    })
}
