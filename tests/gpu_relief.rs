//! Relief mapping on the GPU against the CPU reference of the same tracers.

use hikage_runtime::{CpuBundle, DrawOptions, GpuBundle};

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

/// The relief material on a curved mesh (`data/sphere.obj` with the brick relief, seed 003's
/// Fig. 12 setting: shadows and ambient occlusion) drawn on the GPU, against its CPU reference
/// on a CPU rasterisation of the same mesh: the hit depth within 2% of the relief's depth, and
/// the same shadow and occlusion, on at least 99% of the pixels, for every tracer.
#[test]
fn relief_material_on_a_curved_mesh_matches_the_cpu() {
    use hikage_runtime::glam::{Vec2, Vec3, Vec4};
    use hikage_runtime::relief::{
        ReliefFrame, ReliefMaps, ReliefMaterial, ReliefMaterialUniform, Tracer, relief_material_shade,
    };
    use hikage_runtime::wgpu;
    use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, VISIBILITY_FORMAT};
    use hikage_scenes::horizon_sphere::AnalyticSphere;
    use hikage_scenes::raster::{interpolate, rasterise};

    let dir = crate::util::shared_bundle(
        "gpu_relief_material",
        r#"(output: "bundle", jobs: [
            Curvature(id: "sphere", input: "data/sphere.obj"),
            Relief(id: "relief_bricks", input: "data/relief_bricks.png", theta: 16, phi: 16),
        ])"#,
    );
    let cpu = CpuBundle::read(&dir).unwrap();
    let maps = ReliefMaps::from_bundle(&cpu, "relief_bricks.relief").unwrap();
    let mesh = cpu.asset("sphere").unwrap().mesh().unwrap().clone();
    let vertices = hikage_scenes::relief_vertices(&mesh);
    let indices = mesh.read_indices().unwrap();
    let Some(g) = gpu("relief_material_on_a_curved_mesh_matches_the_cpu") else { return };
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let options = DrawOptions {
        depth_format: Some(DEPTH_FORMAT),
        visibility_format: Some(VISIBILITY_FORMAT),
        cull_mode: Some(wgpu::Face::Back),
        ..DrawOptions::new(COLOR_FORMAT)
    };
    let material = ReliefMaterial::new(&g.device, &g.queue, &gb, "relief_bricks.relief", &options).unwrap();
    let vbytes = hikage_runtime::bytemuck::cast_slice(&vertices);
    let vbuf = g.buffer(vbytes.len() as u64, wgpu::BufferUsages::VERTEX, Some(vbytes));
    let ibytes = hikage_runtime::bytemuck::cast_slice(&indices);
    let ibuf = g.buffer(ibytes.len() as u64, wgpu::BufferUsages::INDEX, Some(ibytes));

    let sphere = AnalyticSphere::SAMPLE;
    let view_proj = sphere.view_proj();
    let size = 192u32;
    let clip: Vec<Vec4> = vertices.iter().map(|v| view_proj * Vec3::from(v.position).extend(1.0)).collect();
    let cover = rasterise(&clip, &indices, (size, size), true);
    let stream = |f: &dyn Fn(&hikage_runtime::relief::ReliefVertex) -> Vec<f32>| -> Vec<f32> {
        vertices.iter().flat_map(f).collect()
    };
    let (pos, nor, tan, uv) = (
        stream(&|v| v.position.to_vec()),
        stream(&|v| v.normal.to_vec()),
        stream(&|v| v.tangent.to_vec()),
        stream(&|v| v.uv.to_vec()),
    );
    for tracer in [
        Tracer::Linear { steps: 48, binary: 6 },
        Tracer::DepthMap { steps: 32, binary: 6 },
        Tracer::Combined { margin: 0.1, start_level: 3 },
    ] {
        let frame = ReliefFrame {
            view_proj,
            view_direction: Some(Vec3::NEG_Z),
            light: Vec3::new(-0.6, 0.5, 0.6).normalize(),
            tile: Vec2::splat(std::f32::consts::TAU * sphere.radius / sphere.tiles),
            tracer,
            ..ReliefFrame::default()
        };
        material.update(&g.queue, &frame);
        let f = g.render((size, size), wgpu::Color::BLACK, |pass| {
            material.draw(pass, vbuf.slice(..), ibuf.slice(..), indices.len() as u32)
        });
        let uniform = ReliefMaterialUniform::new(&frame);
        let (mut both, mut close, mut same, mut lit, mut shadowed) = (0, 0, 0, 0, 0);
        for (i, c) in cover.iter().enumerate() {
            let (Some((t, w)), true) = (*c, f.visibility[i][1] > 0.5) else { continue };
            let at = |s: &[f32], k: usize| interpolate(s, k, &indices, t, w);
            let p = relief_material_shade(
                &maps,
                tracer,
                &uniform,
                Vec3::from_slice(&at(&pos, 3)),
                Vec3::from_slice(&at(&nor, 3)),
                Vec4::from_slice(&at(&tan, 4)),
                Vec2::from_slice(&at(&uv, 2)),
            );
            let v = f.visibility[i];
            if p.s.is_none() {
                continue;
            }
            both += 1;
            close += ((p.depth - v[3]).abs() <= 0.02) as u32;
            same += ((p.lit as u32 as f32 == v[0]) && (p.ao - v[2]).abs() <= 0.02) as u32;
            lit += p.lit as u32;
            shadowed += !p.lit as u32;
        }
        eprintln!(
            "{}: {both} pixels, depth within 2% on {:.2}%, same shadow and AO on {:.2}% ({lit} lit, {shadowed} shadowed)",
            tracer.name(),
            100.0 * close as f64 / both as f64,
            100.0 * same as f64 / both as f64
        );
        assert!(both > 15_000, "the sphere should fill the image: {both}");
        assert!(lit > both / 10 && shadowed > both / 20, "a picture with light and shadow");
        assert!(close as f64 >= 0.99 * both as f64 && same as f64 >= 0.99 * both as f64);
    }
}
