//! [`ReliefMaterial`]: relief mapping with depth-map shadows and ambient occlusion on any mesh
//! with tangents (its CPU reference is [`super::reference::relief_material_shade`]).

use glam::{Mat4, Vec2, Vec3};

use super::{RELIEF_WGSL, ReliefUniform, Tracer, VisibilityPath};
use crate::draw::DrawOptions;
use crate::error::RuntimeError;
use crate::gpu;
use crate::scene::SceneUniform;
use crate::upload::GpuBundle;
use hikage_bundle::relief::DirectionRule;

const MATERIAL_WGSL: &str = include_str!("../shaders/relief_material.wgsl");

/// One vertex of a mesh a [`ReliefMaterial`] draws: the layout of the vertex buffer given to
/// [`ReliefMaterial::draw`] (48 bytes, as glTF's `POSITION`, `NORMAL`, `TANGENT`, `TEXCOORD_0`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ReliefVertex {
    /// Mesh-space position.
    pub position: [f32; 3],
    /// Unit normal.
    pub normal: [f32; 3],
    /// `xyz`: unit tangent along +u; `w`: ±1, the bitangent (along +v) is
    /// `w · cross(normal, tangent)`.
    pub tangent: [f32; 4],
    /// Texture coordinates: one relief tile per unit.
    pub uv: [f32; 2],
}

/// What changes from frame to frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReliefFrame {
    /// World → clip (wgpu: depth 0..1).
    pub view_proj: Mat4,
    /// Mesh space → world (rotation, translation, uniform scale).
    pub model: Mat4,
    /// The camera's position in world space, for a perspective camera.
    pub eye: Vec3,
    /// For an orthographic camera: its unit view direction (world), used instead of `eye`.
    pub view_direction: Option<Vec3>,
    /// Unit direction toward a directional light, world space.
    pub light: Vec3,
    /// Linear RGB of the light.
    pub light_color: Vec3,
    /// Linear RGB of the ambient light, scaled by the ambient occlusion's open share.
    pub ambient: Vec3,
    /// Linear RGB albedo.
    pub albedo: Vec3,
    /// World size of one relief tile (one unit of uv) along the tangent and the bitangent.
    pub tile: Vec2,
    /// The tracer and its setting.
    pub tracer: Tracer,
    /// Which row of the direction table the depth-map estimates are read from.
    pub rule: DirectionRule,
    /// How shadows and ambient occlusion decide visibility.
    pub visibility: VisibilityPath,
    /// Depth-map shadows.
    pub shadows: bool,
    /// Ambient occlusion over every `ao_stride`-th sample direction; 0 turns it off.
    pub ao_stride: u32,
    /// Depth (share of the relief's thickness) a stored hit may lie above a point that still
    /// counts as lit.
    pub bias: f32,
}

impl Default for ReliefFrame {
    fn default() -> ReliefFrame {
        ReliefFrame {
            view_proj: Mat4::IDENTITY,
            model: Mat4::IDENTITY,
            eye: Vec3::ZERO,
            view_direction: None,
            light: Vec3::new(0.5, 0.5, 0.5).normalize(),
            light_color: Vec3::ONE,
            ambient: Vec3::splat(0.3),
            albedo: Vec3::new(0.85, 0.78, 0.68),
            tile: Vec2::ONE,
            tracer: Tracer::Combined { margin: 0.1, start_level: 3 },
            rule: DirectionRule::default(),
            visibility: VisibilityPath::default(),
            shadows: true,
            ao_stride: 16,
            bias: 0.02,
        }
    }
}

/// The `ReliefMaterialUniform` of the material WGSL, as it is in the uniform buffer (240 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ReliefMaterialUniform {
    /// The head every component shares: `model` mesh space → world; `light` the unit direction
    /// toward the light (world).
    pub scene: SceneUniform,
    /// `w = 1`: the camera's position; `w = 0`: an orthographic camera's view direction.
    pub eye: [f32; 4],
    /// World size of one tile along the tangent and the bitangent.
    pub tile: [f32; 2],
    /// Ambient occlusion stride (0: off).
    pub ao_stride: u32,
    /// 1: shadows.
    pub shadows: u32,
    /// Shadow and occlusion bias.
    pub bias: f32,
    /// Padding.
    pub _pad: [u32; 3],
}

impl ReliefMaterialUniform {
    /// The uniform of `frame`.
    pub fn new(frame: &ReliefFrame) -> ReliefMaterialUniform {
        let light = frame.light.normalize().extend(0.0);
        ReliefMaterialUniform {
            scene: SceneUniform::new(
                frame.view_proj,
                frame.model,
                light,
                frame.light_color,
                frame.ambient,
                frame.albedo,
            ),
            eye: match frame.view_direction {
                Some(d) => d.normalize().extend(0.0),
                None => frame.eye.extend(1.0),
            }
            .to_array(),
            tile: frame.tile.to_array(),
            ao_stride: frame.ao_stride,
            shadows: u32::from(frame.shadows),
            bias: frame.bias,
            _pad: [0; 3],
        }
    }
}

/// Relief mapping (seed 003) as a material for the game's own meshes: per pixel the view ray
/// is taken into the relief's texel space through the mesh's tangent frame and traced from the
/// depth map's estimate (or by another [`Tracer`]), then lit with depth-map shadows and ambient
/// occlusion from the same maps.
///
/// Built from a `Relief` asset (its max-mip pyramid comes with it). The mesh is the game's:
/// vertices laid out as [`ReliefVertex`], a `u32` index buffer.
///
/// ```no_run
/// # fn frame(device: &wgpu::Device, queue: &wgpu::Queue, pass: &mut wgpu::RenderPass<'_>, vertices: &wgpu::Buffer, indices: &wgpu::Buffer, count: u32, view_proj: hikage_runtime::glam::Mat4) -> Result<(), hikage_runtime::RuntimeError> {
/// use hikage_runtime::relief::{ReliefFrame, ReliefMaterial};
/// use hikage_runtime::{CpuBundle, DrawOptions, GpuBundle, glam::{Vec2, Vec3}, wgpu};
///
/// let cpu = CpuBundle::read_ids("bundle".as_ref(), &["relief_bricks.relief"])?;
/// let gpu = GpuBundle::upload(device, queue, &cpu)?;
/// let options = DrawOptions::new(wgpu::TextureFormat::Rgba8UnormSrgb);
/// let bricks = ReliefMaterial::new(device, queue, &gpu, "relief_bricks.relief", &options)?;
/// let eye = Vec3::new(0.0, 2.0, 5.0);
/// bricks.update(queue, &ReliefFrame { view_proj, eye, tile: Vec2::splat(1.0), ..ReliefFrame::default() });
/// bricks.draw(pass, vertices.slice(..), indices.slice(..), count);
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct ReliefMaterial {
    program: gpu::Program,
    tracing: wgpu::Buffer,
    uniform: wgpu::Buffer,
    statics: ReliefUniform,
    assets: Vec<String>,
}

impl ReliefMaterial {
    /// Builds the material of `relief` (a `Relief` asset of `gpu`, with its max-mip pyramid).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        gpu: &GpuBundle,
        relief: &str,
        options: &DrawOptions,
    ) -> Result<ReliefMaterial, RuntimeError> {
        let depth = gpu.texture(relief)?;
        let settings = depth.asset.settings.relief().ok_or_else(|| RuntimeError::Asset {
            asset: relief.to_string(),
            message: format!("expected a relief asset, found a {}", depth.asset.kind.name()),
        })?;
        let heights = gpu.texture(&settings.max_mip)?;
        let statics = ReliefUniform::for_maps(settings, &depth.desc, &heights.desc);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hikage relief"),
            entries: &[
                gpu::texture_entry(0, wgpu::TextureViewDimension::D2, false),
                gpu::texture_entry(1, wgpu::TextureViewDimension::D2Array, false),
                gpu::uniform_entry::<ReliefUniform>(2),
                gpu::uniform_entry::<ReliefMaterialUniform>(3),
            ],
        });
        let tracing = gpu::uniform_buffer(device, queue, "hikage relief tracer", &statics);
        let uniform = gpu::uniform_buffer(
            device,
            queue,
            "hikage relief material",
            &ReliefMaterialUniform::new(&ReliefFrame::default()),
        );
        let bind_group = gpu::checked(device, relief, || {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("hikage relief"),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&heights.view) },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&depth.view) },
                    wgpu::BindGroupEntry { binding: 2, resource: tracing.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 3, resource: uniform.as_entire_binding() },
                ],
            })
        })?;
        let program = gpu::Program::new(
            device,
            relief,
            format!("{RELIEF_WGSL}\n{MATERIAL_WGSL}"),
            (layout, bind_group),
            gpu::Stages { vs: "relief_vs", fs: "relief_fs", fs_visibility: "relief_fs_visibility" },
            &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<ReliefVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4, 3 => Float32x2],
            })],
            options,
        )?;
        let assets = vec![relief.to_string(), settings.max_mip.clone()];
        Ok(ReliefMaterial { program, tracing, uniform, statics, assets })
    }

    /// The ids of the assets the material was built from (depth maps, max-mip pyramid): after
    /// a reload whose [`crate::Changes::touches`] them, build it again.
    pub fn asset_ids(&self) -> &[String] {
        &self.assets
    }

    /// The material's WGSL with its bindings at the chosen group, for a game's own shaders:
    /// `relief_material_shade(...)`, the tracers, `relief_lit`, `relief_ambient_occlusion`.
    pub fn wgsl(&self) -> &str {
        &self.program.wgsl
    }

    /// The layout of the material's bind group.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.program.layout
    }

    /// The material's bind group (max-mip heights, depth maps, tracer and material uniforms).
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.program.bind_group
    }

    /// Writes both uniforms for `frame`; the next submitted draw uses them.
    pub fn update(&self, queue: &wgpu::Queue, frame: &ReliefFrame) {
        let tracing = self.statics.with_tracer(frame.tracer).with_reads(frame.rule, frame.visibility);
        queue.write_buffer(&self.tracing, 0, bytemuck::bytes_of(&tracing));
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&ReliefMaterialUniform::new(frame)));
    }

    /// Draws the triangles of `indices` (u32) over `vertices` ([`ReliefVertex`]) into `pass`,
    /// whose attachments must match the options. The visibility target receives `(1 lit /
    /// 0 shadowed, 1, ambient occlusion's open share, hit depth)`.
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        vertices: wgpu::BufferSlice<'_>,
        indices: wgpu::BufferSlice<'_>,
        count: u32,
    ) {
        self.program.bind(pass);
        pass.set_vertex_buffer(0, vertices);
        pass.set_index_buffer(indices, wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..count, 0, 0..1);
    }
}
