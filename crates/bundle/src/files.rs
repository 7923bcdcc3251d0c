//! Opening untrusted files: regular files only, sizes checked before reading.
//!
//! Every file hikage reads on someone else's word — an input named by a pipeline, a manifest, a
//! payload, a shard record, a cache entry — goes through here. A FIFO would block the read
//! forever and `/dev/zero` never ends, so anything that is not a regular file (after following
//! symbolic links, which a user may legitimately point at their data) is refused before it is
//! opened for reading; a size is checked against its limit before anything is allocated for it.

use std::fs;
use std::io::Read;
use std::path::Path;

use crate::error::BundleError;

/// The metadata of `path` (symbolic links followed) when it is a regular file; an
/// [`std::io::ErrorKind::InvalidInput`] error naming what it is otherwise.
pub fn regular_metadata(path: &Path) -> std::io::Result<fs::Metadata> {
    let meta = fs::metadata(path)?;
    if meta.is_file() { Ok(meta) } else { Err(not_regular(&meta)) }
}

/// Opens `path` for reading when it is a regular file (checked before opening, so a FIFO is
/// never waited on, and again on the opened file).
pub fn open_regular(path: &Path) -> std::io::Result<fs::File> {
    regular_metadata(path)?;
    let file = fs::File::open(path)?;
    let meta = file.metadata()?;
    if meta.is_file() { Ok(file) } else { Err(not_regular(&meta)) }
}

/// A file inside a bundle (a payload, a tile table) as [`open_regular`] opens it, but a symbolic
/// link is refused: a bundle's files are its own, and a link may lead anywhere.
pub fn open_in_bundle(path: &Path) -> std::io::Result<fs::File> {
    let meta = fs::symlink_metadata(path)?;
    if !meta.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            if meta.file_type().is_symlink() {
                "a symbolic link: a bundle's files are refused through links".to_string()
            } else {
                not_regular(&meta).to_string()
            },
        ));
    }
    open_regular(path)
}

/// Reads the file `path` inside a bundle ([`open_in_bundle`]: no symbolic links), refusing it
/// before reading when it is larger than `limit` bytes.
pub fn read_in_bundle(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>, BundleError> {
    open_in_bundle(path).map_err(|e| BundleError::io(path, e))?;
    read_limited(path, limit, what)
}

/// Reads the regular file `path`, refusing it before reading when it is larger than `limit`
/// bytes (`what` names the quantity in the error: `manifest size`, `payload size`).
pub fn read_limited(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>, BundleError> {
    let file = open_regular(path).map_err(|e| BundleError::io(path, e))?;
    let len = file.metadata().map_err(|e| BundleError::io(path, e))?.len();
    let over = |value: u64| BundleError::Limit { path: path.to_path_buf(), what: what.into(), value, limit };
    if len > limit {
        return Err(over(len));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    // The file may grow after the check: never read past the limit.
    file.take(limit + 1).read_to_end(&mut bytes).map_err(|e| BundleError::io(path, e))?;
    if bytes.len() as u64 > limit {
        return Err(over(bytes.len() as u64));
    }
    Ok(bytes)
}

/// The error for a path that is not a regular file, naming what it is.
fn not_regular(meta: &fs::Metadata) -> std::io::Error {
    let ft = meta.file_type();
    let what = if ft.is_dir() {
        "a directory"
    } else {
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            if ft.is_fifo() {
                "a FIFO"
            } else if ft.is_char_device() {
                "a character device"
            } else if ft.is_block_device() {
                "a block device"
            } else if ft.is_socket() {
                "a socket"
            } else {
                "not a file"
            }
        }
        #[cfg(not(unix))]
        {
            "not a file"
        }
    };
    std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("expected a regular file, found {what}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directories_and_devices_are_refused_before_reading() {
        let dir = std::env::temp_dir().join(format!("hikage-files-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let err = open_regular(&dir).unwrap_err();
        assert!(err.to_string().contains("found a directory"), "{err}");
        #[cfg(unix)]
        {
            let err = read_limited(Path::new("/dev/zero"), 10, "x").unwrap_err();
            assert!(err.to_string().contains("character device"), "{err}");
        }
        let file = dir.join("ten");
        fs::write(&file, [7u8; 10]).unwrap();
        assert_eq!(read_limited(&file, 10, "x").unwrap().len(), 10);
        let err = read_limited(&file, 9, "test size").unwrap_err();
        assert!(matches!(err, BundleError::Limit { value: 10, limit: 9, .. }), "{err}");
        fs::remove_dir_all(&dir).unwrap();
    }
}
