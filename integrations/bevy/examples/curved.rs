//! Curvature-corrected horizon shadows: the default bundle's sphere (κ = 0.015) carrying the
//! cylinder bumps, and its torus carrying the reptile cells, lit from low on the left. Bake the
//! bundle first (`cargo run --release -- bake` in the repository root); without a display the
//! frame is saved as a PNG.

#[path = "common/mod.rs"]
mod common;

use bevy::prelude::*;
use hikage_bevy::CurvedSurface;

fn main() {
    common::run("curved", |app| {
        app.add_systems(Startup, setup);
    });
}

fn setup(mut commands: Commands, assets: Res<AssetServer>) {
    let bundle: Handle<_> = assets.load("bundle/bundle.ron");
    commands.spawn((
        CurvedSurface::new(bundle.clone(), "sphere", "cylinders.horizon"),
        Transform::from_xyz(-80.0, 0.0, 0.0),
    ));
    commands.spawn((CurvedSurface::new(bundle, "torus", "reptile.horizon"), Transform::from_xyz(110.0, 0.0, 0.0)));
    commands.spawn((
        DirectionalLight { illuminance: 8_000.0, shadow_maps_enabled: true, ..default() },
        Transform::default().looking_to(Vec3::new(0.8, -0.25, -0.45), Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Projection::Perspective(PerspectiveProjection { far: 5_000.0, ..default() }),
        Transform::from_xyz(15.0, 120.0, 420.0).looking_at(Vec3::new(15.0, 0.0, 0.0), Vec3::Y),
    ));
}
