//! Relief mapping on a game's own mesh: a cube whose faces carry the default bundle's bricks
//! (depth maps, self-shadowing and ambient occlusion) beside a plain one, under a low sun.
//! Bake the bundle first (`cargo run --release -- bake` in the repository root); without a
//! display the frame is saved as a PNG.

#[path = "common/mod.rs"]
mod common;

use bevy::prelude::*;
use hikage_bevy::ReliefSurface;

fn main() {
    common::run("relief", |app| {
        app.add_systems(Startup, setup);
    });
}

fn setup(mut commands: Commands, assets: Res<AssetServer>, mut meshes: ResMut<Assets<Mesh>>) {
    let bundle = assets.load("bundle/bundle.ron");
    let cube = Cuboid::new(2.0, 2.0, 2.0).mesh().build().with_generated_tangents().unwrap();
    let brick = StandardMaterial { base_color: Color::srgb(0.7, 0.42, 0.3), perceptual_roughness: 0.9, ..default() };
    commands.spawn((
        Mesh3d(meshes.add(cube)),
        ReliefSurface::new(bundle, "relief_bricks.relief").with_base(brick),
        Transform::from_rotation(Quat::from_rotation_y(0.6)),
    ));
    commands.spawn((
        DirectionalLight { illuminance: 8_000.0, shadow_maps_enabled: true, ..default() },
        Transform::default().looking_to(Vec3::new(-1.0, -0.45, -0.35), Vec3::Y),
    ));
    commands.spawn((Camera3d::default(), Transform::from_xyz(2.6, 2.2, 3.6).looking_at(Vec3::ZERO, Vec3::Y)));
}
