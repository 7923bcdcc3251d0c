//! A shadow map fitted to what the camera sees: a field of boxes on wide ground, the sun's
//! shadow map fitted each frame to the visible geometry and snapped to its texel grid, in place
//! of Bevy's cascades. Without a display the frame is saved as a PNG.

#[path = "common/mod.rs"]
mod common;

use bevy::prelude::*;
use hikage_bevy::FittedShadows;

fn main() {
    common::run("light_fit", |app| {
        app.add_systems(Startup, setup);
    });
}

fn setup(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>, mut materials: ResMut<Assets<StandardMaterial>>) {
    let ground = meshes.add(Plane3d::default().mesh().size(400.0, 400.0));
    let post = meshes.add(Cuboid::new(1.0, 4.0, 1.0));
    let white = materials.add(StandardMaterial { perceptual_roughness: 1.0, ..default() });
    commands.spawn((Mesh3d(ground), MeshMaterial3d(white.clone())));
    for k in 0..60 {
        let (x, z) = ((k % 6) as f32 * 6.0 - 15.0, -((k / 6) as f32) * 8.0);
        commands.spawn((Mesh3d(post.clone()), MeshMaterial3d(white.clone()), Transform::from_xyz(x, 2.0, z)));
    }
    commands.spawn((
        DirectionalLight { illuminance: 8_000.0, shadow_maps_enabled: true, ..default() },
        Transform::default().looking_to(Vec3::new(-0.6, -0.5, -0.3), Vec3::Y),
        FittedShadows::default(),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 5.0, 14.0).looking_at(Vec3::new(0.0, 0.0, -20.0), Vec3::Y),
    ));
}
