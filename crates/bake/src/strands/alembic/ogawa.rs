//! Ogawa, the container under Alembic files: a tree of groups (lists of child offsets) and data
//! blocks (length-prefixed bytes), read from the file's bytes with every offset and length
//! checked against the file before anything is allocated.
//!
//! A hostile file can make one block the child of many groups, so that a reader walking the
//! tree reads it again and again; the bytes read are counted against a multiple of the file's
//! length, which a well-formed archive (each block read about once) stays far below.

use std::cell::Cell;

/// A child of a group: another group or a data block, by its offset in the file (0: empty).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Node {
    /// A group.
    Group(u64),
    /// A data block.
    Data(u64),
}

/// An Ogawa file's bytes.
pub(super) struct Ogawa<'a> {
    bytes: &'a [u8],
    /// Bytes of groups and data read so far, against [`Ogawa::budget`].
    read: Cell<u64>,
}

/// How many times over its own length a file's blocks may be read.
const REREADS: u64 = 16;

/// The high bit of a child offset: set for a data block.
const DATA_BIT: u64 = 1 << 63;

impl<'a> Ogawa<'a> {
    /// The file and its root group, after the signature, the frozen flag (a writer that did not
    /// finish leaves it clear) and the version are checked.
    pub(super) fn open(bytes: &'a [u8]) -> Result<(Ogawa<'a>, u64), String> {
        if bytes.len() < 16 || &bytes[..5] != b"Ogawa" {
            return Err("not an Alembic archive: expected the Ogawa signature (HDF5 Alembic files are not read; \
                        re-export as Ogawa)"
                .into());
        }
        if bytes[5] != 0xff {
            return Err("the archive was not finished: its writer did not close it".into());
        }
        let version = u16::from_be_bytes([bytes[6], bytes[7]]);
        if version != 1 {
            return Err(format!("Ogawa version {version}: expected 1"));
        }
        let file = Ogawa { bytes, read: Cell::new(0) };
        let root = file.u64_at(8)?;
        Ok((file, root))
    }

    /// The file's length in bytes.
    pub(super) fn len(&self) -> u64 {
        self.bytes.len() as u64
    }

    /// The most bytes of blocks a walk of this file may read.
    fn budget(&self) -> u64 {
        REREADS * self.len() + (1 << 20)
    }

    /// Counts `n` bytes read, failing once the walk has read more than a well-formed archive's.
    fn charge(&self, n: u64) -> Result<(), String> {
        let read = self.read.get().saturating_add(n);
        self.read.set(read);
        if read > self.budget() {
            return Err(format!(
                "the archive's blocks are shared so that reading it takes over {REREADS} times its {} bytes \
                 (a malformed or hostile file)",
                self.len()
            ));
        }
        Ok(())
    }

    fn u64_at(&self, at: u64) -> Result<u64, String> {
        let start = usize::try_from(at).ok().filter(|&s| s <= self.bytes.len().saturating_sub(8));
        let start = start.ok_or_else(|| format!("offset {at} lies past the end of the file ({} bytes)", self.len()))?;
        Ok(u64::from_le_bytes(self.bytes[start..start + 8].try_into().expect("8 bytes")))
    }

    /// The children of the group at `offset`.
    pub(super) fn children(&self, offset: u64) -> Result<Vec<Node>, String> {
        if offset == 0 {
            return Ok(Vec::new());
        }
        let count = self.u64_at(offset)?;
        let room = (self.len() - offset - 8) / 8;
        if count > room {
            return Err(format!("the group at byte {offset} claims {count} children; the file holds room for {room}"));
        }
        self.charge(8 + 8 * count)?;
        (0..count)
            .map(|i| {
                let v = self.u64_at(offset + 8 + 8 * i)?;
                Ok(if v & DATA_BIT != 0 { Node::Data(v & !DATA_BIT) } else { Node::Group(v) })
            })
            .collect()
    }

    /// The bytes of the data block at `offset`.
    pub(super) fn data(&self, offset: u64) -> Result<&'a [u8], String> {
        if offset == 0 {
            return Ok(&[]);
        }
        let size = self.u64_at(offset)?;
        let room = self.len() - offset - 8;
        if size > room {
            return Err(format!("the data at byte {offset} claims {size} bytes; the file holds {room} after it"));
        }
        self.charge(8 + size)?;
        let start = (offset + 8) as usize;
        Ok(&self.bytes[start..start + size as usize])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file of `body` after the header, whose root group is at `root`.
    fn file(frozen: u8, root: u64, body: &[u8]) -> Vec<u8> {
        let mut f = b"Ogawa".to_vec();
        f.extend([frozen, 0, 1]);
        f.extend(root.to_le_bytes());
        f.extend(body);
        f
    }

    #[test]
    fn groups_and_data_are_read_within_the_file() {
        // Root at 16: two children, a data block at 40 and an empty group.
        let mut body = Vec::new();
        body.extend(2u64.to_le_bytes());
        body.extend((40 | DATA_BIT).to_le_bytes());
        body.extend(0u64.to_le_bytes());
        body.extend(3u64.to_le_bytes());
        body.extend(b"abc");
        let bytes = file(0xff, 16, &body);
        let (f, root) = Ogawa::open(&bytes).unwrap();
        assert_eq!(f.children(root).unwrap(), [Node::Data(40), Node::Group(0)]);
        assert_eq!(f.data(40).unwrap(), b"abc");
        assert!(f.children(0).unwrap().is_empty());
    }

    #[test]
    fn counts_and_offsets_past_the_end_are_errors() {
        let mut body = Vec::new();
        body.extend(u64::MAX.to_le_bytes());
        let bytes = file(0xff, 16, &body);
        let (f, root) = Ogawa::open(&bytes).unwrap();
        assert!(f.children(root).unwrap_err().contains("claims 18446744073709551615 children"));
        assert!(f.data(16).unwrap_err().contains("claims"));
        assert!(f.children(u64::MAX - 3).unwrap_err().contains("past the end"));
        assert!(Ogawa::open(&file(0, 16, &body)).err().unwrap().contains("not finished"));
        assert!(Ogawa::open(b"HDF5 archive....").err().unwrap().contains("Ogawa signature"));
    }

    #[test]
    fn a_block_read_over_and_over_is_an_error() {
        // A group whose 2,000 children are all one 1 KiB data block, read whole each time.
        let mut body = Vec::new();
        let data = 16 + 8 + 8 * 2000;
        body.extend(2000u64.to_le_bytes());
        (0..2000).for_each(|_| body.extend((data as u64 | DATA_BIT).to_le_bytes()));
        body.extend(1024u64.to_le_bytes());
        body.extend([7; 1024]);
        let bytes = file(0xff, 16, &body);
        let (f, root) = Ogawa::open(&bytes).unwrap();
        let mut result = Ok(&[][..]);
        for child in f.children(root).unwrap() {
            let Node::Data(at) = child else { unreachable!() };
            result = f.data(at);
            if result.is_err() {
                break;
            }
        }
        assert!(result.unwrap_err().contains("hostile"));
        assert!(f.read.get() > 16 * bytes.len() as u64);
    }
}
