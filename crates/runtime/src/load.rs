//! The device-free half of loading: read, verify and decode payloads, all of them or only the
//! ones a level needs.

use std::collections::BTreeSet;
use std::path::Path;

use hikage_bundle::{Asset, Bundle, BundleError, MeshData, Payload, TextureData};

use crate::error::RuntimeError;

/// A decoded payload.
#[derive(Clone, Debug, PartialEq)]
pub enum CpuPayload {
    /// Uncompressed texture levels.
    Texture(TextureData),
    /// A mesh buffer with its accessors.
    Mesh(MeshData),
}

/// One asset in memory: its manifest entry and decoded payload.
#[derive(Clone, Debug, PartialEq)]
pub struct CpuAsset {
    /// The manifest entry (id, kind, settings, hashes).
    pub asset: Asset,
    /// The decoded payload.
    pub payload: CpuPayload,
}

impl CpuAsset {
    /// The texture, when the payload is one.
    pub fn texture(&self) -> Option<&TextureData> {
        match &self.payload {
            CpuPayload::Texture(t) => Some(t),
            CpuPayload::Mesh(_) => None,
        }
    }

    /// The mesh, when the payload is one.
    pub fn mesh(&self) -> Option<&MeshData> {
        match &self.payload {
            CpuPayload::Mesh(m) => Some(m),
            CpuPayload::Texture(_) => None,
        }
    }
}

/// Assets read into memory, ready for [`crate::GpuBundle::upload`]. `Send`, so it can be built
/// on a loader thread.
///
/// ```no_run
/// use hikage_runtime::CpuBundle;
/// // Everything the terrain job made (`terrain.height`, `terrain.horizon`, `terrain.ao`) and
/// // nothing else: other payloads are neither read nor hashed.
/// let terrain = CpuBundle::read_prefix("bundle".as_ref(), "terrain.")?;
/// // One asset and the assets it names (a horizon map's heightfield).
/// let horizon = CpuBundle::read_ids("bundle".as_ref(), &["cylinders.horizon"])?;
/// # Ok::<(), hikage_runtime::RuntimeError>(())
/// ```
#[derive(Clone, Debug)]
pub struct CpuBundle {
    /// The opened bundle (directory and the whole manifest).
    pub bundle: Bundle,
    /// The assets read, in manifest order.
    pub assets: Vec<CpuAsset>,
}

impl CpuBundle {
    /// Opens the bundle in `dir` and decodes every asset, checking sizes, hashes and KTX2
    /// headers against the manifest.
    pub fn read(dir: &Path) -> Result<CpuBundle, RuntimeError> {
        CpuBundle::read_where(dir, |_| true)
    }

    /// Reads the assets named in `ids` and, transitively, the assets they depend on
    /// ([`hikage_bundle::Settings::depends_on`]). An id the bundle does not have is an error
    /// that lists the ids it has.
    pub fn read_ids(dir: &Path, ids: &[&str]) -> Result<CpuBundle, RuntimeError> {
        let bundle = Bundle::open(dir)?;
        let mut wanted = BTreeSet::new();
        let mut queue: Vec<String> = ids.iter().map(|s| s.to_string()).collect();
        while let Some(id) = queue.pop() {
            let asset = bundle.asset(&id)?;
            if wanted.insert(id) {
                queue.extend(asset.settings.depends_on().into_iter().map(str::to_string));
            }
        }
        CpuBundle::read_from(bundle, |a| wanted.contains(&a.id))
    }

    /// Reads the assets whose id starts with `prefix` (a job's assets share its id as prefix:
    /// `terrain.` gives `terrain.height`, `terrain.horizon` and `terrain.ao`), and the assets
    /// they depend on. No match is an error.
    pub fn read_prefix(dir: &Path, prefix: &str) -> Result<CpuBundle, RuntimeError> {
        let bundle = Bundle::open(dir)?;
        let ids: Vec<String> =
            bundle.manifest().assets.iter().filter(|a| a.id.starts_with(prefix)).map(|a| a.id.clone()).collect();
        if ids.is_empty() {
            return Err(RuntimeError::Bundle(BundleError::Lookup {
                path: dir.join(hikage_bundle::MANIFEST_FILE),
                message: format!("no asset id starts with `{prefix}`"),
            }));
        }
        let refs: Vec<&str> = ids.iter().map(String::as_str).collect();
        CpuBundle::read_ids(dir, &refs)
    }

    /// Reads the assets for which `select` is true; the others are neither read nor hashed.
    pub fn read_where(dir: &Path, select: impl Fn(&Asset) -> bool) -> Result<CpuBundle, RuntimeError> {
        CpuBundle::read_from(Bundle::open(dir)?, select)
    }

    fn read_from(bundle: Bundle, select: impl Fn(&Asset) -> bool) -> Result<CpuBundle, RuntimeError> {
        let mut assets = Vec::new();
        for asset in bundle.manifest().assets.iter().filter(|a| select(a)) {
            let payload = match &asset.payload {
                Payload::Texture(_) => CpuPayload::Texture(bundle.read_texture(&asset.id)?),
                Payload::Mesh(_) => CpuPayload::Mesh(bundle.read_mesh(&asset.id)?),
            };
            assets.push(CpuAsset { asset: asset.clone(), payload });
        }
        Ok(CpuBundle { bundle, assets })
    }

    /// The asset with this id, if it was read.
    pub fn asset(&self, id: &str) -> Option<&CpuAsset> {
        self.assets.iter().find(|a| a.asset.id == id)
    }
}
