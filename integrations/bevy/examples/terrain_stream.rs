//! A terrain of any size: devkit's generated rough terrain at 4096² (30 m texels: 123 km a
//! side, 1.2 km of relief), baked on the first run in 256² tiles with every level of detail
//! (BC5 horizons, 16 directions; about four minutes on two cores, then kept), streamed by
//! `StreamedTerrain` around a camera circling 1.5 km up under a low sun. The ridges' shadows
//! run for kilometres, far past the few hundred metres Bevy's cascades cover. Without a display
//! the first frame is saved as a PNG.
//!
//! ```text
//! cargo run --example terrain_stream -- [out.png]
//! ```

#[path = "common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};

use bevy::light::NotShadowCaster;
use bevy::prelude::*;
use hikage_bevy::{StreamedTerrain, TerrainStreamStats};

/// Map side in texels and texel size (m).
const N: u32 = 4096;
const TEXEL: f32 = 30.0;

fn main() {
    let dir = bake();
    common::run_in("terrain_stream", &dir, |app| {
        app.add_systems(Startup, setup).add_systems(Update, (fly, report));
    });
}

// The scene: everything a game writes.
fn setup(mut commands: Commands, assets: Res<AssetServer>) {
    let rock = StandardMaterial { base_color: Color::srgb(0.5, 0.45, 0.36), perceptual_roughness: 1.0, ..default() };
    // The horizon map shadows the terrain: it need not cast into Bevy's cascades too.
    let terrain = StreamedTerrain::new(assets.load("bundle/bundle.ron"), "dem").with_base(rock);
    commands.spawn((terrain, NotShadowCaster));
    // The sun 4° up in the north-west.
    commands.spawn((
        DirectionalLight { illuminance: 8_000.0, shadow_maps_enabled: true, ..default() },
        Transform::default().looking_to(Vec3::new(0.7, -0.07, 0.7), Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Projection::Perspective(PerspectiveProjection { far: 250_000.0, ..default() }),
        flight(0.0),
    ));
}

/// The camera at `t` seconds: a circle of 30 km round the map's centre, 1.5 km up, looking
/// ahead and down.
fn flight(t: f32) -> Transform {
    let side = N as f32 * TEXEL;
    let angle = 0.8 + t / 60.0;
    let at = |a: f32| Vec3::new(0.5 * side + 30_000.0 * a.cos(), 1500.0, 0.5 * side + 30_000.0 * a.sin());
    let ahead = at(angle + 0.1);
    Transform::from_translation(at(angle)).looking_at(Vec3::new(ahead.x, 0.0, ahead.z), Vec3::Y)
}

/// The flight, in a window (headless, the first frame is kept still for its picture).
fn fly(time: Res<Time>, windows: Query<(), With<Window>>, mut cameras: Query<&mut Transform, With<Camera3d>>) {
    if windows.is_empty() {
        return;
    }
    for mut camera in &mut cameras {
        *camera = flight(time.elapsed_secs());
    }
}

/// What the stream holds, once a second.
fn report(time: Res<Time>, mut last: Local<f32>, terrains: Query<&TerrainStreamStats>) {
    if time.elapsed_secs() - *last < 1.0 {
        return;
    }
    *last = time.elapsed_secs();
    for s in &terrains {
        info!(
            "{} tiles drawn (finest level {}), {} resident in {:.1} MiB, {} wanted still loading",
            s.0.drawn,
            s.0.finest_drawn,
            s.0.resident_tiles,
            s.0.resident_bytes as f64 / (1 << 20) as f64,
            s.0.missing
        );
    }
}

/// Generates the terrain and bakes it (the bake skips what is already baked); returns the
/// directory whose `bundle/` holds it.
fn bake() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/terrain_stream");
    std::fs::create_dir_all(&dir).unwrap();
    let dem = dir.join("dem.r32");
    if !dem.exists() {
        let heights: Vec<u8> = hikage_devkit::synth::terrain(N).into_iter().flat_map(f32::to_le_bytes).collect();
        std::fs::write(&dem, heights).unwrap();
    }
    let pipeline = format!(
        r#"(output: "bundle", jobs: [Horizon(id: "dem", input: "dem.r32", texel_size: ({TEXEL}, {TEXEL}),
            height_scale: 1200, directions: 16, edge: Clamp, max_distance: 4000, ao: true, format: Bc5RgUnorm,
            tile: 256, levels: 16)])"#
    );
    std::fs::write(dir.join("pipeline.ron"), pipeline).unwrap();
    println!("terrain_stream: baking {N}² in 256² tiles with every level (kept for later runs)…");
    hikage_bake::build::BuildScript::new(dir.join("pipeline.ron")).into_pipeline_output().run().unwrap();
    dir
}
