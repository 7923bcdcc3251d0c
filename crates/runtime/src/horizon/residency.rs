//! [`TileResidency`]: the tiles of a streamed map an engine holds, and the one frame loop both
//! streams run ([`super::TerrainStream`] here, hikage-bevy's `StreamedTerrain`): what to read,
//! what to add within the frame's upload budget (making room by evicting), what to draw, and
//! what a reload of a rebaked bundle keeps.

use std::collections::HashMap;

use super::stream::{MAX_TILE_SIDE, StreamOptions, StreamStats};
use super::tile_plan::{MAX_PENDING_TILES, TileKey, TileLayout};

/// What opening a stream checks before any tile is read, whatever holds the tiles: every
/// level's tiles at most [`MAX_TILE_SIDE`] a side (`side(level)`: its tile `(0, 0)`, the
/// largest), the coarsest level's tiles and one level-0 tile within the resident budget, one
/// level-0 tile within the upload budget (`bytes(key)`: what a tile holds). Returns what a tile
/// of each level holds (its tile `(0, 0)`); or why the stream cannot be, for the engine to say
/// with the map's name.
///
/// ```no_run
/// # fn f(layout: &hikage_runtime::horizon::TileLayout) -> Result<(), String> {
/// use hikage_runtime::horizon::{StreamOptions, check_budgets};
///
/// let level_bytes = check_budgets(layout, &StreamOptions::default(), |_level| (257, 257), |_key| 4 << 20)?;
/// # Ok(()) }
/// ```
pub fn check_budgets(
    layout: &TileLayout,
    options: &StreamOptions,
    side: impl Fn(u32) -> (u32, u32),
    bytes: impl Fn(TileKey) -> u64,
) -> Result<Vec<u64>, String> {
    for level in 0..layout.levels.len() as u32 {
        let (w, h) = side(level);
        if w.max(h) > MAX_TILE_SIDE {
            return Err(format!(
                "tiles of {w}×{h} texels: a streamed terrain holds tiles of at most {MAX_TILE_SIDE} a side (bake with \
                 tile ≤ {})",
                MAX_TILE_SIDE - 1
            ));
        }
    }
    let level_bytes: Vec<u64> = (0..layout.levels.len() as u32).map(|k| bytes((k, 0, 0))).collect();
    let roots: Vec<TileKey> = layout.roots().collect();
    let root_bytes: u64 = roots.iter().map(|&k| bytes(k)).sum();
    let largest = level_bytes[0];
    if root_bytes + largest > options.resident_bytes {
        return Err(format!(
            "the coarsest level's {} tiles hold {root_bytes} bytes and a level-0 tile {largest}: above the resident \
             budget of {} (bake levels of detail, `levels: Some(16)`, or raise `resident_bytes`)",
            roots.len(),
            options.resident_bytes
        ));
    }
    if largest > options.upload_bytes {
        return Err(format!(
            "a level-0 tile holds {largest} bytes, above the upload budget of {} a frame (raise `upload_bytes`)",
            options.upload_bytes
        ));
    }
    Ok(level_bytes)
}

/// A resident budget too small for a camera to draw the finest level it asks for under it
/// ([`TileLayout::budget_shortfall`]): the stream still runs, holding the finest complete level
/// the budget allows and asking for nothing finer. Its text says the budget that would do.
#[derive(Clone, Debug, PartialEq)]
pub struct BudgetShortfall {
    /// The map.
    pub map: String,
    /// The resident budget, bytes.
    pub budget: u64,
    /// What drawing `wanted_level` under the camera needs wherever it stands, bytes
    /// ([`TileLayout::resident_bytes_needed`]).
    pub needed: u64,
    /// What holds every tile the camera asks for at `detail`, bytes
    /// ([`TileLayout::resident_bytes_wanted`]).
    pub wanted: u64,
    /// The level asked for ([`StreamOptions::finest_level`](StreamOptions::finest_level)).
    pub wanted_level: u32,
    /// The finest level the budget holds under the camera.
    pub reachable_level: u32,
    /// Nodes a tile spans.
    pub tile: u32,
    /// The level-of-detail distance ([`StreamOptions::detail`](StreamOptions::detail)).
    pub detail: f32,
}

impl std::fmt::Display for BudgetShortfall {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mib = |b: u64| b as f64 / (1 << 20) as f64;
        write!(
            f,
            "map `{}`: a resident budget of {:.1} MiB holds level {} under the camera at most; level {} needs {:.1} MiB \
             ({} bytes) for tiles of {}², and {:.1} MiB holds all that detail {} asks for: raise `resident_bytes`",
            self.map,
            mib(self.budget),
            self.reachable_level,
            self.wanted_level,
            mib(self.needed),
            self.needed,
            self.tile,
            mib(self.wanted),
            self.detail
        )
    }
}

impl TileLayout {
    /// `None` when `options.resident_bytes` lets a camera anywhere draw
    /// [`StreamOptions::finest_level`](StreamOptions::finest_level) under it (tiles of
    /// `bytes` each, [`TileLayout::resident_bytes_needed`]); otherwise what it needs, and the
    /// finest level it holds.
    pub fn budget_shortfall(&self, options: &StreamOptions, bytes: impl Fn(TileKey) -> u64) -> Option<BudgetShortfall> {
        let needed = self.resident_bytes_needed(options, &bytes);
        if needed <= options.resident_bytes {
            return None;
        }
        let reachable_level = (options.finest_level + 1..=self.coarsest())
            .find(|&finest_level| {
                let coarser = StreamOptions { finest_level, ..*options };
                self.resident_bytes_needed(&coarser, &bytes) <= options.resident_bytes
            })
            .unwrap_or(self.coarsest());
        Some(BudgetShortfall {
            map: self.map.clone(),
            budget: options.resident_bytes,
            needed,
            wanted: self.resident_bytes_wanted(options, &bytes),
            wanted_level: options.finest_level,
            reachable_level,
            tile: self.tile,
            detail: options.detail,
        })
    }
}

/// How an engine reads its tiles (a thread, a task pool): a [`TileResidency`] asks for tiles and
/// takes them as they finish.
pub trait TileReads<L, E> {
    /// The reads that finished since the last call, each a tile read or why not.
    fn finished(&mut self) -> Vec<(TileKey, Result<L, E>)>;
    /// Drops the reads of tiles `wanted` says no (where the engine can stop a read).
    fn retain(&mut self, wanted: &dyn Fn(TileKey) -> bool);
    /// Whether `key` is being read.
    fn reading(&self, key: TileKey) -> bool;
    /// Reads in flight.
    fn in_flight(&self) -> usize;
    /// Starts reading `key`; or why it cannot.
    fn start(&mut self, key: TileKey) -> Result<(), E>;
}

/// What an engine does with a tile read ([`TileResidency::frame`]): adds it (its device
/// objects, entities) and says what it holds, or drops one it holds.
pub trait TileStore<T, L, E> {
    /// Bytes `loaded` will hold once added (the frame's upload budget counts them).
    fn bytes(&self, loaded: &L) -> u64;
    /// Adds tile `key`: what the engine keeps of it, and the bytes it holds.
    fn add(&mut self, key: TileKey, loaded: L) -> Result<(T, u64), E>;
    /// Drops a tile it holds.
    fn evict(&mut self, key: TileKey, tile: T);
}

/// A tile held: what the engine keeps, its bytes, when it was last drawn, and whether a reload
/// found it changed (drawn until its new version is added).
#[derive(Debug)]
struct Held<T> {
    tile: T,
    bytes: u64,
    last_used: u64,
    stale: bool,
}

/// The tiles of one streamed map an engine holds, and those read and waiting to be added.
///
/// Each frame, [`frame`](TileResidency::frame) plans the tiles for the camera
/// ([`TileLayout::plan`]), takes the finished reads, starts the reads the resident budget
/// holds (at most [`MAX_PENDING_TILES`] in flight, the most wanted first), adds what the
/// upload budget allows (evicting as [`super::TilePlan::victim`] says) and returns what to draw.
/// [`reload`](TileResidency::reload) keeps the tiles a rebake left as they were and reads the
/// others again, drawing the old ones until their new versions are added: no frame without
/// terrain.
///
/// An engine brings how it reads tiles ([`TileReads`]) and what it makes of them
/// ([`TileStore`]):
///
/// ```no_run
/// use hikage_runtime::horizon::{StreamOptions, TileKey, TileLayout, TileReads, TileResidency, TileStore};
///
/// /// Tiles read at once, from memory; each held as its byte count.
/// struct Instant(Vec<(TileKey, Result<u64, String>)>);
/// impl TileReads<u64, String> for Instant {
///     fn finished(&mut self) -> Vec<(TileKey, Result<u64, String>)> { std::mem::take(&mut self.0) }
///     fn retain(&mut self, _wanted: &dyn Fn(TileKey) -> bool) {}
///     fn reading(&self, _key: TileKey) -> bool { false }
///     fn in_flight(&self) -> usize { 0 }
///     fn start(&mut self, key: TileKey) -> Result<(), String> { self.0.push((key, Ok(1 << 20))); Ok(()) }
/// }
/// struct Counted;
/// impl TileStore<u64, u64, String> for Counted {
///     fn bytes(&self, loaded: &u64) -> u64 { *loaded }
///     fn add(&mut self, _key: TileKey, loaded: u64) -> Result<(u64, u64), String> { Ok((loaded, loaded)) }
///     fn evict(&mut self, _key: TileKey, _tile: u64) {}
/// }
///
/// # fn f(layout: &TileLayout, level_bytes: &[u64]) {
/// let mut residency = TileResidency::default();
/// let options = StreamOptions::default();
/// // Every frame, for the camera's place in the map frame:
/// let done = residency.frame((layout, &options, level_bytes), (1000.0, 2000.0), &mut Instant(Vec::new()), &mut Counted);
/// for key in &done.drawn {
///     let _tile = residency.get(*key); // draw it
/// }
/// # }
/// ```
#[derive(Debug)]
pub struct TileResidency<T, L> {
    resident: HashMap<TileKey, Held<T>>,
    ready: Vec<(TileKey, L)>,
    frame: u64,
}

impl<T, L> Default for TileResidency<T, L> {
    fn default() -> Self {
        TileResidency { resident: HashMap::new(), ready: Vec::new(), frame: 0 }
    }
}

/// What one [`TileResidency::frame`] did: the stats, the tiles to draw (resident, covering the
/// map once) and the first failure (a tile that failed to read or add), if any.
#[derive(Debug)]
pub struct ResidencyFrame<E> {
    /// What is held and what the frame did.
    pub stats: StreamStats,
    /// The tiles to draw.
    pub drawn: Vec<TileKey>,
    /// The first tile that failed to read or add.
    pub failure: Option<E>,
}

impl<T, L> TileResidency<T, L> {
    /// Holds `tile` (of `bytes`) at `key` from the start: the coarsest level, read before the
    /// first frame so that there is always terrain.
    pub fn insert(&mut self, key: TileKey, tile: T, bytes: u64) {
        self.resident.insert(key, Held { tile, bytes, last_used: self.frame, stale: false });
    }

    /// The tile held at `key`.
    pub fn get(&self, key: TileKey) -> Option<&T> {
        self.resident.get(&key).map(|h| &h.tile)
    }

    /// Every tile held.
    pub fn iter(&self) -> impl Iterator<Item = (TileKey, &T)> {
        self.resident.iter().map(|(k, h)| (*k, &h.tile))
    }

    /// Every tile held, to change.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (TileKey, &mut T)> {
        self.resident.iter_mut().map(|(k, h)| (*k, &mut h.tile))
    }

    /// Drops every tile (each through `evict`) and every read waiting.
    pub fn clear(&mut self, mut evict: impl FnMut(TileKey, T)) {
        for (k, h) in self.resident.drain() {
            evict(k, h.tile);
        }
        self.ready.clear();
    }

    /// After a rebake: the tiles `unchanged` says are as they were stay; the others are read
    /// again and drawn until their new versions are added. Reads waiting to be added are
    /// dropped (they may be of the old files). Returns (tiles kept, tiles to read again).
    pub fn reload(&mut self, unchanged: impl Fn(TileKey) -> bool) -> (usize, usize) {
        self.ready.clear();
        let mut counts = (0, 0);
        for (k, h) in self.resident.iter_mut() {
            h.stale = h.stale || !unchanged(*k);
            if h.stale {
                counts.1 += 1;
            } else {
                counts.0 += 1;
            }
        }
        counts
    }

    /// One frame for a camera at `cam` (the map frame's `u`, `v`): see [`TileResidency`].
    pub fn frame<E>(
        &mut self,
        (layout, options, level_bytes): (&TileLayout, &StreamOptions, &[u64]),
        cam: (f32, f32),
        reads: &mut dyn TileReads<L, E>,
        store: &mut dyn TileStore<T, L, E>,
    ) -> ResidencyFrame<E> {
        self.frame += 1;
        let plan = layout.plan(cam, options, |k| self.resident.contains_key(&k));
        // What is wanted and not held, or held from before a rebake.
        let wants = |resident: &HashMap<TileKey, Held<T>>, k: TileKey| resident.get(&k).is_none_or(|h| h.stale);
        let mut failure = None;
        for (key, result) in reads.finished() {
            match result {
                Ok(loaded) => self.ready.push((key, loaded)),
                Err(e) => failure = failure.or(Some(e)),
            }
        }
        reads.retain(&|k| plan.rank(k).is_some());
        let resident = &self.resident;
        self.ready.retain(|(key, _)| plan.rank(*key).is_some() && wants(resident, *key));
        // Most wanted last, to pop.
        self.ready.sort_by_key(|(key, _)| std::cmp::Reverse(plan.rank(*key)));
        let affordable = plan.affordable(options.resident_bytes, |k| level_bytes[k.0 as usize]);
        for &key in affordable {
            if reads.in_flight() >= MAX_PENDING_TILES {
                break;
            }
            let queued = reads.reading(key) || self.ready.iter().any(|(k, _)| *k == key);
            if wants(&self.resident, key)
                && !queued
                && let Err(e) = reads.start(key)
            {
                failure = failure.or(Some(e));
            }
        }
        let mut uploaded = 0u64;
        while let Some((key, loaded)) = self.ready.pop() {
            let bytes = store.bytes(&loaded);
            if uploaded + bytes > options.upload_bytes {
                self.ready.push((key, loaded));
                break;
            }
            // A tile's old version makes room for its new one.
            if let Some(old) = self.resident.remove(&key) {
                store.evict(key, old.tile);
            }
            if !self.make_room(bytes, affordable.len(), &plan, options.resident_bytes, store) {
                self.ready.push((key, loaded));
                break;
            }
            match store.add(key, loaded) {
                Ok((tile, bytes)) => {
                    uploaded += bytes;
                    self.resident.insert(key, Held { tile, bytes, last_used: self.frame, stale: false });
                }
                Err(e) => failure = failure.or(Some(e)),
            }
        }
        // What to draw now that tiles came and went (an evicted tile's area falls back to its
        // coarser tile, which stays while finer tiles hang from it).
        let plan = layout.plan(cam, options, |k| self.resident.contains_key(&k));
        for key in &plan.drawn {
            if let Some(h) = self.resident.get_mut(key) {
                h.last_used = self.frame;
            }
        }
        let stats = StreamStats {
            resident_tiles: self.resident.len(),
            resident_bytes: self.resident.values().map(|h| h.bytes).sum(),
            uploaded_bytes: uploaded,
            drawn: plan.drawn.len(),
            missing: plan.wanted.iter().filter(|k| wants(&self.resident, **k)).count(),
            finest_drawn: plan.drawn.iter().map(|k| k.0).min().unwrap_or(layout.coarsest()),
        };
        ResidencyFrame { stats, drawn: plan.drawn, failure }
    }

    /// Evicts tiles until `bytes` more fit `budget`, in the order [`super::TilePlan::victim`]
    /// gives with the plan's first `affordable` tiles held. False when the bytes cannot be found.
    fn make_room<E>(
        &mut self,
        bytes: u64,
        affordable: usize,
        plan: &super::TilePlan,
        budget: u64,
        store: &mut dyn TileStore<T, L, E>,
    ) -> bool {
        loop {
            let resident: u64 = self.resident.values().map(|h| h.bytes).sum();
            if resident + bytes <= budget {
                return true;
            }
            match plan.victim(affordable, self.resident.iter().map(|(k, h)| (*k, h.last_used))) {
                Some(k) => {
                    let gone = self.resident.remove(&k).expect("a resident tile");
                    store.evict(k, gone.tile);
                }
                None => return false,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::horizon::tile_plan::tests::square;

    /// Reads that finish in the frame after they start, unless `slow`; every one counted.
    #[derive(Default)]
    struct Reads {
        started: Vec<TileKey>,
        flying: Vec<TileKey>,
        slow: bool,
    }

    impl TileReads<u64, String> for Reads {
        fn finished(&mut self) -> Vec<(TileKey, Result<u64, String>)> {
            if self.slow {
                return Vec::new();
            }
            std::mem::take(&mut self.flying).into_iter().map(|k| (k, Ok(100))).collect()
        }
        fn retain(&mut self, wanted: &dyn Fn(TileKey) -> bool) {
            self.flying.retain(|k| wanted(*k));
        }
        fn reading(&self, key: TileKey) -> bool {
            self.flying.contains(&key)
        }
        fn in_flight(&self) -> usize {
            self.flying.len()
        }
        fn start(&mut self, key: TileKey) -> Result<(), String> {
            self.started.push(key);
            self.flying.push(key);
            Ok(())
        }
    }

    /// Tiles of 100 bytes, each held as the number of its addition; evictions counted.
    #[derive(Default)]
    struct Store {
        added: u64,
        evicted: Vec<TileKey>,
    }

    impl TileStore<u64, u64, String> for Store {
        fn bytes(&self, loaded: &u64) -> u64 {
            *loaded
        }
        fn add(&mut self, _key: TileKey, loaded: u64) -> Result<(u64, u64), String> {
            self.added += 1;
            Ok((self.added, loaded))
        }
        fn evict(&mut self, key: TileKey, _tile: u64) {
            self.evicted.push(key);
        }
    }

    /// Level 0 everywhere on a 3-level map of 4×4 tiles: every tile of the pyramid read once,
    /// at most `MAX_PENDING_TILES` at a time, none evicted with room for all; the drawn tiles
    /// cover the map once, then a reload reads again exactly the tiles it says changed, drawing
    /// them meanwhile, and gives them new versions.
    #[test]
    fn every_tile_is_read_once_and_a_reload_reads_only_the_changed() {
        let layout = square(3, 4, 64, 10.0);
        let options =
            StreamOptions { detail: 1e9, resident_bytes: 1 << 20, upload_bytes: 1 << 20, ..Default::default() };
        let level_bytes = [100, 100, 100];
        let mut r: TileResidency<u64, u64> = TileResidency::default();
        r.insert((2, 0, 0), 0, 100);
        let (mut reads, mut store) = (Reads::default(), Store::default());
        let mut last = None;
        for _ in 0..10 {
            assert!(reads.flying.len() <= MAX_PENDING_TILES);
            last = Some(r.frame((&layout, &options, &level_bytes), (5.0, 5.0), &mut reads, &mut store));
        }
        let done = last.expect("ten frames");
        assert_eq!((done.stats.missing, done.stats.drawn, done.stats.finest_drawn), (0, 16, 0), "{:?}", done.stats);
        assert_eq!(reads.started.len(), 4 + 16, "each tile read once: {:?}", reads.started);
        assert!(store.evicted.is_empty());
        let before: HashMap<TileKey, u64> = r.iter().map(|(k, t)| (k, *t)).collect();
        // A rebake changed the tiles of column 1 at level 0 and their level-1 parent.
        let changed = |k: TileKey| (k.0 == 0 && k.1 == 1) || k == (1, 0, 0) || k == (1, 0, 1);
        assert_eq!(r.reload(|k| !changed(k)), (21 - 6, 6));
        reads.started.clear();
        reads.slow = true;
        let slow = r.frame((&layout, &options, &level_bytes), (5.0, 5.0), &mut reads, &mut store);
        assert_eq!((slow.stats.drawn, slow.stats.finest_drawn), (16, 0), "the old versions are drawn meanwhile");
        reads.slow = false;
        for _ in 0..4 {
            r.frame((&layout, &options, &level_bytes), (5.0, 5.0), &mut reads, &mut store);
        }
        let mut again = reads.started.clone();
        again.sort();
        let mut want: Vec<TileKey> = before.keys().copied().filter(|k| changed(*k)).collect();
        want.sort();
        assert_eq!(again, want);
        for (k, t) in r.iter() {
            assert_eq!(before[&k] != *t, changed(k), "{k:?}");
        }
    }

    /// A budget for the root, its four tiles and one set of four below: a camera crossing the
    /// map makes the old level-0 set go for the new one (level 0 drawn under the camera at
    /// both ends), within the budget in every frame, the root and the level-1 tiles never.
    #[test]
    fn a_small_budget_evicts_what_is_no_longer_wanted_and_never_the_root() {
        let layout = square(3, 4, 64, 10.0);
        let options = StreamOptions { detail: 0.5, resident_bytes: 900, upload_bytes: 1 << 20, ..Default::default() };
        let level_bytes = [100, 100, 100];
        let mut r: TileResidency<u64, u64> = TileResidency::default();
        r.insert((2, 0, 0), 0, 100);
        let (mut reads, mut store) = (Reads::default(), Store::default());
        for (cam, under) in [((5.0, 5.0), (0, 0, 0)), ((2555.0, 2555.0), (0, 3, 3))] {
            let mut last = None;
            for _ in 0..6 {
                let done = r.frame((&layout, &options, &level_bytes), cam, &mut reads, &mut store);
                assert!(done.stats.resident_bytes <= 900, "{:?}", done.stats);
                last = Some(done);
            }
            assert!(last.expect("six frames").drawn.contains(&under), "level 0 under the camera at {cam:?}");
        }
        let mut evicted = store.evicted.clone();
        evicted.sort();
        assert_eq!(evicted, [(0, 0, 0), (0, 0, 1), (0, 1, 0), (0, 1, 1)]);
    }
}
