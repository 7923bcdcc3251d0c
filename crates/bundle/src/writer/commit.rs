//! The commit of a [`BundleWriter`]: under the bundle's lock, the new manifest checked as a
//! reader will, the staged payloads recorded and moved to their names, the manifest replaced
//! atomically, then the payloads no manifest names any more removed once no reader can hold
//! them (see the module docs of [`super`]).

use super::*;

impl BundleWriter {
    /// Commits under the bundle's lock (see the module docs).
    pub fn commit(self) -> Result<CommitSummary, BundleError> {
        self.commit_waiting(&|_| {})
    }

    /// [`commit`](BundleWriter::commit), calling `waiting(lock file)` first when another
    /// writer holds the lock (so a command line can say why it pauses).
    pub fn commit_waiting(mut self, waiting: &dyn Fn(&Path)) -> Result<CommitSummary, BundleError> {
        let _lock = self.lock(waiting)?;
        // 0. Whose bundle it is.
        self.check_owner()?;
        // 1. The manifest as it is now, with this writer's changes, checked as a reader will.
        let current = current_manifest(&self.dir, self.ignore_bad)?;
        let new = self.apply(current.as_ref());
        let (text, tables) = checked_manifest_text(&self.dir, &new)?;
        if let Some(budget) = &new.budget {
            let overruns = budget.overruns(&new.weights());
            if !overruns.is_empty() {
                return Err(BundleError::OverBudget { path: self.dir.clone(), overruns });
            }
        }
        // 2. Staged payloads recorded, then to their names, every payload the new manifest
        // names in place; 3. the manifest. On a failure the payloads moved in are taken out
        // again: the bundle stays as it was.
        let named_now: BTreeSet<String> = current.iter().flat_map(|m| m.files()).collect();
        self.stage_shared(&new, &named_now)?;
        self.stage_tables(&tables)?;
        let new_files: BTreeSet<String> =
            new.assets.iter().map(|a| a.file.clone()).chain(tables.iter().map(|(name, _)| name.clone())).collect();
        let recorded = read_retired(&self.dir);
        let retired = self.record_pending(&named_now, &new_files, &recorded)?;
        let readers_lock_created = self.create_readers_lock()?;
        let mut moved = Vec::new();
        let written = self.place_payloads(&new, &tables, &mut moved).and_then(|()| self.write_manifest(&text));
        let manifest_written = match written {
            Ok(w) => w,
            Err(e) => {
                for file in moved.iter().filter(|f| !named_now.contains(*f)) {
                    let _ = fs::remove_file(self.dir.join(file));
                }
                if retired != recorded {
                    let _ = write_retired(&self.dir, &self.tag, &recorded);
                }
                return Err(e);
            }
        };
        self.record_owner();
        // 4. Retired payloads, and what killed writers left.
        let mut removed = self.remove_retired(&named_now, &new_files, &retired, readers_lock_created);
        removed.extend(self.sweep_dead_writers());
        removed.sort();
        let shared = new
            .assets
            .iter()
            .filter(|a| a.file != payload_file_name(&a.id, &a.blake3, a.payload.file_extension()))
            .map(|a| (a.id.clone(), a.file.clone()))
            .collect();
        Ok(CommitSummary { manifest_written, removed, shared })
    }

    /// The bundle's writer lock, held until dropped; `waiting(lock file)` is called first when
    /// another writer holds it.
    fn lock(&self, waiting: &dyn Fn(&Path)) -> Result<fs::File, BundleError> {
        let lock_path = self.dir.join(LOCK_FILE);
        let lock = open_lock_file(&lock_path)?;
        match lock.try_lock() {
            Ok(()) => {}
            Err(fs::TryLockError::WouldBlock) => {
                waiting(&lock_path);
                lock.lock().map_err(|e| BundleError::io(&lock_path, e))?;
            }
            Err(fs::TryLockError::Error(e)) => return Err(BundleError::io(&lock_path, e)),
        }
        Ok(lock)
    }

    /// Refuses a bundle another pipeline owns (unless told to take it over). A record is the
    /// owner's path relative to the bundle (or an absolute one, as older bundles hold).
    fn check_owner(&self) -> Result<(), BundleError> {
        if let Some((owner, take_over)) = &self.owner
            && let Some(recorded) = read_owner(&self.dir).filter(|r| !same_file(&self.dir, r, owner))
            && !take_over
            && self.dir.join(&recorded).exists()
        {
            let (owner, writer) = (resolved(&self.dir, &recorded), resolved(&self.dir, owner));
            return Err(BundleError::Owned { path: self.dir.clone(), owner, writer });
        }
        Ok(())
    }

    /// Stages the tile tables like payloads, unless the same bytes are in place.
    fn stage_tables(&mut self, tables: &[(String, Vec<u8>)]) -> Result<(), BundleError> {
        for (name, bytes) in tables {
            let in_place = || crate::files::read_limited(&self.dir.join(name), bytes.len() as u64, "tile table size");
            if !self.staged.contains_key(name) && !in_place().is_ok_and(|b| b == *bytes) {
                let temp = stage(&self.dir, &self.tag, name, bytes)?;
                self.staged.insert(name.clone(), temp);
            }
        }
        Ok(())
    }

    /// Records, before anything moves, what this commit places and what the manifest it
    /// replaces (naming `named_now`) names and the new one (naming `new_files`) does not — so a
    /// commit killed after its rename leaves nothing no record names. Returns the record now
    /// (`recorded` and those).
    fn record_pending(
        &self,
        named_now: &BTreeSet<String>,
        new_files: &BTreeSet<String>,
        recorded: &BTreeSet<String>,
    ) -> Result<BTreeSet<String>, BundleError> {
        let mut retired = recorded.clone();
        let placing = self.staged.keys().filter(|f| !named_now.contains(*f));
        let retiring = named_now.difference(new_files);
        let pending: BTreeSet<String> = placing.chain(retiring).cloned().collect();
        if !pending.is_subset(&retired) {
            retired.extend(pending);
            write_retired(&self.dir, &self.tag, &retired)?;
        }
        Ok(retired)
    }

    /// Creates the readers' lock before the manifest it guards, so every reader of it can lock;
    /// true when it did not exist (readers of a manifest from before could not lock, so this
    /// commit keeps their payloads).
    fn create_readers_lock(&self) -> Result<bool, BundleError> {
        let readers_path = self.dir.join(READERS_LOCK_FILE);
        match fs::OpenOptions::new().write(true).create_new(true).open(&readers_path) {
            Ok(_) => Ok(true),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(false),
            Err(e) => Err(BundleError::io(&readers_path, e)),
        }
    }

    /// Records this writer's pipeline as the bundle's owner. Best effort: a record that cannot
    /// be written only weakens the next check.
    fn record_owner(&self) {
        if let Some((owner, _)) = &self.owner
            && read_owner(&self.dir).as_ref() != Some(owner)
        {
            let _ = stage(&self.dir, &self.tag, OWNER_FILE, format!("{owner}\n").as_bytes())
                .and_then(|temp| fs::rename(&temp, self.dir.join(OWNER_FILE)).map_err(|e| BundleError::io(&temp, e)));
        }
    }

    /// Removes the retired payloads: the replaced manifest's at once when no reader can hold
    /// them (`readers_lock_created`: none could lock), else one commit later; and what the
    /// record `retired` held from before. The commit has happened: a file that cannot be
    /// removed now stays recorded for the next one. Returns the files removed.
    fn remove_retired(
        &mut self,
        named_now: &BTreeSet<String>,
        new_files: &BTreeSet<String>,
        retired: &BTreeSet<String>,
        readers_lock_created: bool,
    ) -> Vec<String> {
        drop(self.reading.take());
        let readers = crate::files::open_regular(&self.dir.join(READERS_LOCK_FILE)).ok();
        let no_reader = !readers_lock_created && readers.as_ref().is_some_and(|f| f.try_lock().is_ok());
        let mut stale: BTreeSet<String> = retired.iter().filter(|f| !named_now.contains(*f)).cloned().collect();
        let mut keep_recorded: BTreeSet<String> = BTreeSet::new();
        for file in named_now.difference(new_files) {
            if no_reader {
                stale.insert(file.clone());
            } else {
                keep_recorded.insert(file.clone());
            }
        }
        let mut removed = Vec::new();
        for name in stale.into_iter().filter(|f| !new_files.contains(f)) {
            match fs::remove_file(self.dir.join(&name)) {
                Ok(()) => removed.push(name),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(_) => {
                    keep_recorded.insert(name);
                }
            }
        }
        drop(readers);
        if keep_recorded != *retired {
            // Best effort: a record that cannot be written is rewritten by the next commit.
            let _ = write_retired(&self.dir, &self.tag, &keep_recorded);
        }
        removed
    }

    /// Makes every payload file `new` names available to place: staged, or in place and named
    /// by the manifest it replaces (`named_now`). A file shared by identical payloads is the
    /// staged file of one of them under the shared name, or a copy of one in place (when the
    /// assets sharing it changed since the last commit); staged files no asset names any more
    /// are dropped.
    fn stage_shared(&mut self, new: &Manifest, named_now: &BTreeSet<String>) -> Result<(), BundleError> {
        let wanted: BTreeSet<&str> = new.assets.iter().map(|a| a.file.as_str()).collect();
        let in_place = |dir: &Path, file: &str| fs::symlink_metadata(dir.join(file)).is_ok_and(|m| m.is_file());
        for a in &new.assets {
            if self.staged.contains_key(&a.file) || (named_now.contains(&a.file) && in_place(&self.dir, &a.file)) {
                continue;
            }
            let ext = a.payload.file_extension();
            let same = |dir: &Path, file: &str| {
                is_payload_file_of(file, &a.blake3, ext)
                    && fs::symlink_metadata(dir.join(file)).is_ok_and(|m| m.is_file() && m.len() == a.byte_length)
            };
            let spare = self
                .staged
                .iter()
                .find(|(name, temp)| {
                    !wanted.contains(name.as_str()) && is_payload_file_of(name, &a.blake3, ext) && temp.is_file()
                })
                .map(|(name, _)| name.clone());
            if let Some(name) = spare {
                let temp = self.staged.remove(&name).expect("found among the staged files");
                self.staged.insert(a.file.clone(), temp);
            } else if let Some(source) = named_now.iter().find(|f| same(&self.dir, f)) {
                let path = self.dir.join(source);
                let bytes = crate::files::read_limited(&path, a.byte_length, "payload size")?;
                if blake3::hash(&bytes).to_hex().as_str() == a.blake3 {
                    let temp = stage(&self.dir, &self.tag, &a.file, &bytes)?;
                    self.staged.insert(a.file.clone(), temp);
                }
            }
            // Otherwise the payload is missing: placing reports it, naming the asset.
        }
        let unused: Vec<String> = self.staged.keys().filter(|name| !wanted.contains(name.as_str())).cloned().collect();
        for name in unused {
            if let Some(temp) = self.staged.remove(&name) {
                let _ = fs::remove_file(temp);
            }
        }
        Ok(())
    }

    /// Removes the staged files and locks of writers that were killed; returns their names.
    fn sweep_dead_writers(&self) -> Vec<String> {
        let Ok(entries) = fs::read_dir(&self.dir) else { return Vec::new() };
        let mut dead = BTreeMap::new();
        let mut removed = Vec::new();
        for name in entries.flatten().map(|e| e.file_name().to_string_lossy().into_owned()) {
            let stale = if let Some(tag) = name.strip_prefix(TEMP_PREFIX).and_then(|rest| rest.split('.').next()) {
                let tag = tag.split_once("-s").map_or(tag, |(tag, _)| tag);
                tag != self.tag && *dead.entry(tag.to_string()).or_insert_with(|| writer_is_dead(&self.dir, tag))
            } else if let Some(tag) = name.strip_prefix(WRITER_PREFIX).and_then(|rest| rest.strip_suffix(".lock")) {
                tag != self.tag && *dead.entry(tag.to_string()).or_insert_with(|| writer_is_dead(&self.dir, tag))
            } else if name.starts_with(WRITER_PREFIX) && name.ends_with(".lock.new") {
                // A writer killed between creating its lock and naming it: an hour later.
                fs::symlink_metadata(self.dir.join(&name))
                    .and_then(|m| m.modified())
                    .is_ok_and(|t| t.elapsed().is_ok_and(|age| age > std::time::Duration::from_secs(3600)))
            } else {
                false
            };
            // Another writer's sweep may get there first; what cannot go now goes next time.
            if stale && fs::remove_file(self.dir.join(&name)).is_ok() {
                removed.push(name);
            }
        }
        removed
    }
}

/// The text of `manifest` when a reader would accept it: every asset well-formed (ids, file
/// names, descriptions, settings) and the manifest within the default [`Limits`] on assets and
/// bytes; otherwise an error naming the first problem, before anything is written.
fn checked_manifest_text(dir: &Path, manifest: &Manifest) -> Result<(String, TableFiles), BundleError> {
    let limits = Limits::default();
    let path = dir.join(MANIFEST_FILE);
    check_accepted(manifest, &limits, &path, "the new manifest's asset count (readers accept no more)")?;
    let (text, tables) = manifest.encode();
    if text.len() as u64 > limits.max_manifest_bytes {
        return Err(BundleError::Limit {
            path,
            what: format!(
                "the new manifest's size in bytes for {} assets (readers accept no more)",
                manifest.assets.len()
            ),
            value: text.len() as u64,
            limit: limits.max_manifest_bytes,
        });
    }
    Ok((text, tables))
}

/// The payload names recorded in `.hikage-retired`; names that are not plain payload names of
/// this directory are ignored (the record is never trusted to name anything else).
fn read_retired(dir: &Path) -> BTreeSet<String> {
    let limit = Limits::default().max_manifest_bytes;
    let Ok(bytes) = crate::files::read_limited(&dir.join(RETIRED_FILE), limit, "retired record size") else {
        return BTreeSet::new();
    };
    String::from_utf8_lossy(&bytes).lines().filter(|l| looks_like_payload(l)).map(str::to_string).collect()
}

/// Whether owner records `a` and `b` name one file seen from bundle `dir` (a record written
/// relative and an older one written absolute included).
fn same_file(dir: &Path, a: &str, b: &str) -> bool {
    a == b
        || match (fs::canonicalize(dir.join(a)), fs::canonicalize(dir.join(b))) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        }
}

/// Owner record `record` seen from bundle `dir`, as a path to show: joined and with its `..`
/// taken lexically (`/a/b/../p.ron` → `/a/p.ron`).
fn resolved(dir: &Path, record: &str) -> String {
    let mut path = PathBuf::new();
    for c in dir.join(record).components() {
        match c {
            std::path::Component::ParentDir if path.file_name().is_some() => {
                path.pop();
            }
            std::path::Component::CurDir => {}
            c => path.push(c),
        }
    }
    path.display().to_string()
}

/// Replaces `.hikage-retired` with `names` (through a synced temporary file and a rename), or
/// removes it when there are none.
fn write_retired(dir: &Path, tag: &str, names: &BTreeSet<String>) -> Result<(), BundleError> {
    let path = dir.join(RETIRED_FILE);
    if names.is_empty() {
        return match fs::remove_file(&path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(BundleError::io(&path, e)),
            _ => Ok(()),
        };
    }
    let text: String = names.iter().map(|n| format!("{n}\n")).collect();
    let temp = stage(dir, tag, RETIRED_FILE, text.as_bytes())?;
    fs::rename(&temp, &path).and_then(|()| sync_dir(dir)).map_err(|e| {
        let _ = fs::remove_file(&temp);
        BundleError::io(&path, e)
    })
}

/// Opens (creating it if missing) a lock file; anything but a regular file there (a FIFO would
/// block the open) is refused.
fn open_lock_file(path: &Path) -> Result<fs::File, BundleError> {
    match fs::symlink_metadata(path) {
        Ok(m) if !m.is_file() => {
            return Err(BundleError::io(
                path,
                std::io::Error::new(std::io::ErrorKind::InvalidInput, "expected a regular lock file"),
            ));
        }
        _ => {}
    }
    fs::OpenOptions::new().create(true).truncate(false).write(true).open(path).map_err(|e| BundleError::io(path, e))
}

/// True when the writer tagged `tag` is gone: its lock file is missing (a writer stages files
/// only once its lock is named), or free to take.
fn writer_is_dead(dir: &Path, tag: &str) -> bool {
    match fs::OpenOptions::new().write(true).open(dir.join(format!("{WRITER_PREFIX}{tag}.lock"))) {
        Ok(file) => match file.try_lock() {
            Ok(()) => true,
            Err(fs::TryLockError::WouldBlock) => false,
            // A file system that cannot lock: assume the writer lives (never sweep in doubt).
            Err(fs::TryLockError::Error(_)) => false,
        },
        Err(e) => e.kind() == std::io::ErrorKind::NotFound,
    }
}

impl BundleWriter {
    /// Writes `text` over `bundle.ron` through a synced temporary file and a rename, unless the
    /// file already holds those bytes; true when it wrote.
    fn write_manifest(&self, text: &str) -> Result<bool, BundleError> {
        let path = self.dir.join(MANIFEST_FILE);
        if crate::files::read_limited(&path, text.len() as u64, "manifest size").is_ok_and(|old| old == text.as_bytes())
        {
            return Ok(false);
        }
        let temp = stage(&self.dir, &self.tag, MANIFEST_FILE, text.as_bytes())?;
        if let Err(e) = fs::rename(&temp, &path).and_then(|()| sync_dir(&self.dir)) {
            let _ = fs::remove_file(&temp);
            return Err(BundleError::io(&path, e));
        }
        Ok(true)
    }

    /// Renames the staged payloads to their names (recording each in `moved`), then checks
    /// that every payload `new` names is in place.
    fn place_payloads(
        &mut self,
        new: &Manifest,
        tables: &TableFiles,
        moved: &mut Vec<String>,
    ) -> Result<(), BundleError> {
        while let Some((file, temp)) = self.staged.pop_first() {
            let target = self.dir.join(&file);
            if let Err(e) = fs::rename(&temp, &target) {
                let _ = fs::remove_file(&temp);
                return Err(BundleError::io(&target, e));
            }
            moved.push(file);
        }
        sync_dir(&self.dir).map_err(|e| BundleError::io(&self.dir, e))?;
        for a in &new.assets {
            let path = self.dir.join(&a.file);
            match fs::symlink_metadata(&path) {
                Ok(m) if m.is_file() && m.len() == a.byte_length => {}
                _ => {
                    return Err(BundleError::Payload {
                        path,
                        asset: a.id.clone(),
                        message: "the payload this commit keeps vanished while baking (another writer \
                                  removed it); nothing was committed: bake again"
                            .into(),
                    });
                }
            }
        }
        for (name, bytes) in tables {
            let path = self.dir.join(name);
            if !fs::symlink_metadata(&path).is_ok_and(|m| m.is_file() && m.len() == bytes.len() as u64) {
                return Err(BundleError::Payload {
                    path,
                    asset: name.clone(),
                    message: "the tile table this commit names vanished (another writer removed it); nothing \
                              was committed: bake again"
                        .into(),
                });
            }
        }
        Ok(())
    }
}

#[cfg(unix)]
fn sync_dir(dir: &Path) -> std::io::Result<()> {
    fs::File::open(dir)?.sync_all()
}

#[cfg(not(unix))]
fn sync_dir(_dir: &Path) -> std::io::Result<()> {
    Ok(())
}
