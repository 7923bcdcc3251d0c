//! Full validation of a bundle: everything a reader relies on, each problem reported.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::bundle::{Bundle, manifest_problems};
use crate::error::BundleError;
use crate::limits::Limits;
use crate::manifest::{Asset, Payload};
use crate::mesh::{ComponentType, read_elements, read_uint};

/// One thing wrong with a bundle.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Problem {
    /// The asset concerned.
    pub asset: String,
    /// The file concerned (the payload, or the manifest for manifest-level problems).
    pub file: PathBuf,
    /// What is wrong and what was expected.
    pub message: String,
}

/// The result of validating a bundle that could be opened.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Report {
    /// Assets checked.
    pub assets: usize,
    /// Everything found wrong; empty when the bundle is valid.
    pub problems: Vec<Problem>,
}

impl Report {
    /// True when no problem was found.
    pub fn is_valid(&self) -> bool {
        self.problems.is_empty()
    }
}

/// Validates the bundle in `dir`.
///
/// Returns `Err` when the manifest itself cannot be used (missing, unreadable, syntax error with
/// line and column, unknown major version). Otherwise checks, per asset: ids and file names
/// (unique, inside the directory), the payload exists and is a regular file, its size and
/// BLAKE3, the KTX2 header against the manifest, that every float texel is finite, mesh
/// accessors in bounds, indices below the vertex count, float attributes finite.
pub fn validate(dir: &Path) -> Result<Report, BundleError> {
    validate_with_limits(dir, Limits::default())
}

/// [`validate`] with explicit limits.
pub fn validate_with_limits(dir: &Path, limits: Limits) -> Result<Report, BundleError> {
    // Structural problems are reported, not fatal: open with them tolerated.
    let manifest_path = dir.join(crate::MANIFEST_FILE);
    let bundle = match Bundle::open_with_limits(dir, limits) {
        Ok(b) => b,
        Err(BundleError::InvalidAsset { .. }) => {
            let text = crate::bundle::read_limited(&manifest_path, limits.max_manifest_bytes, "manifest size")?;
            let manifest = crate::Manifest::parse(&String::from_utf8_lossy(&text), &manifest_path)?;
            let problems = manifest_problems(&manifest, &limits)
                .into_iter()
                .map(|(asset, message)| Problem { asset, file: manifest_path.clone(), message })
                .collect();
            return Ok(Report { assets: manifest.assets.len(), problems });
        }
        Err(e) => return Err(e),
    };
    let mut report = Report { assets: bundle.manifest().assets.len(), problems: Vec::new() };
    for asset in &bundle.manifest().assets {
        if let Err(e) = check_asset(&bundle, asset) {
            report.problems.push(Problem {
                asset: asset.id.clone(),
                file: bundle.payload_path(asset),
                message: match e {
                    BundleError::Payload { message, .. } | BundleError::Ktx2 { message, .. } => message,
                    other => other.to_string(),
                },
            });
        }
    }
    Ok(report)
}

fn check_asset(bundle: &Bundle, asset: &Asset) -> Result<(), BundleError> {
    let path = bundle.payload_path(asset);
    let fail = |message: String| BundleError::Payload { path: path.clone(), asset: asset.id.clone(), message };
    match &asset.payload {
        Payload::Texture(_) => {
            let tex = bundle.read_texture(&asset.id)?;
            if let Some((level, slice, row, col, ch)) = tex.first_non_finite() {
                return Err(fail(format!(
                    "texel at level {level}, slice {slice}, row {row}, column {col}, channel {ch} is not finite"
                )));
            }
        }
        Payload::Mesh(desc) => {
            let mesh = bundle.read_mesh(&asset.id)?;
            if let Some(ix) = &desc.indices {
                for (i, e) in read_elements(&mesh.bytes, ix).enumerate() {
                    let v = read_uint(e, ix.component);
                    if v >= desc.vertex_count {
                        return Err(fail(format!(
                            "index {i} is {v}, expected below the vertex count {}",
                            desc.vertex_count
                        )));
                    }
                }
            }
            for a in desc.attributes.iter().filter(|a| a.component == ComponentType::F32) {
                for (i, e) in read_elements(&mesh.bytes, a).enumerate() {
                    if e.chunks_exact(4).any(|c| !f32::from_le_bytes(c.try_into().unwrap()).is_finite()) {
                        return Err(fail(format!("attribute `{}` element {i} is not finite", a.name)));
                    }
                }
            }
        }
    }
    Ok(())
}
