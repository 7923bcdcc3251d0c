//! The reference scene of seed 003: one tile of a relief as a quad (the top plane `z = 0`, world
//! `x = u`, `y = v` in texels, `z` up) seen by a pinhole camera, traced per pixel. The GPU draws
//! it with [`render`]; [`camera_ray`] gives the same ray per pixel on the CPU so the tracers of
//! [`hikage_runtime::relief`] can be compared pixel by pixel. Used by the `relief_plane` example and the
//! GPU tests.

use glam::Vec3;
use hikage_bundle::relief::ReliefRay;

use crate::headless::{Headless, clear_attachment, plain_target, render_pipeline};
use hikage_runtime::relief::Tracer;
use hikage_runtime::relief::reference::ReliefMaps;

/// WGSL of the scene; prepend [`hikage_runtime::relief::RELIEF_WGSL`] and append
/// [`crate::headless::FULLSCREEN_WGSL`].
pub const PLANE_WGSL: &str = include_str!("shaders/relief_plane.wgsl");

/// One view of the relief quad.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneView {
    /// Camera position (texels; `z` up, above the plane).
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Vertical field of view, degrees.
    pub fov_y_degrees: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Unit vector toward the light (`z` up).
    pub light: Vec3,
    /// Depth-map shadows.
    pub shadows: bool,
    /// Ambient occlusion over every `ao_stride`-th direction (0: off).
    pub ao_stride: u32,
}

/// The camera basis the shader gets: forward, and right/up scaled by the field of view.
fn basis(view: &PlaneView) -> (Vec3, Vec3, Vec3) {
    let forward = (view.target - view.eye).normalize();
    let right = forward.cross(Vec3::Z).normalize();
    let up = right.cross(forward);
    let tan = (view.fov_y_degrees.to_radians() * 0.5).tan();
    let aspect = view.width as f32 / view.height as f32;
    (forward, right * tan * aspect, up * tan)
}

/// The relief ray of pixel `(px, py)` (centre at `+0.5`), or `None` when the pixel misses the
/// quad `[0, width) × [0, height)` texels. Follows `fs` in the scene shader.
pub fn camera_ray(view: &PlaneView, maps: &ReliefMaps, px: u32, py: u32) -> Option<ReliefRay> {
    let (forward, right, up) = basis(view);
    let ndc_x = (px as f32 + 0.5) / view.width as f32 * 2.0 - 1.0;
    let ndc_y = 1.0 - (py as f32 + 0.5) / view.height as f32 * 2.0;
    let d = (forward + right * ndc_x + up * ndc_y).normalize();
    if d.z >= 0.0 {
        return None;
    }
    let t = -view.eye.z / d.z;
    let (u, v) = (view.eye.x + t * d.x, view.eye.y + t * d.y);
    let (w, h) = (maps.max_mip.width() as f32, maps.max_mip.height() as f32);
    if u < 0.0 || v < 0.0 || u >= w || v >= h {
        return None;
    }
    Some(maps.ray([u, v], [d.x, d.y, -d.z]))
}

/// Depth (normalised) a stored hit may lie above a point that still counts as lit or open; the
/// shader's `SHADOW_BIAS`.
pub const SHADOW_BIAS: f32 = 0.02;

/// One pixel of a GPU render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelData {
    /// Hit length along the ray (texels).
    pub s: f32,
    /// Height-map reads of the tracer.
    pub height_reads: u32,
    /// Depth-map reads of the tracer.
    pub depth_reads: u32,
    /// False for background pixels.
    pub on_quad: bool,
    /// Lit by the depth-map shadow test (always true with shadows off).
    pub lit: bool,
    /// Open share of the hemisphere (1 with ambient occlusion off).
    pub ao: f32,
}

/// Renders the quad on the GPU with `tracer`: RGBA8 colour and per-pixel data. `max_mip` is the
/// max-mip texture's view (every level), `depth` the depth maps' (2D array).
pub fn render(
    gpu: &Headless,
    maps: &ReliefMaps,
    tracer: Tracer,
    view: &PlaneView,
    max_mip: &wgpu::TextureView,
    depth: &wgpu::TextureView,
) -> (Vec<u8>, Vec<PixelData>) {
    let device = &gpu.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("relief plane"),
        source: wgpu::ShaderSource::Wgsl(
            format!("{}\n{}\n{}", hikage_runtime::relief::RELIEF_WGSL, PLANE_WGSL, crate::headless::FULLSCREEN_WGSL)
                .into(),
        ),
    });
    let targets = [
        plain_target(wgpu::TextureFormat::Rgba8Unorm),
        plain_target(wgpu::TextureFormat::Rgba32Float),
        plain_target(wgpu::TextureFormat::Rgba32Float),
    ];
    let pipeline = render_pipeline(device, &module, ("vs", "fs"), &[], &targets, None);
    let params = maps.uniform(tracer);
    let params = hikage_runtime::bytemuck::bytes_of(&params);
    let pbuf = gpu.buffer(params.len() as u64, wgpu::BufferUsages::UNIFORM, Some(params));
    let (forward, right, up) = basis(view);
    let l = view.light;
    let mut scene: Vec<f32> = Vec::new();
    for v in [view.eye, forward, right, up] {
        scene.extend([v.x, v.y, v.z, 0.0]);
    }
    scene.extend([l.x, l.y, l.z, if view.shadows { 1.0 } else { 0.0 }]);
    scene.extend([view.width as f32, view.height as f32, f32::from_bits(view.ao_stride), 0.0]);
    let bytes: Vec<u8> = scene.iter().flat_map(|v| v.to_le_bytes()).collect();
    let sbuf = gpu.buffer(bytes.len() as u64, wgpu::BufferUsages::UNIFORM, Some(&bytes));
    let relief_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(max_mip) },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(depth) },
            wgpu::BindGroupEntry { binding: 2, resource: pbuf.as_entire_binding() },
        ],
    });
    let scene_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(1),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: sbuf.as_entire_binding() }],
    });
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
    let target = |format| gpu.texture((view.width, view.height), format, usage);
    let color = target(wgpu::TextureFormat::Rgba8Unorm);
    let data = target(wgpu::TextureFormat::Rgba32Float);
    let shade = target(wgpu::TextureFormat::Rgba32Float);
    let (cv, dv) = (color.create_view(&Default::default()), data.create_view(&Default::default()));
    let sv = shade.create_view(&Default::default());
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let attach = |view| clear_attachment(view, wgpu::Color::BLACK);
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("relief plane"),
            color_attachments: &[attach(&cv), attach(&dv), attach(&sv)],
            ..Default::default()
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &relief_group, &[]);
        pass.set_bind_group(1, &scene_group, &[]);
        pass.draw(0..3, 0..1);
    }
    gpu.queue.submit([enc.finish()]);
    let rgba = gpu.read_texture(&color);
    let (raw, shade) = (gpu.read_texture(&data), gpu.read_texture(&shade));
    let f = |c: &[u8], k: usize| f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]]);
    let pixels = raw
        .chunks_exact(16)
        .zip(shade.chunks_exact(16))
        .map(|(c, sh)| PixelData {
            s: f(c, 0),
            height_reads: f(c, 1) as u32,
            depth_reads: f(c, 2) as u32,
            on_quad: f(c, 3) > 0.5,
            lit: f(sh, 0) > 0.5,
            ao: f(sh, 1),
        })
        .collect();
    (rgba, pixels)
}
