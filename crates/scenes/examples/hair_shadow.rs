//! Seed 004, headless, through `hikage_runtime::hair::HairRenderer`: hair above a ground plane
//! under one light, with deep opacity maps of 256² built from (a) the shading set itself (plain
//! deep opacity maps), (a′) the same read through a 2×2 percentage-closer lookup, (b) the
//! seed's wide faint opacity set, (c) the opacity set `--auto` chose. Each ground shadow is
//! measured against a reference — the shading set's maps at 8× the resolution, the ground
//! rendered at 8× and box-filtered down — by RMS and largest error, error of mean darkness,
//! and its aliasing (high-frequency energy). Three layouts: the sample head (the file's
//! 0.016 cm strands), the same head at the seed's widths (0.16 and 1.40 cm), and straight combed
//! strands. Then the error the layer rule puts into the hair's own shadow, and the camera's
//! order-independent blend and the opaque draw against an exact, sorted CPU composite. Writes
//! the sample head's views and ground shadows as a PNG.
//!
//! ```text
//! cargo run --release -- bake      # makes bundle/ with head.strips and head_auto.strips
//! cargo run --release -p hikage-scenes --example hair_shadow -- bundle docs/images
//! ```

use std::path::{Path, PathBuf};
use std::time::Instant;

use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::{look_at_mat4, look_to_mat4};
use hikage_runtime::glam::{Mat4, Vec3};
use hikage_runtime::hair::reference::StripArrays;
use hikage_runtime::hair::{HairFrame, HairLight, HairLod, HairOptions, HairRenderer, HairSet, LayerRule, Lod, Lookup};
use hikage_runtime::{CpuBundle, GpuBundle, wgpu};
use hikage_scenes::hair_scene::{
    Composite, Ground, HairBlend, camera_reference, high_frequency_energy, layer_errors, read_opacity_maps,
    reference_shadow, render_frame, shadow_errors, srgb_to_linear,
};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, Headless};

const RESOLUTION: u32 = 256;
/// The reference's resolution, as a multiple of the test's.
const REFERENCE_FACTOR: u32 = 8;
const GROUND: u32 = 256;
/// Every strand, in both passes: the shadow figures are of the full hair.
const FULL: HairLod = HairLod { camera: Lod::Level(0), light: Lod::Level(0) };

/// The head at the seed's widths and the combed strands, baked into `dir/bundle` from
/// `data/head.hair` and strands generated here.
fn bake_layouts(dir: &Path) -> Result<PathBuf, Box<dyn std::error::Error>> {
    std::fs::create_dir_all(dir)?;
    let combed = hikage_devkit::synth::combed(10_000, 22, 11);
    std::fs::write(dir.join("combed.hair"), hikage_bake::strands::cyhair::encode(&combed, "combed strands"))?;
    let head = std::fs::canonicalize("data/head.hair")?;
    let pipeline = format!(
        r#"(output: "bundle", jobs: [
            Strands(id: "head_paper", input: "{head}", shading_width: Some(0.16)),
            Strands(id: "head_paper_auto", input: "{head}", shading_width: Some(0.16), auto: Some({RESOLUTION})),
            Strands(id: "combed", input: "combed.hair"),
            Strands(id: "combed_auto", input: "combed.hair", auto: Some({RESOLUTION})),
        ])"#,
        head = head.display()
    );
    std::fs::write(dir.join("pipeline.ron"), pipeline)?;
    hikage_bake::run::run_pipeline(&dir.join("pipeline.ron"), &Default::default())?;
    Ok(dir.join("bundle"))
}

/// The ground under a hair's box, its shadow's view from above, and the light.
struct Stage {
    to_light: Vec3,
    corners: [Vec3; 4],
    top: Mat4,
}

impl Stage {
    fn new(lo: Vec3, hi: Vec3) -> Stage {
        let to_light = Vec3::new(0.45, 1.0, 0.3).normalize();
        // The ground 3 cm below the hair; its shadow lies away from the light.
        let y = lo.y - 3.0;
        let mid = 0.5 * (lo + hi);
        let centre =
            Vec3::new(mid.x, y, mid.z) - Vec3::new(to_light.x, 0.0, to_light.z) * ((hi.y - y) * 0.5 / to_light.y);
        let half = 45.0;
        let corners =
            [(-half, -half), (-half, half), (half, half), (half, -half)].map(|(x, z)| centre + Vec3::new(x, 0.0, z));
        let top = directx::orthographic(-half, half, -half, half, 0.0, 200.0)
            * look_to_mat4(centre + Vec3::new(0.0, 100.0, 0.0), Vec3::NEG_Y, Vec3::NEG_Z);
        Stage { to_light, corners, top }
    }
}

/// One layout's rows of the shadow table; the ground images of its variants, the reference last.
fn shadow_rows(
    g: &Headless,
    gb: &GpuBundle,
    layout: &str,
    (paper, auto): (&str, &str),
) -> Result<Vec<Vec<f32>>, Box<dyn std::error::Error>> {
    let options = HairOptions { resolution: RESOLUTION, ..HairOptions::new(COLOR_FORMAT, (8, 8)) };
    let paper_r = HairRenderer::new(&g.device, &g.queue, gb, paper, &options)?;
    let auto_r = HairRenderer::new(&g.device, &g.queue, gb, auto, &options)?;
    let stage = Stage::new(Vec3::from(paper_r.settings().bounds_min), Vec3::from(paper_r.settings().bounds_max));
    let size = (GROUND, GROUND);
    let reference =
        reference_shadow(g, gb, paper, stage.to_light, stage.corners, stage.top, (RESOLUTION, size), REFERENCE_FACTOR)?;
    let (_, _, ref_dark) = shadow_errors(&vec![1.0; reference.len()], &reference);
    let variants = [
        ("(a) shading set (plain deep opacity maps)", &paper_r, HairSet::Shading, Lookup::Nearest),
        ("(a′) shading set, 2×2 PCF lookup", &paper_r, HairSet::Shading, Lookup::Bilinear),
        ("(b) the seed's opacity set", &paper_r, HairSet::Opacity, Lookup::Nearest),
        ("(c) auto opacity set", &auto_r, HairSet::Opacity, Lookup::Nearest),
    ];
    let mut images = Vec::new();
    for (name, renderer, set, lookup) in variants {
        let frame = HairFrame {
            set,
            lookup,
            lod: FULL,
            ..HairFrame::new(Mat4::IDENTITY, Vec3::ZERO, renderer.light(stage.to_light))
        };
        renderer.update(&g.queue, &frame);
        let mut encoder = g.device.create_command_encoder(&Default::default());
        renderer.render_opacity_maps(&mut encoder);
        g.queue.submit([encoder.finish()]);
        let vis = Ground::new(g, renderer, stage.corners).visibility(g, renderer, stage.top, size);
        let hf = high_frequency_energy(&vis, size);
        let (rms, max, dark) = shadow_errors(&vis, &reference);
        let settings = renderer.settings();
        let (width, alpha) = if set == HairSet::Opacity { settings.opacity } else { settings.shading };
        println!(
            "| {layout} | {name} | {width:.3} × {alpha:.4} | {rms:.4} | {max:.3} | {dark:+.3} (of {:.3}) | {hf:.4} |",
            -ref_dark
        );
        images.push(vis);
    }
    println!(
        "| {layout} | reference: shading set at {0}× ({1}² maps, ground {2}² box-filtered) | — | 0 | 0 | 0 (of {3:.3}) | {4:.4} |",
        REFERENCE_FACTOR,
        RESOLUTION * REFERENCE_FACTOR,
        GROUND * REFERENCE_FACTOR,
        -ref_dark,
        high_frequency_energy(&reference, size)
    );
    images.push(reference);
    Ok(images)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (bundle, out) = hikage_scenes::example_paths("hair_shadow")?;
    let layouts_dir = bake_layouts(Path::new("target/hair_layouts"))?;
    let (cpu, g, gb) = hikage_scenes::open_bundle(&bundle, &["head.strips", "head_auto.strips"])?;
    let extra = CpuBundle::read(&layouts_dir)?;
    let extra_gb = GpuBundle::upload(&g.device, &g.queue, &extra)?;

    println!(
        "\nGround shadow against the reference ({RESOLUTION}² opacity maps; errors over the pixels in or beside shadow; darkness = mean of 1 − visibility there)\n"
    );
    println!(
        "| layout | opacity maps | width × opacity (cm) | RMS error | max error | darkness error | high-frequency energy |"
    );
    println!("|---|---|---|---|---|---|---|");
    let head_images = shadow_rows(&g, &gb, "sample head", ("head.strips", "head_auto.strips"))?;
    shadow_rows(&g, &extra_gb, "head at the seed's widths", ("head_paper.strips", "head_paper_auto.strips"))?;
    shadow_rows(&g, &extra_gb, "straight combed strands", ("combed.strips", "combed_auto.strips"))?;

    // The layer rule: error in the hair's own shadow at every strand point.
    println!(
        "\nLayer rule: the hair's own shadow at every strand point through the layered maps of the seed's set, against the exact sum of the opacities in front ({RESOLUTION}², CPU)\n"
    );
    println!("| layout | rule | RMS error | max error |");
    println!("|---|---|---|---|");
    for (layout, bundle, gpu, id) in [
        ("sample head", &cpu, &gb, "head.strips"),
        ("head at the seed's widths", &extra, &extra_gb, "head_paper.strips"),
        ("straight combed strands", &extra, &extra_gb, "combed.strips"),
    ] {
        let asset = bundle.asset(id).ok_or("missing strands")?;
        let settings = asset.asset.settings.strands().ok_or("not strands")?;
        let strips = StripArrays::from_mesh(asset.mesh().ok_or("not a mesh")?, settings).ok_or("not a strands mesh")?;
        let options = HairOptions { resolution: RESOLUTION, ..HairOptions::new(COLOR_FORMAT, (8, 8)) };
        let renderer = HairRenderer::new(&g.device, &g.queue, gpu, id, &options)?;
        let (lo, hi) = (Vec3::from(settings.bounds_min), Vec3::from(settings.bounds_max));
        for (rule, name) in
            [(LayerRule::Box, "box range / 10 everywhere"), (LayerRule::PerTexel, "per texel (the seed's)")]
        {
            let light = HairLight { rule, ..HairLight::for_bounds(lo, hi, Stage::new(lo, hi).to_light) };
            let frame = HairFrame { lod: FULL, ..HairFrame::new(Mat4::IDENTITY, Vec3::ZERO, light) };
            let (rms, max) = layer_errors(&strips, &renderer.uniform(&frame), &light, strips.points_of_level(0));
            println!("| {layout} | {name} | {rms:.4} | {max:.3} |");
        }
    }

    // The sample head's picture: the views of (a), (b), (c) above their ground shadows, and the
    // reference's shadow.
    let (w, h) = (320u32, 240u32);
    let mut options = HairOptions { resolution: RESOLUTION, ..HairOptions::new(COLOR_FORMAT, (w, h)) };
    options.draw.depth_format = Some(DEPTH_FORMAT);
    let paper = HairRenderer::new(&g.device, &g.queue, &gb, "head.strips", &options)?;
    let auto = HairRenderer::new(&g.device, &g.queue, &gb, "head_auto.strips", &options)?;
    let stage = Stage::new(Vec3::from(paper.settings().bounds_min), Vec3::from(paper.settings().bounds_max));
    let eye = Vec3::new(-55.0, 35.0, 75.0);
    let mid = 0.25 * stage.corners.iter().copied().sum::<Vec3>();
    let camera = directx::perspective(45f32.to_radians(), w as f32 / h as f32, 1.0, 400.0)
        * look_at_mat4(eye, mid + Vec3::new(0.0, 18.0, 0.0), Vec3::Y);
    let sky = wgpu::Color { r: 0.3, g: 0.4, b: 0.6, a: 1.0 };
    let gsize = GROUND;
    let mut image = image::RgbaImage::new(4 * w, h + gsize);
    let views = [(&paper, HairSet::Shading, 0usize), (&paper, HairSet::Opacity, 2), (&auto, HairSet::Opacity, 3)];
    for (k, (renderer, set, shadow)) in views.into_iter().enumerate() {
        let frame = HairFrame { set, ..HairFrame::new(camera, eye, renderer.light(stage.to_light)) };
        renderer.update(&g.queue, &frame);
        let ground = Ground::new(&g, renderer, stage.corners);
        let rgba = render_frame(&g, renderer, Some((&ground, camera)), HairBlend::OrderIndependent, (w, h), sky);
        let view = image::RgbaImage::from_raw(w, h, rgba).ok_or("read-back size")?;
        image::imageops::replace(&mut image, &view, (k as u32 * w) as i64, 0);
        put_shadow(&mut image, &head_images[shadow], k as u32 * w + (w - gsize) / 2, h);
    }
    put_shadow(&mut image, &head_images[4], 3 * w + (w - gsize) / 2, h);
    let path = out.join("hair_shadow.png");
    hikage_scenes::png::save(&image, &path)?;
    println!("\nwrote {}", path.display());

    // The camera's blend: the hair alone over black, the seed's opacity maps, against the exact
    // composite of the same fragments sorted by depth on the CPU.
    let frame = HairFrame { lod: FULL, ..HairFrame::new(camera, eye, paper.light(stage.to_light)) };
    paper.update(&g.queue, &frame);
    let uniform = paper.uniform(&frame);
    let head = cpu.asset("head.strips").ok_or("no head.strips")?;
    let strips = StripArrays::from_mesh(head.mesh().ok_or("not a mesh")?, paper.settings()).ok_or("not strands")?;
    let black = wgpu::Color::BLACK;
    let oit = render_frame(&g, &paper, None, HairBlend::OrderIndependent, (w, h), black);
    let maps = read_opacity_maps(&g, &paper);
    let sorted = camera_reference(
        &strips,
        &uniform,
        &frame.light,
        &maps,
        ((w, h), strips.points_of_level(0)),
        Composite::Sorted,
    );
    println!();
    println!(
        "| camera draws the shading set | vs the sorted composite: mean abs error | RMS | pixels off by > 0.05 | frame time on this adapter (best of 3) |"
    );
    println!("|---|---|---|---|---|");
    for (name, blend, image) in [
        ("blended, order-independent (default)", HairBlend::OrderIndependent, oit),
        ("opaque", HairBlend::Opaque, render_frame(&g, &paper, None, HairBlend::Opaque, (w, h), black)),
    ] {
        let (mut n, mut sum, mut sq, mut off) = (0usize, 0.0f64, 0.0f64, 0usize);
        for (i, r) in sorted.iter().enumerate() {
            if r[3] <= 0.0 {
                continue;
            }
            let worst = (0..3).map(|k| (srgb_to_linear(image[4 * i + k]) - r[k].min(1.0)).abs()).fold(0.0f32, f32::max);
            n += 1;
            sum += worst as f64;
            sq += (worst as f64).powi(2);
            off += (worst > 0.05) as usize;
        }
        let time = (0..3)
            .map(|_| {
                let t = Instant::now();
                let _ = render_frame(&g, &paper, None, blend, (w, h), black);
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min);
        println!(
            "| {name} | {:.4} | {:.4} | {:.1}% | {:.1} ms |",
            sum / n as f64,
            (sq / n as f64).sqrt(),
            100.0 * off as f64 / n as f64,
            1000.0 * time
        );
    }
    Ok(())
}

/// Draws a ground visibility image (gamma-encoded grey) at `(x, y)`.
fn put_shadow(image: &mut image::RgbaImage, vis: &[f32], x: u32, y: u32) {
    for (i, &v) in vis.iter().enumerate() {
        let c = (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0) as u8;
        image.put_pixel(x + i as u32 % GROUND, y + i as u32 / GROUND, image::Rgba([c, c, c, 255]));
    }
}
