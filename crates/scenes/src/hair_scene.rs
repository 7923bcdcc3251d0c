//! The hair scene of seed 004 (demo code): the strips of a `strands` asset drawn into deep
//! opacity maps from a light, then seen by a camera over a ground quad, and the aliasing figure
//! of the ground's shadow. Used by the `hair_shadow` example and the GPU tests.

use hikage_bundle::MeshDesc;
use hikage_runtime::glam::{Mat4, Vec3};
use hikage_runtime::hair::{HAIR_WGSL, HairLight, HairSet};

use crate::headless::{Headless, clear_attachment, depth_attachment, depth_test, plain_target, render_pipeline};

/// The `HairFrame` uniform.
fn frame_bytes(light: &HairLight, camera: Mat4, eye: Vec3, set: HairSet, resolution: u32) -> Vec<u8> {
    let mut f: Vec<f32> = Vec::new();
    f.extend(light.view_proj.to_cols_array());
    f.extend(camera.to_cols_array());
    f.extend([eye.x, eye.y, eye.z, 1.0]);
    f.extend([light.to_light.x, light.to_light.y, light.to_light.z, 0.0]);
    f.extend([0.0, 1.0, light.step, if set == HairSet::Opacity { 1.0 } else { 0.0 }]);
    f.extend([resolution as f32, 0.0, 0.0, 0.0]);
    f.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// Strip geometry on the GPU: the payload buffer of a `strands` mesh and its layout.
pub struct GpuStrips<'a> {
    /// The payload (usage `VERTEX | INDEX`).
    pub buffer: &'a wgpu::Buffer,
    /// Its layout.
    pub desc: &'a MeshDesc,
}

const STREAMS: [(&str, wgpu::VertexFormat); 6] = [
    ("position", wgpu::VertexFormat::Float32x3),
    ("side", wgpu::VertexFormat::Float32),
    ("tangent", wgpu::VertexFormat::Float32x3),
    ("width", wgpu::VertexFormat::Float32x2),
    ("opacity", wgpu::VertexFormat::Float32x2),
    ("color", wgpu::VertexFormat::Float32x3),
];

impl GpuStrips<'_> {
    fn layouts() -> Vec<wgpu::VertexBufferLayout<'static>> {
        const ATTRS: [[wgpu::VertexAttribute; 1]; 6] = [
            [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x3, offset: 0, shader_location: 0 }],
            [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32, offset: 0, shader_location: 1 }],
            [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x3, offset: 0, shader_location: 2 }],
            [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x2, offset: 0, shader_location: 3 }],
            [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x2, offset: 0, shader_location: 4 }],
            [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x3, offset: 0, shader_location: 5 }],
        ];
        ATTRS
            .iter()
            .zip(STREAMS)
            .map(|(a, (_, f))| wgpu::VertexBufferLayout {
                array_stride: f.size(),
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: a,
            })
            .collect()
    }

    fn bind<'p>(&self, pass: &mut wgpu::RenderPass<'p>) -> Result<u32, String> {
        for (slot, (name, _)) in STREAMS.iter().enumerate() {
            let a = self.desc.attribute(name).ok_or_else(|| format!("the strands mesh has no `{name}` stream"))?;
            pass.set_vertex_buffer(slot as u32, self.buffer.slice(a.offset..));
        }
        let ix = self.desc.indices.as_ref().ok_or("the strands mesh has no indices")?;
        pass.set_index_buffer(self.buffer.slice(ix.offset..ix.offset + 4 * ix.count as u64), wgpu::IndexFormat::Uint32);
        Ok(ix.count)
    }
}

/// The opacity maps on the GPU: the depth map (R32Float) and the layers (Rgba16Float).
pub struct OpacityMaps {
    /// Nearest hair depth per texel, light NDC (1: none).
    pub depth: wgpu::Texture,
    /// Cumulative opacity of layers 1–4.
    pub layers: wgpu::Texture,
    /// Texels per side.
    pub resolution: u32,
}

fn module(gpu: &Headless) -> wgpu::ShaderModule {
    gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("hair"),
        source: wgpu::ShaderSource::Wgsl(HAIR_WGSL.into()),
    })
}

/// Renders the depth map and the opacity layers of `strips` drawn with `set`.
pub fn render_opacity_maps(
    gpu: &Headless,
    strips: &GpuStrips,
    light: &HairLight,
    set: HairSet,
    resolution: u32,
) -> Result<OpacityMaps, String> {
    let module = module(gpu);
    let layouts: Vec<_> = GpuStrips::layouts().into_iter().map(Some).collect();
    let usage =
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC;
    let size = (resolution, resolution);
    let depth = gpu.texture(size, wgpu::TextureFormat::R32Float, usage);
    let layers = gpu.texture(size, wgpu::TextureFormat::Rgba16Float, usage);
    let zbuf = gpu.texture(size, wgpu::TextureFormat::Depth32Float, wgpu::TextureUsages::RENDER_ATTACHMENT);
    let add = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    let device = &gpu.device;
    let depth_pipe = render_pipeline(
        device,
        &module,
        ("vs_light", "fs_depth"),
        &layouts,
        &[plain_target(wgpu::TextureFormat::R32Float)],
        Some(depth_test()),
    );
    let layer_pipe = render_pipeline(
        device,
        &module,
        ("vs_light", "fs_opacity"),
        &layouts,
        &[Some(wgpu::ColorTargetState {
            format: wgpu::TextureFormat::Rgba16Float,
            blend: Some(wgpu::BlendState { color: add, alpha: add }),
            write_mask: wgpu::ColorWrites::ALL,
        })],
        None,
    );
    let frame = frame_bytes(light, Mat4::IDENTITY, Vec3::ZERO, set, resolution);
    let ubuf = gpu.buffer(frame.len() as u64, wgpu::BufferUsages::UNIFORM, Some(&frame));
    let dview = depth.create_view(&Default::default());
    let lview = layers.create_view(&Default::default());
    let zview = zbuf.create_view(&Default::default());
    let depth_bind = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &depth_pipe.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: ubuf.as_entire_binding() }],
    });
    let layer_bind = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &layer_pipe.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: ubuf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&dview) },
        ],
    });
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("hair depth"),
            color_attachments: &[clear_attachment(&dview, wgpu::Color { r: 1.0, g: 1.0, b: 1.0, a: 1.0 })],
            depth_stencil_attachment: depth_attachment(&zview),
            ..Default::default()
        });
        pass.set_pipeline(&depth_pipe);
        pass.set_bind_group(0, &depth_bind, &[]);
        let n = strips.bind(&mut pass)?;
        pass.draw_indexed(0..n, 0, 0..1);
    }
    {
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("hair opacity"),
            color_attachments: &[clear_attachment(&lview, wgpu::Color::TRANSPARENT)],
            ..Default::default()
        });
        pass.set_pipeline(&layer_pipe);
        pass.set_bind_group(0, &layer_bind, &[]);
        let n = strips.bind(&mut pass)?;
        pass.draw_indexed(0..n, 0, 0..1);
    }
    gpu.queue.submit([enc.finish()]);
    Ok(OpacityMaps { depth, layers, resolution })
}

impl OpacityMaps {
    /// Reads both maps back: depth per texel and the four layers.
    pub fn read(&self, gpu: &Headless) -> (Vec<f32>, Vec<[f32; 4]>) {
        let d = gpu.read_texture(&self.depth);
        let l = gpu.read_texture(&self.layers);
        let depth = d.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        let layers = l
            .chunks_exact(8)
            .map(|c| std::array::from_fn(|k| half::f16::from_le_bytes([c[2 * k], c[2 * k + 1]]).to_f32()))
            .collect();
        (depth, layers)
    }
}

/// A camera view of the hair (shading set, Kajiya-Kay) over a ground quad, both shadowed from
/// `maps`; and the ground's visibility seen by `ground_camera` (R32Float), for the aliasing
/// figure, drawn once each at their own sizes `(image, ground)`. Returns (RGBA8 image, visibility
/// image).
#[allow(clippy::too_many_arguments)]
pub fn render_scene(
    gpu: &Headless,
    strips: &GpuStrips,
    maps: &OpacityMaps,
    light: &HairLight,
    (camera, eye): (Mat4, Vec3),
    ground: [Vec3; 4],
    ground_camera: Mat4,
    (size, ground_size): ((u32, u32), (u32, u32)),
) -> Result<(Vec<u8>, Vec<f32>), String> {
    let module = module(gpu);
    let layouts: Vec<_> = GpuStrips::layouts().into_iter().map(Some).collect();
    let ground_layout = [Some(wgpu::VertexBufferLayout {
        array_stride: 12,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &wgpu::vertex_attr_array![0 => Float32x3],
    })];
    let rgba = wgpu::TextureFormat::Rgba8Unorm;
    let device = &gpu.device;
    let pipe = |entries, layout: &[Option<wgpu::VertexBufferLayout>], format, depth| {
        render_pipeline(device, &module, entries, layout, &[plain_target(format)], depth)
    };
    let hair_pipe = pipe(("vs_hair", "fs_hair"), &layouts, rgba, Some(depth_test()));
    let ground_pipe = pipe(("vs_ground", "fs_ground"), &ground_layout, rgba, Some(depth_test()));
    let vis_pipe = pipe(("vs_ground", "fs_ground_visibility"), &ground_layout, wgpu::TextureFormat::R32Float, None);
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
    let color = gpu.texture(size, rgba, usage);
    let zbuf = gpu.texture(size, wgpu::TextureFormat::Depth32Float, wgpu::TextureUsages::RENDER_ATTACHMENT);
    let vis = gpu.texture(ground_size, wgpu::TextureFormat::R32Float, usage);
    let frame = frame_bytes(light, camera, eye, HairSet::Shading, maps.resolution);
    let top = frame_bytes(light, ground_camera, eye, HairSet::Shading, maps.resolution);
    let ubuf = gpu.buffer(frame.len() as u64, wgpu::BufferUsages::UNIFORM, Some(&frame));
    let tbuf = gpu.buffer(top.len() as u64, wgpu::BufferUsages::UNIFORM, Some(&top));
    let quad: Vec<u8> =
        [0usize, 1, 2, 0, 2, 3].iter().flat_map(|&i| ground[i].to_array()).flat_map(f32::to_le_bytes).collect();
    let gbuf = gpu.buffer(quad.len() as u64, wgpu::BufferUsages::VERTEX, Some(&quad));
    let (dview, lview) = (maps.depth.create_view(&Default::default()), maps.layers.create_view(&Default::default()));
    let bind = |pipe: &wgpu::RenderPipeline, u: &wgpu::Buffer| {
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipe.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: u.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&dview) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&lview) },
            ],
        })
    };
    let (hb, gb, vb) = (bind(&hair_pipe, &ubuf), bind(&ground_pipe, &ubuf), bind(&vis_pipe, &tbuf));
    let (cview, zview, vview) = (
        color.create_view(&Default::default()),
        zbuf.create_view(&Default::default()),
        vis.create_view(&Default::default()),
    );
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("hair scene"),
            color_attachments: &[clear_attachment(&cview, wgpu::Color { r: 0.55, g: 0.65, b: 0.8, a: 1.0 })],
            depth_stencil_attachment: depth_attachment(&zview),
            ..Default::default()
        });
        pass.set_pipeline(&ground_pipe);
        pass.set_bind_group(0, &gb, &[]);
        pass.set_vertex_buffer(0, gbuf.slice(..));
        pass.draw(0..6, 0..1);
        pass.set_pipeline(&hair_pipe);
        pass.set_bind_group(0, &hb, &[]);
        let n = strips.bind(&mut pass)?;
        pass.draw_indexed(0..n, 0, 0..1);
    }
    {
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("ground visibility"),
            color_attachments: &[clear_attachment(&vview, wgpu::Color::WHITE)],
            ..Default::default()
        });
        pass.set_pipeline(&vis_pipe);
        pass.set_bind_group(0, &vb, &[]);
        pass.set_vertex_buffer(0, gbuf.slice(..));
        pass.draw(0..6, 0..1);
    }
    gpu.queue.submit([enc.finish()]);
    let image = gpu.read_texture(&color);
    let v = gpu.read_texture(&vis).chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    Ok((image, v))
}

/// Aliasing of a shadow image: the mean squared difference between each pixel and the mean of
/// its 3×3 neighbourhood (high-frequency energy), over pixels in shadow (visibility < 0.98) or
/// next to one, relative to the squared mean darkness there. Holes and stripes in a shadow raise
/// it; a smooth shadow of the same darkness keeps it low.
pub fn high_frequency_energy(v: &[f32], (w, h): (u32, u32)) -> f64 {
    let (w, h) = (w as usize, h as usize);
    let (mut energy, mut dark, mut n) = (0.0f64, 0.0f64, 0usize);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let mut sum = 0.0f64;
            let mut any = false;
            for dy in 0..3 {
                for dx in 0..3 {
                    let s = v[(y + dy - 1) * w + x + dx - 1] as f64;
                    sum += s;
                    any |= s < 0.98;
                }
            }
            if !any {
                continue;
            }
            let c = v[y * w + x] as f64;
            energy += (c - sum / 9.0).powi(2);
            dark += 1.0 - c;
            n += 1;
        }
    }
    if n == 0 || dark == 0.0 {
        return 0.0;
    }
    (energy / n as f64) / (dark / n as f64).powi(2)
}
