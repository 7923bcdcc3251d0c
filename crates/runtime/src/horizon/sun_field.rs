//! [`SunField`]: the terrain's far shadows on whatever stands on it — houses, trees, characters,
//! water — for any shader of a game, from the baked horizons, with no re-bake when the sun moves.

use glam::{Mat4, Vec2, Vec3};

use super::HORIZON_WGSL;
use super::terrain::{TERRAIN_WGSL, TerrainFrame};
use super::tile_plan::TileKey;
use crate::error::RuntimeError;
use crate::gpu;
use crate::scene::SCENE_WGSL;

/// What the field's receivers and its build passes share: the uniform and the level lookups.
pub(crate) const COMMON_WGSL: &str = include_str!("../shaders/sun_field_common.wgsl");
/// The first build pass: ground and horizon points from the terrain's pieces.
pub(crate) const FILL_WGSL: &str = include_str!("../shaders/sun_field_fill.wgsl");
/// The second build pass: the walk over the first's texels.
pub(crate) const WALK_WGSL: &str = include_str!("../shaders/sun_field_walk.wgsl");

/// The receivers' WGSL with its bindings at `@group(0)` (binding 0 the uniform, 1 the
/// thresholds): `sun_field_visibility(world: vec3<f32>) -> f32`. For an engine whose material
/// system places bindings itself; a wgpu game takes [`SunField::wgsl`], at the group it chose.
pub const SUN_FIELD_WGSL: &str =
    concat!(include_str!("../shaders/sun_field_common.wgsl"), "\n", include_str!("../shaders/sun_field.wgsl"));

/// Bytes of the receivers' uniform (binding 0 of [`SunField::layout`]), for an engine that
/// declares the binding itself.
pub const SUN_FIELD_UNIFORM_BYTES: u64 = std::mem::size_of::<SunFieldUniform>() as u64;

/// Levels a field holds at most (the uniform's array).
pub const MAX_SUN_FIELD_LEVELS: u32 = 8;

/// Bytes a field texel holds on the device: a horizon point in two directions (16), the ground
/// (4) and the two thresholds receivers read (8).
const TEXEL_BYTES: u64 = 28;

/// Dispatches a new field has room for; it grows as a stream's tiles need.
const INITIAL_PASSES: u64 = 64;

/// Alignment of a dynamic uniform offset on every backend.
const PASS_STRIDE: u64 = 256;

/// How a [`SunField`] covers the terrain and when it rebuilds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunFieldOptions {
    /// Texels a side of each level. Default 512.
    pub side: u32,
    /// Levels, each twice as wide as the one before, all centred on the camera (at most
    /// [`MAX_SUN_FIELD_LEVELS`]). Default 4. The finest level's texel is the terrain's, or
    /// coarser when the coarsest level would not otherwise cover the whole map from anywhere
    /// on it.
    pub levels: u32,
    /// How far the sun may move (radians) before the field is rebuilt. Default 0.05°, a fifth of
    /// the real sun's radius: shadow edges move less than their own softness between builds.
    pub sun_step: f32,
    /// The bind group index of the field in the game's shaders ([`SunField::wgsl`]). Default 0.
    pub group: u32,
}

impl Default for SunFieldOptions {
    fn default() -> SunFieldOptions {
        SunFieldOptions { side: 512, levels: 4, sun_step: 0.05f32.to_radians(), group: 0 }
    }
}

/// What one [`SunField::update`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SunFieldStats {
    /// Levels rebuilt (0: the field still held for this sun and camera).
    pub levels_built: u32,
    /// Compute dispatches recorded.
    pub dispatches: u32,
}

/// A terrain a [`SunField`] reads: [`super::TerrainShadows`] and [`super::TerrainStream`].
pub trait SunFieldSource {
    /// The terrain's pieces now covering its map, as the field reads them.
    fn field_terrain(&self) -> FieldTerrain<'_>;
}

/// A terrain as a [`SunField`] reads it (opaque): its map's size and baked horizons, and the
/// pieces covering the map now — the whole map, or the tiles a stream draws.
#[derive(Debug)]
pub struct FieldTerrain<'a> {
    pub(crate) layout: &'a wgpu::BindGroupLayout,
    /// The map's extent in the map frame, world units.
    pub(crate) map_size: Vec2,
    /// Level 0's texel size.
    pub(crate) texel: Vec2,
    /// Baked azimuths.
    pub(crate) directions: u32,
    /// The bake's farthest horizon distance.
    pub(crate) reach: f32,
    pub(crate) tiles: Vec<FieldTile<'a>>,
}

/// One piece of a [`FieldTerrain`]: a terrain bind group and where its texels lie.
#[derive(Debug)]
pub(crate) struct FieldTile<'a> {
    pub group: &'a wgpu::BindGroup,
    pub key: TileKey,
    /// Where the piece's frame lies in the map frame.
    pub offset: Vec2,
    /// Its texel size and size in texels.
    pub texel: Vec2,
    pub size: (u32, u32),
    /// Its sides on the map's edge (bits: 1 `u = 0`, 2 `v = 0`, 4 last `u`, 8 last `v`).
    pub edges: u32,
}

/// The `SunFieldUniform` of the field's WGSL.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct SunFieldUniform {
    pub to_map: [[f32; 4]; 4],
    pub levels: [[f32; 4]; MAX_SUN_FIELD_LEVELS as usize],
    pub walk: [[f32; 4]; 2],
    pub slopes: [f32; 4],
    pub map_size: [f32; 2],
    pub side: u32,
    pub count: u32,
}

/// The `SunFieldPass` of the build passes: one dispatch's block and tile.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct SunFieldPass {
    pub offset: [f32; 2],
    pub first: [u32; 2],
    pub level: u32,
    pub edges: u32,
    pub _pad: [u32; 2],
}

/// What the field was last built for.
#[derive(Debug)]
struct Built {
    sun: Vec3,
    origins: Vec<Vec2>,
    tiles: Vec<(TileKey, wgpu::BindGroup)>,
}

/// The terrain's sun visibility at any world point, for any receiver's shader: a house, a tree,
/// a character or a lake kilometres from the camera falls into a mountain's shadow at sunset.
///
/// The field is a stack of square levels centred on the camera, each twice as wide as the one
/// before, the coarsest covering the whole map. Each texel holds the two world heights between
/// which the sun's disc sinks behind the terrain above that point (below the first, none of it
/// is seen). They come from the baked horizons alone: from the texel's horizon point, that
/// point's own horizon point, and so on (the upper convex hull of the terrain's profile toward
/// the sun), in the two baked directions either side of the sun, blended — the rule of
/// [`super::reference::horizon_raised_sun_visible`], walked over the field's texels so that it
/// crosses tiles and levels where a streamed terrain's textures end. Where level 0 is not
/// resident, the coarser tiles the stream draws answer.
///
/// The field is rebuilt only when the sun has moved by [`SunFieldOptions::sun_step`], the
/// camera by a texel of a level (that level and the finer ones), or the terrain's pieces have
/// changed (a stream's tiles came in). The terrain's own drawing is untouched.
///
/// Receivers read it through [`wgsl`](SunField::wgsl)'s `sun_field_visibility(world)` and the
/// [`bind_group`](SunField::bind_group):
///
/// ```no_run
/// # fn frame(device: &wgpu::Device, queue: &wgpu::Queue, terrain: &hikage_runtime::horizon::TerrainStream, frame: &hikage_runtime::horizon::TerrainFrame, eye: hikage_runtime::glam::Vec3) -> Result<(), hikage_runtime::RuntimeError> {
/// use hikage_runtime::horizon::{SunField, SunFieldOptions};
///
/// // Once: the field at bind group 2 of the game's receiver shaders.
/// let mut field = SunField::new(device, terrain, SunFieldOptions { group: 2, ..SunFieldOptions::default() })?;
/// let shader = format!("{}\n{}", field.wgsl(), "
///     @fragment fn fs(@location(0) world: vec3<f32>) -> @location(0) vec4<f32> {
///         let sun = sun_field_visibility(world);
///         return vec4<f32>(vec3<f32>(0.1 + 0.9 * sun), 1.0);
///     }");
/// // The pipeline's layout takes `field.layout()` at group 2; each draw binds `field.bind_group()`.
///
/// // Every frame, after the terrain's own update:
/// field.update(device, queue, terrain, frame, eye)?;
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct SunField {
    options: SunFieldOptions,
    wgsl: String,
    texel: Vec2,
    directions: u32,
    uniform: wgpu::Buffer,
    passes: wgpu::Buffer,
    pass_capacity: u64,
    hops: wgpu::TextureView,
    ground: wgpu::TextureView,
    thresholds: wgpu::TextureView,
    fill_group: wgpu::BindGroup,
    fill: wgpu::ComputePipeline,
    walk_group: wgpu::BindGroup,
    walk: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    built: Option<Built>,
}

impl SunField {
    /// A field over `terrain` (a [`super::TerrainShadows`] or [`super::TerrainStream`]); built
    /// by the first [`update`](SunField::update). Refuses options the device cannot hold.
    pub fn new(
        device: &wgpu::Device,
        terrain: &impl SunFieldSource,
        options: SunFieldOptions,
    ) -> Result<SunField, RuntimeError> {
        let source = terrain.field_terrain();
        let limits = device.limits();
        let bad = |message: String| RuntimeError::Asset { asset: "sun field".into(), message };
        if options.side < 16 || options.side > limits.max_texture_dimension_2d {
            return Err(bad(format!(
                "a side of {} texels: between 16 and the device's {}",
                options.side, limits.max_texture_dimension_2d
            )));
        }
        if options.levels == 0 || options.levels > MAX_SUN_FIELD_LEVELS.min(limits.max_texture_array_layers) {
            return Err(bad(format!("{} levels: between 1 and {MAX_SUN_FIELD_LEVELS}", options.levels)));
        }
        // The coarsest level, centred anywhere on the map, covers all of it.
        let widest =
            source.map_size.max_element() * 2.0 / (options.side as f32 * (1u32 << (options.levels - 1)) as f32);
        let texel = Vec2::splat(source.texel.max_element().max(widest));
        let texture = |label: &str, format: wgpu::TextureFormat, usage: wgpu::TextureUsages| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d {
                        width: options.side,
                        height: options.side,
                        depth_or_array_layers: options.levels,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage,
                    view_formats: &[],
                })
                .create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2Array),
                    ..Default::default()
                })
        };
        let both = wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING;
        gpu::checked(device, "sun field", || {
            let hops = texture("hikage sun field hops", wgpu::TextureFormat::Rgba32Float, both);
            let ground = texture("hikage sun field ground", wgpu::TextureFormat::R32Float, both);
            let thresholds = texture("hikage sun field", wgpu::TextureFormat::Rg32Float, both);
            let uniform = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("hikage sun field"),
                size: std::mem::size_of::<SunFieldUniform>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let passes = pass_buffer(device, INITIAL_PASSES);
            let fill_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("hikage sun field fill"),
                entries: &[
                    compute(gpu::uniform_entry::<SunFieldUniform>(0)),
                    pass_entry(1),
                    storage_entry(2, wgpu::TextureFormat::Rgba32Float),
                    storage_entry(3, wgpu::TextureFormat::R32Float),
                ],
            });
            let walk_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("hikage sun field walk"),
                entries: &[
                    compute(gpu::uniform_entry::<SunFieldUniform>(0)),
                    pass_entry(1),
                    compute(gpu::texture_entry(2, wgpu::TextureViewDimension::D2Array, false)),
                    compute(gpu::texture_entry(3, wgpu::TextureViewDimension::D2Array, false)),
                    storage_entry(4, wgpu::TextureFormat::Rg32Float),
                ],
            });
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("hikage sun field"),
                entries: &[
                    gpu::uniform_entry::<SunFieldUniform>(0),
                    gpu::texture_entry(1, wgpu::TextureViewDimension::D2Array, false),
                ],
            });
            let fill_group = pass_group(device, &fill_layout, (&uniform, &passes), &[&hops, &ground]);
            let walk_group = pass_group(device, &walk_layout, (&uniform, &passes), &[&hops, &ground, &thresholds]);
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("hikage sun field"),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&thresholds) },
                ],
            });
            let pipeline = |label: &str, layouts: &[Option<&wgpu::BindGroupLayout>], wgsl: &str, entry: &str| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(label),
                    layout: Some(&device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: Some(label),
                        bind_group_layouts: layouts,
                        immediate_size: 0,
                    })),
                    module: &gpu::module(device, label, wgsl),
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                })
            };
            let fill = pipeline(
                "hikage sun field fill",
                &[Some(source.layout), Some(&fill_layout)],
                &format!("{SCENE_WGSL}\n{HORIZON_WGSL}\n{TERRAIN_WGSL}\n{COMMON_WGSL}\n{FILL_WGSL}"),
                "sun_field_fill",
            );
            let walk = pipeline(
                "hikage sun field walk",
                &[None, Some(&walk_layout)],
                &format!("{COMMON_WGSL}\n{WALK_WGSL}"),
                "sun_field_walk",
            );
            SunField {
                options,
                wgsl: gpu::at_group(SUN_FIELD_WGSL, options.group),
                texel,
                directions: source.directions,
                uniform,
                passes,
                pass_capacity: INITIAL_PASSES,
                hops,
                ground,
                thresholds,
                fill_group,
                fill,
                walk_group,
                walk,
                layout,
                bind_group,
                built: None,
            }
        })
    }

    /// The receivers' WGSL, bindings at [`SunFieldOptions::group`]: `sun_field_visibility(world:
    /// vec3<f32>) -> f32`, the share of the sun's disc seen past the terrain from a world point
    /// (1 in the open and off the map). Prepend it to a receiver's shader.
    pub fn wgsl(&self) -> &str {
        &self.wgsl
    }

    /// The layout of the receivers' bind group, for a receiver pipeline's layout at
    /// [`SunFieldOptions::group`].
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// The receivers' bind group (the field's uniform and thresholds).
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    /// The receivers' two bindings, for an engine that builds its own bind group: binding 0, the
    /// uniform buffer; binding 1, the thresholds (a 2D array of `Rg32Float`, not filterable).
    /// Both live as long as the field, and [`update`](SunField::update) rewrites them in place.
    pub fn bindings(&self) -> (&wgpu::Buffer, &wgpu::TextureView) {
        (&self.uniform, &self.thresholds)
    }

    /// Device memory the field holds, bytes: 28 a texel, `side² × levels` texels.
    pub fn device_bytes(&self) -> u64 {
        TEXEL_BYTES * u64::from(self.options.side).pow(2) * u64::from(self.options.levels)
    }

    /// World units per texel of `level` (0 the finest), along `u` and `v` of the map frame.
    pub fn texel_size(&self, level: u32) -> Vec2 {
        self.texel * (1u32 << level.min(MAX_SUN_FIELD_LEVELS - 1)) as f32
    }

    /// Rebuilds what the sun's or the camera's move since the last build calls for, from
    /// `terrain` as it is now (after its own update this frame), and submits the work. `frame`
    /// gives the sun and the map's placement ([`TerrainFrame::model`]), `eye` the camera (world).
    pub fn update(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        terrain: &impl SunFieldSource,
        frame: &TerrainFrame,
        eye: Vec3,
    ) -> Result<SunFieldStats, RuntimeError> {
        let source = terrain.field_terrain();
        let to_map = frame.model.inverse();
        let cam = to_map.transform_point3(eye);
        let sun = to_map.transform_vector3(frame.sun.direction).normalize_or(Vec3::Y);
        let (side, count) = (self.options.side, self.options.levels);
        let origins: Vec<Vec2> = (0..count)
            .map(|k| {
                let t = self.texel_size(k);
                ((Vec2::new(cam.x, cam.z) / t).floor() - Vec2::splat((side / 2) as f32)) * t
            })
            .collect();
        // The pieces as a set: a stream lists the same tiles in another order as the camera moves.
        let mut tiles: Vec<(TileKey, wgpu::BindGroup)> =
            source.tiles.iter().map(|t| (t.key, t.group.clone())).collect();
        tiles.sort_by_key(|t| t.0);
        // Levels to build: all of them for a new sun or new pieces of terrain; else the finest
        // ones up to the coarsest that moved (a level's walk reads the coarser levels).
        let build = match &self.built {
            Some(b) if b.tiles == tiles && b.sun.angle_between(sun) <= self.options.sun_step => {
                (0..count).rev().find(|&k| b.origins[k as usize] != origins[k as usize]).map_or(0, |k| k + 1)
            }
            _ => count,
        };
        if build == 0 {
            return Ok(SunFieldStats::default());
        }
        let sun = match &self.built {
            Some(b) if build < count => b.sun,
            _ => sun,
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&self.uniform(&source, to_map, sun, frame, &origins)));
        // One fill dispatch per level and piece of terrain that meet, then one walk per level.
        let mut passes = Vec::new();
        for level in 0..build {
            let (origin, t) = (origins[level as usize], self.texel_size(level));
            for tile in &source.tiles {
                if let Some((first, last)) = block(tile, origin, t, side) {
                    passes.push((
                        Some(tile.group),
                        SunFieldPass { offset: tile.offset.to_array(), first, level, edges: tile.edges, _pad: [0; 2] },
                        [last[0] - first[0], last[1] - first[1]],
                    ));
                }
            }
        }
        let fills = passes.len();
        for level in 0..build {
            let pass = SunFieldPass { offset: [0.0; 2], first: [0; 2], level, edges: 0, _pad: [0; 2] };
            passes.push((None, pass, [side, side]));
        }
        self.reserve(device, passes.len() as u64);
        let mut bytes = vec![0u8; passes.len() * PASS_STRIDE as usize];
        for (i, (_, pass, _)) in passes.iter().enumerate() {
            let at = i * PASS_STRIDE as usize;
            bytes[at..at + std::mem::size_of::<SunFieldPass>()].copy_from_slice(bytemuck::bytes_of(pass));
        }
        queue.write_buffer(&self.passes, 0, &bytes);
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("hikage sun field") });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("hikage sun field fill"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.fill);
            for (i, (group, _, [w, h])) in passes[..fills].iter().enumerate() {
                pass.set_bind_group(0, *group, &[]);
                pass.set_bind_group(1, &self.fill_group, &[(i as u64 * PASS_STRIDE) as u32]);
                pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
            }
        }
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("hikage sun field walk"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.walk);
            for (i, (_, _, [w, h])) in passes.iter().enumerate().skip(fills) {
                pass.set_bind_group(1, &self.walk_group, &[(i as u64 * PASS_STRIDE) as u32]);
                pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
            }
        }
        queue.submit([encoder.finish()]);
        self.built = Some(Built { sun, origins, tiles });
        Ok(SunFieldStats { levels_built: build, dispatches: passes.len() as u32 })
    }

    /// The uniform for a build: the levels at `origins`, the sun's two bracketing directions and
    /// its disc's slopes.
    fn uniform(
        &self,
        source: &FieldTerrain<'_>,
        to_map: Mat4,
        sun: Vec3,
        frame: &TerrainFrame,
        origins: &[Vec2],
    ) -> SunFieldUniform {
        let mut levels = [[0.0; 4]; MAX_SUN_FIELD_LEVELS as usize];
        for (k, o) in origins.iter().enumerate() {
            let t = self.texel_size(k as u32);
            levels[k] = [o.x, o.y, t.x, t.y];
        }
        // The sun in the bump frame (u, v, up) and its azimuth in texel space.
        let (texel, directions) = (source.texel, self.directions.max(1) as f32);
        let turns = (sun.z / texel.y).atan2(sun.x / texel.x) / std::f32::consts::TAU * directions;
        let f = turns.rem_euclid(directions);
        let k0 = f.floor();
        let walk = |k: f32, weight: f32| {
            let k = k.rem_euclid(directions);
            let phi = std::f32::consts::TAU * k / directions;
            let w = (Vec2::new(phi.cos(), phi.sin()) * texel).normalize();
            [w.x, w.y, k, weight]
        };
        let elevation = sun.y.atan2(Vec2::new(sun.x, sun.z).length());
        let r = frame.sun.angular_radius.max(0.0);
        let limit = 89.9f32.to_radians();
        SunFieldUniform {
            to_map: to_map.to_cols_array_2d(),
            levels,
            walk: [walk(k0, 1.0 - (f - k0)), walk(k0 + 1.0, f - k0)],
            slopes: [(elevation + r).min(limit).tan(), (elevation - r).max(-limit).tan(), source.reach, 1.0],
            map_size: source.map_size.to_array(),
            side: self.options.side,
            count: self.options.levels,
        }
    }

    /// Makes room for `passes` dispatches' parameters.
    fn reserve(&mut self, device: &wgpu::Device, passes: u64) {
        if passes <= self.pass_capacity {
            return;
        }
        self.pass_capacity = passes.next_power_of_two();
        self.passes = pass_buffer(device, self.pass_capacity);
        let buffers = (&self.uniform, &self.passes);
        let fill = self.fill.get_bind_group_layout(1);
        self.fill_group = pass_group(device, &fill, buffers, &[&self.hops, &self.ground]);
        let walk = self.walk.get_bind_group_layout(1);
        self.walk_group = pass_group(device, &walk, buffers, &[&self.hops, &self.ground, &self.thresholds]);
    }
}

/// The block of a level's texels (origin `origin`, texel `t`, `side` a side) whose centres, moved
/// inside the map, fall in `tile`: first and one past the last, with a texel of margin (the
/// shader decides each texel exactly). `None` when they do not meet.
fn block(tile: &FieldTile<'_>, origin: Vec2, t: Vec2, side: u32) -> Option<([u32; 2], [u32; 2])> {
    let lo = tile.offset;
    let hi = tile.offset + tile.texel * Vec2::new(tile.size.0 as f32, tile.size.1 as f32);
    let axis = |lo: f32, hi: f32, low_edge: bool, high_edge: bool, origin: f32, t: f32| -> Option<(u32, u32)> {
        let index = |x: f32| (x - origin) / t - 0.5;
        let first = if low_edge { 0.0 } else { index(lo).floor() - 1.0 };
        let last = if high_edge { side as f32 } else { index(hi).ceil() + 2.0 };
        let (first, last) = (first.clamp(0.0, side as f32) as u32, last.clamp(0.0, side as f32) as u32);
        (first < last).then_some((first, last))
    };
    let (x0, x1) = axis(lo.x, hi.x, tile.edges & 1 != 0, tile.edges & 4 != 0, origin.x, t.x)?;
    let (y0, y1) = axis(lo.y, hi.y, tile.edges & 2 != 0, tile.edges & 8 != 0, origin.y, t.y)?;
    Some(([x0, y0], [x1, y1]))
}

/// A buffer of `passes` dispatch parameters, one every [`PASS_STRIDE`] bytes.
fn pass_buffer(device: &wgpu::Device, passes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("hikage sun field passes"),
        size: passes * PASS_STRIDE,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// One dispatch's parameters, at a dynamic offset.
fn pass_binding(passes: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
        buffer: passes,
        offset: 0,
        size: std::num::NonZeroU64::new(std::mem::size_of::<SunFieldPass>() as u64),
    })
}

/// `entry` for the build passes alone.
fn compute(entry: wgpu::BindGroupLayoutEntry) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry { visibility: wgpu::ShaderStages::COMPUTE, ..entry }
}

/// A build pass's bind group: the field's uniform, the dispatch parameters, then `views` (the
/// fill writes hops and ground; the walk reads them and writes the thresholds).
fn pass_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    (uniform, passes): (&wgpu::Buffer, &wgpu::Buffer),
    views: &[&wgpu::TextureView],
) -> wgpu::BindGroup {
    let mut entries = vec![
        wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
        wgpu::BindGroupEntry { binding: 1, resource: pass_binding(passes) },
    ];
    for (k, view) in views.iter().enumerate() {
        entries
            .push(wgpu::BindGroupEntry { binding: 2 + k as u32, resource: wgpu::BindingResource::TextureView(view) });
    }
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("hikage sun field pass"),
        layout,
        entries: &entries,
    })
}

/// The binding of a dispatch's parameters: a uniform at a dynamic offset.
fn pass_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    compute(gpu::entry(
        binding,
        wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: true,
            min_binding_size: std::num::NonZeroU64::new(std::mem::size_of::<SunFieldPass>() as u64),
        },
    ))
}

/// A write-only storage texture array of `format`.
fn storage_entry(binding: u32, format: wgpu::TextureFormat) -> wgpu::BindGroupLayoutEntry {
    compute(gpu::entry(
        binding,
        wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format,
            view_dimension: wgpu::TextureViewDimension::D2Array,
        },
    ))
}
