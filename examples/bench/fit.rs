//! Shadow-map fitting: CPU cost of the per-frame fit per 100,000 vertices, on one core.

use hikage_runtime::glam::Vec3;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::shadow_fit::{self, FitOptions, Light, Scratch};
use hikage_scenes::shadow_scene::Scene;

use crate::best_of;

/// The fit rows (issue 6).
pub fn run() {
    // 4,166 boxes × 24 vertices + the ground ≈ 100,000 vertices.
    let scene = Scene::boxes(4166, 400.0, 7);
    let vertices = scene.positions.len();
    let camera = directx::perspective(60f32.to_radians(), 4.0 / 3.0, 0.5, 150.0)
        * look_at_mat4(Vec3::new(90.0, 4.0, 0.0), Vec3::new(90.0, 1.0, 20.0), Vec3::Y);
    let light = Light::Point(Vec3::new(-260.0, 380.0, 160.0));
    let base = FitOptions::new(scene.bounds);
    println!(
        "Shadow-map fit, CPU, one thread ({vertices} vertices, {} triangles; best of 20)\n",
        scene.indices.len() / 3
    );
    println!("| fit | time | per 100,000 vertices | target | ratio |");
    println!("|---|---|---|---|---|");
    let mesh = [scene.mesh()];
    let mut scratch = Scratch::default();
    let variants = [
        ("seed's vertex test only", FitOptions { vertex_test_only: true, ..base }),
        ("vertices + triangle clipping", base),
        ("+ snapping", FitOptions { snap: true, ..base }),
        ("+ PSM", FitOptions { psm: true, ..base }),
    ];
    for (name, o) in variants {
        let (t, fit) = best_of(20, || shadow_fit::fit(light, camera, &mesh, &o, &mut scratch));
        let per = t * 1e3 * 100_000.0 / vertices as f64;
        assert!(fit.view_proj.is_finite());
        println!("| {name} | {:.3} ms | {per:.3} ms | 1 ms | {:.2}× of the budget |", t * 1e3, per);
    }
    println!();
}
