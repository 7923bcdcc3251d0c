//! Seed 003, headless: the three relief families of `data/` as a quad seen at a grazing angle,
//! traced on the GPU with (a) linear + binary search, (b) the seed's depth-map start and
//! (d) depth-map start + max-mip traversal, shaded with depth-map shadows and ambient occlusion;
//! under each, a heat map of height-map reads per pixel (the seed's Fig. 9). Writes one PNG per
//! family and prints the mean reads per pixel.
//!
//! ```text
//! cargo run --release -- bake                      # makes bundle/ with relief_*.relief
//! cargo run --release -p hikage-scenes --example relief_plane -- bundle docs/images
//! ```

use hikage_runtime::glam::Vec3;
use hikage_runtime::relief::Tracer;
use hikage_runtime::relief::reference::ReliefMaps;
use hikage_scenes::relief_plane::{PlaneView, render};

/// Blue → green → yellow → red over `[0, 1]`.
fn heat(t: f32) -> [u8; 4] {
    let stops = [[30.0, 40.0, 140.0], [40.0, 170.0, 90.0], [240.0, 220.0, 50.0], [220.0, 40.0, 30.0]];
    let x = t.clamp(0.0, 1.0) * 3.0;
    let i = (x.floor() as usize).min(2);
    let f = x - i as f32;
    let c = |k: usize| (stops[i][k] * (1.0 - f) + stops[i + 1][k] * f) as u8;
    [c(0), c(1), c(2), 255]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (bundle, out) = hikage_scenes::example_paths("relief_plane")?;
    let families = ["relief_fbm.relief", "relief_bricks.relief", "relief_spikes.relief"];
    let (cpu, gpu, gb) = hikage_scenes::open_bundle(&bundle, &families)?;
    let (w, h) = (256u32, 176u32);
    let view = PlaneView {
        eye: Vec3::new(128.0, -12.0, 62.0),
        target: Vec3::new(128.0, 110.0, 0.0),
        fov_y_degrees: 50.0,
        width: w,
        height: h,
        light: Vec3::new(-0.55, 0.3, 0.6).normalize(),
        shadows: true,
        ao_stride: 8,
    };
    // The cheapest settings meeting the accuracy bar on these maps (docs/relief.md, the relief benchmark).
    let tracers = [
        Tracer::Linear { steps: 256, binary: 6 },
        Tracer::DepthMap { steps: 128, binary: 6 },
        Tracer::Combined { margin: 0.1, start_level: 3 },
    ];
    println!("| family | tracer | mean height reads per pixel | mean depth-map reads |");
    println!("|---|---|---|---|");
    for family in ["fbm", "bricks", "spikes"] {
        let id = format!("relief_{family}");
        let maps = ReliefMaps::from_bundle(&cpu, &format!("{id}.relief"))?;
        let mv = &gb.textures.get(&format!("{id}.maxmip")).ok_or("no max-mip texture")?.view;
        let dv = &gb.textures.get(&format!("{id}.relief")).ok_or("no relief texture")?.view;
        let mut image = image::RgbaImage::new(w * tracers.len() as u32, h * 2);
        let renders: Vec<_> = tracers.iter().map(|&t| render(&gpu, &maps, t, &view, mv, dv)).collect();
        let most = renders.iter().flat_map(|(_, p)| p.iter().map(|p| p.height_reads)).max().unwrap_or(1).max(1);
        for (k, (tracer, (rgba, pixels))) in tracers.iter().zip(&renders).enumerate() {
            let quad: Vec<_> = pixels.iter().filter(|p| p.on_quad).collect();
            let mean = |f: fn(&&_) -> u32| quad.iter().map(f).sum::<u32>() as f64 / quad.len().max(1) as f64;
            println!(
                "| {family} | {} | {:.1} | {:.1} |",
                tracer.name(),
                mean(|p: &&hikage_scenes::relief_plane::PixelData| p.height_reads),
                mean(|p: &&hikage_scenes::relief_plane::PixelData| p.depth_reads)
            );
            for (i, (px, c)) in pixels.iter().zip(rgba.chunks_exact(4)).enumerate() {
                let (x, y) = (k as u32 * w + i as u32 % w, i as u32 / w);
                image.put_pixel(x, y, image::Rgba([c[0], c[1], c[2], 255]));
                let hc = if px.on_quad { heat(px.height_reads as f32 / most as f32) } else { [0, 0, 0, 255] };
                image.put_pixel(x, y + h, image::Rgba(hc));
            }
        }
        let path = out.join(format!("relief_{family}.png"));
        hikage_scenes::png::save(&image, &path)?;
        println!("wrote {} (reads scale 0–{most})", path.display());
    }
    Ok(())
}
