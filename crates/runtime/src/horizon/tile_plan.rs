//! Which tiles of a terrain baked in tiles and levels of detail a camera wants, which of them
//! to draw, and which to evict for a tile coming in: the policy of [`super::TerrainStream`],
//! public for an engine that loads and uploads tiles its own way (hikage-bevy does).

use std::collections::{HashMap, HashSet};

use hikage_bundle::Asset;

use crate::error::RuntimeError;

/// A tile: level of detail, column and row in the level's grid.
pub type TileKey = (u32, u32, u32);

/// The ids of a tiled map's parts: `<map>.height`, `<map>.horizon` and, when the job baked
/// ambient occlusion, `<map>.ao`. Tile `(level, x, y)` of a part is the asset
/// `part + tile_suffix(level, (x, y))` (see `hikage_bundle::tiles::tile_suffix`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TileParts {
    /// The heights' part.
    pub height: String,
    /// The horizons' part.
    pub horizon: String,
    /// The occlusion's part, if baked.
    pub ao: Option<String>,
}

impl TileParts {
    /// Every part, heights first.
    pub fn all(&self) -> impl Iterator<Item = &str> {
        [Some(self.height.as_str()), Some(self.horizon.as_str()), self.ao.as_deref()].into_iter().flatten()
    }
}

/// Tiles being read at once at most, by any streamer of a [`TilePlan`]: enough to keep a loader
/// busy, few enough that a camera turning round does not leave a long queue of tiles no longer
/// wanted.
pub const MAX_PENDING_TILES: usize = 8;

/// One level of a tiled map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileLevel {
    /// Tiles along `u` and `v`.
    pub grid: (u32, u32),
    /// The level's size in nodes.
    pub size: (u32, u32),
    /// World units per node.
    pub texel: (f32, f32),
}

/// A map baked in tiles and levels of detail (a `Horizon` job with `tile` and `levels`), as a
/// streamer sees it: its parts, its levels and where each tile lies.
///
/// Level `k`'s node `i` lies on level 0's texel `i·2^k`; in the map frame (the one-mesh
/// terrain's) level 0's texel `(i, j)` is centred at `((i + ½)·sx, h, (j + ½)·sy)`.
///
/// ```no_run
/// # fn f(dir: &std::path::Path) -> Result<(), Box<dyn std::error::Error>> {
/// use hikage_runtime::horizon::{StreamOptions, TileLayout};
///
/// let index = hikage_runtime::hikage_bundle::tile_index::TileIndex::open(dir)?;
/// let layout = TileLayout::new("terrain", |part, level, at| index.tile(part, level, at))?;
/// // A camera at (1200, 800) in the map frame, nothing resident yet: the coarsest tiles first.
/// let plan = layout.plan((1200.0, 800.0), &StreamOptions::default(), |_| false);
/// assert!(plan.drawn.is_empty() && plan.wanted.len() >= layout.roots().count());
/// # Ok(()) }
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct TileLayout {
    /// The map's id (the tiled job's).
    pub map: String,
    /// Its parts.
    pub parts: TileParts,
    /// Its levels, level 0 first.
    pub levels: Vec<TileLevel>,
    /// Nodes a tile spans along each axis (its textures hold one more: neighbours share their
    /// edge nodes).
    pub tile: u32,
}

impl TileLayout {
    /// The layout of map `map`, from `tile(part, level, (x, y))`, which gives a tile's manifest
    /// entry (`hikage_bundle::tile_index::TileIndex::tile`, or a manifest's asset of that id). Each
    /// level's grid and texel size come from its tile `(0, 0)`; the levels end at the first
    /// level without one.
    pub fn new(map: &str, tile: impl Fn(&str, u32, (u32, u32)) -> Option<Asset>) -> Result<TileLayout, RuntimeError> {
        let bad = |message: String| RuntimeError::Asset { asset: map.to_string(), message };
        let part = |kind: &str| {
            let id = format!("{map}.{kind}");
            tile(&id, 0, (0, 0)).is_some().then_some(id)
        };
        let (Some(height), Some(horizon)) = (part("height"), part("horizon")) else {
            return Err(bad(
                "expected the tiles of a Horizon job baked with `tile`: `<map>.height` and `<map>.horizon`, tile (0, 0)"
                    .into(),
            ));
        };
        let parts = TileParts { height, horizon, ao: part("ao") };
        let mut levels: Vec<TileLevel> = Vec::new();
        let mut side = 0;
        while let Some(first) = tile(&parts.horizon, levels.len() as u32, (0, 0)) {
            let settings = first.settings.horizon().ok_or_else(|| bad(format!("`{}` is not a horizon", first.id)))?;
            let place = settings.tile.clone().ok_or_else(|| bad(format!("`{}` has no tile placement", first.id)))?;
            let (w, h) = first.payload.texture().map_or((0, 0), |t| (t.width, t.height));
            if levels.is_empty() {
                side = w.max(h).saturating_sub(1).max(1);
            }
            let count = |n: u32| n.saturating_sub(1).div_ceil(side).max(1);
            levels.push(TileLevel {
                grid: (count(place.map_size.0), count(place.map_size.1)),
                size: place.map_size,
                texel: settings.texel_size,
            });
        }
        if levels.is_empty() {
            return Err(bad("no level-0 horizon tile `(0, 0)`".into()));
        }
        Ok(TileLayout { map: map.to_string(), parts, levels, tile: side })
    }

    /// The coarsest level.
    pub fn coarsest(&self) -> u32 {
        self.levels.len() as u32 - 1
    }

    /// The coarsest level's tiles: kept resident, so there is always terrain to draw.
    pub fn roots(&self) -> impl Iterator<Item = TileKey> + '_ {
        let top = self.coarsest();
        let grid = self.levels[top as usize].grid;
        (0..grid.1).flat_map(move |y| (0..grid.0).map(move |x| (top, x, y)))
    }

    /// Tile `key`'s id in part `part`.
    pub fn tile_id(part: &str, (level, x, y): TileKey) -> String {
        hikage_bundle::tiles::tile_id(part, level, (x, y))
    }

    /// Tile `key`'s first and last node in the map frame (world units along `u`, `v`).
    pub fn rect(&self, (level, x, y): TileKey) -> [(f32, f32); 2] {
        let l = &self.levels[level as usize];
        let s = (1u32 << level) as f32;
        let (sx, sy) = self.levels[0].texel;
        let node = |i: u32, n: u32, t: f32| (i.min(n - 1) as f32 * s + 0.5) * t;
        let (x0, y0) = (x * self.tile, y * self.tile);
        [
            (node(x0, l.size.0, sx), node(y0, l.size.1, sy)),
            (node(x0 + self.tile, l.size.0, sx), node(y0 + self.tile, l.size.1, sy)),
        ]
    }

    /// Where tile `key`'s frame lies in the map frame (world units along `u`, `v`): its node
    /// `(a, b)` is at `((a + ½)·texel_k, (b + ½)·texel_k)` in its own frame, as a whole map's
    /// texel, so the frame moves by `(origin·2^k + ½ − 2^(k−1))·texel_0`.
    pub fn offset(&self, (level, x, y): TileKey) -> (f32, f32) {
        let s = (1u32 << level) as f32;
        let (sx, sy) = self.levels[0].texel;
        let origin = ((x * self.tile) as f32, (y * self.tile) as f32);
        ((origin.0 * s + 0.5 - 0.5 * s) * sx, (origin.1 * s + 0.5 - 0.5 * s) * sy)
    }

    /// How far tile `key` is from the camera at `cam` (map frame, horizontal), in widths of the
    /// tile: 0 under the camera.
    pub fn remoteness(&self, key: TileKey, cam: (f32, f32)) -> f32 {
        let [lo, hi] = self.rect(key);
        self.distance(key, cam) / (hi.0 - lo.0).max(hi.1 - lo.1).max(f32::MIN_POSITIVE)
    }

    /// How far tile `key`'s rectangle is from the camera at `cam` (map frame, horizontal), in
    /// world units: 0 under the camera.
    fn distance(&self, key: TileKey, cam: (f32, f32)) -> f32 {
        let [lo, hi] = self.rect(key);
        let dx = (lo.0 - cam.0).max(cam.0 - hi.0).max(0.0);
        let dy = (lo.1 - cam.1).max(cam.1 - hi.1).max(0.0);
        dx.hypot(dy)
    }

    /// The tiles a camera at `cam` (map frame, horizontal) wants and the ones to draw, given
    /// which are `resident`. From the coarsest level's tiles down, a tile is replaced by its
    /// four finer tiles while the camera is within [`StreamOptions::detail`] tile widths of it,
    /// down to [`StreamOptions::finest_level`] — and only once all four are resident, so a
    /// coarser tile is drawn while finer ones load.
    ///
    /// [`StreamOptions::detail`]: super::StreamOptions::detail
    /// [`StreamOptions::finest_level`]: super::StreamOptions::finest_level
    pub fn plan(
        &self,
        cam: (f32, f32),
        options: &super::StreamOptions,
        resident: impl Fn(TileKey) -> bool,
    ) -> TilePlan {
        let mut walk = Walk::default();
        for key in self.roots() {
            self.visit(key, None, cam, options, &resident, &mut walk);
        }
        // A tile's four finer tiles are wanted together (a tile is replaced only by all four), so
        // they are ranked together, siblings in a row. Sets within a level-0 tile's width of the
        // camera (where it may be next frame) come first, coarser levels first, so the levels
        // around the camera are held one deeper than under it before it goes deeper: moving, the
        // level under it never falls back by more than one. Then the other sets, nearest in tile
        // widths first, coarser at a tie. The coarsest level comes first of all, and a set never
        // before its parent's.
        let reach = self.levels[0].texel.0.max(self.levels[0].texel.1) * self.tile as f32;
        let parent_of: HashMap<TileKey, Option<TileKey>> = walk.wanted.iter().copied().collect();
        let remote: HashMap<TileKey, f32> = walk.wanted.iter().map(|&(k, _)| (k, self.remoteness(k, cam))).collect();
        let mut nearest: HashMap<Option<TileKey>, Place> = HashMap::new();
        for &(key, parent) in &walk.wanted {
            let own = Place::new(key, remote[&key], self.distance(key, cam) <= reach);
            nearest.entry(parent).and_modify(|n| *n = (*n).min(own)).or_insert(own);
        }
        // Coarser sets first, so that a parent's set has its place before its children's.
        let mut sets: Vec<Option<TileKey>> = nearest.keys().copied().collect();
        sets.sort_by_key(|set| std::cmp::Reverse(set.map_or(u32::MAX, |p| p.0)));
        let mut order: HashMap<Option<TileKey>, Place> = HashMap::new();
        for set in sets {
            let place = match set {
                None => Place::FIRST,
                Some(p) => nearest[&set].max(order.get(&parent_of[&p]).copied().unwrap_or(Place::FIRST)),
            };
            order.insert(set, place);
        }
        // Within a set, nearest in tile widths first.
        let own = |k: &TileKey| Place::new(*k, remote[k], false);
        let mut ranked: Vec<(TileKey, Option<TileKey>)> = walk.wanted.clone();
        ranked.sort_by(|a, b| {
            let by_set = order[&a.1].cmp(&order[&b.1]).then(a.1.cmp(&b.1));
            by_set.then(own(&a.0).cmp(&own(&b.0))).then(a.0.cmp(&b.0))
        });
        let wanted: Vec<TileKey> = ranked.iter().map(|&(k, _)| k).collect();
        let rank = wanted.iter().enumerate().map(|(i, &k)| (k, i)).collect();
        let set_of = parent_of;
        let keep: HashSet<TileKey> = walk.split.iter().copied().collect();
        TilePlan { wanted, drawn: walk.drawn, rank, set_of, keep, coarsest: self.coarsest() }
    }

    /// Adds `key` (one of `parent`'s four, or a root) and, while it is near enough to split, its
    /// finer tiles to the walk's wanted tiles; the resident tiles that cover its area to its
    /// drawn ones, and the tiles they replace to its split ones.
    fn visit(
        &self,
        key: TileKey,
        parent: Option<TileKey>,
        cam: (f32, f32),
        options: &super::StreamOptions,
        resident: &impl Fn(TileKey) -> bool,
        walk: &mut Walk,
    ) {
        walk.wanted.push((key, parent));
        if key.0 > options.finest_level && self.remoteness(key, cam) < options.detail {
            let children = self.children(key);
            if children.iter().all(|&c| resident(c)) {
                walk.split.push(key);
                for c in children {
                    self.visit(c, Some(key), cam, options, resident, walk);
                }
                return;
            }
            walk.wanted.extend(children.into_iter().map(|c| (c, Some(key))));
        }
        if resident(key) {
            walk.drawn.push(key);
        }
    }

    /// The finer tiles that replace tile `key` (four, fewer at the map's far edges).
    fn children(&self, (level, x, y): TileKey) -> Vec<TileKey> {
        let Some(finer) = level.checked_sub(1).map(|l| &self.levels[l as usize]) else { return Vec::new() };
        [(0, 0), (1, 0), (0, 1), (1, 1)]
            .into_iter()
            .map(|(i, j)| (level - 1, 2 * x + i, 2 * y + j))
            .filter(|&(_, cx, cy)| cx < finer.grid.0 && cy < finer.grid.1)
            .collect()
    }

    /// The resident bytes a camera needs to draw the finest level `options` allow under it,
    /// wherever it stands: the coarsest level, and at each finer level the four tiles that
    /// replace the tile under the camera (`bytes` of each). Below it, a stream never reaches
    /// [`StreamOptions::finest_level`](super::StreamOptions::finest_level) under the camera.
    pub fn resident_bytes_needed(&self, options: &super::StreamOptions, bytes: &impl Fn(TileKey) -> u64) -> u64 {
        let roots: u64 = self.roots().map(bytes).sum();
        let finest = options.finest_level.min(self.coarsest());
        let level = &self.levels[finest as usize];
        let mut most = 0u64;
        for y in 0..level.grid.1 {
            for x in 0..level.grid.0 {
                let mut key = (finest, x, y);
                let mut chain = 0u64;
                while key.0 < self.coarsest() {
                    let parent = (key.0 + 1, key.1 / 2, key.2 / 2);
                    chain += self.children(parent).into_iter().map(bytes).sum::<u64>();
                    key = parent;
                }
                most = most.max(chain);
            }
        }
        roots + most
    }

    /// The resident bytes that hold everything a camera asks for at
    /// [`StreamOptions::detail`](super::StreamOptions::detail), wherever it stands (the most over
    /// cameras at tile corners and centres across the map, `bytes` of each tile): a budget with
    /// which no wanted tile is ever left out.
    pub fn resident_bytes_wanted(&self, options: &super::StreamOptions, bytes: &impl Fn(TileKey) -> u64) -> u64 {
        let level0 = &self.levels[0];
        let (sx, sy) = level0.texel;
        let width = (self.tile as f32 * sx, self.tile as f32 * sy);
        let spots = |tiles: u32| -> Vec<f32> {
            // Up to 9 tile corners and centres along an axis, the middle of the map among them.
            let step = tiles.div_ceil(8).max(1);
            (0..=tiles).step_by(step as usize).chain([tiles / 2]).flat_map(|t| [t as f32, t as f32 + 0.5]).collect()
        };
        let mut most = 0u64;
        for v in spots(level0.grid.1) {
            for u in spots(level0.grid.0) {
                let cam = (0.5 * sx + u * width.0, 0.5 * sy + v * width.1);
                let plan = self.plan(cam, options, |_| true);
                most = most.max(plan.wanted.iter().map(|&k| bytes(k)).sum());
            }
        }
        most
    }
}

/// Which tiles a [`TileLayout::plan`] walk found: each wanted tile with its parent (none for
/// the coarsest level's), the drawn ones, and the ones replaced by their finer tiles.
#[derive(Default)]
struct Walk {
    wanted: Vec<(TileKey, Option<TileKey>)>,
    drawn: Vec<TileKey>,
    split: Vec<TileKey>,
}

/// Where a set of tiles stands in a plan's order: sets near the camera (within a level-0 tile's
/// width) first, coarser first among them, then nearer; then the rest, nearer in tile widths
/// first, coarser at a tie.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Place {
    far: bool,
    first: f32,
    then: f32,
}

impl Place {
    /// Before every other: the coarsest level's.
    const FIRST: Place = Place { far: false, first: f32::NEG_INFINITY, then: f32::NEG_INFINITY };

    /// The place of tile `key`, `remoteness` tile widths from the camera, `near` it or not.
    fn new((level, ..): TileKey, remoteness: f32, near: bool) -> Place {
        let coarser_first = -(level as f32);
        if near {
            Place { far: false, first: coarser_first, then: remoteness }
        } else {
            Place { far: true, first: remoteness, then: coarser_first }
        }
    }

    fn cmp(&self, other: &Place) -> std::cmp::Ordering {
        self.far.cmp(&other.far).then(self.first.total_cmp(&other.first)).then(self.then.total_cmp(&other.then))
    }

    fn min(self, other: Place) -> Place {
        if self.cmp(&other).is_le() { self } else { other }
    }

    fn max(self, other: Place) -> Place {
        if self.cmp(&other).is_ge() { self } else { other }
    }
}

/// What a camera wants of a [`TileLayout`] now ([`TileLayout::plan`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TilePlan {
    /// The tiles wanted, most wanted first: the coarsest level, then each tile's four finer
    /// tiles together, the sets within a level-0 tile's width of the camera first (coarser
    /// first), then the others nearest in tile widths first (coarser at a tie); a set never
    /// before its parent's.
    pub wanted: Vec<TileKey>,
    /// The resident tiles to draw: together they cover the map once.
    pub drawn: Vec<TileKey>,
    rank: HashMap<TileKey, usize>,
    /// Each wanted tile's parent (the tile its set replaces), `None` for the coarsest level.
    set_of: HashMap<TileKey, Option<TileKey>>,
    /// The tiles the drawn ones hang from (replaced by their four finer tiles).
    keep: HashSet<TileKey>,
    coarsest: u32,
}

impl TilePlan {
    /// Where `key` stands in [`TilePlan::wanted`] (0 most wanted), or `None` when unwanted.
    pub fn rank(&self, key: TileKey) -> Option<usize> {
        self.rank.get(&key).copied()
    }

    /// The most wanted tiles whose bytes (`bytes` of each) fit `budget` together, whole sets of
    /// four at a time: the tiles worth reading now. A set that does not fit with the tiles before
    /// it ends the list, so no tile is read that could not be drawn (a tile is replaced only by
    /// all four), and a budget too small for the next level holds the finest it can, asking
    /// for nothing more.
    pub fn affordable(&self, budget: u64, bytes: impl Fn(TileKey) -> u64) -> &[TileKey] {
        let mut total = 0u64;
        let mut end = 0;
        let mut i = 0;
        while i < self.wanted.len() {
            let set = self.set_of[&self.wanted[i]];
            let mut j = i;
            let mut sum = 0u64;
            while j < self.wanted.len() && self.set_of[&self.wanted[j]] == set {
                sum = sum.saturating_add(bytes(self.wanted[j]));
                j += 1;
            }
            // The coarsest level is always resident: it counts, and never ends the list.
            if set.is_some() && total.saturating_add(sum) > budget {
                break;
            }
            total = total.saturating_add(sum);
            end = j;
            i = j;
        }
        &self.wanted[..end]
    }

    /// The resident tile to evict to make room for a tile coming in, from `resident` (each tile with
    /// the frame it was last drawn), when the first `affordable` wanted tiles are the ones worth
    /// holding ([`TilePlan::affordable`]): first those no longer wanted, least recently drawn
    /// first, then wanted ones past the affordable, least wanted first. Never an affordable one
    /// (the budget holds them all, so none is read again while it stays so), never one that
    /// drawn tiles hang from (a parent stays while its finer tiles are resident, as virtual
    /// texturing keeps a page's parents, so an evicted tile's area falls back one level only),
    /// never one of the coarsest level. A tile drawn by this plan may go: plan again before
    /// drawing. `None` when no tile may go.
    pub fn victim(&self, affordable: usize, resident: impl Iterator<Item = (TileKey, u64)>) -> Option<TileKey> {
        resident
            .filter(|(k, _)| k.0 != self.coarsest && !self.keep.contains(k))
            .filter(|(k, _)| self.rank(*k).is_none_or(|r| r >= affordable))
            .min_by_key(|&(k, last_used)| match self.rank(k) {
                None => (0, 0, last_used, k),
                Some(r) => (1, usize::MAX - r, last_used, k),
            })
            .map(|(k, _)| k)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A square map of `levels` levels, `grid`² tiles of `tile`² texels of `texel` m at level
    /// 0, without reading a bundle.
    pub(crate) fn square(levels: u32, grid: u32, tile: u32, texel: f32) -> TileLayout {
        let level = |k: u32| TileLevel {
            grid: (grid >> k, grid >> k),
            size: (grid * tile / (1 << k) + 1, grid * tile / (1 << k) + 1),
            texel: (texel * (1 << k) as f32, texel * (1 << k) as f32),
        };
        TileLayout {
            map: "m".into(),
            parts: TileParts { height: "m.height".into(), horizon: "m.horizon".into(), ao: None },
            levels: (0..levels).map(level).collect(),
            tile,
        }
    }

    /// A 3-level layout of 4×4 tiles at level 0.
    fn layout() -> TileLayout {
        square(3, 4, 64, 10.0)
    }

    #[test]
    fn a_tile_is_drawn_only_once_its_four_finer_tiles_are_resident() {
        let l = layout();
        let options = super::super::StreamOptions { detail: 1e9, ..Default::default() };
        // Only the root resident: the root drawn, its four children wanted.
        let plan = l.plan((5.0, 5.0), &options, |k| k.0 == 2);
        assert_eq!(plan.drawn, vec![(2, 0, 0)]);
        for c in [(1, 0, 0), (1, 1, 0), (1, 0, 1), (1, 1, 1)] {
            assert!(plan.rank(c).is_some(), "{c:?} not wanted");
        }
        // Three of four children resident: still the root.
        let plan = l.plan((5.0, 5.0), &options, |k| k.0 == 2 || (k.0 == 1 && k != (1, 1, 1)));
        assert_eq!(plan.drawn, vec![(2, 0, 0)]);
        // Everything resident: level 0 everywhere, each of its 16 tiles once.
        let plan = l.plan((5.0, 5.0), &options, |_| true);
        let mut drawn = plan.drawn.clone();
        drawn.sort();
        let all: Vec<TileKey> = (0..4).flat_map(|y| (0..4).map(move |x| (0, x, y))).collect();
        let mut all = all;
        all.sort();
        assert_eq!(drawn, all);
    }

    #[test]
    fn the_victim_is_never_affordable_split_nor_coarsest_and_unwanted_tiles_go_first() {
        let l = layout();
        // Split only the tiles under the camera: over tile (0, 0) the far corner's level-0 tile
        // is not wanted.
        let options = super::super::StreamOptions { detail: 0.5, ..Default::default() };
        let resident = |k: TileKey| k.0 == 2 || k.0 == 1;
        let plan = l.plan((5.0, 5.0), &options, resident);
        let far = (0, 3, 3);
        assert_eq!(plan.rank(far), None);
        let all = plan.wanted.len();
        let candidates = vec![((2, 0, 0), 1), (far, 7), ((1, 1, 1), 3)];
        assert_eq!(plan.victim(all, candidates.clone().into_iter()), Some(far));
        // Every wanted tile affordable: only unwanted ones may go, and here there are none.
        let drawn_now: Vec<(TileKey, u64)> = plan.drawn.iter().map(|&k| (k, 0)).collect();
        assert_eq!(plan.victim(all, drawn_now.clone().into_iter().chain([((2, 0, 0), 0)])), None);
        // Nothing affordable: a drawn level-1 tile may go, least wanted first, never the root
        // (coarsest, and the drawn tiles hang from it).
        let least = *plan.wanted.iter().rev().find(|k| plan.drawn.contains(k)).unwrap();
        assert_eq!(plan.victim(0, drawn_now.into_iter().chain([((2, 0, 0), 0)])), Some(least));
    }

    #[test]
    fn only_the_wanted_tiles_the_budget_holds_are_affordable() {
        let l = layout();
        let plan = l.plan((5.0, 5.0), &super::super::StreamOptions { detail: 1e9, ..Default::default() }, |_| true);
        assert_eq!(plan.affordable(u64::MAX, |_| 10).len(), plan.wanted.len());
        // Whole sets of four only: the root, then a set of four that does not fit 35.
        assert_eq!(plan.affordable(35, |_| 10), &plan.wanted[..1]);
        let first_set = plan.affordable(55, |_| 10);
        assert_eq!(first_set.len(), 5);
        assert!(first_set[1..].iter().all(|k| k.0 == 1), "{first_set:?}");
        // The coarsest level is always resident: it never ends the list.
        assert_eq!(plan.affordable(5, |_| 10), &plan.wanted[..1]);
    }

    /// A 2048² map in 256² tiles (4 levels), every tile 8 MiB: the flight the streaming issue
    /// measured in Bevy.
    fn map_2048() -> TileLayout {
        square(4, 8, 256, 30.0)
    }

    /// What one flight under a resident budget did, frame by frame.
    struct Flight {
        /// The level of the drawn tile under the camera, each frame.
        under: Vec<u32>,
        /// Tiles evicted while the plan still asked for them (among its affordable tiles).
        evicted_asked: usize,
        /// Tiles evicted without ever being drawn.
        never_drawn: usize,
        /// Tiles uploaded, each frame.
        uploads: Vec<usize>,
        /// The most resident bytes in any frame.
        peak: u64,
    }

    /// A flight over [`map_2048`] under `budget`, the camera at `path(t)` for `t` from 0 to 1
    /// over 240 frames: the residency loop both engines run around a [`TilePlan`] (requests of
    /// what is affordable, at most 8 in flight, each read in 2 frames; uploads of 32 MiB a
    /// frame, room made by evicting the plan's victims).
    fn fly(budget: u64, path: impl Fn(f32) -> (f32, f32)) -> Flight {
        const TILE: u64 = 8 << 20;
        let l = map_2048();
        let options = super::super::StreamOptions { resident_bytes: budget, ..Default::default() };
        let mut resident: HashMap<TileKey, (u64, bool)> = l.roots().map(|k| (k, (0, false))).collect();
        let mut pending: Vec<(TileKey, u32)> = Vec::new();
        let mut flight = Flight { under: Vec::new(), evicted_asked: 0, never_drawn: 0, uploads: Vec::new(), peak: 0 };
        let frames = 240;
        for f in 0..frames {
            let cam = path(f as f32 / (frames - 1) as f32);
            let plan = l.plan(cam, &options, |k| resident.contains_key(&k));
            // Reads done this frame, in the order the plan wants them.
            let mut ready: Vec<TileKey> = pending
                .iter()
                .filter(|(_, at)| *at <= f)
                .map(|(k, _)| *k)
                .filter(|k| plan.rank(*k).is_some())
                .collect();
            pending.retain(|(_, at)| *at > f);
            ready.sort_by_key(|k| plan.rank(*k));
            let affordable = plan.affordable(budget, |_| TILE);
            for &k in affordable {
                if pending.len() >= 8 {
                    break;
                }
                if !resident.contains_key(&k) && !pending.iter().any(|(p, _)| *p == k) && !ready.contains(&k) {
                    pending.push((k, f + 2));
                }
            }
            let mut uploaded = 0;
            for k in ready {
                if uploaded + TILE > options.upload_bytes {
                    pending.push((k, f + 1));
                    continue;
                }
                let mut fits = true;
                while (resident.len() as u64 + 1) * TILE > budget {
                    match plan.victim(affordable.len(), resident.iter().map(|(k, (last, _))| (*k, *last))) {
                        Some(v) => {
                            let (_, drawn) = resident.remove(&v).unwrap();
                            flight.never_drawn += !drawn as usize;
                            flight.evicted_asked += affordable.contains(&v) as usize;
                        }
                        None => {
                            fits = false;
                            break;
                        }
                    }
                }
                if fits {
                    resident.insert(k, (f as u64, false));
                    uploaded += TILE;
                }
            }
            // What is drawn now that tiles came and went.
            let plan = l.plan(cam, &options, |k| resident.contains_key(&k));
            for k in &plan.drawn {
                *resident.get_mut(k).expect("drawn tiles are resident") = (f as u64, true);
            }
            flight.uploads.push((uploaded / TILE) as usize);
            flight.peak = flight.peak.max(resident.len() as u64 * TILE);
            let under = plan.drawn.iter().filter(|&&k| {
                let [lo, hi] = l.rect(k);
                (lo.0..=hi.0).contains(&cam.0) && (lo.1..=hi.1).contains(&cam.1)
            });
            flight.under.push(under.map(|k| k.0).min().expect("a drawn tile under the camera"));
        }
        flight
    }

    /// Corner to corner, low, through the middle of the map where every level's tiles meet.
    fn diagonal(t: f32) -> (f32, f32) {
        let side = 2048.0 * 30.0;
        (side * (0.05 + 0.9 * t), side * (0.1 + 0.8 * t))
    }

    /// At 64, 160 and 256 MiB the level under the camera never falls back more than one level
    /// between frames (the camera moves under a tenth of a tile a frame), no tile the plan
    /// still asks for is evicted, none is loaded and evicted without being drawn, and the
    /// budget holds; the larger budgets reach level 0, the smallest holds the finest complete
    /// level it can. Hovering, the stream settles: nothing is uploaded once it holds its tiles.
    #[test]
    fn a_flight_never_collapses_nor_thrashes_at_any_budget() {
        for (mib, finest) in [(64u64, 2u32), (160, 0), (256, 0)] {
            let flight = fly(mib << 20, diagonal);
            let falls = flight.under.windows(2).filter(|w| w[1] > w[0] + 1).count();
            assert_eq!(falls, 0, "{mib} MiB: levels under the camera {:?}", flight.under);
            assert_eq!(flight.evicted_asked, 0, "{mib} MiB: tiles evicted while asked for");
            assert_eq!(flight.never_drawn, 0, "{mib} MiB: tiles evicted before ever being drawn");
            assert!(flight.peak <= mib << 20, "{mib} MiB: {} resident", flight.peak);
            let reached = *flight.under.iter().min().unwrap();
            assert_eq!(reached, finest, "{mib} MiB: finest level under the camera");

            let hover = fly(mib << 20, |_| diagonal(0.3));
            let settled = hover.uploads.iter().rposition(|&n| n > 0).unwrap_or(0);
            assert!(settled < 20, "{mib} MiB hovering: uploads until frame {settled}: {:?}", hover.uploads);
            assert_eq!((hover.evicted_asked, hover.never_drawn), (0, 0), "{mib} MiB hovering");
            assert_eq!(*hover.under.last().unwrap(), finest, "{mib} MiB hovering");
        }
    }

    /// The bytes a camera needs for level 0 under it: the coarsest tile and the four tiles
    /// around the camera at each finer level; with exactly that, a flight reaches level 0.
    #[test]
    fn the_budget_for_level_zero_is_what_a_flight_needs() {
        let l = map_2048();
        let needed = l.resident_bytes_needed(&Default::default(), &|_| 8 << 20);
        assert_eq!(needed, 13 * (8 << 20));
        assert!(l.resident_bytes_wanted(&Default::default(), &|_| 8 << 20) > needed);
        let flight = fly(needed, diagonal);
        assert_eq!(*flight.under.iter().min().unwrap(), 0);
        assert_eq!((flight.evicted_asked, flight.never_drawn), (0, 0));
        assert!(*fly(needed - 1, diagonal).under.iter().min().unwrap() > 0, "one byte less never reaches level 0");
        let coarse = super::super::StreamOptions { finest_level: 2, ..Default::default() };
        assert!(l.resident_bytes_needed(&coarse, &|_| 8 << 20) < needed);
        // A 64 MiB budget is told what level 0 needs, and that it holds level 2.
        let small = super::super::StreamOptions { resident_bytes: 64 << 20, ..Default::default() };
        let short = l.budget_shortfall(&small, |_| 8 << 20).unwrap();
        assert_eq!((short.needed, short.reachable_level, short.wanted_level), (needed, 2, 0));
        let text = short.to_string();
        assert!(text.contains("64.0 MiB") && text.contains("level 2") && text.contains("256²"), "{text}");
        let enough = super::super::StreamOptions { resident_bytes: needed, ..small };
        assert!(l.budget_shortfall(&enough, |_| 8 << 20).is_none());
    }

    #[test]
    fn tile_frames_put_nodes_on_level_zero_texels() {
        let l = layout();
        // Level 1's node 0 of tile (1, 0) is its node 64, level 0's texel 128, centred at
        // 1285 m; the tile's own frame puts its node 0 at ½·20 m.
        let (ox, oy) = l.offset((1, 1, 0));
        assert_eq!((ox + 10.0, oy + 10.0), (1285.0, 5.0));
        assert_eq!(l.rect((0, 1, 1))[0], (64.0 * 10.0 + 5.0, 64.0 * 10.0 + 5.0));
    }
}
