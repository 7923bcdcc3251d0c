//! Horizon-shadowed terrain: the default bundle's 512² terrain (80 m × 60 m texels) with its
//! baked horizon map and ambient occlusion, under a low sun. Bake the bundle first
//! (`cargo run --release -- bake` in the repository root); without a display the frame is
//! saved as a PNG.

#[path = "common/mod.rs"]
mod common;

use bevy::prelude::*;
use hikage_bevy::HorizonTerrain;

fn main() {
    common::run("terrain", |app| {
        app.add_systems(Startup, setup);
    });
}

// The scene: everything a game writes.
fn setup(mut commands: Commands, assets: Res<AssetServer>) {
    let bundle = assets.load("bundle/bundle.ron");
    let rock = StandardMaterial { base_color: Color::srgb(0.55, 0.5, 0.42), perceptual_roughness: 1.0, ..default() };
    commands.spawn(HorizonTerrain::new(bundle, "terrain.horizon").with_ao("terrain.ao").with_base(rock));
    commands.spawn((
        DirectionalLight { illuminance: 6_000.0, shadow_maps_enabled: true, ..default() },
        Transform::default().looking_to(Vec3::new(-1.0, -0.25, -0.5), Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Projection::Perspective(PerspectiveProjection { far: 200_000.0, ..default() }),
        Transform::from_xyz(20_000.0, 16_000.0, 50_000.0).looking_at(Vec3::new(20_000.0, 0.0, 14_000.0), Vec3::Y),
    ));
}
