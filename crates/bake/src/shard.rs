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

/// Most shards in a split: more machines than jobs is never useful, and a part's record is
/// not trusted to size anything.
pub const MAX_SHARDS: u32 = 65_536;

/// Largest `shard.ron` read (a record is about a hundred bytes).
const MAX_RECORD_BYTES: u64 = 64 << 10;

/// Shard `index` of an N-way split (`index < count ≤` [`MAX_SHARDS`]). Every way of making one
/// — [`Shard::new`], [`Shard::parse`], reading a `shard.ron` — checks that.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "UncheckedShard")]
pub struct Shard {
    /// This shard, 0-based.
    index: u32,
    /// Shards in the split.
    count: u32,
}

/// A shard as a file spells it, before [`Shard::new`] checks it.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct UncheckedShard {
    index: u32,
    count: u32,
}

impl TryFrom<UncheckedShard> for Shard {
    type Error = String;
    fn try_from(s: UncheckedShard) -> Result<Shard, String> {
        Shard::new(s.index, s.count)
    }
}

impl Shard {
    /// Shard `index` of `count`, or why it cannot be one.
    pub fn new(index: u32, count: u32) -> Result<Shard, String> {
        if count == 0 || count > MAX_SHARDS {
            return Err(format!("a split has 1 to {MAX_SHARDS} shards, found {count}"));
        }
        if index >= count {
            return Err(format!("shard {index} of {count}: the index must be below the count"));
        }
        Ok(Shard { index, count })
    }

    /// This shard, 0-based.
    pub fn index(&self) -> u32 {
        self.index
    }

    /// Shards in the split.
    pub fn count(&self) -> u32 {
        self.count
    }

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
        Shard::new(index, count)
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
#[serde(deny_unknown_fields)]
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

    /// Reads the record of the partial bundle in `dir`: at most 64 KiB of text, every field
    /// checked (a shard of a split of 1 to [`MAX_SHARDS`], a 64-digit BLAKE3).
    pub fn read(dir: &Path) -> Result<ShardRecord, BakeError> {
        let path = dir.join(SHARD_FILE);
        let bytes = hikage_bundle::files::read_limited(&path, MAX_RECORD_BYTES, "shard record size")?;
        let text = std::str::from_utf8(&bytes)
            .map_err(|e| BakeError::input(&path, Some(format!("byte {}", e.valid_up_to())), "expected UTF-8 text"))?;
        let record: ShardRecord = ron::from_str(text).map_err(|e| {
            BakeError::input(
                &path,
                Some(format!("{}:{}", e.span.start.line, e.span.start.col)),
                format!("expected a shard record: {}", e.code),
            )
        })?;
        if record.pipeline.len() != 64 || !record.pipeline.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(BakeError::input(
                &path,
                Some("pipeline".into()),
                format!("expected a 64-digit BLAKE3, found {:?}", record.pipeline),
            ));
        }
        Ok(record)
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
/// directory `out`, replacing the bundle there; an `out` whose manifest cannot be read is
/// replaced only with `force` (as `bake --force` does). Files in `out` that no manifest of ours
/// names are left alone.
pub fn merge(out: &Path, parts: &[PathBuf], force: bool) -> Result<MergeReport, BakeError> {
    let refuse = |path: &Path, message: String| BakeError::input(path, None, message);
    let first = parts.first().ok_or_else(|| refuse(out, "merge needs at least one part".into()))?;
    let records: Vec<ShardRecord> = parts.iter().map(|p| ShardRecord::read(p)).collect::<Result<_, _>>()?;
    let count = records[0].shard.count;
    let mut seen: std::collections::BTreeMap<u32, &Path> = Default::default();
    for (part, record) in parts.iter().zip(&records) {
        if record.pipeline != records[0].pipeline {
            return Err(refuse(part, format!("is a shard of another pipeline than {}", first.display())));
        }
        if record.shard.count != count {
            return Err(refuse(
                part,
                format!("is shard {} of {}, not of {count}", record.shard.index, record.shard.count),
            ));
        }
        if let Some(other) = seen.insert(record.shard.index, part) {
            return Err(refuse(
                part,
                format!("is shard {} of {count} again (so is {})", record.shard.index, other.display()),
            ));
        }
    }
    if let Some(missing) = (0..count).find(|k| !seen.contains_key(k)) {
        return Err(refuse(out, format!("shard {missing} of {count} is missing from the parts")));
    }
    let bundles: Vec<Bundle> = parts.iter().map(|p| Bundle::open(p)).collect::<Result<_, _>>()?;
    for (part, bundle) in parts.iter().zip(&bundles) {
        let (m, m0) = (bundle.manifest(), bundles[0].manifest());
        if m.budget != m0.budget {
            return Err(refuse(
                part,
                format!("records the budget {:?}, {} records {:?}", m.budget, first.display(), m0.budget),
            ));
        }
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
    let mut writer = if force {
        BundleWriter::open_ignoring_previous(out, WriteMode::Replace)?
    } else {
        BundleWriter::open(out, WriteMode::Replace)?
    };
    // The pipeline's budget, as each part records it: the merged bundle's, checked at the commit.
    writer.set_budget(bundles[0].manifest().budget.clone());
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
            // Read with its size and hash checked against the part's manifest.
            let bytes = bundle.read_payload(asset)?;
            writer.put_existing(asset.clone(), &bytes).map_err(|e| match e {
                e @ hikage_bundle::BundleError::Io { .. } => BakeError::Bundle(e),
                e => refuse(&bundle.payload_path(asset), e.to_string()),
            })?;
        }
    }
    writer.commit()?;
    ShardRecord::clear(out)?;
    Ok(MergeReport { assets: taken.len(), parts: parts.to_vec() })
}
