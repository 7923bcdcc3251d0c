//! Seed 000 Fig. 4/5, headless: spheres of curvature κ = 0.015 and κ = 0.005 carrying the
//! cylinder bump map (128², 32 directions), shadowed with the flat horizon test (left) and the
//! curvature-corrected one (right). Writes PNGs and prints the shadowed share of each.
//!
//! ```text
//! cargo run --release -- bake                      # makes bundle/ with cylinders.horizon
//! cargo run --release -p hikage-scenes --example horizon_sphere -- bundle docs/images
//! ```

use std::path::PathBuf;

use hikage_runtime::glam::Vec3;
use hikage_runtime::{CpuBundle, GpuBundle};
use hikage_scenes::headless::Headless;
use hikage_scenes::horizon_sphere::{SphereScene, render, shadowed_fraction};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let bundle = PathBuf::from(args.next().unwrap_or_else(|| "bundle".into()));
    let out = PathBuf::from(args.next().unwrap_or_else(|| "target/horizon_sphere".into()));
    std::fs::create_dir_all(&out)?;

    let cpu = CpuBundle::read(&bundle)?;
    let gpu = Headless::new()?;
    println!("adapter: {}", gpu.describe());
    let gb = GpuBundle::upload(&gpu.device, &gpu.queue, &cpu)?;
    let horizon = &gb.textures.get("cylinders.horizon").ok_or("bundle has no cylinders.horizon")?;
    let heights = &gb.textures.get("cylinders.height").ok_or("bundle has no cylinders.height")?;
    let hf = match &cpu.asset("cylinders.height").ok_or("no cylinders.height")?.asset.settings {
        hikage_bundle::Settings::Heightfield(h) => h.clone(),
        _ => return Err("cylinders.height is not a heightfield".into()),
    };
    let tile_world = hf.texel_size.0 * heights.desc.width as f32;

    let size = 384u32;
    println!("| κ | flat test: shadowed | corrected: shadowed | difference |");
    println!("|---|---|---|---|");
    for kappa in [0.015f32, 0.005] {
        let mut image = image::RgbaImage::new(size * 2, size);
        let mut shares = Vec::new();
        for (i, corrected) in [false, true].into_iter().enumerate() {
            let scene = SphereScene {
                light: Vec3::new(-0.8, 0.25, 0.45).normalize(),
                sphere_kappa: kappa,
                corrected,
                tile_world,
                height_scale: hf.height_scale,
                size,
            };
            let (rgba, flags) = render(&gpu, &scene, &horizon.view, &heights.view);
            shares.push(shadowed_fraction(&flags));
            let half = image::RgbaImage::from_raw(size, size, rgba).ok_or("readback size")?;
            image::imageops::replace(&mut image, &half, (i as u32 * size) as i64, 0);
        }
        let file = out.join(format!("horizon_sphere_k{kappa}.png"));
        image.save(&file)?;
        println!(
            "| {kappa} | {:.1}% | {:.1}% | {:.1} points ({}) |",
            shares[0] * 100.0,
            shares[1] * 100.0,
            (shares[0] - shares[1]) * 100.0,
            file.display()
        );
    }
    Ok(())
}
