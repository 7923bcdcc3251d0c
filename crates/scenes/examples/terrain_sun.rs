//! Horizon maps on terrain, the way games use them most: `data/terrain.png` (512², 80 m × 60 m
//! texels, 0–1500 m) drawn as a grid by `hikage_runtime::horizon::TerrainShadows`, under a sun
//! crossing the sky from sunrise to sunset, with the soft shadow edge of the sun's disc and the
//! baked ambient occlusion. Writes the frames as one strip and prints the shadowed share of the
//! terrain in each.
//!
//! ```text
//! cargo run --release -- bake
//! cargo run --release -p hikage-scenes --example terrain_sun -- bundle docs/images
//! ```

use hikage_runtime::glam::Vec3;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::horizon::{Sun, TerrainFrame, TerrainShadows};
use hikage_runtime::{DrawOptions, wgpu};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, VISIBILITY_FORMAT};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (bundle, out) = hikage_scenes::example_paths("terrain_sun")?;
    // Only the terrain's assets are read and uploaded.
    let (_, g, gpu) = hikage_scenes::open_bundle(&bundle, &["terrain.horizon", "terrain.ao"])?;
    let options = DrawOptions {
        depth_format: Some(DEPTH_FORMAT),
        visibility_format: Some(VISIBILITY_FORMAT),
        ..DrawOptions::new(COLOR_FORMAT)
    };
    let terrain = TerrainShadows::new(&g.device, &g.queue, &gpu, "terrain.horizon", Some("terrain.ao"), &options)?;

    // The terrain spans 40.96 km (x, +u) by 30.72 km (z, +v); the camera looks north over its
    // southern half from 4 km up.
    let (w, h) = (384u32, 256u32);
    let view_proj = directx::perspective(55f32.to_radians(), w as f32 / h as f32, 200.0, 90_000.0)
        * look_at_mat4(Vec3::new(20_000.0, 4_000.0, 33_000.0), Vec3::new(20_500.0, 0.0, 16_000.0), Vec3::Y);
    // North is −z: the sun rises in the east (+x), stands in the south (+z) at noon, sets in the
    // west, 55° up at noon.
    let hours = [6.3, 6.8, 7.6, 9.5, 14.5, 16.4, 17.2, 17.7];
    let mut strip = image::RgbaImage::new(w * 4, h * 2);
    println!("| local time | sun elevation | terrain in shadow | mean sky visibility |");
    println!("|---|---|---|---|");
    for (k, hour) in hours.into_iter().enumerate() {
        let t = (hour - 6.0) / 12.0 * std::f32::consts::PI;
        let elevation = 55f32.to_radians() * t.sin() + 1f32.to_radians();
        let across = Vec3::new(t.cos(), 0.0, t.sin() * 0.6).normalize();
        let direction = (across * elevation.cos() + Vec3::Y * elevation.sin()).normalize();
        let sun = Sun { direction, color: Vec3::new(1.0, 0.92, 0.8) * 1.7, angular_radius: 0.00465 };
        let frame = TerrainFrame {
            view_proj,
            sun,
            sky_color: Vec3::new(0.35, 0.45, 0.6),
            albedo: Vec3::new(0.42, 0.38, 0.3),
            ..TerrainFrame::default()
        };
        terrain.update(&g.queue, &frame);
        let f = g.render((w, h), wgpu::Color { r: 0.5, g: 0.62, b: 0.8, a: 1.0 }, |pass| terrain.draw(pass));
        let covered: Vec<&[f32; 4]> = f.visibility.iter().filter(|v| v[1] > 0.5).collect();
        let shadow = covered.iter().map(|v| 1.0 - v[0]).sum::<f32>() / covered.len().max(1) as f32;
        let sky = covered.iter().map(|v| v[2]).sum::<f32>() / covered.len().max(1) as f32;
        println!(
            "| {:02}:{:02} | {:.1}° | {:.1}% | {:.3} |",
            hour as u32,
            ((hour.fract()) * 60.0) as u32,
            elevation.to_degrees(),
            100.0 * shadow,
            sky
        );
        let tile = image::RgbaImage::from_raw(w, h, f.color).ok_or("read-back size")?;
        image::imageops::replace(&mut strip, &tile, ((k % 4) as u32 * w) as i64, ((k / 4) as u32 * h) as i64);
    }
    let path = out.join("terrain_sun.png");
    hikage_scenes::png::save(&strip, &path)?;
    println!("wrote {}", path.display());
    Ok(())
}
