//! hikage-bevy says what is wrong, on the entity: hostile bundles under a running app (at first
//! load and at hot reload: truncated KTX2 and mesh payloads, wrong hashes, a deleted payload,
//! manifests that do not parse or are of a newer format, an asset that changes kind between
//! bakes) never panic, leave the last good terrain drawn pixel for pixel, and put a
//! `HikageError` naming the cause on the entity until a good bake loads; and the mistakes a game
//! makes — a relief mesh without tangents or without a mesh, a sun without shadow maps, another
//! map's AO — are each said, or made to work.

#[path = "../examples/common/mod.rs"]
mod common;

use std::collections::BTreeMap;
use std::path::Path;

use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use hikage_bevy::{HikageBundle, HikageError, HorizonTerrain, ReliefMaterial, ReliefSurface, TerrainMaterial};

use common::{Headless, MaskScene, bake, gpu_or_skip};

/// A hostile case: its name, the bundle's files, words its error must hold.
type Case<'a> = (&'a str, BTreeMap<String, Vec<u8>>, Vec<&'a str>);

/// The files of the bundle in `dir`, by name.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| e.file_type().unwrap().is_file() && !e.file_name().to_string_lossy().starts_with('.'))
        .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap()))
        .collect()
}

/// Writes `files` into `dir` (created if need be).
fn put(dir: &Path, files: &BTreeMap<String, Vec<u8>>) {
    std::fs::create_dir_all(dir).unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
}

/// The name of the payload of asset `id` among `files`.
fn payload(files: &BTreeMap<String, Vec<u8>>, id: &str) -> String {
    files.keys().find(|k| k.starts_with(&format!("{id}.")) && !k.ends_with(".ron")).unwrap().clone()
}

/// `files` with the payload of `id` cut to half its length, and, with `matched`, the
/// manifest's length and hash made to match it (so the payload's own reader must catch it).
fn truncated(files: &BTreeMap<String, Vec<u8>>, id: &str, matched: bool) -> BTreeMap<String, Vec<u8>> {
    let mut out = files.clone();
    let name = payload(files, id);
    let old = files[&name].clone();
    let new = old[..old.len() / 2].to_vec();
    if matched {
        let manifest = String::from_utf8(files["bundle.ron"].clone()).unwrap();
        let manifest = manifest
            .replace(&format!("byte_length: {},", old.len()), &format!("byte_length: {},", new.len()))
            .replace(blake3::hash(&old).to_hex().as_str(), blake3::hash(&new).to_hex().as_str());
        out.insert("bundle.ron".into(), manifest.into_bytes());
    }
    out.insert(name, new);
    out
}

/// Frames until `entity`'s `HikageError` contains every one of `words`; its text.
fn error_saying(app: &mut Headless, entity: Entity, words: &[&str]) -> String {
    let said =
        |world: &mut World| world.get::<HikageError>(entity).is_some_and(|e| words.iter().all(|w| e.0.contains(w)));
    let found = app.update_until(300, said);
    let now = app.world().get::<HikageError>(entity).map(|e| e.0.clone());
    assert!(found, "expected an error saying {words:?}, found {now:?}");
    now.unwrap()
}

#[test]
fn hostile_bundles_at_first_load_and_at_hot_reload() {
    if !gpu_or_skip("hostile_bundles_at_first_load_and_at_hot_reload") {
        return;
    }
    let dir = bake(
        "diagnostics_hostile",
        r#"Horizon(id: "terrain", input: "data/cylinders.png", height_scale: 4, directions: 8, edge: Clamp, ao: true),
           Curvature(id: "sphere", input: "data/sphere.obj")"#,
    );
    // Another bake where `terrain.horizon` is a heightfield.
    let other = bake("diagnostics_kind", r#"Heightfield(id: "terrain.horizon", input: "data/cylinders.png")"#);
    let bundle_dir = dir.join("bundle");
    let good = files(&bundle_dir);
    let changed_kind = files(&other.join("bundle"));
    let manifest = String::from_utf8(good["bundle.ron"].clone()).unwrap();
    let mut flipped = good.clone();
    let ao = payload(&good, "terrain.ao");
    let at = flipped[&ao].len() - 1;
    flipped.get_mut(&ao).unwrap()[at] ^= 0x40;
    let mut unparsable = good.clone();
    unparsable.insert("bundle.ron".into(), manifest.as_bytes()[..manifest.len() / 3].to_vec());
    let mut newer = good.clone();
    newer.insert("bundle.ron".into(), manifest.replacen("major: 1,", "major: 2,", 1).into_bytes());
    let hostile: Vec<Case> = vec![
        (
            "a truncated KTX2 payload",
            truncated(&good, "terrain.horizon", false),
            vec!["`terrain.horizon`", "the manifest says"],
        ),
        (
            "a truncated KTX2 payload its manifest matches",
            truncated(&good, "terrain.horizon", true),
            vec!["`terrain.horizon`", "past the end"],
        ),
        ("a truncated mesh payload its manifest matches", truncated(&good, "sphere", true), vec!["`sphere`", ".bin"]),
        ("a payload with a wrong hash", flipped, vec!["`terrain.ao`", "BLAKE3"]),
        ("a manifest that does not parse", unparsable, vec!["bundle.ron:", "RON"]),
        ("a manifest of a newer format", newer, vec!["bundle.ron", "bundle format 2.", "not supported"]),
    ];

    let sun = Vec3::new(0.6, 0.25, 0.3).normalize();
    let view = Transform::from_xyz(64.0, 50.0, 64.0).looking_at(Vec3::new(64.0, 0.0, 64.0), Vec3::NEG_Z);
    let MaskScene { mut app, target, .. } =
        MaskScene::new(&dir, 64, sun, view, MaskScene::orthographic(128.0, 128.0, 100.0));
    let handle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let terrain = app.world().spawn(HorizonTerrain::new(handle, "terrain.horizon").with_ao("terrain.ao")).id();
    let built = app.update_until(600, |w| w.get::<MeshMaterial3d<TerrainMaterial>>(terrain).is_some());
    assert!(built, "the good terrain was not built");
    let drawn = app.capture_settled(&target);
    assert!(app.world().get::<HikageError>(terrain).is_none());

    // Hot reload: each hostile bake replaces the good one, then the good one comes back.
    let deleted = {
        let mut f = good.clone();
        f.remove(&ao);
        f
    };
    let mut cases: Vec<Case> = hostile.clone();
    cases.push(("a deleted payload", deleted, vec!["`terrain.ao`", "not found"]));
    cases.push(("an asset that changed kind", changed_kind.clone(), vec!["terrain.horizon", "Heightfield"]));
    for (case, bundle, words) in &cases {
        let _ = std::fs::remove_dir_all(&bundle_dir);
        put(&bundle_dir, bundle);
        app.world().resource::<AssetServer>().reload("bundle/bundle.ron");
        let message = error_saying(&mut app, terrain, words);
        eprintln!("reload of {case}: {message}");
        let load_failed = *case != "an asset that changed kind";
        assert_eq!(message.contains("still drawn"), load_failed, "{case}: {message}");
        assert!(app.world().get::<MeshMaterial3d<TerrainMaterial>>(terrain).is_some(), "{case}: material lost");
        assert!(app.capture(&target) == drawn, "{case}: the last good terrain is no longer drawn as it was");
        let _ = std::fs::remove_dir_all(&bundle_dir);
        put(&bundle_dir, &good);
        app.world().resource::<AssetServer>().reload("bundle/bundle.ron");
        let cleared = app.update_until(300, |w| w.get::<HikageError>(terrain).is_none());
        assert!(cleared, "{case}: the error stayed after a good reload: {:?}", app.world().get::<HikageError>(terrain));
        assert!(app.capture_settled(&target) == drawn, "{case}: the good terrain is not drawn again");
    }

    // First load: each hostile bundle in a directory of its own, on a terrain of its own; the
    // entity says why and draws nothing.
    for (k, (case, bundle, words)) in hostile.iter().enumerate() {
        put(&dir.join(format!("first{k}")), bundle);
        let handle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load(format!("first{k}/bundle.ron"));
        let e = app.world().spawn(HorizonTerrain::new(handle, "terrain.horizon").with_ao("terrain.ao")).id();
        let message = error_saying(&mut app, e, words);
        eprintln!("first load of {case}: {message}");
        assert!(message.starts_with("the bundle failed to load: "), "{message}");
        assert!(app.world().get::<MeshMaterial3d<TerrainMaterial>>(e).is_none(), "{case}: built from a bad bundle");
        app.world().despawn(e);
    }
    // A bundle that is missing at first, then baked: the error goes and the terrain is drawn.
    let handle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("later/bundle.ron");
    let e = app.world().spawn(HorizonTerrain::new(handle, "terrain.horizon")).id();
    error_saying(&mut app, e, &["later/bundle.ron"]);
    put(&dir.join("later"), &good);
    app.world().resource::<AssetServer>().reload("later/bundle.ron");
    let built = app.update_until(300, |w| {
        w.get::<MeshMaterial3d<TerrainMaterial>>(e).is_some() && w.get::<HikageError>(e).is_none()
    });
    assert!(built, "a bundle that loads after a failed first load is drawn: {:?}", app.world().get::<HikageError>(e));
    assert!(app.world().resource::<bevy::ecs::message::Messages<AppExit>>().is_empty(), "the app was asked to quit");
}

/// A 2 × 2 quad in the xz plane facing +y, with normals and UVs but no tangents.
fn quad_without_tangents() -> Mesh {
    let mut mesh = Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::default());
    mesh.insert_attribute(
        Mesh::ATTRIBUTE_POSITION,
        vec![[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0]],
    );
    mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, vec![[0.0f32, 1.0, 0.0]; 4]);
    mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, vec![[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    mesh.insert_indices(Indices::U32(vec![0, 3, 1, 1, 3, 2]));
    mesh
}

#[test]
fn mistakes_of_a_game_are_said_on_the_entity_or_made_to_work() {
    if !gpu_or_skip("mistakes_of_a_game_are_said_on_the_entity_or_made_to_work") {
        return;
    }
    let dir = bake(
        "diagnostics_mistakes",
        r#"Horizon(id: "terrain", input: "data/cylinders.png", directions: 8, edge: Clamp, ao: true),
           Horizon(id: "other", input: "data/reptile.png", directions: 8, edge: Clamp, ao: true),
           Relief(id: "bricks", input: "data/relief_bricks.png")"#,
    );
    let sun = Vec3::new(0.6, 0.25, 0.3).normalize();
    let view = Transform::from_xyz(0.0, 5.0, 0.1).looking_at(Vec3::ZERO, Vec3::Y);
    let MaskScene { mut app, light, .. } = MaskScene::new(&dir, 32, sun, view, Projection::default());
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let world = app.world();
    let quad = world.resource_mut::<Assets<Mesh>>().add(quad_without_tangents());
    // A relief quad without tangents, a relief surface without a mesh, another map's AO.
    let relief = world.spawn((Mesh3d(quad.clone()), ReliefSurface::new(bundle.clone(), "bricks.relief"))).id();
    let meshless = world.spawn(ReliefSurface::new(bundle.clone(), "bricks.relief")).id();
    let wrong_ao = world.spawn(HorizonTerrain::new(bundle.clone(), "terrain.horizon").with_ao("other.ao")).id();
    let terrain = world.spawn(HorizonTerrain::new(bundle.clone(), "terrain.horizon").with_ao("terrain.ao")).id();

    // Tangents are generated for the quad, which is then relief-mapped without complaint.
    let built = app.update_until(600, |w| {
        w.get::<MeshMaterial3d<ReliefMaterial>>(relief).is_some()
            && w.resource::<Assets<Mesh>>().get(&quad).is_some_and(|m| m.contains_attribute(Mesh::ATTRIBUTE_TANGENT))
    });
    assert!(built, "the relief quad was not built with tangents: {:?}", app.world().get::<HikageError>(relief));
    assert!(app.world().get::<HikageError>(relief).is_none());
    let text = error_saying(&mut app, meshless, &["Mesh3d"]);
    eprintln!("no mesh: {text}");
    let text = error_saying(&mut app, wrong_ao, &["other.ao", "256×256", "128×128"]);
    eprintln!("another map's AO: {text}");
    assert!(app.world().get::<MeshMaterial3d<TerrainMaterial>>(wrong_ao).is_none());
    assert!(app.world().get::<HikageError>(terrain).is_none());

    // A sun without shadow maps: said on every entity it would shadow, and gone when enabled.
    app.world().get_mut::<DirectionalLight>(light).unwrap().shadow_maps_enabled = false;
    for e in [terrain, relief] {
        error_saying(&mut app, e, &["shadow_maps_enabled"]);
    }
    // A relief surface without shadows does not need them.
    app.world().get_mut::<ReliefSurface>(relief).unwrap().shadows = false;
    let cleared = app.update_until(50, |w| w.get::<HikageError>(relief).is_none());
    assert!(cleared, "{:?}", app.world().get::<HikageError>(relief));
    app.world().get_mut::<DirectionalLight>(light).unwrap().shadow_maps_enabled = true;
    let cleared = app.update_until(50, |w| w.get::<HikageError>(terrain).is_none());
    assert!(cleared, "{:?}", app.world().get::<HikageError>(terrain));
    // The mesh-less surface keeps its error, and loses it when given a mesh.
    assert!(app.world().get::<HikageError>(meshless).is_some());
    app.world().entity_mut(meshless).insert(Mesh3d(quad));
    let cleared = app.update_until(50, |w| w.get::<HikageError>(meshless).is_none());
    assert!(cleared, "{:?}", app.world().get::<HikageError>(meshless));
    assert!(app.world().resource::<bevy::ecs::message::Messages<AppExit>>().is_empty(), "the app was asked to quit");
}
