//! Crash-safe, concurrency-safe bundle writing.
//!
//! A writer stages each payload in a synced temporary file while it bakes, outside any lock.
//! [`BundleWriter::commit`] then, holding an exclusive lock on `.hikage.lock` in the bundle
//! directory:
//!
//! 1. re-reads the manifest as it is now (another writer may have committed since this one
//!    opened) and applies this writer's changes to it — in [`WriteMode::Update`] its own
//!    additions, replacements and removals; in [`WriteMode::Replace`] exactly its own assets —
//!    then checks the result as a reader will (ids, file names, descriptions, the number of
//!    assets and the manifest's size against [`Limits`]): a commit never leaves a bundle that
//!    [`crate::validate()`] or the next bake would refuse;
//! 2. records the payloads it is about to place in `.hikage-retired` (so a commit killed from
//!    here on leaves nothing a later commit cannot name), renames its staged payloads to their
//!    content-derived names (a name never holds other bytes, so a reader of the current manifest
//!    is never disturbed) and checks that every payload the new manifest names is in place;
//! 3. writes the manifest to a temporary file, syncs it and renames it over `bundle.ron`;
//! 4. removes the payloads the replaced manifest named and the new one does not — at once when
//!    no reader holds the bundle's [`READERS_LOCK_FILE`] (every [`Bundle`] holds it shared while
//!    it lives), else one commit later, for a reader that opened the replaced manifest (readers
//!    retry against the newest manifest if two commits pass during a read). Only files a
//!    manifest or `.hikage-retired` of this bundle named are ever removed: a file of the user's
//!    that merely looks like a payload stays.
//!
//! A process killed at any point leaves the old or the new manifest, each with all its
//! payloads; a failed write leaves the old one untouched. Each writer holds a lock on a file of
//! its own (`.hikage-writer-<tag>.lock`) while it lives and tags its staged files with it: a
//! commit sweeps the staged files whose writer's lock is free (the writer was killed), never
//! those of a writer still baking.
//!
//! Locking uses [`std::fs::File::lock`] (`flock` on Unix, `LockFileEx` on Windows). It holds
//! between processes on one machine and on NFS (Linux emulates `flock` with POSIX locks there);
//! on a file system that cannot lock, the commit fails with an I/O error naming the lock file
//! rather than writing unlocked.

mod commit;

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::asset::{Asset, Payload};
use crate::bundle::{Bundle, READERS_LOCK_FILE, check_accepted, reader_lock};
use crate::error::BundleError;
use crate::limits::Limits;
use crate::manifest::{MANIFEST_FILE, Manifest};
use crate::mesh::MeshData;
use crate::names::{check_asset_id, is_payload_file_of, looks_like_payload, payload_file_name};
use crate::settings::Settings;
use crate::texture::{Supercompression, TextureData};
use crate::tiles::TableFiles;
use crate::validate::{check_mesh, check_payload, check_texture};

const TEMP_PREFIX: &str = ".hikage-tmp-";

/// The lock file writers hold while they commit.
pub const LOCK_FILE: &str = ".hikage.lock";

/// Prefix of a writer's own lock file, held while the writer lives.
const WRITER_PREFIX: &str = ".hikage-writer-";

/// The payloads a commit placed or replaced that no manifest may name any more: removed by a
/// later commit once no reader can hold them. One file name per line.
pub const RETIRED_FILE: &str = ".hikage-retired";

/// The pipeline a bundle belongs to (`WriteMode::Replace` writers record and check it): one
/// line naming it.
pub const OWNER_FILE: &str = ".hikage-owner";

/// What the new manifest is made of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WriteMode {
    /// Exactly the assets put or kept by this writer: a pipeline owns its bundle, and assets it
    /// did not make (removed jobs, one-shots into its bundle) go.
    Replace,
    /// The manifest as it is at commit, with this writer's additions, replacements and removals
    /// applied: a one-shot command adding to a bundle others also write.
    Update,
}

/// What a commit changed.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CommitSummary {
    /// True when `bundle.ron` was rewritten (false when it already had the same bytes).
    pub manifest_written: bool,
    /// Payload files removed because neither the new nor the replaced manifest names them.
    pub removed: Vec<String>,
    /// Assets whose payload is stored once under another asset's file, the bytes being the same
    /// (see [`BundleWriter::commit`]): id → the file the committed manifest names.
    pub shared: BTreeMap<String, String>,
}

/// Writes a bundle directory transactionally; see the module docs for the order of writes.
///
/// Dropping a writer without [`commit`](BundleWriter::commit) removes what it staged, leaving
/// the bundle as it was.
#[derive(Debug)]
pub struct BundleWriter {
    dir: PathBuf,
    mode: WriteMode,
    ignore_bad: bool,
    previous: Option<Manifest>,
    /// This writer's changes: an asset put or kept, or `None` for one removed.
    changes: BTreeMap<String, Option<Asset>>,
    /// Staged payloads: final file name → temporary path.
    staged: BTreeMap<String, PathBuf>,
    /// This writer's tag in the names of its staged files and of its lock.
    tag: String,
    /// This writer's own lock, held while it lives.
    alive: Option<(fs::File, PathBuf)>,
    /// A shared lock on the readers' lock file while the writer may read payloads of the
    /// previous manifest (to keep them).
    reading: Option<fs::File>,
    /// The owner this writer commits as, and whether it may take over another's bundle.
    owner: Option<(String, bool)>,
    /// The budget the committed bundle must keep, and records.
    budget: Option<crate::budget::Budget>,
}

impl BundleWriter {
    /// Opens `dir` for writing, creating it if needed. An existing manifest must parse and have
    /// a supported major version: a bundle this reader does not understand is never replaced.
    pub fn open(dir: &Path, mode: WriteMode) -> Result<BundleWriter, BundleError> {
        Self::open_inner(dir, mode, false)
    }

    /// Like [`open`](BundleWriter::open), but an existing manifest that cannot be read is
    /// ignored (and replaced on commit). Used by `bake --force`.
    pub fn open_ignoring_previous(dir: &Path, mode: WriteMode) -> Result<BundleWriter, BundleError> {
        Self::open_inner(dir, mode, true)
    }

    fn open_inner(dir: &Path, mode: WriteMode, ignore_bad: bool) -> Result<BundleWriter, BundleError> {
        fs::create_dir_all(dir).map_err(|e| BundleError::io(dir, e))?;
        // The writer reads the previous payloads it keeps, so it is a reader too.
        let reading = reader_lock(dir);
        let previous = current_manifest(dir, ignore_bad)?;
        // The writer's lock appears under its name only once held: a sweep that finds it free
        // may take its writer for dead.
        let tag = writer_tag();
        let path = dir.join(format!("{WRITER_PREFIX}{tag}.lock"));
        let pending = dir.join(format!("{WRITER_PREFIX}{tag}.lock.new"));
        let file = fs::File::create_new(&pending).map_err(|e| BundleError::io(&pending, e))?;
        let held = file.lock().and_then(|()| fs::rename(&pending, &path));
        if let Err(e) = held {
            let _ = fs::remove_file(&pending);
            return Err(BundleError::io(&path, e));
        }
        Ok(BundleWriter {
            dir: dir.to_path_buf(),
            mode,
            ignore_bad,
            previous,
            changes: BTreeMap::new(),
            staged: BTreeMap::new(),
            tag,
            alive: Some((file, path)),
            reading,
            owner: None,
            budget: None,
        })
    }

    /// The bundle directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The owner recorded in the bundle (the pipeline that last replaced it), if any.
    pub fn recorded_owner(&self) -> Option<String> {
        read_owner(&self.dir)
    }

    /// Commits as `owner` (the path of a pipeline file, relative to the bundle directory or
    /// absolute): the commit is refused when another owner is recorded whose file still exists,
    /// unless `take_over`, and records `owner` afterwards. Two pipelines sharing one output then fail by name instead of the last writer
    /// silently winning; a checkout that moved takes its bundle back.
    pub fn set_owner(&mut self, owner: &str, take_over: bool) {
        self.owner = Some((owner.to_string(), take_over));
    }

    /// Commits only a bundle within `budget`, and records it in the manifest (`None`: no
    /// budget; a writer in [`WriteMode::Update`] then keeps the bundle's own).
    pub fn set_budget(&mut self, budget: Option<crate::budget::Budget>) {
        self.budget = budget;
    }

    /// The manifest that was in place when the writer opened, if any.
    pub fn previous(&self) -> Option<&Manifest> {
        self.previous.as_ref()
    }

    /// The previous asset `id` when it was baked from the same `input_hash` and its payload is
    /// intact (size and BLAKE3 match), so the job that makes it can be skipped.
    pub fn reusable(&self, id: &str, input_hash: &str) -> Option<Asset> {
        let asset = self.previous.as_ref()?.asset(id)?;
        if asset.input_hash != input_hash {
            return None;
        }
        let bytes = crate::files::read_limited(&self.dir.join(&asset.file), asset.byte_length, "payload size").ok()?;
        (bytes.len() as u64 == asset.byte_length && blake3::hash(&bytes).to_hex().as_str() == asset.blake3)
            .then(|| asset.clone())
    }

    /// Puts an asset into the new manifest unchanged (its payload is already in place).
    pub fn keep(&mut self, asset: Asset) {
        self.changes.insert(asset.id.clone(), Some(asset));
    }

    /// Removes asset `id` from the new manifest (its payload goes one commit later).
    pub fn remove(&mut self, id: &str) {
        self.changes.insert(id.to_string(), None);
    }

    /// Stages the payload of an asset taken from another bundle (merging shards) and adds or
    /// replaces it; the bytes must be the asset's own (length, BLAKE3 and file name agree).
    pub fn put_existing(&mut self, asset: Asset, bytes: &[u8]) -> Result<(), BundleError> {
        check_asset_id(&asset.id).map_err(|m| BundleError::InvalidData(format!("asset {m}")))?;
        let hash = blake3::hash(bytes).to_hex().to_string();
        let ext = asset.file.rsplit_once('.').map(|(_, e)| e).unwrap_or_default();
        if bytes.len() as u64 != asset.byte_length || hash != asset.blake3 {
            return Err(BundleError::InvalidData(format!(
                "asset `{}`: payload of {} bytes with BLAKE3 {hash} does not match its manifest entry ({} bytes, {})",
                asset.id,
                bytes.len(),
                asset.byte_length,
                asset.blake3
            )));
        }
        if ext != asset.payload.file_extension() || !is_payload_file_of(&asset.file, &hash, ext) {
            return Err(BundleError::InvalidData(format!(
                "asset `{}`: unexpected payload file name `{}`",
                asset.id, asset.file
            )));
        }
        check_payload(&asset, bytes, &self.dir.join(&asset.file), &Limits::default())?;
        if !self.staged.contains_key(&asset.file) {
            let temp = stage(&self.dir, &self.tag, &asset.file, bytes)?;
            self.staged.insert(asset.file.clone(), temp);
        }
        self.changes.insert(asset.id.clone(), Some(asset));
        Ok(())
    }

    /// Encodes a texture as KTX2, stages it, and adds or replaces asset `id`.
    pub fn put_texture(
        &mut self,
        id: &str,
        settings: Settings,
        input_hash: &str,
        texture: &TextureData,
    ) -> Result<Asset, BundleError> {
        self.put_texture_with(id, settings, input_hash, texture, &crate::zstd::fastest)
    }

    /// [`put_texture`](Self::put_texture), its levels compressed by `zstd` when its description
    /// asks for zstd supercompression.
    pub fn put_texture_with(
        &mut self,
        id: &str,
        settings: Settings,
        input_hash: &str,
        texture: &TextureData,
        zstd: crate::zstd::Encoder,
    ) -> Result<Asset, BundleError> {
        check_texture(texture).map_err(|m| BundleError::InvalidData(format!("asset `{id}`: {m}")))?;
        let bytes = crate::ktx2_file::encode_with(texture, crate::GENERATOR, zstd)?;
        self.put_payload(id, settings, input_hash, Payload::Texture(texture.desc.clone()), &bytes, "ktx2")
    }

    /// Stages a mesh payload and adds or replaces asset `id`.
    pub fn put_mesh(
        &mut self,
        id: &str,
        settings: Settings,
        input_hash: &str,
        mesh: &MeshData,
    ) -> Result<Asset, BundleError> {
        self.put_mesh_with(id, settings, input_hash, mesh, &crate::zstd::fastest)
    }

    /// [`put_mesh`](Self::put_mesh), its bytes stored as one frame compressed by `zstd` when its
    /// description asks for zstd supercompression.
    pub fn put_mesh_with(
        &mut self,
        id: &str,
        settings: Settings,
        input_hash: &str,
        mesh: &MeshData,
        zstd: crate::zstd::Encoder,
    ) -> Result<Asset, BundleError> {
        mesh.desc
            .check(mesh.bytes.len() as u64)
            .and_then(|()| check_mesh(&mesh.desc, &mesh.bytes))
            .map_err(|m| BundleError::InvalidData(format!("asset `{id}`: {m}")))?;
        let payload = Payload::Mesh(mesh.desc.clone());
        match mesh.desc.supercompression {
            Supercompression::None => self.put_payload(id, settings, input_hash, payload, &mesh.bytes, "bin"),
            Supercompression::Zstd => self.put_payload(id, settings, input_hash, payload, &zstd(&mesh.bytes), "bin"),
        }
    }

    fn put_payload(
        &mut self,
        id: &str,
        settings: Settings,
        input_hash: &str,
        payload: Payload,
        bytes: &[u8],
        ext: &str,
    ) -> Result<Asset, BundleError> {
        check_asset_id(id).map_err(|m| BundleError::InvalidData(format!("asset {m}")))?;
        let hash = blake3::hash(bytes).to_hex().to_string();
        let file = payload_file_name(id, &hash, ext);
        if !self.staged.contains_key(&file) {
            let temp = stage(&self.dir, &self.tag, &file, bytes)?;
            self.staged.insert(file.clone(), temp);
        }
        let asset = Asset {
            id: id.to_string(),
            kind: settings.kind(&payload),
            file,
            byte_length: bytes.len() as u64,
            blake3: hash,
            input_hash: input_hash.to_string(),
            payload,
            settings,
        };
        self.changes.insert(id.to_string(), Some(asset.clone()));
        Ok(asset)
    }

    /// The manifest this writer's changes make of `base` (the manifest at commit).
    fn apply(&self, base: Option<&Manifest>) -> Manifest {
        let mut assets: BTreeMap<String, Asset> = match (self.mode, base) {
            (WriteMode::Update, Some(m)) => m.assets.iter().map(|a| (a.id.clone(), a.clone())).collect(),
            _ => BTreeMap::new(),
        };
        for (id, change) in &self.changes {
            match change {
                Some(asset) => assets.insert(id.clone(), asset.clone()),
                None => assets.remove(id),
            };
        }
        let mut m = Manifest::new();
        m.assets = assets.into_values().collect();
        share_identical_payloads(&mut m.assets);
        m.budget = match (&self.budget, self.mode, base) {
            (Some(b), ..) => Some(b.clone()),
            (None, WriteMode::Update, Some(base)) => base.budget.clone(),
            _ => None,
        };
        m
    }

    /// The manifest [`commit`](BundleWriter::commit) would write if nobody else committed first.
    pub fn manifest(&self) -> Manifest {
        let current = current_manifest(&self.dir, true).ok().flatten();
        self.apply(current.as_ref().or(self.previous.as_ref()))
    }
}

/// Points assets whose payloads are the same bytes (BLAKE3, length and extension) at one file,
/// named after the first of their ids, so a bundle stores them once (format 1.10); every other
/// asset names its own content-derived file. Tiles are left out: a tile's entry is rebuilt from
/// its tile-table record, which names its own file. `assets` are in id order, so the shared
/// name does not depend on the order in which jobs were baked.
fn share_identical_payloads(assets: &mut [Asset]) {
    let mut first: BTreeMap<(String, u64, &'static str), String> = BTreeMap::new();
    for a in assets.iter_mut().filter(|a| a.settings.tile().is_none()) {
        let ext = a.payload.file_extension();
        let owner = first.entry((a.blake3.clone(), a.byte_length, ext)).or_insert_with(|| a.id.clone());
        a.file = payload_file_name(owner, &a.blake3, ext);
    }
}

/// The owner recorded in `dir`, if any (the first line of `.hikage-owner`, at most 64 KiB).
fn read_owner(dir: &Path) -> Option<String> {
    let bytes = crate::files::read_limited(&dir.join(OWNER_FILE), 64 << 10, "owner record size").ok()?;
    String::from_utf8_lossy(&bytes).lines().next().map(str::to_string).filter(|l| !l.is_empty())
}

impl Drop for BundleWriter {
    fn drop(&mut self) {
        for temp in self.staged.values() {
            let _ = fs::remove_file(temp);
        }
        if let Some((file, path)) = self.alive.take() {
            drop(file);
            let _ = fs::remove_file(path);
        }
    }
}

/// A tag no other writer has had: the process id, a per-process counter and the time (a
/// reused process id cannot meet a dead writer's files).
fn writer_tag() -> String {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
    format!("{}w{n}t{nanos}", std::process::id())
}

/// The manifest in `dir` now: `None` when there is none (or it cannot be read and
/// `ignore_bad`), an error when it cannot be read.
fn current_manifest(dir: &Path, ignore_bad: bool) -> Result<Option<Manifest>, BundleError> {
    if !dir.join(MANIFEST_FILE).exists() {
        return Ok(None);
    }
    match Bundle::open(dir) {
        Ok(b) => Ok(Some(b.manifest().clone())),
        Err(_) if ignore_bad => Ok(None),
        Err(e) => Err(e),
    }
}

/// Writes `bytes` to a new synced temporary file in `dir` for `name`, tagged with its writer's
/// `tag`; returns its path.
fn stage(dir: &Path, tag: &str, name: &str, bytes: &[u8]) -> Result<PathBuf, BundleError> {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let temp = dir.join(format!("{TEMP_PREFIX}{tag}-s{n}.{name}"));
    let result = (|| {
        let mut f = fs::File::create_new(&temp)?;
        f.write_all(bytes)?;
        f.sync_all()
    })();
    result.map_err(|e| {
        let _ = fs::remove_file(&temp);
        BundleError::io(dir.join(name), e)
    })?;
    Ok(temp)
}
