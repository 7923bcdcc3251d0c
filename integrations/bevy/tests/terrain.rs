//! The terrain material rendered by Bevy on a GPU (lavapipe in CI) against hikage-runtime's CPU
//! reference of the same horizon test: the lit/shadow mask seen from above agrees on ≥ 98% of
//! the pixels, as the raw-wgpu terrain component does, for rg16f and BC5 horizons.

#[path = "../examples/common/mod.rs"]
mod common;

use bevy::light::{NotShadowCaster, SunDisk};
use bevy::prelude::*;
use bevy::render::render_resource::TextureFormat;
use hikage_bevy::{HikageBundle, HorizonTerrain, TerrainMaterial};
use hikage_runtime::CpuBundle;
use hikage_runtime::glam;
use hikage_runtime::horizon::reference::{HorizonMap, horizon_sun_visible};

use common::{MaskScene, bake, gpu_or_skip};

const SIZE: u32 = 512;

#[test]
fn terrain_mask_matches_the_cpu_reference() {
    if gpu_or_skip("terrain_mask_matches_the_cpu_reference") {
        terrain_mask("terrain", "Rg16Float", TextureFormat::Rg16Float);
    }
}

/// A BC5 horizon stays blocks on a device that samples them (lavapipe does, 3D included) and
/// shadows as the CPU reference of its decoded texels says.
#[test]
fn bc5_terrain_keeps_its_blocks_and_matches_the_cpu_reference() {
    if gpu_or_skip("bc5_terrain_keeps_its_blocks_and_matches_the_cpu_reference") {
        terrain_mask("terrain_bc5", "Bc5RgUnorm", TextureFormat::Bc5RgUnorm);
    }
}

/// Renders the default terrain's horizon baked as `format`, checks the image Bevy holds is
/// `on_device`, and compares the lit mask with the CPU reference.
fn terrain_mask(name: &str, format: &str, on_device: TextureFormat) {
    let dir = bake(
        name,
        &format!(
            r#"Horizon(id: "terrain", input: "data/terrain.png", texel_size: (80, 60), height_scale: 1500,
                   directions: 32, edge: Clamp, ao: true, format: {format})"#
        ),
    );
    let (w, h, sx, sy) = (512.0f32, 512.0f32, 80.0f32, 60.0f32);
    let (ex, ez) = (w * sx / 2.0, h * sy / 2.0);
    // The sun at 45° in the world between +x (u) and +z (v), 9° up.
    let elevation = 9f32.to_radians();
    let sun = Vec3::new(elevation.cos() * 0.5f32.sqrt(), elevation.sin(), elevation.cos() * 0.5f32.sqrt());

    let MaskScene { mut app, target, .. } = MaskScene::new(
        &dir,
        SIZE,
        sun,
        Transform::from_xyz(ex, 4000.0, ez).looking_at(Vec3::new(ex, 0.0, ez), Vec3::NEG_Z),
        MaskScene::orthographic(2.0 * ex, 2.0 * ez, 10_000.0),
    );
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    app.world().spawn((HorizonTerrain::new(bundle.clone(), "terrain.horizon"), NotShadowCaster));
    let built =
        app.update_until(600, |world| world.query::<&MeshMaterial3d<TerrainMaterial>>().iter(world).next().is_some());
    assert!(built, "the terrain was not built");
    let shadowed = app.capture_settled(&target);
    let world = app.world();
    let handle = world.resource::<Assets<HikageBundle>>().get(&bundle).unwrap().image("terrain.horizon").unwrap();
    assert_eq!(world.resource::<Assets<Image>>().get(handle).unwrap().texture_descriptor.format, on_device);
    let material = app.world().query::<&MeshMaterial3d<TerrainMaterial>>().single(app.world()).unwrap().0.clone();
    app.world().resource_mut::<Assets<TerrainMaterial>>().get_mut(&material).unwrap().extension.uniform.horizon = 0;
    let open = app.capture_settled(&target);

    let cpu = CpuBundle::read_prefix(&dir.join("bundle"), "terrain.").unwrap();
    let asset = cpu.asset("terrain.horizon").unwrap();
    let map = HorizonMap::new(asset.texture().unwrap(), asset.asset.settings.horizon().unwrap(), true).unwrap();
    let bump_sun = glam::Vec3::new(sun.x, sun.z, sun.y);
    let radius = 0.5 * SunDisk::EARTH.angular_size;
    let (mut checked, mut agree, mut lit) = (0usize, 0usize, 0usize);
    for row in 0..SIZE {
        for col in 0..SIZE {
            let k = (row * SIZE + col) as usize;
            if open[k][1] < 0.02 {
                continue; // facing away from the sun, or off the terrain
            }
            let uv = glam::Vec2::new((col as f32 + 0.5) / w, (row as f32 + 0.5) / h);
            let reference = horizon_sun_visible(&map, uv, bump_sun, glam::Vec2::new(sx, sy), radius) >= 0.5;
            let bevy = shadowed[k][1] >= 0.5 * open[k][1];
            checked += 1;
            lit += reference as usize;
            agree += (reference == bevy) as usize;
        }
    }
    let share = agree as f64 / checked as f64;
    eprintln!(
        "bevy terrain ({format}): {checked} pixels, {:.1}% lit; the Bevy render agrees with the CPU reference on {:.2}%",
        100.0 * lit as f64 / checked as f64,
        100.0 * share
    );
    assert!(checked > 150_000, "{checked} pixels face the sun");
    assert!((0.2..0.95).contains(&(lit as f64 / checked as f64)), "a low sun casts long shadows");
    assert!(share >= 0.98, "{:.2}% agree", 100.0 * share);
}

/// A rebake of the bundle under a running app (what Bevy's file watcher reports) rebuilds the
/// terrain's material from the new manifest: a changed texel size reaches the shader's uniform.
#[test]
fn a_rebaked_terrain_rebuilds_its_material() {
    if !gpu_or_skip("a_rebaked_terrain_rebuilds_its_material") {
        return;
    }
    let job = |texel: f32| {
        format!(
            r#"Horizon(id: "t", input: "data/cylinders.png", texel_size: ({texel}, {texel}), height_scale: 4, directions: 8, edge: Clamp)"#
        )
    };
    let dir = bake("terrain_reload", &job(1.0));
    let MaskScene { mut app, .. } = MaskScene::new(
        &dir,
        64,
        Vec3::Y,
        Transform::from_xyz(64.0, 200.0, 64.0).looking_at(Vec3::new(64.0, 0.0, 64.0), Vec3::NEG_Z),
        Projection::default(),
    );
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let terrain = app.world().spawn(HorizonTerrain::new(bundle, "t.horizon")).id();
    let material =
        |app: &mut common::Headless| app.world().get::<MeshMaterial3d<TerrainMaterial>>(terrain).map(|m| m.0.clone());
    assert!(app.update_until(600, |w| w.get::<MeshMaterial3d<TerrainMaterial>>(terrain).is_some()));
    let first = material(&mut app).unwrap();

    // The same pipeline with 2-unit texels, baked in place; then the reload the watcher would ask for.
    let rebaked = bake("terrain_reload_next", &job(2.0));
    for entry in std::fs::read_dir(rebaked.join("bundle")).unwrap() {
        let entry = entry.unwrap();
        std::fs::copy(entry.path(), dir.join("bundle").join(entry.file_name())).unwrap();
    }
    app.world().resource::<AssetServer>().reload("bundle/bundle.ron");
    let rebuilt =
        app.update_until(600, |w| w.get::<MeshMaterial3d<TerrainMaterial>>(terrain).is_some_and(|m| m.0 != first));
    assert!(rebuilt, "the material was not rebuilt after the reload");
    let now = material(&mut app).unwrap();
    let texel = app.world().resource::<Assets<TerrainMaterial>>().get(&now).unwrap().extension.uniform.texel_size;
    assert_eq!(texel, Vec2::splat(2.0));
}
