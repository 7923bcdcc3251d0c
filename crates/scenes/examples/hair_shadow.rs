//! Seed 004, headless, through `hikage_runtime::hair::HairRenderer`: the sample head (10,000
//! strands) above a ground plane under one light, with deep opacity maps of 256² built from
//! (a) the shading set itself (plain deep opacity maps), (b) the seed's wide faint opacity set,
//! (c) the opacity set `--auto` chose; the hair blended at its opacity over the ground. Writes
//! the three views and the ground's shadow seen from above as PNGs, prints the aliasing of each
//! ground shadow (high-frequency energy; lower is smoother) and its mean darkness, and measures
//! the camera's order-independent blend and the opaque draw against an exact, sorted CPU
//! composite of the same fragments.
//!
//! ```text
//! cargo run --release -- bake      # makes bundle/ with head.strips and head_auto.strips
//! cargo run --release -p hikage-scenes --example hair_shadow -- bundle docs/images
//! ```

use std::time::Instant;

use hikage_runtime::glam::Vec3;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::{look_at_mat4, look_to_mat4};
use hikage_runtime::hair::reference::StripArrays;
use hikage_runtime::hair::{HairFrame, HairOptions, HairRenderer, HairSet};
use hikage_runtime::wgpu;
use hikage_scenes::hair_scene::{
    Composite, Ground, HairBlend, camera_reference, high_frequency_energy, read_opacity_maps, render_frame,
    srgb_to_linear,
};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT};

const RESOLUTION: u32 = 256;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (bundle, out) = hikage_scenes::example_paths("hair_shadow")?;
    let (cpu, g, gb) = hikage_scenes::open_bundle(&bundle, &["head.strips", "head_auto.strips"])?;
    let (w, h) = (320u32, 240u32);
    let options = HairOptions {
        resolution: RESOLUTION,
        depth_format: Some(DEPTH_FORMAT),
        ..HairOptions::new(COLOR_FORMAT, (w, h))
    };
    let paper = HairRenderer::new(&g.device, &g.queue, &gb, "head.strips", &options)?;
    let auto = HairRenderer::new(&g.device, &g.queue, &gb, "head_auto.strips", &options)?;
    let (lo, hi) = (Vec3::from(paper.settings().bounds_min), Vec3::from(paper.settings().bounds_max));
    let to_light = Vec3::new(0.45, 1.0, 0.3).normalize();
    // The ground 3 cm below the hair; its shadow lies away from the light.
    let y = lo.y - 3.0;
    let centre = Vec3::new(0.0, y, 0.0) - Vec3::new(to_light.x, 0.0, to_light.z) * ((hi.y - y) * 0.5 / to_light.y);
    let half = 45.0;
    let corners =
        [(-half, -half), (-half, half), (half, half), (half, -half)].map(|(x, z)| centre + Vec3::new(x, 0.0, z));
    let eye = Vec3::new(-55.0, 35.0, 75.0);
    let camera = directx::perspective(45f32.to_radians(), w as f32 / h as f32, 1.0, 400.0)
        * look_at_mat4(eye, centre + Vec3::new(0.0, 18.0, 0.0), Vec3::Y);
    let top = directx::orthographic(-half, half, -half, half, 0.0, 200.0)
        * look_to_mat4(centre + Vec3::new(0.0, 100.0, 0.0), Vec3::NEG_Y, Vec3::NEG_Z);
    let sky = wgpu::Color { r: 0.3, g: 0.4, b: 0.6, a: 1.0 };
    let variants = [
        ("(a) shading set in the opacity maps (plain DOM)", &paper, HairSet::Shading),
        ("(b) the seed's opacity set", &paper, HairSet::Opacity),
        ("(c) auto opacity set", &auto, HairSet::Opacity),
    ];
    let gsize = 256u32;
    let mut image = image::RgbaImage::new(3 * w, h + gsize);
    println!(
        "| opacity maps ({RESOLUTION}²) | width × opacity | ground shadow: high-frequency energy | mean darkness in shadow |"
    );
    println!("|---|---|---|---|");
    for (k, (name, renderer, set)) in variants.into_iter().enumerate() {
        let frame = HairFrame { set, ..HairFrame::new(camera, eye, renderer.light(to_light)) };
        renderer.update(&g.queue, &frame);
        let ground = Ground::new(&g, renderer, corners);
        let rgba = render_frame(&g, renderer, Some((&ground, camera)), HairBlend::OrderIndependent, (w, h), sky);
        let vis = ground.visibility(&g, renderer, top, (gsize, gsize));
        let hf = high_frequency_energy(&vis, (gsize, gsize));
        let shadowed: Vec<f32> = vis.iter().copied().filter(|&v| v < 0.98).collect();
        let dark = shadowed.iter().map(|v| 1.0 - v).sum::<f32>() / shadowed.len().max(1) as f32;
        let settings = renderer.settings();
        let (width, alpha) = if set == HairSet::Opacity { settings.opacity } else { settings.shading };
        println!("| {name} | {width:.3} × {alpha:.4} | {hf:.4} | {dark:.3} |");
        let view = image::RgbaImage::from_raw(w, h, rgba).ok_or("read-back size")?;
        image::imageops::replace(&mut image, &view, (k as u32 * w) as i64, 0);
        for (i, &v) in vis.iter().enumerate() {
            let c = (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0) as u8;
            let (x, y) = (k as u32 * w + (w - gsize) / 2 + i as u32 % gsize, h + i as u32 / gsize);
            image.put_pixel(x, y, image::Rgba([c, c, c, 255]));
        }
    }
    let path = out.join("hair_shadow.png");
    hikage_scenes::png::save(&image, &path)?;
    println!("wrote {}", path.display());

    // The camera's blend: the hair alone over black, the seed's opacity maps, against the exact
    // composite of the same fragments sorted by depth on the CPU.
    let frame = HairFrame::new(camera, eye, paper.light(to_light));
    paper.update(&g.queue, &frame);
    let uniform = paper.uniform(&frame);
    let strips = StripArrays::from_mesh(cpu.asset("head.strips").and_then(|a| a.mesh()).ok_or("no head.strips")?)
        .ok_or("not a strands mesh")?;
    let black = wgpu::Color::BLACK;
    let oit = render_frame(&g, &paper, None, HairBlend::OrderIndependent, (w, h), black);
    let maps = read_opacity_maps(&g, &paper);
    let sorted = camera_reference(&strips, &uniform, &frame.light, &maps, camera, eye, (w, h), Composite::Sorted);
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
