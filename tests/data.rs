//! The committed sample data is what the committed generators make (data/README.md).

use hikage_bake::heightfield::{LoadOptions, load_samples};
use hikage_devkit::synth;

use crate::util::repo;

fn check(file: &str, n: u32, generated: Vec<f32>, quantize: impl Fn(f32) -> f32) {
    let s = load_samples(&repo().join("data").join(file), &LoadOptions::default()).unwrap();
    assert_eq!((s.width, s.height), (n, n), "{file}");
    let expected: Vec<f32> = generated.into_iter().map(quantize).collect();
    let differ = s.values.iter().zip(&expected).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{file}: {differ} samples differ from the generator; rerun the make_data example");
}

#[test]
fn committed_samples_match_their_generators() {
    let q16 = |x: f32| (x * 65535.0).round() / 65535.0;
    let q8 = |x: f32| (x * 255.0).round() / 255.0;
    let f16 = |x: f32| half::f16::from_f32(x).to_f32();
    check("cylinders.png", 128, synth::cylinder_bumps(128), q16);
    check("reptile.png", 256, synth::reptile_cells(256), q16);
    check("dunes.exr", 256, synth::dune_ripples(256), f16);
    check("terrain.png", 512, synth::terrain(512), q16);
    check("relief_fbm.png", 256, synth::fbm_relief(256), q16);
    check("relief_bricks.png", 256, synth::bricks(256), q8);
    check("relief_spikes.png", 256, synth::spikes_and_walls(256), q8);
    let sphere = std::fs::read_to_string(repo().join("data/sphere.obj")).unwrap();
    assert!(sphere == synth::uv_sphere_obj(1.0 / 0.015, 48, 24, 3.0), "sphere.obj differs from its generator");
    let torus = std::fs::read(repo().join("data/torus.glb")).unwrap();
    assert!(torus == synth::torus_glb(100.0, 40.0, 64, 32, (4.0, 1.0)), "torus.glb differs from its generator");
}

#[test]
fn data_stays_small() {
    let total: u64 =
        std::fs::read_dir(repo().join("data")).unwrap().map(|e| e.unwrap().metadata().unwrap().len()).sum();
    assert!(total < 4 << 20, "data/ is {total} bytes, above 4 MiB");
}

#[test]
fn hair_sample_is_a_valid_hair_file_of_the_papers_size() {
    let bytes = std::fs::read(repo().join("data/head.hair")).unwrap();
    // Header fields read by offset, as the format's documentation lays them out.
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    assert_eq!(&bytes[0..4], b"HAIR");
    assert_eq!(u32_at(4), 10_000, "strands");
    assert_eq!(u32_at(8), 220_000, "points");
    assert_eq!(u32_at(12), 2, "flags: points array only");
    assert_eq!(u32_at(16), 21, "default segments per strand");
    assert!((f32_at(24) - (1.0 - 0.366)).abs() < 1e-6, "default transparency");
    assert_eq!(bytes.len(), 128 + 220_000 * 12);
    // Every point finite and outside the head; strands leave the scalp and hang down.
    let point = |i: usize| [0, 1, 2].map(|c| f32_at(128 + i * 12 + c * 4));
    for i in 0..220_000 {
        let p = point(i);
        assert!(p.iter().all(|c| c.is_finite()));
        let e = (p[0] / 8.0).powi(2) + (p[1] / 10.5).powi(2) + (p[2] / 9.5).powi(2);
        assert!(e >= 0.99, "point {i} inside the head");
    }
    let (root, tip) = (point(0), point(21));
    assert!(tip[1] < root[1], "gravity pulls the tip below the root");
    // And it is what the committed generator writes.
    let mut hair = synth::hair(10_000, 22, 7);
    hair.thickness = None;
    hair.transparency = None;
    let info = "hikage synth::hair(10000, 22, seed 7), cm; head ellipsoid 8 x 10.5 x 9.5";
    assert!(bytes == hikage_bake::strands::cyhair::encode(&hair, info), "head.hair differs from its generator");
}
