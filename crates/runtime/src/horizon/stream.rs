//! [`TerrainStream`]: a terrain baked in tiles with levels of detail (a `Horizon` job with `tile`
//! and `levels`), drawn from the tiles near the camera and coarser ones farther out, loaded on
//! a thread of its own and uploaded within a byte budget a frame.

use std::collections::HashSet;
use std::path::Path;
use std::sync::mpsc;

use glam::{Mat4, Vec2, Vec3};
use hikage_bundle::tile_index::TileIndex;
use hikage_bundle::{Asset, PayloadData, TextureData};

use super::horizon_filterable;
use super::residency::{BudgetShortfall, TileReads, TileResidency, TileStore, check_budgets};
use super::sun_field::{FieldTerrain, FieldTile, SunFieldSource};
use super::terrain::{TerrainBinding, TerrainExtent, TerrainFrame, terrain_layout, terrain_program};
use super::tile_data::{apron_neighbours, heights_with_apron, tile_device_bytes, tile_unchanged};
use super::tile_plan::{TileKey, TileLayout, TileParts};
use crate::draw::DrawOptions;
use crate::error::RuntimeError;
use crate::gpu;
use crate::load::CpuAsset;
use crate::upload::GpuBundle;

/// Largest side of a tile's textures: every backend holds a 3D texture of 2048 a side (D3D12,
/// WebGPU's defaults), so a streamed terrain never needs more whatever the map's size.
pub const MAX_TILE_SIDE: u32 = 2048;

/// How a [`TerrainStream`] chooses, loads and keeps tiles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamOptions {
    /// GPU memory the resident tiles may hold, in bytes (their textures). Default 256 MiB.
    pub resident_bytes: u64,
    /// Texture bytes uploaded in one [`TerrainStream::update`] at most. Default 32 MiB.
    pub upload_bytes: u64,
    /// Level of detail by distance: a tile is replaced by its four finer tiles while the
    /// camera is closer (horizontally, to the tile's rectangle) than `detail` times the tile's
    /// width. Default 1.5: level 0 within 1.5 tile widths, level 1 within 3 of its own, and so on.
    pub detail: f32,
    /// The finest level drawn (0: the map as baked).
    pub finest_level: u32,
    /// Depth of the skirt hung under each tile's edges, in texels of the tile's level: hides the
    /// cracks where tiles of two levels meet. Default 4.
    pub skirt_texels: f32,
}

impl Default for StreamOptions {
    fn default() -> StreamOptions {
        StreamOptions {
            resident_bytes: 256 << 20,
            upload_bytes: 32 << 20,
            detail: 1.5,
            finest_level: 0,
            skirt_texels: 4.0,
        }
    }
}

/// What one [`TerrainStream::update`] did and what is resident after it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StreamStats {
    /// Tiles on the device, and their texture bytes.
    pub resident_tiles: usize,
    /// See `resident_tiles`.
    pub resident_bytes: u64,
    /// Texture bytes uploaded by this update.
    pub uploaded_bytes: u64,
    /// Tiles drawn by the next [`TerrainStream::draw`].
    pub drawn: usize,
    /// Tiles wanted and not yet on the device (a coarser tile is drawn in their place).
    pub missing: usize,
    /// The finest level drawn.
    pub finest_drawn: u32,
}

/// What the loader thread sends back: the index generation it read from, and a tile's payloads
/// read and checked, or why not.
type Loaded = (u64, Key, Result<Vec<CpuAsset>, RuntimeError>);

/// What the loader thread is asked: a tile, or to read from a reloaded bundle's index from now
/// on (its generation).
enum Request {
    Tile(Key),
    Index(Box<TileIndex>, u64),
}

/// A tile's key.
type Key = TileKey;

/// A tile on the device.
#[derive(Debug)]
struct Resident {
    binding: TerrainBinding,
    /// Holds the textures the bind group samples.
    _textures: GpuBundle,
    bytes: u64,
    /// Level-0 map frame → tile frame offset (world units along `u`, `v`).
    offset: (f32, f32),
}

/// The loader thread as the residency reads through it.
#[derive(Debug)]
struct ThreadReads {
    requests: mpsc::Sender<Request>,
    results: mpsc::Receiver<Loaded>,
    pending: HashSet<Key>,
    /// The index the loader reads from now (a reload's results before it are dropped).
    generation: u64,
}

impl TileReads<Vec<CpuAsset>, RuntimeError> for ThreadReads {
    fn finished(&mut self) -> Vec<(Key, Result<Vec<CpuAsset>, RuntimeError>)> {
        let mut out = Vec::new();
        while let Ok((generation, key, result)) = self.results.try_recv() {
            if generation == self.generation {
                self.pending.remove(&key);
                out.push((key, result));
            }
        }
        out
    }

    /// A read on the thread cannot be stopped: it finishes and is dropped if still unwanted.
    fn retain(&mut self, _wanted: &dyn Fn(Key) -> bool) {}

    fn reading(&self, key: Key) -> bool {
        self.pending.contains(&key)
    }

    fn in_flight(&self) -> usize {
        self.pending.len()
    }

    fn start(&mut self, key: Key) -> Result<(), RuntimeError> {
        if self.requests.send(Request::Tile(key)).is_ok() {
            self.pending.insert(key);
        }
        Ok(())
    }
}

/// The device as the residency adds tiles to it.
struct DeviceStore<'a> {
    device: &'a wgpu::Device,
    queue: &'a wgpu::Queue,
    binder: &'a Binder,
}

impl TileStore<Resident, Vec<CpuAsset>, RuntimeError> for DeviceStore<'_> {
    fn bytes(&self, assets: &Vec<CpuAsset>) -> u64 {
        assets.iter().filter_map(|a| a.texture()).map(|t| t.desc.total_bytes().unwrap_or(0)).sum()
    }

    fn add(&mut self, key: Key, assets: Vec<CpuAsset>) -> Result<(Resident, u64), RuntimeError> {
        let r = upload(self.device, self.queue, self.binder, key, &assets)?;
        let bytes = r.bytes;
        Ok((r, bytes))
    }

    fn evict(&mut self, _key: Key, _tile: Resident) {}
}

/// A terrain baked in tiles and levels of detail, streamed around a camera.
///
/// - **Choice of level:** by distance (say [`StreamOptions::detail`]): from the coarsest level's
///   tiles down, a tile is replaced by its four finer tiles while the camera is within `detail`
///   tile widths of it, horizontally, until [`StreamOptions::finest_level`].
/// - **Loading:** a thread of its own reads, hashes and decodes the tiles asked for (at most 8 in
///   flight, coarser and nearer first); [`update`](TerrainStream::update) never waits on it.
/// - **Uploads:** at most [`StreamOptions::upload_bytes`] of textures an update.
/// - **Residency:** at most [`StreamOptions::resident_bytes`]. Tiles are wanted four at a time
///   (the four that replace a coarser tile), the sets nearest the camera in tile widths first
///   ([`TilePlan`](super::TilePlan)); only whole sets the budget holds are read, so a budget too small for the
///   next level holds the finest it can (see [`budget_warning`](TerrainStream::budget_warning)).
///   To make room, tiles no longer wanted go first (least recently drawn first), then wanted
///   ones past the sets the budget holds; never one of those sets, never a tile that finer
///   resident tiles hang from, never the coarsest level's, which stay so that there is always
///   terrain to draw.
/// - **While a finer tile loads** its coarser tile is drawn: a tile is replaced only when all
///   four of its finer tiles are on the device.
/// - **Cracks** between levels are hidden by skirts ([`StreamOptions::skirt_texels`]).
/// - Every tile's textures are at most [`MAX_TILE_SIDE`] a side.
///
/// The map frame is the one-mesh terrain's ([`TerrainFrame::model`] places it): level 0's texel
/// `(i, j)` centred at `((i + ½)·sx, h, (j + ½)·sy)`; a level-`k` node sits on level 0's texel
/// `(i·2^k, j·2^k)`.
///
/// ```no_run
/// # fn frame(device: &wgpu::Device, queue: &wgpu::Queue, pass: &mut wgpu::RenderPass<'_>, view_proj: hikage_runtime::glam::Mat4, eye: hikage_runtime::glam::Vec3) -> Result<(), hikage_runtime::RuntimeError> {
/// use hikage_runtime::horizon::{StreamOptions, TerrainFrame, TerrainStream};
/// use hikage_runtime::{DrawOptions, wgpu};
///
/// let options = DrawOptions {
///     depth_format: Some(wgpu::TextureFormat::Depth32Float),
///     ..DrawOptions::new(wgpu::TextureFormat::Rgba8UnormSrgb)
/// };
/// // The tiles of the `terrain` job (`tile: Some(512), levels: Some(16)`).
/// let mut terrain = TerrainStream::open(device, queue, "bundle".as_ref(), "terrain", &options, StreamOptions::default())?;
///
/// // Every frame, before the pass: choose, upload and place the tiles for this camera.
/// let stats = terrain.update(device, queue, &TerrainFrame { view_proj, ..TerrainFrame::default() }, eye)?;
/// assert!(stats.resident_bytes <= StreamOptions::default().resident_bytes);
/// terrain.draw(pass);
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct TerrainStream {
    program: gpu::Program,
    options: StreamOptions,
    /// The map's parts and levels, and how a tile is bound.
    binder: Binder,
    /// What a tile of each level holds on the device (its tile `(0, 0)`, the largest).
    level_bytes: Vec<u64>,
    residency: TileResidency<Resident, Vec<CpuAsset>>,
    reads: ThreadReads,
    /// The index the tiles are read from (a reload compares the rebaked one with it).
    index: TileIndex,
    drawn: Vec<Key>,
    extent: TerrainExtent,
    shortfall: Option<BudgetShortfall>,
    /// The bake's farthest horizon distance and azimuths (the coarsest level's, as every level's).
    reach: f32,
    directions: u32,
}

impl TerrainStream {
    /// Opens the tiles of map `map` (the tiled job's id) in the bundle in `dir`, loads its
    /// coarsest level before returning (so there is always terrain to draw) and starts the
    /// loader thread. Refuses tiles wider than [`MAX_TILE_SIDE`], a coarsest level larger than
    /// the resident budget, and a tile larger than the upload budget; a budget that cannot hold
    /// the finest level under the camera is its [`budget_warning`](TerrainStream::budget_warning).
    pub fn open(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        dir: &Path,
        map: &str,
        draw: &DrawOptions,
        options: StreamOptions,
    ) -> Result<TerrainStream, RuntimeError> {
        let index = TileIndex::open(dir)?;
        let bad = |message: String| RuntimeError::Asset { asset: map.to_string(), message };
        if !index.sets().any(|s| s.map == map) {
            let maps: Vec<&str> = index.sets().map(|s| s.map.as_str()).collect();
            return Err(bad(format!("no map baked in tiles of that name; the bundle has: {}", maps.join(", "))));
        }
        let layout = TileLayout::new(map, |part, level, at| index.tile(part, level, at))?;
        let first = index.tile(&layout.parts.horizon, 0, (0, 0)).expect("the layout found it");
        let format = first.payload.texture().map(|t| t.format).expect("a texture");
        let filterable = horizon_filterable(device, format);
        let group_layout = terrain_layout(device, filterable);

        // The loader thread: a clone of the index, one tile's payloads per request.
        let (requests, to_load) = mpsc::channel::<Request>();
        let (loaded, results) = mpsc::channel::<Loaded>();
        let mut loader = index.clone();
        let loader_parts = layout.parts.clone();
        std::thread::Builder::new()
            .name(format!("hikage terrain {map}"))
            .spawn(move || {
                let mut generation = 0;
                while let Ok(request) = to_load.recv() {
                    match request {
                        Request::Index(index, g) => (loader, generation) = (*index, g),
                        Request::Tile(key) => {
                            if loaded.send((generation, key, load_tile(&loader, &loader_parts, key))).is_err() {
                                break;
                            }
                        }
                    }
                }
            })
            .map_err(|e| bad(format!("could not start the loader thread: {e}")))?;

        let binder = Binder { tiles: layout, skirt_texels: options.skirt_texels, layout: group_layout, filterable };
        // What a tile holds on the device: the budgets are checked before anything is read.
        let tiles = &binder.tiles;
        let tile_bytes = |key: Key| -> u64 {
            let entries: Vec<Asset> = tiles.parts.all().filter_map(|p| index.tile(p, key.0, (key.1, key.2))).collect();
            tile_device_bytes(&entries)
        };
        let side = |level: u32| {
            let first = index.tile(&tiles.parts.horizon, level, (0, 0));
            first.and_then(|a| a.payload.texture().map(|t| (t.width, t.height))).unwrap_or((0, 0))
        };
        let level_bytes = check_budgets(tiles, &options, side, tile_bytes).map_err(bad)?;
        let roots: Vec<Key> = tiles.roots().collect();
        let shortfall = binder.tiles.budget_shortfall(&options, |k| level_bytes[k.0 as usize]);
        // The coarsest level, now: there is always terrain to draw.
        let mut residency = TileResidency::default();
        let mut program = None;
        let (mut heights, mut root) = ((f32::MAX, f32::MIN), None);
        for &key in &roots {
            let assets = load_tile(&index, &binder.tiles.parts, key)?;
            let r = upload(device, queue, &binder, key, &assets)?;
            if program.is_none() {
                let group = (binder.layout.clone(), r.binding.bind_group.clone());
                program = Some(terrain_program(device, map, group, draw)?);
            }
            let range = r.binding.extent.height_range;
            heights = (heights.0.min(range.0), heights.1.max(range.1));
            root = root.or(Some((r.binding.reach, r.binding.directions)));
            let bytes = r.bytes;
            residency.insert(key, r, bytes);
        }
        let level0 = &binder.tiles.levels[0];
        let extent = TerrainExtent::new(level0.size, level0.texel, heights);
        let (reach, directions) = root.expect("at least one coarsest tile");
        Ok(TerrainStream {
            program: program.expect("at least one coarsest tile"),
            options,
            binder,
            level_bytes,
            residency,
            reads: ThreadReads { requests, results, pending: HashSet::new(), generation: 0 },
            index,
            drawn: Vec::new(),
            extent,
            shortfall,
            reach,
            directions,
        })
    }

    /// The warning of [`open`](TerrainStream::open) when the resident budget cannot hold level
    /// [`StreamOptions::finest_level`] under the camera: the stream then holds the finest
    /// complete level the budget allows and reads nothing finer, and this says what budget
    /// would do. `None` when the budget reaches it.
    ///
    /// ```no_run
    /// # fn f(stream: &hikage_runtime::horizon::TerrainStream) {
    /// if let Some(short) = stream.budget_warning() {
    ///     eprintln!("terrain: {short}"); // or raise `resident_bytes` to `short.needed`
    /// }
    /// # }
    /// ```
    pub fn budget_warning(&self) -> Option<&BudgetShortfall> {
        self.shortfall.as_ref()
    }

    /// The whole map's extent in the map frame (heights from the coarsest level).
    pub fn extent(&self) -> &TerrainExtent {
        &self.extent
    }

    /// Chooses the tiles for a camera at `eye` (world space), asks the loader for missing ones,
    /// uploads what it has loaded within the budgets, evicts what the budget cannot keep, and
    /// writes the drawn tiles' uniforms for `frame`. Never waits for the loader.
    ///
    /// An error is a tile that failed to load (named), or one the device refused; the stream
    /// keeps drawing what it has.
    pub fn update(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &TerrainFrame,
        eye: Vec3,
    ) -> Result<StreamStats, RuntimeError> {
        let cam = frame.model.inverse().transform_point3(eye);
        let mut store = DeviceStore { device, queue, binder: &self.binder };
        let done = self.residency.frame(
            (&self.binder.tiles, &self.options, &self.level_bytes),
            (cam.x, cam.z),
            &mut self.reads,
            &mut store,
        );
        // The drawn tiles' uniforms.
        for key in &done.drawn {
            let r = self.residency.get(*key).expect("drawn tiles are resident");
            let model = frame.model * Mat4::from_translation(Vec3::new(r.offset.0, 0.0, r.offset.1));
            let uniform = r.binding.uniform(&TerrainFrame { model, ..*frame });
            queue.write_buffer(&r.binding.uniform, 0, bytemuck::bytes_of(&uniform));
        }
        self.drawn = done.drawn;
        match done.failure {
            Some(e) => Err(e),
            None => Ok(done.stats),
        }
    }

    /// Takes up a rebake of the bundle in `dir` (the one the stream was opened from): the
    /// resident tiles whose payloads, and whose neighbours' heights, are as they were stay; the
    /// others are read again and drawn as they were until their new versions are uploaded, so
    /// no frame lacks terrain. Returns (tiles kept, tiles to read again). A rebake that changed
    /// the map's tiling (tile size, levels, parts) is refused: open the stream again.
    ///
    /// ```no_run
    /// # fn f(stream: &mut hikage_runtime::horizon::TerrainStream) -> Result<(), hikage_runtime::RuntimeError> {
    /// // When the bundle's files changed (a file watcher, an editor's "bake" button):
    /// let (kept, again) = stream.reload("bundle".as_ref())?;
    /// eprintln!("terrain: {kept} tiles kept, {again} read again");
    /// # Ok(()) }
    /// ```
    pub fn reload(&mut self, dir: &Path) -> Result<(usize, usize), RuntimeError> {
        let index = TileIndex::open(dir)?;
        let map = self.binder.tiles.map.clone();
        let layout = TileLayout::new(&map, |part, level, at| index.tile(part, level, at))?;
        if layout != self.binder.tiles {
            return Err(RuntimeError::Asset {
                asset: map,
                message: "the rebake changed the map's tiling (tile size, levels or parts): open the stream again"
                    .into(),
            });
        }
        let parts = &self.binder.tiles.parts;
        let unchanged = |key: Key| {
            tile_unchanged(parts, key, |part, k| {
                (self.index.tile(part, k.0, (k.1, k.2)), index.tile(part, k.0, (k.1, k.2)))
            })
        };
        let counts = self.residency.reload(unchanged);
        self.reads.generation += 1;
        self.reads.pending.clear();
        let _ = self.reads.requests.send(Request::Index(Box::new(index.clone()), self.reads.generation));
        self.index = index;
        Ok(counts)
    }

    /// Draws the tiles the last [`update`](TerrainStream::update) chose into `pass`, whose
    /// attachments must match the options the stream was opened with.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        self.program.bind(pass);
        for r in self.drawn.iter().filter_map(|key| self.residency.get(*key)) {
            pass.set_bind_group(self.program.group, &r.binding.bind_group, &[]);
            pass.draw(0..r.binding.vertices, 0..1);
        }
    }

    /// The tiles the next [`draw`](TerrainStream::draw) draws: level, column and row, and where
    /// each lies in the map frame (its first and last node, world units along `u` and `v`).
    pub fn drawn(&self) -> impl Iterator<Item = ((u32, u32, u32), [(f32, f32); 2])> + '_ {
        self.drawn.iter().map(|&key| (key, self.binder.tiles.rect(key)))
    }

    /// The WGSL of the terrain (bindings at the chosen group), as [`super::TerrainShadows::wgsl`].
    pub fn wgsl(&self) -> &str {
        &self.program.wgsl
    }
}

impl SunFieldSource for TerrainStream {
    fn field_terrain(&self) -> FieldTerrain<'_> {
        let tiles = &self.binder.tiles;
        let level0 = &tiles.levels[0];
        let pieces = self
            .drawn
            .iter()
            .filter_map(|&key| {
                let r = self.residency.get(key)?;
                let grid = tiles.levels[key.0 as usize].grid;
                let statics = &r.binding.statics;
                let edges = u32::from(key.1 == 0)
                    | u32::from(key.2 == 0) << 1
                    | u32::from(key.1 + 1 == grid.0) << 2
                    | u32::from(key.2 + 1 == grid.1) << 3;
                Some(FieldTile {
                    group: &r.binding.bind_group,
                    key,
                    offset: Vec2::new(r.offset.0, r.offset.1),
                    texel: Vec2::from(statics.texel_size),
                    size: (statics.size[0], statics.size[1]),
                    edges,
                })
            })
            .collect();
        let texel = Vec2::new(level0.texel.0, level0.texel.1);
        FieldTerrain {
            layout: &self.binder.layout,
            map_size: texel * Vec2::new(level0.size.0 as f32, level0.size.1 as f32),
            texel,
            directions: self.directions,
            reach: self.reach,
            tiles: pieces,
        }
    }
}

/// Reads and checks tile `key`'s payloads: heights (with an apron from the neighbouring tiles'
/// heights), horizons and, when baked, occlusion.
fn load_tile(index: &TileIndex, parts: &TileParts, key: Key) -> Result<Vec<CpuAsset>, RuntimeError> {
    let (level, x, y) = key;
    let read = |part: &str, (x, y): (u32, u32)| -> Result<Option<(Asset, TextureData)>, RuntimeError> {
        match index.tile(part, level, (x, y)) {
            Some(asset) => Ok(Some((asset.clone(), index.read_texture(&asset)?))),
            None => Ok(None),
        }
    };
    let mut out = Vec::new();
    for part in parts.all() {
        let (asset, mut texture) = read(part, (x, y))?.ok_or_else(|| RuntimeError::Asset {
            asset: hikage_bundle::tiles::tile_id(part, level, (x, y)),
            message: "the tile table has no such tile".into(),
        })?;
        if part == parts.height {
            // The neighbours' heights next to the edges, for the edge texels' normals.
            let mut sides = [None, None, None, None];
            for (side, n) in sides.iter_mut().zip(apron_neighbours(key)) {
                if let Some((_, nx, ny)) = n {
                    *side = read(part, (nx, ny))?.map(|(_, t)| t);
                }
            }
            texture = heights_with_apron(&texture, &sides);
        }
        out.push(CpuAsset { asset, payload: PayloadData::Texture(texture) });
    }
    Ok(out)
}

/// What every tile of a stream is bound with: the parts it reads, the levels' geometry, the
/// skirt, and the bind group layout.
#[derive(Debug)]
struct Binder {
    /// The map's parts and levels.
    tiles: TileLayout,
    skirt_texels: f32,
    layout: wgpu::BindGroupLayout,
    filterable: bool,
}

/// Uploads a loaded tile and binds it.
fn upload(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    binder: &Binder,
    key: Key,
    assets: &[CpuAsset],
) -> Result<Resident, RuntimeError> {
    let (horizon, ao) = (&binder.tiles.parts.horizon, &binder.tiles.parts.ao);
    let (levels, skirt_texels, layout) =
        (&binder.tiles.levels, binder.skirt_texels, (&binder.layout, binder.filterable));
    let mut textures = GpuBundle::default();
    for a in assets {
        textures.insert(device, queue, a)?;
    }
    let id = |part: &str| hikage_bundle::tiles::tile_id(part, key.0, (key.1, key.2));
    let ao_id = ao.as_deref().map(id);
    let level = &levels[key.0 as usize];
    let skirt = skirt_texels * level.texel.0.max(level.texel.1);
    let binding = TerrainBinding::new(device, queue, &textures, (&id(horizon), ao_id.as_deref()), (skirt, 1), layout)?;
    let bytes = textures.textures.values().map(|t| t.desc.total_bytes().unwrap_or(0)).sum();
    let offset = binder.tiles.offset(key);
    Ok(Resident { binding, _textures: textures, bytes, offset })
}
