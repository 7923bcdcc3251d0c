//! SRTM `.hgt` tiles, built here byte by byte as the format defines them (a square grid of
//! big-endian i16 metres, −32768 for a void, the side from the file's length).

use std::path::PathBuf;

use hikage_bake::heightfield::{LoadOptions, load_samples};

fn tile(name: &str, samples: &[i16]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hikage_hgt_{}_{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, samples.iter().flat_map(|v| v.to_be_bytes()).collect::<Vec<u8>>()).unwrap();
    path
}

#[test]
fn a_tile_reads_as_metres_with_voids_filled_by_the_lowest_elevation() {
    // 3 × 3, row 0 first: heights as stored, one void in the middle, one negative height.
    let path = tile("N35E138.hgt", &[100, 200, 300, -5, i16::MIN, 3776, 0, 1, 2]);
    let s = load_samples(&path, &LoadOptions::default()).unwrap();
    assert_eq!((s.width, s.height), (3, 3));
    assert_eq!(s.values, [100.0, 200.0, 300.0, -5.0, -5.0, 3776.0, 0.0, 1.0, 2.0]);
    assert!(!s.normalized);
    assert_eq!(s.channel, "elevation");
    // The extension decides, in either case.
    let upper = tile("N35E138.HGT", &[1, 2, 3, 4]);
    assert_eq!(load_samples(&upper, &LoadOptions::default()).unwrap().values, [1.0, 2.0, 3.0, 4.0]);
}

#[test]
fn bad_tiles_are_refused_by_file_and_reason() {
    let cases: [(&str, Vec<u8>, &str); 4] = [
        ("odd.hgt", vec![0u8; 9], "2·N² bytes"),
        ("oblong.hgt", vec![0u8; 2 * 6], "2·N² bytes"),
        (
            "voids.hgt",
            [i16::MIN; 4].iter().flat_map(|v| v.to_be_bytes()).collect(),
            "every one of the 4 samples is no-data",
        ),
        ("one.hgt", vec![0u8; 2], "2·N² bytes"),
    ];
    for (name, bytes, needle) in cases {
        let path = tile(name, &[]);
        std::fs::write(&path, bytes).unwrap();
        let e = load_samples(&path, &LoadOptions::default()).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains(needle), "{name}: {e}");
    }
    // The size limit is checked from the length, before the file is read.
    let path = tile("big.hgt", &[0; 64 * 64]);
    let e = load_samples(&path, &LoadOptions { max_dimension: 32, ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("(64×64) is 64, above the limit of 32"), "{e}");
    let e = load_samples(
        &tile("chan.hgt", &[1, 2, 3, 4]),
        &LoadOptions { channel: Some("R".into()), ..Default::default() },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("elevation"), "{e}");
}
