//! Relief mapping on the GPU against the CPU reference of the same tracers.

use hikage_runtime::{CpuBundle, GpuBundle};

use crate::util::{Dir, gpu};

/// A relief quad traced on the GPU by every tracer agrees with the CPU reference of the same
/// tracer: the hit within one texel on at least 99% of the quad's pixels, and the read counts
/// equal on most of them (the same search, step for step).
#[test]
fn relief_quad_render_matches_the_cpu_tracers() {
    use hikage_runtime::glam::Vec3;
    use hikage_runtime::relief::{Reads, ReliefMaps, Tracer};
    use hikage_scenes::relief_plane::{PlaneView, SHADOW_BIAS, camera_ray, render};

    let dir = Dir::new("gpu_relief");
    dir.copy_data();
    dir.run(&["relief", "data/relief_bricks.png", "--out", "bundle", "--theta", "16", "--phi", "16"]);
    let cpu = CpuBundle::read(&dir.path("bundle")).unwrap();
    let maps = ReliefMaps::from_bundle(&cpu, "relief_bricks.relief").unwrap();
    let Some(g) = gpu("relief_quad_render_matches_the_cpu_tracers") else { return };
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let (mv, dv) = (&gb.textures["relief_bricks.maxmip"].view, &gb.textures["relief_bricks.relief"].view);
    let view = PlaneView {
        eye: Vec3::new(128.0, -20.0, 75.0),
        target: Vec3::new(128.0, 120.0, 0.0),
        fov_y_degrees: 50.0,
        width: 160,
        height: 120,
        light: Vec3::new(-0.5, 0.3, 0.6).normalize(),
        shadows: true,
        ao_stride: 16,
    };
    for tracer in [
        Tracer::Linear { steps: 48, binary: 6 },
        Tracer::DepthMap { steps: 32, binary: 6 },
        Tracer::MaxMip { start_level: 8, stop_level: 0 },
        Tracer::Combined { margin: 0.1, start_level: 3 },
    ] {
        let (_, pixels) = render(&g, &maps, tracer, &view, mv, dv);
        let (mut quad, mut close, mut same_reads, mut same_shade) = (0, 0, 0, 0);
        let (mut lit_count, mut ao_sum) = (0, 0.0);
        for (i, px) in pixels.iter().enumerate() {
            let ray = camera_ray(&view, &maps, i as u32 % view.width, i as u32 / view.width);
            assert_eq!(ray.is_some(), px.on_quad, "{tracer:?}: pixel {i} on the quad on one side only");
            let Some(ray) = ray else { continue };
            let mut reads = Reads::default();
            let s = maps.trace(tracer, &ray, &mut reads);
            quad += 1;
            close += ((s - px.s).abs() <= 1.0) as u32;
            same_reads += (reads.height == px.height_reads && reads.depth == px.depth_reads) as u32;
            // Shadow and ambient occlusion at the CPU's hit, from the same depth maps.
            let p = ray.at(s);
            let lit = maps.lit(p, view.light.to_array(), SHADOW_BIAS, &mut reads);
            let ao = maps.ambient_occlusion(p, view.ao_stride, SHADOW_BIAS, &mut reads);
            same_shade += (lit == px.lit && (ao - px.ao).abs() <= 0.02) as u32;
            lit_count += lit as u32;
            ao_sum += ao;
        }
        let share = close as f64 / quad as f64;
        eprintln!(
            "{}: {quad} quad pixels, {:.2}% within a texel, {:.2}% with equal read counts, {:.2}% same shadow and AO",
            tracer.name(),
            100.0 * share,
            100.0 * same_reads as f64 / quad as f64,
            100.0 * same_shade as f64 / quad as f64
        );
        assert!(same_shade as f64 >= 0.99 * quad as f64, "{tracer:?}: shadow or AO differ");
        // The comparison means something: the view has shadows and occlusion.
        let lit_share = lit_count as f64 / quad as f64;
        assert!((0.1..0.95).contains(&lit_share), "lit share {lit_share}");
        assert!(ao_sum / (quad as f32) < 0.97, "mean AO {}", ao_sum / quad as f32);
        assert!(quad > 12_000, "the quad should fill most of the image, {quad} pixels");
        assert!(share >= 0.99, "{tracer:?}: only {:.2}% of pixels within a texel", 100.0 * share);
        assert!(same_reads as f64 >= 0.9 * quad as f64, "{tracer:?}: read counts differ on many pixels");
    }
}
