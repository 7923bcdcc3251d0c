//! A content-addressed cache of baked payloads shared between checkouts and machines
//! (`--cache DIR`, or `cache:` in `pipeline.ron`): a job's assets are stored under its input
//! hash, so a bake anywhere skips a job someone already baked from the same inputs, settings
//! and algorithm version.
//!
//! Layout: `DIR/ab/abcdef…/entry.ron` (the job's asset records) beside its payload files.
//! Entries are written whole into `DIR/tmp/` and renamed into place, so a reader sees an entry
//! complete or not at all and concurrent bakers can share the directory.
//!
//! A cache directory is shared, so its contents are untrusted: a hit is used only when its
//! records are exactly the job's assets (the ids the job makes, no more, no fewer, each well
//! formed, its payload named as the bundle names it) and every payload is a regular file whose
//! size, BLAKE3 and content check out ([`hikage_bundle::check_payload`]); anything else is a
//! miss, and the entry is removed. Nothing is followed out of the cache: symbolic links and
//! names that are not entries are skipped when walking and never removed through. The cache
//! keeps to a size bound by evicting the entries used least recently (a hit refreshes the
//! entry's time); scratch entries a killed baker left in `tmp/` are swept after an hour.
//!
//! The cache is an optimisation: the runner reports its failures as warnings and never fails a
//! bake for them.

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use hikage_bundle::{Asset, Limits, Manifest, is_payload_file_of};

use crate::error::BakeError;

/// The file naming an entry's assets.
const ENTRY_FILE: &str = "entry.ron";
/// Largest `entry.ron` read (a job's asset records are a few kilobytes).
const MAX_ENTRY_BYTES: u64 = 1 << 20;
/// Age after which a scratch entry in `tmp/` is taken for a killed baker's.
const SCRATCH_AGE: Duration = Duration::from_secs(3600);
/// The size bound of a cache a pipeline names (`cache:`), and the default of `--cache-max-gib`.
pub const DEFAULT_MAX_GIB: u64 = 20;
/// The largest size bound in GiB (`u64` bytes).
pub const MAX_GIB: u64 = u64::MAX >> 30;

/// A cache directory and its size bound.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cache {
    dir: PathBuf,
    max_bytes: u64,
}

impl Cache {
    /// The cache in `dir` (created if missing), kept to at most `max_gib` GiB of entries
    /// (at most [`MAX_GIB`]).
    pub fn open(dir: &Path, max_gib: u64) -> Result<Cache, BakeError> {
        if max_gib > MAX_GIB {
            return Err(BakeError::Limit {
                path: dir.to_path_buf(),
                what: "the cache's size bound in GiB".into(),
                value: max_gib,
                limit: MAX_GIB,
            });
        }
        let tmp = dir.join("tmp");
        std::fs::create_dir_all(&tmp).map_err(|e| BakeError::io(&tmp, e))?;
        if !is_real_dir(&tmp) {
            return Err(BakeError::io(
                &tmp,
                std::io::Error::new(std::io::ErrorKind::InvalidInput, "expected a directory, not a link"),
            ));
        }
        Ok(Cache { dir: dir.to_path_buf(), max_bytes: max_gib << 30 })
    }

    /// The cache directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The entry directory of input hash `hash`, when the hash is one (64 hex digits).
    fn entry_dir(&self, hash: &str) -> Option<PathBuf> {
        is_hash(hash).then(|| self.dir.join(&hash[..2]).join(hash))
    }

    /// The assets baked from input hash `hash` with their payloads, when the entry holds
    /// exactly `outputs` (the ids the job makes), each verified; `None` otherwise (a damaged or
    /// foreign entry is removed).
    pub fn get(&self, hash: &str, outputs: &[String]) -> Option<Vec<(Asset, Vec<u8>)>> {
        let dir = self.entry_dir(hash)?;
        // A link in place of either level is not ours to read or to remove through.
        if !is_real_dir(dir.parent()?) || !is_real_dir(&dir) {
            return None;
        }
        match self.verified(&dir, hash, outputs) {
            Some(found) => {
                // Least recently used: a hit makes the entry new again.
                if let Ok(f) = std::fs::File::options().append(true).open(dir.join(ENTRY_FILE)) {
                    let _ = f.set_modified(SystemTime::now());
                }
                Some(found)
            }
            None => {
                let _ = self.remove(&dir);
                None
            }
        }
    }

    /// The entry in `dir` when it is exactly the job's assets, every record and payload sound.
    fn verified(&self, dir: &Path, hash: &str, outputs: &[String]) -> Option<Vec<(Asset, Vec<u8>)>> {
        let bytes = hikage_bundle::files::read_limited(&dir.join(ENTRY_FILE), MAX_ENTRY_BYTES, "entry").ok()?;
        let assets: Vec<Asset> = ron::from_str(std::str::from_utf8(&bytes).ok()?).ok()?;
        let mut ids: Vec<&str> = assets.iter().map(|a| a.id.as_str()).collect();
        let mut wanted: Vec<&str> = outputs.iter().map(String::as_str).collect();
        ids.sort_unstable();
        wanted.sort_unstable();
        if ids != wanted {
            return None;
        }
        // The records as a manifest: well-formed ids, file names, descriptions and settings.
        let limits = Limits::default();
        let manifest = Manifest { assets: assets.clone(), ..Manifest::new() };
        if !hikage_bundle::validate::manifest_problems(&manifest, &limits).is_empty() {
            return None;
        }
        assets
            .into_iter()
            .map(|a| {
                let ext = a.payload.file_extension();
                if a.input_hash != hash || !is_payload_file_of(&a.file, &a.blake3, ext) {
                    return None;
                }
                let path = dir.join(&a.file);
                // Regular files only (no link out of the cache), size checked before reading.
                let meta = std::fs::symlink_metadata(&path).ok()?;
                if !meta.is_file() || meta.len() != a.byte_length {
                    return None;
                }
                let bytes = hikage_bundle::files::read_limited(&path, a.byte_length, "payload").ok()?;
                let intact = blake3::hash(&bytes).to_hex().as_str() == a.blake3
                    && hikage_bundle::check_payload(&a, &bytes, &path, &limits).is_ok();
                intact.then_some((a, bytes))
            })
            .collect()
    }

    /// Stores `assets` (baked from input hash `hash`), their payloads copied from the bundle
    /// directory `bundle` (from the file `shared` names for an asset whose identical payload
    /// the bundle stores under another asset's name), unless an entry is already there.
    pub fn put(
        &self,
        hash: &str,
        assets: &[Asset],
        bundle: &Path,
        shared: &std::collections::BTreeMap<String, String>,
    ) -> Result<(), BakeError> {
        let Some(dir) = self.entry_dir(hash) else { return Ok(()) };
        if std::fs::symlink_metadata(dir.join(ENTRY_FILE)).is_ok() {
            return Ok(());
        }
        let tmp = self.scratch(hash);
        std::fs::create_dir_all(&tmp).map_err(|e| BakeError::io(&tmp, e))?;
        let written = (|| {
            for a in assets {
                let (from, to) = (bundle.join(shared.get(&a.id).unwrap_or(&a.file)), tmp.join(&a.file));
                std::fs::copy(&from, &to).map_err(|e| BakeError::io(&from, e))?;
            }
            let text = ron::ser::to_string_pretty(assets, ron::ser::PrettyConfig::default())
                .map_err(|e| BakeError::input(&tmp, None, e.to_string()))?;
            let entry = tmp.join(ENTRY_FILE);
            std::fs::write(&entry, text).map_err(|e| BakeError::io(&entry, e))?;
            let parent = dir.parent().expect("an entry has a parent");
            std::fs::create_dir_all(parent).map_err(|e| BakeError::io(parent, e))?;
            if !is_real_dir(parent) {
                return Err(BakeError::io(
                    parent,
                    std::io::Error::new(std::io::ErrorKind::InvalidInput, "expected a directory, not a link"),
                ));
            }
            Ok(())
        })();
        // Another baker may have stored the same entry meanwhile: then ours is dropped.
        if written.is_err() || std::fs::rename(&tmp, &dir).is_err() {
            let _ = std::fs::remove_dir_all(&tmp);
        }
        written
    }

    /// Evicts the least recently used entries until the entries fit the size bound, and sweeps
    /// the scratch entries of bakers killed while storing. Only real directories named like
    /// entries are counted or removed.
    pub fn evict(&self) -> Result<(), BakeError> {
        let mut entries: Vec<(SystemTime, u64, PathBuf)> = Vec::new();
        let shards = std::fs::read_dir(&self.dir).map_err(|e| BakeError::io(&self.dir, e))?;
        for shard in shards.flatten() {
            let name = shard.file_name().to_string_lossy().into_owned();
            if name.len() != 2 || !name.bytes().all(|b| b.is_ascii_hexdigit()) || !is_real_dir(&shard.path()) {
                continue;
            }
            for entry in std::fs::read_dir(shard.path()).into_iter().flatten().flatten() {
                let dir = entry.path();
                let entry_name = entry.file_name().to_string_lossy().into_owned();
                if !is_hash(&entry_name) || !entry_name.starts_with(&name) || !is_real_dir(&dir) {
                    continue;
                }
                let Ok(meta) = std::fs::symlink_metadata(dir.join(ENTRY_FILE)) else { continue };
                let used = meta.modified().unwrap_or(SystemTime::UNIX_EPOCH);
                entries.push((used, dir_size(&dir), dir));
            }
        }
        let mut total: u64 = entries.iter().map(|e| e.1).sum();
        entries.sort();
        for (_, size, dir) in entries {
            if total <= self.max_bytes {
                break;
            }
            self.remove(&dir)?;
            total -= size;
        }
        self.sweep_scratch();
        Ok(())
    }

    /// Removes what killed bakers left in `tmp/`: anything older than [`SCRATCH_AGE`].
    fn sweep_scratch(&self) {
        let tmp = self.dir.join("tmp");
        for e in std::fs::read_dir(&tmp).into_iter().flatten().flatten() {
            let Ok(meta) = std::fs::symlink_metadata(e.path()) else { continue };
            let old = meta.modified().ok().and_then(|t| t.elapsed().ok()).is_some_and(|age| age > SCRATCH_AGE);
            if old {
                // remove_dir_all never follows a link; a link itself is removed as a file.
                let _ = if meta.is_dir() { std::fs::remove_dir_all(e.path()) } else { std::fs::remove_file(e.path()) };
            }
        }
    }

    /// A fresh path in the cache's `tmp/` (same file system as the entries, so renames are
    /// atomic), unique to this process and moment.
    fn scratch(&self, name: &str) -> PathBuf {
        let nanos = SystemTime::now().duration_since(SystemTime::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
        self.dir.join("tmp").join(format!("{name}.{}.{nanos}", std::process::id()))
    }

    /// Removes an entry (a real directory): renamed out of the way first, so no reader finds
    /// half of it.
    fn remove(&self, dir: &Path) -> Result<(), BakeError> {
        if !is_real_dir(dir) {
            return Ok(());
        }
        let trash = self.scratch("evicted");
        if std::fs::rename(dir, &trash).is_ok() {
            std::fs::remove_dir_all(&trash).map_err(|e| BakeError::io(&trash, e))?;
        }
        Ok(())
    }
}

/// True when `path` is a directory itself, not a symbolic link to one.
fn is_real_dir(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.is_dir())
}

/// True when `s` has the form of an input hash: 64 lower-case hex digits.
fn is_hash(s: &str) -> bool {
    s.len() == 64 && s.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

/// The bytes of the regular files directly in `dir` (links not followed).
fn dir_size(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|f| std::fs::symlink_metadata(f.path()).ok())
        .filter(|m| m.is_file())
        .map(|m| m.len())
        .sum()
}
