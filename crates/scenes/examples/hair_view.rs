//! Hair in the camera view, through `hikage_runtime::hair::HairRenderer`: four layouts — the
//! sample head (10,000 strands of 0.016 cm), the same at the seed's 0.16 cm, a denser head
//! (40,000) and curly strands (10,000 ringlets of 48 points) — drawn at 512² over black, each against the same renderer at 8× the
//! size box-filtered down (the reference). Prints, for strips at their own width (`before`) and
//! widened to at least 1 pixel with their opacity lowered to keep the coverage (`after`): RMS
//! and largest difference, noise (mean absolute Laplacian) as a ratio to the reference's, the
//! share of pixels changing by more than 0.1 under a 1° orbit, and the frame time. Then the
//! blend against an exact sorted composite on the CPU, the levels of detail (coverage kept,
//! difference, frame time), and writes `hair_view.png`: before, after and the reference on the
//! curly layout, then its levels of detail 0–3.
//!
//! ```text
//! cargo run --release -p hikage-scenes --example hair_view -- target/hair_view docs/images
//! ```

use std::path::Path;
use std::time::Instant;

use hikage_runtime::glam::Vec3;
use hikage_runtime::hair::reference::StripArrays;
use hikage_runtime::hair::{BlendWeight, HairFrame, HairLod, HairRenderer, Lod};
use hikage_runtime::{CpuBundle, GpuBundle};
use hikage_scenes::hair_scene::{Composite, camera_reference, read_opacity_maps};
use hikage_scenes::hair_view::{
    Image, difference, flicker, hair_mask, mean_luminance, noise, orbit_camera, render_view, renderer, renderers,
};
use hikage_scenes::headless::Headless;

const SIZE: u32 = 512;
const FACTOR: u32 = 8;
const MAPS: u32 = 256;
const PICTURE: u32 = 256;

/// The layouts, baked into `dir/bundle`.
fn bake_layouts(dir: &Path) -> Result<(), Box<dyn std::error::Error>> {
    std::fs::create_dir_all(dir)?;
    let write = |name: &str, s: &hikage_bake::strands::Strands| {
        std::fs::write(dir.join(name), hikage_bake::strands::cyhair::encode(s, name))
    };
    write("dense.hair", &hikage_devkit::synth::hair(40_000, 22, 21))?;
    write("curly.hair", &hikage_devkit::synth::curly(10_000, 48, 5))?;
    let head = std::fs::canonicalize("data/head.hair")?;
    let pipeline = format!(
        r#"(output: "bundle", jobs: [
            Strands(id: "head", input: "{0}"),
            Strands(id: "head_paper", input: "{0}", shading_width: Some(0.16)),
            Strands(id: "dense", input: "dense.hair"),
            Strands(id: "curly", input: "curly.hair"),
        ])"#,
        head.display()
    );
    std::fs::write(dir.join("pipeline.ron"), pipeline)?;
    hikage_bake::run::run_pipeline(&dir.join("pipeline.ron"), &Default::default())?;
    Ok(())
}

fn frame(renderer: &HairRenderer, degrees: f32, min_pixel_width: f32, level: u32) -> HairFrame {
    let s = renderer.settings();
    let (lo, hi) = (Vec3::from(s.bounds_min), Vec3::from(s.bounds_max));
    let (camera, eye) = orbit_camera(lo, hi, degrees);
    let lod = HairLod { camera: Lod::Level(level), light: Lod::Level(0) };
    HairFrame { min_pixel_width, lod, ..HairFrame::new(camera, eye, renderer.light(Vec3::new(0.45, 1.0, 0.3))) }
}

/// Best of three frame times (opacity maps, hair, composite) at 1×.
fn frame_time(g: &Headless, renderer: &HairRenderer, frame: &HairFrame) -> f64 {
    (0..3)
        .map(|_| {
            let t = Instant::now();
            render_view(g, renderer, frame, SIZE, 1);
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// The shading strips' median width in pixels at the 1× view.
fn strip_pixels(renderer: &HairRenderer, frame: &HairFrame, strips: &StripArrays) -> f32 {
    use hikage_runtime::hair::reference::{across, hair_point, pixel_width};
    let u = renderer.uniform(frame);
    let eye = Vec3::from_slice(&u.eye);
    let mut widths: Vec<f32> = strips
        .points
        .iter()
        .step_by(7)
        .map(|p| {
            let p = hair_point(&u, p, false, 1.0);
            pixel_width(&u, p.position, across(p.tangent, (eye - p.position).normalize()), p.width)
        })
        .collect();
    widths.sort_by(f32::total_cmp);
    widths[widths.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let work = std::path::PathBuf::from(args.next().unwrap_or_else(|| "target/hair_view".into()));
    let out = std::path::PathBuf::from(args.next().unwrap_or_else(|| "target/hair_view".into()));
    std::fs::create_dir_all(&out)?;
    bake_layouts(&work)?;
    let cpu = CpuBundle::read(&work.join("bundle"))?;
    let g = Headless::new()?;
    println!("adapter: {}", g.describe());
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu)?;
    let layouts = [
        ("sample head", "head.strips"),
        ("head at the seed's widths", "head_paper.strips"),
        ("denser head", "dense.strips"),
        ("curly strands", "curly.strips"),
    ];

    println!(
        "\nCamera view at {SIZE}² against the same renderer at {FACTOR}× box-filtered ({MAPS}² opacity maps; errors in sRGB over the pixels with hair)\n"
    );
    println!(
        "| layout | strips on screen | strips drawn | RMS / max | noise ÷ reference's | pixels changing > 0.1 under 1° (reference) | frame time |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (name, id) in layouts {
        let (one, eight) = renderers(&g, &gb, id, SIZE, FACTOR, MAPS)?;
        let asset = cpu.asset(id).ok_or("missing strands")?;
        let strips = StripArrays::from_mesh(asset.mesh().ok_or("not a mesh")?, one.settings()).ok_or("not strands")?;
        let reference = [0.0, 1.0].map(|deg| render_view(&g, &eight, &frame(&eight, deg, 0.0, 0), SIZE, FACTOR));
        let mask = hair_mask(&reference[0], &reference[0]);
        let ref_noise = noise(&reference[0], SIZE, &mask);
        let ref_flicker = flicker(&reference[0], &reference[1], &mask);
        let mut times = Vec::new();
        for (label, min_width) in [("own width (before)", 0.0), ("≥ 1 px, opacity compensated (after)", 1.0)] {
            let f0 = frame(&one, 0.0, min_width, 0);
            let views: [Image; 2] =
                [0.0, 1.0].map(|deg| render_view(&g, &one, &frame(&one, deg, min_width, 0), SIZE, 1));
            let mask = hair_mask(&views[0], &reference[0]);
            let (rms, max) = difference(&views[0], &reference[0], &mask);
            let time = frame_time(&g, &one, &f0);
            times.push(time);
            println!(
                "| {name} | {:.3} px | {label} | {rms:.3} / {max:.2} | {:.2}× | {:.1}% ({:.1}%) | {:.0} ms{} |",
                strip_pixels(&one, &f0, &strips),
                noise(&views[0], SIZE, &mask) / ref_noise,
                100.0 * flicker(&views[0], &views[1], &mask),
                100.0 * ref_flicker,
                1000.0 * time,
                if times.len() == 2 { format!(" ({:.2}× before)", times[1] / times[0]) } else { String::new() },
            );
        }
    }
    println!(
        "\nThe blend against the sorted composite (CPU, same fragments and opacity maps), {SIZE}², strips ≥ 1 px\n"
    );
    println!(
        "| layout | weighted by the camera layers (GPU, default) RMS | weighted by depth (GPU) RMS | one weight for all (CPU) RMS | mean luminance: sorted / layers / depth | frame time: layers / depth |"
    );
    println!("|---|---|---|---|---|---|");
    for (name, id) in layouts {
        let (one, _) = renderers(&g, &gb, id, SIZE, 1, MAPS)?;
        let by_depth = renderer(&g, &gb, id, SIZE, MAPS, BlendWeight::Depth)?;
        let asset = cpu.asset(id).ok_or("missing strands")?;
        let strips = StripArrays::from_mesh(asset.mesh().ok_or("not a mesh")?, one.settings()).ok_or("not strands")?;
        let f = frame(&one, 0.0, 1.0, 0);
        let gpu = render_view(&g, &one, &f, SIZE, 1);
        let gpu_depth = render_view(&g, &by_depth, &f, SIZE, 1);
        let maps = read_opacity_maps(&g, &one);
        let u = one.uniform(&f);
        let points = strips.points_of_level(0);
        let encode = |c: f32| {
            let c = c.clamp(0.0, 1.0);
            if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
        };
        let to_image =
            |v: &[[f32; 4]]| -> Image { v.iter().map(|p| [encode(p[0]), encode(p[1]), encode(p[2])]).collect() };
        let sorted =
            to_image(&camera_reference(&strips, &u, &f.light, &maps, ((SIZE, SIZE), points), Composite::Sorted));
        // The first blend's weight reached its cap for every fragment: the same as one weight for all.
        let flat_u = hikage_runtime::hair::HairUniform { oit_falloff: 0.0, ..u };
        let flat = to_image(&camera_reference(
            &strips,
            &flat_u,
            &f.light,
            &maps,
            ((SIZE, SIZE), points),
            Composite::DepthWeighted,
        ));
        let mask = hair_mask(&sorted, &gpu);
        let (time_layers, time_depth) = (frame_time(&g, &one, &f), frame_time(&g, &by_depth, &f));
        println!(
            "| {name} | {:.4} | {:.4} | {:.4} | {:.3} / {:.3} / {:.3} | {:.0} / {:.0} ms ({:.2}×) |",
            difference(&gpu, &sorted, &mask).0,
            difference(&gpu_depth, &sorted, &mask).0,
            difference(&flat, &sorted, &mask).0,
            mean_luminance(&sorted),
            mean_luminance(&gpu),
            mean_luminance(&gpu_depth),
            1000.0 * time_layers,
            1000.0 * time_depth,
            time_layers / time_depth,
        );
    }

    println!("\nLevels of detail at {SIZE}² (strips ≥ 1 px; level l draws ~1/2^l of the strands, each 2^l× wider)\n");
    println!(
        "| layout | level | strands | coverage × brightness vs level 0 | RMS vs reference | frame time | auto picks |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (name, id) in layouts {
        let (one, eight) = renderers(&g, &gb, id, SIZE, FACTOR, MAPS)?;
        let reference = render_view(&g, &eight, &frame(&eight, 0.0, 0.0, 0), SIZE, FACTOR);
        let auto = one.chosen_levels(&HairFrame { lod: HairLod::default(), ..frame(&one, 0.0, 1.0, 0) }).0;
        let base = mean_luminance(&render_view(&g, &one, &frame(&one, 0.0, 1.0, 0), SIZE, 1));
        for (level, l) in one.levels().iter().enumerate().take(5) {
            let f = frame(&one, 0.0, 1.0, level as u32);
            let view = render_view(&g, &one, &f, SIZE, 1);
            let mask = hair_mask(&view, &reference);
            println!(
                "| {name} | {level} | {} | {:+.1}% | {:.3} | {:.0} ms | {} |",
                l[0],
                100.0 * (mean_luminance(&view) / base - 1.0),
                difference(&view, &reference, &mask).0,
                1000.0 * frame_time(&g, &one, &f),
                if auto == level as u32 { "←" } else { "" }
            );
        }
    }

    // The picture: the curly layout before, after, reference; then levels 0–3.
    let (one, eight) = renderers(&g, &gb, "curly.strips", PICTURE, FACTOR, MAPS)?;
    let mut tiles = vec![
        render_view(&g, &one, &frame(&one, 0.0, 0.0, 0), PICTURE, 1),
        render_view(&g, &one, &frame(&one, 0.0, 1.0, 0), PICTURE, 1),
        render_view(&g, &eight, &frame(&eight, 0.0, 0.0, 0), PICTURE, FACTOR),
    ];
    for level in 0..4 {
        tiles.push(render_view(&g, &one, &frame(&one, 0.0, 1.0, level), PICTURE, 1));
    }
    let mut image = image::RgbaImage::from_pixel(4 * PICTURE, 2 * PICTURE, image::Rgba([0, 0, 0, 255]));
    for (k, tile) in tiles.iter().enumerate() {
        let (col, row) = if k < 3 { (k as u32, 0) } else { (k as u32 - 3, 1) };
        for (i, p) in tile.iter().enumerate() {
            let px = p.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
            let (x, y) = (col * PICTURE + i as u32 % PICTURE, row * PICTURE + i as u32 / PICTURE);
            image.put_pixel(x, y, image::Rgba([px[0], px[1], px[2], 255]));
        }
    }
    let path = out.join("hair_view.png");
    hikage_scenes::png::save(&image, &path)?;
    println!("\nwrote {}", path.display());
    Ok(())
}
