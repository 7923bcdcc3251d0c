//! The device-free half of loading: read, verify and decode every payload.

use std::path::Path;

use hikage_bundle::{Asset, Bundle, MeshData, Payload, TextureData};

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
    /// The manifest entry.
    pub asset: Asset,
    /// The decoded payload.
    pub payload: CpuPayload,
}

/// A bundle read into memory, ready for [`crate::GpuBundle::upload`]. `Send`, so it can be
/// built on a loader thread.
#[derive(Clone, Debug)]
pub struct CpuBundle {
    /// The opened bundle (directory and manifest).
    pub bundle: Bundle,
    /// Every asset, in manifest order.
    pub assets: Vec<CpuAsset>,
}

impl CpuAsset {
    /// The texture, when the payload is one.
    pub fn texture(&self) -> Option<&TextureData> {
        match &self.payload {
            CpuPayload::Texture(t) => Some(t),
            CpuPayload::Mesh(_) => None,
        }
    }
}

impl CpuBundle {
    /// Opens the bundle in `dir` and decodes every asset, checking sizes, hashes and KTX2
    /// headers against the manifest.
    pub fn read(dir: &Path) -> Result<CpuBundle, RuntimeError> {
        let bundle = Bundle::open(dir)?;
        let mut assets = Vec::with_capacity(bundle.manifest().assets.len());
        for asset in &bundle.manifest().assets {
            let payload = match &asset.payload {
                Payload::Texture(_) => CpuPayload::Texture(bundle.read_texture(&asset.id)?),
                Payload::Mesh(_) => CpuPayload::Mesh(bundle.read_mesh(&asset.id)?),
            };
            assets.push(CpuAsset { asset: asset.clone(), payload });
        }
        Ok(CpuBundle { bundle, assets })
    }

    /// The asset with this id.
    pub fn asset(&self, id: &str) -> Option<&CpuAsset> {
        self.assets.iter().find(|a| a.asset.id == id)
    }
}
