//! A device without a window, for tests, examples and the bench (the framework of the scenes,
//! never part of a game).
//!
//! On CI this is Mesa's lavapipe (a software Vulkan device); on a desktop any adapter wgpu
//! finds. [`gpu_required`] reads `HIKAGE_REQUIRE_GPU`: tests skip when no adapter exists unless
//! it is `1`.

use pollster::block_on;

/// True when `HIKAGE_REQUIRE_GPU=1`: a missing adapter must fail tests instead of skipping them.
pub fn gpu_required() -> bool {
    std::env::var("HIKAGE_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

/// An adapter, device and queue.
pub struct Headless {
    /// The adapter (its info names the driver, e.g. llvmpipe).
    pub adapter: wgpu::Adapter,
    /// The device, with the adapter's own limits.
    pub device: wgpu::Device,
    /// The device's queue.
    pub queue: wgpu::Queue,
}

impl Headless {
    /// Opens the first adapter wgpu offers (software adapters included) and a device with the
    /// adapter's limits and, where the adapter has it, `FLOAT32_BLENDABLE` (as a game asking
    /// for the best hair blend would).
    pub fn new() -> Result<Headless, String> {
        Headless::with_features(wgpu::Features::FLOAT32_BLENDABLE)
    }

    /// Like [`Headless::new`], with the features of `wanted` the adapter has and no others.
    pub fn with_features(wanted: wgpu::Features) -> Result<Headless, String> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::None,
            force_fallback_adapter: false,
            compatible_surface: None,
            ..Default::default()
        }))
        .map_err(|e| format!("no GPU device: {e}"))?;
        let (device, queue) = block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("hikage headless"),
            required_features: wanted & adapter.features(),
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| format!("no GPU device: {e}"))?;
        Ok(Headless { adapter, device, queue })
    }

    /// A one-line description of the adapter.
    pub fn describe(&self) -> String {
        let info = self.adapter.get_info();
        format!("{} ({:?}, {})", info.name, info.backend, info.driver)
    }

    /// Copies `buffer` (which needs `COPY_SRC`) into a mappable buffer and returns its bytes.
    pub fn read_buffer(&self, buffer: &wgpu::Buffer) -> Vec<u8> {
        let size = buffer.size();
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hikage readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
        self.queue.submit([encoder.finish()]);
        staging.map_async(wgpu::MapMode::Read, .., |r| r.expect("mapping a fresh staging buffer"));
        self.device.poll(wgpu::PollType::wait_indefinitely()).expect("device poll");
        let bytes = staging.get_mapped_range(..).expect("buffer was mapped above").to_vec();
        staging.unmap();
        bytes
    }

    /// Copies level 0 of a 2D texture (`COPY_SRC`, an uncompressed colour format) into memory,
    /// row-major, rows packed (the 256-byte row alignment of the copy is removed).
    pub fn read_texture(&self, texture: &wgpu::Texture) -> Vec<u8> {
        let (w, h) = (texture.width(), texture.height());
        let texel = texture.format().block_copy_size(None).unwrap_or(4);
        let row = w * texel;
        let padded = row.div_ceil(256) * 256;
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hikage texture readback"),
            size: padded as u64 * h as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: Some(h) },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        self.queue.submit([encoder.finish()]);
        let bytes = self.read_buffer(&buffer);
        bytes.chunks_exact(padded as usize).flat_map(|r| r[..row as usize].to_vec()).collect()
    }

    /// A buffer of `size` bytes for `usage`, filled with `contents` when given.
    pub fn buffer(&self, size: u64, usage: wgpu::BufferUsages, contents: Option<&[u8]>) -> wgpu::Buffer {
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size,
            usage: usage | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        if let Some(bytes) = contents {
            self.queue.write_buffer(&buffer, 0, bytes);
        }
        buffer
    }

    /// A 2D single-level texture of `size` for `usage`.
    pub fn texture(&self, size: (u32, u32), format: wgpu::TextureFormat, usage: wgpu::TextureUsages) -> wgpu::Texture {
        self.device.create_texture(&wgpu::TextureDescriptor {
            label: None,
            size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    }

    /// Runs one compute dispatch of `pipeline` with bind group 0 and waits for nothing: reads
    /// through [`read_buffer`](Self::read_buffer) are ordered after it.
    pub fn dispatch(&self, pipeline: &wgpu::ComputePipeline, bind: &wgpu::BindGroup, groups: (u32, u32, u32)) {
        let mut encoder = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, groups.2);
        }
        self.queue.submit([encoder.finish()]);
    }
}

/// The formats [`Headless::render`] draws into: what the examples and tests build components for.
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// See [`COLOR_FORMAT`]: the components' visibility target.
pub const VISIBILITY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// See [`COLOR_FORMAT`].
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// One rendered frame read back.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width and height.
    pub size: (u32, u32),
    /// sRGB RGBA8 pixels, row-major (ready for a PNG).
    pub color: Vec<u8>,
    /// The visibility target's pixels (zero where nothing was drawn).
    pub visibility: Vec<[f32; 4]>,
}

impl Headless {
    /// Renders one pass into a `size` colour target ([`COLOR_FORMAT`], cleared to `clear`), a
    /// visibility target ([`VISIBILITY_FORMAT`], cleared to zero) and a depth target
    /// ([`DEPTH_FORMAT`]); `draw` records the pass. Reads both colour targets back.
    pub fn render(&self, size: (u32, u32), clear: wgpu::Color, draw: impl FnOnce(&mut wgpu::RenderPass<'_>)) -> Frame {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        let color = self.texture(size, COLOR_FORMAT, usage);
        let visibility = self.texture(size, VISIBILITY_FORMAT, usage);
        let depth = self.texture(size, DEPTH_FORMAT, wgpu::TextureUsages::RENDER_ATTACHMENT);
        let (cv, vv, dv) = (
            color.create_view(&Default::default()),
            visibility.create_view(&Default::default()),
            depth.create_view(&Default::default()),
        );
        let mut encoder = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("frame"),
                color_attachments: &[clear_attachment(&cv, clear), clear_attachment(&vv, wgpu::Color::TRANSPARENT)],
                depth_stencil_attachment: depth_attachment(&dv),
                ..Default::default()
            });
            draw(&mut pass);
        }
        self.queue.submit([encoder.finish()]);
        let visibility = self
            .read_texture(&visibility)
            .chunks_exact(16)
            .map(|c| std::array::from_fn(|k| f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]])))
            .collect();
        Frame { size, color: self.read_texture(&color), visibility }
    }
}

/// WGSL of a vertex stage `vs` drawing one triangle over the whole target (3 vertices, no
/// buffers), for scenes whose fragment stage computes each pixel's ray.
pub const FULLSCREEN_WGSL: &str = include_str!("shaders/fullscreen.wgsl");

/// A colour attachment cleared to `clear` and stored.
pub fn clear_attachment(view: &wgpu::TextureView, clear: wgpu::Color) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store },
    })
}

/// A depth attachment cleared to 1 and discarded after the pass.
pub fn depth_attachment(view: &wgpu::TextureView) -> Option<wgpu::RenderPassDepthStencilAttachment<'_>> {
    Some(wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
        stencil_ops: None,
    })
}

/// Depth testing with `Less` into a `Depth32Float` attachment.
pub fn depth_test() -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: wgpu::TextureFormat::Depth32Float,
        depth_write_enabled: Some(true),
        depth_compare: Some(wgpu::CompareFunction::Less),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

/// A render pipeline with an automatic layout, no culling, one vertex and fragment entry point
/// of `module` and unblended targets of `formats`.
pub fn render_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    (vs, fs): (&str, &str),
    buffers: &[Option<wgpu::VertexBufferLayout>],
    targets: &[Option<wgpu::ColorTargetState>],
    depth: Option<wgpu::DepthStencilState>,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(fs),
        layout: None,
        vertex: wgpu::VertexState { module, entry_point: Some(vs), compilation_options: Default::default(), buffers },
        primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
        depth_stencil: depth,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fs),
            compilation_options: Default::default(),
            targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// An unblended colour target of `format`.
pub fn plain_target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })
}
