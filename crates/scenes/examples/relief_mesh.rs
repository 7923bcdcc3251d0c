//! Seed 003's Fig. 12 setting: relief mapping on a curved mesh with depth-map shadows and
//! ambient occlusion, through `hikage_runtime::relief::ReliefMaterial`. The sphere of
//! `data/sphere.obj` (its tangents from the Curvature asset's texture frame) carries the brick
//! and the spike reliefs; each is drawn plain (left) and with shadows and ambient occlusion
//! (right). Prints the lit share and the mean open share of the hemisphere.
//!
//! ```text
//! cargo run --release -- bake
//! cargo run --release -p hikage-scenes --example relief_mesh -- bundle docs/images
//! ```

use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::glam::{Vec2, Vec3};
use hikage_runtime::relief::{ReliefFrame, ReliefMaterial, Tracer};
use hikage_runtime::{DrawOptions, bytemuck, wgpu};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, VISIBILITY_FORMAT};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (bundle, out) = hikage_scenes::example_paths("relief_mesh")?;
    let (cpu, g, gpu) =
        hikage_scenes::open_bundle(&bundle, &["sphere", "relief_bricks.relief", "relief_spikes.relief"])?;

    // The game's mesh: here the sphere, its tangent along P_u.
    let mesh = cpu.asset("sphere").and_then(|a| a.mesh()).ok_or("no sphere mesh")?;
    let vertices = hikage_scenes::relief_vertices(mesh);
    let indices = mesh.read_indices().ok_or("no indices")?;
    let vbuf = g.buffer(
        std::mem::size_of_val(vertices.as_slice()) as u64,
        wgpu::BufferUsages::VERTEX,
        Some(bytemuck::cast_slice(&vertices)),
    );
    let ibuf = g.buffer(4 * indices.len() as u64, wgpu::BufferUsages::INDEX, Some(bytemuck::cast_slice(&indices)));

    let options = DrawOptions {
        depth_format: Some(DEPTH_FORMAT),
        visibility_format: Some(VISIBILITY_FORMAT),
        cull_mode: Some(wgpu::Face::Back),
        ..DrawOptions::new(COLOR_FORMAT)
    };
    let size = 320u32;
    let radius = 1.0 / 0.015;
    let eye = Vec3::new(-60.0, 70.0, 190.0);
    let view_proj =
        directx::perspective(42f32.to_radians(), 1.0, 10.0, 1000.0) * look_at_mat4(eye, Vec3::ZERO, Vec3::Y);
    let mut image = image::RgbaImage::new(2 * size, 2 * size);
    println!("| relief | shading | lit | mean open share (AO) |");
    println!("|---|---|---|---|");
    for (row, id) in ["relief_bricks.relief", "relief_spikes.relief"].into_iter().enumerate() {
        let material = ReliefMaterial::new(&g.device, &g.queue, &gpu, id, &options)?;
        for (col, (shadows, ao_stride)) in [(false, 0), (true, 16)].into_iter().enumerate() {
            let frame = ReliefFrame {
                view_proj,
                eye,
                light: Vec3::new(-0.7, 0.55, 0.45).normalize(),
                light_color: Vec3::splat(1.1),
                ambient: Vec3::splat(0.35),
                tile: Vec2::splat(std::f32::consts::TAU * radius / 3.0),
                tracer: Tracer::Combined { margin: 0.1, start_level: 3 },
                shadows,
                ao_stride,
                ..ReliefFrame::default()
            };
            material.update(&g.queue, &frame);
            let f = g.render((size, size), wgpu::Color { r: 0.55, g: 0.65, b: 0.8, a: 1.0 }, |pass| {
                material.draw(pass, vbuf.slice(..), ibuf.slice(..), indices.len() as u32)
            });
            let covered: Vec<&[f32; 4]> = f.visibility.iter().filter(|v| v[1] > 0.5).collect();
            let n = covered.len().max(1) as f32;
            let lit = covered.iter().map(|v| v[0]).sum::<f32>() / n;
            let ao = covered.iter().map(|v| v[2]).sum::<f32>() / n;
            let shading = if shadows { "shadows + AO" } else { "plain" };
            println!("| {id} | {shading} | {:.1}% | {ao:.3} |", 100.0 * lit);
            let tile = image::RgbaImage::from_raw(size, size, f.color).ok_or("read-back size")?;
            image::imageops::replace(&mut image, &tile, (col as u32 * size) as i64, (row as u32 * size) as i64);
        }
    }
    let path = out.join("relief_mesh.png");
    hikage_scenes::png::save(&image, &path)?;
    println!("wrote {}", path.display());
    Ok(())
}
