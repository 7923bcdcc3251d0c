//! What the examples and render tests share: [`run`], which opens an example in a window where
//! a display exists and otherwise renders it headless to a PNG; a headless Bevy app (default
//! plugins without a window or winit, pumped frame by frame, rendering to an image that is read
//! back); and bundles baked by hikage-bake from the repository's sample data.

#![allow(dead_code, reason = "each example and test uses part of it")]

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use bevy::app::SubApps;
use bevy::asset::RenderAssetUsages;
use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::render_resource::{PollType, TextureFormat};
use bevy::render::renderer::RenderDevice;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::window::ExitCondition;
use bevy::winit::WinitPlugin;

/// The repository's root (two levels above this crate).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").canonicalize().unwrap()
}

/// Bakes `jobs` (pipeline.ron job entries over the repository's `data/`) into a fresh
/// directory `name` under the target directory; returns that directory (the bundle is its
/// `bundle/`).
pub fn bake(name: &str, jobs: &str) -> PathBuf {
    let dir = option_env!("CARGO_TARGET_TMPDIR").map_or_else(std::env::temp_dir, PathBuf::from).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let data = repo_root().join("data");
    let jobs = jobs.replace("data/", &format!("{}/", data.display()));
    std::fs::write(dir.join("pipeline.ron"), format!("(output: \"bundle\", jobs: [{jobs}])")).unwrap();
    hikage_bake::build::BuildScript::new(dir.join("pipeline.ron")).into_pipeline_output().run().unwrap();
    dir
}

/// Bakes the repository's own `pipeline.ron` (the README's default bundle: every sample, its
/// budget and compression as they are) into a fresh directory `name` under the target
/// directory; returns that directory (the bundle is its `bundle/`).
pub fn bake_default(name: &str) -> PathBuf {
    let dir = option_env!("CARGO_TARGET_TMPDIR").map_or_else(std::env::temp_dir, PathBuf::from).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let root = repo_root();
    let pipeline = std::fs::read_to_string(root.join("pipeline.ron")).unwrap();
    let pipeline = pipeline.replace("\"data/", &format!("\"{}/", root.join("data").display()));
    std::fs::write(dir.join("pipeline.ron"), pipeline).unwrap();
    hikage_bake::build::BuildScript::new(dir.join("pipeline.ron")).into_pipeline_output().run().unwrap();
    dir
}

/// True when a Vulkan/GL/Metal adapter exists; panics instead of skipping under
/// `HIKAGE_REQUIRE_GPU=1`.
pub fn gpu_or_skip(test: &str) -> bool {
    use hikage_runtime::wgpu;
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
    let adapter = bevy::tasks::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()));
    match adapter {
        Ok(_) => true,
        Err(e) if std::env::var("HIKAGE_REQUIRE_GPU").as_deref() != Ok("1") => {
            eprintln!("skipping {test}: no GPU adapter ({e}); set HIKAGE_REQUIRE_GPU=1 to make this a failure");
            false
        }
        Err(e) => panic!("{test}: HIKAGE_REQUIRE_GPU=1 but no GPU adapter: {e}"),
    }
}

/// Runs an example whose scene `build` adds (the bundle under the repository root, as the
/// README's bake leaves it): in a window when `DISPLAY` or `WAYLAND_DISPLAY` is set, otherwise
/// headless, saving the frame to the path given as the first argument (default
/// `target/<name>.png` in this crate).
pub fn run(name: &str, build: impl FnOnce(&mut App)) {
    let root = repo_root();
    if !root.join("bundle/bundle.ron").exists() {
        eprintln!("{name}: no bundle at {}: bake it first (`cargo run --release -- bake` there)", root.display());
        std::process::exit(1);
    }
    run_in(name, &root, build);
}

/// [`run`] with the assets under `root` (its bundle at `root/bundle/bundle.ron`).
pub fn run_in(name: &str, root: &Path, build: impl FnOnce(&mut App)) {
    if std::env::var_os("DISPLAY").is_some() || std::env::var_os("WAYLAND_DISPLAY").is_some() {
        let mut app = App::new();
        app.add_plugins((
            DefaultPlugins.set(AssetPlugin { file_path: root.to_string_lossy().into_owned(), ..default() }),
            hikage_bevy::HikagePlugin,
        ));
        build(&mut app);
        app.run();
        return;
    }
    let out = std::env::args().nth(1).map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("target").join(format!("{name}.png")),
        PathBuf::from,
    );
    render(name, root, &out, build);
    println!("{name}: no display; rendered headless to {}", out.display());
}

/// Renders the scene `build` adds (assets under `root`) headless, once everything in it has
/// loaded, into a 960×540 PNG at `out`.
pub fn render(name: &str, root: &Path, out: &Path, build: impl FnOnce(&mut App)) {
    let mut app = Headless::new(root, |app| {
        app.add_plugins(hikage_bevy::HikagePlugin);
        build(app);
    });
    let (width, height) = (960, 540);
    let target = app.target(width, height);
    // Every camera renders into the image.
    let image = target.clone();
    app.world().add_observer(move |added: On<Add<Camera>>, mut commands: Commands| {
        commands.entity(added.entity).insert(RenderTarget::from(image.clone()));
    });
    let built = app.update_until(600, |world| pending(world) == 0);
    assert!(built, "{name}: the scene's assets did not load");
    settle(&mut app);
    app.update_until(3, |_| false);
    let pixels = app.capture_bytes(&target);
    let bytes: Vec<u8> = pixels.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
    image::save_buffer(out, &bytes, width, height, image::ColorType::Rgb8).unwrap();
}

/// Frames until every streamed terrain draws all the tiles its camera wants, or holds as many
/// as its budget allows (a second without a tile added).
fn settle(app: &mut Headless) {
    let mut idle = 0;
    for _ in 0..3000 {
        app.update();
        let mut streams = app.world().query::<&hikage_bevy::TerrainStreamStats>();
        let stats: Vec<_> = streams.iter(app.world()).map(|s| s.0).collect();
        if stats.iter().all(|s| s.missing == 0) {
            return;
        }
        idle = if stats.iter().any(|s| s.uploaded_bytes > 0) { 0 } else { idle + 1 };
        if idle >= 100 {
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

/// hikage components whose bundle has not given them a material (or an error) yet.
fn pending(world: &mut World) -> usize {
    use hikage_bevy::*;
    let receivers = world
        .query_filtered::<(), (With<HairReceiver>, Without<MeshMaterial3d<HairReceiverMaterial>>, Without<HikageError>)>()
        .iter(world)
        .count()
        + world
            .query_filtered::<(), (
                With<TerrainReceiver>,
                Without<MeshMaterial3d<TerrainReceiverMaterial>>,
                Without<HikageError>,
            )>()
            .iter(world)
            .count();
    let server = world.resource::<AssetServer>().clone();
    let hairs =
        world.query::<&HairStrands>().iter(world).filter(|h| !server.is_loaded_with_dependencies(&h.bundle)).count();
    // A streamed terrain waits for its coarsest tiles here, and in `settle` for the rest.
    let streams = world
        .query_filtered::<&TerrainStreamStats, Without<HikageError>>()
        .iter(world)
        .filter(|s| s.0.drawn == 0)
        .count();
    receivers
        + hairs
        + streams
        + world
            .query_filtered::<(), (
                Or<(With<HorizonTerrain>, With<ReliefSurface>, With<CurvedSurface>)>,
                Without<MeshMaterial3d<TerrainMaterial>>,
                Without<MeshMaterial3d<ReliefMaterial>>,
                Without<MeshMaterial3d<CurvedMaterial>>,
                Without<HikageError>,
            )>()
            .iter(world)
            .count()
}

/// A Bevy app with no window, its update loop driven by the caller.
pub struct Headless(pub SubApps);

impl Headless {
    /// Default plugins (no winit, no primary window, pipelines compiled in the frame that needs
    /// them), assets read from `assets`, then `setup`.
    pub fn new(assets: &Path, setup: impl FnOnce(&mut App)) -> Headless {
        let mut app = App::new();
        app.add_plugins(
            DefaultPlugins
                .set(WindowPlugin { primary_window: None, exit_condition: ExitCondition::DontExit, ..default() })
                .set(RenderPlugin { synchronous_pipeline_compilation: true, ..default() })
                .set(AssetPlugin { file_path: assets.to_string_lossy().into_owned(), ..default() })
                .disable::<WinitPlugin>(),
        );
        setup(&mut app);
        app.finish();
        app.cleanup();
        Headless(std::mem::take(app.sub_apps_mut()))
    }

    /// The main world.
    pub fn world(&mut self) -> &mut World {
        self.0.main.world_mut()
    }

    /// One frame, waited for.
    pub fn update(&mut self) {
        self.0.update();
        self.0
            .main
            .world()
            .resource::<RenderDevice>()
            .wgpu_device()
            .poll(PollType::Wait { submission_index: None, timeout: None })
            .unwrap();
    }

    /// Frames until `done` holds, at most `frames`.
    pub fn update_until(&mut self, frames: usize, mut done: impl FnMut(&mut World) -> bool) -> bool {
        for _ in 0..frames {
            self.update();
            if done(self.world()) {
                return true;
            }
        }
        false
    }

    /// A `width` × `height` sRGB colour target.
    pub fn target(&mut self, width: u32, height: u32) -> Handle<Image> {
        let mut image = Image::new_target_texture(width, height, TextureFormat::Rgba8UnormSrgb, None);
        image.asset_usage = RenderAssetUsages::RENDER_WORLD;
        self.world().resource_mut::<Assets<Image>>().add(image)
    }

    /// The world ray through the centre of pixel (`col`, `row`) of the one camera.
    pub fn pixel_ray(&mut self, col: u32, row: u32) -> Ray3d {
        let world = self.world();
        let (camera, transform) = world.query::<(&Camera, &GlobalTransform)>().single(world).unwrap();
        camera.viewport_to_world(transform, Vec2::new(col as f32 + 0.5, row as f32 + 0.5)).unwrap()
    }

    /// Renders a frame and reads `target` back: linear RGB per pixel, row-major.
    pub fn capture(&mut self, target: &Handle<Image>) -> Vec<[f32; 3]> {
        linear(self.capture_bytes(target))
    }

    /// [`capture`](Self::capture) until two frames in a row agree: the first frames after a
    /// material appears may still miss the textures it waits for on the render side.
    pub fn capture_settled(&mut self, target: &Handle<Image>) -> Vec<[f32; 3]> {
        linear(self.capture_bytes_settled(target))
    }

    /// [`capture_bytes`](Self::capture_bytes) until two frames in a row agree (at most 10).
    pub fn capture_bytes_settled(&mut self, target: &Handle<Image>) -> Vec<[u8; 4]> {
        let mut last = self.capture_bytes(target);
        for _ in 0..10 {
            let next = self.capture_bytes(target);
            if next == last {
                return next;
            }
            last = next;
        }
        panic!("the frame did not settle in 10 captures");
    }

    /// Renders frames until image `image` (with `COPY_SRC` usage) is read back: its bytes as
    /// stored, rows unpadded.
    pub fn read_image(&mut self, image: &Handle<Image>) -> Vec<u8> {
        use bevy::render::gpu_readback::{Readback, ReadbackComplete};
        let read: Arc<Mutex<Option<Vec<u8>>>> = Arc::default();
        let slot = read.clone();
        // A standing readback (`ReadbackOnce` is dropped at the start of the next frame, before
        // this caller's first frame extracts it), despawned once it has answered.
        let reader = self
            .world()
            .spawn(Readback::texture(image.clone()))
            .observe(move |done: On<ReadbackComplete>| {
                *slot.lock().unwrap() = Some(done.data.clone());
            })
            .id();
        let done = self.update_until(20, |_| read.lock().unwrap().is_some());
        assert!(done, "no readback after 20 frames");
        self.world().despawn(reader);
        read.lock().unwrap().take().unwrap()
    }

    /// Renders a frame and reads `target` back as it is stored: RGBA bytes per pixel.
    pub fn capture_bytes(&mut self, target: &Handle<Image>) -> Vec<[u8; 4]> {
        let shot: Arc<Mutex<Option<Image>>> = Arc::default();
        let slot = shot.clone();
        self.world().spawn(Screenshot(RenderTarget::from(target.clone()))).observe(
            move |captured: On<ScreenshotCaptured>| {
                *slot.lock().unwrap() = Some(captured.image.clone());
            },
        );
        let captured = self.update_until(20, |_| shot.lock().unwrap().is_some());
        assert!(captured, "no screenshot after 20 frames");
        let image = shot.lock().unwrap().take().unwrap();
        let bytes = image.data.expect("screenshot data");
        bytes.chunks_exact(4).map(|p| [p[0], p[1], p[2], p[3]]).collect()
    }
}

/// sRGB bytes as linear RGB.
fn linear(pixels: Vec<[u8; 4]>) -> Vec<[f32; 3]> {
    let linear = |c: u8| {
        let c = c as f32 / 255.0;
        if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
    };
    pixels.into_iter().map(|p| [linear(p[0]), linear(p[1]), linear(p[2])]).collect()
}

/// A scene for comparing a method's shadow term with a reference: hikage's plugin, no ambient
/// light, a sun with shadow maps shining from `toward_sun`, and a camera at `view` drawing into
/// a `size`² sRGB image with nothing of its own on the pixels (no MSAA, tonemapping or dither).
pub struct MaskScene {
    /// The app.
    pub app: Headless,
    /// The camera's target.
    pub target: Handle<Image>,
    /// The sun.
    pub light: Entity,
}

impl MaskScene {
    /// The scene over assets in `assets`.
    pub fn new(assets: &Path, size: u32, toward_sun: Vec3, view: Transform, projection: Projection) -> MaskScene {
        use bevy::core_pipeline::tonemapping::DebandDither;
        use bevy::light::GlobalAmbientLight;
        use bevy::render::view::{Msaa, Tonemapping};
        let mut app = Headless::new(assets, |app| {
            app.add_plugins(hikage_bevy::HikagePlugin)
                .insert_resource(GlobalAmbientLight { brightness: 0.0, ..default() });
        });
        let target = app.target(size, size);
        let world = app.world();
        let light = world
            .spawn((
                DirectionalLight { illuminance: 2000.0, shadow_maps_enabled: true, ..default() },
                Transform::IDENTITY.looking_to(-toward_sun, Vec3::Y),
            ))
            .id();
        world.spawn((
            Camera3d::default(),
            RenderTarget::from(target.clone()),
            projection,
            view,
            Msaa::Off,
            Tonemapping::None,
            DebandDither::Disabled,
        ));
        MaskScene { app, target, light }
    }

    /// An orthographic projection `width` × `height` wide, from 0 to `far`.
    pub fn orthographic(width: f32, height: f32, far: f32) -> Projection {
        Projection::Orthographic(OrthographicProjection {
            scaling_mode: bevy::camera::ScalingMode::Fixed { width, height },
            near: 0.0,
            far,
            ..OrthographicProjection::default_3d()
        })
    }
}
