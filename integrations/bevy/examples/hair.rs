//! Hair in Bevy: the default bundle's sample head (10,000 strands) blended over the scene and
//! shaded with Kajiya-Kay, its deep opacity maps rendered from the sun each frame and shadowing
//! the head under it and a ground plane (both `HairReceiver`s), beside a plain sphere lit by
//! Bevy alone. Bake the bundle
//! first (`cargo run --release -- bake` in the repository root); without a display the frame is
//! saved as a PNG.

#[path = "common/mod.rs"]
mod common;

use bevy::prelude::*;
use hikage_bevy::hair::{HairReceiver, HairStrands};

fn main() {
    common::run("hair", |app| {
        app.add_systems(Startup, setup);
    });
}

fn setup(mut commands: Commands, assets: Res<AssetServer>, mut meshes: ResMut<Assets<Mesh>>) {
    let bundle = assets.load("bundle/bundle.ron");
    let mut hair = HairStrands::new(bundle, "head.strips");
    hair.style.root_tint = Vec3::new(0.3, 0.2, 0.14);
    hair.style.tip_tint = Vec3::new(0.7, 0.55, 0.4);
    hair.style.color_variation = 0.3;
    let hair = commands.spawn(hair).id();
    // The scalp the strands grow from: a sphere through their roots.
    let skin = StandardMaterial { base_color: Color::srgb(0.85, 0.62, 0.5), perceptual_roughness: 0.7, ..default() };
    commands.spawn((
        Mesh3d(meshes.add(Sphere::new(7.6).mesh().uv(48, 32))),
        Transform::from_xyz(0.1, 2.2, -1.7),
        HairReceiver::new(hair).with_base(skin),
    ));
    let ground = Plane3d::default().mesh().size(160.0, 160.0);
    let sand = StandardMaterial { base_color: Color::srgb(0.75, 0.7, 0.62), perceptual_roughness: 1.0, ..default() };
    commands.spawn((
        Mesh3d(meshes.add(ground)),
        Transform::from_xyz(0.0, -26.0, 0.0),
        HairReceiver::new(hair).with_base(sand),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Sphere::new(9.0))),
        MeshMaterial3d(assets.add(StandardMaterial { base_color: Color::srgb(0.3, 0.45, 0.7), ..default() })),
        Transform::from_xyz(40.0, -17.0, 10.0),
    ));
    commands.spawn((
        DirectionalLight { illuminance: 9_000.0, shadow_maps_enabled: true, ..default() },
        Transform::default().looking_to(-Vec3::new(0.45, 1.0, 0.3), Vec3::Y),
    ));
    // Bevy's default camera (MSAA 4×): the hair needs no camera setting.
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(52.0, 26.0, 72.0).looking_at(Vec3::new(6.0, -2.0, 0.0), Vec3::Y),
    ));
}
