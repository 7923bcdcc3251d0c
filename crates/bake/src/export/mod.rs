//! Writing assets back out for other tools and people: textures as OpenEXR or raw
//! little-endian f32 ([`texture`]), meshes as binary glTF 2.0 ([`gltf`]), and a whole bundle as
//! a contact sheet of pictures for review ([`sheet`]).

pub mod gltf;
#[cfg(feature = "png")]
pub mod sheet;
pub mod texture;

use std::io::Write;
use std::path::Path;

use crate::error::BakeError;

pub use gltf::export_gltf;
pub use texture::{ExportFormat, ExportSummary, export_texture};

/// Writes `out` through a synced temporary file beside it and a rename, so a reader never sees
/// half a file and a failed write leaves what was there.
pub(crate) fn write_via_temp(out: &Path, bytes: &[u8]) -> Result<(), BakeError> {
    let name = out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "export".into());
    let tmp = out.with_file_name(format!(".{name}.hikage-tmp"));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, out)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        BakeError::io(out, e)
    })
}
