//! Checks the bytes the KTX2 writer produces against the field values of the KTX 2.0
//! specification, reading offsets directly (not through the writer's types or the `ktx2`
//! crate), so a writer bug cannot hide behind a matching reader bug.

use hikage_bundle::ktx2_file::encode;
use hikage_bundle::{Supercompression, TextureData, TextureDesc, TextureDimension, TextureFormat};

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}
fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}
fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes(b[at..at + 2].try_into().unwrap())
}

fn texture(format: TextureFormat, dimension: TextureDimension, w: u32, h: u32, d: u32, layers: u32) -> TextureData {
    let desc = TextureDesc {
        format,
        dimension,
        width: w,
        height: h,
        depth: d,
        layers,
        levels: 1,
        supercompression: Supercompression::None,
        channels: (0..format.channels()).map(|c| format!("c{c}")).collect(),
    };
    let n = desc.level_bytes(0).unwrap() as usize;
    TextureData { desc, levels: vec![(0..n).map(|i| (i % 251) as u8).collect()] }
}

#[test]
fn rg16f_3d_header_matches_the_specification() {
    let tex = texture(TextureFormat::Rg16Float, TextureDimension::D3, 4, 2, 3, 1);
    let b = encode(&tex, "hikage test").unwrap();

    // Identifier: «KTX 20»\r\n\x1A\n.
    assert_eq!(&b[0..12], &[0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A]);
    assert_eq!(u32_at(&b, 12), 83, "vkFormat VK_FORMAT_R16G16_SFLOAT");
    assert_eq!(u32_at(&b, 16), 2, "typeSize");
    assert_eq!((u32_at(&b, 20), u32_at(&b, 24), u32_at(&b, 28)), (4, 2, 3), "pixelWidth/Height/Depth");
    assert_eq!(u32_at(&b, 32), 0, "layerCount of a non-array texture");
    assert_eq!(u32_at(&b, 36), 1, "faceCount");
    assert_eq!(u32_at(&b, 40), 1, "levelCount");
    assert_eq!(u32_at(&b, 44), 0, "supercompressionScheme none");

    // Index: DFD right after the level index (80 + 24 bytes).
    let dfd_offset = u32_at(&b, 48) as usize;
    let dfd_length = u32_at(&b, 52) as usize;
    assert_eq!(dfd_offset, 104);
    assert_eq!(dfd_length, 4 + 24 + 2 * 16, "total size + basic block header + 2 samples");
    let kvd_offset = u32_at(&b, 56) as usize;
    let kvd_length = u32_at(&b, 60) as usize;
    assert_eq!(kvd_offset, dfd_offset + dfd_length);
    assert_eq!((u64_at(&b, 64), u64_at(&b, 72)), (0, 0), "no supercompression global data");

    // Level index entry 0.
    let level_offset = u64_at(&b, 80) as usize;
    assert_eq!(level_offset % 4, 0, "level aligned to lcm(texel size 4, 4)");
    assert!(level_offset >= kvd_offset + kvd_length);
    assert_eq!(u64_at(&b, 88), 4 * 2 * 3 * 4, "byteLength");
    assert_eq!(u64_at(&b, 96), 4 * 2 * 3 * 4, "uncompressedByteLength");
    assert_eq!(&b[level_offset..], &tex.levels[0][..], "level bytes stored verbatim at the end");

    // Basic data format descriptor.
    let d = dfd_offset;
    assert_eq!(u32_at(&b, d), dfd_length as u32, "dfdTotalSize");
    assert_eq!(u32_at(&b, d + 4), 0, "vendorId Khronos, descriptorType basic");
    assert_eq!(u16_at(&b, d + 8), 2, "versionNumber");
    assert_eq!(u16_at(&b, d + 10), 24 + 2 * 16, "descriptorBlockSize");
    assert_eq!(b[d + 12], 1, "colorModel KHR_DF_MODEL_RGBSDA");
    assert_eq!(b[d + 14], 1, "transferFunction linear");
    assert_eq!(&b[d + 16..d + 20], &[0, 0, 0, 0], "texelBlockDimension 1x1x1x1");
    assert_eq!(b[d + 20], 4, "bytesPlane0 = texel size");
    for (s, channel) in [(0usize, 0u8), (1, 1)] {
        let at = d + 28 + 16 * s;
        assert_eq!(u16_at(&b, at), 16 * s as u16, "bitOffset");
        assert_eq!(b[at + 2], 15, "bitLength - 1");
        assert_eq!(b[at + 3], 0x80 | 0x40 | channel, "channelType: FLOAT | SIGNED | channel id");
        assert_eq!(u32_at(&b, at + 8), 0xBF80_0000, "sampleLower -1.0");
        assert_eq!(u32_at(&b, at + 12), 0x3F80_0000, "sampleUpper 1.0");
    }

    // Key/value data: one entry, KTXwriter, NUL-terminated key and value, padded to 4.
    let k = kvd_offset;
    let entry = u32_at(&b, k) as usize;
    assert_eq!(&b[k + 4..k + 4 + entry], b"KTXwriter\0hikage test\0");
    assert_eq!(kvd_length, (4 + entry).div_ceil(4) * 4);
}

#[test]
fn r8_array_and_zstd_headers() {
    let tex = texture(TextureFormat::R8Unorm, TextureDimension::D2Array, 8, 8, 1, 5);
    let b = encode(&tex, "w").unwrap();
    assert_eq!(u32_at(&b, 12), 9, "VK_FORMAT_R8_UNORM");
    assert_eq!(u32_at(&b, 16), 1, "typeSize");
    assert_eq!((u32_at(&b, 28), u32_at(&b, 32)), (0, 5), "pixelDepth 0, layerCount 5");
    let d = u32_at(&b, 48) as usize;
    assert_eq!(b[d + 28 + 3], 0, "unsigned normalised R channel");
    assert_eq!((u32_at(&b, d + 28 + 8), u32_at(&b, d + 28 + 12)), (0, 255), "sampleLower/Upper");

    let mut z = texture(TextureFormat::R32Float, TextureDimension::D2, 64, 64, 1, 1);
    z.levels[0] = vec![0; 64 * 64 * 4]; // compresses well
    z.desc.supercompression = Supercompression::Zstd;
    let b = encode(&z, "w").unwrap();
    assert_eq!(u32_at(&b, 44), 2, "supercompressionScheme zstd");
    let (offset, len, full) = (u64_at(&b, 80) as usize, u64_at(&b, 88) as usize, u64_at(&b, 96));
    assert_eq!(full, 64 * 64 * 4);
    assert!(len < 1000, "zeros compress: {len} bytes");
    assert_eq!(&b[offset..offset + 4], &[0x28, 0xB5, 0x2F, 0xFD], "zstd frame magic");
}

/// BC5 and BC4 as the specification lays out block formats: typeSize 1, the BC colour models
/// with 4×4 texel blocks, one 64-bit sample per channel, levels of whole blocks aligned to the
/// block size.
#[test]
fn block_format_headers() {
    // 10 × 6 texels: 3 × 2 blocks per slice, 3 slices.
    let tex = texture(TextureFormat::Bc5RgUnorm, TextureDimension::D3, 10, 6, 3, 1);
    let b = encode(&tex, "w").unwrap();
    assert_eq!(u32_at(&b, 12), 141, "VK_FORMAT_BC5_UNORM_BLOCK");
    assert_eq!(u32_at(&b, 16), 1, "typeSize of a block-compressed format");
    assert_eq!((u32_at(&b, 20), u32_at(&b, 24), u32_at(&b, 28)), (10, 6, 3), "size in texels");
    let level_offset = u64_at(&b, 80) as usize;
    assert_eq!(level_offset % 16, 0, "level aligned to lcm(block size 16, 4)");
    assert_eq!(u64_at(&b, 88), 3 * 2 * 3 * 16, "byteLength: whole blocks");
    let d = u32_at(&b, 48) as usize;
    assert_eq!(u32_at(&b, 52), 4 + 24 + 2 * 16, "two samples");
    assert_eq!(b[d + 12], 132, "colorModel KHR_DF_MODEL_BC5");
    assert_eq!(&b[d + 16..d + 20], &[3, 3, 0, 0], "texelBlockDimension 4x4x1x1");
    assert_eq!(b[d + 20], 16, "bytesPlane0 = block size");
    for (s, channel) in [(0usize, 0u8), (1, 1)] {
        let at = d + 28 + 16 * s;
        assert_eq!(u16_at(&b, at), 64 * s as u16, "bitOffset: red block, then green");
        assert_eq!(b[at + 2], 63, "bitLength - 1");
        assert_eq!(b[at + 3], channel, "channelType: unsigned, red then green");
        assert_eq!((u32_at(&b, at + 8), u32_at(&b, at + 12)), (0, u32::MAX), "sampleLower/Upper");
    }

    let tex = texture(TextureFormat::Bc4RUnorm, TextureDimension::D2Array, 8, 8, 1, 2);
    let b = encode(&tex, "w").unwrap();
    assert_eq!(u32_at(&b, 12), 139, "VK_FORMAT_BC4_UNORM_BLOCK");
    assert_eq!(u64_at(&b, 88), 2 * 2 * 2 * 8, "byteLength: 2 × 2 blocks × 2 layers");
    let d = u32_at(&b, 48) as usize;
    assert_eq!((b[d + 12], b[d + 20]), (131, 8), "colorModel KHR_DF_MODEL_BC4, 8-byte blocks");
    // The ktx2 crate reads the same format back.
    let reader = ktx2::Reader::new(&b[..]).unwrap();
    assert_eq!(reader.header().format, Some(ktx2::Format::BC4_UNORM_BLOCK));
}
