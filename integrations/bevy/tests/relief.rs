//! The relief material rendered by Bevy (lavapipe in CI) against hikage-runtime's CPU reference
//! of the same pixel: where the view ray hits (read back through a texture coding each texel's
//! column and row) and whether the hit is lit.

#[path = "../examples/common/mod.rs"]
mod common;

use bevy::asset::RenderAssetUsages;
use bevy::image::{ImageSampler, ImageSamplerDescriptor};
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use hikage_bevy::{HikageBundle, ReliefMaterial, ReliefSurface};
use hikage_runtime::CpuBundle;
use hikage_runtime::glam;
use hikage_runtime::relief::reference::{ReliefMaps, relief_material_shade};
use hikage_runtime::relief::{ReliefFrame, ReliefMaterialUniform, Tracer};

use common::{Headless, MaskScene, bake, gpu_or_skip};

const SIZE: u32 = 256;

/// A 2 × 2 quad in the xz plane facing +y, u along +x, v along +z (bitangent = −cross(n, t)).
fn quad() -> Mesh {
    let mut mesh = Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::default());
    mesh.insert_attribute(
        Mesh::ATTRIBUTE_POSITION,
        vec![[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0]],
    );
    mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, vec![[0.0f32, 1.0, 0.0]; 4]);
    mesh.insert_attribute(Mesh::ATTRIBUTE_TANGENT, vec![[1.0f32, 0.0, 0.0, -1.0]; 4]);
    mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, vec![[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    mesh.insert_indices(Indices::U32(vec![0, 3, 1, 1, 3, 2]));
    mesh
}

/// `n` × `n` sRGB texels whose red and green bytes are their column and row: an unlit material
/// reading it writes the texel it read, byte for byte, to an sRGB target.
fn texel_code(n: u32) -> Image {
    let data = (0..n * n).flat_map(|k| [(k % n) as u8, (k / n) as u8, 0, 255]).collect();
    let mut image = Image::new(
        Extent3d { width: n, height: n, depth_or_array_layers: 1 },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::default(),
    );
    image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
        address_mode_u: bevy::image::ImageAddressMode::Repeat,
        address_mode_v: bevy::image::ImageAddressMode::Repeat,
        ..ImageSamplerDescriptor::nearest()
    });
    image
}

#[test]
fn relief_hits_and_shadows_match_the_cpu_reference() {
    if !gpu_or_skip("relief_hits_and_shadows_match_the_cpu_reference") {
        return;
    }
    let dir = bake("relief", r#"Relief(id: "relief_bricks", input: "data/relief_bricks.png")"#);
    let eye = Vec3::new(0.3, 1.1, 2.0);
    let sun = Vec3::new(-1.0, 0.08, -0.4).normalize();

    let view = Transform::from_translation(eye).looking_at(Vec3::new(0.0, 0.0, 0.1), Vec3::Y);
    let MaskScene { mut app, target, .. } = MaskScene::new(&dir, SIZE, sun, view, Projection::default());
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let world = app.world();
    let mesh = world.resource_mut::<Assets<Mesh>>().add(quad());
    let code = world.resource_mut::<Assets<Image>>().add(texel_code(256));
    let coded = StandardMaterial { base_color_texture: Some(code), unlit: true, ..default() };
    let surface = ReliefSurface { ao_stride: 0, ..ReliefSurface::new(bundle, "relief_bricks.relief") }.with_base(coded);
    let surface = world.spawn((Mesh3d(mesh), surface)).id();
    let built = app.update_until(600, |world| world.get::<MeshMaterial3d<ReliefMaterial>>(surface).is_some());
    assert!(built, "the relief material was not built");
    let texels = app.capture_bytes(&target);
    // The same surface white and lit, with the depth maps' shadows and without.
    let handle = app.world().get::<MeshMaterial3d<ReliefMaterial>>(surface).unwrap().0.clone();
    let set = |app: &mut Headless, shadows: u32| {
        let mut materials = app.world().resource_mut::<Assets<ReliefMaterial>>();
        let mut material = materials.get_mut(&handle).unwrap();
        material.base = StandardMaterial { perceptual_roughness: 1.0, ..default() };
        material.extension.shading.shadows = shadows;
    };
    set(&mut app, 1);
    let shadowed = app.capture(&target);
    set(&mut app, 0);
    let open = app.capture_settled(&target);

    let cpu = CpuBundle::read_prefix(&dir.join("bundle"), "relief_bricks.").unwrap();
    let maps = ReliefMaps::from_bundle(&cpu, "relief_bricks.relief").unwrap();
    let tracer = Tracer::Combined { margin: 0.1, start_level: 3 };
    let uniform = ReliefMaterialUniform::new(&ReliefFrame {
        eye: glam::Vec3::from_array(eye.to_array()),
        light: glam::Vec3::from_array(sun.to_array()),
        tile: glam::Vec2::splat(2.0),
        tracer,
        shadows: true,
        ao_stride: 0,
        ..ReliefFrame::default()
    });
    let size = 256.0f32;
    let (mut covered, mut within, mut lit_checked, mut lit_agree, mut lit) = (0, 0, 0, 0, 0);
    for row in 0..SIZE {
        for col in 0..SIZE {
            let ray = app.pixel_ray(col, row);
            let t = -ray.origin.y / ray.direction.y;
            let p = ray.origin + t * *ray.direction;
            if t <= 0.0 || p.x.abs() > 0.98 || p.z.abs() > 0.98 {
                continue; // off the quad, or too near its edge for a pixel to be sure
            }
            let uv = glam::Vec2::new((p.x + 1.0) / 2.0, (p.z + 1.0) / 2.0);
            let world = glam::Vec3::from_array(p.to_array());
            let pixel = relief_material_shade(
                &maps,
                tracer,
                &uniform,
                world,
                glam::Vec3::Y,
                glam::Vec4::new(1.0, 0.0, 0.0, -1.0),
                uv,
            );
            let Some(s) = pixel.s else { continue };
            // The reference's hit in texels of the 256² relief: the ray in texel space (x along
            // u, y along v, z down; the 2-unit tile scales all three alike) from the pixel's uv.
            let d = glam::Vec3::new(p.x - eye.x, p.y - eye.y, p.z - eye.z);
            let dir = glam::Vec3::new(d.x, d.z, -d.y).normalize();
            let hit = uv * size + s * dir.truncate();
            let k = (row * SIZE + col) as usize;
            let off = |gpu: u8, cpu: f32| {
                let d = (gpu as i32 - cpu.floor().rem_euclid(size) as i32).rem_euclid(256);
                d.min(256 - d)
            };
            covered += 1;
            within += (off(texels[k][0], hit.x) <= 1 && off(texels[k][1], hit.y) <= 1) as usize;
            if open[k][1] > 0.02 {
                lit_checked += 1;
                let bevy_lit = shadowed[k][1] >= 0.5 * open[k][1];
                lit += pixel.lit as usize;
                lit_agree += (bevy_lit == pixel.lit) as usize;
            }
        }
    }
    let hits = within as f64 / covered as f64;
    let shadows = lit_agree as f64 / lit_checked as f64;
    eprintln!(
        "bevy relief: {covered} pixels, hit within a texel of the CPU's on {:.2}%; {lit_checked} sunward, {:.1}% lit, lit/shadowed agree on {:.2}%",
        100.0 * hits,
        100.0 * lit as f64 / lit_checked as f64,
        100.0 * shadows
    );
    assert!(covered > 20_000, "{covered} pixels on the quad");
    assert!(hits >= 0.99, "{:.2}% of hits within a texel", 100.0 * hits);
    assert!((0.05..0.95).contains(&(lit as f64 / lit_checked as f64)), "a low sun shadows part of the bricks");
    assert!(shadows >= 0.98, "{:.2}% agree", 100.0 * shadows);
}
