//! Windows of heightfield files, as tiled bakes read them, against the whole file as
//! `load_samples` reads it: every format, windows inside the map, across its edges, starting
//! left of and above it and larger than it (read around the torus), with voids.

use std::path::{Path, PathBuf};

use hikage_bake::heightfield::{HeightFile, LoadOptions, load_samples};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hikage_windows_{}_{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn repo(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..").join(path)
}

/// Every window of a set against the whole file cut by hand; returns how many samples were
/// compared.
fn windows_match_the_whole_file(path: &Path, options: &LoadOptions) -> usize {
    let whole = load_samples(path, options).unwrap();
    let (w, h) = (whole.width as i64, whole.height as i64);
    let mut source = HeightFile::open(path, options).unwrap();
    assert_eq!(source.size(), (whole.width, whole.height), "{}", path.display());
    assert_eq!(source.channel(), (whole.normalized, whole.channel.clone()), "{}", path.display());
    let fill = source.void_fill().unwrap();
    let windows = [
        (0, 0, w, h),
        (1, 2, w / 2, h / 3),
        (w - 3, h - 2, 5, 4),
        (-4, -3, 9, 7),
        (-w, -1, 3 * w, 2),
        (2, -h - 1, 3, 3 * h + 2),
    ];
    let mut compared = 0;
    for (x, y, ww, wh) in windows {
        let got = source.read_window((x, y), (ww as u32, wh as u32), fill).unwrap();
        for j in 0..wh {
            for i in 0..ww {
                let (u, v) = ((x + i).rem_euclid(w), (y + j).rem_euclid(h));
                let want = whole.values[(v * w + u) as usize];
                assert_eq!(
                    got[(j * ww + i) as usize],
                    want,
                    "{}: window ({x}, {y}) {ww}×{wh}, texel ({i}, {j}) = map ({u}, {v})",
                    path.display()
                );
                compared += 1;
            }
        }
    }
    compared
}

#[test]
fn tiff_strips_and_tiles_with_voids_read_by_window_as_whole() {
    for name in ["u16_strips.tif", "f32_strips.tif", "i16_tiles_nodata.tif"] {
        let path = repo("tests/fixtures/tiff").join(name);
        assert!(windows_match_the_whole_file(&path, &LoadOptions::default()) > 300);
    }
}

#[test]
fn srtm_tiles_with_voids_read_by_window_as_whole() {
    let n = 37u32;
    let mut bytes = Vec::new();
    for y in 0..n {
        for x in 0..n {
            let v: i16 = if (x * 7 + y * 3) % 23 == 0 { i16::MIN } else { (x as i16 * 13 - y as i16 * 5) % 97 + 400 };
            bytes.extend_from_slice(&v.to_be_bytes());
        }
    }
    let path = scratch("hgt").join("N00E000.hgt");
    std::fs::write(&path, bytes).unwrap();
    assert!(windows_match_the_whole_file(&path, &LoadOptions::default()) > 300);
}

#[test]
fn raw_heightmaps_read_by_window_as_whole() {
    let (w, h) = (29u32, 17u32);
    let dir = scratch("raw");
    let r16: Vec<u8> = (0..w * h).flat_map(|i| ((i.wrapping_mul(2654435761u32) >> 16) as u16).to_le_bytes()).collect();
    let r32: Vec<u8> = (0..w * h).flat_map(|i| ((i as f32 * 0.37).sin() * 120.0).to_le_bytes()).collect();
    std::fs::write(dir.join("map.r16"), r16).unwrap();
    std::fs::write(dir.join("map.r32"), r32).unwrap();
    let options = LoadOptions { raw_size: Some((w, h)), ..Default::default() };
    for name in ["map.r16", "map.r32"] {
        assert!(windows_match_the_whole_file(&dir.join(name), &options) > 300);
    }
}

#[test]
fn images_without_random_access_read_by_window_as_whole() {
    assert!(windows_match_the_whole_file(&repo("data/cylinders.png"), &LoadOptions::default()) > 300);
}

#[test]
fn a_window_of_a_non_finite_sample_is_refused_by_place() {
    let dir = scratch("nan");
    let mut values = [1.0f32; 16];
    values[6] = f32::NAN;
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(dir.join("nan.r32"), bytes).unwrap();
    let mut source = HeightFile::open(&dir.join("nan.r32"), &LoadOptions::default()).unwrap();
    assert!(source.read_window((0, 0), (2, 2), None).is_ok());
    let e = source.read_window((1, 0), (2, 2), None).unwrap_err().to_string();
    assert!(e.contains("nan.r32") && e.contains("pixel (2, 1)"), "{e}");
}
