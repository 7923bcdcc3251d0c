//! How a job's payloads are stored: as they are, or zstd-compressed at a level (a texture's
//! levels each as a KTX2 zstd supercompression frame, a mesh's buffer as one frame), written with
//! libzstd. Readers inflate with the pure-Rust ruzstd (`hikage_bundle::zstd`).

use serde::{Deserialize, Serialize};

/// A job's payload compression, `compression: Zstd(19)` in `pipeline.ron`, `--zstd 19` on a
/// one-shot command (`--zstd 0` for none).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Compression {
    /// Payloads stored as they are: the fastest to load, the largest to ship.
    None,
    /// Zstandard at this level, 1–22 (as `ktx create --zstd` and the `zstd` tool take it).
    Zstd(i32),
}

impl Default for Compression {
    /// [`DEFAULT_LEVEL`]: see there for why.
    fn default() -> Compression {
        Compression::Zstd(DEFAULT_LEVEL)
    }
}

/// The default level, zstd's own default: on the default bundle it stores 0.58× the raw bytes,
/// compressing the whole bundle in about half a second, while level 19 stores 0.48× but takes
/// 70× as long to write (half a minute, on every rebake and build script run) and inflates 40%
/// slower; `bench -- size` measures both. Levels 19–22 are for a game's release bake.
pub const DEFAULT_LEVEL: i32 = 3;

impl Compression {
    /// The level's range, or none.
    pub fn check(self) -> Result<(), String> {
        match self {
            Compression::Zstd(level) if !(1..=22).contains(&level) => {
                Err(format!("compression: zstd level {level} is outside 1–22"))
            }
            _ => Ok(()),
        }
    }

    /// The text the input hash takes (a payload compressed otherwise is another payload).
    pub fn canonical(self) -> String {
        match self {
            Compression::None => "none".into(),
            Compression::Zstd(level) => format!("zstd{level}"),
        }
    }

    /// The supercompression a payload's description records.
    pub fn supercompression(self) -> hikage_bundle::Supercompression {
        match self {
            Compression::None => hikage_bundle::Supercompression::None,
            Compression::Zstd(_) => hikage_bundle::Supercompression::Zstd,
        }
    }

    /// `data` as the payload stores it: one zstd frame (with its content size) at the level,
    /// the same bytes for the same input on any thread; as it is for `None`.
    pub fn compress(self, data: &[u8]) -> Vec<u8> {
        match self {
            Compression::None => data.to_vec(),
            Compression::Zstd(level) => {
                zstd::bulk::compress(data, level).expect("compressing a buffer in memory cannot fail")
            }
        }
    }
}

/// `--zstd N`: a level 1–22, or 0 for none.
pub fn parse_level(text: &str) -> Result<Compression, String> {
    let level: i32 = text.parse().map_err(|e| format!("{text:?}: {e}"))?;
    let c = if level == 0 { Compression::None } else { Compression::Zstd(level) };
    c.check().map(|()| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// libzstd's frames declare their size, inflate with the readers' ruzstd within a limit that
    /// fits and are refused by one that does not; the same input gives the same bytes.
    #[test]
    fn frames_inflate_with_the_readers_decoder() {
        let data: Vec<u8> = (0..200_000u32).map(|i| ((i * 31) % 253) as u8 ^ (i >> 9) as u8).collect();
        for level in [1, 3, 19] {
            let c = Compression::Zstd(level);
            let frame = c.compress(&data);
            assert_eq!(frame, c.compress(&data));
            assert!(frame.len() < data.len() / 2, "level {level}: {} bytes", frame.len());
            assert_eq!(hikage_bundle::zstd::inflate(&frame, 200_000).unwrap(), data);
            let refused = hikage_bundle::zstd::inflate(&frame, 199_999).unwrap_err();
            assert!(refused.contains("declares 200000 bytes"), "{refused}");
        }
        assert_eq!(Compression::None.compress(&data), data);
        assert_eq!(parse_level("0"), Ok(Compression::None));
        assert_eq!(parse_level("19"), Ok(Compression::Zstd(19)));
        assert!(parse_level("23").unwrap_err().contains("outside 1–22"));
    }
}
