//! Relief mapping on the GPU against the CPU reference of the same tracers.

use hikage_runtime::{CpuBundle, DrawOptions, GpuBundle};

use crate::util::{Dir, gpu};

/// The row a ray's estimate is read from, by both direction rules, on the GPU (`relief_pick`)
/// and on the CPU (`ReliefDirections::pick`): the same layer for every direction away from a
/// row or azimuth boundary, on a table of 8 rows × 12 azimuths.
#[test]
fn direction_rules_pick_the_same_layer_on_gpu_and_cpu() {
    use hikage_bundle::relief::{DirectionRule, ReliefDirections};
    use hikage_runtime::relief::{RELIEF_WGSL, ReliefUniform};
    use hikage_runtime::wgpu;

    let Some(g) = gpu("direction_rules_pick_the_same_layer_on_gpu_and_cpu") else { return };
    let dirs = ReliefDirections { theta: 8, phi: 12 };
    // Zenith angles over the whole hemisphere in steps of 0.1°, at 36 azimuths each.
    let mut rays: Vec<[f32; 4]> = Vec::new();
    for t in 0..900 {
        for p in 0..36 {
            let (theta, phi) = ((t as f32 * 0.1 + 0.05).to_radians(), (p as f32 * 10.0 + 3.0).to_radians());
            rays.push([theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos(), 0.0]);
        }
    }
    let shader = format!(
        "{RELIEF_WGSL}
        @group(1) @binding(0) var<storage, read> rays: array<vec4<f32>>;
        @group(1) @binding(1) var<storage, read_write> picked: array<u32>;
        @compute @workgroup_size(64)
        fn pick(@builtin(global_invocation_id) id: vec3<u32>) {{
            if id.x < arrayLength(&rays) {{ picked[id.x] = relief_pick(rays[id.x].xyz); }}
        }}"
    );
    let module = g.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("relief_pick"),
        source: wgpu::ShaderSource::Wgsl(shader.into()),
    });
    let pipeline = g.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("relief_pick"),
        layout: None,
        module: &module,
        entry_point: Some("pick"),
        compilation_options: Default::default(),
        cache: None,
    });
    let ray_bytes = hikage_runtime::bytemuck::cast_slice(&rays);
    let ray_buf = g.buffer(ray_bytes.len() as u64, wgpu::BufferUsages::STORAGE, Some(ray_bytes));
    let out = g.buffer(rays.len() as u64 * 4, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC, None);
    for rule in [DirectionRule::Nearest, DirectionRule::Zenith] {
        let uniform = ReliefUniform {
            theta_rows: dirs.theta,
            phi_cols: dirs.phi,
            direction_rule: rule.code(),
            ..Default::default()
        };
        let ubytes = hikage_runtime::bytemuck::bytes_of(&uniform);
        let ubuf = g.buffer(ubytes.len() as u64, wgpu::BufferUsages::UNIFORM, Some(ubytes));
        let group = |index: u32, entries: &[wgpu::BindGroupEntry<'_>]| {
            g.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &pipeline.get_bind_group_layout(index),
                entries,
            })
        };
        let relief = group(0, &[wgpu::BindGroupEntry { binding: 2, resource: ubuf.as_entire_binding() }]);
        let io = group(
            1,
            &[
                wgpu::BindGroupEntry { binding: 0, resource: ray_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
            ],
        );
        let mut encoder = g.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &relief, &[]);
            pass.set_bind_group(1, &io, &[]);
            pass.dispatch_workgroups((rays.len() as u32).div_ceil(64), 1, 1);
        }
        g.queue.submit([encoder.finish()]);
        let picked: Vec<u32> =
            g.read_buffer(&out).chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect();
        let (mut compared, mut differ) = (0, 0);
        let band = 90.0 / dirs.theta as f32;
        for (ray, &gpu_layer) in rays.iter().zip(&picked) {
            let cpu_layer = dirs.pick([ray[0], ray[1], ray[2]], rule);
            // Skip directions within 0.01° of a row boundary (f32 atan2 may fall either way).
            let theta = ray[0].hypot(ray[1]).atan2(ray[2]).to_degrees();
            let edge = match rule {
                DirectionRule::Nearest => theta / band,
                DirectionRule::Zenith => theta / band - 0.5,
            };
            if (edge - edge.round()).abs() * band < 0.01 {
                continue;
            }
            compared += 1;
            differ += (cpu_layer != gpu_layer) as u32;
        }
        // The rules really differ on this table, so the test tells them apart.
        let other = if rule == DirectionRule::Nearest { DirectionRule::Zenith } else { DirectionRule::Nearest };
        let apart = rays.iter().zip(&picked).filter(|(r, l)| dirs.pick([r[0], r[1], r[2]], other) != **l).count();
        eprintln!("{rule:?}: {compared} directions, {differ} differ; {apart} differ from the other rule");
        assert_eq!(differ, 0, "{rule:?}");
        assert!(apart > rays.len() / 3, "{rule:?}: only {apart} directions tell the rules apart");
    }
}

/// A relief quad traced on the GPU by every tracer, with both direction rules and both
/// visibility paths, agrees with the CPU reference of the same settings: the hit within one
/// texel on at least 99% of the quad's pixels, and the read counts equal on most of them (the
/// same search, step for step).
#[test]
fn relief_quad_render_matches_the_cpu_tracers() {
    use hikage_runtime::glam::Vec3;
    use hikage_runtime::relief::reference::{Reads, ReliefMaps};
    use hikage_runtime::relief::{DirectionRule, Tracer, VisibilityPath};
    use hikage_scenes::relief_plane::{PlaneView, SHADOW_BIAS, camera_ray, render};

    let dir = Dir::new("gpu_relief");
    dir.copy_data();
    dir.run(&["relief", "data/relief_bricks.png", "--out", "bundle", "--theta", "16", "--phi", "16"]);
    let cpu = CpuBundle::read(&dir.path("bundle")).unwrap();
    let mut maps = ReliefMaps::from_bundle(&cpu, "relief_bricks.relief").unwrap();
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
    let tracers = [
        Tracer::Linear { steps: 48, binary: 6 },
        Tracer::DepthMap { steps: 32, binary: 6 },
        Tracer::MaxMip { start_level: 8, stop_level: 0 },
        Tracer::Combined { margin: 0.1, start_level: 3 },
    ];
    let reads = [
        (DirectionRule::Nearest, VisibilityPath::MaxMip),
        (DirectionRule::Zenith, VisibilityPath::Seed { steps: 32, binary: 6 }),
    ];
    for (tracer, (rule, visibility)) in tracers.into_iter().flat_map(|t| reads.map(|r| (t, r))) {
        (maps.rule, maps.visibility) = (rule, visibility);
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
            "{} ({rule:?}, {}): {quad} quad pixels, {:.2}% within a texel, {:.2}% with equal read counts, {:.2}% same shadow and AO",
            tracer.name(),
            visibility.name(),
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
    use hikage_runtime::relief::reference::{ReliefMaps, relief_material_shade};
    use hikage_runtime::relief::{ReliefFrame, ReliefMaterial, ReliefMaterialUniform, Tracer};
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
