//! The GPU side of [`super::HairRenderer`]: its bind group layouts, the frame-sized targets of
//! the camera's blend, and the render pipelines of its passes.

use super::frame::{BlendWeight, HairOptions};
use crate::gpu;

/// The record's streams the shaders read, by their names in the one table of the kind
/// ([`hikage_bundle::STRANDS_STREAMS`]), with the vertex format each is read as.
pub(super) const STREAMS: [(&str, wgpu::VertexFormat); 6] = {
    let s = hikage_bundle::STRANDS_STREAMS;
    [
        (s[0].name, wgpu::VertexFormat::Float32x3),
        (s[1].name, wgpu::VertexFormat::Unorm16x2),
        (s[2].name, wgpu::VertexFormat::Unorm16x2),
        (s[3].name, wgpu::VertexFormat::Unorm8x4),
        (s[4].name, wgpu::VertexFormat::Uint16x2),
        (s[5].name, wgpu::VertexFormat::Uint32),
    ]
};

/// Bytes of one strand record.
pub(super) const RECORD: u64 = hikage_bundle::STRANDS_RECORD_BYTES as u64;

pub(super) const DEPTH_MAP: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
pub(super) const LAYERS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(super) const REVEALAGE: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;

#[derive(Debug)]
pub(super) struct Layouts {
    pub(super) light: wgpu::BindGroupLayout,
    pub(super) opacity: wgpu::BindGroupLayout,
    pub(super) receiver: wgpu::BindGroupLayout,
    /// The blended pass weighted by the camera's layers: the receivers' entries and the layers.
    pub(super) camera: wgpu::BindGroupLayout,
    pub(super) composite: wgpu::BindGroupLayout,
}

/// The frame-sized targets of the camera's blend and the groups that read them.
#[derive(Debug)]
pub(super) struct FrameTargets {
    pub(super) accum: wgpu::TextureView,
    pub(super) revealage: wgpu::TextureView,
    /// With [`BlendWeight::Layers`]: the camera's 8 cumulative opacity layers (the nearer four,
    /// the farther four) and the blended pass's group reading them with the opacity maps.
    pub(super) layers: Option<([wgpu::Texture; 2], wgpu::BindGroup)>,
    pub(super) composite_group: wgpu::BindGroup,
}

#[derive(Debug)]
pub(super) struct Pipelines {
    pub(super) depth: wgpu::RenderPipeline,
    pub(super) opacity: wgpu::RenderPipeline,
    /// With [`BlendWeight::Layers`]: the camera's opacity layers, drawn before the blend.
    pub(super) camera_layers: Option<wgpu::RenderPipeline>,
    pub(super) oit: wgpu::RenderPipeline,
    pub(super) opaque: wgpu::RenderPipeline,
    pub(super) composite: wgpu::RenderPipeline,
}

pub(super) fn texture(
    device: &wgpu::Device,
    size: (u32, u32),
    format: wgpu::TextureFormat,
    label: &str,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: size.0.max(1), height: size.1.max(1), depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

pub(super) fn view_entry(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) }
}

pub(super) fn color_attachment(
    view: &wgpu::TextureView,
    clear: wgpu::Color,
) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store },
    })
}

/// The order-independent blend's targets of `size` and the groups over them; `maps` are the
/// uniform and the opacity maps the blended pass also reads.
pub(super) fn frame_targets(
    device: &wgpu::Device,
    layouts: &Layouts,
    size: (u32, u32),
    accum_format: wgpu::TextureFormat,
    blend: BlendWeight,
    (uniform, depth_map, layers): (&wgpu::Buffer, &wgpu::TextureView, &wgpu::TextureView),
) -> FrameTargets {
    let accum = texture(device, size, accum_format, "hikage hair accumulation").create_view(&Default::default());
    let revealage = texture(device, size, REVEALAGE, "hikage hair revealage").create_view(&Default::default());
    let composite_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("hikage hair composite"),
        layout: &layouts.composite,
        entries: &[view_entry(3, &accum), view_entry(4, &revealage)],
    });
    let layers = (blend == BlendWeight::Layers).then(|| {
        let textures = ["hikage hair camera layers 1-4", "hikage hair camera layers 5-8"]
            .map(|label| texture(device, size, LAYERS_FORMAT, label));
        let [near, far] = textures.each_ref().map(|t| t.create_view(&Default::default()));
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hikage hair camera"),
            layout: &layouts.camera,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                view_entry(1, depth_map),
                view_entry(2, layers),
                view_entry(5, &near),
                view_entry(6, &far),
            ],
        });
        (textures, group)
    });
    FrameTargets { accum, revealage, layers, composite_group }
}

pub(super) fn pipelines(
    device: &wgpu::Device,
    wgsl: &str,
    layouts: &Layouts,
    options: &HairOptions,
    accum_format: wgpu::TextureFormat,
) -> Pipelines {
    let module = gpu::module(device, "hikage hair", wgsl);
    // Both ends of a segment: the same record layout at locations 0–5 and 6–11.
    let attributes: Vec<Vec<wgpu::VertexAttribute>> = (0..2u32)
        .map(|end| {
            let mut offset = 0;
            STREAMS
                .iter()
                .enumerate()
                .map(|(k, &(_, format))| {
                    let a = wgpu::VertexAttribute { format, offset, shader_location: 6 * end + k as u32 };
                    offset += format.size();
                    a
                })
                .collect()
        })
        .collect();
    let buffers: Vec<Option<wgpu::VertexBufferLayout>> = attributes
        .iter()
        .map(|a| {
            Some(wgpu::VertexBufferLayout {
                array_stride: RECORD,
                step_mode: wgpu::VertexStepMode::Instance,
                attributes: a,
            })
        })
        .collect();
    let add = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    let keep_inverse = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::OneMinusSrc,
        operation: wgpu::BlendOperation::Add,
    };
    let target = |format, blend| Some(wgpu::ColorTargetState { format, blend, write_mask: wgpu::ColorWrites::ALL });
    let depth = |format, write, compare| wgpu::DepthStencilState {
        depth_write_enabled: Some(write),
        ..gpu::depth_state(format, compare)
    };
    let scene_depth = |write| options.draw.depth_format.map(|f| depth(f, write, options.draw.depth_compare));
    let color = options.draw.color.format;
    let pipeline = |layout: &wgpu::BindGroupLayout,
                    (vs, fs): (&str, &str),
                    strips: bool,
                    targets: &[Option<wgpu::ColorTargetState>],
                    depth: Option<wgpu::DepthStencilState>| {
        let desc = gpu::PipelineDesc {
            label: fs,
            vs,
            fs,
            buffers: if strips { &buffers } else { &[] },
            targets,
            depth,
            cull_mode: None,
            topology: if strips {
                wgpu::PrimitiveTopology::TriangleStrip
            } else {
                wgpu::PrimitiveTopology::TriangleList
            },
        };
        gpu::render_pipeline(device, &module, (options.draw.group, layout), desc)
    };
    let oit_targets = [
        target(accum_format, Some(wgpu::BlendState { color: add, alpha: add })),
        target(REVEALAGE, Some(wgpu::BlendState { color: keep_inverse, alpha: keep_inverse })),
    ];
    Pipelines {
        depth: pipeline(
            &layouts.light,
            ("hair_vs_light", "hair_fs_depth"),
            true,
            &[target(DEPTH_MAP, None)],
            Some(depth(wgpu::TextureFormat::Depth32Float, true, wgpu::CompareFunction::Less)),
        ),
        opacity: pipeline(
            &layouts.opacity,
            ("hair_vs_light", "hair_fs_opacity"),
            true,
            &[target(LAYERS_FORMAT, Some(wgpu::BlendState { color: add, alpha: add }))],
            None,
        ),
        camera_layers: (options.blend == BlendWeight::Layers).then(|| {
            pipeline(
                &layouts.light,
                ("hair_vs_camera", "hair_fs_camera_layers"),
                true,
                &[
                    target(LAYERS_FORMAT, Some(wgpu::BlendState { color: add, alpha: add })),
                    target(LAYERS_FORMAT, Some(wgpu::BlendState { color: add, alpha: add })),
                ],
                scene_depth(false),
            )
        }),
        oit: match options.blend {
            BlendWeight::Layers => pipeline(
                &layouts.camera,
                ("hair_vs_camera", "hair_fs_oit_layered"),
                true,
                &oit_targets,
                scene_depth(false),
            ),
            BlendWeight::Depth => {
                pipeline(&layouts.receiver, ("hair_vs_camera", "hair_fs_oit"), true, &oit_targets, scene_depth(false))
            }
        },
        opaque: pipeline(
            &layouts.receiver,
            ("hair_vs_camera_opaque", "hair_fs_opaque"),
            true,
            &[target(color, None)],
            scene_depth(true),
        ),
        composite: pipeline(
            &layouts.composite,
            ("hair_vs_composite", "hair_fs_composite"),
            false,
            &[target(color, Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING))],
            None,
        ),
    }
}
