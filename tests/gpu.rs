//! The runtime on baked bundles: upload to a real device (Mesa lavapipe on CI) and read every
//! texel back through a compute shader, compared exactly with the CPU decode.

use hikage_bundle::{
    BundleWriter, Settings, Supercompression, TextureData, TextureDesc, TextureDimension, TextureFormat, WriteMode,
};
use hikage_runtime::{CpuBundle, GpuBundle, RuntimeError, wgpu};
use hikage_scenes::headless::{Headless, gpu_required};

use crate::util::Dir;

/// A device, or `None` with the reason printed when there is none and it is not required.
fn gpu(test: &str) -> Option<Headless> {
    match Headless::new() {
        Ok(g) => Some(g),
        Err(e) if !gpu_required() => {
            eprintln!("skipping {test}: {e} (set HIKAGE_REQUIRE_GPU=1 to make this a failure)");
            None
        }
        Err(e) => panic!("{test}: HIKAGE_REQUIRE_GPU=1 but {e}"),
    }
}

const READBACK: &str = r#"
struct Params { level: u32, width: u32, height: u32, slices: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<f32>;
@group(0) @binding(2) var tex2d: texture_2d<f32>;
@group(0) @binding(3) var tex3d: texture_3d<f32>;
@group(0) @binding(4) var texarr: texture_2d_array<f32>;

fn index(id: vec3<u32>) -> u32 { return (id.z * params.height + id.y) * params.width + id.x; }
fn inside(id: vec3<u32>) -> bool { return id.x < params.width && id.y < params.height && id.z < params.slices; }

@compute @workgroup_size(4, 4, 1)
fn read_2d(@builtin(global_invocation_id) id: vec3<u32>) {
    if !inside(id) { return; }
    out[index(id)] = textureLoad(tex2d, vec2<i32>(id.xy), i32(params.level)).r;
}

@compute @workgroup_size(4, 4, 1)
fn read_3d(@builtin(global_invocation_id) id: vec3<u32>) {
    if !inside(id) { return; }
    let t = textureLoad(tex3d, vec3<i32>(id), i32(params.level));
    out[index(id) * 2u] = t.r;
    out[index(id) * 2u + 1u] = t.g;
}

@compute @workgroup_size(4, 4, 1)
fn read_array(@builtin(global_invocation_id) id: vec3<u32>) {
    if !inside(id) { return; }
    out[index(id)] = textureLoad(texarr, vec2<i32>(id.xy), i32(id.z), i32(params.level)).r;
}
"#;

/// Reads level `level` of `view` with entry point `entry`, `channels` floats per texel.
fn read_back(
    g: &Headless,
    entry: &str,
    binding: u32,
    view: &wgpu::TextureView,
    desc: &TextureDesc,
    level: u32,
    channels: u32,
) -> Vec<f32> {
    let (w, h, d) = desc.level_extent(level);
    let slices = if desc.dimension == TextureDimension::D2Array { desc.layers } else { d };
    let module = g.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("readback"),
        source: wgpu::ShaderSource::Wgsl(READBACK.into()),
    });
    let pipeline = g.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: None,
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    });
    let params: Vec<u8> = [level, w, h, slices].iter().flat_map(|v| v.to_le_bytes()).collect();
    let uniform = g.buffer(16, wgpu::BufferUsages::UNIFORM, Some(&params));
    let count = (w * h * slices * channels) as u64;
    let out = g.buffer(count * 4, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC, None);
    let bind = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
            wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) },
        ],
    });
    g.dispatch(&pipeline, &bind, (w.div_ceil(4), h.div_ceil(4), slices));
    g.read_buffer(&out).chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
}

/// Asserts equal slices, reporting the count and first mismatch rather than both slices.
fn assert_same<T: PartialEq + std::fmt::Debug>(what: &str, got: &[T], expected: &[T]) {
    assert_eq!(got.len(), expected.len(), "{what}: length");
    let bad: Vec<usize> = (0..got.len()).filter(|&i| got[i] != expected[i]).collect();
    if let Some(&i) = bad.first() {
        panic!(
            "{what}: {} of {} values differ; first at {i}: GPU {:?}, CPU {:?}",
            bad.len(),
            got.len(),
            got[i],
            expected[i]
        );
    }
}

fn volume_texture() -> TextureData {
    // 12×8×6 Rg16Float, two levels, zstd: values with signs, fractions and zeros.
    let desc = TextureDesc {
        format: TextureFormat::Rg16Float,
        dimension: TextureDimension::D3,
        width: 12,
        height: 8,
        depth: 6,
        layers: 1,
        levels: 2,
        supercompression: Supercompression::Zstd,
        channels: vec!["slope".into(), "distance".into()],
    };
    let levels = (0..2)
        .map(|l| {
            let n = desc.level_bytes(l).unwrap() as usize / 2;
            (0..n)
                .flat_map(|i| half::f16::from_f32(((i * 37 % 101) as f32 - 50.0) / 7.0 + l as f32).to_le_bytes())
                .collect()
        })
        .collect();
    TextureData { desc, levels }
}

fn array_texture() -> TextureData {
    let desc = TextureDesc {
        format: TextureFormat::R8Unorm,
        dimension: TextureDimension::D2Array,
        width: 16,
        height: 16,
        depth: 1,
        layers: 5,
        levels: 1,
        supercompression: Supercompression::None,
        channels: vec!["depth".into()],
    };
    let n = desc.level_bytes(0).unwrap() as usize;
    TextureData { levels: vec![(0..n).map(|i| (i * 13 % 256) as u8).collect()], desc }
}

#[test]
fn baked_textures_read_back_exactly_on_the_device() {
    let dir = Dir::new("gpu_readback");
    dir.copy_data();
    dir.write("pipeline.ron", "(output: \"bundle\", jobs: [Heightfield(id: \"cyl\", input: \"data/cylinders.png\")])");
    dir.run(&["bake"]);
    let mut writer = BundleWriter::open(&dir.path("bundle"), WriteMode::Update).unwrap();
    writer.put_texture("volume", Settings::Generic, "test", &volume_texture()).unwrap();
    writer.put_texture("layers", Settings::Generic, "test", &array_texture()).unwrap();
    writer.commit().unwrap();
    dir.run(&["validate", "bundle"]);

    // The device-free half runs on another thread, as a game's loader would.
    let path = dir.path("bundle");
    let cpu = std::thread::spawn(move || CpuBundle::read(&path).unwrap()).join().unwrap();
    let Some(g) = gpu("baked_textures_read_back_exactly_on_the_device") else { return };
    eprintln!("adapter: {}", g.describe());
    let gpu_bundle = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();

    let bundle = hikage_bundle::Bundle::open(&dir.path("bundle")).unwrap();
    let cyl = &gpu_bundle.textures["cyl"];
    assert_eq!(cyl.texture.dimension(), wgpu::TextureDimension::D2);
    assert_eq!(cyl.texture.format(), wgpu::TextureFormat::R32Float);
    let expected = bundle.read_texture("cyl").unwrap().to_f32(0);
    assert_same("cyl", &read_back(&g, "read_2d", 2, &cyl.view, &cyl.desc, 0, 1), &expected);

    let vol = &gpu_bundle.textures["volume"];
    assert_eq!(vol.texture.dimension(), wgpu::TextureDimension::D3, "3D stays 3D");
    assert_eq!(vol.texture.depth_or_array_layers(), 6);
    assert_eq!(vol.texture.mip_level_count(), 2);
    let cpu_volume = bundle.read_texture("volume").unwrap();
    assert_eq!(cpu_volume.levels, volume_texture().levels, "zstd round trip");
    for level in 0..2 {
        let got = read_back(&g, "read_3d", 3, &vol.view, &vol.desc, level, 2);
        assert_same(&format!("volume level {level}"), &got, &cpu_volume.to_f32(level));
    }

    let arr = &gpu_bundle.textures["layers"];
    assert_eq!(arr.texture.depth_or_array_layers(), 5);
    // Unorm → float is exact up to the last ulp of b/255 on every device; compare the bytes.
    let got: Vec<u8> =
        read_back(&g, "read_array", 4, &arr.view, &arr.desc, 0, 1).iter().map(|v| (v * 255.0).round() as u8).collect();
    assert_same("layers", &got, &array_texture().levels[0]);
}

#[test]
fn hostile_bundles_give_errors_not_panics() {
    let dir = Dir::new("gpu_hostile");
    let mut writer = BundleWriter::open(&dir.path("bundle"), WriteMode::Replace).unwrap();
    let asset = writer.put_texture("volume", Settings::Generic, "x", &volume_texture()).unwrap();
    writer.commit().unwrap();

    // Tampered payload: refused before any device work.
    let path = dir.path(&format!("bundle/{}", asset.file));
    let mut bytes = std::fs::read(&path).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0xFF;
    std::fs::write(&path, &bytes).unwrap();
    let err = CpuBundle::read(&dir.path("bundle")).unwrap_err().to_string();
    assert!(err.contains("volume") && err.contains("BLAKE3"), "{err}");

    // Manifest dimensions disagreeing with the KTX2 header.
    let dir = Dir::new("gpu_hostile_dims");
    let mut writer = BundleWriter::open(&dir.path("bundle"), WriteMode::Replace).unwrap();
    writer.put_texture("volume", Settings::Generic, "x", &volume_texture()).unwrap();
    writer.commit().unwrap();
    let manifest = std::fs::read_to_string(dir.path("bundle/bundle.ron")).unwrap();
    std::fs::write(dir.path("bundle/bundle.ron"), manifest.replace("depth: 6", "depth: 7")).unwrap();
    let err = CpuBundle::read(&dir.path("bundle")).unwrap_err().to_string();
    assert!(err.contains("KTX2 header says"), "{err}");

    // A texture deeper than the device allows: an error naming the asset.
    let Some(g) = gpu("hostile_bundles_give_errors_not_panics") else { return };
    let max3d = g.device.limits().max_texture_dimension_3d;
    let depth = 16_384u32;
    let desc = TextureDesc {
        format: TextureFormat::R8Unorm,
        dimension: TextureDimension::D3,
        width: 1,
        height: 1,
        depth,
        layers: 1,
        levels: 1,
        supercompression: Supercompression::Zstd,
        channels: vec!["x".into()],
    };
    let tall = TextureData { levels: vec![vec![7u8; depth as usize]], desc };
    let dir = Dir::new("gpu_hostile_limits");
    let mut writer = BundleWriter::open(&dir.path("bundle"), WriteMode::Replace).unwrap();
    writer.put_texture("tall", Settings::Generic, "x", &tall).unwrap();
    writer.commit().unwrap();
    let cpu = CpuBundle::read(&dir.path("bundle")).unwrap();
    match GpuBundle::upload(&g.device, &g.queue, &cpu) {
        Err(RuntimeError::Unsupported { asset, message }) if depth > max3d => {
            assert_eq!(asset, "tall");
            assert!(message.contains("device limit"), "{message}");
        }
        Ok(_) if depth <= max3d => {}
        other => panic!("depth {depth}, device limit {max3d}: unexpected {other:?}"),
    }
}

const HORIZON_TEST: &str = r#"
struct Sample { uv: vec2<f32>, principal: vec2<f32>, light: vec4<f32>, k: vec4<f32> }
@group(0) @binding(0) var map: texture_3d<f32>;
@group(0) @binding(1) var samp: sampler;
@group(0) @binding(2) var<storage, read> samples: array<Sample>;
@group(0) @binding(3) var<storage, read_write> lit: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&samples) { return; }
    let s = samples[i];
    lit[i] = select(0u, 1u, horizon_shadow_lit(map, samp, s.uv, s.light.xyz, s.k.x, s.k.y, s.principal, s.k.z));
}
"#;

#[test]
fn horizon_shader_agrees_with_its_cpu_reference() {
    use hikage_runtime::glam::{Vec2, Vec3};
    use hikage_runtime::horizon::{
        HORIZON_WGSL, HorizonMap, horizon_corrected_slope, horizon_fetch, horizon_shadow_lit,
    };

    let dir = Dir::new("gpu_horizon");
    dir.copy_data();
    dir.run(&["horizon", "data/cylinders.png", "--out", "bundle", "--directions", "32", "--height-scale", "4"]);
    let cpu = CpuBundle::read(&dir.path("bundle")).unwrap();
    let bundle = hikage_bundle::Bundle::open(&dir.path("bundle")).unwrap();
    let horizon = bundle.read_texture("cylinders.horizon").unwrap();
    let heights = bundle.read_texture("cylinders.height").unwrap().to_f32(0);
    let map = HorizonMap::new(&horizon).unwrap();

    // Samples: a 64×64 grid of texture coordinates, lights from 8 azimuths at 3 elevations
    // (one below the tangent plane), on a flat surface and on spheres of κ = 0.005 and 0.015.
    let mut samples: Vec<f32> = Vec::new();
    let mut cases = Vec::new();
    for gy in 0..64 {
        for gx in 0..64 {
            let uv = Vec2::new((gx as f32 + 0.37) / 64.0, (gy as f32 + 0.71) / 64.0);
            let texel = (uv.y * 128.0) as usize * 128 + (uv.x * 128.0) as usize;
            let h = 4.0 * heights[texel];
            for a in 0..8 {
                let az = a as f32 * 0.785 + 0.2;
                for elev in [-0.05f32, 0.3, 0.7] {
                    for kappa in [0.0f32, 0.005, 0.015] {
                        let light = Vec3::new(az.cos() * elev.cos(), az.sin() * elev.cos(), elev.sin());
                        let principal = Vec2::new(1.0, 0.3);
                        samples.extend([uv.x, uv.y, principal.x, principal.y, light.x, light.y, light.z, 0.0]);
                        samples.extend([kappa, kappa * 0.5, h, 0.0]);
                        cases.push((uv, light, kappa, kappa * 0.5, principal, h));
                    }
                }
            }
        }
    }
    let Some(g) = gpu("horizon_shader_agrees_with_its_cpu_reference") else { return };
    let gpu_bundle = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let view = &gpu_bundle.textures["cylinders.horizon"].view;
    let sampler = hikage_runtime::horizon::horizon_sampler(&g.device);
    let module = g.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("horizon test"),
        source: wgpu::ShaderSource::Wgsl(format!("{HORIZON_WGSL}\n{HORIZON_TEST}").into()),
    });
    let pipeline = g.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: None,
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bytes: Vec<u8> = samples.iter().flat_map(|v| v.to_le_bytes()).collect();
    let input = g.buffer(bytes.len() as u64, wgpu::BufferUsages::STORAGE, Some(&bytes));
    let out = g.buffer(cases.len() as u64 * 4, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC, None);
    let bind = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(view) },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&sampler) },
            wgpu::BindGroupEntry { binding: 2, resource: input.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: out.as_entire_binding() },
        ],
    });
    g.dispatch(&pipeline, &bind, ((cases.len() as u32).div_ceil(64), 1, 1));
    let lit: Vec<u32> =
        g.read_buffer(&out).chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect();

    let (mut disagree, mut lit_count) = (0usize, 0usize);
    let mut lit_by_kappa = std::collections::BTreeMap::new();
    for (i, &(uv, light, k1, k2, principal, h)) in cases.iter().enumerate() {
        let cpu_lit = horizon_shadow_lit(&map, uv, light, k1, k2, principal, h);
        lit_count += cpu_lit as usize;
        *lit_by_kappa.entry((k1 * 1000.0) as u32).or_insert(0usize) += (lit[i] == 1) as usize;
        if cpu_lit != (lit[i] == 1) {
            disagree += 1;
            // Only along shadow boundaries: the light is within a small angle of the horizon.
            let [tb, d] = horizon_fetch(&map, uv, light.y.atan2(light.x));
            let dir = light.truncate().normalize();
            let p = principal.normalize();
            let kappa = k1 * dir.dot(p).powi(2) + k2 * (dir.x * p.y - dir.y * p.x).powi(2);
            let corrected = horizon_corrected_slope(tb, d, kappa, h).atan();
            let elevation = light.z.atan2(light.truncate().length());
            assert!(
                (elevation - corrected).abs() < 0.05,
                "case {i}: disagreement {:.3} rad from the boundary",
                (elevation - corrected).abs()
            );
        }
    }
    let share = disagree as f64 / cases.len() as f64;
    eprintln!("horizon shader vs CPU: {disagree} of {} disagree ({:.3}%), {lit_count} lit", cases.len(), share * 100.0);
    assert!(share <= 0.005, "{:.3}% of samples disagree", share * 100.0);
    assert!(lit_count > cases.len() / 4 && lit_count < cases.len(), "a test with shadows and light");
    // Curvature shortens shadows, more so at higher curvature (seed 000, Fig. 4 vs 5).
    let l: Vec<usize> = lit_by_kappa.values().copied().collect();
    eprintln!("lit on the GPU for κ = 0, 0.005, 0.015: {l:?}");
    assert!(l[0] < l[1] && l[1] < l[2], "{l:?}");
}

#[test]
fn lit_sphere_render_matches_the_cpu_reference_per_pixel() {
    use hikage_runtime::glam::Vec3;
    use hikage_runtime::horizon::HorizonMap;
    use hikage_scenes::horizon_sphere::{SphereScene, render, render_cpu, shadowed_fraction};

    let dir = Dir::new("gpu_sphere");
    dir.copy_data();
    dir.run(&["horizon", "data/cylinders.png", "--out", "bundle", "--directions", "32", "--height-scale", "4"]);
    let cpu = CpuBundle::read(&dir.path("bundle")).unwrap();
    let bundle = hikage_bundle::Bundle::open(&dir.path("bundle")).unwrap();
    let map = HorizonMap::new(&bundle.read_texture("cylinders.horizon").unwrap()).unwrap();
    let heights = bundle.read_texture("cylinders.height").unwrap().to_f32(0);
    let Some(g) = gpu("lit_sphere_render_matches_the_cpu_reference_per_pixel") else { return };
    let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
    let (hv, tv) = (&gb.textures["cylinders.horizon"].view, &gb.textures["cylinders.height"].view);

    let size = 192u32;
    let mut fractions = Vec::new();
    for kappa in [0.005f32, 0.015] {
        for corrected in [false, true] {
            let scene = SphereScene {
                light: Vec3::new(-0.8, 0.25, 0.45).normalize(),
                sphere_kappa: kappa,
                corrected,
                tile_world: 128.0,
                height_scale: 4.0,
                size,
            };
            let (_, gpu_flags) = render(&g, &scene, hv, tv);
            let cpu_flags = render_cpu(&scene, &map, &heights, (128, 128));
            let sphere = cpu_flags.iter().filter(|&&f| f != 2).count();
            let mut disagree = 0;
            for (i, (&a, &b)) in cpu_flags.iter().zip(&gpu_flags).enumerate() {
                if a == b {
                    continue;
                }
                disagree += 1;
                // Only along boundaries: the CPU image changes within the pixel's 3×3 neighbourhood.
                let (x, y) = ((i as u32 % size) as i64, (i as u32 / size) as i64);
                let mut seen = std::collections::BTreeSet::new();
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let (nx, ny) = (x + dx, y + dy);
                        if (0..size as i64).contains(&nx) && (0..size as i64).contains(&ny) {
                            seen.insert(cpu_flags[(ny * size as i64 + nx) as usize]);
                        }
                    }
                }
                // Or where the height lookup changes texel: at a heightfield texel edge the height
                // (and so κh in eq. 2–3) jumps, and GPU and CPU trigonometry may pick either side.
                let r = 1.0 / kappa;
                let (px, py) = ((x as f32 + 0.5) / size as f32 * 2.0 - 1.0, (y as f32 + 0.5) / size as f32 * 2.0 - 1.0);
                let (wx, wy) = (px * r * 1.05, -py * r * 1.05);
                let lam = wx.atan2((r * r - wx * wx - wy * wy).sqrt());
                let psi = (wy / r).asin();
                let texel_edge = [lam * r, -psi * r].iter().any(|c| {
                    let f = (c / 128.0 * 128.0).rem_euclid(1.0);
                    f.min(1.0 - f) < 0.02
                });
                assert!(
                    seen.len() > 1 || texel_edge,
                    "κ {kappa} corrected {corrected}: pixel ({x}, {y}) disagrees away from any boundary"
                );
            }
            let share = disagree as f64 / sphere as f64;
            eprintln!(
                "κ {kappa} corrected {corrected}: {disagree} of {sphere} sphere pixels disagree ({:.3}%)",
                share * 100.0
            );
            assert!(share <= 0.005, "{:.3}% disagree", share * 100.0);
            fractions.push(shadowed_fraction(&gpu_flags));
        }
    }
    // Corrected shadows are shorter, and the difference is larger at the larger curvature.
    let (flat_lo, corr_lo, flat_hi, corr_hi) = (fractions[0], fractions[1], fractions[2], fractions[3]);
    eprintln!(
        "shadowed: κ=0.005 flat {flat_lo:.4} corrected {corr_lo:.4}; κ=0.015 flat {flat_hi:.4} corrected {corr_hi:.4}"
    );
    assert!(corr_lo < flat_lo && corr_hi < flat_hi);
    assert!(flat_hi - corr_hi > flat_lo - corr_lo);
}

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

/// The shadow-fit scene on the GPU: σ from the shader's derivatives agrees with σ recomputed on
/// the CPU from the matrices alone at sampled pixels; the fitted projection gives a higher
/// density than the fixed one; ground far from every box is lit.
#[test]
fn shadow_fit_scene_sigma_matches_the_cpu() {
    use hikage_runtime::glam::Vec3;
    use hikage_runtime::glam::camera::rh::proj::directx;
    use hikage_runtime::glam::camera::rh::view::look_at_mat4;
    use hikage_runtime::shadow_fit::{self, FitOptions, Light, Scratch};
    use hikage_scenes::shadow_scene::{FrameSetup, Scene, check_sigma, frame_stats, render_frame};

    let Some(g) = gpu("shadow_fit_scene_sigma_matches_the_cpu") else { return };
    let scene = Scene::boxes(60, 100.0, 3);
    let size = (200, 150);
    let camera = directx::perspective(60f32.to_radians(), 4.0 / 3.0, 0.5, 80.0)
        * look_at_mat4(Vec3::new(-40.0, 5.0, 30.0), Vec3::new(0.0, 0.0, 0.0), Vec3::Y);
    let light_pos = Vec3::new(-150.0, 200.0, 60.0);
    let light = Light::Point(light_pos);
    let options = FitOptions {
        near: ((light_pos - scene.bounds.centre).length() - scene.bounds.radius) * 0.95,
        resolution: 512,
        ..FitOptions::new(scene.bounds)
    };
    let fit = shadow_fit::fit(light, camera, &[scene.mesh()], &options, &mut Scratch::default());
    let mut medians = Vec::new();
    for light_matrix in [shadow_fit::fixed(light, &options), fit.view_proj] {
        let setup = FrameSetup { camera, light: light_matrix, resolution: 512, size };
        let data = render_frame(&g, &scene, &setup);
        let (checked, agree) = check_sigma(&data, &setup, 7);
        let stats = frame_stats(&data, 512);
        let ground: Vec<_> =
            data.world.iter().zip(&data.shadow).filter(|(w, s)| w[3] == 2.0 && w[1] < 0.01 && s[3] >= 0.0).collect();
        let lit = ground.iter().filter(|(_, s)| s[3] > 0.5).count() as f64 / ground.len().max(1) as f64;
        eprintln!(
            "σ median {:.3} p10 {:.3}; {checked} pixels checked, {:.2}% within 5% of the CPU; ground lit {:.1}%",
            stats.sigma_median,
            stats.sigma_p10,
            100.0 * agree as f64 / checked as f64,
            100.0 * lit
        );
        assert!(checked > 1000);
        assert!(agree as f64 >= 0.97 * checked as f64);
        assert!((0.5..0.98).contains(&lit), "ground lit {lit}: shadows missing or acne");
        medians.push(stats.sigma_median);
    }
    assert!(medians[1] > 1.5 * medians[0], "fit σ {} vs fixed {}", medians[1], medians[0]);
}

/// Deep opacity maps of a few strands on the GPU against the CPU reference of the same
/// accumulation: the nearest depth and all four cumulative layers per texel, for both sets.
#[test]
fn hair_opacity_maps_match_the_cpu_accumulation() {
    use hikage_bake::strands::Strands;
    use hikage_bake::strands::strips::{StripSets, build};
    use hikage_runtime::glam::Vec3;
    use hikage_runtime::hair::{HairLight, HairSet, StripArrays, accumulate_cpu};
    use hikage_scenes::hair_scene::{GpuStrips, render_opacity_maps};

    let Some(g) = gpu("hair_opacity_maps_match_the_cpu_accumulation") else { return };
    // Three straight strands along x at different heights, overlapping seen from above, a
    // fourth along z crossing them, and a curved one.
    let mut points = Vec::new();
    let mut segments = Vec::new();
    for (k, (y, z)) in [(0.0f32, 0.0f32), (0.37, 0.113), (0.81, -0.071)].iter().enumerate() {
        for i in 0..6 {
            points.push([-1.0 + 0.4 * i as f32 + 0.013 * k as f32, *y, *z]);
        }
        segments.push(5u16);
    }
    for i in 0..5 {
        points.push([0.217, 0.55, -0.9 + 0.45 * i as f32]);
    }
    segments.push(4);
    for i in 0..8 {
        let a = i as f32 * 0.35;
        points.push([0.6 * a.cos() - 0.1, 0.2 + 0.05 * i as f32, 0.6 * a.sin()]);
    }
    segments.push(7);
    let s = Strands {
        segments,
        points,
        thickness: None,
        transparency: None,
        color: None,
        default_thickness: 0.05,
        default_transparency: 0.6,
        default_color: [0.5; 3],
    };
    let sets = StripSets { shading: (0.05, 0.4), opacity: (0.23, 0.09), taper: 0.0 };
    let (mesh, lo, hi) = build(&s, &sets);
    let arrays = StripArrays {
        position: mesh.read_f32("position").unwrap().chunks_exact(3).map(Vec3::from_slice).collect(),
        side: mesh.read_f32("side").unwrap(),
        tangent: mesh.read_f32("tangent").unwrap().chunks_exact(3).map(Vec3::from_slice).collect(),
        width: mesh.read_f32("width").unwrap().chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
        opacity: mesh.read_f32("opacity").unwrap().chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
        indices: mesh.read_indices().unwrap(),
    };
    let buffer =
        g.buffer(mesh.bytes.len() as u64, wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::INDEX, Some(&mesh.bytes));
    let strips = GpuStrips { buffer: &buffer, desc: &mesh.desc };
    let light = HairLight::for_bounds(Vec3::from(lo), Vec3::from(hi), Vec3::new(0.15, 1.0, 0.1));
    let resolution = 96;
    for set in [HairSet::Shading, HairSet::Opacity] {
        let maps = render_opacity_maps(&g, &strips, &light, set, resolution).unwrap();
        let (gpu_depth, gpu_layers) = maps.read(&g);
        let (cpu_depth, cpu_layers) = accumulate_cpu(&arrays, &light, set, resolution);
        let n = (resolution * resolution) as usize;
        let (mut covered, mut depth_ok, mut layers_ok) = (0, 0, 0);
        for i in 0..n {
            covered += (cpu_depth[i] < 1.0) as usize;
            depth_ok += ((gpu_depth[i] - cpu_depth[i]).abs() < 1e-4) as usize;
            // Half-float sums: a few thousandths.
            layers_ok += (0..4).all(|k| (gpu_layers[i][k] - cpu_layers[i][k]).abs() < 5e-3) as usize;
        }
        eprintln!(
            "{set:?}: {covered} texels covered; depth equal on {:.2}%, layers on {:.2}%",
            100.0 * depth_ok as f64 / n as f64,
            100.0 * layers_ok as f64 / n as f64
        );
        assert!(covered > 300, "the strands should cover part of the map");
        // Texel centres exactly on a shared triangle edge may be drawn once on the GPU and
        // twice by the inclusive CPU test: allow 1%.
        assert!(depth_ok as f64 >= 0.99 * n as f64 && layers_ok as f64 >= 0.99 * n as f64);
        // Several layers differ somewhere: the strands overlap in depth.
        assert!(cpu_layers.iter().any(|l| l[0] > 0.0 && l[3] > l[0] + 1e-3));
    }
}
