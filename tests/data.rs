//! The committed sample data is what the committed generators make (data/README.md).

use hikage_bake::heightfield::{LoadOptions, load_samples};
use hikage_bake::synth;

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
}

#[test]
fn data_stays_small() {
    let total: u64 =
        std::fs::read_dir(repo().join("data")).unwrap().map(|e| e.unwrap().metadata().unwrap().len()).sum();
    assert!(total < 4 << 20, "data/ is {total} bytes, above 4 MiB");
}
