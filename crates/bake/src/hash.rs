//! Input hashes: what decides whether a job must be baked again.

use std::path::Path;

use crate::error::BakeError;
use crate::jobs::Baker;
use crate::limits::InputLimits;

/// The input hash of a job: a domain tag, the kind, its algorithm version, the canonical
/// settings with the input limits (so a tightened limit re-checks inputs baked before it), then
/// each input file's length and bytes. Paths are not hashed: moving an input does not force a
/// re-bake, changing a byte does.
pub(crate) fn job_hash(job: &dyn Baker, base_dir: &Path, limits: &InputLimits) -> Result<String, BakeError> {
    let settings = format!("{};max_dimension={}", job.canonical_settings(), limits.max_dimension);
    let mut h = blake3::Hasher::new();
    h.update(b"hikage input hash v1\0");
    h.update(job.kind().as_bytes());
    h.update(&[0]);
    h.update(&job.algorithm_version().to_le_bytes());
    h.update(&(settings.len() as u64).to_le_bytes());
    h.update(settings.as_bytes());
    for path in job.inputs(base_dir) {
        let bytes = std::fs::read(&path).map_err(|e| BakeError::io(&path, e))?;
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(&bytes);
    }
    Ok(h.finalize().to_hex().to_string())
}
