//! [`TerrainStream`]: a terrain baked in tiles with levels of detail (a `Horizon` job with `tile`
//! and `levels`), drawn from the tiles near the camera and coarser ones farther out, loaded on
//! a thread of its own and uploaded within a byte budget a frame.

use std::collections::{HashMap, HashSet, VecDeque};
use std::path::Path;
use std::sync::mpsc;

use glam::{Mat4, Vec3};
use hikage_bundle::tiles::TileIndex;
use hikage_bundle::{Asset, PayloadData, TextureData};

use super::horizon_filterable;
use super::terrain::{TerrainBinding, TerrainExtent, TerrainFrame, terrain_layout, terrain_program};
use crate::draw::DrawOptions;
use crate::error::RuntimeError;
use crate::gpu;
use crate::load::CpuAsset;
use crate::upload::GpuBundle;

/// Requests in flight to the loader thread at most: enough to keep it busy, few enough that a
/// camera turning round does not leave a long queue of tiles no longer wanted.
const MAX_PENDING: usize = 8;

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

/// A tile: level of detail, column and row in the level's grid.
type Key = (u32, u32, u32);

/// What the loader thread sends back: a tile's payloads read and checked, or why not.
type Loaded = (Key, Result<Vec<CpuAsset>, RuntimeError>);

/// One level of the map: its grid of tiles and where its tiles lie.
#[derive(Clone, Copy, Debug)]
struct Level {
    /// Tiles along `u` and `v`.
    grid: (u32, u32),
    /// The level's size in nodes.
    size: (u32, u32),
    /// World units per node.
    texel: (f32, f32),
}

/// A tile on the device.
#[derive(Debug)]
struct Resident {
    binding: TerrainBinding,
    /// Holds the textures the bind group samples.
    _textures: GpuBundle,
    bytes: u64,
    last_used: u64,
    /// Level-0 map frame → tile frame offset (world units along `u`, `v`).
    offset: (f32, f32),
}

/// A terrain baked in tiles and levels of detail, streamed around a camera.
///
/// - **Choice of level:** by distance (say [`StreamOptions::detail`]): from the coarsest level's
///   tiles down, a tile is replaced by its four finer tiles while the camera is within `detail`
///   tile widths of it, horizontally, until [`StreamOptions::finest_level`].
/// - **Loading:** a thread of its own reads, hashes and decodes the tiles asked for (at most 8 in
///   flight, coarser and nearer first); [`update`](TerrainStream::update) never waits on it.
/// - **Uploads:** at most [`StreamOptions::upload_bytes`] of textures an update.
/// - **Residency:** at most [`StreamOptions::resident_bytes`]. Tiles are wanted in order of
///   their distance in tile widths (the tile under the camera first, then the coarser); to make
///   room, tiles no longer wanted go first (least recently drawn first), then wanted ones less
///   wanted than the tile coming in; never a tile drawn now, never the coarsest level's, which
///   stay so that there is always terrain to draw.
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
    /// Part ids (heights, horizons and, when baked, occlusion), levels, layout.
    binder: Binder,
    /// Level-0 tile size in nodes (every level's tiles hold as many, plus one).
    tile: u32,
    resident: HashMap<Key, Resident>,
    requests: mpsc::Sender<Key>,
    results: mpsc::Receiver<Loaded>,
    pending: HashSet<Key>,
    ready: VecDeque<(Key, Vec<CpuAsset>)>,
    drawn: Vec<Key>,
    frame: u64,
    extent: TerrainExtent,
}

impl TerrainStream {
    /// Opens the tiles of map `map` (the tiled job's id) in the bundle in `dir`, loads its
    /// coarsest level before returning (so there is always terrain to draw) and starts the
    /// loader thread. Refuses tiles wider than [`MAX_TILE_SIDE`], a coarsest level larger than
    /// the resident budget, and a tile larger than the upload budget.
    pub fn open(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        dir: &Path,
        map: &str,
        draw: &DrawOptions,
        options: StreamOptions,
    ) -> Result<TerrainStream, RuntimeError> {
        let index = TileIndex::open(dir)?;
        let set = index.sets().find(|s| s.map == map).ok_or_else(|| RuntimeError::Asset {
            asset: map.to_string(),
            message: format!(
                "no map baked in tiles of that name; the bundle has: {}",
                index.sets().map(|s| s.map.as_str()).collect::<Vec<_>>().join(", ")
            ),
        })?;
        let part =
            |kind: &str| set.parts.iter().any(|p| p.id == format!("{map}.{kind}")).then(|| format!("{map}.{kind}"));
        let bad = |message: String| RuntimeError::Asset { asset: map.to_string(), message };
        let (Some(height), Some(horizon)) = (part("height"), part("horizon")) else {
            return Err(bad("expected the tiles of a Horizon job: `<map>.height` and `<map>.horizon`".into()));
        };
        let parts = (height, horizon, part("ao"));
        // Each level's grid and geometry from its first tile.
        let mut levels = Vec::new();
        let mut tile = 0;
        while let Some(first) = index.tile(&parts.1, levels.len() as u32, (0, 0)) {
            let settings = first.settings.horizon().ok_or_else(|| bad(format!("`{}` is not a horizon", first.id)))?;
            let place = settings.tile.clone().ok_or_else(|| bad(format!("`{}` has no tile placement", first.id)))?;
            let (w, h) = first.payload.texture().map_or((0, 0), |t| (t.width, t.height));
            if w.max(h) > MAX_TILE_SIDE {
                return Err(bad(format!(
                    "tiles of {w}×{h} texels: a streamed terrain holds tiles of at most {MAX_TILE_SIDE} a side (bake with tile ≤ {})",
                    MAX_TILE_SIDE - 1
                )));
            }
            if levels.is_empty() {
                tile = w.max(h).saturating_sub(1).max(1);
            }
            let count = |n: u32| n.saturating_sub(1).div_ceil(tile).max(1);
            levels.push(Level {
                grid: (count(place.map_size.0), count(place.map_size.1)),
                size: place.map_size,
                texel: settings.texel_size,
            });
        }
        let Some(coarsest) = levels.last().copied() else {
            return Err(bad("no level-0 tile `(0, 0)`".into()));
        };
        let first = index.tile(&parts.1, 0, (0, 0)).expect("found above");
        let format = first.payload.texture().map(|t| t.format).expect("a texture");
        let filterable = horizon_filterable(device, format);
        let layout = terrain_layout(device, filterable);

        // The loader thread: a clone of the index, one tile's payloads per request.
        let (requests, to_load) = mpsc::channel::<Key>();
        let (loaded, results) = mpsc::channel::<Loaded>();
        let loader = index.clone();
        let loader_parts = parts.clone();
        std::thread::Builder::new()
            .name(format!("hikage terrain {map}"))
            .spawn(move || {
                while let Ok(key) = to_load.recv() {
                    if loaded.send((key, load_tile(&loader, &loader_parts, key))).is_err() {
                        break;
                    }
                }
            })
            .map_err(|e| bad(format!("could not start the loader thread: {e}")))?;

        let binder = Binder {
            parts: parts.clone(),
            levels: levels.clone(),
            skirt_texels: options.skirt_texels,
            layout: layout.clone(),
            filterable,
        };
        // What a tile holds on the device, from its entries (a heights apron of one texel more
        // on every side): the coarsest level's tiles and a level-0 tile, the largest, must fit
        // the budgets before anything is read.
        let tile_bytes = |key: Key| -> u64 {
            [Some(&parts.0), Some(&parts.1), parts.2.as_ref()]
                .into_iter()
                .flatten()
                .filter_map(|p| index.tile(p, key.0, (key.1, key.2)))
                .filter_map(|a| {
                    let t = a.payload.texture()?;
                    let apron = if a.settings.heightfield().is_some() { 2 } else { 0 };
                    hikage_bundle::TextureDesc { width: t.width + apron, height: t.height + apron, ..t.clone() }
                        .total_bytes()
                })
                .sum()
        };
        let roots: Vec<Key> = grid_keys(levels.len() as u32 - 1, coarsest.grid).collect();
        let root_bytes: u64 = roots.iter().map(|&k| tile_bytes(k)).sum();
        let largest = tile_bytes((0, 0, 0));
        if root_bytes + largest > options.resident_bytes {
            return Err(bad(format!(
                "the coarsest level's {} tiles hold {root_bytes} bytes and a level-0 tile {largest}: above the \
                 resident budget of {} (bake levels of detail, `levels: Some(16)`, or raise the budget)",
                roots.len(),
                options.resident_bytes
            )));
        }
        if largest > options.upload_bytes {
            return Err(bad(format!(
                "a level-0 tile holds {largest} bytes, above the upload budget of {} a frame",
                options.upload_bytes
            )));
        }
        // The coarsest level, now: there is always terrain to draw.
        let mut resident = HashMap::new();
        let mut program = None;
        for &key in &roots {
            let assets = load_tile(&index, &parts, key)?;
            let r = upload(device, queue, &binder, key, &assets)?;
            if program.is_none() {
                let group = (layout.clone(), r.binding.bind_group.clone());
                program = Some(terrain_program(device, map, group, draw)?);
            }
            resident.insert(key, r);
        }
        let (sx, sy) = levels[0].texel;
        let (w, h) = levels[0].size;
        let (low, high) = resident.values().fold((f32::MAX, f32::MIN), |(lo, hi), r| {
            (lo.min(r.binding.extent.height_range.0), hi.max(r.binding.extent.height_range.1))
        });
        let extent = TerrainExtent {
            size: (w, h),
            texel_size: (sx, sy),
            height_range: (low, high),
            min: Vec3::new(0.5 * sx, low, 0.5 * sy),
            max: Vec3::new((w as f32 - 0.5) * sx, high, (h as f32 - 0.5) * sy),
        };
        Ok(TerrainStream {
            program: program.expect("at least one coarsest tile"),
            options,
            binder,
            tile,
            resident,
            requests,
            results,
            pending: HashSet::new(),
            ready: VecDeque::new(),
            drawn: Vec::new(),
            frame: 0,
            extent,
        })
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
        self.frame += 1;
        let cam = frame.model.inverse().transform_point3(eye);
        // 1. What to draw, and what is wanted (in the order it is wanted).
        let mut wanted = Vec::new();
        let mut drawn = Vec::new();
        let top = self.binder.levels.len() as u32 - 1;
        for key in grid_keys(top, self.binder.levels[top as usize].grid) {
            self.visit(key, (cam.x, cam.z), &mut wanted, &mut drawn);
        }
        // Most wanted first: the nearest in tile widths (the tile under the camera at 0), then
        // the coarser.
        let mut ranked: Vec<(f32, Key)> = wanted.iter().map(|&k| (self.remoteness(k, (cam.x, cam.z)), k)).collect();
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.0.cmp(&a.1.0)).then(a.1.cmp(&b.1)));
        let wanted: Vec<Key> = ranked.iter().map(|&(_, k)| k).collect();
        let rank: HashMap<Key, usize> = wanted.iter().enumerate().map(|(i, &k)| (k, i)).collect();
        let missing = wanted.iter().filter(|k| !self.resident.contains_key(k)).count();
        // 2. What the loader finished.
        let mut failure = None;
        while let Ok((key, result)) = self.results.try_recv() {
            self.pending.remove(&key);
            match result {
                Ok(assets) => self.ready.push_back((key, assets)),
                Err(e) => failure = failure.or(Some(e)),
            }
        }
        let wanted_set: HashSet<Key> = wanted.iter().copied().collect();
        self.ready.retain(|(key, _)| wanted_set.contains(key) && !self.resident.contains_key(key));
        self.ready.make_contiguous().sort_by_key(|(key, _)| rank.get(key).copied().unwrap_or(usize::MAX));
        // 3. Requests, coarser and nearer first (the order of `wanted`).
        for &key in &wanted {
            if self.pending.len() >= MAX_PENDING {
                break;
            }
            let queued = self.pending.contains(&key) || self.ready.iter().any(|(k, _)| *k == key);
            if !self.resident.contains_key(&key) && !queued && self.requests.send(key).is_ok() {
                self.pending.insert(key);
            }
        }
        // 4. Uploads within the frame's budget, making room by evicting.
        let mut uploaded = 0u64;
        // Tiles drawn now stay; a wanted tile goes only for a more wanted one.
        let drawn_set: HashSet<Key> = drawn.iter().copied().collect();
        while let Some((key, assets)) = self.ready.pop_front() {
            let bytes: u64 = assets.iter().filter_map(|a| a.texture()).map(|t| t.desc.total_bytes().unwrap_or(0)).sum();
            let fits = uploaded + bytes <= self.options.upload_bytes;
            if !fits || !self.make_room(bytes, rank.get(&key).copied().unwrap_or(usize::MAX), &rank, &drawn_set) {
                self.ready.push_front((key, assets));
                break;
            }
            match upload(device, queue, &self.binder, key, &assets) {
                Ok(mut r) => {
                    r.last_used = self.frame;
                    uploaded += r.bytes;
                    self.resident.insert(key, r);
                }
                Err(e) => failure = failure.or(Some(e)),
            }
        }
        // 5. The drawn tiles' uniforms.
        for key in &drawn {
            let r = self.resident.get_mut(key).expect("drawn tiles are resident");
            r.last_used = self.frame;
            let model = frame.model * Mat4::from_translation(Vec3::new(r.offset.0, 0.0, r.offset.1));
            let uniform = r.binding.uniform(&TerrainFrame { model, ..*frame });
            queue.write_buffer(&r.binding.uniform, 0, bytemuck::bytes_of(&uniform));
        }
        let stats = StreamStats {
            resident_tiles: self.resident.len(),
            resident_bytes: self.resident.values().map(|r| r.bytes).sum(),
            uploaded_bytes: uploaded,
            drawn: drawn.len(),
            missing,
            finest_drawn: drawn.iter().map(|k| k.0).min().unwrap_or(top),
        };
        self.drawn = drawn;
        match failure {
            Some(e) => Err(e),
            None => Ok(stats),
        }
    }

    /// Draws the tiles the last [`update`](TerrainStream::update) chose into `pass`, whose
    /// attachments must match the options the stream was opened with.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        self.program.bind(pass);
        for r in self.drawn.iter().filter_map(|key| self.resident.get(key)) {
            pass.set_bind_group(self.program.group, &r.binding.bind_group, &[]);
            pass.draw(0..r.binding.vertices, 0..1);
        }
    }

    /// The tiles the next [`draw`](TerrainStream::draw) draws: level, column and row, and where
    /// each lies in the map frame (its first and last node, world units along `u` and `v`).
    pub fn drawn(&self) -> impl Iterator<Item = ((u32, u32, u32), [(f32, f32); 2])> + '_ {
        self.drawn.iter().map(|&key| (key, self.rect(key)))
    }

    /// The WGSL of the terrain (bindings at the chosen group), as [`super::TerrainShadows::wgsl`].
    pub fn wgsl(&self) -> &str {
        &self.program.wgsl
    }

    /// Tile `key`'s first and last node in the map frame (world units along `u`, `v`).
    fn rect(&self, (level, x, y): Key) -> [(f32, f32); 2] {
        let l = &self.binder.levels[level as usize];
        let s = (1u32 << level) as f32;
        let (sx, sy) = self.binder.levels[0].texel;
        let node = |i: u32, n: u32, t: f32| (i.min(n - 1) as f32 * s + 0.5) * t;
        let (x0, y0) = (x * self.tile, y * self.tile);
        [
            (node(x0, l.size.0, sx), node(y0, l.size.1, sy)),
            (node(x0 + self.tile, l.size.0, sx), node(y0 + self.tile, l.size.1, sy)),
        ]
    }

    /// Adds `key` and, while it is near enough to split, its finer tiles to `wanted`; adds the
    /// tiles that cover its area and are on the device to `drawn`.
    fn visit(&self, key: Key, cam: (f32, f32), wanted: &mut Vec<Key>, drawn: &mut Vec<Key>) {
        wanted.push(key);
        let (level, x, y) = key;
        if level > self.options.finest_level && self.remoteness(key, cam) < self.options.detail {
            let finer = &self.binder.levels[level as usize - 1];
            let children: Vec<Key> = [(0, 0), (1, 0), (0, 1), (1, 1)]
                .into_iter()
                .map(|(i, j)| (level - 1, 2 * x + i, 2 * y + j))
                .filter(|&(_, cx, cy)| cx < finer.grid.0 && cy < finer.grid.1)
                .collect();
            if children.iter().all(|c| self.resident.contains_key(c)) {
                for c in children {
                    self.visit(c, cam, wanted, drawn);
                }
                return;
            }
            wanted.extend(children);
        }
        if self.resident.contains_key(&key) {
            drawn.push(key);
        }
    }

    /// How far tile `key` is from the camera at `cam` (map frame, horizontal), in widths of the
    /// tile: 0 under the camera.
    fn remoteness(&self, key: Key, cam: (f32, f32)) -> f32 {
        let [lo, hi] = self.rect(key);
        let dx = (lo.0 - cam.0).max(cam.0 - hi.0).max(0.0);
        let dy = (lo.1 - cam.1).max(cam.1 - hi.1).max(0.0);
        dx.hypot(dy) / (hi.0 - lo.0).max(hi.1 - lo.1).max(f32::MIN_POSITIVE)
    }

    /// Evicts tiles until `bytes` more fit the resident budget, for a tile of rank `wanted_rank`
    /// in `rank` (the tiles wanted now, most wanted first): first those no longer wanted, least
    /// recently drawn first, then wanted ones less wanted than it, least wanted first; never a
    /// tile in `drawn` nor one of the coarsest level. False when the bytes cannot be found.
    fn make_room(&mut self, bytes: u64, wanted_rank: usize, rank: &HashMap<Key, usize>, drawn: &HashSet<Key>) -> bool {
        let top = self.binder.levels.len() as u32 - 1;
        loop {
            let resident: u64 = self.resident.values().map(|r| r.bytes).sum();
            if resident + bytes <= self.options.resident_bytes {
                return true;
            }
            // (wanted, how little, how long unused): the smallest goes first.
            let victim = self
                .resident
                .iter()
                .filter(|(k, _)| k.0 != top && !drawn.contains(k))
                .filter(|(k, _)| rank.get(k).is_none_or(|&r| r > wanted_rank))
                .min_by_key(|(k, r)| match rank.get(k) {
                    None => (0, 0, r.last_used, **k),
                    Some(&at) => (1, usize::MAX - at, r.last_used, **k),
                })
                .map(|(k, _)| *k);
            match victim {
                Some(k) => {
                    self.resident.remove(&k);
                }
                None => return false,
            }
        }
    }
}

/// The keys of every tile of a level's `grid`.
fn grid_keys(level: u32, grid: (u32, u32)) -> impl Iterator<Item = Key> {
    (0..grid.1).flat_map(move |y| (0..grid.0).map(move |x| (level, x, y)))
}

/// Reads and checks tile `key`'s payloads: heights (with an apron from the neighbouring tiles'
/// heights), horizons and, when baked, occlusion.
fn load_tile(
    index: &TileIndex,
    (height, horizon, ao): &(String, String, Option<String>),
    (level, x, y): Key,
) -> Result<Vec<CpuAsset>, RuntimeError> {
    let read = |part: &str, (x, y): (u32, u32)| -> Result<Option<(Asset, TextureData)>, RuntimeError> {
        match index.tile(part, level, (x, y)) {
            Some(asset) => Ok(Some((asset.clone(), index.read_texture(&asset)?))),
            None => Ok(None),
        }
    };
    let mut out = Vec::new();
    for part in [Some(height), Some(horizon), ao.as_ref()].into_iter().flatten() {
        let (asset, mut texture) = read(part, (x, y))?.ok_or_else(|| RuntimeError::Asset {
            asset: format!("{part}{}", hikage_bundle::tiles::tile_suffix(level, (x, y))),
            message: "the tile table has no such tile".into(),
        })?;
        if part == height {
            // The neighbours' heights next to the edges, for the edge texels' normals.
            let neighbour = |dx: i64, dy: i64| -> Result<Option<TextureData>, RuntimeError> {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if nx < 0 || ny < 0 {
                    return Ok(None);
                }
                Ok(read(part, (nx as u32, ny as u32))?.map(|(_, t)| t))
            };
            let sides = [neighbour(-1, 0)?, neighbour(1, 0)?, neighbour(0, -1)?, neighbour(0, 1)?];
            texture = with_apron(&texture, &sides);
        }
        out.push(CpuAsset { asset, payload: PayloadData::Texture(texture) });
    }
    Ok(out)
}

/// `heights` with one more texel on every side: next to each edge the texel beside the shared
/// edge in the neighbouring tile (`[left, right, above, below]`), or the edge texel itself at
/// the map's edge (as the one-mesh terrain clamps).
fn with_apron(heights: &TextureData, [left, right, above, below]: &[Option<TextureData>; 4]) -> TextureData {
    let (w, h) = (heights.desc.width as usize, heights.desc.height as usize);
    let tb = heights.desc.format.texel_bytes();
    let src = &heights.levels[0];
    let (aw, ah) = (w + 2, h + 2);
    let mut out = vec![0u8; aw * ah * tb];
    let texel = |t: &TextureData, x: usize, y: usize| -> Vec<u8> {
        let tw = t.desc.width as usize;
        t.levels[0][(y * tw + x) * tb..][..tb].to_vec()
    };
    let put = |out: &mut Vec<u8>, x: usize, y: usize, v: &[u8]| out[(y * aw + x) * tb..][..tb].copy_from_slice(v);
    for y in 0..h {
        out[((y + 1) * aw + 1) * tb..][..w * tb].copy_from_slice(&src[y * w * tb..][..w * tb]);
        // A neighbour of another size (none here: a row of tiles shares its rows) is ignored.
        let l = left.as_ref().filter(|t| t.desc.height as usize == h && t.desc.width >= 2);
        let r = right.as_ref().filter(|t| t.desc.height as usize == h && t.desc.width >= 2);
        put(&mut out, 0, y + 1, &l.map_or_else(|| texel(heights, 0, y), |t| texel(t, t.desc.width as usize - 2, y)));
        put(&mut out, w + 1, y + 1, &r.map_or_else(|| texel(heights, w - 1, y), |t| texel(t, 1, y)));
    }
    for x in 0..w {
        let a = above.as_ref().filter(|t| t.desc.width as usize == w && t.desc.height >= 2);
        let b = below.as_ref().filter(|t| t.desc.width as usize == w && t.desc.height >= 2);
        put(&mut out, x + 1, 0, &a.map_or_else(|| texel(heights, x, 0), |t| texel(t, x, t.desc.height as usize - 2)));
        put(&mut out, x + 1, h + 1, &b.map_or_else(|| texel(heights, x, h - 1), |t| texel(t, x, 1)));
    }
    for (cx, cy, sx, sy) in [(0, 0, 0, 0), (w + 1, 0, w - 1, 0), (0, h + 1, 0, h - 1), (w + 1, h + 1, w - 1, h - 1)] {
        put(&mut out, cx, cy, &texel(heights, sx, sy));
    }
    let desc = hikage_bundle::TextureDesc { width: aw as u32, height: ah as u32, levels: 1, ..heights.desc.clone() };
    TextureData { desc, levels: vec![out] }
}

/// What every tile of a stream is bound with: the parts it reads, the levels' geometry, the
/// skirt, and the bind group layout.
#[derive(Debug)]
struct Binder {
    /// Part ids: heights, horizons and, when baked, occlusion.
    parts: (String, String, Option<String>),
    levels: Vec<Level>,
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
    let (_, horizon, ao) = &binder.parts;
    let (levels, skirt_texels, layout) = (&binder.levels, binder.skirt_texels, (&binder.layout, binder.filterable));
    let mut textures = GpuBundle::default();
    for a in assets {
        textures.insert(device, queue, a)?;
    }
    let suffix = hikage_bundle::tiles::tile_suffix(key.0, (key.1, key.2));
    let ao_id = ao.as_ref().map(|a| format!("{a}{suffix}"));
    let level = &levels[key.0 as usize];
    let skirt = skirt_texels * level.texel.0.max(level.texel.1);
    let binding = TerrainBinding::new(
        device,
        queue,
        &textures,
        (&format!("{horizon}{suffix}"), ao_id.as_deref()),
        (skirt, 1),
        layout,
    )?;
    let bytes = textures.textures.values().map(|t| t.desc.total_bytes().unwrap_or(0)).sum();
    // Level k's node i lies on level 0's texel i·2^k: the tile frame, whose node a is at
    // (a + ½)·texel_k, moves by (origin·2^k + ½ − 2^(k−1))·texel_0.
    let place = assets[0].asset.settings.tile().cloned().unwrap_or_else(|| hikage_bundle::TilePlacement {
        map: String::new(),
        index: (key.1, key.2),
        origin: (0, 0),
        map_size: level.size,
        level: key.0,
    });
    let s = (1u32 << key.0) as f32;
    let (sx, sy) = levels[0].texel;
    let offset = ((place.origin.0 as f32 * s + 0.5 - 0.5 * s) * sx, (place.origin.1 as f32 * s + 0.5 - 0.5 * s) * sy);
    Ok(Resident { binding, _textures: textures, bytes, last_used: 0, offset })
}
