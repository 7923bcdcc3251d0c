//! The curved-surface material rendered by Bevy (lavapipe in CI) against hikage-runtime's CPU
//! reference on a CPU rasterisation of the same mesh: the baked sphere with the cylinder bumps,
//! lit or shadowed by the curvature-corrected horizon test.

#[path = "../examples/common/mod.rs"]
mod common;

use bevy::light::NotShadowCaster;
use bevy::prelude::*;
use hikage_bevy::{CurvedMaterial, CurvedSurface, HikageBundle};
use hikage_runtime::CpuBundle;
use hikage_runtime::glam;
use hikage_runtime::horizon::reference::SurfaceReference;
use hikage_scenes::horizon_sphere::AnalyticSphere;
use hikage_scenes::raster::{interpolate, rasterise};

use common::{MaskScene, bake, gpu_or_skip};

const SIZE: u32 = 256;

#[test]
fn curved_sphere_matches_the_cpu_reference() {
    if !gpu_or_skip("curved_sphere_matches_the_cpu_reference") {
        return;
    }
    let dir = bake(
        "curved",
        r#"Horizon(id: "cylinders", input: "data/cylinders.png", height_scale: 4, directions: 32, edge: Wrap),
           Curvature(id: "sphere", input: "data/sphere.obj")"#,
    );
    let light = Vec3::new(-0.8, 0.25, 0.45).normalize();
    let sphere = AnalyticSphere::SAMPLE;
    let (radius, extent) = (sphere.radius, 1.05 * sphere.radius);

    let MaskScene { mut app, target, .. } = MaskScene::new(
        &dir,
        SIZE,
        light,
        Transform::from_xyz(0.0, 0.0, 2.0 * radius).looking_at(Vec3::ZERO, Vec3::Y),
        MaskScene::orthographic(2.0 * extent, 2.0 * extent, 4.0 * radius),
    );
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let surface = app.world().spawn((CurvedSurface::new(bundle, "sphere", "cylinders.horizon"), NotShadowCaster)).id();
    let built = app.update_until(600, |world| world.get::<MeshMaterial3d<CurvedMaterial>>(surface).is_some());
    assert!(built, "the curved material was not built");
    let shadowed = app.capture(&target);
    let handle = app.world().get::<MeshMaterial3d<CurvedMaterial>>(surface).unwrap().0.clone();
    app.world().resource_mut::<Assets<CurvedMaterial>>().get_mut(&handle).unwrap().extension.uniform.test = 2;
    let open = app.capture_settled(&target);

    let cpu = CpuBundle::read(&dir.join("bundle")).unwrap();
    let reference = SurfaceReference::new(&cpu, "cylinders.horizon", true).unwrap();
    let mesh = cpu.asset("sphere").unwrap().mesh().unwrap();
    let indices = mesh.read_indices().unwrap();
    let stream = |name: &str| mesh.read_f32(name).unwrap();
    let clip: Vec<glam::Vec4> = stream("position")
        .chunks_exact(3)
        .map(|p| sphere.view_proj() * glam::Vec3::from_slice(p).extend(1.0))
        .collect();
    let cover = rasterise(&clip, &indices, (SIZE, SIZE), true);
    let streams: Vec<(Vec<f32>, usize)> = [
        ("uv", 2),
        ("normal", 3),
        ("curvature", 2),
        ("principal1", 2),
        ("principal2", 2),
        ("tangent_u", 3),
        ("tangent_v", 3),
    ]
    .iter()
    .map(|&(n, c)| (stream(n), c))
    .collect();
    let l = glam::Vec3::from_array(light.to_array());
    let (mut checked, mut agree, mut lit) = (0usize, 0usize, 0usize);
    for (k, c) in cover.iter().enumerate() {
        let Some((t, w)) = *c else { continue };
        if open[k][1] < 0.02 {
            continue; // facing away from the light
        }
        let s: Vec<Vec<f32>> = streams.iter().map(|(v, n)| interpolate(v, *n, &indices, t, w)).collect();
        let v2 = |i: usize| glam::Vec2::from_slice(&s[i]);
        let v3 = |i: usize| glam::Vec3::from_slice(&s[i]);
        let reference = reference.lit(l, true, v2(0), v3(1).normalize(), v2(2), v2(3), v2(4), v3(5), v3(6));
        let bevy = shadowed[k][1] >= 0.5 * open[k][1];
        checked += 1;
        lit += reference as usize;
        agree += (reference == bevy) as usize;
    }
    let share = agree as f64 / checked as f64;
    eprintln!(
        "bevy curved: {checked} pixels, {:.1}% lit; the Bevy render agrees with the CPU reference on {:.2}%",
        100.0 * lit as f64 / checked as f64,
        100.0 * share
    );
    assert!(checked > 15_000, "{checked} lit-side pixels");
    assert!((0.1..0.95).contains(&(lit as f64 / checked as f64)), "light and shadow both");
    assert!(share >= 0.99, "{:.2}% agree", 100.0 * share);
}
