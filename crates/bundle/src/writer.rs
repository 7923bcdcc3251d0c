//! Crash-safe bundle writing.
//!
//! Order of operations: each payload is written to a temporary file, synced and renamed to its
//! content-derived name (so it never replaces a file the current manifest relies on with
//! different bytes); then the manifest is written to a temporary file, synced, and renamed over
//! `bundle.ron`; only then are payloads the new manifest no longer names removed. A process
//! killed at any point leaves either the old or the new manifest, each with all its payloads.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::bundle::Bundle;
use crate::error::BundleError;
use crate::manifest::{Asset, MANIFEST_FILE, Manifest, Payload, Settings};
use crate::mesh::MeshData;
use crate::names::{check_asset_id, looks_like_payload, payload_file_name};
use crate::texture::TextureData;

const TEMP_PREFIX: &str = ".hikage-tmp-";

/// Which assets the new manifest starts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WriteMode {
    /// The new manifest holds exactly the assets put or kept by this writer (a pipeline run).
    Replace,
    /// The new manifest starts as a copy of the previous one; puts add or replace assets (a
    /// one-shot command adding to an existing bundle).
    Update,
}

/// What a commit changed.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CommitSummary {
    /// True when `bundle.ron` was rewritten (false when it already had the same bytes).
    pub manifest_written: bool,
    /// Payload files removed because no asset names them any more.
    pub removed: Vec<String>,
}

/// Writes a bundle directory transactionally; see the module docs for the order of writes.
///
/// Dropping a writer without [`commit`](BundleWriter::commit) removes the payloads it wrote
/// that the previous manifest does not name, leaving the previous bundle as it was.
#[derive(Debug)]
pub struct BundleWriter {
    dir: PathBuf,
    previous: Option<Manifest>,
    assets: BTreeMap<String, Asset>,
    written: BTreeSet<String>,
    committed: bool,
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
        let previous = if dir.join(MANIFEST_FILE).exists() {
            match Bundle::open(dir) {
                Ok(b) => Some(b.manifest().clone()),
                Err(_) if ignore_bad => None,
                Err(e) => return Err(e),
            }
        } else {
            None
        };
        let assets = match (&previous, mode) {
            (Some(m), WriteMode::Update) => m.assets.iter().map(|a| (a.id.clone(), a.clone())).collect(),
            _ => BTreeMap::new(),
        };
        Ok(BundleWriter { dir: dir.to_path_buf(), previous, assets, written: BTreeSet::new(), committed: false })
    }

    /// The bundle directory.
    pub fn dir(&self) -> &Path {
        &self.dir
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
        let bytes = fs::read(self.dir.join(&asset.file)).ok()?;
        (bytes.len() as u64 == asset.byte_length && blake3::hash(&bytes).to_hex().as_str() == asset.blake3)
            .then(|| asset.clone())
    }

    /// Puts an asset into the new manifest unchanged (its payload is already in place).
    pub fn keep(&mut self, asset: Asset) {
        self.assets.insert(asset.id.clone(), asset);
    }

    /// Removes asset `id` from the new manifest (its payload goes at commit).
    pub fn remove(&mut self, id: &str) -> Option<Asset> {
        self.assets.remove(id)
    }

    /// Encodes a texture as KTX2, writes it, and adds or replaces asset `id`.
    pub fn put_texture(
        &mut self,
        id: &str,
        settings: Settings,
        input_hash: &str,
        texture: &TextureData,
    ) -> Result<Asset, BundleError> {
        let bytes = crate::ktx2_file::encode(texture, crate::GENERATOR)?;
        self.put_payload(id, settings, input_hash, Payload::Texture(texture.desc.clone()), &bytes, "ktx2")
    }

    /// Writes a mesh payload and adds or replaces asset `id`.
    pub fn put_mesh(
        &mut self,
        id: &str,
        settings: Settings,
        input_hash: &str,
        mesh: &MeshData,
    ) -> Result<Asset, BundleError> {
        mesh.desc.check(mesh.bytes.len() as u64).map_err(BundleError::InvalidData)?;
        self.put_payload(id, settings, input_hash, Payload::Mesh(mesh.desc.clone()), &mesh.bytes, "bin")
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
        write_atomically(&self.dir, &file, bytes)?;
        self.written.insert(file.clone());
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
        self.assets.insert(id.to_string(), asset.clone());
        Ok(asset)
    }

    /// The manifest that [`commit`](BundleWriter::commit) would write.
    pub fn manifest(&self) -> Manifest {
        let mut m = Manifest::new();
        m.assets = self.assets.values().cloned().collect();
        m
    }

    /// Replaces `bundle.ron` atomically with the new manifest, then removes payloads that no
    /// asset names any more and temporary files left by interrupted writes.
    pub fn commit(mut self) -> Result<CommitSummary, BundleError> {
        let text = self.manifest().to_ron();
        let manifest_path = self.dir.join(MANIFEST_FILE);
        let unchanged = fs::read(&manifest_path).map(|old| old == text.as_bytes()).unwrap_or(false);
        if !unchanged {
            write_atomically(&self.dir, MANIFEST_FILE, text.as_bytes())?;
        }
        self.committed = true;

        // Remove what the new manifest does not name.
        let keep: BTreeSet<&str> = self.assets.values().map(|a| a.file.as_str()).collect();
        let mut removed = Vec::new();
        let entries = fs::read_dir(&self.dir).map_err(|e| BundleError::io(&self.dir, e))?;
        for entry in entries {
            let entry = entry.map_err(|e| BundleError::io(&self.dir, e))?;
            let name = entry.file_name().to_string_lossy().into_owned();
            let stale = (looks_like_payload(&name) && !keep.contains(name.as_str())) || name.starts_with(TEMP_PREFIX);
            if stale {
                let path = entry.path();
                fs::remove_file(&path).map_err(|e| BundleError::io(&path, e))?;
                removed.push(name);
            }
        }
        removed.sort();
        Ok(CommitSummary { manifest_written: !unchanged, removed })
    }
}

impl Drop for BundleWriter {
    fn drop(&mut self) {
        if self.committed {
            return;
        }
        let referenced: BTreeSet<&str> =
            self.previous.iter().flat_map(|m| m.assets.iter().map(|a| a.file.as_str())).collect();
        for file in &self.written {
            if !referenced.contains(file.as_str()) {
                let _ = fs::remove_file(self.dir.join(file));
            }
        }
    }
}

/// Writes `dir/name` through a synced temporary file and a rename, then syncs the directory.
fn write_atomically(dir: &Path, name: &str, bytes: &[u8]) -> Result<(), BundleError> {
    let tmp = dir.join(format!("{TEMP_PREFIX}{}-{name}", std::process::id()));
    let target = dir.join(name);
    let result = (|| {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        fs::rename(&tmp, &target)?;
        sync_dir(dir)
    })();
    result.map_err(|e| {
        let _ = fs::remove_file(&tmp);
        BundleError::io(&target, e)
    })
}

#[cfg(unix)]
fn sync_dir(dir: &Path) -> std::io::Result<()> {
    fs::File::open(dir)?.sync_all()
}

#[cfg(not(unix))]
fn sync_dir(_dir: &Path) -> std::io::Result<()> {
    Ok(())
}
