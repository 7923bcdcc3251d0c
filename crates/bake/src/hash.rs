//! Input hashes: what decides whether a job must be baked again.

use std::path::Path;

use crate::error::BakeError;

/// Hashes a job's inputs: a domain tag, the job kind, the baker's algorithm version, the
/// canonical settings string, then each input file's length and bytes. Paths are not hashed:
/// moving an input does not force a re-bake, changing a byte does.
pub(crate) fn input_hash(
    kind: &str,
    algorithm_version: u32,
    settings: &str,
    inputs: &[&Path],
) -> Result<String, BakeError> {
    let mut h = blake3::Hasher::new();
    h.update(b"hikage input hash v1\0");
    h.update(kind.as_bytes());
    h.update(&[0]);
    h.update(&algorithm_version.to_le_bytes());
    h.update(&(settings.len() as u64).to_le_bytes());
    h.update(settings.as_bytes());
    for path in inputs {
        let bytes = std::fs::read(path).map_err(|e| BakeError::io(*path, e))?;
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(&bytes);
    }
    Ok(h.finalize().to_hex().to_string())
}
