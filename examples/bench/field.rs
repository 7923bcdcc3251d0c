//! The terrain's sun-visibility field (issue 48) against the streamed terrain's own frame on this
//! adapter: the devkit's rough terrain at 1024² and 2048² (30 m texels) in 256² tiles with every
//! level, streamed along a low flight at 512² (update + render + read back); the field's full
//! rebuild (the sun moved), its finest level's (the camera moved a texel), and its mean cost a
//! frame as a game pays it: 120 frames of a camera moving 2 m a frame (430 km/h at 60 fps) under
//! a sun sinking 0.004° a frame (a day in 24 minutes), each update waited for on the device; its
//! memory at sides 256, 512 and 1024.

use std::time::Instant;

use hikage_runtime::glam::Vec3;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::horizon::{StreamOptions, Sun, SunField, SunFieldOptions, TerrainFrame, TerrainStream};
use hikage_runtime::{DrawOptions, wgpu};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, Headless, VISIBILITY_FORMAT};

const TEXEL: f32 = 30.0;
const FRAMES: usize = 24;
/// Frames of a game's camera and sun moving at game speeds.
const GAME_FRAMES: usize = 120;

pub fn run() {
    let Ok(g) = Headless::new() else {
        println!("(no GPU adapter: sun field skipped)\n");
        return;
    };
    println!(
        "The sun-visibility field against the streamed terrain's frame on {}: 256² tiles with every level, \
         16 directions, 4 field levels; 512² frames of a low flight (update + render + read back); field \
         updates waited for on the device, the game's mean over {GAME_FRAMES} frames of a camera 2 m and a sun \
         0.004° on a frame; best of 3\n",
        g.describe()
    );
    println!(
        "| map | field side | field memory | terrain frame | full rebuild | finest level | game's mean | \
         mean / frame | full / frame |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for n in [1024u32, 2048] {
        rows(&g, n);
    }
    println!();
}

fn rows(g: &Headless, n: u32) {
    let dir = std::env::temp_dir().join(format!("hikage-bench-field-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let heights: Vec<u8> = hikage_devkit::synth::terrain(n).into_iter().flat_map(f32::to_le_bytes).collect();
    std::fs::write(dir.join("dem.r32"), heights).expect("the DEM");
    let text = format!(
        r#"(output: "bundle", jobs: [Horizon(id: "dem", input: "dem.r32", texel_size: ({TEXEL}, {TEXEL}),
           height_scale: 1200, directions: 16, edge: Clamp, max_distance: 6000, tile: 256, levels: 16)])"#
    );
    std::fs::write(dir.join("pipeline.ron"), text).expect("the pipeline");
    hikage_bake::run::run_pipeline(&dir.join("pipeline.ron"), &Default::default()).expect("the terrain bakes");
    let options = DrawOptions {
        depth_format: Some(DEPTH_FORMAT),
        visibility_format: Some(VISIBILITY_FORMAT),
        ..DrawOptions::new(COLOR_FORMAT)
    };
    let side = n as f32 * TEXEL;
    let sun_at = |i: usize| {
        let e = (6.0 - 0.02 * i as f32).to_radians();
        Sun { direction: Vec3::new(-0.8 * e.cos(), e.sin(), 0.6 * e.cos()).normalize(), ..Sun::default() }
    };
    let frame_at = |i: usize| {
        let t = i as f32 / FRAMES as f32;
        let eye = Vec3::new(side * (0.2 + 0.6 * t), 1500.0, side * (0.25 + 0.5 * t));
        let view_proj = directx::perspective(1.0, 1.0, 10.0, 2.0 * side)
            * look_at_mat4(eye, eye + Vec3::new(1.0, -0.25, 0.8), Vec3::Y);
        (TerrainFrame { view_proj, sun: sun_at(i), ..TerrainFrame::default() }, eye)
    };
    let mut stream =
        TerrainStream::open(&g.device, &g.queue, &dir.join("bundle"), "dem", &options, StreamOptions::default())
            .expect("streams");
    for i in 0..FRAMES {
        let (frame, eye) = frame_at(i);
        for _ in 0..400 {
            if stream.update(&g.device, &g.queue, &frame, eye).expect("updates").missing == 0 {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }
    let wait = || g.device.poll(wgpu::PollType::wait_indefinitely()).expect("device poll");
    let terrain_frame = best(FRAMES, || {
        for i in 0..FRAMES {
            let (frame, eye) = frame_at(i);
            stream.update(&g.device, &g.queue, &frame, eye).expect("updates");
            g.render((512, 512), wgpu::Color::BLACK, |pass| stream.draw(pass));
        }
    });
    for field_side in [256u32, 512, 1024] {
        let field_options = SunFieldOptions { side: field_side, ..SunFieldOptions::default() };
        let mut field = SunField::new(&g.device, &stream, field_options).expect("a field");
        let (frame, eye) = frame_at(0);
        // A new sun each run: every level rebuilt.
        let mut turn = 0;
        let full = best(1, || {
            turn += 1;
            let sun = Sun { direction: frame.sun.direction + Vec3::Y * 0.01 * turn as f32, ..frame.sun };
            let stats =
                field.update(&g.device, &g.queue, &stream, &TerrainFrame { sun, ..frame }, eye).expect("builds");
            assert_eq!(stats.levels_built, field_options.levels);
            wait();
        });
        // The camera a texel on, then back, inside one texel of the next level: the finest alone.
        let step = field.texel_size(0).x;
        let coarser = field.texel_size(1).x;
        let eye = Vec3::new(((eye.x / coarser).floor() + 0.25) * coarser, eye.y, eye.z);
        let frame = TerrainFrame {
            sun: Sun { direction: frame.sun.direction + Vec3::Y * 0.01 * turn as f32, ..frame.sun },
            ..frame
        };
        field.update(&g.device, &g.queue, &stream, &frame, eye).expect("builds");
        let mut flip = false;
        let finest = best(1, || {
            flip = !flip;
            let at = eye + Vec3::X * if flip { step } else { 0.0 };
            let stats = field.update(&g.device, &g.queue, &stream, &frame, at).expect("builds");
            assert_eq!(stats.levels_built, 1);
            wait();
        });
        // A game's frames: the camera 2 m on, the sun 0.004° lower, each frame.
        let (start, eye) = frame_at(FRAMES / 2);
        let mut at = 0;
        let mean = best(GAME_FRAMES, || {
            for _ in 0..GAME_FRAMES {
                at += 1;
                let e = (6.0 - 0.004 * at as f32).to_radians();
                let sun = Sun { direction: Vec3::new(-0.8 * e.cos(), e.sin(), 0.6 * e.cos()).normalize(), ..start.sun };
                let eye = eye + Vec3::new(2.0, 0.0, 1.0) * at as f32;
                field.update(&g.device, &g.queue, &stream, &TerrainFrame { sun, ..start }, eye).expect("builds");
                wait();
            }
        });
        let mib = field.device_bytes() as f64 / (1 << 20) as f64;
        println!(
            "| {n}² ({:.0} km) | {field_side} | {mib:.0} MiB | {:.1} ms | {:.1} ms | {:.1} ms | {:.2} ms | {:.1}% | {:.0}% |",
            side / 1000.0,
            terrain_frame * 1e3,
            full * 1e3,
            finest * 1e3,
            mean * 1e3,
            100.0 * mean / terrain_frame,
            100.0 * full / terrain_frame
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The best of 3 runs of `f`, seconds per one of its `frames` frames.
fn best(frames: usize, mut f: impl FnMut()) -> f64 {
    (0..3)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() / frames as f64
        })
        .fold(f64::INFINITY, f64::min)
}
