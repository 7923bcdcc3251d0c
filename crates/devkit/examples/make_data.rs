//! Regenerates the sample heightfields in `data/` from the generators in
//! `hikage_devkit::synth`. Run from the repository root:
//!
//! ```text
//! cargo run --release -p hikage-devkit --example make_data
//! ```
//!
//! The outputs are deterministic; `tests/` checks that the committed files still decode to what
//! the generators produce.

use std::path::Path;

use exr::prelude::{
    AnyChannel, AnyChannels, Compression, Encoding, FlatSamples, Image, LayerAttributes, SmallVec, WritableImage,
};
use hikage_devkit::synth;

fn png16(path: &Path, n: u32, v: &[f32]) {
    let px: Vec<u16> = v.iter().map(|x| (x.clamp(0.0, 1.0) * 65535.0).round() as u16).collect();
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(n, n, px).unwrap().save(path).unwrap();
}

fn png8(path: &Path, n: u32, v: &[f32]) {
    let px: Vec<u8> = v.iter().map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8).collect();
    image::ImageBuffer::<image::Luma<u8>, _>::from_raw(n, n, px).unwrap().save(path).unwrap();
}

fn exr_f16(path: &Path, n: u32, v: &[f32]) {
    let samples = v.iter().map(|&x| half::f16::from_f32(x)).collect();
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    channels.push(AnyChannel::new("Y", FlatSamples::F16(samples)));
    let encoding = Encoding { compression: Compression::ZIP16, ..Encoding::FAST_LOSSLESS };
    let image = Image::from_layer(exr::prelude::Layer::new(
        (n as usize, n as usize),
        LayerAttributes::default(),
        encoding,
        AnyChannels::sort(channels),
    ));
    image.write().non_parallel().to_file(path).unwrap();
}

fn main() {
    let data = Path::new("data");
    std::fs::create_dir_all(data).unwrap();
    png16(&data.join("cylinders.png"), 128, &synth::cylinder_bumps(128));
    png16(&data.join("reptile.png"), 256, &synth::reptile_cells(256));
    exr_f16(&data.join("dunes.exr"), 256, &synth::dune_ripples(256));
    png16(&data.join("terrain.png"), 512, &synth::terrain(512));
    png16(&data.join("relief_fbm.png"), 256, &synth::fbm_relief(256));
    png8(&data.join("relief_bricks.png"), 256, &synth::bricks(256));
    png8(&data.join("relief_spikes.png"), 256, &synth::spikes_and_walls(256));
    // Seed 000's sphere of curvature 0.015 (radius 66.7), three bump tiles around.
    std::fs::write(data.join("sphere.obj"), synth::uv_sphere_obj(1.0 / 0.015, 48, 24, 3.0)).unwrap();
    // A torus for κ1 ≠ κ2 (seed 000 eq. 1): tube curvature 1/40, ring curvature 1/140 outside.
    std::fs::write(data.join("torus.glb"), synth::torus_glb(100.0, 40.0, 64, 32, (4.0, 1.0))).unwrap();
    // Seed 004's hair: 10,000 strands × 22 points. Positions only: the per-strand width and
    // opacity arrays would add 1.8 MB and break data/'s 4 MiB budget; the header defaults are
    // the paper's shading set (width 0.016 cm here, opacity 0.366).
    let mut hair = synth::hair(10_000, 22, 7);
    hair.thickness = None;
    hair.transparency = None;
    let info = "hikage synth::hair(10000, 22, seed 7), cm; head ellipsoid 8 x 10.5 x 9.5";
    std::fs::write(data.join("head.hair"), hikage_bake::strands::cyhair::encode(&hair, info)).unwrap();
    println!("wrote the sample inputs to {}", data.display());
}
