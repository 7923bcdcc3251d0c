//! Horizon shadows on the GPU: the WGSL functions against their CPU reference, the curved-mesh
//! component against a CPU rasterisation of the same mesh, the baked sphere against the
//! analytic one, eq. (1) with κ1 ≠ κ2 on the torus, and the terrain component against a
//! brute-force lit mask on anisotropic texels.

use std::path::PathBuf;

use hikage_bundle::MeshData;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::glam::{Mat4, Vec2, Vec3, Vec4};
use hikage_runtime::horizon::reference::{HorizonMap, SurfaceReference, horizon_sun_visible};
use hikage_runtime::horizon::{Sun, SurfaceFrame, SurfaceShadows, TerrainFrame, TerrainShadows, horizon_filterable};
use hikage_runtime::{CpuBundle, DrawOptions, GpuBundle, wgpu};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, Headless, VISIBILITY_FORMAT};
use hikage_scenes::horizon_sphere::{AnalyticSphere, shadowed_fraction};
use hikage_scenes::raster::{interpolate, rasterise};

use crate::util::{compute_pipeline, gpu, shared_bundle, storage_entry};

/// The default pipeline's horizon and curvature jobs.
fn bundle() -> PathBuf {
    shared_bundle(
        "gpu_horizon",
        r#"(output: "bundle", jobs: [
            Horizon(id: "cylinders", input: "data/cylinders.png", height_scale: 4, directions: 32, edge: Wrap),
            Horizon(id: "reptile", input: "data/reptile.png", height_scale: 3, directions: 16, edge: Wrap),
            Horizon(id: "terrain", input: "data/terrain.png", texel_size: (80, 60), height_scale: 1500,
                    directions: 32, edge: Clamp, ao: true),
            Curvature(id: "sphere", input: "data/sphere.obj"),
            Curvature(id: "torus", input: "data/torus.glb"),
        ])"#,
    )
}

fn surface_options() -> DrawOptions {
    DrawOptions {
        depth_format: Some(DEPTH_FORMAT),
        visibility_format: Some(VISIBILITY_FORMAT),
        cull_mode: Some(wgpu::Face::Back),
        ..DrawOptions::new(COLOR_FORMAT)
    }
}

/// A mesh's streams on the CPU.
struct Streams {
    mesh: MeshData,
}

impl Streams {
    fn f(&self, name: &str) -> Vec<f32> {
        self.mesh.read_f32(name).unwrap_or_else(|| panic!("no stream {name}"))
    }
}

/// Per pixel of a `size`² render of `mesh` under `view_proj`: the CPU reference's flag (0
/// shadowed, 1 lit, 2 not covered), from a CPU rasterisation and the streams interpolated there.
fn cpu_flags(
    reference: &SurfaceReference,
    mesh: &Streams,
    view_proj: Mat4,
    light: Vec3,
    corrected: bool,
    size: u32,
) -> Vec<u32> {
    let indices = mesh.mesh.read_indices().unwrap();
    let position = mesh.f("position");
    let clip: Vec<Vec4> = position.chunks_exact(3).map(|p| view_proj * Vec3::from_slice(p).extend(1.0)).collect();
    let cover = rasterise(&clip, &indices, (size, size), true);
    let streams: Vec<(Vec<f32>, usize)> = [
        ("uv", 2),
        ("normal", 3),
        ("curvature", 2),
        ("principal1", 2),
        ("principal2", 2),
        ("tangent_u", 3),
        ("tangent_v", 3),
    ]
    .iter()
    .map(|&(n, c)| (mesh.f(n), c))
    .collect();
    cover
        .iter()
        .map(|c| {
            let Some((t, w)) = *c else { return 2 };
            let s: Vec<Vec<f32>> = streams.iter().map(|(v, k)| interpolate(v, *k, &indices, t, w)).collect();
            let v2 = |i: usize| Vec2::from_slice(&s[i]);
            let v3 = |i: usize| Vec3::from_slice(&s[i]);
            reference.lit(light, corrected, v2(0), v3(1).normalize(), v2(2), v2(3), v2(4), v3(5), v3(6)) as u32
        })
        .collect()
}

/// GPU flags of the surface's visibility target: 0 shadowed, 1 lit, 2 not covered.
fn gpu_flags(g: &Headless, surface: &SurfaceShadows, frame: &SurfaceFrame, size: u32) -> Vec<u32> {
    surface.update(&g.queue, frame);
    let f = g.render((size, size), wgpu::Color::BLACK, |pass| surface.draw(pass));
    f.visibility.iter().map(|v| if v[1] < 0.5 { 2 } else { (v[0] > 0.5) as u32 }).collect()
}

/// Compares two flag images: (pixels covered by both, of those differing, differing pixels with
/// no lit/shadow change in their 3×3 CPU neighbourhood, pixels covered by one side only).
fn compare(gpu: &[u32], cpu: &[u32], size: u32) -> (usize, usize, usize, usize) {
    let (mut both, mut differ, mut off_boundary, mut one_side) = (0, 0, 0, 0);
    let n = size as i64;
    for i in 0..gpu.len() {
        match (gpu[i] == 2, cpu[i] == 2) {
            (true, true) => continue,
            (true, false) | (false, true) => {
                one_side += 1;
                continue;
            }
            _ => {}
        }
        both += 1;
        if gpu[i] == cpu[i] {
            continue;
        }
        differ += 1;
        let (x, y) = (i as i64 % n, i as i64 / n);
        let mut seen = [false; 2];
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (xx, yy) = (x + dx, y + dy);
                if (0..n).contains(&xx) && (0..n).contains(&yy) {
                    let f = cpu[(yy * n + xx) as usize];
                    if f < 2 {
                        seen[f as usize] = true;
                    }
                }
            }
        }
        off_boundary += !(seen[0] && seen[1]) as usize;
    }
    (both, differ, off_boundary, one_side)
}

/// Seed 000 on real meshes: the sphere of `data/sphere.obj` with the cylinder bumps and the torus
/// with the reptile map, drawn by `SurfaceShadows` on the GPU and by its CPU reference on a CPU
/// rasterisation of the same mesh: at most 0.5% of pixels differ, all next to a shadow boundary.
/// The sphere's shadowed share, from its baked curvature and interpolated frame, is within half
/// a point of the analytic sphere's.
#[test]
fn curved_mesh_shadows_match_the_cpu_reference_and_the_analytic_sphere() {
    let dir = bundle();
    let cpu = CpuBundle::read(&dir).unwrap();
    let Some(g) = gpu("curved_mesh_shadows_match_the_cpu_reference_and_the_analytic_sphere") else { return };
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let light = Vec3::new(-0.8, 0.25, 0.45).normalize();
    let size = 256;
    let sphere = AnalyticSphere::SAMPLE;
    let torus_view = directx::orthographic(-150.0, 150.0, -150.0, 150.0, 10.0, 600.0)
        * look_at_mat4(Vec3::new(0.0, 150.0, 260.0), Vec3::ZERO, Vec3::Y);
    for (mesh_id, horizon_id, view_proj) in
        [("sphere", "cylinders.horizon", sphere.view_proj()), ("torus", "reptile.horizon", torus_view)]
    {
        let surface = SurfaceShadows::new(&g.device, &g.queue, &gb, mesh_id, horizon_id, &surface_options()).unwrap();
        let filtered = horizon_filterable(&g.device, gb.textures[horizon_id].desc.format);
        let reference = SurfaceReference::new(&cpu, horizon_id, filtered).unwrap();
        let streams = Streams { mesh: cpu.asset(mesh_id).unwrap().mesh().unwrap().clone() };
        for corrected in [false, true] {
            let frame = SurfaceFrame { view_proj, light, corrected, ..SurfaceFrame::default() };
            let on_gpu = gpu_flags(&g, &surface, &frame, size);
            let on_cpu = cpu_flags(&reference, &streams, view_proj, light, corrected, size);
            let (both, differ, off_boundary, one_side) = compare(&on_gpu, &on_cpu, size);
            let shadowed = shadowed_fraction(&on_gpu);
            eprintln!(
                "{mesh_id} corrected={corrected}: {both} pixels, {differ} differ ({:.3}%), {off_boundary} of them \
                 away from a shadow boundary, {one_side} covered on one side only; shadowed {:.2}%",
                100.0 * differ as f64 / both as f64,
                100.0 * shadowed
            );
            assert!(both > 20_000, "the mesh should fill much of the image");
            assert!(differ as f64 <= 0.005 * both as f64, "{differ} of {both} pixels differ");
            assert_eq!(off_boundary, 0, "every difference lies on a shadow boundary");
            assert!(one_side as f64 <= 0.01 * both as f64, "silhouettes differ on {one_side} pixels");
            assert!((0.05..0.9).contains(&shadowed), "a picture with light and shadow: {shadowed}");
            if mesh_id == "sphere" {
                let analytic = shadowed_fraction(&sphere.flags(&reference, light, corrected, size));
                eprintln!("  analytic sphere: shadowed {:.2}%", 100.0 * analytic);
                assert!((shadowed - analytic).abs() <= 0.005, "mesh {shadowed} vs analytic {analytic}");
            }
        }
    }
}

/// κ1 ≠ κ2 on the torus: at the front of the tube (κ1 = 1/40 across the tube, along V1;
/// κ2 = 1/140 along the ring, along V2), a light tilted along V1 has its shadows shortened by the
/// correction more than a light tilted along V2 at the same elevation, as eq. (1) predicts.
#[test]
fn torus_correction_follows_the_principal_directions() {
    let dir = bundle();
    let cpu = CpuBundle::read_ids(&dir, &["torus", "reptile.horizon"]).unwrap();
    let Some(g) = gpu("torus_correction_follows_the_principal_directions") else { return };
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let surface =
        SurfaceShadows::new(&g.device, &g.queue, &gb, "torus", "reptile.horizon", &surface_options()).unwrap();
    // The front of the outer equator (x ≈ 0, y ≈ 0, z = 140), seen from +z, filling the image.
    let view_proj = directx::orthographic(-30.0, 30.0, -15.0, 15.0, 10.0, 400.0)
        * look_at_mat4(Vec3::new(0.0, 0.0, 300.0), Vec3::ZERO, Vec3::Y);
    let size = 256;
    let elevation = 12f32.to_radians();
    let mut drop = Vec::new();
    for axis in [Vec3::Y, Vec3::X] {
        let light = (axis * elevation.cos() + Vec3::Z * elevation.sin()).normalize();
        let mut shares = [0.0; 2];
        for (k, corrected) in [false, true].into_iter().enumerate() {
            let frame = SurfaceFrame { view_proj, light, corrected, ..SurfaceFrame::default() };
            shares[k] = shadowed_fraction(&gpu_flags(&g, &surface, &frame, size));
        }
        eprintln!("light along {axis}: flat {:.2}%, corrected {:.2}%", 100.0 * shares[0], 100.0 * shares[1]);
        drop.push(shares[0] - shares[1]);
    }
    assert!(drop[0] > 0.0 && drop[1] >= 0.0, "the correction only shortens shadows: {drop:?}");
    assert!(drop[0] > 2.0 * drop[1], "along V1 (κ1 = 1/40) {:.4} vs along V2 (κ2 = 1/140) {:.4}", drop[0], drop[1]);
}

/// The terrain component on anisotropic texels (80 m × 60 m) under a low sun at a diagonal
/// azimuth, seen straight down with one pixel per texel, against a brute-force ray march toward
/// the sun from every 4th texel: the azimuth taken in texel space agrees on ≥ 98%, and better
/// than the same maps read along the world azimuth (the trap of non-square texels).
#[test]
fn terrain_matches_a_brute_force_lit_mask_on_anisotropic_texels() {
    use hikage_bake::horizon::HorizonParams;
    use hikage_bundle::EdgeMode;

    let dir = bundle();
    let cpu = CpuBundle::read_prefix(&dir, "terrain.").unwrap();
    let Some(g) = gpu("terrain_matches_a_brute_force_lit_mask_on_anisotropic_texels") else { return };
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let options = DrawOptions {
        depth_format: Some(DEPTH_FORMAT),
        visibility_format: Some(VISIBILITY_FORMAT),
        ..DrawOptions::new(COLOR_FORMAT)
    };
    let terrain =
        TerrainShadows::new(&g.device, &g.queue, &gb, "terrain.horizon", Some("terrain.ao"), &options).unwrap();
    let (w, h, sx, sy) = (512u32, 512u32, 80.0f32, 60.0f32);
    let (ex, ez) = (w as f32 * sx / 2.0, h as f32 * sy / 2.0);
    let view_proj = directx::orthographic(-ex, ex, -ez, ez, 100.0, 5000.0)
        * look_at_mat4(Vec3::new(ex, 4000.0, ez), Vec3::new(ex, 0.0, ez), Vec3::NEG_Z);
    // The sun at 45° in the world between +u and +v, 9° up: 53° in texel space.
    let elevation = 9f32.to_radians();
    let sun_dir = Vec3::new(elevation.cos() * 0.5f32.sqrt(), elevation.sin(), elevation.cos() * 0.5f32.sqrt());
    let sun = Sun { direction: sun_dir, color: Vec3::ONE, angular_radius: 0.0 };
    terrain.update(&g.queue, &TerrainFrame { view_proj, sun, ..TerrainFrame::default() });
    let frame = g.render((w, h), wgpu::Color::BLACK, |pass| terrain.draw(pass));

    // The brute force: the baked heights, every crossing of the ray at the exact azimuth.
    let heights = cpu.asset("terrain.height").unwrap();
    let hf_settings = heights.asset.settings.heightfield().unwrap();
    let mut hf = hikage_bake::Heightfield::from_samples(w, h, heights.texture().unwrap().to_f32(0));
    hf.texel_size = hf_settings.texel_size;
    hf.height_scale = hf_settings.height_scale;
    let params = HorizonParams { edge: EdgeMode::Clamp, ..HorizonParams::default() };
    let phi = ((sun_dir.z / sy) as f64).atan2((sun_dir.x / sx) as f64);
    let map_asset = cpu.asset("terrain.horizon").unwrap();
    let map = HorizonMap::new(map_asset.texture().unwrap(), map_asset.asset.settings.horizon().unwrap(), true).unwrap();
    let bump_sun = Vec3::new(sun_dir.x, sun_dir.z, sun_dir.y);
    let (mut checked, mut agree, mut agree_world_azimuth, mut lit) = (0, 0, 0, 0);
    for row in (2..h - 2).step_by(4) {
        for col in (2..w - 2).step_by(4) {
            let v = frame.visibility[(row * w + col) as usize];
            if v[1] < 0.5 {
                continue;
            }
            let (tan_beta, _) = hikage_devkit::brute_force::horizon(&hf, &params, row as usize, col as usize, phi);
            let truth = (elevation as f64).tan() > tan_beta;
            let uv = Vec2::new((col as f32 + 0.5) / w as f32, (row as f32 + 0.5) / h as f32);
            // The same maps read along the world azimuth, as if texels were square.
            let naive = horizon_sun_visible(&map, uv, bump_sun, Vec2::ONE, 0.0) > 0.5;
            checked += 1;
            lit += truth as u32;
            agree += ((v[0] > 0.5) == truth) as u32;
            agree_world_azimuth += (naive == truth) as u32;
        }
    }
    let share = agree as f64 / checked as f64;
    let naive_share = agree_world_azimuth as f64 / checked as f64;
    eprintln!(
        "terrain: {checked} texels, {:.1}% lit; GPU agrees with the brute force on {:.2}%, the world azimuth on {:.2}%",
        100.0 * lit as f64 / checked as f64,
        100.0 * share,
        100.0 * naive_share
    );
    assert!(checked > 15_000);
    assert!((0.2..0.95).contains(&(lit as f64 / checked as f64)), "a low sun casts long shadows");
    assert!(share >= 0.98, "{:.2}% agree", 100.0 * share);
    assert!(share > naive_share + 0.005, "texel-space azimuth {share} vs world azimuth {naive_share}");
}

/// A clamped bake is sampled with `ClampToEdge`: next to the map's left edge the horizon is the
/// edge texel's own, not a blend with the right edge's (which `Repeat` would give), read through
/// the terrain's WGSL and bind group in a compute shader of the test's own, as a game would.
#[test]
fn clamped_terrain_is_sampled_without_wrap() {
    let dir = bundle();
    let cpu = CpuBundle::read_prefix(&dir, "terrain.").unwrap();
    let Some(g) = gpu("clamped_terrain_is_sampled_without_wrap") else { return };
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let terrain =
        TerrainShadows::new(&g.device, &g.queue, &gb, "terrain.horizon", None, &DrawOptions::new(COLOR_FORMAT))
            .unwrap();
    let (w, h) = (512usize, 512usize);
    // Direction 8 of 32 (φ = 90°, +v) at its texel-space azimuth, a quarter texel from the left
    // edge, on every row.
    let phi = std::f32::consts::FRAC_PI_2;
    let shader = format!(
        "{}\n@group(1) @binding(0) var<storage, read_write> out: array<f32>;
        @compute @workgroup_size(64)
        fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
            if id.x >= {h}u {{ return; }}
            let uv = vec2<f32>(0.25 / {w}.0, (f32(id.x) + 0.5) / {h}.0);
            out[id.x] = horizon_fetch(terrain_horizon, terrain_sampler, terrain.encoding, uv, {phi}).x;
        }}",
        terrain.wgsl()
    );
    let out = g.buffer(4 * h as u64, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC, None);
    let out_layout = g
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: None, entries: &[storage_entry(0)] });
    let pipeline = compute_pipeline(&g, &shader, &[terrain.layout(), &out_layout]);
    let out_group = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &out_layout,
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: out.as_entire_binding() }],
    });
    let mut encoder = g.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, terrain.bind_group(), &[]);
        pass.set_bind_group(1, &out_group, &[]);
        pass.dispatch_workgroups((h as u32).div_ceil(64), 1, 1);
    }
    g.queue.submit([encoder.finish()]);
    let got: Vec<f32> =
        g.read_buffer(&out).chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();

    let horizon = cpu.asset("terrain.horizon").unwrap().texture().unwrap().to_f32(0);
    let slope = |k: usize, row: usize, col: usize| horizon[((k * h + row) * w + col) * 2];
    let (mut edges_differ, mut worst) = (0, 0.0f32);
    for (row, &value) in got.iter().enumerate() {
        let (left, right) = (slope(8, row, 0), slope(8, row, w - 1));
        if (left - right).abs() > 0.2 {
            edges_differ += 1;
            worst = worst.max((value - left).abs());
            let repeat = 0.75 * left + 0.25 * right;
            assert!(
                (value - left).abs() < (value - repeat).abs(),
                "row {row}: {value} is closer to the wrapped blend {repeat} than to the edge texel {left}"
            );
        }
    }
    eprintln!("clamp: {edges_differ} rows where the left and right edges differ by more than 0.2; worst {worst}");
    assert!(edges_differ > 50, "the test needs rows whose edges differ");
}

/// What a game reads off a terrain to place a camera, against the baked heights read on the
/// CPU; and an occlusion id naming the wrong kind of asset refused by that id.
#[test]
fn terrain_extent_and_a_wrong_occlusion_map_are_named() {
    let dir = bundle();
    let cpu = CpuBundle::read_prefix(&dir, "terrain.").unwrap();
    let heights = cpu.asset("terrain.height").unwrap().texture().unwrap().to_f32(0);
    let (lo, hi) = heights.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let Some(g) = gpu("terrain_extent_and_a_wrong_occlusion_map_are_named") else { return };
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let options = DrawOptions::new(COLOR_FORMAT);
    let terrain =
        TerrainShadows::new(&g.device, &g.queue, &gb, "terrain.horizon", Some("terrain.ao"), &options).unwrap();
    let e = terrain.extent();
    assert_eq!((e.size, e.texel_size), ((512, 512), (80.0, 60.0)));
    assert_eq!(e.height_range, (1500.0 * lo, 1500.0 * hi));
    assert_eq!(
        (e.min, e.max),
        (Vec3::new(40.0, 1500.0 * lo, 30.0), Vec3::new(511.5 * 80.0, 1500.0 * hi, 511.5 * 60.0))
    );
    assert_eq!(terrain.asset_ids(), ["terrain.horizon", "terrain.height", "terrain.ao"]);
    for wrong in ["terrain.height", "terrain.horizon"] {
        let err = TerrainShadows::new(&g.device, &g.queue, &gb, "terrain.horizon", Some(wrong), &options).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains(&format!("`{wrong}`")) && msg.contains("expected an ambient_occlusion asset"), "{msg}");
    }
}
