//! Size limits applied before anything is allocated for untrusted files.

/// Upper bounds checked against sizes claimed by untrusted files (manifests, KTX2 headers,
/// mesh accessors) before any memory is allocated for them.
///
/// The defaults allow everything hikage bakes (3D textures up to 4096²×256, meshes of tens of
/// millions of vertices) and refuse claims that could only exhaust memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Largest `bundle.ron` accepted, in bytes.
    pub max_manifest_bytes: u64,
    /// Most assets one manifest may list.
    pub max_assets: usize,
    /// Largest width, height or depth of a texture.
    pub max_texture_dimension: u32,
    /// Most array layers of a texture.
    pub max_texture_layers: u32,
    /// Largest uncompressed texture (all levels) in bytes.
    pub max_texture_bytes: u64,
    /// Largest payload file in bytes.
    pub max_payload_bytes: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_manifest_bytes: 16 << 20,
            max_assets: 100_000,
            max_texture_dimension: 16_384,
            max_texture_layers: 4_096,
            max_texture_bytes: 4 << 30,
            max_payload_bytes: 4 << 30,
        }
    }
}
