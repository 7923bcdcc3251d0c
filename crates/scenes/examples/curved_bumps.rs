//! Seed 000 Figs. 4 and 7 on real meshes with baked curvature: `data/sphere.obj` (κ1 = κ2 =
//! 0.015) carrying the cylinder bumps, and `data/torus.glb` (κ1 = 1/40 across the tube, κ2 = 1/140
//! along the ring) carrying the reptile cells, each drawn with the flat horizon test (left) and
//! the curvature-corrected one (right) by `hikage_runtime::horizon::SurfaceShadows`. Prints the
//! shadowed share of each, the analytic sphere's for comparison, and the torus under lights
//! tilted along each principal direction.
//!
//! ```text
//! cargo run --release -- bake
//! cargo run --release -p hikage-scenes --example curved_bumps -- bundle docs/images
//! ```

use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::glam::{Mat4, Vec3};
use hikage_runtime::horizon::reference::SurfaceReference;
use hikage_runtime::horizon::{SurfaceFrame, SurfaceShadows, horizon_filterable};
use hikage_runtime::{DrawOptions, wgpu};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, Frame, Headless, VISIBILITY_FORMAT};
use hikage_scenes::horizon_sphere::{AnalyticSphere, shadowed_fraction};

const SIZE: u32 = 384;

/// Draws `surface` under `light` and returns the frame and its shadowed share.
fn draw(g: &Headless, surface: &SurfaceShadows, view_proj: Mat4, light: Vec3, corrected: bool) -> (Frame, f64) {
    surface.update(&g.queue, &SurfaceFrame { view_proj, light, corrected, ..SurfaceFrame::default() });
    let frame = g.render((SIZE, SIZE), wgpu::Color { r: 0.02, g: 0.02, b: 0.03, a: 1.0 }, |pass| surface.draw(pass));
    let flags: Vec<u32> = frame.visibility.iter().map(|v| if v[1] < 0.5 { 2 } else { (v[0] > 0.5) as u32 }).collect();
    (frame, shadowed_fraction(&flags))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (bundle, out) = hikage_scenes::example_paths("curved_bumps")?;
    let (cpu, g, gb) =
        hikage_scenes::open_bundle(&bundle, &["sphere", "torus", "cylinders.horizon", "reptile.horizon"])?;
    let options = DrawOptions {
        depth_format: Some(DEPTH_FORMAT),
        visibility_format: Some(VISIBILITY_FORMAT),
        cull_mode: Some(wgpu::Face::Back),
        ..DrawOptions::new(COLOR_FORMAT)
    };
    let sphere = AnalyticSphere::SAMPLE;
    let torus_view = directx::orthographic(-150.0, 150.0, -150.0, 150.0, 10.0, 600.0)
        * look_at_mat4(Vec3::new(0.0, 150.0, 260.0), Vec3::ZERO, Vec3::Y);
    let light = Vec3::new(-0.8, 0.25, 0.45).normalize();
    let mut image = image::RgbaImage::new(2 * SIZE, 2 * SIZE);
    println!(
        "| mesh | bump map | flat test: shadowed | corrected: shadowed | difference | analytic sphere (flat / corrected) |"
    );
    println!("|---|---|---|---|---|---|");
    let scenes = [("sphere", "cylinders.horizon", sphere.view_proj()), ("torus", "reptile.horizon", torus_view)];
    for (row, (mesh, map, view_proj)) in scenes.into_iter().enumerate() {
        let surface = SurfaceShadows::new(&g.device, &g.queue, &gb, mesh, map, &options)?;
        let mut shares = [0.0; 2];
        for (col, corrected) in [false, true].into_iter().enumerate() {
            let (frame, share) = draw(&g, &surface, view_proj, light, corrected);
            shares[col] = share;
            let tile = image::RgbaImage::from_raw(SIZE, SIZE, frame.color).ok_or("read-back size")?;
            image::imageops::replace(&mut image, &tile, (col as u32 * SIZE) as i64, (row as u32 * SIZE) as i64);
        }
        let analytic = if mesh == "sphere" {
            let reference =
                SurfaceReference::new(&cpu, map, horizon_filterable(&g.device, gb.texture(map)?.desc.format))?;
            let s = |corrected| 100.0 * shadowed_fraction(&sphere.flags(&reference, light, corrected, SIZE));
            format!("{:.1}% / {:.1}%", s(false), s(true))
        } else {
            "—".into()
        };
        println!(
            "| {mesh} | {map} | {:.1}% | {:.1}% | {:.1} points | {analytic} |",
            100.0 * shares[0],
            100.0 * shares[1],
            100.0 * (shares[0] - shares[1])
        );
    }
    let path = out.join("curved_bumps.png");
    hikage_scenes::png::save(&image, &path)?;
    println!("wrote {}", path.display());

    // κ1 ≠ κ2: the front of the torus tube under lights 12° above it, tilted along each
    // principal direction.
    let surface = SurfaceShadows::new(&g.device, &g.queue, &gb, "torus", "reptile.horizon", &options)?;
    let front = directx::orthographic(-30.0, 30.0, -15.0, 15.0, 10.0, 400.0)
        * look_at_mat4(Vec3::new(0.0, 0.0, 300.0), Vec3::ZERO, Vec3::Y);
    let elevation = 12f32.to_radians();
    println!();
    println!(
        "| torus front, light 12° up, tilted along | curvature along the light | flat: shadowed | corrected: shadowed | shortened by |"
    );
    println!("|---|---|---|---|---|");
    for (axis, name, kappa) in [(Vec3::Y, "V1 (across the tube)", "1/40"), (Vec3::X, "V2 (along the ring)", "1/140")] {
        let l = (axis * elevation.cos() + Vec3::Z * elevation.sin()).normalize();
        let (_, flat) = draw(&g, &surface, front, l, false);
        let (_, corrected) = draw(&g, &surface, front, l, true);
        println!(
            "| {name} | {kappa} | {:.1}% | {:.1}% | {:.1} points |",
            100.0 * flat,
            100.0 * corrected,
            100.0 * (flat - corrected)
        );
    }
    Ok(())
}
