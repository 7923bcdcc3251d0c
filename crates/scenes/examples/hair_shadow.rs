//! Seed 004, headless: the sample head (10,000 strands) above a ground plane under one light,
//! with deep opacity maps of 256² built from (a) the shading set itself (plain deep opacity
//! maps), (b) the seed's wide faint opacity set, (c) the opacity set `--auto` chose. Writes the
//! three views and the ground's shadow seen from above as PNGs, and prints the aliasing of each
//! ground shadow (high-frequency energy; lower is smoother) and its mean darkness.
//!
//! ```text
//! cargo run --release -- bake      # makes bundle/ with head.strips and head_auto.strips
//! cargo run --release -p hikage-scenes --example hair_shadow -- bundle docs/images
//! ```

use std::path::PathBuf;

use hikage_bundle::Settings;
use hikage_runtime::glam::Vec3;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::{look_at_mat4, look_to_mat4};
use hikage_runtime::hair::{HairLight, HairSet};
use hikage_runtime::{CpuBundle, GpuBundle};
use hikage_scenes::hair_scene::{GpuStrips, high_frequency_energy, render_opacity_maps, render_scene};
use hikage_scenes::headless::Headless;

const RESOLUTION: u32 = 256;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let bundle = PathBuf::from(args.next().unwrap_or_else(|| "bundle".into()));
    let out = PathBuf::from(args.next().unwrap_or_else(|| "target/hair_shadow".into()));
    std::fs::create_dir_all(&out)?;
    let cpu = CpuBundle::read(&bundle)?;
    let gpu = Headless::new()?;
    println!("adapter: {}", gpu.describe());
    let gb = GpuBundle::upload(&gpu.device, &gpu.queue, &cpu)?;
    let strips_of = |id: &str| -> Result<(GpuStrips<'_>, hikage_bundle::StrandsSettings), String> {
        let m = gb.meshes.get(id).ok_or(format!("bundle has no {id}"))?;
        let s = match &m.asset.settings {
            Settings::Strands(s) => s.clone(),
            _ => return Err(format!("{id} is not a strands asset")),
        };
        Ok((GpuStrips { buffer: &m.buffer, desc: &m.desc }, s))
    };
    let (paper, settings) = strips_of("head.strips")?;
    let (auto, auto_settings) = strips_of("head_auto.strips")?;
    let (lo, hi) = (Vec3::from(settings.bounds_min), Vec3::from(settings.bounds_max));
    let to_light = Vec3::new(0.45, 1.0, 0.3).normalize();
    let light = HairLight::for_bounds(lo, hi, to_light);
    // The ground 3 cm below the hair; its shadow lies away from the light.
    let y = lo.y - 3.0;
    let centre = Vec3::new(0.0, y, 0.0) - Vec3::new(to_light.x, 0.0, to_light.z) * ((hi.y - y) * 0.5 / to_light.y);
    let half = 45.0;
    let ground = [
        centre + Vec3::new(-half, 0.0, -half),
        centre + Vec3::new(half, 0.0, -half),
        centre + Vec3::new(half, 0.0, half),
        centre + Vec3::new(-half, 0.0, half),
    ];
    let eye = Vec3::new(-55.0, 35.0, 75.0);
    let camera = directx::perspective(45f32.to_radians(), 4.0 / 3.0, 1.0, 400.0)
        * look_at_mat4(eye, centre + Vec3::new(0.0, 18.0, 0.0), Vec3::Y);
    let top = directx::orthographic(-half, half, -half, half, 0.0, 200.0)
        * look_to_mat4(centre + Vec3::new(0.0, 100.0, 0.0), Vec3::NEG_Y, Vec3::NEG_Z);
    let variants = [
        ("(a) shading set in the opacity maps (plain DOM)", &paper, HairSet::Shading, settings.shading),
        ("(b) the seed's opacity set", &paper, HairSet::Opacity, settings.opacity),
        ("(c) auto opacity set", &auto, HairSet::Opacity, auto_settings.opacity),
    ];
    let (w, h) = (320u32, 240u32);
    let g = 256u32;
    let mut image = image::RgbaImage::new(3 * w, h + g);
    println!(
        "| opacity maps ({RESOLUTION}²) | width × opacity | ground shadow: high-frequency energy | mean darkness in shadow |"
    );
    println!("|---|---|---|---|");
    for (k, (name, strips, set, (width, alpha))) in variants.into_iter().enumerate() {
        let maps = render_opacity_maps(&gpu, strips, &light, set, RESOLUTION)?;
        // The camera always draws the thin shading set.
        let (rgba, vis) = render_scene(&gpu, &paper, &maps, &light, (camera, eye), ground, top, ((w, h), (g, g)))?;
        let hf = high_frequency_energy(&vis, (g, g));
        let shadowed: Vec<f32> = vis.iter().copied().filter(|&v| v < 0.98).collect();
        let dark = shadowed.iter().map(|v| 1.0 - v).sum::<f32>() / shadowed.len().max(1) as f32;
        println!("| {name} | {width:.3} × {alpha:.4} | {hf:.4} | {dark:.3} |");
        for (i, c) in rgba.chunks_exact(4).enumerate() {
            image.put_pixel(k as u32 * w + i as u32 % w, i as u32 / w, image::Rgba([c[0], c[1], c[2], 255]));
        }
        for (i, &v) in vis.iter().enumerate() {
            let c = (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0) as u8;
            image.put_pixel(k as u32 * w + (w - g) / 2 + i as u32 % g, h + i as u32 / g, image::Rgba([c, c, c, 255]));
        }
    }
    let path = out.join("hair_shadow.png");
    hikage_scenes::png::save(&image, &path)?;
    println!("wrote {}", path.display());
    Ok(())
}
