//! The figures docs/bevy.md reports, in one run, each against a baseline measured in the same
//! run: the terrain scene's frame time with the hikage material against Bevy's
//! `StandardMaterial` with cascaded shadows on the same mesh; the hair scene's against the same
//! scene without hair; relief reads per pixel and error
//! against the exact surface, hikage's tracer against Bevy's `ParallaxMappingMethod::Relief`
//! algorithm on the same height map; shadow-texel density on visible surfaces, the fitted map
//! against Bevy's default cascades. Needs the default bundle (`cargo run --release -- bake` in
//! the repository root) and a GPU (lavapipe will do):
//!
//! ```sh
//! cargo run --release --ignore-rust-version --example measure           # every table
//! cargo run --release --ignore-rust-version --example measure -- hair   # or one: terrain, hair, relief, stream, density
//! ```
//!
//! `stream` bakes its own bundle (a generated 1024² map in 128² tiles, and the same map whole)
//! and times how soon tiles arrive; run it in the dev profile too (`cargo run --example measure
//! -- stream`, with and without `--config 'profile.dev.package."*".opt-level=3'`) for the
//! dev-profile table of docs/bevy.md.

#[path = "common/mod.rs"]
mod common;

use std::time::Instant;

use bevy::light::{CascadeShadowConfig, CascadeShadowConfigBuilder, Cascades, NotShadowCaster};
use bevy::prelude::*;
use hikage_bevy::{
    FittedShadows, HairDraw, HairReceiver, HairStrands, HikageBundle, HikagePlugin, HorizonTerrain, TerrainMaterial,
};
use hikage_runtime::CpuBundle;
use hikage_runtime::relief::Tracer;
use hikage_runtime::relief::reference::{Reads, ReliefMaps, fine_march};

use common::{Headless, repo_root};

const RUNS: usize = 3;
const FRAMES: usize = 5;
const VIEW: (u32, u32) = (960, 540);

fn main() {
    let root = repo_root();
    assert!(root.join("bundle/bundle.ron").exists(), "bake the default bundle first (`cargo run --release -- bake`)");
    println!(
        "hikage-bevy measurements ({} threads, {}×{} views, lavapipe or the first adapter)",
        threads(),
        VIEW.0,
        VIEW.1
    );
    // One part only when named: terrain, hair, relief or density.
    let only = std::env::args().nth(1);
    let run = |part: &str| only.as_deref().is_none_or(|o| o == part);
    if run("terrain") {
        println!();
        terrain_frame_time(&root);
    }
    if run("hair") {
        println!();
        hair_frame_time(&root);
    }
    if run("relief") {
        println!();
        relief_comparison(&root);
    }
    if run("stream") {
        println!();
        stream_arrival();
    }
    if run("density") {
        println!();
        texel_density();
    }
}

fn threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Which terrain scene to time.
#[derive(Clone, Copy, PartialEq)]
enum TerrainScene {
    /// hikage's material (horizon shadows and AO); the terrain also casts into Bevy's cascades.
    Hikage,
    /// The same, the terrain marked `NotShadowCaster` (nothing else needs its shadow).
    HikageNoCaster,
    /// `StandardMaterial` on the same grid, Bevy's default cascades.
    StandardDefault,
    /// `StandardMaterial`, the cascades stretched over the whole terrain (so it shadows itself).
    StandardCovering,
}

/// Milliseconds per frame of one terrain scene: best of `RUNS` runs of `FRAMES` frames.
fn terrain_ms(root: &std::path::Path, scene: TerrainScene) -> f64 {
    let mut app = Headless::new(root, |app| {
        app.add_plugins(HikagePlugin);
    });
    let target = app.target(VIEW.0, VIEW.1);
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let world = app.world();
    let terrain = world.spawn(HorizonTerrain::new(bundle.clone(), "terrain.horizon").with_ao("terrain.ao")).id();
    let mut light = world.spawn((
        DirectionalLight { illuminance: 6_000.0, shadow_maps_enabled: true, ..default() },
        Transform::default().looking_to(Vec3::new(-1.0, -0.25, -0.5), Vec3::Y),
    ));
    if scene == TerrainScene::StandardCovering {
        light.insert(CascadeShadowConfig::from(CascadeShadowConfigBuilder {
            maximum_distance: 100_000.0,
            first_cascade_far_bound: 20_000.0,
            ..default()
        }));
    }
    world.spawn((
        Camera3d::default(),
        bevy::camera::RenderTarget::from(target),
        Projection::Perspective(PerspectiveProjection { far: 200_000.0, ..default() }),
        Transform::from_xyz(20_000.0, 16_000.0, 50_000.0).looking_at(Vec3::new(20_000.0, 0.0, 14_000.0), Vec3::Y),
    ));
    let built = app.update_until(600, |w| w.get::<MeshMaterial3d<TerrainMaterial>>(terrain).is_some());
    assert!(built, "the terrain did not load");
    match scene {
        TerrainScene::Hikage => {}
        TerrainScene::HikageNoCaster => {
            app.world().entity_mut(terrain).insert(NotShadowCaster);
        }
        TerrainScene::StandardDefault | TerrainScene::StandardCovering => {
            let plain = app
                .world()
                .resource_mut::<Assets<StandardMaterial>>()
                .add(StandardMaterial { perceptual_roughness: 1.0, ..default() });
            app.world()
                .entity_mut(terrain)
                .remove::<(HorizonTerrain, MeshMaterial3d<TerrainMaterial>)>()
                .insert(MeshMaterial3d(plain));
        }
    }
    frame_ms(&mut app)
}

/// Milliseconds per frame of `app` after 10 frames to settle: best of `RUNS` runs of `FRAMES`.
fn frame_ms(app: &mut Headless) -> f64 {
    app.update_until(10, |_| false);
    (0..RUNS)
        .map(|_| {
            let start = Instant::now();
            app.update_until(FRAMES, |_| false);
            start.elapsed().as_secs_f64() * 1000.0 / FRAMES as f64
        })
        .fold(f64::INFINITY, f64::min)
}

fn terrain_frame_time(root: &std::path::Path) {
    println!(
        "Terrain scene (512² grid, 80 m × 60 m texels; the terrain example's view), ms/frame, best of {RUNS}×{FRAMES}:"
    );
    let base = terrain_ms(root, TerrainScene::StandardDefault);
    println!("| scene | ms/frame | vs StandardMaterial + default cascades |");
    println!("|---|---|---|");
    println!("| StandardMaterial, Bevy's default cascades (baseline) | {base:.1} | 1.00× |");
    for (name, scene) in [
        ("StandardMaterial, cascades over the whole terrain", TerrainScene::StandardCovering),
        ("hikage TerrainMaterial (terrain also casts into the cascades)", TerrainScene::Hikage),
        ("hikage TerrainMaterial, terrain NotShadowCaster", TerrainScene::HikageNoCaster),
    ] {
        let ms = terrain_ms(root, scene);
        println!("| {name} | {ms:.1} | {:.2}× |", ms / base);
    }
}

/// Milliseconds per frame of the hair example's scene (the sample head over a ground plane, the
/// scalp and ground receiving its shadow) drawn as `draw`, or without hair (`None`: the scalp and
/// ground plain `StandardMaterial`s), by a camera with `msaa`: best of `RUNS` runs of `FRAMES`
/// frames.
fn hair_ms(root: &std::path::Path, draw: Option<HairDraw>, msaa: bevy::render::view::Msaa) -> f64 {
    let mut app = Headless::new(root, |app| {
        app.add_plugins(HikagePlugin);
    });
    let target = app.target(VIEW.0, VIEW.1);
    let bundle: Handle<HikageBundle> = app.world().resource::<AssetServer>().load("bundle/bundle.ron");
    let world = app.world();
    let hair = world.spawn(HairStrands::new(bundle.clone(), "head.strips").with_draw(draw.unwrap_or_default())).id();
    let (scalp, ground) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (meshes.add(Sphere::new(7.6).mesh().uv(48, 32)), meshes.add(Plane3d::default().mesh().size(160.0, 160.0)))
    };
    let plain = world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::default());
    for (mesh, at) in [(scalp, Vec3::new(0.1, 2.2, -1.7)), (ground, Vec3::new(0.0, -26.0, 0.0))] {
        let mut e = world.spawn((Mesh3d(mesh), Transform::from_translation(at)));
        match draw {
            Some(_) => e.insert(HairReceiver::new(hair)),
            None => e.insert(MeshMaterial3d(plain.clone())),
        };
    }
    world.spawn((
        DirectionalLight { illuminance: 9_000.0, shadow_maps_enabled: true, ..default() },
        Transform::default().looking_to(-Vec3::new(0.45, 1.0, 0.3), Vec3::Y),
    ));
    world.spawn((
        Camera3d::default(),
        bevy::camera::RenderTarget::from(target),
        msaa,
        Transform::from_xyz(52.0, 26.0, 72.0).looking_at(Vec3::new(6.0, -2.0, 0.0), Vec3::Y),
    ));
    let server = app.world().resource::<AssetServer>().clone();
    let loaded = app.update_until(600, |_| server.is_loaded_with_dependencies(&bundle));
    assert!(loaded, "the bundle did not load");
    if draw.is_none() {
        app.world().despawn(hair);
    }
    frame_ms(&mut app)
}

fn hair_frame_time(root: &std::path::Path) {
    println!(
        "Hair scene (the hair example: 10,000 strands × 22 points, 256² opacity maps, scalp and ground receiving), ms/frame, best of {RUNS}×{FRAMES}:"
    );
    use bevy::render::view::Msaa;
    let base = hair_ms(root, None, Msaa::Off);
    println!("| scene | ms/frame | vs no hair |");
    println!("|---|---|---|");
    println!("| scalp and ground, no hair (baseline) | {base:.1} | 1.00× |");
    let mut blended = base;
    for (name, draw) in [
        ("hair shadows only (opacity maps, receivers)", HairDraw::ShadowsOnly),
        ("hair blended (maps, receivers, strips, composite)", HairDraw::Blended),
        ("hair opaque", HairDraw::Opaque),
    ] {
        let ms = hair_ms(root, Some(draw), Msaa::Off);
        if draw == HairDraw::Blended {
            blended = ms;
        }
        println!("| {name} | {ms:.1} | {:.2}× |", ms / base);
    }
    // Bevy's default camera: MSAA 4×, the hair blended against the depth resolved to one sample.
    let base4 = hair_ms(root, None, Msaa::Sample4);
    let blended4 = hair_ms(root, Some(HairDraw::Blended), Msaa::Sample4);
    println!("| MSAA 4× (Bevy's default): scalp and ground, no hair | {base4:.1} | {:.2}× |", base4 / base);
    println!(
        "| MSAA 4×: hair blended (+ the depth resolve) | {blended4:.1} | {:.2}× (the hair's own cost {:.1} ms, {:.1} ms with MSAA off) |",
        blended4 / base4,
        blended4 - base4,
        blended - base
    );
}

/// A small deterministic generator for the sample rays.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Bevy's `ParallaxMappingMethod::Relief` (bevy_pbr's `parallaxed_uv` with `RELIEF_MAPPING`)
/// on the CPU: steep parallax over `layers` layers mixed toward 1 as the view steepens, then
/// `steps` halvings, reading a bilinear, repeating depth map (depth = 1 − height). Returns the
/// hit (texels) and the depth-map reads.
fn bevy_relief(maps: &ReliefMaps, origin: [f32; 2], dir: [f32; 3], layers: f32, steps: u32) -> ([f32; 2], u32) {
    let (w, h) = (maps.max_mip.width() as i64, maps.max_mip.height() as i64);
    let depth = |u: f32, v: f32| {
        // Bilinear between texel centres, wrapping.
        let (x, y) = (u - 0.5, v - 0.5);
        let (i, j) = (x.floor() as i64, y.floor() as i64);
        let (fx, fy) = (x - x.floor(), y - y.floor());
        let d = |a: i64, b: i64| 1.0 - maps.max_mip.max_height(0, a.rem_euclid(w), b.rem_euclid(h));
        let top = d(i, j) * (1.0 - fx) + d(i + 1, j) * fx;
        let bottom = d(i, j + 1) * (1.0 - fx) + d(i + 1, j + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    };
    let steepness = dir[2];
    let layer_count = layers + (1.0 - layers) * steepness;
    let layer_depth = 1.0 / layer_count;
    // Texels along the ray per unit of normalised depth.
    let per_depth = [maps.thickness * dir[0] / dir[2], maps.thickness * dir[1] / dir[2]];
    let mut delta = [per_depth[0] * layer_depth, per_depth[1] * layer_depth];
    let mut uv = origin;
    let mut current = 0.0;
    let mut reads = 1;
    let mut texture_depth = depth(uv[0], uv[1]);
    let mut i = 0;
    while texture_depth > current && i <= layer_count as i32 {
        current += layer_depth;
        uv = [uv[0] + delta[0], uv[1] + delta[1]];
        texture_depth = depth(uv[0], uv[1]);
        reads += 1;
        i += 1;
    }
    delta = [delta[0] * 0.5, delta[1] * 0.5];
    let mut delta_depth = 0.5 * layer_depth;
    uv = [uv[0] - delta[0], uv[1] - delta[1]];
    current -= delta_depth;
    for _ in 0..steps {
        texture_depth = depth(uv[0], uv[1]);
        reads += 1;
        delta = [delta[0] * 0.5, delta[1] * 0.5];
        delta_depth *= 0.5;
        let sign = if texture_depth > current { 1.0 } else { -1.0 };
        uv = [uv[0] + sign * delta[0], uv[1] + sign * delta[1]];
        current += sign * delta_depth;
    }
    (uv, reads)
}

/// Mean, 99th percentile and share above one texel of `errors`.
fn summary(errors: &mut [f32]) -> (f32, f32, f32) {
    errors.sort_by(f32::total_cmp);
    let mean = errors.iter().sum::<f32>() / errors.len() as f32;
    let p99 = errors[(errors.len() * 99 / 100).min(errors.len() - 1)];
    let above = errors.iter().filter(|&&e| e > 1.0).count() as f32 / errors.len() as f32;
    (mean, p99, above)
}

fn relief_comparison(root: &std::path::Path) {
    const RAYS: usize = 20_000;
    println!("Relief, {RAYS} view rays per map (zenith 0–75°, any azimuth), hit error (texels, in the");
    println!("plane) against the exact first hit on the texel surface; reads per pixel:");
    println!("| map | method | reads/pixel | mean error | p99 error | error > 1 texel |");
    println!("|---|---|---|---|---|---|");
    for id in ["relief_bricks", "relief_fbm", "relief_spikes"] {
        let cpu = CpuBundle::read_prefix(&root.join("bundle"), &format!("{id}.")).unwrap();
        let maps = ReliefMaps::from_bundle(&cpu, &format!("{id}.relief")).unwrap();
        let size = maps.max_mip.width() as f32;
        let mut rng = Lcg(7);
        let rays: Vec<([f32; 2], [f32; 3])> = (0..RAYS)
            .map(|_| {
                let (theta, phi) = (rng.next() * 75f32.to_radians(), rng.next() * std::f32::consts::TAU);
                (
                    [rng.next() * size, rng.next() * size],
                    [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()],
                )
            })
            .collect();
        let exact: Vec<[f32; 2]> = rays
            .iter()
            .map(|&(o, d)| {
                let s = fine_march(&maps.max_mip, &maps.ray(o, d));
                [o[0] + s * d[0], o[1] + s * d[1]]
            })
            .collect();
        let off = |a: [f32; 2], b: [f32; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
        let tracer = Tracer::Combined { margin: 0.1, start_level: 3 };
        let (mut errors, mut reads) = (Vec::with_capacity(RAYS), 0u64);
        for (&(o, d), &truth) in rays.iter().zip(&exact) {
            let mut r = Reads::default();
            let s = maps.trace(tracer, &maps.ray(o, d), &mut r);
            reads += r.total() as u64;
            errors.push(off([o[0] + s * d[0], o[1] + s * d[1]], truth));
        }
        let (mean, p99, above) = summary(&mut errors);
        println!(
            "| {id} | hikage ReliefSurface (depth map + max-mip) | {:.1} | {mean:.3} | {p99:.2} | {:.2}% |",
            reads as f64 / RAYS as f64,
            100.0 * above
        );
        for (layers, steps) in [(16.0, 5), (64.0, 8)] {
            let (mut errors, mut reads) = (Vec::with_capacity(RAYS), 0u64);
            for (&(o, d), &truth) in rays.iter().zip(&exact) {
                let (hit, r) = bevy_relief(&maps, o, d, layers, steps);
                reads += r as u64;
                errors.push(off(hit, truth));
            }
            let (mean, p99, above) = summary(&mut errors);
            println!(
                "| {id} | Bevy Relief, {layers} layers, {steps} steps{} | {:.1} | {mean:.3} | {p99:.2} | {:.2}% |",
                if layers == 16.0 { " (defaults)" } else { "" },
                reads as f64 / RAYS as f64,
                100.0 * above
            );
        }
    }
}

/// Shadow-map texels per m² on the ground at `p` under `clip_from_world` with `size`² texels.
fn density(clip_from_world: Mat4, p: Vec3, size: f32) -> f32 {
    let ndc = |q: Vec3| {
        let c = clip_from_world * q.extend(1.0);
        Vec2::new(c.x, c.y) / c.w
    };
    let e = 0.01;
    let (du, dv) = ((ndc(p + Vec3::X * e) - ndc(p)) / e, (ndc(p + Vec3::Z * e) - ndc(p)) / e);
    (du.perp_dot(dv)).abs() * (0.5 * size).powi(2)
}

fn texel_density() {
    println!("Shadow-texel density on the visible ground (texels/m², 2048² maps; ground points under a");
    println!("96×54 grid of the view; 'covered' = inside a map): the light_fit example's posts, the sun");
    println!("low in front of the camera, on open ground (400 m) and in a 40 m yard:");
    println!("| ground | shadow map | median texels/m² | vs baseline | 10th percentile | vs baseline | covered |");
    println!("|---|---|---|---|---|---|---|");
    for extent in [400.0, 40.0] {
        let mut base = None;
        for (name, fitted) in [
            ("Bevy default cascades (4, to 150 m; baseline)", None),
            ("FittedShadows, world space, snapped", Some(FittedShadows::default())),
            (
                "FittedShadows, PSM (balanced pull-back), snapped",
                Some(FittedShadows {
                    space: hikage_bevy::light_fit::FitSpace::PostPerspective(
                        hikage_bevy::light_fit::PullBack::Balanced,
                    ),
                    ..FittedShadows::default()
                }),
            ),
        ] {
            let (median, p10, covered) = densities(extent, fitted);
            let (bm, bp) = *base.get_or_insert((median, p10));
            println!(
                "| {extent} m | {name} | {median:.0} | {:.2}× | {p10:.1} | {:.2}× | {:.1}% |",
                median / bm,
                p10 / bp,
                100.0 * covered
            );
        }
    }
}

/// Median and 10th-percentile density over the visible ground, and the share of it covered.
fn densities(extent: f32, fitted: Option<FittedShadows>) -> (f32, f32, f32) {
    let mut app = Headless::new(&std::env::temp_dir(), |app| {
        app.add_plugins(HikagePlugin);
    });
    let target = app.target(VIEW.0, VIEW.1);
    let world = app.world();
    let ground = world.resource_mut::<Assets<Mesh>>().add(Plane3d::default().mesh().size(extent, extent).build());
    let post = world.resource_mut::<Assets<Mesh>>().add(Cuboid::new(1.0, 4.0, 1.0));
    let white = world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::default());
    world.spawn((Mesh3d(ground), MeshMaterial3d(white.clone()), Transform::from_xyz(0.0, 0.0, 14.0 - extent / 2.0)));
    for k in 0..60 {
        let (x, z) = ((k % 6) as f32 * 6.0 - 15.0, -((k / 6) as f32) * 2.5);
        world.spawn((Mesh3d(post.clone()), MeshMaterial3d(white.clone()), Transform::from_xyz(x, 2.0, z)));
    }
    let mut light = world.spawn((
        DirectionalLight { illuminance: 8_000.0, shadow_maps_enabled: true, ..default() },
        Transform::default().looking_to(Vec3::new(-0.6, -0.5, 0.3), Vec3::Y),
    ));
    if let Some(f) = fitted {
        light.insert(f);
    }
    let light = light.id();
    let camera = world
        .spawn((
            Camera3d::default(),
            bevy::camera::RenderTarget::from(target),
            Transform::from_xyz(0.0, 5.0, 14.0).looking_at(Vec3::new(0.0, 0.0, -20.0), Vec3::Y),
        ))
        .id();
    app.update_until(5, |_| false);
    let size = 2048.0;
    let bounds = app.world().get::<CascadeShadowConfig>(light).unwrap().bounds.clone();
    let cascades = app.world().get::<Cascades>(light).unwrap().cascades[&camera].clone();
    let view_from_world = app.world().get::<GlobalTransform>(camera).unwrap().to_matrix().inverse();
    let (mut values, mut points) = (Vec::new(), 0);
    for gy in 0..54 {
        for gx in 0..96 {
            let ray = app.pixel_ray(gx * 10 + 5, gy * 10 + 5);
            let t = -ray.origin.y / ray.direction.y;
            let p = ray.origin + t * *ray.direction;
            if t <= 0.0 || p.x.abs() > extent / 2.0 || (p.z - (14.0 - extent / 2.0)).abs() > extent / 2.0 {
                continue;
            }
            points += 1;
            let depth = -view_from_world.transform_point3(p).z;
            if let Some(k) = bounds.iter().position(|&far| depth < far) {
                values.push(density(cascades[k].clip_from_world, p, size));
            }
        }
    }
    values.sort_by(f32::total_cmp);
    let at = |q: usize| values.get(values.len() * q / 100).copied().unwrap_or(0.0);
    (at(50), at(10), values.len() as f32 / points as f32)
}

/// A generated 1024² map baked in 128² tiles with every level (`dem`) and whole (`whole`, 16×
/// a tile's texels that the bundle's loader reads and checks): the bundle `stream` times.
fn stream_bundle() -> std::path::PathBuf {
    let dir = std::env::temp_dir().join("hikage_measure_stream");
    if dir.join("bundle/bundle.ron").exists() {
        return dir;
    }
    std::fs::create_dir_all(&dir).unwrap();
    let heights: Vec<u8> = hikage_devkit::synth::terrain(1024).into_iter().flat_map(f32::to_le_bytes).collect();
    std::fs::write(dir.join("dem.r32"), heights).unwrap();
    let job = |id: &str, tiles: &str| {
        format!(
            r#"Horizon(id: "{id}", input: "dem.r32", texel_size: (30, 30), height_scale: 1200, directions: 16,
               edge: Clamp, max_distance: 900, ao: true{tiles}),"#
        )
    };
    let jobs = format!("{} {}", job("whole", ""), job("dem", ", tile: 128, levels: 16"));
    std::fs::write(dir.join("pipeline.ron"), format!(r#"(output: "bundle", jobs: [{jobs}])"#)).unwrap();
    hikage_bake::build::BuildScript::new(dir.join("pipeline.ron")).into_pipeline_output().run().unwrap();
    dir
}

/// How soon a `StreamedTerrain` draws: seconds from the app's start (before its plugins are
/// built) to the first tile drawn and to level 0 under the camera, against the bundle's own load
/// (every untiled asset read and checked) in the same run; then tiles per second while the
/// camera hovers with room for all it wants. Best of `RUNS`.
fn stream_arrival() {
    use hikage_bevy::{StreamOptions, StreamedTerrain, TerrainStreamStats};
    let dir = stream_bundle();
    let profile = if cfg!(debug_assertions) { "dev" } else { "release" };
    let (mut best, mut best_rate) = ([f64::INFINITY; 5], 0.0f64);
    for _ in 0..RUNS {
        let start = Instant::now();
        let mut app = Headless::new(&dir, |app| {
            app.add_plugins(HikagePlugin);
        });
        let built = start.elapsed().as_secs_f64();
        let target = app.target(VIEW.0, VIEW.1);
        let world = app.world();
        world.spawn((
            DirectionalLight { illuminance: 6_000.0, shadow_maps_enabled: true, ..default() },
            Transform::default().looking_to(Vec3::new(-1.0, -0.25, -0.5), Vec3::Y),
        ));
        world.spawn((
            Camera3d::default(),
            bevy::camera::RenderTarget::from(target),
            Projection::Perspective(PerspectiveProjection { far: 100_000.0, ..default() }),
            Transform::from_xyz(9_000.0, 900.0, 9_000.0).looking_at(Vec3::new(15_000.0, 0.0, 15_000.0), Vec3::Y),
        ));
        let bundle: Handle<HikageBundle> = world.resource::<AssetServer>().load("bundle/bundle.ron");
        let options = StreamOptions { resident_bytes: 1 << 30, ..StreamOptions::default() };
        let terrain = world.spawn(StreamedTerrain::new(bundle.clone(), "dem").with_options(options)).id();
        let (mut first, mut level0, mut loaded, mut settled) = (None, None, None, None);
        let (mut tiles, mut first_frame) = (0usize, None);
        while settled.is_none() && start.elapsed().as_secs() < 600 {
            app.update();
            let now = start.elapsed().as_secs_f64();
            first_frame.get_or_insert(now);
            let world = app.world();
            let stats = world.get::<TerrainStreamStats>(terrain).map(|s| s.0).unwrap_or_default();
            if stats.drawn > 0 && first.is_none() {
                first = Some(now);
            }
            if stats.drawn > 0 && stats.finest_drawn == 0 && level0.is_none() {
                level0 = Some(now);
            }
            if loaded.is_none() && world.resource::<AssetServer>().is_loaded_with_dependencies(&bundle) {
                loaded = Some(now);
            }
            tiles = stats.resident_tiles;
            if stats.drawn > 0 && stats.missing == 0 && loaded.is_some() {
                settled = Some(now);
            }
        }
        let (Some(first), Some(level0), Some(settled)) = (first, level0, settled) else {
            panic!("the stream did not settle in 600 s")
        };
        let run = [built, first_frame.unwrap_or(f64::INFINITY), first, level0, loaded.unwrap_or(f64::INFINITY)];
        for (b, run) in best.iter_mut().zip(run) {
            *b = b.min(run);
        }
        best_rate = best_rate.max(tiles as f64 / (settled - first).max(1e-3));
    }
    println!(
        "StreamedTerrain arrival ({profile} build, 1024² in 128² tiles + the map whole, {}×{}, best of {RUNS})",
        VIEW.0, VIEW.1
    );
    println!("| from the app's start | seconds |");
    println!("|---|---|");
    println!("| the app built (Bevy's plugins and the render device) | {:.2} |", best[0]);
    println!("| its first frame done | {:.2} |", best[1]);
    println!("| first tile drawn | {:.2} |", best[2]);
    println!("| level 0 under the camera | {:.2} |", best[3]);
    println!("| the bundle's own load (its untiled assets read and checked) | {:.2} |", best[4]);
    println!("| tiles per second, hovering with room for all | {best_rate:.1} |");
}
