//! The shadow-fit scene on the GPU.

use crate::util::gpu;

/// The shadow-fit scene on the GPU: σ from the shader's derivatives agrees with σ recomputed on
/// the CPU from the matrices alone at sampled pixels; the fitted projection gives a higher
/// density than the fixed one; ground far from every box is lit; and the fit, and the fit in
/// post-perspective space, get the lit state of nearly every pixel facing the light right
/// against a ray cast to the light.
#[test]
fn shadow_fit_scene_sigma_matches_the_cpu() {
    use hikage_runtime::glam::Vec3;
    use hikage_runtime::glam::camera::rh::proj::directx;
    use hikage_runtime::glam::camera::rh::view::look_at_mat4;
    use hikage_runtime::shadow_fit::{self, Camera, FitOptions, Light, Scratch};
    use hikage_scenes::shadow_scene::{FrameSetup, Scene, check_sigma, errors_exact, frame_stats, render_frame};

    let Some(g) = gpu("shadow_fit_scene_sigma_matches_the_cpu") else { return };
    let scene = Scene::boxes(60, 100.0, 3);
    let size = (200, 150);
    let camera = Camera {
        view: look_at_mat4(Vec3::new(-40.0, 5.0, 30.0), Vec3::new(0.0, 0.0, 0.0), Vec3::Y),
        projection: directx::perspective(60f32.to_radians(), 4.0 / 3.0, 0.5, 80.0),
    };
    let light_pos = Vec3::new(-150.0, 200.0, 60.0);
    let light = Light::Point(light_pos);
    let options = FitOptions {
        near: ((light_pos - scene.bounds.centre).length() - scene.bounds.radius) * 0.95,
        resolution: 512,
        ..FitOptions::new(scene.bounds)
    };
    let fit = shadow_fit::fit(light, &camera, &[scene.mesh()], &options, &mut Scratch::default());
    let psm = FitOptions { space: shadow_fit::FitSpace::PostPerspective(shadow_fit::PullBack::Balanced), ..options };
    let psm = shadow_fit::fit(light, &camera, &[scene.mesh()], &psm, &mut Scratch::default());
    let mut medians = Vec::new();
    for light_matrix in [shadow_fit::fixed(light, &options), fit.view_proj, psm.view_proj] {
        let setup =
            FrameSetup { camera: camera.view_proj(), light: light_matrix, source: light, resolution: 512, size };
        let data = render_frame(&g, &scene, &setup);
        let (checked, agree) = check_sigma(&data, &setup, 7);
        let stats = frame_stats(&data, 512);
        let ground: Vec<_> =
            data.world.iter().zip(&data.shadow).filter(|(w, s)| w[3] == 2.0 && w[1] < 0.01 && s[3] >= 0.0).collect();
        let lit = ground.iter().filter(|(_, s)| s[3] > 0.5).count() as f64 / ground.len().max(1) as f64;
        let wrong = errors_exact(&scene, &data, light);
        eprintln!(
            "σ median {:.3} p10 {:.3}; {checked} pixels checked, {:.2}% within 5% of the CPU; ground lit {:.1}%; lit state ≠ ray cast on {:.2}%",
            stats.sigma_median,
            stats.sigma_p10,
            100.0 * agree as f64 / checked as f64,
            100.0 * lit,
            100.0 * wrong
        );
        if light_matrix != shadow_fit::fixed(light, &options) {
            assert!(wrong < 0.02, "lit state wrong on {:.2}% of pixels", 100.0 * wrong);
        }
        assert!(checked > 1000);
        assert!(agree as f64 >= 0.97 * checked as f64);
        assert!((0.5..0.98).contains(&lit), "ground lit {lit}: shadows missing or acne");
        medians.push(stats.sigma_median);
    }
    assert!(medians[1] > 1.5 * medians[0], "fit σ {} vs fixed {}", medians[1], medians[0]);
}
