//! The device-free half of loading: read, verify and decode payloads, all of them or only the
//! ones a level needs, and again after a rebake (hot reload).
//!
//! Payloads are read, hashed and decoded on every core (independent files, one thread each at
//! a time). A bake may replace the bundle while it is read: the manifest is replaced
//! atomically and the payloads of the replaced manifest stay until the next commit, so a read
//! sees one whole bundle; if two commits pass during a read and a payload has vanished, the
//! read starts again from the newest manifest.

use std::collections::BTreeSet;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use hikage_bundle::{Asset, Bundle, BundleError, MeshData, Payload, PayloadData, TextureData};

use crate::error::RuntimeError;

/// Attempts at reading a consistent bundle while writers replace it.
const ATTEMPTS: usize = 4;

/// One asset in memory: its manifest entry and decoded payload.
#[derive(Clone, Debug, PartialEq)]
pub struct CpuAsset {
    /// The manifest entry (id, kind, settings, hashes).
    pub asset: Asset,
    /// The decoded payload.
    pub payload: PayloadData,
}

impl CpuAsset {
    /// The texture, when the payload is one.
    pub fn texture(&self) -> Option<&TextureData> {
        self.payload.texture()
    }

    /// The mesh, when the payload is one.
    pub fn mesh(&self) -> Option<&MeshData> {
        self.payload.mesh()
    }
}

/// Which assets a [`CpuBundle`] holds, kept so [`CpuBundle::reload`] asks the same again.
#[derive(Clone, Debug, PartialEq)]
enum Selection {
    All,
    Ids(Vec<String>),
    Prefix(String),
}

/// What [`CpuBundle::reload`] found changed on disk, by asset id.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Changes {
    /// Assets whose payload changed (another BLAKE3) and were read again.
    pub changed: Vec<String>,
    /// Assets that appeared (a new asset under the prefix, or one a changed asset now names).
    pub added: Vec<String>,
    /// Assets that are no longer in the bundle, or no longer named.
    pub removed: Vec<String>,
}

impl Changes {
    /// True when nothing changed.
    pub fn is_empty(&self) -> bool {
        self.changed.is_empty() && self.added.is_empty() && self.removed.is_empty()
    }

    /// True when any of `ids` changed or went: a component built from them (see each
    /// component's `asset_ids`) must be built again after [`crate::GpuBundle::apply`].
    ///
    /// ```no_run
    /// # fn f(device: &wgpu::Device, queue: &wgpu::Queue, mut cpu: hikage_runtime::CpuBundle, mut gpu: hikage_runtime::GpuBundle, terrain: &mut hikage_runtime::horizon::TerrainShadows, options: &hikage_runtime::DrawOptions) -> Result<(), hikage_runtime::RuntimeError> {
    /// use hikage_runtime::horizon::TerrainShadows;
    /// let changes = cpu.reload()?;
    /// gpu.apply(device, queue, &cpu, &changes)?;
    /// if changes.touches(terrain.asset_ids()) {
    ///     *terrain = TerrainShadows::new(device, queue, &gpu, "terrain.horizon", Some("terrain.ao"), options)?;
    /// }
    /// # Ok(()) }
    /// ```
    pub fn touches<S: AsRef<str>>(&self, ids: &[S]) -> bool {
        ids.iter().any(|id| {
            let id = id.as_ref();
            self.changed.iter().chain(&self.removed).any(|c| c == id)
        })
    }
}

/// Assets read into memory, ready for [`crate::GpuBundle::upload`]. `Send`, so it can be built
/// on a loader thread.
///
/// ```no_run
/// use hikage_runtime::CpuBundle;
/// // Everything the terrain job made (`terrain.height`, `terrain.horizon`, `terrain.ao`) and
/// // nothing else: other payloads are neither read nor hashed.
/// let mut terrain = CpuBundle::read_prefix("bundle".as_ref(), "terrain.")?;
/// // One asset and the assets it names (a horizon map's heightfield).
/// let horizon = CpuBundle::read_ids("bundle".as_ref(), &["cylinders.horizon"])?;
/// // Later, after an artist rebaked: read again only what changed.
/// let changes = terrain.reload()?;
/// println!("changed: {:?}", changes.changed);
/// // A map baked in tiles (`tile: Some(1024)`): stream the horizon tiles within 2 tiles of
/// // the camera's tile, each with its heights; every tile says where it lies in the map.
/// let (cx, cy) = (3, 5);
/// let near = CpuBundle::read_where("bundle".as_ref(), |a| {
///     a.settings.horizon().and_then(|h| h.tile.as_ref()).is_some_and(|t| {
///         t.map == "dem" && t.index.0.abs_diff(cx) <= 2 && t.index.1.abs_diff(cy) <= 2
///     })
/// })?;
/// for tile in near.assets.iter().filter_map(|a| a.asset.settings.tile()) {
///     println!("tile {:?} starts at texel {:?} of {:?}", tile.index, tile.origin, tile.map_size);
/// }
/// # Ok::<(), hikage_runtime::RuntimeError>(())
/// ```
#[derive(Clone, Debug)]
pub struct CpuBundle {
    /// The opened bundle (directory and the whole manifest).
    pub bundle: Bundle,
    /// The assets read, in manifest order.
    pub assets: Vec<CpuAsset>,
    selection: Selection,
}

impl CpuBundle {
    /// Opens the bundle in `dir` and decodes every asset, checking sizes, hashes and KTX2
    /// headers against the manifest.
    pub fn read(dir: &Path) -> Result<CpuBundle, RuntimeError> {
        CpuBundle::read_selection(dir, Selection::All)
    }

    /// Reads the assets named in `ids` and, transitively, the assets they depend on
    /// ([`hikage_bundle::Settings::depends_on`]). An id the bundle does not have is an error
    /// that lists the ids it has.
    pub fn read_ids(dir: &Path, ids: &[&str]) -> Result<CpuBundle, RuntimeError> {
        CpuBundle::read_selection(dir, Selection::Ids(ids.iter().map(|s| s.to_string()).collect()))
    }

    /// Reads the assets whose id starts with `prefix` (a job's assets share its id as prefix:
    /// `terrain.` gives `terrain.height`, `terrain.horizon` and `terrain.ao`), and the assets
    /// they depend on. No match is an error.
    pub fn read_prefix(dir: &Path, prefix: &str) -> Result<CpuBundle, RuntimeError> {
        CpuBundle::read_selection(dir, Selection::Prefix(prefix.to_string()))
    }

    /// Reads the assets for which `select` is true (the others are neither read nor hashed),
    /// and the assets they depend on.
    pub fn read_where(dir: &Path, select: impl Fn(&Asset) -> bool) -> Result<CpuBundle, RuntimeError> {
        let bundle = Bundle::open(dir)?;
        let ids = bundle.manifest().assets.iter().filter(|a| select(a)).map(|a| a.id.clone()).collect();
        CpuBundle::read_selection(dir, Selection::Ids(ids))
    }

    fn read_selection(dir: &Path, selection: Selection) -> Result<CpuBundle, RuntimeError> {
        let mut last = None;
        for _ in 0..ATTEMPTS {
            let bundle = Bundle::open(dir)?;
            let wanted = resolve(&bundle, &selection)?;
            let assets: Vec<&Asset> = bundle.manifest().assets.iter().filter(|a| wanted.contains(&a.id)).collect();
            match read_assets(&bundle, &assets) {
                Ok(assets) => return Ok(CpuBundle { bundle, assets, selection }),
                Err(e) if vanished(&e) => last = Some(e),
                Err(e) => return Err(e.into()),
            }
        }
        Err(last.expect("at least one attempt").into())
    }

    /// The asset with this id, if it was read.
    pub fn asset(&self, id: &str) -> Option<&CpuAsset> {
        self.assets.iter().find(|a| a.asset.id == id)
    }

    /// The bundle's directory.
    pub fn dir(&self) -> &Path {
        self.bundle.dir()
    }

    /// Picks up a rebake: opens the manifest again, and reads only the assets of the same
    /// selection whose BLAKE3 differs from the ones held (and those that appeared), dropping
    /// the ones that went. The bundle is never seen torn: every asset held afterwards is from
    /// the same manifest. On an error nothing held changes.
    pub fn reload(&mut self) -> Result<Changes, RuntimeError> {
        let mut last = None;
        for _ in 0..ATTEMPTS {
            let bundle = Bundle::open(self.dir())?;
            let wanted = resolve(&bundle, &self.selection)?;
            let mut changes = Changes::default();
            let mut read = Vec::new();
            for a in bundle.manifest().assets.iter().filter(|a| wanted.contains(&a.id)) {
                match self.asset(&a.id) {
                    Some(held) if held.asset == *a => {}
                    Some(_) => {
                        changes.changed.push(a.id.clone());
                        read.push(a);
                    }
                    None => {
                        changes.added.push(a.id.clone());
                        read.push(a);
                    }
                }
            }
            changes.removed =
                self.assets.iter().map(|a| a.asset.id.clone()).filter(|id| !wanted.contains(id)).collect();
            let fresh = match read_assets(&bundle, &read) {
                Ok(fresh) => fresh,
                Err(e) if vanished(&e) => {
                    last = Some(e);
                    continue;
                }
                Err(e) => return Err(e.into()),
            };
            let mut held: Vec<CpuAsset> = std::mem::take(&mut self.assets);
            held.retain(|a| wanted.contains(&a.asset.id));
            held.retain(|a| !fresh.iter().any(|f| f.asset.id == a.asset.id));
            held.extend(fresh);
            let order = |id: &str| bundle.manifest().assets.iter().position(|a| a.id == id);
            held.sort_by_key(|a| order(&a.asset.id));
            // Held assets that did not change keep their entry; the manifest is the new one.
            for a in &mut held {
                if let Some(m) = bundle.manifest().asset(&a.asset.id) {
                    a.asset = m.clone();
                }
            }
            self.assets = held;
            self.bundle = bundle;
            return Ok(changes);
        }
        Err(last.expect("at least one attempt").into())
    }
}

/// The ids `selection` names in `bundle`, with every asset they depend on.
fn resolve(bundle: &Bundle, selection: &Selection) -> Result<BTreeSet<String>, RuntimeError> {
    let manifest = bundle.manifest();
    let mut queue: Vec<String> = match selection {
        Selection::All => manifest.assets.iter().map(|a| a.id.clone()).collect(),
        Selection::Ids(ids) => ids.clone(),
        Selection::Prefix(prefix) => {
            let ids: Vec<String> =
                manifest.assets.iter().filter(|a| a.id.starts_with(prefix.as_str())).map(|a| a.id.clone()).collect();
            if ids.is_empty() {
                return Err(RuntimeError::Bundle(BundleError::Lookup {
                    path: bundle.dir().join(hikage_bundle::MANIFEST_FILE),
                    message: format!(
                        "no asset id starts with `{prefix}`; the bundle has: {}",
                        manifest.assets.iter().map(|a| a.id.as_str()).collect::<Vec<_>>().join(", ")
                    ),
                }));
            }
            ids
        }
    };
    let mut wanted = BTreeSet::new();
    while let Some(id) = queue.pop() {
        let asset = bundle.asset(&id)?;
        if wanted.insert(id) {
            queue.extend(asset.settings.depends_on().into_iter().map(str::to_string));
        }
    }
    Ok(wanted)
}

/// True when `e` is a payload that vanished (a writer swept it after two commits).
fn vanished(e: &BundleError) -> bool {
    matches!(e, BundleError::Io { error, .. } if error.kind() == std::io::ErrorKind::NotFound)
}

/// Reads, hashes and decodes `assets` on every core, in order.
fn read_assets(bundle: &Bundle, assets: &[&Asset]) -> Result<Vec<CpuAsset>, BundleError> {
    let read = |a: &Asset| -> Result<CpuAsset, BundleError> {
        let payload = match &a.payload {
            Payload::Texture(_) => PayloadData::Texture(bundle.read_texture(&a.id)?),
            Payload::Mesh(_) => PayloadData::Mesh(bundle.read_mesh(&a.id)?),
        };
        Ok(CpuAsset { asset: a.clone(), payload })
    };
    let workers = std::thread::available_parallelism().map_or(1, |n| n.get()).min(assets.len());
    if workers <= 1 {
        return assets.iter().map(|a| read(a)).collect();
    }
    let next = AtomicUsize::new(0);
    let results: Vec<Mutex<Option<Result<CpuAsset, BundleError>>>> = assets.iter().map(|_| Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= assets.len() {
                        break;
                    }
                    let r = read(assets[i]);
                    *results[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
                }
            });
        }
    });
    results
        .into_iter()
        .map(|r| r.into_inner().unwrap_or_else(|e| e.into_inner()).expect("every asset was read"))
        .collect()
}
