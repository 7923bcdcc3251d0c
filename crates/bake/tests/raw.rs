//! Raw `.r16` / `.r32` heightmaps, written here byte by byte as engines export them (little
//! endian, row 0 first, no header).

use std::path::PathBuf;

use hikage_bake::heightfield::{LoadOptions, load_samples};

fn file(name: &str, bytes: Vec<u8>) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hikage_raw_{}_{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

#[test]
fn raw_maps_read_as_stored_with_an_explicit_or_square_size() {
    // 4 × 2, u16: values as stored, not normalised.
    let values: [u16; 8] = [0, 1, 65535, 300, 7, 8, 9, 40000];
    let path = file("terrain.r16", values.iter().flat_map(|v| v.to_le_bytes()).collect());
    let s = load_samples(&path, &LoadOptions { raw_size: Some((4, 2)), ..Default::default() }).unwrap();
    assert_eq!((s.width, s.height), (4, 2));
    assert_eq!(s.values, values.map(f32::from));
    assert!(!s.normalized);
    // 2 × 2 f32, the side from the length.
    let floats = [-12.5f32, 0.25, 1e4, 3.0];
    let path = file("terrain.R32", floats.iter().flat_map(|v| v.to_le_bytes()).collect());
    let s = load_samples(&path, &LoadOptions::default()).unwrap();
    assert_eq!((s.width, s.height, s.values.clone()), (2, 2, floats.to_vec()));
}

#[test]
fn bad_raw_maps_are_refused_by_file_and_reason() {
    let short = file("short.r16", vec![0u8; 14]);
    let e =
        load_samples(&short, &LoadOptions { raw_size: Some((4, 2)), ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("short.r16") && e.contains("16 bytes, found 14"), "{e}");
    let oblong = file("oblong.r32", vec![0u8; 4 * 6]);
    let e = load_samples(&oblong, &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("raw_size"), "{e}");
    let nan = file("nan.r32", f32::NAN.to_le_bytes().repeat(4));
    let e = load_samples(&nan, &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("pixel (0, 0)") && e.contains("finite"), "{e}");
    // The size limit, before reading.
    let big = file("big.r16", vec![0u8; 2 * 64 * 64]);
    let e = load_samples(&big, &LoadOptions { max_dimension: 32, ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("(64×64) is 64, above the limit of 32"), "{e}");
}
