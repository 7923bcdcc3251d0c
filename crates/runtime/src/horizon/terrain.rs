//! [`TerrainShadows`]: a heightfield drawn as a grid mesh, lit by a sun whose disc sinks
//! behind the baked horizons, with the baked ambient occlusion as sky visibility.

use glam::{Mat4, Vec2, Vec3};
use hikage_bundle::{AssetKind, HeightfieldSettings, HorizonSettings};

use super::sun_field::{FieldTerrain, FieldTile, SunFieldSource};
use super::{HORIZON_WGSL, HorizonEncoding, horizon_filterable, horizon_sampler};
use crate::draw::DrawOptions;
use crate::error::RuntimeError;
use crate::gpu;
use crate::scene::SceneUniform;
use crate::upload::{GpuBundle, GpuTexture};

/// WGSL of the terrain: its uniform, bindings (at `@group(0)`, moved to the chosen group by
/// [`TerrainShadows::wgsl`]), `terrain_sun_visibility`, `terrain_sky_visibility` and the
/// vertex and fragment entry points.
pub(super) const TERRAIN_WGSL: &str = include_str!("../shaders/terrain.wgsl");

/// A sun: where it is, how bright, and how large it looks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sun {
    /// Unit direction toward the sun, world space.
    pub direction: Vec3,
    /// Linear RGB irradiance.
    pub color: Vec3,
    /// Angular radius in radians: the shadow edge softens over twice this (the real sun's is
    /// 0.00465, 0.27°); 0 gives hard shadows.
    pub angular_radius: f32,
}

impl Default for Sun {
    fn default() -> Sun {
        Sun { direction: Vec3::new(0.5, 0.5, 0.5).normalize(), color: Vec3::ONE, angular_radius: 0.00465 }
    }
}

/// What changes from frame to frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TerrainFrame {
    /// World → clip (wgpu: depth 0..1).
    pub view_proj: Mat4,
    /// Terrain frame → world. The terrain frame has `x` along +u (columns), `y` up, `z` along +v
    /// (rows), in the heightfield's world units, texel `(i, j)` centred at `((i + ½)·sx, h,
    /// (j + ½)·sy)`. A tile of a map baked in tiles sits in the map's frame translated by
    /// [`hikage_bundle::TilePlacement::offset`].
    pub model: Mat4,
    /// The sun.
    pub sun: Sun,
    /// Linear RGB of the sky's ambient light, scaled by sky visibility (`1 − ao`).
    pub sky_color: Vec3,
    /// Linear RGB albedo of the ground.
    pub albedo: Vec3,
}

impl Default for TerrainFrame {
    fn default() -> TerrainFrame {
        TerrainFrame {
            view_proj: Mat4::IDENTITY,
            model: Mat4::IDENTITY,
            sun: Sun::default(),
            sky_color: Vec3::splat(0.25),
            albedo: Vec3::splat(0.6),
        }
    }
}

/// The `TerrainUniform` of the terrain WGSL, as it is in the uniform buffer (256 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TerrainUniform {
    /// The head every component shares: `model` terrain frame → world; `light` the unit
    /// direction toward the sun in the terrain frame, `w` its angular radius; `light_color` the
    /// sun's; `ambient` the sky's.
    pub scene: SceneUniform,
    /// World units per texel along `u` and `v`.
    pub texel_size: [f32; 2],
    /// World height = `height_offset + height_scale × sample`.
    pub height_scale: f32,
    /// See `height_scale`.
    pub height_offset: f32,
    /// Heightfield width and height.
    pub size: [u32; 2],
    /// 1 when an ambient-occlusion map is bound.
    pub has_ao: u32,
    /// Depth in world units of the skirt hung under the edges (0: none, as for a whole map;
    /// streamed tiles have one to hide cracks between levels of detail).
    pub skirt: f32,
    /// How the horizon texture is stored.
    pub encoding: HorizonEncoding,
    /// Texels of heights around the terrain's own in its heights texture (0 for a whole map; 1
    /// for a streamed tile, whose edge normals then see the neighbouring tile's heights).
    pub apron: u32,
    /// Padding.
    pub _pad: [u32; 3],
}

/// A heightfield with horizon shadows from a sun and ambient occlusion from the sky
/// (seed 000's maps on terrain, where the curvature is the geometry's own: κ = 0).
///
/// Created from a `horizon` asset (its heightfield comes with it) and optionally the `ao` asset
/// baked beside it. The sun's azimuth is taken in texel space from its direction in the terrain
/// frame, so anisotropic texels (80 m × 60 m) shadow along the right azimuth; a clamped bake is
/// sampled with `ClampToEdge`, a wrapped one with `Repeat`.
///
/// ```no_run
/// # fn frame(device: &wgpu::Device, queue: &wgpu::Queue, target: &wgpu::TextureView, depth: &wgpu::TextureView, view_proj: hikage_runtime::glam::Mat4) -> Result<(), hikage_runtime::RuntimeError> {
/// use hikage_runtime::horizon::{Sun, TerrainFrame, TerrainShadows};
/// use hikage_runtime::{CpuBundle, DrawOptions, GpuBundle, glam::Vec3, wgpu};
///
/// let cpu = CpuBundle::read_prefix("bundle".as_ref(), "terrain.")?;
/// let gpu = GpuBundle::upload(device, queue, &cpu)?;
/// let options = DrawOptions {
///     depth_format: Some(wgpu::TextureFormat::Depth32Float),
///     ..DrawOptions::new(wgpu::TextureFormat::Rgba8UnormSrgb)
/// };
/// let terrain = TerrainShadows::new(device, queue, &gpu, "terrain.horizon", Some("terrain.ao"), &options)?;
///
/// // Every frame:
/// let sun = Sun { direction: Vec3::new(-0.6, 0.3, 0.2).normalize(), ..Sun::default() };
/// terrain.update(queue, &TerrainFrame { view_proj, sun, ..TerrainFrame::default() });
/// let mut encoder = device.create_command_encoder(&Default::default());
/// {
///     let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
///         color_attachments: &[Some(wgpu::RenderPassColorAttachment {
///             view: target,
///             depth_slice: None,
///             resolve_target: None,
///             ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
///         })],
///         depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
///             view: depth,
///             depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
///             stencil_ops: None,
///         }),
///         ..Default::default()
///     });
///     terrain.draw(&mut pass);
/// }
/// queue.submit([encoder.finish()]);
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct TerrainShadows {
    program: gpu::Program,
    uniform: wgpu::Buffer,
    statics: TerrainUniform,
    vertices: u32,
    extent: TerrainExtent,
    assets: Vec<String>,
    reach: f32,
    directions: u32,
}

/// Where a terrain lies in its own frame: what a game needs to place a camera over it. The
/// terrain frame has `x` along +u (columns), `y` up, `z` along +v (rows), in the heightfield's
/// world units, with texel `(i, j)`'s centre at `((i + ½)·sx, h, (j + ½)·sy)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TerrainExtent {
    /// Heightfield samples along `u` and `v`.
    pub size: (u32, u32),
    /// World units per texel along `u` and `v`.
    pub texel_size: (f32, f32),
    /// The lowest and highest world height.
    pub height_range: (f32, f32),
    /// The lower corner of the terrain's box in the terrain frame (the first texel's centre,
    /// the lowest height).
    pub min: Vec3,
    /// The upper corner (the last texel's centre, the highest height).
    pub max: Vec3,
}

impl TerrainExtent {
    /// The extent of a map of `size` texels of `texel_size` world units whose heights span
    /// `height_range`.
    pub fn new(size: (u32, u32), texel_size: (f32, f32), height_range: (f32, f32)) -> TerrainExtent {
        let (w, h) = size;
        let (sx, sy) = texel_size;
        let (low, high) = height_range;
        TerrainExtent {
            size,
            texel_size,
            height_range,
            min: Vec3::new(0.5 * sx, low, 0.5 * sy),
            max: Vec3::new((w as f32 - 0.5) * sx, high, (h as f32 - 0.5) * sy),
        }
    }

    /// The centre of the terrain's box, terrain frame.
    pub fn centre(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// The radius of the sphere around the box.
    pub fn radius(&self) -> f32 {
        0.5 * (self.max - self.min).length()
    }
}

impl TerrainShadows {
    /// Builds the terrain of `horizon` (a `Horizon` asset of `gpu`, with its heightfield) and
    /// `ao` (an `AmbientOcclusion` asset, or `None` for an open sky).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        gpu: &GpuBundle,
        horizon: &str,
        ao: Option<&str>,
        options: &DrawOptions,
    ) -> Result<TerrainShadows, RuntimeError> {
        let filterable = horizon_filterable(device, gpu.texture(horizon)?.desc.format);
        let layout = terrain_layout(device, filterable);
        let binding = TerrainBinding::new(device, queue, gpu, (horizon, ao), (0.0, 0), (&layout, filterable))?;
        let program = terrain_program(device, horizon, (layout, binding.bind_group.clone()), options)?;
        let TerrainBinding { uniform, statics, vertices, extent, assets, reach, directions, .. } = binding;
        Ok(TerrainShadows { program, uniform, statics, vertices, extent, assets, reach, directions })
    }

    /// Where the terrain lies in its frame: size, texel size, height range and box, for placing
    /// a camera ([`TerrainFrame::model`] places the frame in the world).
    pub fn extent(&self) -> &TerrainExtent {
        &self.extent
    }

    /// The ids of the assets the terrain was built from (horizon, heightfield, occlusion): after
    /// a reload whose [`crate::Changes::touches`] them, build it again.
    pub fn asset_ids(&self) -> &[String] {
        &self.assets
    }

    /// The terrain's WGSL with its bindings at the chosen group, for a game's own shaders:
    /// `terrain_sun_visibility(uv)`, `terrain_sky_visibility(uv)`, `terrain_position(texel)`,
    /// `terrain_normal(texel)` and the horizon functions.
    pub fn wgsl(&self) -> &str {
        &self.program.wgsl
    }

    /// The layout of the terrain's bind group.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.program.layout
    }

    /// The terrain's bind group (uniform, horizon map and sampler, heights, occlusion).
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.program.bind_group
    }

    /// The uniform for `frame`: the sun taken into the terrain frame, with the terrain's own
    /// constants.
    pub fn uniform(&self, frame: &TerrainFrame) -> TerrainUniform {
        uniform_for(&self.statics, frame)
    }

    /// Writes the uniform for `frame`; the next submitted draw uses it.
    pub fn update(&self, queue: &wgpu::Queue, frame: &TerrainFrame) {
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&self.uniform(frame)));
    }

    /// Draws the terrain into `pass`, whose attachments must match the options it was built
    /// with. The visibility target receives `(sun visibility, 1, sky visibility, 1)`.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        self.program.bind(pass);
        pass.draw(0..self.vertices, 0..1);
    }
}

impl SunFieldSource for TerrainShadows {
    fn field_terrain(&self) -> FieldTerrain<'_> {
        let texel = Vec2::from(self.statics.texel_size);
        let size = (self.statics.size[0], self.statics.size[1]);
        FieldTerrain {
            layout: &self.program.layout,
            map_size: texel * Vec2::new(size.0 as f32, size.1 as f32),
            texel,
            directions: self.directions,
            reach: self.reach,
            tiles: vec![FieldTile {
                group: &self.program.bind_group,
                key: (0, 0, 0),
                offset: Vec2::ZERO,
                texel,
                size,
                edges: 15,
            }],
        }
    }
}

/// `statics` with the per-frame head for `frame`: the sun taken into the terrain frame.
fn uniform_for(statics: &TerrainUniform, frame: &TerrainFrame) -> TerrainUniform {
    let to_terrain = frame.model.inverse();
    let sun = to_terrain.transform_vector3(frame.sun.direction).normalize_or(Vec3::Y);
    let light = sun.extend(frame.sun.angular_radius);
    let scene = SceneUniform::new(frame.view_proj, frame.model, light, frame.sun.color, frame.sky_color, frame.albedo);
    TerrainUniform { scene, ..*statics }
}

/// The bind group layout of a terrain: uniform, horizon map (filterable or not) and sampler,
/// heights, occlusion.
pub(super) fn terrain_layout(device: &wgpu::Device, filterable: bool) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("hikage terrain"),
        entries: &[
            gpu::uniform_entry::<TerrainUniform>(0),
            gpu::texture_entry(1, wgpu::TextureViewDimension::D3, filterable),
            gpu::sampler_entry(2, filterable),
            gpu::texture_entry(3, wgpu::TextureViewDimension::D2, false),
            gpu::texture_entry(4, wgpu::TextureViewDimension::D2, false),
        ],
    })
}

/// The terrain pipeline for `options`' targets around `layout`, bound to `bind_group`.
pub(super) fn terrain_program(
    device: &wgpu::Device,
    label: &str,
    (layout, bind_group): (wgpu::BindGroupLayout, wgpu::BindGroup),
    options: &DrawOptions,
) -> Result<gpu::Program, RuntimeError> {
    gpu::Program::new(
        device,
        label,
        format!("{HORIZON_WGSL}\n{TERRAIN_WGSL}"),
        (layout, bind_group),
        gpu::Stages { vs: "terrain_vs", fs: "terrain_fs", fs_visibility: "terrain_fs_visibility" },
        &[],
        options,
    )
}

/// One terrain's own resources: its uniform buffer and constants, its bind group, its vertex
/// count and extent. The one-mesh terrain holds one; a streamed terrain one per resident tile.
#[derive(Debug)]
pub(super) struct TerrainBinding {
    pub uniform: wgpu::Buffer,
    pub statics: TerrainUniform,
    pub bind_group: wgpu::BindGroup,
    pub vertices: u32,
    pub extent: TerrainExtent,
    pub assets: Vec<String>,
    /// The bake's farthest horizon distance (the map's diagonal when unbounded) and azimuths.
    pub reach: f32,
    pub directions: u32,
}

impl TerrainBinding {
    /// The bindings of `horizon` (with its heightfield, holding `apron` more texels on every
    /// side) and `ao` in `gpu`, with a skirt of `skirt` world units, for a `layout` whose
    /// horizon map is `filterable`.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        gpu: &GpuBundle,
        (horizon, ao): (&str, Option<&str>),
        (skirt, apron): (f32, u32),
        (layout, filterable): (&wgpu::BindGroupLayout, bool),
    ) -> Result<TerrainBinding, RuntimeError> {
        let map = gpu.texture(horizon)?;
        let settings = horizon_settings(map)?;
        let heights = gpu.texture(&settings.heightfield)?;
        let hf = heightfield_settings(heights)?;
        let (w, h) = (heights.desc.width.saturating_sub(2 * apron), heights.desc.height.saturating_sub(2 * apron));
        if w < 2 || h < 2 {
            return Err(RuntimeError::Asset {
                asset: settings.heightfield.clone(),
                message: "a terrain needs at least 2×2 texels".into(),
            });
        }
        let ao = ao.map(|id| ambient_occlusion(gpu, id, (w, h))).transpose()?;
        let statics = TerrainUniform {
            texel_size: [settings.texel_size.0, settings.texel_size.1],
            height_scale: hf.height_scale,
            height_offset: hf.height_offset,
            size: [w, h],
            has_ao: u32::from(ao.is_some()),
            skirt,
            encoding: HorizonEncoding::new(map.desc.format, settings),
            apron,
            ..bytemuck::Zeroable::zeroed()
        };
        let uniform = gpu::uniform_buffer(device, queue, "hikage terrain", &statics);
        let sampler = horizon_sampler(device, settings.edge, filterable);
        let no_ao = gpu::constant_texture(device, queue, 0.0);
        let bind_group = gpu::checked(device, horizon, || {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("hikage terrain"),
                layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&map.view) },
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&sampler) },
                    wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&heights.view) },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: wgpu::BindingResource::TextureView(ao.map_or(&no_ao, |t| &t.view)),
                    },
                ],
            })
        })?;
        let skirts = if skirt > 0.0 { 12 * 2 * ((w - 1) + (h - 1)) } else { 0 };
        let vertices = 6 * (w - 1) * (h - 1) + skirts;
        let (lo, hi) = heights.range.unwrap_or((0.0, 0.0));
        let world = |v: f32| hf.world_height(v);
        let (low, high) = (world(lo).min(world(hi)), world(lo).max(world(hi)));
        let extent = TerrainExtent::new((w, h), settings.texel_size, (low, high));
        let mut assets = vec![horizon.to_string(), settings.heightfield.clone()];
        assets.extend(ao.map(|a| a.asset.id.clone()));
        let diagonal = (w as f32 * settings.texel_size.0).hypot(h as f32 * settings.texel_size.1);
        let reach = settings.max_distance.unwrap_or(diagonal);
        let directions = settings.directions;
        Ok(TerrainBinding { uniform, statics, bind_group, vertices, extent, assets, reach, directions })
    }

    /// The uniform for `frame`: the sun taken into the terrain frame, with the constants.
    pub fn uniform(&self, frame: &TerrainFrame) -> TerrainUniform {
        uniform_for(&self.statics, frame)
    }
}

/// The horizon settings of `map`, or an error saying it is not a horizon asset.
pub(super) fn horizon_settings(map: &GpuTexture) -> Result<&HorizonSettings, RuntimeError> {
    map.asset.settings.horizon().ok_or_else(|| RuntimeError::Asset {
        asset: map.asset.id.clone(),
        message: format!("expected a horizon asset, found a {}", map.asset.kind.name()),
    })
}

/// The `AmbientOcclusion` asset `id` of `gpu` for a terrain of `heights`, or an error naming
/// `id`: another kind (heights drawn as occlusion) or another size.
fn ambient_occlusion<'a>(gpu: &'a GpuBundle, id: &str, (w, h): (u32, u32)) -> Result<&'a GpuTexture, RuntimeError> {
    let ao = gpu.texture(id)?;
    let bad = |message: String| RuntimeError::Asset { asset: id.to_string(), message };
    if ao.asset.kind != AssetKind::AmbientOcclusion {
        return Err(bad(format!("expected an ambient_occlusion asset, found a {}", ao.asset.kind.name())));
    }
    if (ao.desc.width, ao.desc.height) != (w, h) {
        return Err(bad(format!(
            "its {}×{} texels do not match the {w}×{h} heightfield",
            ao.desc.width, ao.desc.height
        )));
    }
    Ok(ao)
}

/// The heightfield settings of `heights`, or an error saying it is not a heightfield.
pub(super) fn heightfield_settings(heights: &GpuTexture) -> Result<&HeightfieldSettings, RuntimeError> {
    heights.asset.settings.heightfield().ok_or_else(|| RuntimeError::Asset {
        asset: heights.asset.id.clone(),
        message: format!("expected a heightfield asset, found a {}", heights.asset.kind.name()),
    })
}
