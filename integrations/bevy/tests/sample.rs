//! The README's default bundle (the repository's own `pipeline.ron` over `data/`) in Bevy:
//! every asset of it loads through the asset server, and every method draws it with no
//! `HikageError` — the check that a format change the core readers accept (quantized ribbon
//! streams) also loads here.

#[path = "../examples/common/mod.rs"]
mod common;

use bevy::prelude::*;
use hikage_bevy::{
    CurvedMaterial, CurvedSurface, HairStrands, HikageBundle, HikageError, HorizonTerrain, ReliefMaterial,
    ReliefSurface, TerrainMaterial,
};
use hikage_bundle::AssetKind;

use common::{MaskScene, bake_default, gpu_or_skip};

#[test]
fn the_default_bundle_loads_every_asset_and_draws_with_no_error() {
    if !gpu_or_skip("the_default_bundle_loads_every_asset_and_draws_with_no_error") {
        return;
    }
    let dir = bake_default("sample");
    // Over the terrain (512 × 80 m by 512 × 60 m), looking down at its middle.
    let centre = Vec3::new(20_480.0, 0.0, 15_360.0);
    let MaskScene { mut app, target, .. } = MaskScene::new(
        &dir,
        128,
        Vec3::new(0.6, 0.5, 0.3).normalize(),
        Transform::from_translation(centre + Vec3::new(0.0, 30_000.0, 25_000.0)).looking_at(centre, Vec3::Y),
        Projection::Perspective(PerspectiveProjection { far: 200_000.0, ..default() }),
    );
    let handle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let loaded = app.update_until(1200, |world| {
        let server = world.resource::<AssetServer>();
        server.is_loaded_with_dependencies(&handle) || server.load_state(&handle).is_failed()
    });
    let state = app.world().resource::<AssetServer>().load_state(&handle);
    assert!(loaded && state.is_loaded(), "the default bundle did not load: {state:?}");

    // Every asset is reachable as Bevy holds it: an image, a mesh, or data (strands, bindings).
    let world = app.world();
    let bundle = world.resource::<Assets<HikageBundle>>().get(&handle).unwrap();
    let assets = bundle.manifest.assets.clone();
    assert!(assets.len() >= 20, "{} assets", assets.len());
    let (images, meshes) = (world.resource::<Assets<Image>>(), world.resource::<Assets<Mesh>>());
    for a in &assets {
        let held = match a.kind {
            AssetKind::Strands => bundle.strands(&a.id).is_some() && bundle.mesh(&a.id).is_some(),
            AssetKind::HairBinding | AssetKind::Scalp => bundle.hair_binding(&a.id).is_some(),
            _ if a.payload.texture().is_some() => bundle.image(&a.id).and_then(|h| images.get(h)).is_some(),
            _ => bundle.mesh(&a.id).and_then(|h| meshes.get(h)).is_some(),
        };
        assert!(held, "asset `{}` ({:?}) is not held by the loaded bundle", a.id, a.kind);
    }

    // Every method on every asset it draws, small ones on the terrain in front of the camera.
    let id = |a: &hikage_bundle::Asset| a.id.clone();
    let of = |kind: AssetKind| assets.iter().filter(move |a| a.kind == kind).map(id).collect::<Vec<_>>();
    let horizons = of(AssetKind::Horizon);
    let has = |id: &str| assets.iter().any(|a| a.id == id);
    let mut entities = Vec::new();
    let mut slot = 0.0f32;
    let mut place = |scale: f32| {
        slot += 1.0;
        Transform::from_translation(centre + Vec3::new(3_000.0 * (slot - 6.0), 2_000.0, 0.0))
            .with_scale(Vec3::splat(scale))
    };
    let world = app.world();
    for h in &horizons {
        let map = h.trim_end_matches(".horizon");
        let mut terrain = HorizonTerrain::new(handle.clone(), h.clone());
        if has(&format!("{map}.ao")) {
            terrain = terrain.with_ao(format!("{map}.ao"));
        }
        // The sample terrain where it lies; the small maps lifted above it, scaled up.
        let at = if map == "terrain" { Transform::IDENTITY } else { place(8.0) };
        entities.push(world.spawn((terrain, at)).id());
    }
    let cube = Cuboid::new(1.0, 1.0, 1.0).mesh().build().with_generated_tangents().unwrap();
    let cube = world.resource_mut::<Assets<Mesh>>().add(cube);
    for r in of(AssetKind::Relief) {
        entities.push(world.spawn((Mesh3d(cube.clone()), ReliefSurface::new(handle.clone(), r), place(1_500.0))).id());
    }
    for c in of(AssetKind::Curvature) {
        let surface = CurvedSurface::new(handle.clone(), c, horizons[0].clone());
        entities.push(world.spawn((surface, place(10.0))).id());
    }
    for s in of(AssetKind::Strands) {
        entities.push(world.spawn((HairStrands::new(handle.clone(), s), place(40.0))).id());
    }
    // The meshes no component draws (the ribbons) as Bevy's own meshes.
    let plain = world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::default());
    let bundle = world.resource::<Assets<HikageBundle>>().get(&handle).unwrap();
    let others: Vec<Handle<Mesh>> =
        assets.iter().filter(|a| a.kind == AssetKind::Mesh).filter_map(|a| bundle.mesh(&a.id).cloned()).collect();
    assert!(!others.is_empty(), "the sample has a ribbon mesh");
    for mesh in others {
        entities.push(world.spawn((Mesh3d(mesh), MeshMaterial3d(plain.clone()), place(40.0))).id());
    }

    let built = app.update_until(600, |world| {
        let errors = world.query::<&HikageError>().iter(world).count();
        let materials = world
            .query_filtered::<(), Or<(
                With<MeshMaterial3d<TerrainMaterial>>,
                With<MeshMaterial3d<ReliefMaterial>>,
                With<MeshMaterial3d<CurvedMaterial>>,
            )>>()
            .iter(world)
            .count();
        errors > 0 || materials == horizons.len() + of(AssetKind::Relief).len() + of(AssetKind::Curvature).len()
    });
    let frame = app.capture_settled(&target);
    let world = app.world();
    let errors: Vec<String> =
        world.query::<(Entity, &HikageError)>().iter(world).map(|(e, err)| format!("{e}: {}", err.0)).collect();
    assert!(errors.is_empty(), "errors on the default bundle: {errors:#?}");
    assert!(built, "not every component built its material");
    let lit = frame.iter().filter(|p| p[0] + p[1] + p[2] > 0.01).count();
    eprintln!(
        "default bundle: {} assets, {} entities drawn, {lit} of {} pixels lit",
        assets.len(),
        entities.len(),
        frame.len()
    );
    assert!(lit > frame.len() / 4, "only {lit} pixels lit: the scene did not draw");
}
