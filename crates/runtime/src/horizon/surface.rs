//! [`SurfaceShadows`]: a bump map on a curved mesh with horizon shadows corrected for the
//! mesh's curvature (seed 000 §3, the whole method), and [`SurfaceReference`], its CPU
//! reference.

use glam::{Mat4, Vec3};
use hikage_bundle::{ComponentType, MeshDesc};

use super::terrain::{heightfield_settings, horizon_settings};
use super::{HORIZON_WGSL, HorizonEncoding, horizon_filterable, horizon_sampler};
use crate::draw::DrawOptions;
use crate::error::RuntimeError;
use crate::gpu;
use crate::scene::SceneUniform;
use crate::upload::{GpuBundle, GpuMesh};

const SURFACE_WGSL: &str = include_str!("../shaders/surface.wgsl");

/// The Curvature asset's streams the surface draws with, in shader location order: all of them.
const STREAMS: [hikage_bundle::Stream; 8] = hikage_bundle::CURVATURE_STREAMS;

/// What changes from frame to frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceFrame {
    /// World → clip (wgpu: depth 0..1).
    pub view_proj: Mat4,
    /// Mesh space → world.
    pub model: Mat4,
    /// Unit direction toward a directional light, world space.
    pub light: Vec3,
    /// Linear RGB of the light.
    pub light_color: Vec3,
    /// Linear RGB of the ambient light.
    pub ambient: Vec3,
    /// Linear RGB albedo.
    pub albedo: Vec3,
    /// Apply the curvature correction; `false` gives the flat horizon test (Forsyth), for
    /// comparison.
    pub corrected: bool,
}

impl Default for SurfaceFrame {
    fn default() -> SurfaceFrame {
        SurfaceFrame {
            view_proj: Mat4::IDENTITY,
            model: Mat4::IDENTITY,
            light: Vec3::new(0.5, 0.5, 0.5).normalize(),
            light_color: Vec3::ONE,
            ambient: Vec3::splat(0.15),
            albedo: Vec3::new(0.85, 0.72, 0.55),
            corrected: true,
        }
    }
}

/// The `SurfaceUniform` of the surface WGSL, as it is in the uniform buffer (240 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SurfaceUniform {
    /// The head every component shares: `model` mesh space → world; `light` the unit direction
    /// toward the light in mesh space, `w` 1 for the curvature-corrected test, 0 flat.
    pub scene: SceneUniform,
    /// One tile of the bump map in its world units, `(W·sx, H·sy)`.
    pub tile: [f32; 2],
    /// The bump map's texel size.
    pub texel_size: [f32; 2],
    /// Bump height = `height_offset + height_scale × sample`.
    pub height_scale: f32,
    /// See `height_scale`.
    pub height_offset: f32,
    /// Heightfield width and height.
    pub size: [u32; 2],
    /// How the horizon texture is stored.
    pub encoding: HorizonEncoding,
}

/// A bump map on a curved mesh with seed 000's curvature-corrected horizon shadows.
///
/// Built from a `Curvature` asset (the mesh with κ1, κ2, the principal directions and the
/// texture frame `P_u`, `P_v` per vertex) and a `Horizon` asset (the bump map's horizons, and its
/// heightfield). Per pixel the light is taken into the seed's frame `(P_u, P_v, N/|N|^½)`,
/// eq. (1) gives the curvature along it from both principal directions, and eq. (2)–(3) lower
/// the horizon before the lit test. The mesh's UVs tile the bump map (`Repeat`).
///
/// ```no_run
/// # fn frame(device: &wgpu::Device, queue: &wgpu::Queue, pass: &mut wgpu::RenderPass<'_>, view_proj: hikage_runtime::glam::Mat4) -> Result<(), hikage_runtime::RuntimeError> {
/// use hikage_runtime::horizon::{SurfaceFrame, SurfaceShadows};
/// use hikage_runtime::{CpuBundle, DrawOptions, GpuBundle, glam::Vec3, wgpu};
///
/// let cpu = CpuBundle::read_ids("bundle".as_ref(), &["sphere", "cylinders.horizon"])?;
/// let gpu = GpuBundle::upload(device, queue, &cpu)?;
/// let options = DrawOptions { cull_mode: Some(wgpu::Face::Back), ..DrawOptions::new(wgpu::TextureFormat::Rgba8UnormSrgb) };
/// let sphere = SurfaceShadows::new(device, queue, &gpu, "sphere", "cylinders.horizon", &options)?;
/// sphere.update(queue, &SurfaceFrame { view_proj, light: Vec3::new(-0.8, 0.25, 0.45).normalize(), ..SurfaceFrame::default() });
/// sphere.draw(pass);
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct SurfaceShadows {
    program: gpu::Program,
    uniform: wgpu::Buffer,
    statics: SurfaceUniform,
    buffer: wgpu::Buffer,
    desc: MeshDesc,
    assets: Vec<String>,
}

impl SurfaceShadows {
    /// Builds the surface of mesh `curvature` (a `Curvature` asset) carrying the bump map of
    /// `horizon` (a `Horizon` asset and its heightfield).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        gpu: &GpuBundle,
        curvature: &str,
        horizon: &str,
        options: &DrawOptions,
    ) -> Result<SurfaceShadows, RuntimeError> {
        let mesh = gpu.mesh(curvature)?;
        check_streams(mesh)?;
        let map = gpu.texture(horizon)?;
        let settings = horizon_settings(map)?;
        let heights = gpu.texture(&settings.heightfield)?;
        let hf = heightfield_settings(heights)?;
        let (sx, sy) = settings.texel_size;
        let statics = SurfaceUniform {
            tile: [heights.desc.width as f32 * sx, heights.desc.height as f32 * sy],
            texel_size: [sx, sy],
            height_scale: hf.height_scale,
            height_offset: hf.height_offset,
            size: [heights.desc.width, heights.desc.height],
            encoding: HorizonEncoding::new(map.desc.format, settings),
            ..bytemuck::Zeroable::zeroed()
        };
        let filterable = horizon_filterable(device, map.desc.format);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hikage surface"),
            entries: &[
                gpu::uniform_entry::<SurfaceUniform>(0),
                gpu::texture_entry(1, wgpu::TextureViewDimension::D3, filterable),
                gpu::sampler_entry(2, filterable),
                gpu::texture_entry(3, wgpu::TextureViewDimension::D2, false),
            ],
        });
        let uniform = gpu::uniform_buffer(device, queue, "hikage surface", &statics);
        let sampler = horizon_sampler(device, hikage_bundle::EdgeMode::Wrap, filterable);
        let bind_group = gpu::checked(device, horizon, || {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("hikage surface"),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&map.view) },
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&sampler) },
                    wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&heights.view) },
                ],
            })
        })?;
        let attributes: Vec<[wgpu::VertexAttribute; 1]> = STREAMS
            .iter()
            .enumerate()
            .map(|(location, stream)| {
                let format = float_format(stream.components);
                [wgpu::VertexAttribute { format, offset: 0, shader_location: location as u32 }]
            })
            .collect();
        let buffers: Vec<Option<wgpu::VertexBufferLayout>> = STREAMS
            .iter()
            .zip(&attributes)
            .map(|(stream, a)| {
                Some(wgpu::VertexBufferLayout {
                    array_stride: 4 * stream.components as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: a,
                })
            })
            .collect();
        let program = gpu::Program::new(
            device,
            curvature,
            format!("{HORIZON_WGSL}\n{SURFACE_WGSL}"),
            (layout, bind_group),
            gpu::Stages { vs: "surface_vs", fs: "surface_fs", fs_visibility: "surface_fs_visibility" },
            &buffers,
            options,
        )?;
        let assets = vec![curvature.to_string(), horizon.to_string(), settings.heightfield.clone()];
        Ok(SurfaceShadows { program, uniform, statics, buffer: mesh.buffer.clone(), desc: mesh.desc.clone(), assets })
    }

    /// The ids of the assets the surface was built from (curvature mesh, horizon, heightfield):
    /// after a reload whose [`crate::Changes::touches`] them, build it again.
    pub fn asset_ids(&self) -> &[String] {
        &self.assets
    }

    /// The surface's WGSL with its bindings at the chosen group, for a game's own shaders:
    /// `surface_lit(...)`, `surface_bumped_normal(...)` and the horizon functions.
    pub fn wgsl(&self) -> &str {
        &self.program.wgsl
    }

    /// The layout of the surface's bind group.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.program.layout
    }

    /// The surface's bind group (uniform, horizon map and sampler, heights).
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.program.bind_group
    }

    /// The uniform for `frame`: the light taken into mesh space, with the bump map's constants.
    pub fn uniform(&self, frame: &SurfaceFrame) -> SurfaceUniform {
        let light = frame.model.inverse().transform_vector3(frame.light).normalize_or(Vec3::Z);
        let light = light.extend(if frame.corrected { 1.0 } else { 0.0 });
        let scene =
            SceneUniform::new(frame.view_proj, frame.model, light, frame.light_color, frame.ambient, frame.albedo);
        SurfaceUniform { scene, ..self.statics }
    }

    /// Writes the uniform for `frame`; the next submitted draw uses it.
    pub fn update(&self, queue: &wgpu::Queue, frame: &SurfaceFrame) {
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&self.uniform(frame)));
    }

    /// Draws the mesh into `pass`, whose attachments must match the options it was built with.
    /// The visibility target receives `(1 lit / 0 shadowed, 1, 0, 1)`.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        self.program.bind(pass);
        for (slot, stream) in STREAMS.iter().enumerate() {
            let a = self.desc.attribute(stream.name).expect("checked when the surface was built");
            pass.set_vertex_buffer(
                slot as u32,
                self.buffer.slice(a.offset..a.offset + a.stride as u64 * a.count as u64),
            );
        }
        let ix = self.desc.indices.as_ref().expect("checked when the surface was built");
        let format = match ix.component {
            ComponentType::U16 => wgpu::IndexFormat::Uint16,
            _ => wgpu::IndexFormat::Uint32,
        };
        let bytes = ix.component.bytes() as u64;
        pass.set_index_buffer(self.buffer.slice(ix.offset..ix.offset + bytes * ix.count as u64), format);
        pass.draw_indexed(0..ix.count, 0, 0..1);
    }
}

fn float_format(components: u8) -> wgpu::VertexFormat {
    match components {
        1 => wgpu::VertexFormat::Float32,
        2 => wgpu::VertexFormat::Float32x2,
        3 => wgpu::VertexFormat::Float32x3,
        _ => wgpu::VertexFormat::Float32x4,
    }
}

/// Every stream the surface reads is present, F32, tightly packed, with the expected
/// components, and the mesh has U16 or U32 indices.
fn check_streams(mesh: &GpuMesh) -> Result<(), RuntimeError> {
    let bad = |message: String| RuntimeError::Asset { asset: mesh.asset.id.clone(), message };
    for hikage_bundle::Stream { name, components: c, .. } in STREAMS {
        let a = mesh.desc.attribute(name).ok_or_else(|| {
            bad(format!(
                "no `{name}` stream: a surface needs a curvature mesh of bundle format 1.3 or later (re-bake it)"
            ))
        })?;
        if a.component != ComponentType::F32 || a.components != c || a.stride != 4 * c as u32 {
            return Err(bad(format!("stream `{name}` must be {c} tightly packed F32 values")));
        }
    }
    match &mesh.desc.indices {
        Some(ix) if matches!(ix.component, ComponentType::U16 | ComponentType::U32) => Ok(()),
        _ => Err(bad("a surface needs U16 or U32 triangle indices".into())),
    }
}
