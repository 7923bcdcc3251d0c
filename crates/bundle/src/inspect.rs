//! A flat, serialisable summary of a bundle for `hikage inspect`.

use serde::Serialize;

use crate::asset::Payload;
use crate::manifest::Manifest;
use crate::settings::{Settings, StrandsSettings};

/// One asset as `hikage inspect` shows it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AssetSummary {
    /// Asset id.
    pub id: String,
    /// Kind name (`heightfield`, `texture`, `mesh`, …).
    pub kind: String,
    /// Payload file.
    pub file: String,
    /// Payload bytes on disk.
    pub byte_length: u64,
    /// Bytes the asset takes in GPU memory uploaded as stored: a texture's texels over every
    /// level, slice and layer (after any supercompression is undone), a mesh's streams and
    /// indices.
    pub gpu_bytes: u64,
    /// Texel format (`R32Float`, …) or `mesh`.
    pub format: String,
    /// `[width, height, depth, layers]` for textures, `[vertices, indices]` for meshes.
    pub dimensions: Vec<u64>,
    /// Texture shape (`D2`, `D2Array`, `D3`) or `mesh`.
    pub dimension: String,
    /// Mip levels (textures) or 0.
    pub levels: u32,
    /// Channel names (textures) or attribute names (meshes).
    pub channels: Vec<String>,
    /// Vertex count (meshes) or 0.
    pub vertex_count: u64,
    /// Index count (meshes) or 0.
    pub index_count: u64,
    /// The settings the asset was baked with, as RON.
    pub settings: String,
    /// For hair strips: the two sets drawn from the shared mesh.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sets: Vec<StrandSet>,
}

/// One set of hair strips as `hikage inspect` shows it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StrandSet {
    /// `shading` or `opacity`.
    pub name: String,
    /// Point records the set is drawn from (both sets share them).
    pub points: u64,
    /// Levels of detail the records hold.
    pub levels: usize,
    /// Full width of a default strand, world units.
    pub width: f32,
    /// Opacity of a default strand.
    pub alpha: f32,
}

/// The whole summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// `major.minor`.
    pub format: String,
    /// Generator string.
    pub generator: String,
    /// One entry per asset, sorted by id.
    pub assets: Vec<AssetSummary>,
    /// The payloads' bytes on disk, all assets (the manifest not counted).
    pub disk_bytes: u64,
    /// GPU memory of all assets uploaded as stored.
    pub gpu_bytes: u64,
}

fn strand_sets(s: &StrandsSettings, points: u64) -> Vec<StrandSet> {
    [("shading", s.shading), ("opacity", s.opacity)]
        .into_iter()
        .map(|(name, (width, alpha))| StrandSet { name: name.into(), points, levels: s.levels.len(), width, alpha })
        .collect()
}

/// Summarises a manifest.
pub fn summarize(manifest: &Manifest) -> Summary {
    let assets: Vec<AssetSummary> = manifest
        .assets
        .iter()
        .map(|a| {
            let settings = match &a.settings {
                Settings::Generic => String::new(),
                s => ron::to_string(s).unwrap_or_default(),
            };
            match &a.payload {
                Payload::Texture(t) => AssetSummary {
                    id: a.id.clone(),
                    kind: a.kind.name().into(),
                    file: a.file.clone(),
                    byte_length: a.byte_length,
                    gpu_bytes: a.gpu_bytes(),
                    format: format!("{:?}", t.format),
                    dimensions: vec![t.width as u64, t.height as u64, t.depth as u64, t.layers as u64],
                    dimension: format!("{:?}", t.dimension),
                    levels: t.levels,
                    channels: t.channels.clone(),
                    vertex_count: 0,
                    index_count: 0,
                    settings,
                    sets: Vec::new(),
                },
                Payload::Mesh(m) => {
                    let indices = m.indices.as_ref().map_or(0, |i| i.count as u64);
                    AssetSummary {
                        id: a.id.clone(),
                        kind: a.kind.name().into(),
                        file: a.file.clone(),
                        byte_length: a.byte_length,
                        gpu_bytes: a.gpu_bytes(),
                        format: "mesh".into(),
                        dimensions: vec![m.vertex_count as u64, indices],
                        dimension: "mesh".into(),
                        levels: 0,
                        channels: m.attributes.iter().map(|x| x.name.clone()).collect(),
                        vertex_count: m.vertex_count as u64,
                        index_count: indices,
                        settings,
                        sets: match &a.settings {
                            Settings::Strands(st) => strand_sets(st, m.vertex_count as u64),
                            _ => Vec::new(),
                        },
                    }
                }
            }
        })
        .collect();
    Summary {
        format: manifest.format.to_string(),
        generator: manifest.generator.clone(),
        disk_bytes: crate::budget::disk_bytes(assets.iter().map(|a| (a.file.as_str(), a.byte_length))),
        gpu_bytes: assets.iter().map(|a| a.gpu_bytes).sum(),
        assets,
    }
}
