//! Which tiles of a terrain baked in tiles and levels of detail a camera wants, which of them
//! to draw, and which to evict for a tile coming in: the policy of [`super::TerrainStream`],
//! public for an engine that loads and uploads tiles its own way (hikage-bevy does).

use std::collections::{HashMap, HashSet};

use hikage_bundle::{Asset, TextureData, TextureDesc};

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
/// let index = hikage_runtime::hikage_bundle::tiles::TileIndex::open(dir)?;
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
    /// entry (`hikage_bundle::tiles::TileIndex::tile`, or a manifest's asset of that id). Each
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
        format!("{part}{}", hikage_bundle::tiles::tile_suffix(level, (x, y)))
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
        let dx = (lo.0 - cam.0).max(cam.0 - hi.0).max(0.0);
        let dy = (lo.1 - cam.1).max(cam.1 - hi.1).max(0.0);
        dx.hypot(dy) / (hi.0 - lo.0).max(hi.1 - lo.1).max(f32::MIN_POSITIVE)
    }

    /// The tiles a camera at `cam` (map frame, horizontal) wants and the ones to draw, given
    /// which are `resident`. From the coarsest level's tiles down, a tile is replaced by its
    /// four finer tiles while the camera is within [`StreamOptions::detail`] tile widths of it,
    /// down to [`StreamOptions::finest_level`] — and only once all four are resident, so a
    /// coarser tile is drawn while finer ones load.
    pub fn plan(
        &self,
        cam: (f32, f32),
        options: &super::StreamOptions,
        resident: impl Fn(TileKey) -> bool,
    ) -> TilePlan {
        let mut wanted = Vec::new();
        let mut drawn = Vec::new();
        for key in self.roots() {
            self.visit(key, cam, options, &resident, &mut wanted, &mut drawn);
        }
        // Most wanted first: the nearest in tile widths (the tile under the camera at 0), then
        // the coarser.
        let mut ranked: Vec<(f32, TileKey)> = wanted.iter().map(|&k| (self.remoteness(k, cam), k)).collect();
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.0.cmp(&a.1.0)).then(a.1.cmp(&b.1)));
        let wanted: Vec<TileKey> = ranked.iter().map(|&(_, k)| k).collect();
        let rank = wanted.iter().enumerate().map(|(i, &k)| (k, i)).collect();
        let drawn_set = drawn.iter().copied().collect();
        TilePlan { wanted, drawn, rank, drawn_set, coarsest: self.coarsest() }
    }

    /// Adds `key` and, while it is near enough to split, its finer tiles to `wanted`; adds the
    /// resident tiles that cover its area to `drawn`.
    fn visit(
        &self,
        key: TileKey,
        cam: (f32, f32),
        options: &super::StreamOptions,
        resident: &impl Fn(TileKey) -> bool,
        wanted: &mut Vec<TileKey>,
        drawn: &mut Vec<TileKey>,
    ) {
        wanted.push(key);
        let (level, x, y) = key;
        if level > options.finest_level && self.remoteness(key, cam) < options.detail {
            let finer = &self.levels[level as usize - 1];
            let children: Vec<TileKey> = [(0, 0), (1, 0), (0, 1), (1, 1)]
                .into_iter()
                .map(|(i, j)| (level - 1, 2 * x + i, 2 * y + j))
                .filter(|&(_, cx, cy)| cx < finer.grid.0 && cy < finer.grid.1)
                .collect();
            if children.iter().all(|&c| resident(c)) {
                for c in children {
                    self.visit(c, cam, options, resident, wanted, drawn);
                }
                return;
            }
            wanted.extend(children);
        }
        if resident(key) {
            drawn.push(key);
        }
    }
}

/// What a camera wants of a [`TileLayout`] now ([`TileLayout::plan`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TilePlan {
    /// The tiles wanted, most wanted first: nearest in tile widths, then coarser.
    pub wanted: Vec<TileKey>,
    /// The resident tiles to draw: together they cover the map once.
    pub drawn: Vec<TileKey>,
    rank: HashMap<TileKey, usize>,
    drawn_set: HashSet<TileKey>,
    coarsest: u32,
}

impl TilePlan {
    /// Where `key` stands in [`TilePlan::wanted`] (0 most wanted), or `None` when unwanted.
    pub fn rank(&self, key: TileKey) -> Option<usize> {
        self.rank.get(&key).copied()
    }

    /// The most wanted tiles whose bytes (`bytes` of each) fit `budget` together: the tiles
    /// worth reading now. Tiles past them would only wait for room the budget cannot make.
    pub fn affordable(&self, budget: u64, bytes: impl Fn(TileKey) -> u64) -> &[TileKey] {
        let mut total = 0u64;
        let n = self.wanted.iter().take_while(|&&k| {
            total = total.saturating_add(bytes(k));
            total <= budget
        });
        &self.wanted[..n.count()]
    }

    /// The resident tile to evict to make room for `incoming`, from `resident` (each tile with
    /// the frame it was last drawn): first those no longer wanted, least recently drawn first,
    /// then wanted ones less wanted than `incoming`, least wanted first; never a tile drawn now,
    /// never one of the coarsest level. `None` when no tile may go.
    pub fn victim(&self, incoming: TileKey, resident: impl Iterator<Item = (TileKey, u64)>) -> Option<TileKey> {
        let at = self.rank(incoming).unwrap_or(usize::MAX);
        resident
            .filter(|(k, _)| k.0 != self.coarsest && !self.drawn_set.contains(k))
            .filter(|(k, _)| self.rank(*k).is_none_or(|r| r > at))
            .min_by_key(|&(k, last_used)| match self.rank(k) {
                None => (0, 0, last_used, k),
                Some(r) => (1, usize::MAX - r, last_used, k),
            })
            .map(|(k, _)| k)
    }
}

/// What a tile's textures take on the device: each part's texture, the heights with the
/// one-texel apron of [`heights_with_apron`].
pub fn tile_device_bytes(entries: &[Asset]) -> u64 {
    entries
        .iter()
        .filter_map(|a| {
            let t = a.payload.texture()?;
            let apron = if a.settings.heightfield().is_some() { 2 } else { 0 };
            TextureDesc { width: t.width + apron, height: t.height + apron, ..t.clone() }.total_bytes()
        })
        .sum()
}

/// The keys of the tiles beside `key` whose heights [`heights_with_apron`] takes:
/// `[left, right, above, below]`, `None` past the map's first row or column.
pub fn apron_neighbours((level, x, y): TileKey) -> [Option<TileKey>; 4] {
    [
        x.checked_sub(1).map(|x| (level, x, y)),
        Some((level, x + 1, y)),
        y.checked_sub(1).map(|y| (level, x, y)),
        Some((level, x, y + 1)),
    ]
}

/// A tile's `heights` with one more texel on every side, so that its edge nodes' normals are
/// the whole map's: next to each edge the texel beside the shared edge in the neighbouring
/// tile (`[left, right, above, below]`, as [`apron_neighbours`] names them), or the edge texel
/// itself at the map's edge (as the one-mesh terrain clamps).
pub fn heights_with_apron(
    heights: &TextureData,
    [left, right, above, below]: &[Option<TextureData>; 4],
) -> TextureData {
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
    // A neighbour of another size (none in a bake: a row of tiles shares its rows) is ignored.
    let l = left.as_ref().filter(|t| t.desc.height as usize == h && t.desc.width >= 2);
    let r = right.as_ref().filter(|t| t.desc.height as usize == h && t.desc.width >= 2);
    let a = above.as_ref().filter(|t| t.desc.width as usize == w && t.desc.height >= 2);
    let b = below.as_ref().filter(|t| t.desc.width as usize == w && t.desc.height >= 2);
    for y in 0..h {
        out[((y + 1) * aw + 1) * tb..][..w * tb].copy_from_slice(&src[y * w * tb..][..w * tb]);
        put(&mut out, 0, y + 1, &l.map_or_else(|| texel(heights, 0, y), |t| texel(t, t.desc.width as usize - 2, y)));
        put(&mut out, w + 1, y + 1, &r.map_or_else(|| texel(heights, w - 1, y), |t| texel(t, 1, y)));
    }
    for x in 0..w {
        put(&mut out, x + 1, 0, &a.map_or_else(|| texel(heights, x, 0), |t| texel(t, x, t.desc.height as usize - 2)));
        put(&mut out, x + 1, h + 1, &b.map_or_else(|| texel(heights, x, h - 1), |t| texel(t, x, 1)));
    }
    for (cx, cy, sx, sy) in [(0, 0, 0, 0), (w + 1, 0, w - 1, 0), (0, h + 1, 0, h - 1), (w + 1, h + 1, w - 1, h - 1)] {
        put(&mut out, cx, cy, &texel(heights, sx, sy));
    }
    let desc = TextureDesc { width: aw as u32, height: ah as u32, levels: 1, ..heights.desc.clone() };
    TextureData { desc, levels: vec![out] }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3-level layout of 4×4 tiles at level 0 without reading a bundle.
    fn layout() -> TileLayout {
        let level = |k: u32| TileLevel {
            grid: (4 >> k, 4 >> k),
            size: (256 / (1 << k) + 1, 256 / (1 << k) + 1),
            texel: (10.0 * (1 << k) as f32, 10.0 * (1 << k) as f32),
        };
        TileLayout {
            map: "m".into(),
            parts: TileParts { height: "m.height".into(), horizon: "m.horizon".into(), ao: None },
            levels: (0..3).map(level).collect(),
            tile: 64,
        }
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
    fn the_victim_is_never_drawn_nor_coarsest_and_unwanted_tiles_go_first() {
        let l = layout();
        // Split only the tiles under the camera: over tile (0, 0) the far corner's level-0 tile
        // is not wanted.
        let options = super::super::StreamOptions { detail: 0.5, ..Default::default() };
        let resident = |k: TileKey| k.0 == 2 || k.0 == 1;
        let plan = l.plan((5.0, 5.0), &options, resident);
        let far = (0, 3, 3);
        assert_eq!(plan.rank(far), None);
        let near = (0, 0, 0);
        let candidates = vec![((2, 0, 0), 1), (far, 7), ((1, 1, 1), 3)];
        assert_eq!(plan.victim(near, candidates.clone().into_iter()), Some(far));
        // Without the unwanted tile only tiles drawn now or of the coarsest level remain.
        let drawn_now: Vec<(TileKey, u64)> = plan.drawn.iter().map(|&k| (k, 0)).collect();
        assert_eq!(plan.victim(near, drawn_now.into_iter().chain([((2, 0, 0), 0)])), None);
    }

    #[test]
    fn only_the_wanted_tiles_the_budget_holds_are_affordable() {
        let l = layout();
        let plan = l.plan((5.0, 5.0), &super::super::StreamOptions { detail: 1e9, ..Default::default() }, |_| true);
        assert_eq!(plan.affordable(u64::MAX, |_| 10).len(), plan.wanted.len());
        assert_eq!(plan.affordable(35, |_| 10), &plan.wanted[..3]);
        assert!(plan.affordable(5, |_| 10).is_empty());
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
