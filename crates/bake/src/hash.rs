//! Input hashes: what decides whether a job must be baked again.

use std::path::{Path, PathBuf};

use crate::error::BakeError;

/// What a job's input hash is made of: its kind and algorithm version, its canonical settings
/// (the input limits among them) and its input files.
pub(crate) struct HashedJob<'a> {
    pub kind: &'a str,
    pub algorithm_version: u32,
    pub settings: String,
    pub inputs: Vec<PathBuf>,
}

/// The input hash of a job: a domain tag, the kind, its algorithm version, the canonical
/// settings, then each input file's length and bytes. Paths are not hashed: moving an input
/// does not force a re-bake, changing a byte does.
pub(crate) fn job_hash(job: &HashedJob) -> Result<String, BakeError> {
    let settings = &job.settings;
    let mut h = blake3::Hasher::new();
    h.update(b"hikage input hash v1\0");
    h.update(job.kind.as_bytes());
    h.update(&[0]);
    h.update(&job.algorithm_version.to_le_bytes());
    h.update(&(settings.len() as u64).to_le_bytes());
    h.update(settings.as_bytes());
    for path in &job.inputs {
        // Before anything is read: a FIFO or /dev/zero as an input would never end.
        let len = hikage_bundle::files::regular_metadata(path).map_err(|e| BakeError::io(path, e))?.len();
        h.update(&len.to_le_bytes());
        stream(path, len, &mut h)?;
    }
    Ok(h.finalize().to_hex().to_string())
}

/// Feeds the `len` bytes of the file at `path` to `h`; an error if the file is not `len` long
/// by the time it has been read (it changed while being hashed).
fn stream(path: &Path, len: u64, h: &mut blake3::Hasher) -> Result<(), BakeError> {
    use std::io::Read;
    let mut file = hikage_bundle::files::open_regular(path).map_err(|e| BakeError::io(path, e))?.take(len + 1);
    let mut buf = vec![0u8; 1 << 20];
    let mut read = 0u64;
    loop {
        let n = file.read(&mut buf).map_err(|e| BakeError::io(path, e))?;
        if n == 0 {
            break;
        }
        h.update(&buf[..n]);
        read += n as u64;
    }
    if read != len {
        return Err(BakeError::input(
            path,
            None,
            format!("the file changed while it was read ({len} bytes, then {read})"),
        ));
    }
    Ok(())
}
