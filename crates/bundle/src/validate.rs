//! Full validation of a bundle: everything a reader relies on, each problem reported.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::asset::{Asset, Payload};
use crate::bundle::Bundle;
pub use crate::bundle::manifest_problems;
use crate::error::BundleError;
use crate::limits::Limits;
use crate::mesh::{ComponentType, MeshDesc, read_elements, read_uint};
use crate::texture::TextureData;

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
    /// The figures over the budget the manifest records (a valid bundle may be over budget).
    pub over_budget: Vec<crate::budget::Overrun>,
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
/// accessors in bounds, every vertex stream readable as a GPU vertex attribute
/// ([`crate::Accessor::vertex_fetch`]), indices below the vertex count, float attributes finite.
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
            let text = crate::files::read_limited(&manifest_path, limits.max_manifest_bytes, "manifest size")?;
            let manifest = crate::bundle::parse_in(dir, &String::from_utf8_lossy(&text), &limits)?;
            let problems = manifest_problems(&manifest, &limits)
                .into_iter()
                .map(|(asset, message)| Problem { asset, file: manifest_path.clone(), message })
                .collect();
            return Ok(Report { assets: manifest.assets.len(), problems, over_budget: Vec::new() });
        }
        Err(e) => return Err(e),
    };
    let mut report = Report { assets: bundle.manifest().assets.len(), ..Report::default() };
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
    let format = bundle.manifest().format;
    if format < crate::bundle::STRANDS_RECORDS_SINCE {
        for asset in bundle.manifest().assets.iter().filter(|a| a.kind == crate::AssetKind::Strands) {
            report.problems.push(Problem {
                asset: asset.id.clone(),
                file: manifest_path.clone(),
                message: format!(
                    "strands of a format {format} bundle cannot be drawn by this hikage (point records since {}): bake them again",
                    crate::bundle::STRANDS_RECORDS_SINCE
                ),
            });
        }
    }
    if let Some(budget) = &bundle.manifest().budget {
        report.over_budget = budget.overruns(&bundle.manifest().weights());
    }
    Ok(report)
}

fn check_asset(bundle: &Bundle, asset: &Asset) -> Result<(), BundleError> {
    let bytes = bundle.read_payload(asset)?;
    check_payload(asset, &bytes, &bundle.payload_path(asset), bundle.limits())?;
    match &asset.settings {
        crate::Settings::HairBinding(b) => check_binding(bundle, asset, b),
        // What the skinning pass reads of a scalp, bound or not.
        crate::Settings::Scalp(_) => crate::Scalp::read(&bundle.read_mesh(&asset.id)?).map(|_| ()).map_err(|message| {
            BundleError::Payload { path: bundle.payload_path(asset), asset: asset.id.clone(), message }
        }),
        _ => Ok(()),
    }
}

/// A hair binding against the assets it names: one binding per strand of its strands, each on
/// a triangle of its scalp, every scalp joint in the scalp's joint list.
fn check_binding(bundle: &Bundle, asset: &Asset, b: &crate::HairBindingSettings) -> Result<(), BundleError> {
    let fail =
        |message: String| BundleError::Payload { path: bundle.payload_path(asset), asset: asset.id.clone(), message };
    let strands = bundle
        .asset(&b.strands)?
        .settings
        .strands()
        .ok_or_else(|| fail(format!("`strands` names {}, which is not a strands asset", b.strands)))?;
    let scalp_asset = bundle.asset(&b.scalp)?;
    let joints = scalp_asset
        .settings
        .scalp()
        .ok_or_else(|| fail(format!("`scalp` names {}, which is not a scalp asset", b.scalp)))?
        .joints
        .len();
    let scalp =
        crate::Scalp::read(&bundle.read_mesh(&b.scalp)?).map_err(|m| fail(format!("scalp {}: {m}", b.scalp)))?;
    let bindings = crate::binding::read_binding(&bundle.read_mesh(&asset.id)?).map_err(fail)?;
    scalp.check(&bindings, joints, strands.strands).map_err(fail)
}

/// Checks the payload `bytes` of `asset` (from `path`) the way a reader relies on it: a texture
/// decodes, its KTX2 header agrees with the manifest and every float texel is finite; a mesh's
/// accessors lie inside the bytes, its indices below the vertex count, its floats finite. The
/// one check [`validate`] and every writer ([`crate::BundleWriter`]) apply, so a bundle that was
/// committed always validates.
pub fn check_payload(asset: &Asset, bytes: &[u8], path: &Path, limits: &Limits) -> Result<(), BundleError> {
    let fail = |message: String| BundleError::Payload { path: path.to_path_buf(), asset: asset.id.clone(), message };
    match &asset.payload {
        Payload::Texture(_) => check_texture(&crate::bundle::decode_texture(asset, bytes, path, limits)?).map_err(fail),
        Payload::Mesh(desc) if desc.supercompression.is_none() => {
            desc.check(bytes.len() as u64).map_err(fail)?;
            check_mesh(desc, bytes).map_err(fail)
        }
        Payload::Mesh(_) => {
            let mesh = crate::bundle::decode_mesh(asset, bytes.to_vec(), path, limits)?;
            check_mesh(&mesh.desc, &mesh.bytes).map_err(fail)
        }
    }
}

/// The first non-finite texel of a decoded texture, as a message.
pub(crate) fn check_texture(tex: &TextureData) -> Result<(), String> {
    match tex.first_non_finite() {
        Some((level, slice, row, col, ch)) => {
            Err(format!("texel at level {level}, slice {slice}, row {row}, column {col}, channel {ch} is not finite"))
        }
        None => Ok(()),
    }
}

/// An index at or past the vertex count, a vertex stream no GPU can fetch
/// ([`crate::Accessor::vertex_fetch`]), or a float attribute that is not finite, as a message
/// (the accessors already checked against `bytes`, as [`crate::decode_mesh`] does).
pub fn check_mesh(desc: &MeshDesc, bytes: &[u8]) -> Result<(), String> {
    if let Some(ix) = &desc.indices {
        for (i, e) in read_elements(bytes, ix).enumerate() {
            let v = read_uint(e, ix.component);
            if v >= desc.vertex_count {
                return Err(format!("index {i} is {v}, expected below the vertex count {}", desc.vertex_count));
            }
        }
    }
    for a in &desc.attributes {
        let fetch = a.vertex_fetch()?;
        let fetched = (fetch.component.bytes() * fetch.components as usize - a.element_bytes()) as u64;
        if a.count > 0 && a.end().is_none_or(|end| end + fetched > bytes.len() as u64) {
            return Err(format!(
                "stream `{}`: its last element is fetched as {} components, past the {}-byte buffer",
                a.name,
                fetch.components,
                bytes.len()
            ));
        }
    }
    for a in desc.attributes.iter().filter(|a| a.component == ComponentType::F32) {
        for (i, e) in read_elements(bytes, a).enumerate() {
            if e.chunks_exact(4).any(|c| !f32::from_le_bytes([c[0], c[1], c[2], c[3]]).is_finite()) {
                return Err(format!("attribute `{}` element {i} is not finite", a.name));
            }
        }
    }
    Ok(())
}
