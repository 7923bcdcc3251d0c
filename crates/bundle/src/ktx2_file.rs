//! KTX2 files: a writer for the formats of [`TextureFormat`] and a reader built on the `ktx2`
//! crate.
//!
//! The writer follows the KTX 2.0 specification (Khronos, 2020): the 80-byte header, the level
//! index, a Khronos Basic Data Format Descriptor (colour model RGBSDA, or BC4/BC5 with 4×4
//! texel blocks; linear transfer), the key/value data with a `KTXwriter` entry, then the levels
//! from the smallest to the largest. Uncompressed levels are aligned to `lcm(block size, 4)`
//! (a texel is a block of one); zstd-supercompressed levels (scheme 2) need no alignment.
//! `bytesPlane0` stays the block size even when supercompressed, as the Data Format
//! specification recommends.

use std::path::Path;

use crate::error::BundleError;
use crate::limits::Limits;
use crate::texture::{Supercompression, TextureData, TextureDesc, TextureDimension, TextureFormat};

/// The 12 identifier bytes every KTX2 file starts with.
pub const IDENTIFIER: [u8; 12] = [0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A];

const HEADER_BYTES: usize = 80;
const LEVEL_INDEX_BYTES: usize = 24;
const SUPERCOMPRESSION_ZSTD: u32 = 2;

/// Encodes `texture` as a KTX2 file, writing `writer` as the `KTXwriter` value.
pub fn encode(texture: &TextureData, writer: &str) -> Result<Vec<u8>, BundleError> {
    encode_with(texture, writer, &crate::zstd::fastest)
}

/// [`encode`], zstd-supercompressed levels (when the description asks for them) compressed by
/// `zstd`.
pub fn encode_with(texture: &TextureData, writer: &str, zstd: crate::zstd::Encoder) -> Result<Vec<u8>, BundleError> {
    let desc = &texture.desc;
    desc.check(&Limits::default()).map_err(|m| BundleError::InvalidData(format!("KTX2 writer: {m}")))?;
    if texture.levels.len() != desc.levels as usize {
        return Err(BundleError::InvalidData(format!(
            "KTX2 writer: {} levels described, {} given",
            desc.levels,
            texture.levels.len()
        )));
    }
    for (l, data) in texture.levels.iter().enumerate() {
        let expected = desc.level_bytes(l as u32).unwrap_or(u64::MAX);
        if data.len() as u64 != expected {
            return Err(BundleError::InvalidData(format!(
                "KTX2 writer: level {l} needs {expected} bytes, {} given",
                data.len()
            )));
        }
    }

    // Stored (possibly compressed) level data.
    let stored: Vec<Vec<u8>> = match desc.supercompression {
        Supercompression::None => texture.levels.clone(),
        Supercompression::Zstd => texture.levels.iter().map(|l| zstd(l)).collect(),
    };

    let dfd = data_format_descriptor(desc.format);
    let kvd = key_value_data(&[("KTXwriter", writer)]);

    // Section offsets: header, level index, DFD, KVD, then levels.
    let level_count = desc.levels as usize;
    let dfd_offset = HEADER_BYTES + LEVEL_INDEX_BYTES * level_count;
    let kvd_offset = dfd_offset + dfd.len();
    let mut end = kvd_offset + kvd.len();
    let align = match desc.supercompression {
        Supercompression::None => lcm(desc.format.block_bytes(), 4),
        Supercompression::Zstd => 1,
    };
    // Levels are stored smallest (highest index) first.
    let mut offsets = vec![0usize; level_count];
    for l in (0..level_count).rev() {
        end = end.div_ceil(align) * align;
        offsets[l] = end;
        end += stored[l].len();
    }

    let mut out = Vec::with_capacity(end);
    out.extend_from_slice(&IDENTIFIER);
    let (pixel_depth, layer_count) = match desc.dimension {
        TextureDimension::D2 => (0, 0),
        TextureDimension::D2Array => (0, desc.layers),
        TextureDimension::D3 => (desc.depth, 0),
    };
    let scheme = match desc.supercompression {
        Supercompression::None => 0,
        Supercompression::Zstd => SUPERCOMPRESSION_ZSTD,
    };
    for v in [
        desc.format.vk_format(),
        desc.format.channel_bytes() as u32,
        desc.width,
        desc.height,
        pixel_depth,
        layer_count,
        1, // faceCount
        desc.levels,
        scheme,
        dfd_offset as u32,
        dfd.len() as u32,
        kvd_offset as u32,
        kvd.len() as u32,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteOffset
    out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteLength
    for l in 0..level_count {
        out.extend_from_slice(&(offsets[l] as u64).to_le_bytes());
        out.extend_from_slice(&(stored[l].len() as u64).to_le_bytes());
        out.extend_from_slice(&(texture.levels[l].len() as u64).to_le_bytes());
    }
    out.extend_from_slice(&dfd);
    out.extend_from_slice(&kvd);
    for l in (0..level_count).rev() {
        out.resize(offsets[l], 0);
        out.extend_from_slice(&stored[l]);
    }
    Ok(out)
}

/// The DFD section: its total size, then one Khronos Basic descriptor block with a sample per
/// channel (an uncompressed format) or per 64-bit BC4 block half (BC4, BC5).
fn data_format_descriptor(format: TextureFormat) -> Vec<u8> {
    let channels = format.channels();
    let block_size = 24 + 16 * channels;
    let mut d = Vec::with_capacity(4 + block_size);
    d.extend_from_slice(&((4 + block_size) as u32).to_le_bytes()); // dfdTotalSize
    d.extend_from_slice(&0u32.to_le_bytes()); // vendorId 0 (Khronos), descriptorType 0 (basic)
    d.extend_from_slice(&2u16.to_le_bytes()); // versionNumber
    d.extend_from_slice(&(block_size as u16).to_le_bytes());
    let (model, block, bits) = match format {
        TextureFormat::Bc4RUnorm => (131, [3, 3, 0, 0], 64), // KHR_DF_MODEL_BC4, 4×4 blocks
        TextureFormat::Bc5RgUnorm => (132, [3, 3, 0, 0], 64), // KHR_DF_MODEL_BC5
        _ => (1, [0, 0, 0, 0], format.channel_bytes() * 8),  // KHR_DF_MODEL_RGBSDA, 1×1×1×1
    };
    d.push(model); // colorModel
    d.push(1); // colorPrimaries: BT709
    d.push(1); // transferFunction: LINEAR
    d.push(0); // flags: alpha straight
    d.extend_from_slice(&block); // texelBlockDimension (each stored minus one)
    let mut planes = [0u8; 8];
    planes[0] = format.block_bytes() as u8;
    d.extend_from_slice(&planes);
    let channel_ids: &[u8] = if channels == 4 { &[0, 1, 2, 15] } else { &[0, 1] }; // R, G, (B, A)
    for (c, &id) in channel_ids.iter().enumerate().take(channels) {
        d.extend_from_slice(&((c * bits) as u16).to_le_bytes()); // bitOffset
        d.push((bits - 1) as u8); // bitLength (minus one)
        let qualifiers = if format.is_float() { 0x80 | 0x40 } else { 0 }; // FLOAT | SIGNED
        d.push(id | qualifiers);
        d.extend_from_slice(&[0, 0, 0, 0]); // samplePosition
        let (lower, upper) = match (format.is_block_compressed(), format.channel_bytes()) {
            (true, _) => (0u32, u32::MAX),
            (false, 1) => (0u32, 255u32),
            _ => ((-1.0f32).to_bits(), 1.0f32.to_bits()),
        };
        d.extend_from_slice(&lower.to_le_bytes());
        d.extend_from_slice(&upper.to_le_bytes());
    }
    d
}

/// Key/value data: each entry is its byte length, `key\0value\0`, padded to 4 bytes; entries
/// sorted by key.
fn key_value_data(entries: &[(&str, &str)]) -> Vec<u8> {
    let mut sorted = entries.to_vec();
    sorted.sort();
    let mut out = Vec::new();
    for (key, value) in sorted {
        let len = key.len() + 1 + value.len() + 1;
        out.extend_from_slice(&(len as u32).to_le_bytes());
        out.extend_from_slice(key.as_bytes());
        out.push(0);
        out.extend_from_slice(value.as_bytes());
        out.push(0);
        out.resize(out.len().div_ceil(4) * 4, 0);
    }
    out
}

fn lcm(a: usize, b: usize) -> usize {
    fn gcd(a: usize, b: usize) -> usize {
        if b == 0 { a } else { gcd(b, a % b) }
    }
    a / gcd(a, b) * b
}

/// Reads the description a KTX2 file declares, without decompressing anything. `path` is only
/// used in error messages.
pub fn read_desc(bytes: &[u8], path: &Path, limits: &Limits) -> Result<TextureDesc, BundleError> {
    let err = |message: String| BundleError::Ktx2 { path: path.to_path_buf(), message };
    if bytes.len() < 12 || bytes[..12] != IDENTIFIER {
        return Err(err("expected the KTX2 identifier «KTX 20» at byte 0".into()));
    }
    check_level_index(bytes, limits).map_err(|m| err(format!("KTX2 level index: {m}")))?;
    check_basic_dfd(bytes).map_err(|m| err(format!("KTX2 data format descriptor: {m}")))?;
    let reader = ktx2::Reader::new(bytes).map_err(|e| err(format!("malformed KTX2: {e}")))?;
    let h = reader.header();
    let vk = u32::from_le_bytes(bytes[12..16].try_into().expect("12 identifier + 4 bytes"));
    let format = TextureFormat::from_vk_format(vk).ok_or_else(|| {
        err(format!(
            "header vkFormat {vk} is not one hikage reads (expected one of {})",
            TextureFormat::ALL.map(|f| f.vk_format().to_string()).join(", ")
        ))
    })?;
    if h.type_size != format.channel_bytes() as u32 {
        return Err(err(format!(
            "header typeSize is {}, expected {} for {format:?}",
            h.type_size,
            format.channel_bytes()
        )));
    }
    if h.face_count != 1 {
        return Err(err(format!("header faceCount is {}, expected 1", h.face_count)));
    }
    if h.pixel_height == 0 {
        return Err(err("header pixelHeight is 0: 1D textures are not supported".into()));
    }
    let dimension = match (h.pixel_depth, h.layer_count) {
        (0, 0) => TextureDimension::D2,
        (0, _) => TextureDimension::D2Array,
        (_, 0) => TextureDimension::D3,
        _ => return Err(err("header has both pixelDepth and layerCount: 3D arrays are not supported".into())),
    };
    let supercompression = match bytes_u32(bytes, 44) {
        0 => Supercompression::None,
        SUPERCOMPRESSION_ZSTD => Supercompression::Zstd,
        other => {
            return Err(err(format!("header supercompressionScheme is {other}, expected 0 (none) or 2 (zstd)")));
        }
    };
    let desc = TextureDesc {
        format,
        dimension,
        width: h.pixel_width,
        height: h.pixel_height,
        depth: h.pixel_depth.max(1),
        layers: h.layer_count.max(1),
        levels: h.level_count.max(1),
        supercompression,
        channels: (0..format.channels()).map(|c| ["r", "g", "b", "a"][c].to_string()).collect(),
    };
    desc.check(limits).map_err(|m| err(format!("header: {m}")))?;
    Ok(desc)
}

/// Texel block dimensions in a basic data format descriptor block are stored minus one, so 255
/// would mean 256: no format has that, and the `ktx2` crate's parser panics on it (0.5.0,
/// found by fuzzing). Refused here first.
fn check_basic_dfd(bytes: &[u8]) -> Result<(), String> {
    let (offset, length) = (bytes_u32(bytes, 48) as usize, bytes_u32(bytes, 52) as usize);
    let end = offset.saturating_add(length).min(bytes.len());
    let mut at = offset.saturating_add(4); // past dfdTotalSize
    while at.saturating_add(16) <= end {
        let kind = bytes_u32(bytes, at);
        let size = u16::from_le_bytes([bytes[at + 6], bytes[at + 7]]) as usize;
        if kind == 0
            && let Some(d) = bytes[at + 12..at + 16].iter().position(|&d| d == 255)
        {
            return Err(format!("texel block dimension {d} is 256 (byte {}), expected at most 255", at + 12 + d));
        }
        if size == 0 {
            break;
        }
        at = at.saturating_add(size);
    }
    Ok(())
}

/// The level index (byte 80 on, 24 bytes a level) against the file's length and the texture
/// byte limit, before any parser trusts it: a level claiming 2^40 bytes is named as such.
fn check_level_index(bytes: &[u8], limits: &Limits) -> Result<(), String> {
    if bytes.len() < 80 {
        return Err(format!("expected an 80-byte header, found a {}-byte file", bytes.len()));
    }
    let levels = bytes_u32(bytes, 40).max(1) as usize;
    if levels > 32 {
        return Err(format!("header levelCount is {levels}, at most 32 levels exist"));
    }
    if bytes.len() < 80 + 24 * levels {
        return Err(format!(
            "the index of {levels} levels needs {} bytes, the file has {}",
            80 + 24 * levels,
            bytes.len()
        ));
    }
    let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"));
    for l in 0..levels {
        let at = 80 + 24 * l;
        let (offset, length, uncompressed) = (u64_at(at), u64_at(at + 8), u64_at(at + 16));
        if uncompressed > limits.max_texture_bytes {
            return Err(format!(
                "level {l} claims {uncompressed} uncompressed bytes (byte {}), above the limit of {}",
                at + 16,
                limits.max_texture_bytes
            ));
        }
        match offset.checked_add(length) {
            Some(end) if end <= bytes.len() as u64 => {}
            _ => {
                return Err(format!(
                    "level {l} claims bytes {offset}..{offset}+{length} (byte {at}), past the end of the {}-byte file",
                    bytes.len()
                ));
            }
        }
    }
    Ok(())
}

fn bytes_u32(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"))
}

/// Decodes a KTX2 file into uncompressed levels. Every size is checked against the header and
/// `limits` before memory is allocated for it.
pub fn decode(bytes: &[u8], path: &Path, limits: &Limits) -> Result<TextureData, BundleError> {
    let desc = read_desc(bytes, path, limits)?;
    let err = |message: String| BundleError::Ktx2 { path: path.to_path_buf(), message };
    let reader = ktx2::Reader::new(bytes).map_err(|e| err(format!("malformed KTX2: {e}")))?;
    let mut levels = Vec::with_capacity(desc.levels as usize);
    for (l, level) in reader.levels().enumerate() {
        let expected = desc.level_bytes(l as u32).expect("checked by TextureDesc::check");
        if level.uncompressed_byte_length != expected {
            return Err(err(format!(
                "level {l}: uncompressedByteLength is {}, expected {expected} from the header",
                level.uncompressed_byte_length
            )));
        }
        let data = match desc.supercompression {
            Supercompression::None => {
                if level.data.len() as u64 != expected {
                    return Err(err(format!("level {l}: byteLength is {}, expected {expected}", level.data.len())));
                }
                level.data.to_vec()
            }
            Supercompression::Zstd => {
                let mut out = vec![0u8; expected as usize];
                let mut decoder = ruzstd::decoding::FrameDecoder::new();
                let n = decoder
                    .decode_all(level.data, &mut out)
                    .map_err(|e| err(format!("level {l}: zstd data is corrupt: {e}")))?;
                if n as u64 != expected {
                    return Err(err(format!("level {l}: zstd data inflates to {n} bytes, expected {expected}")));
                }
                out
            }
        };
        levels.push(data);
    }
    Ok(TextureData { desc, levels })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn desc(format: TextureFormat, dimension: TextureDimension, depth: u32, layers: u32) -> TextureDesc {
        TextureDesc {
            format,
            dimension,
            width: 5,
            height: 3,
            depth,
            layers,
            levels: 1,
            supercompression: Supercompression::None,
            channels: (0..format.channels()).map(|c| ["r", "g", "b", "a"][c].to_string()).collect(),
        }
    }

    fn pattern(desc: &TextureDesc, level: u32) -> Vec<u8> {
        (0..desc.level_bytes(level).unwrap()).map(|i| (i * 7 + level as u64) as u8).collect()
    }

    #[test]
    fn round_trip_every_format_shape_and_compression() {
        for format in TextureFormat::ALL {
            for (dimension, depth, layers) in
                [(TextureDimension::D2, 1, 1), (TextureDimension::D2Array, 1, 4), (TextureDimension::D3, 6, 1)]
            {
                for sc in [Supercompression::None, Supercompression::Zstd] {
                    let mut d = desc(format, dimension, depth, layers);
                    d.supercompression = sc;
                    d.levels = 3;
                    let levels = (0..3).map(|l| pattern(&d, l)).collect();
                    let tex = TextureData { desc: d.clone(), levels };
                    let bytes = encode(&tex, "test").unwrap();
                    let back = decode(&bytes, Path::new("mem"), &Limits::default()).unwrap();
                    assert_eq!(back.levels, tex.levels, "{format:?} {dimension:?} {sc:?}");
                    assert_eq!(back.desc.format, format);
                    assert_eq!(back.desc.dimension, dimension);
                    assert_eq!((back.desc.depth, back.desc.layers, back.desc.levels), (depth, layers, 3));
                    let reader = ktx2::Reader::new(&bytes[..]).unwrap();
                    assert_eq!(reader.writer().map(|w| w.trim_end_matches('\0')), Some("test"));
                }
            }
        }
    }

    #[test]
    fn truncated_and_lying_files_are_refused() {
        let d = desc(TextureFormat::R32Float, TextureDimension::D3, 4, 1);
        let tex = TextureData { levels: vec![pattern(&d, 0)], desc: d };
        let bytes = encode(&tex, "t").unwrap();
        for cut in [0, 11, 40, 80, 150, bytes.len() - 1] {
            assert!(decode(&bytes[..cut], Path::new("t.ktx2"), &Limits::default()).is_err(), "cut {cut}");
        }
        // A header claiming a huge 3D texture is refused before any allocation.
        let mut lying = bytes.clone();
        lying[20..24].copy_from_slice(&16384u32.to_le_bytes()); // pixelWidth
        lying[24..28].copy_from_slice(&16384u32.to_le_bytes()); // pixelHeight
        lying[28..32].copy_from_slice(&16384u32.to_le_bytes()); // pixelDepth
        let e = decode(&lying, Path::new("t.ktx2"), &Limits::default()).unwrap_err().to_string();
        assert!(e.contains("t.ktx2") && e.contains("limit"), "{e}");
    }
}
