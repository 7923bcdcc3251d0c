//! The reference scene of seed 000 (Fig. 4/5): a sphere of curvature κ carrying a tiled bump
//! map, shadowed by the horizon test, flat or curvature-corrected. Drawn analytically per pixel
//! (orthographic view along −z, the sphere filling the image), on the GPU by
//! [`render`] and on the CPU by [`shade_cpu`], which follows the shader line by line so the two
//! can be compared per pixel. Used by the `horizon_sphere` example and the GPU tests.
//!
//! Surface frame: longitude `λ = atan2(x, z)` runs along +u (east), latitude `ψ` decreases
//! along +v (south); texture coordinates count bump-map tiles, `uv = (λR, −ψR) / tile_world`.

use glam::{Vec2, Vec3};

use crate::headless::{Headless, clear_attachment, plain_target, render_pipeline};
use hikage_runtime::horizon::{HorizonMap, horizon_shadow_lit};

/// WGSL of the scene; prepend [`hikage_runtime::horizon::HORIZON_WGSL`] and append
/// [`crate::headless::FULLSCREEN_WGSL`].
pub const SPHERE_WGSL: &str = include_str!("shaders/horizon_sphere.wgsl");

/// One view of the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereScene {
    /// World direction toward the light (normalised by the user).
    pub light: Vec3,
    /// Sphere curvature κ (radius 1/κ).
    pub sphere_kappa: f32,
    /// Apply the curvature correction (false: the flat horizon test of Forsyth).
    pub corrected: bool,
    /// World size of one bump-map tile (texels × texel size).
    pub tile_world: f32,
    /// World height = `height_scale × sample`.
    pub height_scale: f32,
    /// Image width and height in pixels.
    pub size: u32,
}

/// Per-pixel result: 0 shadowed, 1 lit, 2 background.
pub type Flags = Vec<u32>;

/// CPU reference of `fs` in the scene shader for pixel centre `(px + 0.5, py + 0.5)`.
pub fn shade_cpu(
    scene: &SphereScene,
    map: &HorizonMap,
    heights: &[f32],
    dims: (usize, usize),
    px: u32,
    py: u32,
) -> u32 {
    let r = 1.0 / scene.sphere_kappa;
    let size = scene.size as f32;
    let ndc = Vec2::new((px as f32 + 0.5) / size * 2.0 - 1.0, (py as f32 + 0.5) / size * 2.0 - 1.0);
    let (x, y) = (ndc.x * r * 1.05, -ndc.y * r * 1.05);
    let r2 = x * x + y * y;
    if r2 >= r * r {
        return 2;
    }
    let z = (r * r - r2).sqrt();
    let n = Vec3::new(x, y, z) / r;
    let lam = x.atan2(z);
    let psi = (y / r).clamp(-1.0, 1.0).asin();
    let east = Vec3::new(lam.cos(), 0.0, -lam.sin());
    let south = Vec3::new(psi.sin() * lam.sin(), -psi.cos(), psi.sin() * lam.cos());
    let uv = Vec2::new(lam * r / scene.tile_world, -psi * r / scene.tile_world);
    let f = uv - uv.floor();
    let (tx, ty) = ((f.x * dims.0 as f32).floor() as usize, (f.y * dims.1 as f32).floor() as usize);
    let h = scene.height_scale * heights[ty.min(dims.1 - 1) * dims.0 + tx.min(dims.0 - 1)];
    let l = scene.light;
    let lf = Vec3::new(l.dot(east), l.dot(south), l.dot(n));
    let kappa = if scene.corrected { scene.sphere_kappa } else { 0.0 };
    horizon_shadow_lit(map, uv, lf, kappa, kappa, Vec2::new(1.0, 0.0), h) as u32
}

/// The whole image on the CPU.
pub fn render_cpu(scene: &SphereScene, map: &HorizonMap, heights: &[f32], dims: (usize, usize)) -> Flags {
    (0..scene.size * scene.size).map(|i| shade_cpu(scene, map, heights, dims, i % scene.size, i / scene.size)).collect()
}

/// Shadowed share of the sphere's pixels.
pub fn shadowed_fraction(flags: &[u32]) -> f64 {
    let sphere = flags.iter().filter(|&&f| f != 2).count();
    flags.iter().filter(|&&f| f == 0).count() as f64 / sphere.max(1) as f64
}

/// Renders the scene on the GPU: RGBA8 colour (row-major, 4 bytes a pixel) and per-pixel flags.
/// `horizon` is the horizon texture's view, `heights` the heightfield's (R32Float, 2D).
pub fn render(
    gpu: &Headless,
    scene: &SphereScene,
    horizon: &wgpu::TextureView,
    heights: &wgpu::TextureView,
) -> (Vec<u8>, Flags) {
    let device = &gpu.device;
    let size = scene.size;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("horizon sphere"),
        source: wgpu::ShaderSource::Wgsl(
            format!("{}\n{}\n{}", hikage_runtime::horizon::HORIZON_WGSL, SPHERE_WGSL, crate::headless::FULLSCREEN_WGSL)
                .into(),
        ),
    });
    let targets = [plain_target(wgpu::TextureFormat::Rgba8Unorm), plain_target(wgpu::TextureFormat::R32Uint)];
    let pipeline = render_pipeline(device, &module, ("vs", "fs"), &[], &targets, None);
    let kappa = if scene.corrected { scene.sphere_kappa } else { 0.0 };
    let uniform: Vec<f32> = vec![
        scene.light.x,
        scene.light.y,
        scene.light.z,
        0.0,
        1.0 / scene.sphere_kappa,
        kappa,
        scene.tile_world,
        scene.height_scale,
        size as f32,
        size as f32,
        0.0,
        0.0,
    ];
    let bytes: Vec<u8> = uniform.iter().flat_map(|v| v.to_le_bytes()).collect();
    let ubuf = gpu.buffer(bytes.len() as u64, wgpu::BufferUsages::UNIFORM, Some(&bytes));
    let sampler = hikage_runtime::horizon::horizon_sampler(device);
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: ubuf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(horizon) },
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&sampler) },
            wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(heights) },
        ],
    });
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
    let target = |format| gpu.texture((size, size), format, usage);
    let color = target(wgpu::TextureFormat::Rgba8Unorm);
    let flags = target(wgpu::TextureFormat::R32Uint);
    let (cv, fv) = (color.create_view(&Default::default()), flags.create_view(&Default::default()));
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let attach = |view| clear_attachment(view, wgpu::Color::BLACK);
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("horizon sphere"),
            color_attachments: &[attach(&cv), attach(&fv)],
            ..Default::default()
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.draw(0..3, 0..1);
    }
    gpu.queue.submit([enc.finish()]);
    let rgba = gpu.read_texture(&color);
    let flag_bytes = gpu.read_texture(&flags);
    let flags = flag_bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    (rgba, flags)
}
