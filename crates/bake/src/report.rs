//! What a run baked and why: each baked job's [`Reason`], and a summary for a person that
//! groups a tiled map's tiles by level with the texels they cover.

use crate::run::RunReport;

/// Why a job was baked rather than kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reason {
    /// The bundle held none of its assets.
    New,
    /// Its inputs or settings changed: the samples a tile reads, for a tile.
    Changed,
    /// Its assets' payloads were missing or damaged.
    Damaged,
    /// `--force`.
    Forced,
}

/// One job a run baked: its id, why, and where it lies when it is a tile.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rebaked {
    /// The job's (or tile's) id.
    pub id: String,
    /// Why it was baked.
    pub reason: Reason,
    /// Its map, level and texels, for a tile.
    pub tile: Option<crate::jobs::TileArea>,
}

impl RunReport {
    /// What the run baked and why, in a few words for a person: tiles grouped by map and level,
    /// with the texels of level 0 they cover; other jobs by id. `None` when nothing was baked.
    pub fn rebaked_summary(&self) -> Option<String> {
        use std::collections::BTreeMap;
        if self.rebaked.is_empty() {
            return None;
        }
        let word = |r: Reason| match r {
            Reason::New => "new",
            Reason::Changed => "input changed",
            Reason::Damaged => "payload damaged",
            Reason::Forced => "forced",
        };
        // Per map and level: tiles, their bounding texels, and why.
        let mut maps: BTreeMap<&str, BTreeMap<u32, LevelTally>> = BTreeMap::new();
        let mut reasons: BTreeMap<&str, std::collections::BTreeSet<&str>> = BTreeMap::new();
        let mut jobs = Vec::new();
        for r in &self.rebaked {
            match &r.tile {
                Some(t) => {
                    let (x, y, w, h) = t.rect;
                    let e = maps.entry(&t.map).or_default().entry(t.level).or_default();
                    e.tiles += 1;
                    e.low = (e.low.0.min(x), e.low.1.min(y));
                    e.high = (e.high.0.max(x + w), e.high.1.max(y + h));
                    reasons.entry(&t.map).or_default().insert(word(r.reason));
                }
                None => jobs.push(format!("{} ({})", r.id, word(r.reason))),
            }
        }
        let mut parts = Vec::new();
        for (map, levels) in &maps {
            let tiles: usize = levels.values().map(|l| l.tiles).sum();
            let each: Vec<String> = levels
                .iter()
                .map(|(level, l)| {
                    let ((x0, y0), (x1, y1)) = (l.low, l.high);
                    format!("level {level}: {} in x {x0}–{}, y {y0}–{}", l.tiles, x1 - 1, y1 - 1)
                })
                .collect();
            let why: Vec<&str> = reasons[map].iter().copied().collect();
            parts.push(format!("{tiles} tiles of {map}, {} ({})", why.join(", "), each.join("; ")));
        }
        if jobs.len() > 6 {
            let more = jobs.len() - 5;
            jobs.truncate(5);
            jobs.push(format!("{more} more"));
        }
        parts.extend(jobs);
        Some(parts.join("; "))
    }
}

/// The tiles of one map and level that a run baked: how many, and the texels they cover (first
/// column and row, one past the last).
struct LevelTally {
    tiles: usize,
    low: (u32, u32),
    high: (u32, u32),
}

impl Default for LevelTally {
    fn default() -> LevelTally {
        LevelTally { tiles: 0, low: (u32::MAX, u32::MAX), high: (0, 0) }
    }
}
