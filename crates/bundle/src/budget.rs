//! Byte budgets a bundle must keep: bytes on disk and in GPU memory for the whole bundle, per
//! job and per asset. A pipeline states them, the bake refuses to commit a bundle over them, and
//! the manifest records them so `hikage validate` checks a shipped bundle against the same
//! numbers.
//!
//! ```ron
//! budget: (
//!     disk: Some(40_000_000),                           // the payloads on disk
//!     gpu: Some(128_000_000),                           // uploaded as stored
//!     jobs: { "head": (disk: Some(20_000_000)) },       // a job's assets: `head`, `head.*`
//!     assets: { "terrain.horizon": (gpu: Some(16_777_216)) },
//! )
//! ```

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

/// What a bundle may take, in bytes: as a whole, per job (the assets the job makes: its id, or
/// ids starting `<id>.`) and per asset. Each figure is optional.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Budget {
    /// The payloads' bytes on disk, all assets.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disk: Option<u64>,
    /// GPU memory of all assets uploaded as stored (`hikage inspect`'s figure).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu: Option<u64>,
    /// Per job id.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub jobs: BTreeMap<String, Limit>,
    /// Per asset id.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub assets: BTreeMap<String, Limit>,
}

/// A job's or an asset's share of a [`Budget`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limit {
    /// Bytes on disk.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disk: Option<u64>,
    /// Bytes in GPU memory.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu: Option<u64>,
}

/// Which figure a budget bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Figure {
    /// Bytes on disk.
    Disk,
    /// Bytes in GPU memory.
    Gpu,
}

impl fmt::Display for Figure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Figure::Disk => "on disk",
            Figure::Gpu => "in GPU memory",
        })
    }
}

/// One figure over its budget: what, by how much, and the asset that weighs most in it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Overrun {
    /// `bundle`, `job \`id\`` or `asset \`id\``.
    pub scope: String,
    /// The figure.
    pub figure: Figure,
    /// Its bytes.
    pub bytes: u64,
    /// The budget.
    pub budget: u64,
    /// The largest asset counted, and its bytes.
    pub largest: Option<(String, u64)>,
}

impl fmt::Display for Overrun {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {} bytes {}, over its budget of {}", self.scope, self.bytes, self.figure, self.budget)?;
        match &self.largest {
            Some((id, bytes)) if !self.scope.starts_with("asset") => write!(f, " (largest: `{id}`, {bytes} bytes)"),
            _ => Ok(()),
        }
    }
}

/// One asset as a budget weighs it: its id, the file it is stored in, and its bytes on disk and
/// in GPU memory ([`crate::Asset::weight`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Weight<'a> {
    /// The asset's id.
    pub id: &'a str,
    /// Its payload file: identical payloads share one, counted once on disk.
    pub file: &'a str,
    /// Bytes on disk.
    pub disk: u64,
    /// Bytes in GPU memory.
    pub gpu: u64,
}

impl Budget {
    /// Every figure of a bundle's `assets` over this budget, the bundle's first, then each
    /// job's and asset's in id order. A job or asset the budget names and the bundle lacks
    /// counts as 0.
    pub fn overruns(&self, assets: &[Weight<'_>]) -> Vec<Overrun> {
        let mut out = Vec::new();
        let mut check = |scope: String, limit: Limit, assets: &[&Weight<'_>]| {
            let on_disk: fn(&Weight<'_>) -> u64 = |a| a.disk;
            let on_gpu: fn(&Weight<'_>) -> u64 = |a| a.gpu;
            for (figure, budget, bytes) in [(Figure::Disk, limit.disk, on_disk), (Figure::Gpu, limit.gpu, on_gpu)] {
                let Some(budget) = budget else { continue };
                // A file shared by identical payloads is on disk once; each asset is uploaded.
                let total = match figure {
                    Figure::Disk => disk_bytes(assets.iter().map(|a| (a.file, a.disk))),
                    Figure::Gpu => assets.iter().map(|a| bytes(a)).fold(0u64, u64::saturating_add),
                };
                if total > budget {
                    let largest = assets.iter().max_by_key(|a| bytes(a)).map(|a| (a.id.to_string(), bytes(a)));
                    out.push(Overrun { scope: scope.clone(), figure, bytes: total, budget, largest });
                }
            }
        };
        let mut all: Vec<&Weight<'_>> = assets.iter().collect();
        all.sort_by(|a, b| a.id.cmp(b.id));
        check("bundle".into(), Limit { disk: self.disk, gpu: self.gpu }, &all);
        for (job, limit) in &self.jobs {
            let made: Vec<&Weight<'_>> = all.iter().copied().filter(|a| made_by(a.id, job)).collect();
            check(format!("job `{job}`"), *limit, &made);
        }
        for (id, limit) in &self.assets {
            let asset: Vec<&Weight<'_>> = all.iter().copied().filter(|a| a.id == id).collect();
            check(format!("asset `{id}`"), *limit, &asset);
        }
        out
    }
}

/// Whether asset `id` is one job `job` makes: `job` itself or `job.<part>`.
pub fn made_by(id: &str, job: &str) -> bool {
    id.strip_prefix(job).is_some_and(|rest| rest.is_empty() || rest.starts_with('.'))
}

/// Bytes on disk of the payload files `(file, bytes)`, a file shared by identical payloads
/// counted once.
pub fn disk_bytes<'a>(files: impl Iterator<Item = (&'a str, u64)>) -> u64 {
    let files: std::collections::BTreeMap<&str, u64> = files.collect();
    files.values().fold(0u64, |sum, &b| sum.saturating_add(b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::asset::{Asset, AssetKind, Payload};
    use crate::manifest::Manifest;
    use crate::settings::Settings;
    use crate::texture::{Supercompression, TextureDesc, TextureDimension, TextureFormat};

    fn texture(id: &str, side: u32, byte_length: u64) -> Asset {
        Asset {
            id: id.into(),
            kind: AssetKind::Texture,
            file: format!("{id}.ktx2"),
            byte_length,
            blake3: "0".repeat(64),
            input_hash: String::new(),
            payload: Payload::Texture(TextureDesc {
                format: TextureFormat::R8Unorm,
                dimension: TextureDimension::D2,
                width: side,
                height: side,
                depth: 1,
                layers: 1,
                levels: 1,
                supercompression: Supercompression::Zstd,
                channels: vec!["v".into()],
            }),
            settings: Settings::Generic,
        }
    }

    #[test]
    fn each_scope_and_figure_is_counted_by_hand() {
        let mut m = Manifest::new();
        // GPU bytes: 100², 10², 20² one-byte texels.
        m.assets = vec![texture("a.big", 100, 900), texture("a.small", 10, 50), texture("b", 20, 300)];
        let none = Budget::default();
        assert!(none.overruns(&m.weights()).is_empty());
        let budget = Budget {
            disk: Some(1_249),
            gpu: Some(10_500),
            jobs: BTreeMap::from([("a".into(), Limit { disk: Some(950), gpu: Some(10_100) })]),
            assets: BTreeMap::from([("b".into(), Limit { disk: None, gpu: Some(399) })]),
        };
        // The bundle's disk bytes one over; its GPU bytes (10,500) and job `a`'s figures (950 on
        // disk, 10,100 in GPU memory) exactly at their budgets, which is within them.
        let found: Vec<String> = budget.overruns(&m.weights()).iter().map(ToString::to_string).collect();
        assert_eq!(
            found,
            [
                "bundle: 1250 bytes on disk, over its budget of 1249 (largest: `a.big`, 900 bytes)",
                "asset `b`: 400 bytes in GPU memory, over its budget of 399",
            ]
        );
        // Exactly at the budget is within it; one byte more is not.
        let tight =
            Budget { jobs: BTreeMap::from([("a".into(), Limit { disk: Some(949), gpu: None })]), ..Budget::default() };
        assert_eq!(
            tight.overruns(&m.weights())[0].to_string(),
            "job `a`: 950 bytes on disk, over its budget of 949 (largest: `a.big`, 900 bytes)"
        );
        assert!(made_by("a.big", "a") && made_by("a", "a") && !made_by("ab", "a"));
    }
}
