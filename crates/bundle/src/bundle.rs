//! Opening a bundle and reading its payloads with sizes and hashes checked.

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::asset::{Asset, AssetKind, Payload};
use crate::error::BundleError;
use crate::files::read_limited;
use crate::limits::Limits;
use crate::manifest::{MANIFEST_FILE, Manifest};
use crate::mesh::{MeshData, MeshDesc};
use crate::names::{check_asset_id, is_safe_file_name};
use crate::settings::Settings;
use crate::texture::{Supercompression, TextureData, TextureDesc, TextureDimension};
use crate::version::FormatVersion;

/// The format whose `Strands` meshes are point records; older strips are refused.
pub(crate) const STRANDS_RECORDS_SINCE: FormatVersion = FormatVersion { major: 1, minor: 5 };

/// An opened bundle: its directory and parsed, structurally checked manifest.
///
/// Opening reads only `bundle.ron`; payloads are read on demand and each read checks the
/// file's size and BLAKE3 against the manifest. Nothing here touches a GPU, so a game can open
/// and decode a bundle on a worker thread.
///
/// While a `Bundle` (or a clone of it) lives it holds a shared lock on the bundle's
/// [`READERS_LOCK_FILE`], when the directory has one: a writer replacing the manifest then
/// keeps the payloads this manifest names until the next commit, instead of removing them at
/// once (see [`crate::BundleWriter`]).
#[derive(Clone, Debug)]
pub struct Bundle {
    dir: PathBuf,
    manifest: Manifest,
    limits: Limits,
    _reading: Option<Arc<fs::File>>,
}

/// The file readers hold a shared lock on while they use a manifest's payloads, and a writer
/// locks exclusively to know that no reader can still hold the payloads it replaced.
pub const READERS_LOCK_FILE: &str = ".hikage-readers.lock";

/// A shared lock on the readers' lock file of `dir`, or `None` when there is no such file (a
/// bundle from before it existed) or it cannot be opened or locked (a read-only copy, a file
/// system without locks): then the reader relies on writers keeping one generation.
pub(crate) fn reader_lock(dir: &Path) -> Option<fs::File> {
    let file = crate::files::open_regular(&dir.join(READERS_LOCK_FILE)).ok()?;
    file.lock_shared().ok()?;
    Some(file)
}

impl Bundle {
    /// Opens the bundle in `dir` with the default [`Limits`].
    pub fn open(dir: &Path) -> Result<Bundle, BundleError> {
        Bundle::open_with_limits(dir, Limits::default())
    }

    /// Opens the bundle in `dir`: reads `bundle.ron` (refusing one larger than
    /// `limits.max_manifest_bytes` before reading it), refuses an unknown major version, and
    /// checks ids, file names and payload descriptions.
    pub fn open_with_limits(dir: &Path, limits: Limits) -> Result<Bundle, BundleError> {
        let path = dir.join(MANIFEST_FILE);
        // Locked before the manifest is read: a writer seeing the lock held keeps its payloads.
        let reading = reader_lock(dir).map(Arc::new);
        let text = read_limited(&path, limits.max_manifest_bytes, "manifest size")?;
        let text = String::from_utf8(text).map_err(|e| BundleError::ManifestSyntax {
            path: path.clone(),
            line: 1,
            col: 1,
            message: format!("expected UTF-8 text: {e}"),
        })?;
        let manifest = parse_in(dir, &text, &limits)?;
        check_accepted(&manifest, &limits, &path, "asset count")?;
        Ok(Bundle { dir: dir.to_path_buf(), manifest, limits, _reading: reading })
    }

    /// The bundle directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The parsed manifest.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// The limits this bundle was opened with.
    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// The asset with this id, or an error listing the ids that exist.
    pub fn asset(&self, id: &str) -> Result<&Asset, BundleError> {
        self.manifest.asset(id).ok_or_else(|| BundleError::Lookup {
            path: self.dir.join(MANIFEST_FILE),
            message: format!(
                "no asset `{id}`; the bundle has: {}",
                self.manifest.assets.iter().map(|a| a.id.as_str()).collect::<Vec<_>>().join(", ")
            ),
        })
    }

    /// Path of an asset's payload file.
    pub fn payload_path(&self, asset: &Asset) -> PathBuf {
        self.dir.join(&asset.file)
    }

    /// Reads an asset's payload file, checking its size and BLAKE3 against the manifest.
    pub fn read_payload(&self, asset: &Asset) -> Result<Vec<u8>, BundleError> {
        read_payload_in(&self.dir, asset, &self.limits)
    }

    /// Reads and decodes a texture asset; the KTX2 header must agree with the manifest.
    pub fn read_texture(&self, id: &str) -> Result<TextureData, BundleError> {
        let asset = self.asset(id)?;
        if asset.payload.texture().is_none() {
            return Err(self.not_a(asset, "texture"));
        }
        let bytes = self.read_payload(asset)?;
        decode_texture(asset, &bytes, &self.payload_path(asset), &self.limits)
    }

    /// Reads a mesh asset; accessors are checked against the payload.
    pub fn read_mesh(&self, id: &str) -> Result<MeshData, BundleError> {
        let asset = self.asset(id)?;
        if !matches!(asset.payload, Payload::Mesh(_)) {
            return Err(self.not_a(asset, "mesh"));
        }
        let bytes = self.read_payload(asset)?;
        decode_mesh(asset, bytes, &self.payload_path(asset), &self.limits)
    }

    fn not_a(&self, asset: &Asset, what: &str) -> BundleError {
        BundleError::Lookup {
            path: self.dir.join(MANIFEST_FILE),
            message: format!("asset `{}` is a {}, not a {what}", asset.id, asset.kind.name()),
        }
    }
}

/// The mesh of a mesh asset from its payload file's `bytes` (read from `path`): inflated when
/// the manifest says it is zstd-compressed (within `limits`), its accessors checked against the
/// buffer. The mesh's description is the manifest's with no supercompression (it describes the
/// inflated buffer).
pub fn decode_mesh(asset: &Asset, bytes: Vec<u8>, path: &Path, limits: &Limits) -> Result<MeshData, BundleError> {
    let fail = |message: String| BundleError::Payload { path: path.into(), asset: asset.id.clone(), message };
    let Payload::Mesh(desc) = &asset.payload else {
        return Err(fail("not a mesh".into()));
    };
    let bytes = match desc.supercompression {
        Supercompression::None => bytes,
        Supercompression::Zstd => crate::zstd::inflate(&bytes, limits.max_payload_bytes).map_err(&fail)?,
    };
    desc.check(bytes.len() as u64).map_err(&fail)?;
    Ok(MeshData { desc: MeshDesc { supercompression: Supercompression::None, ..desc.clone() }, bytes })
}

/// Decodes the KTX2 payload `bytes` of a texture asset (read from `path`); its header must
/// agree with the manifest entry.
pub(crate) fn decode_texture(
    asset: &Asset,
    bytes: &[u8],
    path: &Path,
    limits: &Limits,
) -> Result<TextureData, BundleError> {
    let Payload::Texture(desc) = &asset.payload else {
        return Err(BundleError::Payload {
            path: path.into(),
            asset: asset.id.clone(),
            message: "not a texture".into(),
        });
    };
    let mut tex = crate::ktx2_file::decode(bytes, path, limits)?;
    let mut declared = desc.clone();
    declared.channels = tex.desc.channels.clone();
    if declared != tex.desc {
        return Err(BundleError::Payload {
            path: path.into(),
            asset: asset.id.clone(),
            message: format!("KTX2 header says {:?}, the manifest says {:?}", tex.desc, desc),
        });
    }
    tex.desc = desc.clone();
    Ok(tex)
}

/// Reads the payload file of `asset` in bundle `dir`, checking its size and BLAKE3 against the
/// entry.
pub(crate) fn read_payload_in(dir: &Path, asset: &Asset, limits: &Limits) -> Result<Vec<u8>, BundleError> {
    let path = dir.join(&asset.file);
    let meta = fs::symlink_metadata(&path).map_err(|e| BundleError::io(&path, e))?;
    let payload_err = |message: String| BundleError::Payload { path: path.clone(), asset: asset.id.clone(), message };
    if !meta.is_file() {
        return Err(payload_err("expected a regular file (symlinks are refused)".into()));
    }
    if meta.len() != asset.byte_length {
        return Err(payload_err(format!("file is {} bytes, the manifest says {}", meta.len(), asset.byte_length)));
    }
    let bytes = read_limited(&path, limits.max_payload_bytes, "payload size")?;
    if bytes.len() as u64 != asset.byte_length {
        return Err(payload_err(format!("file is {} bytes, the manifest says {}", bytes.len(), asset.byte_length)));
    }
    let hash = blake3::hash(&bytes).to_hex();
    if hash.as_str() != asset.blake3 {
        return Err(payload_err(format!(
            "BLAKE3 is {hash}, the manifest says {} (the file was modified or corrupted)",
            asset.blake3
        )));
    }
    Ok(bytes)
}

/// Parses the manifest `text` of the bundle in `dir`, reading its tile tables from `dir`
/// within `limits`.
pub(crate) fn parse_in(dir: &Path, text: &str, limits: &Limits) -> Result<Manifest, BundleError> {
    let path = dir.join(MANIFEST_FILE);
    Manifest::parse_with_tables(text, &path, limits, &mut |set| {
        crate::files::read_in_bundle(&dir.join(&set.table), set.byte_length, "tile table size")
    })
}

/// What a reader requires of a parsed manifest beyond its syntax: at most `limits.max_assets`
/// assets (`what` names the count in the error), each well-formed. [`Bundle::open`] applies it,
/// and the writer before it commits, so that a bundle written is a bundle that opens.
pub(crate) fn check_accepted(manifest: &Manifest, limits: &Limits, path: &Path, what: &str) -> Result<(), BundleError> {
    if manifest.assets.len() > limits.max_assets {
        return Err(BundleError::Limit {
            path: path.to_path_buf(),
            what: what.into(),
            value: manifest.assets.len() as u64,
            limit: limits.max_assets as u64,
        });
    }
    if let Some((asset, message)) = manifest_problems(manifest, limits).into_iter().next() {
        return Err(BundleError::InvalidAsset { path: path.to_path_buf(), asset, message });
    }
    Ok(())
}

/// Problems visible from the manifest alone: ids, file names, duplicates, descriptions,
/// kind/payload/settings agreement. Returns `(asset, message)` pairs; empty when a reader
/// accepts every entry.
pub fn manifest_problems(manifest: &Manifest, limits: &Limits) -> Vec<(String, String)> {
    // Which ids and files repeat an earlier one's: borrowed and hashed, since a tiled map's
    // manifest lists tens of thousands of assets; the checks of each asset alone then run on
    // every core.
    // Every id's kind (the first of a repeated id's), for the assets an asset names.
    let mut kinds = std::collections::HashMap::with_capacity(manifest.assets.len());
    // Assets with identical payloads may share a file (format 1.10); other bytes may not.
    let mut files = std::collections::HashMap::with_capacity(manifest.assets.len());
    let repeats: Vec<(bool, bool)> = manifest
        .assets
        .iter()
        .map(|a| {
            let contents = (a.blake3.as_str(), a.byte_length);
            let clash = *files.entry(a.file.as_str()).or_insert(contents) != contents;
            let repeated = kinds.contains_key(a.id.as_str());
            kinds.entry(a.id.as_str()).or_insert(a.kind);
            (repeated, clash)
        })
        .collect();
    let per_asset =
        crate::parallel::map(&manifest.assets, 4096, |i, a| asset_problems(manifest, i, a, repeats[i], &kinds, limits));
    per_asset.into_iter().flatten().collect()
}

/// What is wrong with asset `i` of `manifest`, `a`, given whether its id and its file repeat an
/// earlier asset's (a file with other contents, for files).
fn asset_problems(
    manifest: &Manifest,
    i: usize,
    a: &Asset,
    (repeated_id, repeated_file): (bool, bool),
    kinds: &std::collections::HashMap<&str, AssetKind>,
    limits: &Limits,
) -> Vec<(String, String)> {
    let mut problems = Vec::new();
    {
        let mut bad = |m: String| problems.push((if a.id.is_empty() { format!("#{i}") } else { a.id.clone() }, m));
        // The assets it is read with: a horizon's heightfield, an occlusion map's horizon.
        let needs = match &a.settings {
            crate::Settings::Horizon(h) => Some((h.heightfield.as_str(), AssetKind::Heightfield)),
            crate::Settings::AmbientOcclusion(o) => Some((o.horizon.as_str(), AssetKind::Horizon)),
            _ => None,
        };
        if let Some((id, kind)) = needs {
            match kinds.get(id) {
                None => bad(format!("it names {} `{id}`, which is not in the bundle", kind.name())),
                Some(k) if *k != kind => {
                    bad(format!("it names `{id}` as its {}, which is a {}", kind.name(), k.name()))
                }
                Some(_) => {}
            }
        }
        if let Err(m) = check_asset_id(&a.id) {
            bad(m);
        }
        if repeated_id {
            bad("duplicate asset id".into());
        }
        if !is_safe_file_name(&a.file) {
            bad(format!(
                "file {:?} is not a plain file name inside the bundle directory (no separators, no .., not absolute)",
                a.file
            ));
        } else if repeated_file {
            bad(format!("file {:?} is used by two assets with different payloads (BLAKE3 and length)", a.file));
        }
        if a.blake3.len() != 64 || !a.blake3.bytes().all(|b| b.is_ascii_hexdigit()) {
            bad(format!("blake3 {:?} is not 64 hex digits", a.blake3));
        }
        if a.byte_length > limits.max_payload_bytes {
            bad(format!("byte_length {} is above the limit of {}", a.byte_length, limits.max_payload_bytes));
        }
        match &a.payload {
            _ if a.kind.is_mesh() != matches!(a.payload, Payload::Mesh(_)) => bad(format!(
                "kind {} does not match its {} payload",
                a.kind.name(),
                if a.kind.is_mesh() { "texture" } else { "mesh" }
            )),
            Payload::Texture(t) => {
                if let Err(m) = t.check(limits) {
                    bad(m);
                }
                texture_problems(a.kind, t, &a.settings).into_iter().for_each(&mut bad);
            }
            // Strands of an older bundle have the strip layout: readable, not drawable
            // ([`crate::validate()`] says so).
            Payload::Mesh(_) if a.kind == AssetKind::Strands && manifest.format < STRANDS_RECORDS_SINCE => {}
            Payload::Mesh(m)
                if a.kind == AssetKind::Strands
                    && (MeshDesc { supercompression: Supercompression::None, ..m.clone() })
                        != crate::strands::strands_desc(m.vertex_count) =>
            {
                bad(format!(
                    "strands must be the interleaved 32-byte point records of format {STRANDS_RECORDS_SINCE} with no indices (an older hikage's strips?): bake them again"
                ))
            }
            Payload::Mesh(m) => {
                for s in a.kind.required_streams(manifest.format) {
                    match m.attribute(s.name) {
                        None => bad(format!("a {} mesh needs a `{}` stream", a.kind.name(), s.name)),
                        Some(x) if x.component != s.component || x.components != s.components => bad(format!(
                            "stream `{}` of a {} mesh must be {:?} × {}, found {:?} × {}",
                            s.name,
                            a.kind.name(),
                            s.component,
                            s.components,
                            x.component,
                            x.components
                        )),
                        Some(_) => {}
                    }
                }
            }
        }
        if a.settings.kind(&a.payload) != a.kind {
            bad(format!("settings do not match kind {}", a.kind.name()));
        }
        let texel = match &a.settings {
            Settings::Heightfield(h) => Some((h.texel_size, h.height_scale, h.height_offset)),
            Settings::Horizon(h) => Some((h.texel_size, h.height_scale, 0.0)),
            _ => None,
        };
        if let Some(((sx, sy), scale, offset)) = texel {
            if !(sx.is_finite() && sy.is_finite() && sx > 0.0 && sy > 0.0) {
                bad(format!("texel_size ({sx}, {sy}) must be finite and positive"));
            }
            if !(scale.is_finite() && offset.is_finite()) {
                bad("height_scale and height_offset must be finite".into());
            }
        }
    }
    problems
}

/// What is wrong with a texture payload of `kind` described by `settings`: its shape, and the
/// sizes the settings imply.
fn texture_problems(kind: AssetKind, t: &TextureDesc, settings: &Settings) -> Vec<String> {
    let mut problems = Vec::new();
    let one_channel_2d = t.dimension == TextureDimension::D2 && t.format.channels() == 1;
    let (shape_ok, shape) = match kind {
        AssetKind::Heightfield | AssetKind::AmbientOcclusion => (one_channel_2d, "a one-channel D2 texture"),
        AssetKind::Horizon => {
            (t.dimension == TextureDimension::D3 && t.format.channels() == 2, "a two-channel D3 texture")
        }
        AssetKind::Relief => {
            (t.dimension == TextureDimension::D2Array && t.format.channels() == 1, "a one-channel D2Array texture")
        }
        AssetKind::MaxMip => (
            one_channel_2d
                && t.width.is_power_of_two()
                && t.height.is_power_of_two()
                && t.levels == crate::relief::MaxMip::level_count_for(t.width, t.height),
            "a one-channel D2 texture with power-of-two sides and a full max-mip chain",
        ),
        _ => (true, ""),
    };
    if !shape_ok {
        problems.push(format!("a {} must be {shape}", kind.name()));
    }
    match settings {
        Settings::Horizon(h) if h.directions != t.depth => {
            problems.push(format!("{} directions but the texture is {} deep", h.directions, t.depth))
        }
        Settings::Relief(r) => {
            let layers = r.theta as u64 * r.phi as u64;
            if layers != t.layers as u64 || r.directions.len() as u64 != layers {
                problems.push(format!(
                    "{}×{} directions and a table of {} but the texture has {} layers",
                    r.theta,
                    r.phi,
                    r.directions.len(),
                    t.layers
                ));
            }
            if !(r.depth_scale.is_finite() && r.depth_scale > 0.0) {
                problems.push(format!("depth_scale {} must be finite and positive", r.depth_scale));
            }
        }
        _ => {}
    }
    if let Some(p) = settings.tile() {
        let fits = |o: u32, n: u32, size: u32| o as u64 + n as u64 <= size as u64;
        if !fits(p.origin.0, t.width, p.map_size.0) || !fits(p.origin.1, t.height, p.map_size.1) {
            problems.push(format!(
                "a {}×{} tile at {:?} does not fit its {}×{} map",
                t.width, t.height, p.origin, p.map_size.0, p.map_size.1
            ));
        }
    }
    problems
}
