//! A directional light whose shadow map is fitted to the visible geometry, rendered by Bevy
//! (lavapipe in CI): the shadow a box casts on the ground agrees with a ray-cast reference.

#[path = "../examples/common/mod.rs"]
mod common;

use bevy::light::{CascadeShadowConfig, Cascades};
use bevy::prelude::*;
use hikage_bevy::FittedShadows;

use common::{MaskScene, gpu_or_skip};

const SIZE: u32 = 256;
const BOX_MIN: Vec3 = Vec3::new(-1.0, 0.0, -1.0);
const BOX_MAX: Vec3 = Vec3::new(1.0, 4.0, 1.0);

/// The entry and exit lengths of ray (`o`, `d`) through the box, if it crosses it.
fn box_hit(o: Vec3, d: Vec3) -> Option<(f32, f32)> {
    let inv = d.recip();
    let (a, b) = ((BOX_MIN - o) * inv, (BOX_MAX - o) * inv);
    let (near, far) = (a.min(b).max_element(), a.max(b).min_element());
    (near <= far && far > 0.0).then_some((near, far))
}

#[test]
fn fitted_shadow_of_a_box_matches_a_ray_cast() {
    if !gpu_or_skip("fitted_shadow_of_a_box_matches_a_ray_cast") {
        return;
    }
    let sun = Vec3::new(1.0, 0.5, 0.6).normalize();
    let eye = Vec3::new(-4.0, 7.0, 9.0);
    let view = Transform::from_translation(eye).looking_at(Vec3::new(-3.0, 0.0, -1.0), Vec3::Y);
    let MaskScene { mut app, target, light } =
        MaskScene::new(&std::env::temp_dir(), SIZE, sun, view, Projection::default());
    let world = app.world();
    world.entity_mut(light).insert(FittedShadows::default());
    let ground = world.resource_mut::<Assets<Mesh>>().add(Plane3d::default().mesh().size(200.0, 200.0).build());
    let cube = world.resource_mut::<Assets<Mesh>>().add(Cuboid::from_corners(BOX_MIN, BOX_MAX)); // centred on the origin
    let white = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial { perceptual_roughness: 1.0, ..default() });
    world.spawn((Mesh3d(ground), MeshMaterial3d(white.clone())));
    world.spawn((Mesh3d(cube), MeshMaterial3d(white), Transform::from_translation((BOX_MIN + BOX_MAX) / 2.0)));
    app.update_until(10, |_| false);
    let shadowed = app.capture(&target);
    let world = app.world();
    assert_eq!(world.get::<CascadeShadowConfig>(light).unwrap().bounds.len(), 1, "one fitted cascade");
    let cascades = &world.get::<Cascades>(light).unwrap().cascades;
    assert!(cascades.values().all(|c| c.len() == 1), "one map per view");
    world.get_mut::<DirectionalLight>(light).unwrap().shadow_maps_enabled = false;
    let open = app.capture_settled(&target);

    let (mut checked, mut agree, mut dark, mut dark_found) = (0usize, 0usize, 0usize, 0usize);
    for row in 0..SIZE {
        for col in 0..SIZE {
            let ray = app.pixel_ray(col, row);
            let (o, d) = (ray.origin, *ray.direction);
            let t = -o.y / d.y;
            if t <= 0.0 || box_hit(o, d).is_some_and(|(near, _)| near < t) {
                continue; // sky, or the box itself
            }
            let k = (row * SIZE + col) as usize;
            if open[k][1] < 0.02 {
                continue;
            }
            let reference = box_hit(o + t * d, sun).is_some();
            let bevy = shadowed[k][1] < 0.5 * open[k][1];
            checked += 1;
            dark += reference as usize;
            dark_found += (reference && bevy) as usize;
            agree += (reference == bevy) as usize;
        }
    }
    let share = agree as f64 / checked as f64;
    eprintln!(
        "fitted shadow: {checked} ground pixels, {:.1}% in the box's shadow ({:.1}% of them dark in Bevy); \
         Bevy agrees with the ray cast on {:.2}%",
        100.0 * dark as f64 / checked as f64,
        100.0 * dark_found as f64 / dark as f64,
        100.0 * share
    );
    assert!(checked > 20_000, "{checked} ground pixels");
    assert!(dark as f64 > 0.05 * checked as f64, "the box's shadow is in view");
    assert!(dark_found as f64 > 0.95 * dark as f64, "the shadow is drawn");
    assert!(share >= 0.98, "{:.2}% agree", 100.0 * share);
}
