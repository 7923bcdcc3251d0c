//! Terrain of any size: [`StreamedTerrain`] draws a map baked in tiles and levels of detail
//! from the tiles near the camera and coarser ones farther out, each tile read through Bevy's
//! asset source on its async compute task pool and added within a byte budget a frame. The choice of
//! tiles is hikage-runtime's `TerrainStream`'s ([`TileLayout::plan`]); each tile is drawn with
//! the [`TerrainMaterial`] of [`crate::HorizonTerrain`].

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use bevy_asset::io::{AssetSourceId, Reader};
use bevy_asset::{AssetEvent, AssetId, AssetServer, Assets, Handle, RenderAssetUsages};
use bevy_camera::primitives::Aabb;
use bevy_camera::visibility::Visibility;
use bevy_camera::{Camera, Camera3d};
use bevy_ecs::prelude::*;
use bevy_image::Image;
use bevy_light::NotShadowCaster;
use bevy_mesh::{Mesh, Mesh3d};
use bevy_pbr::{ExtendedMaterial, MeshMaterial3d, StandardMaterial};
use bevy_tasks::{AsyncComputeTaskPool, Task};
use bevy_transform::components::{GlobalTransform, Transform};
use hikage_bundle::{Asset as Entry, Limits, Manifest, TextureData};
use hikage_runtime::horizon::{
    BudgetShortfall, HorizonEncoding, StreamOptions, StreamStats, TileKey, TileLayout, TileReads, TileResidency,
    TileStore, apron_neighbours, check_budgets, heights_with_apron, tile_unchanged,
};

use hikage_runtime::glam::Vec2;
use hikage_runtime::horizon::FieldMap;

use crate::diagnostics::{Check, NamesBundle, Problems, SunShadowed};
use crate::field::FieldPiece;
use crate::terrain::{TerrainExtension, TerrainMaterial, TerrainUniform};
use crate::{HikageBundle, RegisteredLoader};

/// Draws a terrain baked in tiles and levels of detail (a `Horizon` job with `tile` and
/// `levels`), streamed around the first active 3D camera: put it on an entity with a
/// `Transform`, which places the map frame (level 0's texel `(i, j)` at `((i + ½)·sx, h,
/// (j + ½)·sy)`, as [`crate::HorizonTerrain`]'s).
///
/// - **Level of detail by distance:** from the coarsest level down, a tile is replaced by its
///   four finer tiles while the camera is within [`StreamOptions::detail`] tile widths of it,
///   horizontally; a tile stays drawn until all four of its finer tiles are ready.
/// - **Loading** never blocks a frame: the tiles' payloads are read through the bundle's Bevy
///   asset source (files, the web, an embedded source alike), checked (size, BLAKE3, contents)
///   and made into meshes and images on Bevy's async compute task pool (not the IO pool, where
///   the bundle's own load runs), at most 8 at a time.
/// - **Budgets:** at most [`StreamOptions::upload_bytes`] of new tiles a frame and
///   [`StreamOptions::resident_bytes`] resident, counting each tile's textures as the device
///   holds them and its mesh's vertices and indices. Tiles no longer wanted go first, least
///   recently drawn first; the coarsest level's tiles always stay, so there is always terrain.
/// - **Cracks** where two levels meet are hidden by skirts ([`StreamOptions::skirt_texels`]).
/// - Every tile's textures are at most `MAX_TILE_SIDE` (2048) a side.
///
/// Each tile is a child entity with a [`TerrainTile`], Bevy's `Mesh3d` and a
/// [`TerrainMaterial`]; the sun is the scene's first `DirectionalLight`, with
/// `shadow_maps_enabled`, as for [`crate::HorizonTerrain`]. A `NotShadowCaster` on this entity
/// is given to its tiles. What the stream holds is in its [`TerrainStreamStats`].
///
/// ```no_run
/// use bevy::prelude::*;
/// use hikage_bevy::StreamedTerrain;
///
/// fn setup(mut commands: Commands, assets: Res<AssetServer>) {
///     // The tiles of the `terrain` job (`tile: Some(256), levels: Some(16)`).
///     commands.spawn(StreamedTerrain::new(assets.load("bundle/bundle.ron"), "terrain"));
/// }
/// ```
#[derive(Component, Clone, Debug)]
#[require(Transform, Visibility, Problems, TerrainStreamStats)]
pub struct StreamedTerrain {
    /// The bundle holding the tiles.
    pub bundle: Handle<HikageBundle>,
    /// The tiled job's id: its tiles are `<map>.height`, `<map>.horizon` and, when baked,
    /// `<map>.ao` (their AO is used).
    pub map: String,
    /// Budgets and level of detail.
    pub options: StreamOptions,
    /// The surface under the shadows (colour, roughness); every tile gets a copy.
    pub base: StandardMaterial,
}

impl StreamedTerrain {
    /// The tiles of map `map` in `bundle`, white and rough, with the default budgets (256 MiB
    /// resident, 32 MiB a frame).
    pub fn new(bundle: Handle<HikageBundle>, map: impl Into<String>) -> StreamedTerrain {
        StreamedTerrain {
            bundle,
            map: map.into(),
            options: StreamOptions::default(),
            base: StandardMaterial { perceptual_roughness: 1.0, ..StandardMaterial::default() },
        }
    }

    /// The same with `options` (budgets, level of detail, skirts).
    pub fn with_options(mut self, options: StreamOptions) -> StreamedTerrain {
        self.options = options;
        self
    }

    /// The same over `base` (colour, roughness).
    pub fn with_base(mut self, base: StandardMaterial) -> StreamedTerrain {
        self.base = base;
        self
    }
}

/// What a [`StreamedTerrain`] holds after the last frame, and what that frame did.
///
/// ```no_run
/// use bevy::prelude::*;
/// use hikage_bevy::TerrainStreamStats;
///
/// fn report(terrains: Query<&TerrainStreamStats>) {
///     for stats in &terrains {
///         info!("{} tiles, {} bytes resident", stats.0.resident_tiles, stats.0.resident_bytes);
///     }
/// }
/// ```
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TerrainStreamStats(pub StreamStats);

/// One tile of a [`StreamedTerrain`], on each of its child entities (hidden while not drawn).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct TerrainTile {
    /// Level of detail (0: the map as baked), column and row in the level's grid of tiles.
    pub key: TileKey,
    /// The tile's first and last node in the map frame (world units along `u` and `v`).
    pub rect: [(f32, f32); 2],
}

impl NamesBundle for StreamedTerrain {
    fn bundle(&self) -> &Handle<HikageBundle> {
        &self.bundle
    }
}

impl SunShadowed for StreamedTerrain {}

/// The stream of one [`StreamedTerrain`] (on its entity).
#[derive(Component)]
pub(crate) struct Streaming {
    /// The bundle it was built from (a rebake builds it again, keeping the unchanged tiles).
    bundle: AssetId<HikageBundle>,
    layout: TileLayout,
    /// What a tile of each level holds (its tile `(0, 0)`, the largest).
    level_bytes: Vec<u64>,
    /// The budget's shortfall for level 0 under the camera, said as a `HikageError`.
    shortfall: Option<BudgetShortfall>,
    /// The tiles held and waiting to be added.
    residency: TileResidency<Resident, Loaded>,
    /// The tiles being read, and the manifest and files they are read from.
    reads: TaskReads,
    /// The map as its receivers' sun field sees it, or why it cannot have one.
    pub(crate) field: Result<FieldMap, String>,
    /// This stream among all streams built (a rebuilt stream gets a new field).
    pub(crate) generation: u64,
    /// The tiles drawn after the last frame.
    pub(crate) drawn: Vec<TileKey>,
}

impl Streaming {
    /// What the sun field reads of the tiles drawn now.
    pub(crate) fn drawn_pieces(&self) -> impl Iterator<Item = &FieldPiece> {
        self.drawn.iter().filter_map(|k| self.residency.get(*k)).map(|r| &r.piece)
    }
}

/// A tile's entity, whether it is shown, and what the terrain's sun field reads of it.
struct Resident {
    entity: Entity,
    shown: bool,
    piece: FieldPiece,
}

/// The tiles being read on the async compute task pool, and what starting a read needs.
struct TaskReads {
    tasks: HashMap<TileKey, Task<Result<Loaded, String>>>,
    server: AssetServer,
    source: AssetSourceId<'static>,
    dir: PathBuf,
    manifest: Arc<Manifest>,
    layout: TileLayout,
    features: hikage_runtime::wgpu::Features,
    skirt_texels: f32,
}

impl TileReads<Loaded, String> for TaskReads {
    fn finished(&mut self) -> Vec<(TileKey, Result<Loaded, String>)> {
        let mut done = Vec::new();
        for (key, task) in self.tasks.iter_mut() {
            if let Some(result) = bevy_tasks::futures::check_ready(task) {
                done.push((*key, result));
            }
        }
        for (key, _) in &done {
            self.tasks.remove(key);
        }
        done
    }

    /// Dropping a task stops its read.
    fn retain(&mut self, wanted: &dyn Fn(TileKey) -> bool) {
        self.tasks.retain(|key, _| wanted(*key));
    }

    fn reading(&self, key: TileKey) -> bool {
        self.tasks.contains_key(&key)
    }

    fn in_flight(&self) -> usize {
        self.tasks.len()
    }

    fn start(&mut self, key: TileKey) -> Result<(), String> {
        let request = request(&self.manifest, &self.layout, key)?;
        let task = read_tile(self, request);
        self.tasks.insert(key, task);
        Ok(())
    }
}

/// The world as the residency adds tiles to it: child entities of the terrain.
struct TileEntities<'a, 'w, 's, 't> {
    commands: &'a mut Commands<'w, 's>,
    assets: &'a mut TileAssets<'t>,
    base: &'a StandardMaterial,
    layout: &'a TileLayout,
    parent: Entity,
    no_shadow: bool,
}

impl TileStore<Resident, Loaded, String> for TileEntities<'_, '_, '_, '_> {
    fn bytes(&self, loaded: &Loaded) -> u64 {
        loaded.bytes
    }

    fn add(&mut self, key: TileKey, loaded: Loaded) -> Result<(Resident, u64), String> {
        let bytes = loaded.bytes;
        let (entity, piece) =
            add_tile(self.commands, self.assets, self.base, self.layout, key, loaded, self.parent, self.no_shadow);
        Ok((Resident { entity, shown: false, piece }, bytes))
    }

    fn evict(&mut self, _key: TileKey, tile: Resident) {
        self.commands.entity(tile.entity).despawn();
    }
}

/// A tile read and made ready to add.
struct Loaded {
    mesh: Mesh,
    bounds: Aabb,
    horizon: Image,
    ao: Option<Image>,
    uniform: TerrainUniform,
    /// The tile's heights with its neighbours' apron, as 32-bit floats, and what a sun field
    /// reads with them (the terrain's receivers).
    heights: Image,
    constants: hikage_runtime::horizon::TerrainUniform,
    bytes: u64,
}

/// What reading one tile needs: its entries and its neighbours' heights' entries.
struct Request {
    height: Entry,
    horizon: Entry,
    ao: Option<Entry>,
    neighbours: [Option<Entry>; 4],
}

/// The system's view of a terrain entity.
type TerrainState<'a> = (
    Entity,
    Ref<'a, StreamedTerrain>,
    &'a GlobalTransform,
    Option<&'a mut Streaming>,
    &'a mut Problems,
    &'a mut TerrainStreamStats,
    Has<NotShadowCaster>,
);

/// The asset stores a tile is added to.
#[derive(bevy_ecs::system::SystemParam)]
pub(crate) struct TileAssets<'w> {
    images: ResMut<'w, Assets<Image>>,
    meshes: ResMut<'w, Assets<Mesh>>,
    materials: ResMut<'w, Assets<TerrainMaterial>>,
}

/// Streams every [`StreamedTerrain`]: (re)builds its layout when its bundle (re)loads or the
/// component changes, then chooses, requests, adds, evicts and shows tiles for the camera.
#[expect(clippy::too_many_arguments, reason = "a Bevy system takes what it reads as arguments")]
pub(crate) fn stream_terrain(
    mut commands: Commands,
    server: Res<AssetServer>,
    loader: Res<RegisteredLoader>,
    mut events: MessageReader<AssetEvent<HikageBundle>>,
    bundles: Res<Assets<HikageBundle>>,
    mut assets: TileAssets,
    cameras: Query<(&Camera, &GlobalTransform), With<Camera3d>>,
    mut terrains: Query<TerrainState>,
    mut early: Local<EarlyManifests>,
) {
    let reloaded: Vec<_> =
        events.read().filter_map(|e| if let AssetEvent::Modified { id } = e { Some(*id) } else { None }).collect();
    let eye = cameras.iter().find(|(c, _)| c.is_active).map(|(_, t)| t.translation());
    for (entity, terrain, placed, mut streaming, mut problems, mut stats, no_shadow) in &mut terrains {
        let rebaked =
            streaming.as_ref().is_some_and(|s| reloaded.contains(&s.bundle) && s.bundle == terrain.bundle.id());
        let stale =
            streaming.as_ref().is_none_or(|s| terrain.is_changed() || rebaked || s.bundle != terrain.bundle.id());
        if stale {
            // The loaded bundle's manifest; before it has loaded (its other assets read and
            // checked), the manifest read on its own, so tiles stream from the first frames.
            let loaded = bundles.get(&terrain.bundle).map(|b| Arc::new(b.manifest.clone()));
            if loaded.is_some() {
                // A read begun before the bundle loaded is no longer needed.
                early.0.remove(&entity);
            }
            let Some(manifest) = loaded.or_else(|| early.manifest(&server, &terrain.bundle, entity)) else { continue };
            if problems.get(Check::Build).is_some() && !terrain.is_changed() && !reloaded.contains(&terrain.bundle.id())
            {
                continue;
            }
            let features = loader.0.device_features();
            match start(&server, &terrain, manifest, features) {
                Ok(mut s) => {
                    Problems::set(&mut problems, Check::Build, None);
                    Problems::set(&mut problems, Check::Budget, s.shortfall.as_ref().map(ToString::to_string));
                    match streaming.as_mut() {
                        // A rebake of the same tiling keeps the tiles it left as they were, and
                        // draws the others until their new versions are added.
                        Some(old) if rebaked && !terrain.is_changed() && old.layout == s.layout => {
                            let (before, after) = (old.reads.manifest.clone(), s.reads.manifest.clone());
                            let parts = &s.layout.parts;
                            let unchanged = |key: TileKey| {
                                tile_unchanged(parts, key, |part, k| {
                                    let id = TileLayout::tile_id(part, k);
                                    (before.asset(&id).cloned(), after.asset(&id).cloned())
                                })
                            };
                            old.residency.reload(unchanged);
                            s.residency = std::mem::take(&mut old.residency);
                            s.generation = old.generation;
                            **old = s;
                        }
                        Some(old) => {
                            old.residency.clear(|_, r| commands.entity(r.entity).despawn());
                            **old = s;
                        }
                        None => {
                            commands.entity(entity).insert(s);
                            continue;
                        }
                    }
                }
                Err(message) => {
                    if let Some(old) = streaming.as_mut() {
                        old.residency.clear(|_, r| commands.entity(r.entity).despawn());
                        commands.entity(entity).remove::<Streaming>();
                    }
                    Problems::set(&mut problems, Check::Build, Some(message));
                    continue;
                }
            }
        }
        let (Some(s), Some(eye)) = (streaming.as_deref_mut(), eye) else {
            continue;
        };
        let cam = placed.affine().inverse().transform_point3(eye);
        let mut store = TileEntities {
            commands: &mut commands,
            assets: &mut assets,
            base: &terrain.base,
            layout: &s.layout,
            parent: entity,
            no_shadow,
        };
        let done =
            s.residency.frame((&s.layout, &terrain.options, &s.level_bytes), (cam.x, cam.z), &mut s.reads, &mut store);
        // Show the tiles drawn now (a tile added this frame shows once its mesh and material
        // are ready; an evicted tile's area falls back to its coarser tile).
        let drawn: std::collections::HashSet<TileKey> = done.drawn.iter().copied().collect();
        for (key, r) in s.residency.iter_mut() {
            let show = drawn.contains(&key);
            if show != r.shown {
                r.shown = show;
                let visibility = if show { Visibility::Inherited } else { Visibility::Hidden };
                commands.entity(r.entity).insert(visibility);
            }
        }
        s.drawn = done.drawn;
        stats.0 = done.stats;
        if done.failure.is_some() || problems.get(Check::Tiles).is_some() {
            Problems::set(&mut problems, Check::Tiles, done.failure);
        }
    }
}

/// Manifests read on their own for terrains whose bundle is still loading (its other assets
/// read and checked), by entity: tiles stream without waiting for the rest of the bundle.
#[derive(Default)]
pub(crate) struct EarlyManifests(HashMap<Entity, (AssetId<HikageBundle>, ManifestRead)>);

/// A manifest being read on the async compute task pool.
type ManifestRead = Task<Result<Manifest, String>>;

impl EarlyManifests {
    /// The manifest of `bundle` for `entity` once read; starts reading it (on the async compute pool,
    /// checked as the loader checks it) the first time. `None` while it is read, or when it
    /// cannot be (the bundle's own load then says why).
    fn manifest(
        &mut self,
        server: &AssetServer,
        bundle: &Handle<HikageBundle>,
        entity: Entity,
    ) -> Option<Arc<Manifest>> {
        if let Some((_, task)) = self.0.get_mut(&entity).filter(|(id, _)| *id == bundle.id()) {
            let done = bevy_tasks::futures::check_ready(task)?;
            self.0.remove(&entity);
            return done.ok().map(Arc::new);
        }
        let path = server.get_path(bundle.id())?;
        let (server, source, file) = (server.clone(), path.source().clone_owned(), path.path().to_path_buf());
        let name = path.to_string();
        let task = AsyncComputeTaskPool::get().spawn(async move {
            let (text, names) = crate::loader::manifest_text(read_source(&server, &source, &file).await?, &name)
                .map_err(|e| e.to_string())?;
            let mut tables = std::collections::BTreeMap::new();
            for table in names {
                let bytes = read_source(&server, &source, &file.with_file_name(&table)).await?;
                tables.insert(table, bytes);
            }
            crate::loader::parse_manifest(&text, &name, tables).map_err(|e| e.to_string())
        });
        self.0.insert(entity, (bundle.id(), task));
        None
    }
}

/// The bytes of the file at `path` in asset source `source`; or why not, naming the path.
async fn read_source(server: &AssetServer, source: &AssetSourceId<'static>, path: &Path) -> Result<Vec<u8>, String> {
    let source = server.get_source(source.clone()).map_err(|e| e.to_string())?;
    let mut reader = source.reader().read(path).await.map_err(|e| format!("{}: {e}", path.display()))?;
    let mut bytes = Vec::new();
    reader.read_to_end(&mut bytes).await.map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(bytes)
}

/// The stream of `terrain` over its bundle's `manifest`: the layout of its tiles, checked
/// against the budgets before anything is read; or why not.
fn start(
    server: &AssetServer,
    terrain: &StreamedTerrain,
    manifest: Arc<Manifest>,
    features: hikage_runtime::wgpu::Features,
) -> Result<Streaming, String> {
    let entry = |part: &str, key: TileKey| manifest.asset(&TileLayout::tile_id(part, key)).cloned();
    let layout = TileLayout::new(&terrain.map, |part, level, (x, y)| entry(part, (level, x, y)))
        .map_err(|e| format!("map `{}`: {e}", terrain.map))?;
    let bytes = |key: TileKey| -> u64 {
        let mut total = 0;
        for part in [Some(&layout.parts.horizon), layout.parts.ao.as_ref()].into_iter().flatten() {
            total += entry(part, key).and_then(|e| e.payload.texture()?.total_bytes()).unwrap_or(0);
        }
        let heights = entry(&layout.parts.height, key).and_then(|e| e.payload.texture().cloned());
        // The mesh, and the heights the sun field reads (with their apron, 32-bit floats).
        total + heights.map_or(0, |t| mesh_bytes(t.width, t.height) + 4 * u64::from((t.width + 2) * (t.height + 2)))
    };
    let side = |level: u32| {
        let first = entry(&layout.parts.horizon, (level, 0, 0));
        first.and_then(|e| e.payload.texture().map(|t| (t.width, t.height))).unwrap_or((0, 0))
    };
    let options = &terrain.options;
    let level_bytes =
        check_budgets(&layout, options, side, bytes).map_err(|e| format!("map `{}`: {e}", terrain.map))?;
    let shortfall = layout.budget_shortfall(options, |k| level_bytes[k.0 as usize]);
    let path = server.get_path(terrain.bundle.id()).ok_or("the bundle has no asset path")?;
    static STREAMS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let reads = TaskReads {
        tasks: HashMap::new(),
        server: server.clone(),
        source: path.source().clone_owned(),
        dir: path.path().parent().map(Path::to_path_buf).unwrap_or_default(),
        manifest: manifest.clone(),
        layout: layout.clone(),
        features,
        skirt_texels: options.skirt_texels,
    };
    Ok(Streaming {
        field: field_map(&terrain.map, &layout, entry(&layout.parts.horizon, (0, 0, 0))),
        generation: STREAMS.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        drawn: Vec::new(),
        shortfall,
        bundle: terrain.bundle.id(),
        layout,
        level_bytes,
        residency: TileResidency::default(),
        reads,
    })
}

/// The map of `layout` as a sun field sees it, from its first horizon tile `first`; or why it
/// cannot have one (horizons without distances).
fn field_map(map: &str, layout: &TileLayout, first: Option<Entry>) -> Result<FieldMap, String> {
    let first = first.ok_or_else(|| format!("map `{map}` has no horizon tile (0, 0) at level 0"))?;
    let (Some(settings), Some(texture)) = (first.settings.horizon(), first.payload.texture()) else {
        return Err(format!("`{}` is not a horizon texture", first.id));
    };
    if texture.format.channels() != 2 {
        return Err(format!(
            "map `{map}`'s horizons hold no distances to their horizons (one channel): a receiver needs them; bake \
             it again with this hikage"
        ));
    }
    let level = &layout.levels[0];
    let texel = Vec2::new(level.texel.0, level.texel.1);
    let size = texel * Vec2::new(level.size.0 as f32, level.size.1 as f32);
    Ok(FieldMap { size, texel, directions: settings.directions, reach: settings.max_distance.unwrap_or(size.length()) })
}

/// The bytes of a tile mesh of `w`×`h` nodes with skirts: positions, normals and UVs (32 bytes
/// a vertex) and 4-byte indices.
fn mesh_bytes(w: u32, h: u32) -> u64 {
    let (w, h) = (w as u64, h as u64);
    let ring = 2 * (w + h).saturating_sub(2);
    (w * h + ring) * 32 + 4 * 6 * ((w.saturating_sub(1)) * (h.saturating_sub(1)) + ring)
}

/// The entries tile `key` is read from; or why not (a tile the layout expects is missing).
fn request(manifest: &Manifest, layout: &TileLayout, key: TileKey) -> Result<Request, String> {
    let entry = |part: &str, key: TileKey| manifest.asset(&TileLayout::tile_id(part, key)).cloned();
    let must = |part: &str| {
        entry(part, key).ok_or_else(|| format!("tile `{}` is not in the bundle", TileLayout::tile_id(part, key)))
    };
    Ok(Request {
        height: must(&layout.parts.height)?,
        horizon: must(&layout.parts.horizon)?,
        ao: layout.parts.ao.as_deref().map(must).transpose()?,
        neighbours: apron_neighbours(key).map(|n| n.and_then(|k| entry(&layout.parts.height, k))),
    })
}

/// Starts reading tile `r` on the async compute task pool.
fn read_tile(reads: &TaskReads, r: Request) -> Task<Result<Loaded, String>> {
    let (server, source, dir) = (reads.server.clone(), reads.source.clone(), reads.dir.clone());
    let (skirt_texels, features) = (reads.skirt_texels, reads.features);
    AsyncComputeTaskPool::get().spawn(async move {
        let read = async |entry: &Entry| -> Result<Vec<u8>, String> {
            let path = dir.join(&entry.file);
            let bytes = read_source(&server, &source, &path).await?;
            crate::loader::check(entry, &bytes, &Limits::default())
                .map_err(|e| format!("{}: asset `{}`: {e}", path.display(), entry.id))?;
            Ok(bytes)
        };
        let heights = async |entry: &Entry| -> Result<TextureData, String> {
            let bytes = read(entry).await?;
            hikage_bundle::ktx2_file::decode(&bytes, Path::new(&entry.file), &Limits::default())
                .map_err(|e| e.to_string())
        };
        let own = heights(&r.height).await?;
        let mut sides = [None, None, None, None];
        for (side, entry) in sides.iter_mut().zip(&r.neighbours) {
            if let Some(entry) = entry {
                *side = Some(heights(entry).await?);
            }
        }
        let apron = heights_with_apron(&own, &sides);
        let heights = float_image(&apron);
        let hf = r.height.settings.heightfield().ok_or_else(|| format!("`{}` is not a heightfield", r.height.id))?;
        let skirt = skirt_texels * hf.texel_size.0.max(hf.texel_size.1);
        let (mesh, bounds) =
            crate::grid::tile_mesh(&apron, hf, skirt).map_err(|e| format!("`{}`: {e}", r.height.id))?;
        let image = async |entry: &Entry| -> Result<Image, String> {
            let bytes = read(entry).await?;
            crate::loader::texture_image(entry, &bytes, features, RenderAssetUsages::RENDER_WORLD)
                .map_err(|e| format!("`{}`: {e}", entry.id))
        };
        let horizon = image(&r.horizon).await?;
        let ao = match &r.ao {
            Some(entry) => Some(image(entry).await?),
            None => None,
        };
        let settings = r.horizon.settings.horizon().ok_or_else(|| format!("`{}` is not a horizon", r.horizon.id))?;
        let format = r.horizon.payload.texture().map(|t| t.format).ok_or("a horizon tile without a texture")?;
        let encoding = HorizonEncoding::new(format, settings);
        let uniform = TerrainUniform::new(&encoding, settings.texel_size, ao.is_some());
        let constants = hikage_runtime::horizon::TerrainUniform {
            texel_size: [settings.texel_size.0, settings.texel_size.1],
            height_scale: hf.height_scale,
            height_offset: hf.height_offset,
            size: [own.desc.width, own.desc.height],
            encoding,
            apron: 1,
            ..hikage_runtime::bytemuck::Zeroable::zeroed()
        };
        let image_bytes = |i: &Image| i.data.as_ref().map_or(0, |d| d.len() as u64);
        let indices = mesh.indices().map_or(0, |i| i.len() as u64);
        let bytes = image_bytes(&horizon)
            + ao.as_ref().map_or(0, image_bytes)
            + image_bytes(&heights)
            + mesh.count_vertices() as u64 * mesh.get_vertex_size()
            + 4 * indices;
        Ok(Loaded { mesh, bounds, horizon, ao, uniform, heights, constants, bytes })
    })
}

/// Adds tile `key` as a hidden child of `parent`: its mesh, its images and its material; and
/// what a sun field reads of it.
#[expect(clippy::too_many_arguments, reason = "the tile, its terrain's parts and where it goes")]
fn add_tile(
    commands: &mut Commands,
    assets: &mut TileAssets,
    base: &StandardMaterial,
    layout: &TileLayout,
    key: TileKey,
    loaded: Loaded,
    parent: Entity,
    no_shadow: bool,
) -> (Entity, FieldPiece) {
    let horizon = assets.images.add(loaded.horizon);
    let (x, z) = layout.offset(key);
    let piece = FieldPiece {
        key,
        offset: Vec2::new(x, z),
        horizon: horizon.clone(),
        heights: assets.images.add(loaded.heights),
        constants: loaded.constants,
    };
    let extension =
        TerrainExtension { uniform: loaded.uniform, horizon, ao: loaded.ao.map(|ao| assets.images.add(ao)) };
    let material = assets.materials.add(ExtendedMaterial { base: base.clone(), extension });
    let mut tile = commands.spawn((
        TerrainTile { key, rect: layout.rect(key) },
        Mesh3d(assets.meshes.add(loaded.mesh)),
        MeshMaterial3d(material),
        loaded.bounds,
        Transform::from_xyz(x, 0.0, z),
        Visibility::Hidden,
        ChildOf(parent),
    ));
    if no_shadow {
        tile.insert(NotShadowCaster);
    }
    (tile.id(), piece)
}

/// `heights` (one channel, any format) as a 2D `R32Float` image of its samples, for the render
/// world alone.
fn float_image(heights: &TextureData) -> Image {
    let (w, h) = (heights.desc.width, heights.desc.height);
    let bytes: Vec<u8> = heights.channel_f32(0, 0).into_iter().flat_map(f32::to_le_bytes).collect();
    Image::new(
        bevy_render::render_resource::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        bevy_render::render_resource::TextureDimension::D2,
        bytes,
        bevy_render::render_resource::TextureFormat::R32Float,
        RenderAssetUsages::RENDER_WORLD,
    )
}
