//! The runtime on baked bundles: upload to a real device (Mesa lavapipe on CI) and read every
//! texel back through a compute shader, compared exactly with the CPU decode.

use hikage_bundle::{
    BundleWriter, Settings, Supercompression, TextureData, TextureDesc, TextureDimension, TextureFormat, WriteMode,
};
use hikage_runtime::{CpuBundle, GpuBundle, RuntimeError, wgpu};
use hikage_scenes::headless::Headless;

use crate::util::{Dir, gpu};

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

/// A game loads one asset (and what it names) without reading or hashing the rest: a bundle
/// whose other payloads are corrupt still gives the terrain, and reading everything fails.
#[test]
fn loading_one_asset_reads_only_it_and_what_it_names() {
    let dir = Dir::new("load_partial");
    dir.copy_data();
    dir.write(
        "pipeline.ron",
        r#"(output: "bundle", jobs: [
            Horizon(id: "terrain", input: "data/terrain.png", texel_size: (80, 60), height_scale: 1500, directions: 8, edge: Clamp, ao: true),
            Heightfield(id: "other", input: "data/cylinders.png"),
        ])"#,
    );
    dir.run(&["bake"]);
    let bundle = hikage_bundle::Bundle::open(&dir.path("bundle")).unwrap();
    let other = bundle.asset("other").unwrap().file.clone();
    let path = dir.path(&format!("bundle/{other}"));
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[40] ^= 0x55;
    std::fs::write(&path, &bytes).unwrap();

    let err = CpuBundle::read(&dir.path("bundle")).unwrap_err().to_string();
    assert!(err.contains("other") && err.contains("BLAKE3"), "{err}");
    let horizon = CpuBundle::read_ids(&dir.path("bundle"), &["terrain.horizon"]).unwrap();
    let ids: Vec<&str> = horizon.assets.iter().map(|a| a.asset.id.as_str()).collect();
    assert_eq!(ids, ["terrain.height", "terrain.horizon"], "the horizon and the heightfield it names");
    let job = CpuBundle::read_prefix(&dir.path("bundle"), "terrain.").unwrap();
    let ids: Vec<&str> = job.assets.iter().map(|a| a.asset.id.as_str()).collect();
    assert_eq!(ids, ["terrain.ao", "terrain.height", "terrain.horizon"]);
    let err = CpuBundle::read_ids(&dir.path("bundle"), &["terrain.horizn"]).unwrap_err().to_string();
    assert!(err.contains("terrain.horizn") && err.contains("terrain.horizon"), "names what exists: {err}");
    assert!(CpuBundle::read_prefix(&dir.path("bundle"), "nothing.").is_err());
}
