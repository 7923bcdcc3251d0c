//! Seed 001, headless: 300 boxes over a 400 × 400 ground under a spot light, a camera walking
//! 120 frames along a path through them. Each frame is drawn with five light projections at the
//! same 1024² shadow-map resolution — seed 001's Table 1 (a fixed frustum around the whole scene,
//! plain perspective shadow maps, the seed's fit to the visible geometry, the fit in
//! post-perspective space) and the fit snapped to the texel grid — and the figures of
//! docs/shadow-fit.md are printed: texel density σ on visible surfaces (shadow-map texels per
//! screen pixel; median and 10th percentile), the share of shadow-map texels visible pixels use,
//! the share of pixels whose lit state differs from a 4096² reference, on a slow path the share
//! whose lit state flips between frames, and the CPU time of each projection against polygon
//! count (Table 1's 20,000–100,000). σ is checked on the CPU for sampled pixels. Writes a PNG
//! strip of frames with their shadow maps.
//!
//! ```text
//! cargo run --release -p hikage-scenes --example shadow_fit -- docs/images
//! ```

use std::path::PathBuf;

use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::glam::{Mat4, Vec3};
use hikage_runtime::shadow_fit::{Camera, Scratch};
use hikage_scenes::headless::Headless;
use hikage_scenes::shadow_scene::{
    EMPTY, FACE_NORMALS, FrameData, FrameSetup, Projection, Scene, check_sigma, cpu_times, errors_exact, flips,
    frame_stats, render_frame, spot_light,
};

const RESOLUTION: u32 = 1024;
const SIZE: (u32, u32) = (320, 240);

/// Camera of frame `k` of `n` on a path: along a circle of radius 90 at eye height 4, looking
/// ahead and slightly down; `arc` is the share of the circle walked.
fn camera(k: u32, n: u32, arc: f32) -> Camera {
    let a = std::f32::consts::TAU * arc * k as f32 / n as f32;
    let eye = Vec3::new(90.0 * a.cos(), 4.0, 90.0 * a.sin());
    let ahead = Vec3::new(-a.sin(), 0.0, a.cos());
    let target = eye + ahead * 20.0 - Vec3::new(0.0, 3.0, 0.0) - eye.normalize() * 4.0;
    Camera {
        view: look_at_mat4(eye, target, Vec3::Y),
        projection: directx::perspective(60f32.to_radians(), SIZE.0 as f32 / SIZE.1 as f32, 0.5, 150.0),
    }
}

/// One frame's figures for one projection: σ median, σ p10, texels used, gain ÷ expected gain,
/// share outside the map, share disagreeing with the 4096² fit, share disagreeing with the
/// exact (ray-cast) lit state.
type Figures = (f64, f64, f64, f64, f64, f64, f64);

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() { f64::NAN } else { v[v.len() / 2] }
}

fn shade(data: &FrameData) -> Vec<[u8; 4]> {
    data.shadow
        .iter()
        .zip(&data.world)
        .map(|(s, w)| {
            if w[3] < 0.0 {
                return [140, 170, 215, 255];
            }
            let n = FACE_NORMALS[w[3] as usize % 6];
            let diffuse = n.dot(Vec3::new(-0.45, 0.8, 0.4).normalize()).max(0.0);
            let lit = if s[3] > 0.5 { 1.0 } else { 0.0 };
            let v = (0.25 + 0.7 * diffuse * lit) * 255.0;
            let tint = if s[3] < 0.0 { [1.0, 0.6, 0.6] } else { [1.0, 0.97, 0.9] };
            [(v * tint[0]) as u8, (v * tint[1]) as u8, (v * tint[2]) as u8, 255]
        })
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "target/shadow_fit".into()));
    std::fs::create_dir_all(&out)?;
    let gpu = Headless::new()?;
    println!("adapter: {}", gpu.describe());
    let scene = Scene::boxes(300, 200.0, 1);
    let (light, base) = spot_light(&scene, RESOLUTION);
    let methods = Projection::ALL;
    let mut scratch = Scratch::default();
    let mesh = [scene.mesh()];
    // The light matrix, the fitted radius (the scene's for the fixed frustum) and the pull-back.
    let light_matrix = |m: Projection, cam: &Camera, scratch: &mut Scratch| {
        let (matrix, fit) = m.light_matrix(light, cam, &mesh, &base, scratch);
        let radius = fit.map_or(scene.bounds.radius, |f| f.sphere.radius);
        (matrix, radius, fit.map_or(0.0, |f| f.pull_back))
    };

    let frames = 120;
    println!(
        "{} vertices, {} triangles; path of {frames} frames, {}×{} pixels, {RESOLUTION}² shadow maps",
        scene.positions.len(),
        scene.indices.len() / 3,
        SIZE.0,
        SIZE.1
    );
    let mut per_method: Vec<Vec<Figures>> = vec![Vec::new(); methods.len()];
    let mut pull_backs: Vec<Vec<f64>> = vec![Vec::new(); methods.len()];
    let (mut checked, mut agree) = (0usize, 0usize);
    let mut strip = Vec::new();
    for k in 0..frames {
        let cam = camera(k, frames, 0.5);
        let mut fixed_sigma = 0.0;
        // Reference lit states: the fit (which keeps every caster) at 4× the resolution.
        let (rm, _, _) = light_matrix(Projection::SmFit, &cam, &mut scratch);
        let reference = render_frame(
            &gpu,
            &scene,
            &FrameSetup { camera: cam.view_proj(), light: rm, source: light, resolution: 4 * RESOLUTION, size: SIZE },
        );
        for (mi, &m) in methods.iter().enumerate() {
            let (lm, r, pull_back) = light_matrix(m, &cam, &mut scratch);
            pull_backs[mi].push(pull_back as f64);
            let setup =
                FrameSetup { camera: cam.view_proj(), light: lm, source: light, resolution: RESOLUTION, size: SIZE };
            let data = render_frame(&gpu, &scene, &setup);
            let st = frame_stats(&data, RESOLUTION);
            if m == Projection::Sm {
                fixed_sigma = st.sigma_median as f64;
            }
            // σ on the CPU for every 61st visible pixel inside a face.
            let (c, a) = check_sigma(&data, &setup, 61);
            (checked, agree) = (checked + c, agree + a);
            let gain = st.sigma_median as f64 / fixed_sigma.max(1e-9);
            let expected = scene.bounds.radius as f64 / r as f64;
            let wrong = flips(&reference, &data, light);
            per_method[mi].push((
                st.sigma_median as f64,
                st.sigma_p10 as f64,
                st.texels_used,
                gain / expected,
                st.outside,
                wrong,
                errors_exact(&scene, &data, light),
            ));
            if k % 40 == 0 {
                strip.push((k, m, data));
            }
        }
    }
    println!(
        "\nσ checked on the CPU at {checked} sampled pixels: {:.2}% within 5% of the GPU\n",
        100.0 * agree as f64 / checked.max(1) as f64
    );
    println!(
        "| projection | σ median | σ p10 | σ gain over fixed | gain ÷ (scene r / fitted r) | texels used | visible pixels outside the map | lit state ≠ exact (ray cast): median / mean | lit state ≠ 4096² fit | virtual camera pulled back (median) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let fixed_med = median(per_method[0].iter().map(|f| f.0).collect());
    for (mi, &m) in methods.iter().enumerate() {
        let f = &per_method[mi];
        let med = median(f.iter().map(|f| f.0).collect());
        println!(
            "| {} | {:.3} | {:.3} | {:.2}× | {} | {:.1}% | {:.2}% | {:.2}% / {:.2}% | {:.2}% | {} |",
            m.name(),
            med,
            median(f.iter().map(|f| f.1).collect()),
            med / fixed_med,
            // PSM's sphere lives in post-perspective space: no world radius to compare with.
            if matches!(m, Projection::Sm | Projection::Psm | Projection::PsmFitCasters | Projection::PsmFit) {
                "—".to_string()
            } else {
                format!("{:.2}", median(f.iter().map(|f| f.3).collect()))
            },
            100.0 * median(f.iter().map(|f| f.2).collect()),
            100.0 * median(f.iter().map(|f| f.4).collect()),
            100.0 * median(f.iter().map(|f| f.6).collect()),
            100.0 * f.iter().map(|f| f.6).sum::<f64>() / f.len().max(1) as f64,
            100.0 * median(f.iter().map(|f| f.5).collect()),
            if matches!(m, Projection::Psm | Projection::PsmFitCasters | Projection::PsmFit) {
                format!("{:.1}", median(pull_backs[mi].clone()))
            } else {
                "—".to_string()
            },
        );
    }

    // Shimmer: a slow path (1.5 m over 60 frames). Lit-state flips between consecutive frames
    // (camera motion included, the same for every projection), and the flips the refit alone
    // causes: the frame drawn with this frame's light matrix against the previous one's.
    println!(
        "\n| projection | pixels flipping between consecutive frames (slow path, median) | flips from the refit alone (median / mean) |"
    );
    println!("|---|---|---|");
    for &m in &methods {
        let mut prev: Option<(FrameData, Mat4)> = None;
        let (mut f, mut refit) = (Vec::new(), Vec::new());
        for k in 0..60 {
            let cam = camera(k, 60 * 376, 1.0);
            let (lm, _, _) = light_matrix(m, &cam, &mut scratch);
            let setup =
                FrameSetup { camera: cam.view_proj(), light: lm, source: light, resolution: RESOLUTION, size: SIZE };
            let data = render_frame(&gpu, &scene, &setup);
            if let Some((p, previous_light)) = &prev {
                f.push(flips(p, &data, light));
                let old = if *previous_light == lm {
                    data.clone()
                } else {
                    render_frame(&gpu, &scene, &FrameSetup { light: *previous_light, ..setup })
                };
                refit.push(flips(&old, &data, light));
            }
            prev = Some((data, lm));
        }
        let mean = refit.iter().sum::<f64>() / refit.len().max(1) as f64;
        println!("| {} | {:.3}% | {:.3}% / {:.3}% |", m.name(), 100.0 * median(f), 100.0 * median(refit), 100.0 * mean);
    }

    // Seed 001's Table 1 on the CPU side: the per-frame light-matrix work against polygon count.
    println!("\nCPU time per frame of the light matrix (one thread, best of 20), against polygon count:\n");
    print!("| triangles |");
    for m in Projection::ALL {
        print!(" {} |", m.name());
    }
    println!("\n|---|{}", "---|".repeat(Projection::ALL.len()));
    for polygons in [20_000u32, 37_000, 67_000, 100_000] {
        print!("| {polygons} |");
        for (_, t) in cpu_times(polygons, 20) {
            print!(" {:.3} ms |", t * 1e3);
        }
        println!();
    }

    // The strip: rows are frames 0, 40, 80; columns the camera image and the shadow map of each
    // projection.
    let (w, h) = SIZE;
    let map_px = h;
    let cols = methods.len() as u32;
    let rows = frames.div_ceil(40);
    let mut image = image::RgbaImage::new(cols * (w + map_px), rows * h);
    for (k, m, data) in &strip {
        let (row, col) = (k / 40, methods.iter().position(|x| x == m).expect("listed") as u32);
        let (ox, oy) = (col * (w + map_px), row * h);
        for (i, c) in shade(data).into_iter().enumerate() {
            image.put_pixel(ox + i as u32 % w, oy + i as u32 / w, image::Rgba(c));
        }
        // Distances stretched to the range the map holds (white: nothing drawn there).
        let drawn = data.map.iter().filter(|&&d| d < EMPTY);
        let (lo, hi) = drawn.fold((1.0f32, 0.0f32), |(lo, hi), &d| (lo.min(d), hi.max(d)));
        for y in 0..map_px {
            for x in 0..map_px {
                let (mx, my) = (x * RESOLUTION / map_px, y * RESOLUTION / map_px);
                let d = data.map[(my * RESOLUTION + mx) as usize];
                let v = if d >= EMPTY { 255 } else { (20.0 + 200.0 * (d - lo) / (hi - lo).max(1e-9)) as u8 };
                image.put_pixel(ox + w + x, oy + y, image::Rgba([v, v, v, 255]));
            }
        }
    }
    let path = out.join("shadow_fit.png");
    hikage_scenes::png::save(&image, &path)?;
    println!("\nwrote {}", path.display());
    Ok(())
}
