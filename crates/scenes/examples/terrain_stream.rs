//! A large terrain streamed by `hikage_runtime::horizon::TerrainStream`: the devkit's rough
//! terrain at 4096² (30 m texels: 123 km a side, 1.2 km of relief), baked here in 256² tiles
//! with every level of detail, seen from 5 km up under a low sun (2.5° up). The shadows of ridges
//! run for kilometres, far past where a game's cascaded shadow maps end. The table gives the
//! tiles drawn by level and what the stream holds.
//!
//! ```text
//! cargo run --release -p hikage-scenes --example terrain_stream -- scratch docs/images
//! ```

use hikage_runtime::glam::Vec3;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::horizon::{StreamOptions, Sun, TerrainFrame, TerrainStream};
use hikage_runtime::{DrawOptions, wgpu};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, Headless, VISIBILITY_FORMAT};

const N: u32 = 4096;
const TEXEL: f32 = 30.0;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (scratch, out) = hikage_scenes::example_paths("terrain_stream")?;
    std::fs::create_dir_all(&scratch)?;
    let heights: Vec<u8> = hikage_devkit::synth::terrain(N).into_iter().flat_map(f32::to_le_bytes).collect();
    std::fs::write(scratch.join("dem.r32"), heights)?;
    let pipeline = format!(
        r#"(output: "bundle", jobs: [Horizon(id: "dem", input: "dem.r32", texel_size: ({TEXEL}, {TEXEL}),
            height_scale: 1200, directions: 32, edge: Clamp, max_distance: 8000, ao: true, tile: 256, levels: 16)])"#
    );
    std::fs::write(scratch.join("pipeline.ron"), pipeline)?;
    println!("baking {N}² in 256² tiles with every level…");
    hikage_bake::run::run_pipeline(&scratch.join("pipeline.ron"), &Default::default())?;

    let g = Headless::new()?;
    println!("adapter: {}", g.describe());
    let options = DrawOptions {
        depth_format: Some(DEPTH_FORMAT),
        visibility_format: Some(VISIBILITY_FORMAT),
        ..DrawOptions::new(COLOR_FORMAT)
    };
    let mut terrain =
        TerrainStream::open(&g.device, &g.queue, &scratch.join("bundle"), "dem", &options, StreamOptions::default())?;
    let side = N as f32 * TEXEL;
    let (w, h) = (960u32, 400u32);
    let eye = Vec3::new(0.3 * side, 5000.0, 0.8 * side);
    let view_proj = directx::perspective(60f32.to_radians(), w as f32 / h as f32, 50.0, 1.5 * side)
        * look_at_mat4(eye, Vec3::new(0.45 * side, 0.0, 0.65 * side), Vec3::Y);
    // The sun 2.5° up, across the view from the right.
    let e = 2.5f32.to_radians();
    let sun = Sun {
        direction: Vec3::new(0.7 * e.cos(), e.sin(), 0.7 * e.cos()).normalize(),
        color: Vec3::new(1.0, 0.85, 0.7) * 2.2,
        angular_radius: 0.00465,
    };
    let frame = TerrainFrame {
        view_proj,
        sun,
        sky_color: Vec3::new(0.3, 0.4, 0.55),
        albedo: Vec3::new(0.45, 0.4, 0.32),
        ..TerrainFrame::default()
    };
    // Until every wanted tile is drawn, or the resident budget holds no more (2 s without an
    // upload).
    let mut stats = terrain.update(&g.device, &g.queue, &frame, eye)?;
    let mut idle = 0;
    while stats.missing > 0 && idle < 200 {
        std::thread::sleep(std::time::Duration::from_millis(10));
        stats = terrain.update(&g.device, &g.queue, &frame, eye)?;
        idle = if stats.uploaded_bytes > 0 { 0 } else { idle + 1 };
    }
    let f = g.render((w, h), wgpu::Color { r: 0.55, g: 0.65, b: 0.8, a: 1.0 }, |pass| terrain.draw(pass));
    let covered: Vec<&[f32; 4]> = f.visibility.iter().filter(|v| v[1] > 0.5).collect();
    let shadow = covered.iter().map(|v| 1.0 - v[0]).sum::<f32>() / covered.len().max(1) as f32;
    let mut levels = [0usize; 8];
    for ((level, _, _), _) in terrain.drawn() {
        levels[(level as usize).min(7)] += 1;
    }
    println!("| tiles drawn | by level (0, 1, 2, …) | resident | terrain in shadow |");
    println!("|---|---|---|---|");
    println!(
        "| {} | {:?} | {:.1} MiB | {:.1}% |",
        stats.drawn,
        &levels[..],
        stats.resident_bytes as f64 / (1 << 20) as f64,
        100.0 * shadow
    );
    let image = image::RgbaImage::from_raw(w, h, f.color).ok_or("read-back size")?;
    let path = out.join("terrain_stream.png");
    hikage_scenes::png::save(&image, &path)?;
    println!("wrote {}", path.display());
    Ok(())
}
