//! [`SunFieldTiles`]: a streamed terrain's tiles as an engine that keeps its own textures holds
//! them (hikage-bevy's render world), for a [`super::SunField`] to read.

use std::collections::BTreeMap;

use glam::Vec2;
use hikage_bundle::EdgeMode;

use super::sun_field::{FieldTerrain, FieldTile, SunFieldSource};
use super::terrain::{TerrainUniform, terrain_layout};
use super::tile_plan::TileKey;
use crate::gpu;

/// What a [`SunField`](super::SunField) needs of the whole map, whatever holds its tiles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldMap {
    /// The map's extent in the map frame (world units, from `(0, 0)`): level 0's texels times
    /// its size.
    pub size: Vec2,
    /// Level 0's texel (world units along `u` and `v`).
    pub texel: Vec2,
    /// Baked azimuths of the horizon maps.
    pub directions: u32,
    /// The bake's farthest horizon distance (world units; the map's diagonal when unbounded).
    pub reach: f32,
}

/// One tile drawn now, as its engine holds it on the device.
#[derive(Clone, Copy, Debug)]
pub struct FieldTileTextures<'a> {
    /// Its level of detail, column and row.
    pub key: TileKey,
    /// Where its texel `(0, 0)`'s lower corner lies in the map frame (world units).
    pub offset: Vec2,
    /// Its horizon map (3D: u, v, azimuth), as baked or decoded from blocks.
    pub horizon: &'a wgpu::TextureView,
    /// Its heights as stored samples in a float texture, with `constants.apron` texels of its
    /// neighbours' heights around its own (the terrain WGSL's `terrain_height` reads them).
    pub heights: &'a wgpu::TextureView,
    /// Its texel size, size, height scale and offset, horizon encoding and apron (the rest of
    /// the uniform is not read).
    pub constants: TerrainUniform,
}

/// A terrain's drawn tiles held by an engine's own residency (its textures, its budgets), as a
/// [`SunFieldSource`]: hikage-bevy's stream keeps its tiles as Bevy images and hands their
/// device textures here each frame.
///
/// [`set`](SunFieldTiles::set) takes the tiles drawn now; a tile whose textures did not change
/// keeps its bind group, so the field rebuilds only when the set of tiles does.
///
/// ```no_run
/// # fn frame(device: &wgpu::Device, queue: &wgpu::Queue, field: &mut hikage_runtime::horizon::SunField,
/// #     frame: &hikage_runtime::horizon::TerrainFrame, eye: hikage_runtime::glam::Vec3,
/// #     drawn: Vec<hikage_runtime::horizon::FieldTileTextures<'_>>, map: hikage_runtime::horizon::FieldMap)
/// #     -> Result<(), hikage_runtime::RuntimeError> {
/// use hikage_runtime::horizon::SunFieldTiles;
///
/// // Once, when the map is known (`map`: its size, texel, azimuths and reach):
/// let mut tiles = SunFieldTiles::new(device, queue, map);
/// // Every frame: the tiles the engine draws, then the field.
/// tiles.set(device, queue, drawn);
/// field.update(device, queue, &tiles, frame, eye)?;
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct SunFieldTiles {
    map: FieldMap,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    no_ao: wgpu::TextureView,
    tiles: BTreeMap<TileKey, Bound>,
}

/// A tile's textures and the bind group made of them.
#[derive(Debug)]
struct Bound {
    horizon: wgpu::TextureView,
    heights: wgpu::TextureView,
    constants: TerrainUniform,
    offset: Vec2,
    group: wgpu::BindGroup,
}

impl SunFieldTiles {
    /// No tiles yet, of the terrain `map`.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, map: FieldMap) -> SunFieldTiles {
        SunFieldTiles {
            map,
            layout: terrain_layout(device, false),
            sampler: super::horizon_sampler(device, EdgeMode::Clamp, false),
            no_ao: gpu::constant_texture(device, queue, 0.0),
            tiles: BTreeMap::new(),
        }
    }

    /// The map these tiles cover.
    pub fn map(&self) -> &FieldMap {
        &self.map
    }

    /// The tiles drawn now, in place of the last ones.
    pub fn set<'a>(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        tiles: impl IntoIterator<Item = FieldTileTextures<'a>>,
    ) {
        let mut next = BTreeMap::new();
        for t in tiles {
            let same = |b: &Bound| {
                b.horizon == *t.horizon && b.heights == *t.heights && b.constants == t.constants && b.offset == t.offset
            };
            let bound = match self.tiles.remove(&t.key).filter(same) {
                Some(b) => b,
                None => self.bind(device, queue, &t),
            };
            next.insert(t.key, bound);
        }
        self.tiles = next;
    }

    /// The bind group of tile `t`, as the terrain WGSL reads it.
    fn bind(&self, device: &wgpu::Device, queue: &wgpu::Queue, t: &FieldTileTextures<'_>) -> Bound {
        let uniform = gpu::uniform_buffer(device, queue, "hikage field tile", &t.constants);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hikage field tile"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(t.horizon) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&self.sampler) },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(t.heights) },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&self.no_ao) },
            ],
        });
        Bound {
            horizon: t.horizon.clone(),
            heights: t.heights.clone(),
            constants: t.constants,
            offset: t.offset,
            group,
        }
    }
}

impl SunFieldSource for SunFieldTiles {
    fn field_terrain(&self) -> FieldTerrain<'_> {
        let map = &self.map;
        // A side is on the map's edge when it lies within half a texel of it.
        let tiles = self
            .tiles
            .iter()
            .map(|(&key, b)| {
                let texel = Vec2::from(b.constants.texel_size);
                let size = (b.constants.size[0], b.constants.size[1]);
                let end = b.offset + texel * Vec2::new(size.0 as f32, size.1 as f32);
                let (low, high) = (b.offset.cmple(0.5 * texel), end.cmpge(map.size - 0.5 * texel));
                let edges = u32::from(low.x) | u32::from(low.y) << 1 | u32::from(high.x) << 2 | u32::from(high.y) << 3;
                FieldTile { group: &b.group, key, offset: b.offset, texel, size, edges }
            })
            .collect();
        FieldTerrain {
            layout: &self.layout,
            map_size: map.size,
            texel: map.texel,
            directions: map.directions,
            reach: map.reach,
            tiles,
        }
    }
}
