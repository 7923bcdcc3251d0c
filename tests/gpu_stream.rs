//! A terrain baked in tiles and levels of detail, streamed by `TerrainStream` on the GPU: with
//! level 0 everywhere it shades as the one-mesh terrain of the whole map (sun and sky
//! visibility and colour, tile edges included),
//! and a scripted flight keeps its budgets and always has terrain under the camera.

use std::path::PathBuf;

use hikage_runtime::glam::Vec3;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::horizon::{StreamOptions, Sun, TerrainFrame, TerrainShadows, TerrainStream};
use hikage_runtime::{CpuBundle, DrawOptions, GpuBundle, wgpu};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, VISIBILITY_FORMAT};

use crate::util::{Dir, gpu};

/// Map side, tile size and texel size (m) of the generated terrain.
const N: u32 = 1024;
const TILE: u32 = 64;
const TEXEL: f32 = 30.0;

/// A 1024² rough terrain (devkit's generator), baked whole and in 64² tiles with every level.
fn bundle() -> PathBuf {
    use std::sync::OnceLock;
    static BAKED: OnceLock<PathBuf> = OnceLock::new();
    BAKED
        .get_or_init(|| {
            let dir = Dir::new("gpu_stream");
            let heights: Vec<u8> = hikage_devkit::synth::terrain(N).into_iter().flat_map(f32::to_le_bytes).collect();
            dir.write("dem.r32", heights);
            let job = |id: &str, tiles: &str| {
                format!(
                    r#"Horizon(id: "{id}", input: "dem.r32", texel_size: ({TEXEL}, {TEXEL}), height_scale: 1200,
                       directions: 16, edge: Clamp, max_distance: 600, ao: true{tiles}),"#
                )
            };
            let tiled = format!(", tile: {TILE}, levels: 16");
            dir.write(
                "pipeline.ron",
                format!(r#"(output: "bundle", jobs: [{} {}])"#, job("whole", ""), job("dem", &tiled)),
            );
            dir.run(&["bake"]);
            dir.path("bundle")
        })
        .clone()
}

fn options() -> DrawOptions {
    DrawOptions {
        depth_format: Some(DEPTH_FORMAT),
        visibility_format: Some(VISIBILITY_FORMAT),
        ..DrawOptions::new(COLOR_FORMAT)
    }
}

/// A low sun from the south-west, 6° up.
fn low_sun() -> Sun {
    let e = 6f32.to_radians();
    Sun {
        direction: Vec3::new(-0.8 * e.cos(), e.sin(), 0.6 * e.cos()).normalize(),
        color: Vec3::ONE,
        angular_radius: 0.0,
    }
}

#[test]
fn streamed_level_0_shades_as_the_whole_map_across_tile_edges() {
    let dir = bundle();
    let Some(g) = gpu("streamed_level_0_shades_as_the_whole_map_across_tile_edges") else { return };
    let cpu = CpuBundle::read_prefix(&dir, "whole.").unwrap();
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let whole = TerrainShadows::new(&g.device, &g.queue, &gb, "whole.horizon", Some("whole.ao"), &options()).unwrap();
    // Level 0 everywhere: every tile split down to level 0, all of them resident.
    let stream_options =
        StreamOptions { detail: 1e9, resident_bytes: 1 << 30, upload_bytes: 1 << 30, ..StreamOptions::default() };
    let mut stream = TerrainStream::open(&g.device, &g.queue, &dir, "dem", &options(), stream_options).unwrap();

    // Straight down on the whole map, one pixel a texel.
    let side = N as f32 * TEXEL;
    let half = side / 2.0;
    let view_proj = directx::orthographic(-half, half, -half, half, 100.0, 5000.0)
        * look_at_mat4(Vec3::new(half, 3000.0, half), Vec3::new(half, 0.0, half), Vec3::NEG_Z);
    let frame = TerrainFrame { view_proj, sun: low_sun(), ..TerrainFrame::default() };
    let eye = Vec3::new(half, 3000.0, half);
    let mut stats = stream.update(&g.device, &g.queue, &frame, eye).unwrap();
    for _ in 0..2000 {
        if stats.missing == 0 && stats.finest_drawn == 0 {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
        stats = stream.update(&g.device, &g.queue, &frame, eye).unwrap();
    }
    assert_eq!((stats.missing, stats.finest_drawn, stats.drawn), (0, 0, 256), "{stats:?}");
    whole.update(&g.queue, &frame);
    let a = g.render((N, N), wgpu::Color::BLACK, |pass| whole.draw(pass));
    let b = g.render((N, N), wgpu::Color::BLACK, |pass| stream.draw(pass));

    // Sun and sky visibility, pixel by pixel; pixels within one of a tile edge apart.
    let (mut covered, mut differ, mut edge_pixels, mut edge_differ, mut lit) = (0, 0, 0, 0, 0);
    let mut colour_differ = 0;
    for row in 1..N - 1 {
        for col in 1..N - 1 {
            let (p, q) = (a.visibility[(row * N + col) as usize], b.visibility[(row * N + col) as usize]);
            if p[1] < 0.5 {
                continue;
            }
            covered += 1;
            lit += (p[0] > 0.5) as usize;
            let near_edge = [col, row].iter().any(|&c| matches!(c % TILE, 0 | 1 | 63));
            edge_pixels += near_edge as usize;
            let different = q[1] < 0.5 || (p[0] - q[0]).abs() > 1.0 / 255.0 || (p[2] - q[2]).abs() > 1.0 / 255.0;
            differ += different as usize;
            let at = (row * N + col) as usize * 4;
            colour_differ +=
                (a.color[at..at + 3].iter().zip(&b.color[at..at + 3]).any(|(x, y)| x.abs_diff(*y) > 1)) as usize;
            edge_differ += (different && near_edge) as usize;
        }
    }
    eprintln!(
        "stream vs whole: {covered} pixels, {:.1}% lit; {differ} differ ({colour_differ} in colour), \
         {edge_differ} of {edge_pixels} along tile edges",
        100.0 * lit as f64 / covered as f64
    );
    assert!(covered > 1_000_000 && edge_pixels > 90_000);
    assert!((0.2..0.95).contains(&(lit as f64 / covered as f64)), "a low sun casts long shadows");
    assert_eq!(edge_differ, 0, "tile edges");
    assert!(differ as f64 <= 0.001 * covered as f64, "{differ} pixels differ");
}

#[test]
fn a_flight_keeps_its_budgets_and_always_has_terrain_underneath() {
    let dir = bundle();
    let Some(g) = gpu("a_flight_keeps_its_budgets_and_always_has_terrain_underneath") else { return };
    // A level-0 tile is 65² heights (f32), 65²×16 horizons (rg16f) and 65² occlusion (r8):
    // about 0.29 MiB. Room for about 24 of them, uploads of about 2 a frame.
    let budget = StreamOptions { resident_bytes: 8 << 20, upload_bytes: 640 << 10, ..StreamOptions::default() };
    let mut stream = TerrainStream::open(&g.device, &g.queue, &dir, "dem", &options(), budget).unwrap();
    let side = N as f32 * TEXEL;
    let (mut finest, mut uploaded, mut evicted_some) = (u32::MAX, 0u64, false);
    let frames = 240;
    let mut resident_before = 0;
    for f in 0..frames {
        // Low over the map, corner to corner, looking ahead.
        let t = f as f32 / (frames - 1) as f32;
        let eye = Vec3::new(side * (0.05 + 0.9 * t), 900.0, side * (0.1 + 0.8 * t));
        let view_proj = directx::perspective(1.0, 1.0, 10.0, 40_000.0)
            * look_at_mat4(eye, eye + Vec3::new(1.0, -0.3, 1.0), Vec3::Y);
        let frame = TerrainFrame { view_proj, sun: low_sun(), ..TerrainFrame::default() };
        let stats = stream.update(&g.device, &g.queue, &frame, eye).unwrap();
        assert!(stats.resident_bytes <= budget.resident_bytes, "frame {f}: {stats:?}");
        assert!(stats.uploaded_bytes <= budget.upload_bytes, "frame {f}: {stats:?}");
        // Terrain under the camera: a drawn tile's rectangle holds its position.
        let under =
            stream.drawn().any(|(_, [lo, hi])| (lo.0..=hi.0).contains(&eye.x) && (lo.1..=hi.1).contains(&eye.z));
        assert!(under, "frame {f}: no tile under the camera at {eye}");
        finest = finest.min(stats.finest_drawn);
        uploaded += stats.uploaded_bytes;
        evicted_some |= stats.resident_bytes < resident_before + stats.uploaded_bytes;
        resident_before = stats.resident_bytes;
        if f % 60 == 59 {
            let shot = g.render((128, 128), wgpu::Color::BLACK, |pass| stream.draw(pass));
            let covered = shot.visibility.iter().filter(|v| v[1] > 0.5).count();
            assert!(covered > 128 * 128 / 4, "frame {f}: terrain covers {covered} pixels");
        }
        std::thread::sleep(std::time::Duration::from_millis(4));
    }
    eprintln!("flight: finest level drawn {finest}, {:.1} MiB uploaded", uploaded as f64 / (1 << 20) as f64);
    assert_eq!(finest, 0, "the flight reaches level 0 under the camera");
    assert!(evicted_some && uploaded > budget.resident_bytes, "the flight streams more than it holds");

    // Budgets too small for the coarsest level, or for one tile, are refused by name.
    for (small, what) in [
        (StreamOptions { resident_bytes: 1 << 10, ..budget }, "resident budget"),
        (StreamOptions { upload_bytes: 1 << 10, ..budget }, "upload budget"),
    ] {
        let err = TerrainStream::open(&g.device, &g.queue, &dir, "dem", &options(), small).unwrap_err().to_string();
        assert!(err.contains(what) && err.contains("dem"), "{err}");
    }
    let err = TerrainStream::open(&g.device, &g.queue, &dir, "nothing", &options(), budget).unwrap_err().to_string();
    assert!(err.contains("dem") && err.contains("nothing"), "{err}");
}
