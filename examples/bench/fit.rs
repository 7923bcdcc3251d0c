//! Shadow-map fitting: CPU cost of the per-frame fit per 100,000 vertices, and seed 001's
//! Table 1 on the CPU side (each projection's per-frame time against polygon count).

use hikage_runtime::glam::Vec3;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::shadow_fit::{
    self, Camera, FitOptions, FitSpace, FitTarget, Light, PullBack, Scratch, Snap, VisibleTest,
};
use hikage_scenes::shadow_scene::{Projection, Scene, cpu_times};

use crate::best_of;

/// The fit tables.
pub fn run() {
    // 4,166 boxes × 24 vertices + the ground ≈ 100,000 vertices.
    let scene = Scene::boxes(4166, 400.0, 7);
    let vertices = scene.positions.len();
    let camera = Camera {
        view: look_at_mat4(Vec3::new(90.0, 4.0, 0.0), Vec3::new(90.0, 1.0, 20.0), Vec3::Y),
        projection: directx::perspective(60f32.to_radians(), 4.0 / 3.0, 0.5, 150.0),
    };
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
        ("seed's vertex test only", FitOptions { target: FitTarget::Visible(VisibleTest::VerticesOnly), ..base }),
        ("vertices + triangle clipping", base),
        ("+ snapping", FitOptions { snap: Snap::TexelGrid, ..base }),
        ("+ PSM (casters, pull-back)", FitOptions { space: FitSpace::PostPerspective(PullBack::Balanced), ..base }),
    ];
    for (name, o) in variants {
        let (t, fit) = best_of(20, || shadow_fit::fit(light, &camera, &mesh, &o, &mut scratch));
        let per = t * 1e3 * 100_000.0 / vertices as f64;
        assert!(fit.view_proj.is_finite());
        println!("| {name} | {:.3} ms | {per:.3} ms | 1 ms | {:.2}× of the budget |", t * 1e3, per);
    }
    println!();
    println!("Seed 001 Table 1, CPU side: per-frame light-matrix time against triangles (one thread, best of 20)\n");
    print!("| triangles |");
    for m in Projection::ALL {
        print!(" {} |", m.name());
    }
    println!(" PSM + fit ÷ SM + fit |");
    println!("|---|{}---|", "---|".repeat(Projection::ALL.len()));
    for polygons in [20_000u32, 37_000, 67_000, 100_000] {
        print!("| {polygons} |");
        let times = cpu_times(polygons, 20);
        for (_, t) in &times {
            print!(" {:.3} ms |", t * 1e3);
        }
        let of = |p: Projection| times.iter().find(|(q, _)| *q == p).map_or(f64::NAN, |(_, t)| *t);
        println!(" {:.2}× |", of(Projection::PsmFit) / of(Projection::SmFit));
    }
    println!();
}
