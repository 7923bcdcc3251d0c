//! Block-compressed maps on the GPU: a BC5 horizon (3D) and BC4 relief depth maps (2D array)
//! uploaded as blocks where the device takes them and decoded at upload where it does not
//! (no BC, or BC without sliced 3D), read back texel by texel against the blocks decoded on the
//! CPU; and the terrain drawn alike either way.

use std::path::PathBuf;

use hikage_bundle::{TextureData, TextureDimension, TextureFormat};
use hikage_runtime::glam::Vec3;
use hikage_runtime::glam::camera::rh::proj::directx;
use hikage_runtime::glam::camera::rh::view::look_at_mat4;
use hikage_runtime::horizon::{Sun, TerrainFrame, TerrainShadows};
use hikage_runtime::{CpuBundle, DrawOptions, GpuBundle, wgpu};
use hikage_scenes::headless::{COLOR_FORMAT, DEPTH_FORMAT, Headless, VISIBILITY_FORMAT};

use crate::util::{compute_pipeline, gpu_with, shared_bundle, storage_entry};

fn bundle() -> PathBuf {
    shared_bundle(
        "gpu_bc",
        r#"(output: "bundle", jobs: [
            Horizon(id: "terrain", input: "data/terrain.png", texel_size: (80, 60), height_scale: 1500,
                    directions: 32, edge: Clamp, format: Bc5RgUnorm),
            Relief(id: "relief_fbm", input: "data/relief_fbm.png", format: Bc4RUnorm),
            // The same bakes uncompressed: what the blocks must never cross.
            Horizon(id: "terrain_exact", input: "data/terrain.png", texel_size: (80, 60), height_scale: 1500,
                    directions: 32, edge: Clamp, format: Rg32Float),
            Relief(id: "relief_r8", input: "data/relief_fbm.png"),
        ])"#,
    )
}

const BC: wgpu::Features = wgpu::Features::TEXTURE_COMPRESSION_BC;
const SLICED_3D: wgpu::Features = wgpu::Features::TEXTURE_COMPRESSION_BC_SLICED_3D;

/// Channels 0 and 1 of every texel of every `stride`-th slice (depth slice or layer) of `view`,
/// read with `textureLoad` in a compute shader, `[slice][row][col]`.
fn load_texels(
    g: &Headless,
    view: &wgpu::TextureView,
    desc: &hikage_bundle::TextureDesc,
    stride: u32,
) -> Vec<[f32; 2]> {
    let (w, h) = (desc.width, desc.height);
    let slices = desc.slices().div_ceil(stride);
    let (texture, load, dimension) = match desc.dimension {
        TextureDimension::D3 => (
            "texture_3d<f32>",
            format!("textureLoad(map, vec3<u32>(id.x, id.y, id.z * {stride}u), 0)"),
            wgpu::TextureViewDimension::D3,
        ),
        _ => (
            "texture_2d_array<f32>",
            format!("textureLoad(map, id.xy, id.z * {stride}u, 0)"),
            wgpu::TextureViewDimension::D2Array,
        ),
    };
    let shader = format!(
        "@group(0) @binding(0) var map: {texture};
        @group(0) @binding(1) var<storage, read_write> out: array<vec2<f32>>;
        @compute @workgroup_size(8, 8)
        fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
            if id.x >= {w}u || id.y >= {h}u {{ return; }}
            out[(id.z * {h}u + id.y) * {w}u + id.x] = {load}.xy;
        }}"
    );
    let layout = g.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: dimension,
                    multisampled: false,
                },
                count: None,
            },
            storage_entry(1),
        ],
    });
    let pipeline = compute_pipeline(g, &shader, &[&layout]);
    let out = g.buffer(8 * (w * h * slices) as u64, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC, None);
    let bind = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &layout,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(view) },
            wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
        ],
    });
    g.dispatch(&pipeline, &bind, (w.div_ceil(8), h.div_ceil(8), slices));
    g.read_buffer(&out)
        .chunks_exact(8)
        .map(|c| [f32::from_le_bytes(c[..4].try_into().unwrap()), f32::from_le_bytes(c[4..].try_into().unwrap())])
        .collect()
}

/// The blocks of `tex` decoded on the CPU, unrounded (as the format defines them), in units
/// of 1: `[slice][row][col]`, channels 0 and 1, for every `stride`-th slice.
fn exact_texels(tex: &TextureData, stride: u32) -> Vec<[f32; 2]> {
    let d = &tex.desc;
    let mut out = Vec::new();
    for slice in (0..d.slices() as usize).step_by(stride as usize) {
        for row in 0..d.height as usize {
            for col in 0..d.width as usize {
                let texel =
                    hikage_bundle::bc::decode_texel(d.format, &tex.levels[0], (d.width, d.height), (slice, row, col));
                out.push(texel.map(|v| v / 255.0));
            }
        }
    }
    out
}

/// The texels a device reads of `id` (every `stride`-th slice), against the CPU's decode: the
/// texels, the largest difference and the format the device holds.
fn compare(
    g: &Headless,
    gb: &GpuBundle,
    cpu: &CpuBundle,
    id: &str,
    stride: u32,
) -> (Vec<[f32; 2]>, TextureFormat, f32) {
    let on_device = gb.texture(id).unwrap();
    let tex = cpu.asset(id).unwrap().texture().unwrap();
    let got = load_texels(g, &on_device.view, &tex.desc, stride);
    let want = exact_texels(tex, stride);
    assert_eq!(got.len(), want.len());
    let channels = tex.desc.format.channels();
    let worst =
        got.iter().zip(&want).flat_map(|(g, w)| (0..channels).map(move |c| (g[c] - w[c]).abs())).fold(0f32, f32::max);
    (got, on_device.desc.format, worst)
}

/// Every `stride`-th slice of an uncompressed texture, `[slice][row][col]`, channels 0 and 1.
fn stored_texels(cpu: &CpuBundle, id: &str, stride: u32) -> Vec<[f32; 2]> {
    let tex = cpu.asset(id).unwrap().texture().unwrap();
    let (n, channels) = ((tex.desc.width * tex.desc.height) as usize, tex.desc.format.channels());
    let values = tex.to_f32(0);
    values
        .chunks_exact(n * channels)
        .step_by(stride as usize)
        .flat_map(|slice| slice.chunks_exact(channels).map(|t| [t[0], if channels == 2 { t[1] } else { 0.0 }]))
        .collect()
}

/// Each device reads the same texels from the bundle's blocks: natively (blocks on the device,
/// as the format defines them, within the 1.5 steps of 1/255 a fixed-point decoder may be off
/// by; lavapipe's is) or through the decode at upload (8-bit texels, within half a step); which
/// path each device took is the one [`hikage_runtime::device_format`] names; and on every path
/// the texels the shaders read keep the promises: no depth deeper than the R8 maps', no horizon
/// below the exact bake's, no horizon distance past it.
#[test]
fn block_maps_read_alike_on_devices_with_and_without_bc() {
    let dir = bundle();
    let cpu = CpuBundle::read(&dir).unwrap();
    let horizon = &cpu.asset("terrain.horizon").unwrap().texture().unwrap().desc;
    assert_eq!(horizon.format, TextureFormat::Bc5RgUnorm);
    assert_eq!(cpu.asset("relief_fbm.relief").unwrap().texture().unwrap().desc.format, TextureFormat::Bc4RUnorm);
    let cases = [
        ("BC with sliced 3D", BC | SLICED_3D, TextureFormat::Bc5RgUnorm, TextureFormat::Bc4RUnorm),
        ("BC, 2D only", BC, TextureFormat::Rg8Unorm, TextureFormat::Bc4RUnorm),
        ("no BC", wgpu::Features::empty(), TextureFormat::Rg8Unorm, TextureFormat::R8Unorm),
    ];
    for (name, features, horizon_on_device, relief_on_device) in cases {
        let Some(g) = gpu_with("block_maps_read_alike_on_devices_with_and_without_bc", features) else { return };
        if !g.device.features().contains(features) {
            eprintln!("{name}: the adapter ({}) lacks {features:?}; case skipped", g.describe());
            assert!(!crate::util::gpu_required() || features.is_empty(), "lavapipe has BC");
            continue;
        }
        let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
        let (h_texels, h_format, h_worst) = compare(&g, &gb, &cpu, "terrain.horizon", 5);
        let (r_texels, r_format, r_worst) = compare(&g, &gb, &cpu, "relief_fbm.relief", 7);
        eprintln!(
            "{name}: horizon held as {h_format:?} (worst {:.3}/255), relief as {r_format:?} (worst {:.3}/255)",
            h_worst * 255.0,
            r_worst * 255.0
        );
        assert_eq!((h_format, r_format), (horizon_on_device, relief_on_device), "{name}");
        for (format, worst) in [(h_format, h_worst), (r_format, r_worst)] {
            let bound = if format.is_block_compressed() { 1.5 } else { 0.5 };
            assert!(worst * 255.0 <= bound + 1e-3, "{name}: {format:?} off by {}/255", worst * 255.0);
        }
        let r8 = stored_texels(&cpu, "relief_r8.relief", 7);
        let deeper = r_texels.iter().zip(&r8).filter(|(g, t)| g[0] > t[0] + 1e-6).count();
        let settings = cpu.asset("terrain.horizon").unwrap().asset.settings.horizon().unwrap().clone();
        let exact = stored_texels(&cpu, "terrain_exact.horizon", 5);
        let (mut below, mut past) = (0, 0);
        for (g, e) in h_texels.iter().zip(&exact) {
            let (slope, distance) = settings.decode(TextureFormat::Rg8Unorm, g[0], g[1]);
            if e[0] > settings.open_sky_slope {
                below += (slope < e[0]) as usize;
                past += (distance > e[1] * (1.0 + 1e-5)) as usize;
            }
        }
        eprintln!("{name}: {deeper} depths deeper, {below} horizons lower, {past} distances farther");
        assert_eq!((deeper, below, past), (0, 0, 0), "{name}: the promises hold as the device reads the texels");
    }
}

/// The terrain drawn from the BC5 horizon on a device that holds the blocks and on one that got
/// them decoded at upload: the same shadows on all but a sliver of pixels. The two read slope
/// codes up to 1.5 apart (0.2° … 1.1° of horizon, lavapipe's fixed-point decode against the
/// rounded one), which flips only texels whose horizon is that close to the sun.
#[test]
fn bc5_terrain_shadows_match_with_and_without_device_bc() {
    let dir = bundle();
    let cpu = CpuBundle::read_prefix(&dir, "terrain.").unwrap();
    let mut frames = Vec::new();
    for features in [BC | SLICED_3D, wgpu::Features::empty()] {
        let Some(g) = gpu_with("bc5_terrain_shadows_match_with_and_without_device_bc", features) else { return };
        if !g.device.features().contains(features) {
            eprintln!("the adapter lacks {features:?}: nothing to compare");
            return;
        }
        let gb = GpuBundle::upload(&g.device, &g.queue, &cpu).unwrap();
        let options = DrawOptions {
            depth_format: Some(DEPTH_FORMAT),
            visibility_format: Some(VISIBILITY_FORMAT),
            ..DrawOptions::new(COLOR_FORMAT)
        };
        let terrain = TerrainShadows::new(&g.device, &g.queue, &gb, "terrain.horizon", None, &options).unwrap();
        let (ex, ez) = (512.0 * 80.0 / 2.0, 512.0 * 60.0 / 2.0);
        let view_proj = directx::orthographic(-ex, ex, -ez, ez, 100.0, 5000.0)
            * look_at_mat4(Vec3::new(ex, 4000.0, ez), Vec3::new(ex, 0.0, ez), Vec3::NEG_Z);
        let e = 9f32.to_radians();
        let sun = Sun {
            direction: Vec3::new(e.cos() * 0.5f32.sqrt(), e.sin(), e.cos() * 0.5f32.sqrt()),
            color: Vec3::ONE,
            angular_radius: 0.0,
        };
        terrain.update(&g.queue, &TerrainFrame { view_proj, sun, ..TerrainFrame::default() });
        frames.push(g.render((512, 512), wgpu::Color::BLACK, |pass| terrain.draw(pass)).visibility);
    }
    let (native, decoded) = (&frames[0], &frames[1]);
    let covered: Vec<usize> = (0..native.len()).filter(|&i| native[i][1] > 0.5).collect();
    let lit = covered.iter().filter(|&&i| native[i][0] > 0.5).count();
    let agree = covered.iter().filter(|&&i| (native[i][0] > 0.5) == (decoded[i][0] > 0.5)).count();
    let share = agree as f64 / covered.len() as f64;
    eprintln!(
        "BC5 terrain: {} pixels, {:.1}% lit; native and decoded-at-upload agree on {:.3}%",
        covered.len(),
        100.0 * lit as f64 / covered.len() as f64,
        100.0 * share
    );
    assert!(covered.len() > 200_000 && lit > covered.len() / 5, "the view covers the terrain, partly lit");
    assert!(share >= 0.99, "{:.3}%", 100.0 * share);
}
