//! What every component does with wgpu the same way: bind its group at the index the game
//! chose, build a pipeline around it, hold a uniform, stand in for an optional texture.

use crate::draw::DrawOptions;
use crate::error::RuntimeError;

/// WGSL `source` with its bindings moved to `@group(group)`. The shader files declare their
/// bindings at `@group(0)`; a game that keeps its own bind groups at lower indices picks where
/// a component's group goes.
pub(crate) fn at_group(source: &str, group: u32) -> String {
    source.replace("@group(0)", &format!("@group({group})"))
}

/// A pipeline layout with `layout` at `group` and nothing at the indices below it.
pub(crate) fn pipeline_layout(
    device: &wgpu::Device,
    group: u32,
    layout: &wgpu::BindGroupLayout,
) -> wgpu::PipelineLayout {
    let mut slots: Vec<Option<&wgpu::BindGroupLayout>> = vec![None; group as usize];
    slots.push(Some(layout));
    device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("hikage"),
        bind_group_layouts: &slots,
        immediate_size: 0,
    })
}

/// A layout entry visible to the vertex and fragment stages.
pub(crate) fn entry(binding: u32, ty: wgpu::BindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
        ty,
        count: None,
    }
}

/// A binding of a uniform buffer holding a `T`: its minimum size is `T`'s, so a buffer or a
/// WGSL struct of another size fails when the pipeline or bind group is made, not at a draw.
pub(crate) fn uniform_entry<T: bytemuck::Pod>(binding: u32) -> wgpu::BindGroupLayoutEntry {
    entry(
        binding,
        wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: std::num::NonZeroU64::new(std::mem::size_of::<T>() as u64),
        },
    )
}

/// A float texture binding of `dimension`; `filterable` when it is sampled with filtering.
pub(crate) fn texture_entry(
    binding: u32,
    dimension: wgpu::TextureViewDimension,
    filterable: bool,
) -> wgpu::BindGroupLayoutEntry {
    entry(
        binding,
        wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: dimension,
            multisampled: false,
        },
    )
}

/// A uniform buffer of `T`'s size, filled with `value`.
pub(crate) fn uniform_buffer<T: bytemuck::Pod>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    value: &T,
) -> wgpu::Buffer {
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: std::mem::size_of::<T>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    queue.write_buffer(&buffer, 0, bytemuck::bytes_of(value));
    buffer
}

/// A 1×1 single-channel float texture holding `value`: what a component binds where an
/// optional asset (an ambient-occlusion map) is absent.
pub(crate) fn constant_texture(device: &wgpu::Device, queue: &wgpu::Queue, value: f32) -> wgpu::TextureView {
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("hikage constant"),
        size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R32Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    queue.write_texture(
        texture.as_image_copy(),
        &value.to_le_bytes(),
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4), rows_per_image: None },
        wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
    );
    texture.create_view(&Default::default())
}

/// Depth testing with `compare` into a `format` attachment, written.
pub(crate) fn depth_state(format: wgpu::TextureFormat, compare: wgpu::CompareFunction) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format,
        depth_write_enabled: Some(true),
        depth_compare: Some(compare),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

/// Colour targets of a component's pipeline: the game's `color` target, and the visibility
/// target at location 1 when the game asked for one.
pub(crate) fn targets(
    color: wgpu::ColorTargetState,
    visibility: Option<wgpu::TextureFormat>,
) -> Vec<Option<wgpu::ColorTargetState>> {
    let mut t = vec![Some(color)];
    if let Some(format) = visibility {
        t.push(Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL }));
    }
    t
}

/// Runs `create` inside a validation error scope: a pipeline or bind group wgpu refuses (a
/// target format it cannot render to, a group index past the device's limit) becomes an error
/// instead of a panic in the game's error handler.
pub(crate) fn checked<T>(device: &wgpu::Device, what: &str, create: impl FnOnce() -> T) -> Result<T, RuntimeError> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let value = create();
    match crate::upload::block_on(scope.pop()) {
        Some(e) => Err(RuntimeError::Wgpu { asset: what.to_string(), message: e.to_string() }),
        None => Ok(value),
    }
}

/// One render pipeline of a component: its stages, vertex buffers, targets and depth state,
/// with the component's bind group layout at the group index the game chose.
pub(crate) struct PipelineDesc<'a> {
    pub label: &'a str,
    pub vs: &'a str,
    pub fs: &'a str,
    pub buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    pub targets: &'a [Option<wgpu::ColorTargetState>],
    pub depth: Option<wgpu::DepthStencilState>,
    pub cull_mode: Option<wgpu::Face>,
    pub topology: wgpu::PrimitiveTopology,
}

/// The one way a component builds a render pipeline: `desc` over `module`, with `layout` at
/// `group` (nothing at the indices below).
pub(crate) fn render_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    (group, layout): (u32, &wgpu::BindGroupLayout),
    desc: PipelineDesc,
) -> wgpu::RenderPipeline {
    let pipeline_layout = pipeline_layout(device, group, layout);
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(desc.label),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(desc.vs),
            compilation_options: Default::default(),
            buffers: desc.buffers,
        },
        primitive: wgpu::PrimitiveState { cull_mode: desc.cull_mode, topology: desc.topology, ..Default::default() },
        depth_stencil: desc.depth,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(desc.fs),
            compilation_options: Default::default(),
            targets: desc.targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A shader module of `wgsl`.
pub(crate) fn module(device: &wgpu::Device, label: &str, wgsl: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(wgsl.into()),
    })
}

/// What a drawing component holds: its WGSL (bindings at the game's group), its bind group and
/// layout, and the pipeline built for the game's targets.
#[derive(Debug)]
pub(crate) struct Program {
    pub wgsl: String,
    pub layout: wgpu::BindGroupLayout,
    pub bind_group: wgpu::BindGroup,
    pub pipeline: wgpu::RenderPipeline,
    pub group: u32,
}

/// The entry points of a component's pipeline: the vertex stage, and the fragment stage without
/// and with the visibility target.
pub(crate) struct Stages<'a> {
    pub vs: &'a str,
    pub fs: &'a str,
    pub fs_visibility: &'a str,
}

impl Program {
    /// Builds the pipeline of `source` (after [`crate::SCENE_WGSL`]; bindings at `@group(0)`,
    /// moved to the options' group) around `layout` and `bind_group`, for `options`' targets,
    /// inside a validation scope.
    pub fn new(
        device: &wgpu::Device,
        asset: &str,
        source: String,
        (layout, bind_group): (wgpu::BindGroupLayout, wgpu::BindGroup),
        stages: Stages,
        buffers: &[Option<wgpu::VertexBufferLayout>],
        options: &DrawOptions,
    ) -> Result<Program, RuntimeError> {
        let wgsl = at_group(&format!("{}\n{source}", crate::SCENE_WGSL), options.group);
        let pipeline = checked(device, asset, || {
            let fs = if options.visibility_format.is_some() { stages.fs_visibility } else { stages.fs };
            render_pipeline(
                device,
                &module(device, stages.vs, &wgsl),
                (options.group, &layout),
                PipelineDesc {
                    label: fs,
                    vs: stages.vs,
                    fs,
                    buffers,
                    targets: &targets(options.color.clone(), options.visibility_format),
                    depth: options.depth_format.map(|f| depth_state(f, options.depth_compare)),
                    cull_mode: options.cull_mode,
                    topology: wgpu::PrimitiveTopology::TriangleList,
                },
            )
        })?;
        Ok(Program { wgsl, layout, bind_group, pipeline, group: options.group })
    }

    /// Sets the pipeline and the bind group at the program's group.
    pub fn bind(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(self.group, &self.bind_group, &[]);
    }
}

/// A sampler binding: filtering when the texture it samples can be filtered.
pub(crate) fn sampler_entry(binding: u32, filtering: bool) -> wgpu::BindGroupLayoutEntry {
    entry(
        binding,
        wgpu::BindingType::Sampler(if filtering {
            wgpu::SamplerBindingType::Filtering
        } else {
            wgpu::SamplerBindingType::NonFiltering
        }),
    )
}
