//! A content-addressed cache of baked payloads shared between checkouts and machines
//! (`--cache DIR`, or `cache:` in `pipeline.ron`): a job's assets are stored under its input
//! hash, so a bake anywhere skips a job someone already baked from the same inputs, settings
//! and algorithm version.
//!
//! Layout: `DIR/ab/abcdef…/entry.ron` (the job's asset records) beside its payload files.
//! Entries are written whole into `DIR/tmp/` and renamed into place, so a reader sees an entry
//! complete or not at all and concurrent bakers can share the directory. A hit is verified —
//! every payload's size and BLAKE3 against its record — before use; a corrupt entry is removed
//! and the job baked and stored again. The cache keeps to a size bound by evicting the entries
//! used least recently (a hit refreshes the entry's time).

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use hikage_bundle::Asset;

use crate::error::BakeError;

/// The file naming an entry's assets.
const ENTRY_FILE: &str = "entry.ron";
/// Largest `entry.ron` read (a job's asset records are a few kilobytes).
const MAX_ENTRY_BYTES: u64 = 1 << 20;

/// A cache directory and its size bound.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cache {
    dir: PathBuf,
    max_bytes: u64,
}

impl Cache {
    /// The cache in `dir` (created if missing), kept to at most `max_bytes` of payloads.
    pub fn open(dir: &Path, max_bytes: u64) -> Result<Cache, BakeError> {
        std::fs::create_dir_all(dir.join("tmp")).map_err(|e| BakeError::io(dir, e))?;
        Ok(Cache { dir: dir.to_path_buf(), max_bytes })
    }

    /// The cache directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn entry_dir(&self, hash: &str) -> PathBuf {
        self.dir.join(&hash[..2.min(hash.len())]).join(hash)
    }

    /// The assets baked from input hash `hash` with their payloads, every payload verified;
    /// `None` when there is no entry or it is damaged (a damaged entry is removed).
    pub fn get(&self, hash: &str) -> Option<Vec<(Asset, Vec<u8>)>> {
        let dir = self.entry_dir(hash);
        let entry = dir.join(ENTRY_FILE);
        let len = std::fs::metadata(&entry).ok()?.len();
        let verified = (len <= MAX_ENTRY_BYTES)
            .then(|| std::fs::read_to_string(&entry).ok())
            .flatten()
            .and_then(|text| ron::from_str::<Vec<Asset>>(&text).ok())
            .and_then(|assets| {
                assets
                    .into_iter()
                    .map(|a| {
                        let bytes = std::fs::read(dir.join(&a.file)).ok()?;
                        let intact = a.input_hash == hash
                            && bytes.len() as u64 == a.byte_length
                            && blake3::hash(&bytes).to_hex().as_str() == a.blake3;
                        intact.then_some((a, bytes))
                    })
                    .collect::<Option<Vec<_>>>()
            });
        match verified {
            Some(found) => {
                // Least recently used: a hit makes the entry new again.
                if let Ok(f) = std::fs::File::options().append(true).open(&entry) {
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

    /// Stores `assets` (baked from input hash `hash`), their payloads copied from the bundle
    /// directory `bundle`, unless an entry is already there.
    pub fn put(&self, hash: &str, assets: &[Asset], bundle: &Path) -> Result<(), BakeError> {
        let dir = self.entry_dir(hash);
        if dir.join(ENTRY_FILE).exists() {
            return Ok(());
        }
        let tmp = self.scratch(hash);
        std::fs::create_dir_all(&tmp).map_err(|e| BakeError::io(&tmp, e))?;
        let written = (|| {
            for a in assets {
                let (from, to) = (bundle.join(&a.file), tmp.join(&a.file));
                std::fs::copy(&from, &to).map_err(|e| BakeError::io(&from, e))?;
            }
            let text = ron::ser::to_string_pretty(assets, ron::ser::PrettyConfig::default())
                .map_err(|e| BakeError::input(&tmp, None, e.to_string()))?;
            let entry = tmp.join(ENTRY_FILE);
            std::fs::write(&entry, text).map_err(|e| BakeError::io(&entry, e))?;
            let parent = dir.parent().expect("an entry has a parent");
            std::fs::create_dir_all(parent).map_err(|e| BakeError::io(parent, e))
        })();
        // Another baker may have stored the same entry meanwhile: then ours is dropped.
        if written.is_err() || std::fs::rename(&tmp, &dir).is_err() {
            let _ = std::fs::remove_dir_all(&tmp);
        }
        written
    }

    /// Evicts the least recently used entries until the payloads fit the size bound.
    pub fn evict(&self) -> Result<(), BakeError> {
        let mut entries: Vec<(SystemTime, u64, PathBuf)> = Vec::new();
        let shards = std::fs::read_dir(&self.dir).map_err(|e| BakeError::io(&self.dir, e))?;
        for shard in shards.flatten().filter(|e| e.file_name().len() == 2) {
            for entry in std::fs::read_dir(shard.path()).into_iter().flatten().flatten() {
                let dir = entry.path();
                let Ok(meta) = std::fs::metadata(dir.join(ENTRY_FILE)) else { continue };
                let used = meta.modified().unwrap_or(SystemTime::UNIX_EPOCH);
                let size = std::fs::read_dir(&dir)
                    .into_iter()
                    .flatten()
                    .flatten()
                    .filter_map(|f| f.metadata().ok())
                    .map(|m| m.len())
                    .sum();
                entries.push((used, size, dir));
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
        Ok(())
    }

    /// A fresh path in the cache's `tmp/` (same file system as the entries, so renames are
    /// atomic), unique to this process and moment.
    fn scratch(&self, name: &str) -> PathBuf {
        let nanos = SystemTime::now().duration_since(SystemTime::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
        self.dir.join("tmp").join(format!("{name}.{}.{nanos}", std::process::id()))
    }

    /// Removes an entry: renamed out of the way first, so no reader finds half of it.
    fn remove(&self, dir: &Path) -> Result<(), BakeError> {
        let trash = self.scratch("evicted");
        if std::fs::rename(dir, &trash).is_ok() {
            std::fs::remove_dir_all(&trash).map_err(|e| BakeError::io(&trash, e))?;
        }
        Ok(())
    }
}
