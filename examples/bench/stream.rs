//! A streamed terrain (issue 38) against the one-mesh terrain of the same map on this adapter:
//! the devkit's rough terrain at 2048² (the largest the one-mesh terrain's 3D texture holds on
//! lavapipe) and 4096², baked whole and in 256² tiles with every level (16 directions), a
//! camera flying low across it at 512², frames timed after the stream settles (best of 3
//! flights of 24 frames: update + render + read back); bytes resident.

use std::time::Instant;

use hikage_runtime::glam::Vec3;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::horizon::{StreamOptions, Sun, TerrainFrame, TerrainShadows, TerrainStream};
use hikage_runtime::{CpuBundle, DrawOptions, GpuBundle, wgpu};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, Headless, VISIBILITY_FORMAT};

const TEXEL: f32 = 30.0;
const FRAMES: usize = 24;

pub fn run() {
    let Ok(g) = Headless::new() else {
        println!("(no GPU adapter: streamed terrain skipped)\n");
        return;
    };
    println!(
        "Streamed terrain against the one-mesh terrain on {}: 256² tiles with every level, 16 directions, \
         512² frames of a low flight (update + render + read back), best of 3 flights of {FRAMES} frames\n",
        g.describe()
    );
    println!(
        "| map | streamed frame | tiles drawn | resident | one-mesh frame | one-mesh on the device | frame ratio | memory ratio |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for n in [2048u32, 4096] {
        row(&g, n);
    }
    println!();
}

fn row(g: &Headless, n: u32) {
    let dir = std::env::temp_dir().join(format!("hikage-bench-stream-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let heights: Vec<u8> = hikage_devkit::synth::terrain(n).into_iter().flat_map(f32::to_le_bytes).collect();
    std::fs::write(dir.join("dem.r32"), heights).expect("the DEM");
    let job = |id: &str, extra: &str| {
        format!(
            r#"Horizon(id: "{id}", input: "dem.r32", texel_size: ({TEXEL}, {TEXEL}), height_scale: 1200,
               directions: 16, edge: Clamp, max_distance: 1500, ao: true{extra}),"#
        )
    };
    let text = format!(r#"(output: "bundle", jobs: [{} {}])"#, job("whole", ""), job("dem", ", tile: 256, levels: 16"));
    std::fs::write(dir.join("pipeline.ron"), text).expect("the pipeline");
    hikage_bake::run::run_pipeline(&dir.join("pipeline.ron"), &Default::default()).expect("the terrain bakes");
    let bundle = dir.join("bundle");
    let options = DrawOptions {
        depth_format: Some(DEPTH_FORMAT),
        visibility_format: Some(VISIBILITY_FORMAT),
        ..DrawOptions::new(COLOR_FORMAT)
    };
    let side = n as f32 * TEXEL;
    let sun = Sun { direction: Vec3::new(-0.8, 0.1, 0.6).normalize(), ..Sun::default() };
    let frame_at = |i: usize| {
        let t = i as f32 / FRAMES as f32;
        let eye = Vec3::new(side * (0.2 + 0.6 * t), 1500.0, side * (0.25 + 0.5 * t));
        let view_proj = directx::perspective(1.0, 1.0, 10.0, 2.0 * side)
            * look_at_mat4(eye, eye + Vec3::new(1.0, -0.25, 0.8), Vec3::Y);
        (TerrainFrame { view_proj, sun, ..TerrainFrame::default() }, eye)
    };

    let mut stream =
        TerrainStream::open(&g.device, &g.queue, &bundle, "dem", &options, StreamOptions::default()).expect("streams");
    // Settle along the flight, then time it.
    for i in 0..FRAMES {
        let (frame, eye) = frame_at(i);
        for _ in 0..400 {
            let stats = stream.update(&g.device, &g.queue, &frame, eye).expect("updates");
            if stats.missing == 0 {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }
    let (mut drawn, mut resident) = (0, 0);
    let streamed = best(|| {
        for i in 0..FRAMES {
            let (frame, eye) = frame_at(i);
            let stats = stream.update(&g.device, &g.queue, &frame, eye).expect("updates");
            (drawn, resident) = (drawn.max(stats.drawn), resident.max(stats.resident_bytes));
            g.render((512, 512), wgpu::Color::BLACK, |pass| stream.draw(pass));
        }
    });
    let mib = |b: u64| b as f64 / (1 << 20) as f64;

    let cpu = CpuBundle::read_prefix(&bundle, "whole.").expect("reads");
    let whole = GpuBundle::upload(&g.device, &g.queue, &cpu).and_then(|gb| {
        TerrainShadows::new(&g.device, &g.queue, &gb, "whole.horizon", Some("whole.ao"), &options).map(|t| (t, gb))
    });
    match whole {
        Ok((terrain, gb)) => {
            let bytes: u64 = gb.textures.values().map(|t| t.desc.total_bytes().unwrap_or(0)).sum();
            let one = best(|| {
                for i in 0..FRAMES {
                    terrain.update(&g.queue, &frame_at(i).0);
                    g.render((512, 512), wgpu::Color::BLACK, |pass| terrain.draw(pass));
                }
            });
            println!(
                "| {n}² | {:.1} ms | {drawn} | {:.1} MiB | {:.1} ms | {:.1} MiB | {:.2}× | {:.2}× |",
                streamed * 1e3,
                mib(resident),
                one * 1e3,
                mib(bytes),
                streamed / one,
                resident as f64 / bytes as f64
            );
        }
        Err(e) => println!(
            "| {n}² | {:.1} ms | {drawn} | {:.1} MiB | refused: {e} | — | — | — |",
            streamed * 1e3,
            mib(resident)
        ),
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The best of 3 runs of `f` (a flight of `FRAMES` frames), seconds a frame.
fn best(mut f: impl FnMut()) -> f64 {
    (0..3)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() / FRAMES as f64
        })
        .fold(f64::INFINITY, f64::min)
}
