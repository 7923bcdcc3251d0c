//! TIFF/GeoTIFF elevation grids written by an independent writer (Python's tifffile; the
//! fixtures and the script that made them are in `tests/fixtures/tiff/`): strips and tiles,
//! u16, i16 and f32, deflate, and a GDAL no-data value.

use std::path::PathBuf;

use hikage_bake::heightfield::{LoadOptions, load_samples};

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures/tiff").join(name)
}

/// The grid `make.py` writes: 20 × 12, `100 + 7x − 3y + (x·y mod 5)`.
fn base(x: i32, y: i32) -> i32 {
    100 + 7 * x - 3 * y + (x * y) % 5
}

#[test]
fn strips_and_tiles_read_as_stored() {
    let u16s = load_samples(&fixture("u16_strips.tif"), &LoadOptions::default()).unwrap();
    let f32s = load_samples(&fixture("f32_strips.tif"), &LoadOptions::default()).unwrap();
    let i16s = load_samples(&fixture("i16_tiles_nodata.tif"), &LoadOptions::default()).unwrap();
    for s in [&u16s, &f32s, &i16s] {
        assert_eq!((s.width, s.height), (20, 12));
        assert!(!s.normalized);
    }
    // The two no-data samples (−9999) take the lowest valid height.
    let lowest = (0..12).flat_map(|y| (0..20).map(move |x| (x, y))).filter(|&p| p != (4, 3) && p != (19, 11));
    let lowest = lowest.map(|(x, y)| base(x, y) - 150).min().unwrap() as f32;
    for y in 0..12 {
        for x in 0..20 {
            let i = (y * 20 + x) as usize;
            assert_eq!(u16s.values[i], base(x, y) as f32, "u16 ({x}, {y})");
            assert_eq!(f32s.values[i], base(x, y) as f32 / 4.0 - 30.0, "f32 ({x}, {y})");
            let expected = if (x, y) == (4, 3) || (x, y) == (19, 11) { lowest } else { (base(x, y) - 150) as f32 };
            assert_eq!(i16s.values[i], expected, "i16 ({x}, {y})");
        }
    }
}

#[test]
fn tiffs_over_the_limit_or_cut_short_are_refused_by_name() {
    let e = load_samples(&fixture("u16_strips.tif"), &LoadOptions { max_dimension: 16, ..Default::default() })
        .unwrap_err()
        .to_string();
    assert!(e.contains("u16_strips.tif") && e.contains("(20×12) is 20, above the limit of 16"), "{e}");
    let dir = std::env::temp_dir().join(format!("hikage_tiff_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cut = dir.join("cut.tif");
    let bytes = std::fs::read(fixture("f32_strips.tif")).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = load_samples(&cut, &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("cut.tif") && e.contains("TIFF"), "{e}");
}
