//! The bundle format version, which readers check before anything else.

use std::fmt;

use serde::{Deserialize, Serialize};

/// Bundle format version. Readers accept any minor of their major.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct FormatVersion {
    /// Incompatible changes.
    pub major: u32,
    /// Additions an older reader of the same major can ignore.
    pub minor: u32,
}

impl FormatVersion {
    /// The version this crate writes and reads. 1.1 added the `Horizon`, `AmbientOcclusion`
    /// and `Curvature` kinds; 1.2 the `Relief` and `MaxMip` kinds; 1.3 the `tangent_u` and
    /// `tangent_v` streams of curvature meshes; 1.4 the `tile` placement of heightfields and
    /// horizon textures baked in tiles; 1.5 the compact `Strands` records (one 32-byte record
    /// per point, levels of detail) in place of the expanded strips, which readers no longer
    /// take; 1.6 zstd-compressed mesh payloads (a mesh's `supercompression`); 1.7 the
    /// block-compressed texture formats `Bc4RUnorm` and `Bc5RgUnorm`; 1.8 the manifest's
    /// optional `budget`; 1.9 tile sets (the tiles of a map written as one table, see
    /// [`crate::tiles`]), levels of detail of tiles and the tile placement of occlusion maps; 1.10 one file
    /// shared by assets whose payloads are the same bytes, named after the first of their ids;
    /// 1.11 the `HairBinding` and `Scalp` kinds (strands bound to a skinned scalp).
    pub const CURRENT: FormatVersion = FormatVersion { major: 1, minor: 11 };
}

impl fmt::Display for FormatVersion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}", self.major, self.minor)
    }
}

#[cfg(test)]
mod tests {
    use super::FormatVersion;

    /// The format document's example manifest carries the version the code writes.
    #[test]
    fn the_format_document_shows_the_current_version() {
        let doc = include_str!("../../../docs/bundle-format.md");
        let FormatVersion { major, minor } = FormatVersion::CURRENT;
        let shown = format!("format: (major: {major}, minor: {minor}),");
        assert!(doc.contains(&shown), "docs/bundle-format.md does not show `{shown}`");
    }
}
