//! Splitting a pipeline over machines: `hikage bake --shard K/N` bakes the jobs whose id hashes
//! to shard K of N into a partial bundle, and [`merge`] combines the N partial bundles into the
//! bundle one machine would have baked, byte for byte.
//!
//! The split needs no coordination: a job belongs to shard `blake3(id) mod N` (the first eight
//! bytes, little-endian), so every shard of an N-way split agrees on it. A partial bundle holds
//! a `shard.ron` beside its manifest naming the pipeline (the BLAKE3 of its file) and the split;
//! merge refuses parts of different pipelines or splits, a missing or repeated shard, different
//! generators or format versions, and an asset two parts disagree on, by name.

use std::path::{Path, PathBuf};

use hikage_bundle::{Asset, Bundle, BundleWriter, WriteMode};
use serde::{Deserialize, Serialize};

use crate::error::BakeError;

/// The file beside a partial bundle's manifest that names its pipeline and split.
pub const SHARD_FILE: &str = "shard.ron";

/// Shard `index` of an N-way split (`index < count`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// This shard, 0-based.
    pub index: u32,
    /// Shards in the split.
    pub count: u32,
}

impl Shard {
    /// Parses `K/N`, or `env/N` with K from `JOB_COMPLETION_INDEX` (Kubernetes Indexed Jobs)
    /// or `SLURM_ARRAY_TASK_ID` (Slurm arrays), whichever is set.
    pub fn parse(text: &str) -> Result<Shard, String> {
        let (k, n) = text.split_once('/').ok_or("expected K/N or env/N")?;
        let count: u32 = n.trim().parse().map_err(|_| format!("shard count {n:?} is not a number"))?;
        let index: u32 = if k.trim() == "env" {
            let (name, value) = ["JOB_COMPLETION_INDEX", "SLURM_ARRAY_TASK_ID"]
                .iter()
                .find_map(|name| std::env::var(name).ok().map(|v| (*name, v)))
                .ok_or("env/N needs JOB_COMPLETION_INDEX or SLURM_ARRAY_TASK_ID to be set")?;
            value.trim().parse().map_err(|_| format!("{name}={value:?} is not a shard index"))?
        } else {
            k.trim().parse().map_err(|_| format!("shard index {k:?} is not a number"))?
        };
        if count == 0 || index >= count {
            return Err(format!("shard {index} of {count}: the index must be below the count"));
        }
        Ok(Shard { index, count })
    }

    /// Whether the job `id` is this shard's.
    pub fn has(&self, id: &str) -> bool {
        shard_of(id, self.count) == self.index
    }
}

/// The shard of an N-way split that job `id` belongs to.
pub fn shard_of(id: &str, count: u32) -> u32 {
    let hash = blake3::hash(id.as_bytes());
    let first = u64::from_le_bytes(hash.as_bytes()[..8].try_into().expect("a hash has 32 bytes"));
    (first % count.max(1) as u64) as u32
}

/// What `shard.ron` records.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardRecord {
    /// BLAKE3 of the pipeline file's bytes.
    pub pipeline: String,
    /// The split this part belongs to.
    pub shard: Shard,
}

impl ShardRecord {
    /// The record for `shard` of the pipeline file at `path`.
    pub fn new(path: &Path, shard: Shard) -> Result<ShardRecord, BakeError> {
        let bytes = std::fs::read(path).map_err(|e| BakeError::io(path, e))?;
        Ok(ShardRecord { pipeline: blake3::hash(&bytes).to_hex().to_string(), shard })
    }

    /// Writes the record into the bundle directory `dir` (write, then rename).
    pub fn write(&self, dir: &Path) -> Result<(), BakeError> {
        let text = ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default()).expect("a record serialises");
        let (tmp, path) = (dir.join(".shard.ron.new"), dir.join(SHARD_FILE));
        std::fs::write(&tmp, text + "\n").map_err(|e| BakeError::io(&tmp, e))?;
        std::fs::rename(&tmp, &path).map_err(|e| BakeError::io(&path, e))
    }

    /// Removes the record of the bundle in `dir`, if any: a whole bundle (baked without a shard,
    /// or merged) must not pass for a part.
    pub fn clear(dir: &Path) -> Result<(), BakeError> {
        let path = dir.join(SHARD_FILE);
        match std::fs::remove_file(&path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(BakeError::io(&path, e)),
            _ => Ok(()),
        }
    }

    /// Reads the record of the partial bundle in `dir`.
    pub fn read(dir: &Path) -> Result<ShardRecord, BakeError> {
        let path = dir.join(SHARD_FILE);
        let text = std::fs::read_to_string(&path).map_err(|e| BakeError::io(&path, e))?;
        ron::from_str(&text).map_err(|e| BakeError::input(&path, None, format!("expected a shard record: {e}")))
    }
}

/// What a merge did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MergeReport {
    /// Assets in the merged bundle.
    pub assets: usize,
    /// The parts merged.
    pub parts: Vec<PathBuf>,
}

/// Merges the partial bundles `parts` (all N shards of one pipeline's split) into the bundle
/// directory `out`, replacing what was there: the bundle a one-machine bake makes.
pub fn merge(out: &Path, parts: &[PathBuf]) -> Result<MergeReport, BakeError> {
    let refuse = |path: &Path, message: String| BakeError::input(path, None, message);
    let first = parts.first().ok_or_else(|| refuse(out, "merge needs at least one part".into()))?;
    let records: Vec<ShardRecord> = parts.iter().map(|p| ShardRecord::read(p)).collect::<Result<_, _>>()?;
    let bundles: Vec<Bundle> = parts.iter().map(|p| Bundle::open(p)).collect::<Result<_, _>>()?;
    let count = records[0].shard.count;
    let mut seen = vec![None::<&Path>; count as usize];
    for ((part, record), bundle) in parts.iter().zip(&records).zip(&bundles) {
        if record.pipeline != records[0].pipeline {
            return Err(refuse(part, format!("is a shard of another pipeline than {}", first.display())));
        }
        if record.shard.count != count {
            return Err(refuse(
                part,
                format!("is shard {} of {}, not of {count}", record.shard.index, record.shard.count),
            ));
        }
        if let Some(other) = seen[record.shard.index as usize].replace(part) {
            return Err(refuse(
                part,
                format!("is shard {} of {count} again (so is {})", record.shard.index, other.display()),
            ));
        }
        let (m, m0) = (bundle.manifest(), bundles[0].manifest());
        if m.generator != m0.generator || m.format != m0.format {
            return Err(refuse(
                part,
                format!(
                    "was written by {} (format {}), {} by {} (format {})",
                    m.generator,
                    m.format,
                    first.display(),
                    m0.generator,
                    m0.format
                ),
            ));
        }
    }
    if let Some(missing) = seen.iter().position(Option::is_none) {
        return Err(refuse(out, format!("shard {missing} of {count} is missing from the parts")));
    }
    let mut writer = BundleWriter::open_ignoring_previous(out, WriteMode::Replace)?;
    let mut taken: std::collections::BTreeMap<&str, (&Asset, &Path)> = Default::default();
    for (part, bundle) in parts.iter().zip(&bundles) {
        for asset in &bundle.manifest().assets {
            if let Some((other, from)) = taken.insert(&asset.id, (asset, part)) {
                if other != asset {
                    return Err(refuse(
                        part,
                        format!("asset `{}` differs from the one in {}", asset.id, from.display()),
                    ));
                }
                continue;
            }
            let path = part.join(&asset.file);
            let bytes = std::fs::read(&path).map_err(|e| BakeError::io(&path, e))?;
            writer.put_existing(asset.clone(), &bytes).map_err(|e| refuse(&path, e.to_string()))?;
        }
    }
    writer.commit()?;
    ShardRecord::clear(out)?;
    Ok(MergeReport { assets: taken.len(), parts: parts.to_vec() })
}
