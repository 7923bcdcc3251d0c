//! A mesh in the terrain's far shadow (`TerrainReceiver`), rendered by Bevy on a GPU (lavapipe in
//! CI): a sheet of water at a fixed height over the sample terrain, seen from above, against
//! hikage-runtime's CPU reference of the same test (`horizon_raised_sun_visible`) and against an
//! exact march from each pixel's world point; and the receivers' mistakes said on the entity.

#[path = "../examples/common/mod.rs"]
mod common;

use bevy::light::{NotShadowCaster, SunDisk};
use bevy::prelude::*;
use hikage_bevy::{
    FieldReceiverMaterial, HikageBundle, HikageError, HorizonTerrain, StreamOptions, StreamedTerrain, TerrainReceiver,
    TerrainReceiverMaterial, TerrainStreamStats,
};
use hikage_devkit::brute_force::{bilinear_height, sun_shadow_height};
use hikage_runtime::CpuBundle;
use hikage_runtime::glam;
use hikage_runtime::horizon::reference::{HorizonMap, horizon_raised_sun_visible};

use common::{MaskScene, bake, gpu_or_skip};

const SIZE: u32 = 384;
/// The sheet's height (m): above about half the sample terrain.
const WATER: f32 = 700.0;

/// The pixels of the sheet that stand above the ground are lit as the CPU reference of the
/// shader's test says (≥ 99%; 99.61% measured) and agree with the exact march as often as that
/// reference does, within half a point (97.0% measured, a 5° sun over valleys where the sheet
/// lies close to its shadow's top). Bevy's cascades, 150 m from a camera 4 km up, leave these
/// pixels to the terrain's shadow alone.
#[test]
fn a_receiver_is_shadowed_by_the_far_terrain_as_the_cpu_reference_says() {
    if !gpu_or_skip("a_receiver_is_shadowed_by_the_far_terrain_as_the_cpu_reference_says") {
        return;
    }
    let dir = bake(
        "receiver",
        r#"Horizon(id: "terrain", input: "data/terrain.png", texel_size: (80, 60), height_scale: 1500,
               directions: 32, edge: Clamp)"#,
    );
    let (w, h, sx, sy) = (512usize, 512usize, 80.0f32, 60.0f32);
    let (ex, ez) = (w as f32 * sx, h as f32 * sy);
    // The sun low, between +x (u) and +z (v).
    let (elevation, azimuth) = (5f32.to_radians(), 30f32.to_radians());
    let sun = Vec3::new(elevation.cos() * azimuth.cos(), elevation.sin(), elevation.cos() * azimuth.sin());
    let MaskScene { mut app, target, .. } = MaskScene::new(
        &dir,
        SIZE,
        sun,
        Transform::from_xyz(ex / 2.0, 4000.0, ez / 2.0).looking_at(Vec3::new(ex / 2.0, 0.0, ez / 2.0), Vec3::NEG_Z),
        MaskScene::orthographic(ex, ez, 10_000.0),
    );
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    // The terrain shadows the sheet but is not drawn over it.
    let terrain =
        app.world().spawn((HorizonTerrain::new(bundle, "terrain.horizon"), NotShadowCaster, Visibility::Hidden)).id();
    let water = spawn_sheet(&mut app, terrain, (ex, ez), WATER, StandardMaterial::default());
    let shadowed = app.capture_settled(&target);
    shadow_off(&mut app, water);
    let open = app.capture_settled(&target);
    let (map, heights) = map_and_heights(&dir, "terrain");
    let bump_sun = glam::Vec3::new(sun.x, sun.z, sun.y);
    let radius = 0.5 * SunDisk::EARTH.angular_size;
    let reach = (ex).hypot(ez);
    let (mut checked, mut same, mut marched, mut lit, mut rule) = (0usize, 0usize, 0usize, 0usize, 0usize);
    for row in 0..SIZE {
        for col in 0..SIZE {
            let k = (row * SIZE + col) as usize;
            // The camera looks down with +z at the bottom of the image.
            let (x, z) = ((col as f32 + 0.5) / SIZE as f32 * ex, (row as f32 + 0.5) / SIZE as f32 * ez);
            let Some(ground) = bilinear_height(&heights, (w, h), (sx, sy), (x, z)) else { continue };
            if WATER < ground + 1.0 || open[k][1] < 0.02 {
                continue; // under the terrain: no water there in a game
            }
            let uv = glam::Vec2::new(x / ex, z / ez);
            let above = WATER - ground;
            let reference =
                horizon_raised_sun_visible(&map, uv, bump_sun, glam::Vec2::new(sx, sy), above, reach, radius) >= 0.5;
            let exact = WATER > sun_shadow_height(&heights, (w, h), (sx, sy), (x, z), (elevation, azimuth), reach);
            let bevy = shadowed[k][1] >= 0.5 * open[k][1];
            checked += 1;
            lit += bevy as usize;
            same += (reference == bevy) as usize;
            marched += (exact == bevy) as usize;
            rule += (exact == reference) as usize;
        }
    }
    let share = |n: usize| n as f64 / checked as f64;
    eprintln!(
        "bevy receiver: {checked} pixels of water above the ground, {:.1}% lit; agrees with the CPU reference on \
         {:.2}%, with the exact march on {:.2}% (the CPU reference with the march: {:.2}%)",
        100.0 * share(lit),
        100.0 * share(same),
        100.0 * share(marched),
        100.0 * share(rule)
    );
    assert!(checked > 30_000, "{checked} pixels of water");
    assert!((0.2..0.95).contains(&share(lit)), "a low sun casts long shadows on the water");
    assert!(share(same) >= 0.99, "{:.2}% agree with the CPU reference", 100.0 * share(same));
    assert!(share(marched) >= share(rule) - 0.005, "{:.2}% agree with the march", 100.0 * share(marched));
    assert!(share(rule) >= 0.96, "the rule agrees with the march on {:.2}%", 100.0 * share(rule));
}

/// A sheet of water `ex` × `ez` at height `y` over the terrain on entity `terrain`, a
/// `TerrainReceiver` over `base`, built: its entity.
fn spawn_sheet(
    app: &mut common::Headless,
    terrain: Entity,
    (ex, ez): (f32, f32),
    y: f32,
    base: StandardMaterial,
) -> Entity {
    let sheet = app.world().resource_mut::<Assets<Mesh>>().add(Plane3d::default().mesh().size(ex, ez));
    let receiver = TerrainReceiver::new(terrain).with_base(base);
    let water =
        app.world().spawn((Mesh3d(sheet), Transform::from_xyz(ex / 2.0, y, ez / 2.0), NotShadowCaster, receiver)).id();
    let built = app.update_until(600, |w| {
        w.get::<MeshMaterial3d<TerrainReceiverMaterial>>(water).is_some()
            || w.get::<MeshMaterial3d<FieldReceiverMaterial>>(water).is_some()
    });
    assert!(built, "the receiver was not built: {:?}", app.world().get::<HikageError>(water));
    water
}

/// Turns receiver `water`'s terrain shadow off.
fn shadow_off(app: &mut common::Headless, water: Entity) {
    let material = app.world().get::<MeshMaterial3d<TerrainReceiverMaterial>>(water).unwrap().0.clone();
    let mut materials = app.world().resource_mut::<Assets<TerrainReceiverMaterial>>();
    materials.get_mut(&material).unwrap().extension.uniform.shadow = 0;
}

/// Job `job`'s horizon map (sampled as the GPU does) and world heights, from the bundle in `dir`.
fn map_and_heights(dir: &std::path::Path, job: &str) -> (HorizonMap, Vec<f32>) {
    let cpu = CpuBundle::read_prefix(&dir.join("bundle"), &format!("{job}.")).unwrap();
    let asset = cpu.asset(&format!("{job}.horizon")).unwrap();
    let map = HorizonMap::new(asset.texture().unwrap(), asset.asset.settings.horizon().unwrap(), true).unwrap();
    let heights = cpu.asset(&format!("{job}.height")).unwrap();
    let settings = heights.asset.settings.heightfield().unwrap();
    (map, heights.texture().unwrap().to_f32(0).iter().map(|&v| settings.world_height(v)).collect())
}

/// A receiver says what is wrong (a terrain entity that is none, no mesh) and is drawn once it
/// is fixed; a receiver of a streamed terrain reads its field, and moves to a one-mesh terrain
/// when it names one.
#[test]
fn receiver_mistakes_are_said_on_the_entity() {
    if !gpu_or_skip("receiver_mistakes_are_said_on_the_entity") {
        return;
    }
    let dir = bake(
        "receiver_mistakes",
        r#"Horizon(id: "t", input: "data/cylinders.png", texel_size: (1, 1), height_scale: 4, directions: 8, edge: Clamp),
           Horizon(id: "s", input: "data/cylinders.png", texel_size: (1, 1), height_scale: 4, directions: 8, edge: Clamp,
                   max_distance: 40, tile: 64, levels: 16)"#,
    );
    let MaskScene { mut app, .. } = MaskScene::new(
        &dir,
        32,
        Vec3::Y,
        Transform::from_xyz(64.0, 200.0, 64.0).looking_at(Vec3::new(64.0, 0.0, 64.0), Vec3::NEG_Z),
        default(),
    );
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let nothing = app.world().spawn(Transform::default()).id();
    let streamed = app.world().spawn(StreamedTerrain::new(bundle.clone(), "s")).id();
    let terrain = app.world().spawn(HorizonTerrain::new(bundle, "t.horizon")).id();
    let plane = app.world().resource_mut::<Assets<Mesh>>().add(Plane3d::default().mesh().size(2.0, 2.0));
    let to_nothing = app.world().spawn((Mesh3d(plane.clone()), TerrainReceiver::new(nothing))).id();
    let to_stream = app.world().spawn((Mesh3d(plane.clone()), TerrainReceiver::new(streamed))).id();
    let no_mesh = app.world().spawn(TerrainReceiver::new(terrain)).id();
    let error = |app: &mut common::Headless, e: Entity| app.world().get::<HikageError>(e).map(|e| e.0.clone());
    let said = app.update_until(600, |w| {
        [to_nothing, no_mesh].iter().all(|&e| w.get::<HikageError>(e).is_some())
            && w.get::<MeshMaterial3d<FieldReceiverMaterial>>(to_stream).is_some()
    });
    assert!(said, "{:?} {:?} {:?}", error(&mut app, to_nothing), error(&mut app, to_stream), error(&mut app, no_mesh));
    assert!(error(&mut app, to_nothing).is_some_and(|m| m.contains("has no HorizonTerrain or StreamedTerrain")));
    assert!(error(&mut app, to_stream).is_none());
    assert!(error(&mut app, no_mesh).is_some_and(|m| m.contains("no Mesh3d")));
    // Fixed: the receivers name the terrain, the last gets a mesh.
    app.world().get_mut::<TerrainReceiver>(to_nothing).unwrap().terrain = terrain;
    app.world().get_mut::<TerrainReceiver>(to_stream).unwrap().terrain = terrain;
    app.world().entity_mut(no_mesh).insert(Mesh3d(plane));
    let cleared = app.update_until(200, |w| {
        [to_nothing, to_stream, no_mesh].iter().all(|&e| {
            w.get::<HikageError>(e).is_none()
                && w.get::<MeshMaterial3d<TerrainReceiverMaterial>>(e).is_some()
                && w.get::<MeshMaterial3d<FieldReceiverMaterial>>(e).is_none()
        })
    });
    assert!(
        cleared,
        "{:?} {:?} {:?}",
        error(&mut app, to_nothing),
        error(&mut app, to_stream),
        error(&mut app, no_mesh)
    );
}

/// Bevy's cascades and the terrain's far shadow together, on a sheet of water over a small
/// terrain (1 km, 40 m of relief) seen from a camera 25 m above it, across the end of the
/// cascades (150 m): near the camera the terrain's shadow is drawn by both and not darkened
/// twice (the darker of the two, not their product); past the end the far shadow alone, with the
/// same agreement with the exact march on both sides of it (no seam).
#[test]
fn a_receiver_composes_with_the_cascades_without_a_seam() {
    if !gpu_or_skip("a_receiver_composes_with_the_cascades_without_a_seam") {
        return;
    }
    let dir = bake(
        "receiver_cascades",
        r#"Horizon(id: "small", input: "data/terrain.png", texel_size: (2, 1.5), height_scale: 40,
               directions: 32, edge: Clamp)"#,
    );
    let (w, h, sx, sy) = (512usize, 512usize, 2.0f32, 1.5f32);
    let (ex, ez) = (w as f32 * sx, h as f32 * sy);
    let water = 22.0;
    let (elevation, azimuth) = (6f32.to_radians(), 100f32.to_radians());
    let sun = Vec3::new(elevation.cos() * azimuth.cos(), elevation.sin(), elevation.cos() * azimuth.sin());
    let eye = Vec3::new(60.0, water + 25.0, 0.5 * ez);
    let MaskScene { mut app, target, light } = MaskScene::new(
        &dir,
        SIZE,
        sun,
        Transform::from_translation(eye).looking_at(Vec3::new(700.0, water - 40.0, 0.5 * ez), Vec3::Y),
        Projection::default(),
    );
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let terrain = app.world().spawn(HorizonTerrain::new(bundle, "small.horizon")).id();
    let blue = StandardMaterial {
        base_color: Color::srgb(0.1, 0.2, 0.9),
        perceptual_roughness: 1.0,
        reflectance: 0.0,
        ..default()
    };
    let receiver = spawn_sheet(&mut app, terrain, (ex, ez), water, blue);
    // Both shadows; the cascades' alone; none (the water's full light).
    let both = app.capture_settled(&target);
    shadow_off(&mut app, receiver);
    let cascades = app.capture_settled(&target);
    app.world().get_mut::<DirectionalLight>(light).unwrap().shadow_maps_enabled = false;
    let open = app.capture_settled(&target);
    let (map, heights) = map_and_heights(&dir, "small");
    let bump_sun = glam::Vec3::new(sun.x, sun.z, sun.y);
    let radius = 0.5 * SunDisk::EARTH.angular_size;
    let reach = ex.hypot(ez);
    let forward = (Vec3::new(700.0, water - 40.0, 0.5 * ez) - eye).normalize();
    // Per band of distance from the camera: pixels, agreeing with the march, |drawn − the darker
    // of the two|, pixels the product would darken by more than 0.1 past the darker.
    let bands = [(30.0, 100.0), (100.0, 150.0), (150.0, 250.0), (250.0, 700.0)];
    let mut tally = [(0usize, 0usize, 0.0f64, 0usize, 0usize); 4];
    for row in 0..SIZE {
        for col in 0..SIZE {
            let k = (row * SIZE + col) as usize;
            if open[k][2] < 2.0 * open[k][0] + 0.02 {
                continue; // not the water: the terrain, or the sky
            }
            let ray = app.pixel_ray(col, row);
            let t = (water - ray.origin.y) / ray.direction.y;
            if t <= 0.0 {
                continue;
            }
            let p = ray.origin + *ray.direction * t;
            let Some(ground) = bilinear_height(&heights, (w, h), (sx, sy), (p.x, p.z)) else { continue };
            let depth = (p - eye).dot(forward);
            let Some(band) = bands.iter().position(|&(a, b)| (a..b).contains(&depth)) else { continue };
            let uv = glam::Vec2::new(p.x / ex, p.z / ez);
            let far =
                horizon_raised_sun_visible(&map, uv, bump_sun, glam::Vec2::new(sx, sy), water - ground, reach, radius);
            let lit = water > sun_shadow_height(&heights, (w, h), (sx, sy), (p.x, p.z), (elevation, azimuth), reach);
            let (drawn, cascade) = (both[k][2] / open[k][2], (cascades[k][2] / open[k][2]).min(1.0));
            let t = &mut tally[band];
            t.0 += 1;
            t.1 += usize::from((drawn > 0.5) == lit);
            t.2 += f64::from((drawn - cascade.min(far)).abs());
            t.3 += usize::from(cascade * far < cascade.min(far) - 0.1);
            t.4 += usize::from(drawn <= 0.5);
        }
    }
    for (&(a, b), &(n, agree, off, product, dark)) in bands.iter().zip(&tally) {
        eprintln!(
            "{a}–{b} m: {n} pixels of water, {:.1}% in shadow; {:.2}% agree with the march; drawn within {:.4} of the \
             darker shadow on average; the product would darken {:.2}% by more than 0.1",
            100.0 * dark as f64 / n.max(1) as f64,
            100.0 * agree as f64 / n.max(1) as f64,
            off / n.max(1) as f64,
            100.0 * product as f64 / n.max(1) as f64
        );
    }
    let share = |i: usize| tally[i].1 as f64 / tally[i].0.max(1) as f64;
    assert!(
        tally.iter().all(|t| t.0 > 500 && t.4 * 20 > t.0),
        "every band has water, a twentieth in shadow: {tally:?}"
    );
    assert!(
        (share(1) - share(2)).abs() <= 0.02,
        "no seam at the cascades' end: {} inside, {} past",
        share(1),
        share(2)
    );
    assert!(tally.iter().all(|t| t.2 / (t.0 as f64) < 0.05), "{tally:?}");
    for (i, band) in bands.iter().enumerate() {
        assert!(share(i) >= 0.95, "{band:?}: {}", share(i));
    }
}

/// A streamed terrain's receivers (the terrain's sun field in Bevy's render world): a sheet of
/// water over a generated 41 km terrain baked whole and in 64² tiles, seen from above at a 4°
/// sun. Streamed at level 0 everywhere, its pixels agree with the one-mesh terrain's receiver
/// and with the exact march as well as that receiver does; streamed with coarser tiles away from
/// the camera, within a point of that.
#[test]
fn a_streamed_terrains_receivers_agree_with_the_one_mesh_terrains() {
    if !gpu_or_skip("a_streamed_terrains_receivers_agree_with_the_one_mesh_terrains") {
        return;
    }
    const N: usize = 512;
    const TEXEL: f32 = 80.0;
    const RELIEF: f32 = 1800.0;
    const REACH: f32 = 15_000.0;
    let tmp = option_env!("CARGO_TARGET_TMPDIR").map_or_else(std::env::temp_dir, std::path::PathBuf::from);
    std::fs::create_dir_all(&tmp).unwrap();
    let dem = tmp.join("receiver_stream_dem.r32");
    let samples = hikage_devkit::synth::terrain(N as u32);
    std::fs::write(&dem, samples.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
    let job = |id: &str, tiles: &str| {
        format!(
            r#"Horizon(id: "{id}", input: "{}", texel_size: ({TEXEL}, {TEXEL}), height_scale: {RELIEF},
               directions: 32, edge: Clamp, max_distance: {REACH}{tiles}),"#,
            dem.display()
        )
    };
    let dir = bake("receiver_stream", &format!("{} {}", job("whole", ""), job("dem", ", tile: 64, levels: 16")));
    let heights: Vec<f32> = samples.iter().map(|v| v * RELIEF).collect();
    let mut sorted = heights.clone();
    sorted.sort_by(f32::total_cmp);
    let water = sorted[N * N / 2];
    let extent = N as f32 * TEXEL;
    let (elevation, azimuth) = (4f32.to_radians(), 30f32.to_radians());
    let sun = Vec3::new(elevation.cos() * azimuth.cos(), elevation.sin(), elevation.cos() * azimuth.sin());
    let centre = Vec3::new(extent / 2.0, 0.0, extent / 2.0);
    let MaskScene { mut app, target, .. } = MaskScene::new(
        &dir,
        SIZE,
        sun,
        Transform::from_translation(centre + Vec3::Y * 6000.0).looking_at(centre, Vec3::NEG_Z),
        MaskScene::orthographic(extent, extent, 12_000.0),
    );
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    // The terrains shadow the sheet but are not drawn over it.
    let whole = app
        .world()
        .spawn((HorizonTerrain::new(bundle.clone(), "whole.horizon"), NotShadowCaster, Visibility::Hidden))
        .id();
    let sheet = spawn_sheet(&mut app, whole, (extent, extent), water, StandardMaterial::default());
    let one_mesh = app.capture_settled(&target);
    shadow_off(&mut app, sheet);
    let open = app.capture_settled(&target);
    // The same sheet naming the stream: level 0 everywhere, then as a game streams.
    let streamed = |app: &mut common::Headless, options: StreamOptions| {
        let terrain = app
            .world()
            .spawn((
                StreamedTerrain::new(bundle.clone(), "dem").with_options(options),
                NotShadowCaster,
                Visibility::Hidden,
            ))
            .id();
        app.world().get_mut::<TerrainReceiver>(sheet).unwrap().terrain = terrain;
        let settled = app.update_until(3000, |w| {
            let s = w.get::<TerrainStreamStats>(terrain).map(|s| s.0).unwrap_or_default();
            s.drawn > 0 && s.missing == 0 && w.get::<MeshMaterial3d<FieldReceiverMaterial>>(sheet).is_some()
        });
        assert!(settled, "the stream never settled: {:?}", app.world().get::<HikageError>(terrain));
        assert!(app.world().get::<HikageError>(sheet).is_none(), "{:?}", app.world().get::<HikageError>(sheet));
        let pixels = app.capture_settled(&target);
        let stats = app.world().get::<TerrainStreamStats>(terrain).unwrap().0;
        app.world().despawn(terrain);
        (pixels, stats)
    };
    let all_level_0 =
        StreamOptions { detail: 1e9, resident_bytes: 1 << 30, upload_bytes: 1 << 30, ..StreamOptions::default() };
    let (level_0, stats) = streamed(&mut app, all_level_0);
    assert_eq!(stats.drawn, 64, "level 0 everywhere: {stats:?}");
    // Fine tiles only near the camera, over the map's centre: coarser ones over most of it.
    let (as_a_game, stats) = streamed(&mut app, StreamOptions { detail: 0.5, ..StreamOptions::default() });
    assert!(stats.finest_drawn == 0 && stats.drawn < 30, "coarser tiles far away: {stats:?}");
    // Per pixel of water above the ground: lit by the march, by the one-mesh receiver, by each stream.
    let (mut checked, mut lit, mut agree) = (0usize, 0usize, [0usize; 5]);
    for row in 0..SIZE {
        for col in 0..SIZE {
            let k = (row * SIZE + col) as usize;
            let (x, z) = ((col as f32 + 0.5) / SIZE as f32 * extent, (row as f32 + 0.5) / SIZE as f32 * extent);
            let Some(ground) = bilinear_height(&heights, (N, N), (TEXEL, TEXEL), (x, z)) else { continue };
            if water < ground + 1.0 || open[k][1] < 0.02 {
                continue;
            }
            let exact =
                water > sun_shadow_height(&heights, (N, N), (TEXEL, TEXEL), (x, z), (elevation, azimuth), REACH);
            let drawn = |pixels: &[[f32; 3]]| pixels[k][1] >= 0.5 * open[k][1];
            checked += 1;
            lit += usize::from(exact);
            agree[0] += usize::from(drawn(&one_mesh) == exact);
            agree[1] += usize::from(drawn(&level_0) == exact);
            agree[2] += usize::from(drawn(&as_a_game) == exact);
            agree[3] += usize::from(drawn(&level_0) == drawn(&one_mesh));
            agree[4] += usize::from(drawn(&level_0) == drawn(&as_a_game));
        }
    }
    let share = |n: usize| n as f64 / checked as f64;
    eprintln!(
        "streamed receivers: {checked} pixels of water above the ground, {:.1}% lit by the march; agree with the \
         march: one mesh {:.2}%, stream at level 0 {:.2}%, stream with coarser tiles far away {:.2}%; level 0 with one mesh \
         {:.2}%, with the stream with coarser tiles far away {:.2}%",
        100.0 * share(lit),
        100.0 * share(agree[0]),
        100.0 * share(agree[1]),
        100.0 * share(agree[2]),
        100.0 * share(agree[3]),
        100.0 * share(agree[4])
    );
    assert!(checked > 30_000, "{checked} pixels of water");
    assert!((0.2..0.95).contains(&share(lit)), "a low sun casts long shadows on the water");
    assert!(share(agree[1]) >= share(agree[0]) - 0.005, "level 0 against the march");
    assert!(share(agree[2]) >= share(agree[0]) - 0.01, "coarser tiles far away, against the march");
    assert!(share(agree[3]) >= 0.97, "level 0 against one mesh");
}
