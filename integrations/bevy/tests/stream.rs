//! `StreamedTerrain` on a GPU (lavapipe in CI), on a 512² terrain the test generates and bakes
//! whole and in 64² tiles with every level of detail (4 levels): with level 0 everywhere it
//! draws what `HorizonTerrain` draws of the whole map, tile edges included; a scripted flight
//! keeps its budgets and always has terrain under the camera; a wrong map is said.

#[path = "../examples/common/mod.rs"]
mod common;

use std::path::PathBuf;

use bevy::light::NotShadowCaster;
use bevy::prelude::*;
use hikage_bevy::{
    HikageBundle, HikageError, HorizonTerrain, StreamOptions, StreamedTerrain, TerrainStreamStats, TerrainTile,
};

use common::{Headless, MaskScene, gpu_or_skip};

/// Map side, tile size and texel size (m).
const N: u32 = 512;
const TILE: u32 = 64;
const TEXEL: f32 = 30.0;

/// The generated terrain baked whole (`whole`) and in tiles with every level (`dem`).
fn bundle() -> PathBuf {
    static BAKED: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    BAKED.get_or_init(bake).clone()
}

fn bake() -> PathBuf {
    let tmp = option_env!("CARGO_TARGET_TMPDIR").map_or_else(std::env::temp_dir, PathBuf::from);
    std::fs::create_dir_all(&tmp).unwrap();
    let dem = tmp.join("stream_dem.r32");
    let heights: Vec<u8> = hikage_devkit::synth::terrain(N).into_iter().flat_map(f32::to_le_bytes).collect();
    std::fs::write(&dem, heights).unwrap();
    let job = |id: &str, tiles: &str| {
        format!(
            r#"Horizon(id: "{id}", input: "{}", texel_size: ({TEXEL}, {TEXEL}), height_scale: 1200,
               directions: 16, edge: Clamp, max_distance: 900, ao: true{tiles}),"#,
            dem.display()
        )
    };
    common::bake("stream", &format!("{} {}", job("whole", ""), job("dem", &format!(", tile: {TILE}, levels: 16"))))
}

/// A low sun from the south-west, 6° up, as the direction toward it.
fn low_sun() -> Vec3 {
    let e = 6f32.to_radians();
    Vec3::new(-0.8 * e.cos(), e.sin(), 0.6 * e.cos()).normalize()
}

/// Straight down on the whole map, one pixel a texel.
fn scene(dir: &std::path::Path) -> MaskScene {
    let half = N as f32 * TEXEL / 2.0;
    MaskScene::new(
        dir,
        N,
        low_sun(),
        Transform::from_xyz(half, 3000.0, half).looking_at(Vec3::new(half, 0.0, half), Vec3::NEG_Z),
        MaskScene::orthographic(2.0 * half, 2.0 * half, 6000.0),
    )
}

fn stats(world: &mut World, terrain: Entity) -> hikage_bevy::StreamStats {
    world.get::<TerrainStreamStats>(terrain).map(|s| s.0).unwrap_or_default()
}

#[test]
fn streamed_level_0_draws_as_the_whole_map_across_tile_edges() {
    if !gpu_or_skip("streamed_level_0_draws_as_the_whole_map_across_tile_edges") {
        return;
    }
    let dir = bundle();
    let MaskScene { mut app, target, .. } = scene(&dir);
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");

    // The whole map as one mesh.
    let whole = app
        .world()
        .spawn((HorizonTerrain::new(bundle.clone(), "whole.horizon").with_ao("whole.ao"), NotShadowCaster))
        .id();
    assert!(app.update_until(600, |w| w.get::<MeshMaterial3d<hikage_bevy::TerrainMaterial>>(whole).is_some()));
    let a = app.capture_bytes_settled(&target);
    app.world().despawn(whole);

    // The same map streamed, level 0 everywhere: every tile split down, all of them resident.
    let options =
        StreamOptions { detail: 1e9, resident_bytes: 1 << 30, upload_bytes: 1 << 30, ..StreamOptions::default() };
    let terrain =
        app.world().spawn((StreamedTerrain::new(bundle.clone(), "dem").with_options(options), NotShadowCaster)).id();
    let tiles = (N / TILE) as usize;
    let ready = app.update_until(2000, |w| {
        let s = stats(w, terrain);
        s.missing == 0 && s.finest_drawn == 0 && s.drawn == tiles * tiles
    });
    assert!(ready, "level 0 never drawn everywhere: {:?}", stats(app.world(), terrain));
    assert!(app.world().get::<HikageError>(terrain).is_none(), "{:?}", app.world().get::<HikageError>(terrain));
    let b = app.capture_bytes_settled(&target);

    // Every pixel: the map fills the view; terrain in shadow is black (no ambient light).
    let (mut differ, mut edge_pixels, mut edge_differ, mut lit) = (0, 0, 0, 0);
    for row in 0..N {
        for col in 0..N {
            let k = (row * N + col) as usize;
            lit += (a[k][..3] != [0, 0, 0]) as usize;
            let near_edge = [col, row].iter().any(|&c| matches!(c % TILE, 0 | 1 | 63));
            edge_pixels += near_edge as usize;
            let different = a[k][..3].iter().zip(&b[k][..3]).any(|(x, y)| x.abs_diff(*y) > 1);
            differ += different as usize;
            edge_differ += (different && near_edge) as usize;
        }
    }
    let all = (N * N) as usize;
    eprintln!(
        "bevy stream vs whole: {all} pixels, {:.1}% lit; {differ} differ; {edge_differ} of {edge_pixels} within a \
         pixel of a tile edge",
        100.0 * lit as f64 / all as f64
    );
    assert!((all / 5..all * 19 / 20).contains(&lit), "a low sun lights part of the map: {lit} of {all} pixels lit");
    assert_eq!(edge_differ, 0, "pixels along tile edges differ");
    assert!(differ * 1000 <= all, "{differ} of {all} pixels differ");
}

#[test]
fn a_flight_keeps_its_budgets_and_always_has_terrain_underneath() {
    if !gpu_or_skip("a_flight_keeps_its_budgets_and_always_has_terrain_underneath") {
        return;
    }
    let dir = bundle();
    let mut app = Headless::new(&dir, |app| {
        app.add_plugins(hikage_bevy::HikagePlugin);
    });
    let target = app.target(64, 64);
    let side = N as f32 * TEXEL;
    let camera = app
        .world()
        .spawn((
            Camera3d::default(),
            bevy::camera::RenderTarget::from(target),
            Transform::from_xyz(0.05 * side, 800.0, 0.05 * side),
        ))
        .id();
    app.world().spawn((
        DirectionalLight { shadow_maps_enabled: true, ..default() },
        Transform::IDENTITY.looking_to(-low_sun(), Vec3::Y),
    ));
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    // A budget of about 20 level-0 tiles (0.4 MiB each), uploads of about 2 a frame.
    let options = StreamOptions { resident_bytes: 8 << 20, upload_bytes: 1 << 20, ..StreamOptions::default() };
    let terrain = app.world().spawn(StreamedTerrain::new(bundle, "dem").with_options(options)).id();
    assert!(app.update_until(600, |w| stats(w, terrain).drawn > 0), "the coarsest level never came");

    let (mut finest, mut streamed, mut peak, mut before) = (u32::MAX, 0u64, 0u64, None::<u32>);
    let frames = 240;
    for frame in 0..frames {
        // From one corner to the other, low.
        let t = frame as f32 / (frames - 1) as f32;
        let at = Vec3::new((0.05 + 0.9 * t) * side, 800.0, (0.05 + 0.9 * t) * side);
        *app.world().get_mut::<Transform>(camera).unwrap() =
            Transform::from_translation(at).looking_at(at + Vec3::new(1.0, -0.3, 1.0), Vec3::Y);
        app.update();
        let s = stats(app.world(), terrain);
        assert!(s.resident_bytes <= options.resident_bytes, "frame {frame}: {s:?}");
        assert!(s.uploaded_bytes <= options.upload_bytes, "frame {frame}: {s:?}");
        // The camera's ground is covered by a drawn tile.
        let mut tiles = app.world().query::<(&TerrainTile, &Visibility)>();
        let under = tiles
            .iter(app.world())
            .filter(|(tile, v)| {
                let [lo, hi] = tile.rect;
                **v != Visibility::Hidden && (lo.0..=hi.0).contains(&at.x) && (lo.1..=hi.1).contains(&at.z)
            })
            .map(|(tile, _)| tile.key.0)
            .min();
        let Some(under) = under else { panic!("frame {frame}: no terrain under the camera at {at}: {s:?}") };
        // Moving about a tenth of a level-0 tile a frame, the level under the camera never falls
        // back by more than one (the parents of drawn tiles stay, the levels around the camera
        // are held one deeper before it goes deeper).
        if let Some(before) = before {
            assert!(under <= before + 1, "frame {frame}: level {before} under the camera, then {under}: {s:?}");
        }
        before = Some(under);
        finest = finest.min(s.finest_drawn);
        streamed += s.uploaded_bytes;
        peak = peak.max(s.resident_bytes);
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    assert!(app.world().get::<HikageError>(terrain).is_none(), "{:?}", app.world().get::<HikageError>(terrain));
    eprintln!(
        "bevy flight: {frames} frames, {:.1} MiB streamed, peak {:.2} MiB resident of {:.0} MiB, finest level {finest}",
        streamed as f64 / (1 << 20) as f64,
        peak as f64 / (1 << 20) as f64,
        options.resident_bytes as f64 / (1 << 20) as f64
    );
    assert_eq!(finest, 0, "level 0 was never drawn under the camera");
    assert!(streamed > options.resident_bytes, "a flight across the map streams more than the budget holds");
}

/// A map the bundle does not have, and budgets its tiles cannot meet, are said on the entity.
#[test]
fn a_wrong_map_or_budget_is_said() {
    if !gpu_or_skip("a_wrong_map_or_budget_is_said") {
        return;
    }
    let dir = bundle();
    let MaskScene { mut app, .. } = scene(&dir);
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let wrong = app.world().spawn(StreamedTerrain::new(bundle.clone(), "nope")).id();
    let tight = StreamOptions { resident_bytes: 1000, ..StreamOptions::default() };
    let small = app.world().spawn(StreamedTerrain::new(bundle.clone(), "dem").with_options(tight)).id();
    let whole = app.world().spawn(StreamedTerrain::new(bundle.clone(), "whole")).id();
    // Room for the coarsest tile and a few more (0.4 MiB each), not for the 13 that level 0
    // under the camera needs: said, and the stream still draws what the budget holds.
    let short = StreamOptions { resident_bytes: 3 << 20, ..StreamOptions::default() };
    let coarse = app.world().spawn(StreamedTerrain::new(bundle, "dem").with_options(short)).id();
    let said = |w: &mut World, e: Entity| w.get::<HikageError>(e).map(|m| m.0.clone());
    assert!(app.update_until(600, |w| [wrong, small, whole, coarse].iter().all(|&e| said(w, e).is_some())));
    let coarse_said = said(app.world(), coarse).unwrap();
    assert!(
        coarse_said.contains("3.0 MiB holds level")
            && coarse_said.contains("level 0 needs")
            && coarse_said.contains("64²"),
        "{coarse_said}"
    );
    assert!(app.update_until(600, |w| stats(w, coarse).drawn > 0), "the short budget's stream draws nothing");
    let wrong = said(app.world(), wrong).unwrap();
    assert!(wrong.contains("map `nope`") && wrong.contains("tile"), "{wrong}");
    let small = said(app.world(), small).unwrap();
    assert!(small.contains("resident budget of 1000"), "{small}");
    let whole = said(app.world(), whole).unwrap();
    assert!(whole.contains("map `whole`"), "{whole}");
}

/// Tiles stream from the manifest alone, never waiting for the bundle's other assets to be read
/// and checked: with the whole map's horizons missing from the bundle (so the bundle itself
/// never loads), the tiles still come, and the entity says what the bundle lacks.
#[test]
fn tiles_stream_without_waiting_for_the_rest_of_the_bundle() {
    if !gpu_or_skip("tiles_stream_without_waiting_for_the_rest_of_the_bundle") {
        return;
    }
    let baked = bundle();
    let dir = baked.parent().unwrap().join("stream_lacking");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("bundle")).unwrap();
    for entry in std::fs::read_dir(baked.join("bundle")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if !name.starts_with("whole.horizon.") {
            std::fs::copy(&path, dir.join("bundle").join(&name)).unwrap();
        }
    }
    let mut app = Headless::new(&dir, |app| {
        app.add_plugins(hikage_bevy::HikagePlugin);
    });
    let target = app.target(32, 32);
    let side = N as f32 * TEXEL;
    app.world().spawn((
        Camera3d::default(),
        bevy::camera::RenderTarget::from(target),
        Transform::from_xyz(0.5 * side, 800.0, 0.5 * side).looking_at(Vec3::new(0.6 * side, 0.0, 0.6 * side), Vec3::Y),
    ));
    app.world().spawn((
        DirectionalLight { shadow_maps_enabled: true, ..default() },
        Transform::IDENTITY.looking_to(-low_sun(), Vec3::Y),
    ));
    let start = std::time::Instant::now();
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let terrain = app.world().spawn(StreamedTerrain::new(bundle.clone(), "dem")).id();
    let level0 = |w: &mut World| {
        let s = stats(w, terrain);
        s.drawn > 0 && s.finest_drawn == 0
    };
    assert!(app.update_until(600, level0), "level 0 never came");
    eprintln!("level 0 drawn after {:.2} s", start.elapsed().as_secs_f64());
    let failed = |w: &mut World| w.resource::<AssetServer>().load_state(&bundle).is_failed();
    assert!(app.update_until(600, |w| failed(w) && w.get::<HikageError>(terrain).is_some()), "the load never failed");
    assert!(level0(app.world()), "the tiles stay drawn: {:?}", stats(app.world(), terrain));
    let said = app.world().get::<HikageError>(terrain).map(|e| e.0.clone()).unwrap_or_default();
    assert!(said.contains("whole.horizon"), "{said}");
}

/// A rebake under a running app (what Bevy's file watcher reports) is taken up tile by tile:
/// the tiles whose files, or whose neighbours' heights, changed — found here from the two
/// manifests — are read again and get new entities; the others keep theirs; every frame in
/// between draws level 0 everywhere; and the frame after is a fresh stream's of the edited
/// bundle.
#[test]
fn a_rebake_reloads_only_the_changed_tiles() {
    if !gpu_or_skip("a_rebake_reloads_only_the_changed_tiles") {
        return;
    }
    let (n, tile) = (256u32, 32u32);
    let tmp = option_env!("CARGO_TARGET_TMPDIR").map_or_else(std::env::temp_dir, PathBuf::from);
    std::fs::create_dir_all(&tmp).unwrap();
    let dem = tmp.join("stream_reload_dem.r32");
    let mut heights = hikage_devkit::synth::terrain(n);
    std::fs::write(&dem, heights.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
    let dir = common::bake(
        "stream_reload",
        &format!(
            r#"Horizon(id: "dem", input: "{}", texel_size: ({TEXEL}, {TEXEL}), height_scale: 300, directions: 8,
               edge: Clamp, max_distance: 300, tile: {tile}, levels: 16)"#,
            dem.display()
        ),
    );
    let half = n as f32 * TEXEL / 2.0;
    let MaskScene { mut app, target, .. } = MaskScene::new(
        &dir,
        n,
        low_sun(),
        Transform::from_xyz(half, 2000.0, half).looking_at(Vec3::new(half, 0.0, half), Vec3::NEG_Z),
        MaskScene::orthographic(2.0 * half, 2.0 * half, 4000.0),
    );
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let options =
        StreamOptions { detail: 1e9, resident_bytes: 1 << 30, upload_bytes: 1 << 30, ..StreamOptions::default() };
    let spawn = |app: &mut Headless| {
        app.world().spawn((StreamedTerrain::new(bundle.clone(), "dem").with_options(options), NotShadowCaster)).id()
    };
    let grid = (n / tile) as usize;
    let settled = |w: &mut World, terrain: Entity| {
        let s = stats(w, terrain);
        s.missing == 0 && s.finest_drawn == 0 && s.drawn == grid * grid
    };
    let tiles = |app: &mut Headless| -> std::collections::BTreeMap<(u32, u32, u32), Entity> {
        let world = app.world();
        world.query::<(Entity, &TerrainTile)>().iter(world).map(|(e, t)| (t.key, e)).collect()
    };
    let terrain = spawn(&mut app);
    assert!(app.update_until(2000, |w| settled(w, terrain)), "{:?}", stats(app.world(), terrain));
    let before_tiles = tiles(&mut app);
    let index = |dir: &std::path::Path| hikage_runtime::hikage_bundle::tile_index::TileIndex::open(dir).unwrap();
    let before = index(&dir.join("bundle"));

    // Raise a 12×12-texel square by 40 m and bake again in place.
    for y in 100..112 {
        for x in 40..52 {
            heights[y * n as usize + x] += 40.0 / 300.0;
        }
    }
    std::fs::write(&dem, heights.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
    hikage_bake::build::BuildScript::new(dir.join("pipeline.ron")).into_pipeline_output().run().unwrap();
    let after = index(&dir.join("bundle"));
    let entry = |i: &hikage_runtime::hikage_bundle::tile_index::TileIndex, part: &str, (l, x, y): (u32, u32, u32)| {
        i.tile(&format!("dem.{part}"), l, (x, y)).map(|a| a.blake3)
    };
    let changed: std::collections::BTreeSet<(u32, u32, u32)> = before_tiles
        .keys()
        .copied()
        .filter(|&(l, x, y)| {
            let moved = |k| ["height", "horizon"].iter().any(|p| entry(&before, p, k) != entry(&after, p, k));
            let side = |dx: i64, dy: i64| {
                let k = (l, (x as i64 + dx) as u32, (y as i64 + dy) as u32);
                entry(&before, "height", k) != entry(&after, "height", k)
            };
            moved((l, x, y)) || side(-1, 0) || side(1, 0) || side(0, -1) || side(0, 1)
        })
        .collect();
    assert!(!changed.is_empty() && changed.len() < before_tiles.len() / 4, "{changed:?}");

    app.world().resource::<AssetServer>().reload("bundle/bundle.ron");
    // Until every changed tile has a new entity, and the stream holds all it wants.
    let mut frames = 0;
    loop {
        app.update();
        frames += 1;
        let s = stats(app.world(), terrain);
        assert!(s.drawn == grid * grid && s.finest_drawn == 0, "a frame without level 0 everywhere: {s:?}");
        let now = tiles(&mut app);
        let renewed = changed.iter().all(|k| now.get(k).is_some_and(|e| before_tiles[k] != *e));
        if renewed && settled(app.world(), terrain) {
            let kept = before_tiles.iter().filter(|(k, e)| now.get(k) == Some(e)).count();
            eprintln!("rebake: {} tiles read again, {kept} kept, in {frames} frames", changed.len());
            assert_eq!(kept + changed.len(), before_tiles.len(), "an unchanged tile was read again");
            break;
        }
        assert!(frames < 2000, "the changed tiles were never read again");
    }
    let reloaded = app.capture_bytes_settled(&target);
    app.world().despawn(terrain);
    let fresh = spawn(&mut app);
    assert!(app.update_until(2000, |w| settled(w, fresh)), "{:?}", stats(app.world(), fresh));
    let again = app.capture_bytes_settled(&target);
    assert!(reloaded == again, "the reloaded stream draws as a fresh one");
}
