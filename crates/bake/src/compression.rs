//! How a job's payloads are stored: as they are, or zstd-compressed at a level (a texture's
//! levels each as a KTX2 zstd supercompression frame, a mesh's buffer as one frame), written with
//! libzstd. Readers inflate with the pure-Rust ruzstd (`hikage_bundle::zstd`).

use hikage_bundle::AssetKind;
use serde::{Deserialize, Serialize};

/// A job's payload compression: absent from `pipeline.ron` (or `Auto`, `--zstd auto`) a level
/// per kind of payload; `compression: Zstd(19)`, `--zstd 19` one level for all; `None`,
/// `--zstd 0` for none.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Compression {
    /// Payloads stored as they are: the fastest to load, the largest to ship.
    None,
    /// Zstandard at this level, 1–22 (as `ktx create --zstd` and the `zstd` tool take it).
    Zstd(i32),
    /// Zstandard at the level [`Compression::level_for`] chooses for each kind of payload.
    #[default]
    Auto,
}

/// The level `Auto` gives most payloads, zstd's own default. On the default pipeline level 19
/// everywhere stores 0.80× of level 3's bytes but makes the bake take 3.8× as long (on every
/// rebake and build-script run) and inflates slower; `bench -- size` measures both. Levels
/// 19–22 are for a game's release bake.
pub const DEFAULT_LEVEL: i32 = 3;

/// Payloads from this size on are compressed by libzstd's worker threads, one per thread of the
/// rayon pool. The frame libzstd writes in that mode is the same for any number of workers, so
/// the choice depends on the size alone and the bytes never on the thread count.
const THREADED_FROM: usize = 1 << 20;

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
            Compression::Auto => "auto1".into(),
        }
    }

    /// The zstd level a payload of `kind` gets, or `None` when stored as it is. `Auto` chooses
    /// by what a level buys on each kind (`bench -- size` prints the figures):
    /// - horizons and occlusion maps: level 1. Their half floats' low mantissa bits are noise;
    ///   level 3 stores 4% less at a third of the speed, which made a one-shot horizon bake take
    ///   1.3× as long as an uncompressed one;
    /// - strand records: level 1, which also stores less than level 3 (0.54× against 0.59×);
    /// - everything else (heights, relief maps, meshes): [`DEFAULT_LEVEL`].
    pub fn level_for(self, kind: AssetKind) -> Option<i32> {
        match self {
            Compression::None => None,
            Compression::Zstd(level) => Some(level),
            Compression::Auto => Some(match kind {
                AssetKind::Horizon | AssetKind::AmbientOcclusion | AssetKind::Strands => 1,
                _ => DEFAULT_LEVEL,
            }),
        }
    }

    /// The supercompression a payload's description records.
    pub fn supercompression(self) -> hikage_bundle::Supercompression {
        match self {
            Compression::None => hikage_bundle::Supercompression::None,
            Compression::Zstd(_) | Compression::Auto => hikage_bundle::Supercompression::Zstd,
        }
    }
}

/// `data` as one zstd frame (with its content size) at `level`: the same bytes for the same
/// input on any thread and at any thread count.
pub fn zstd_frame(data: &[u8], level: i32) -> Vec<u8> {
    let frame = (|| {
        let mut c = zstd::bulk::Compressor::new(level)?;
        if data.len() >= THREADED_FROM {
            let workers = rayon::current_num_threads().clamp(1, 64) as u32;
            c.set_parameter(zstd::zstd_safe::CParameter::NbWorkers(workers))?;
        }
        c.compress(data)
    })();
    frame.expect("compressing a buffer in memory cannot fail")
}

/// `--zstd N`: a level 1–22, 0 for none, or `auto` for a level per kind of payload.
pub fn parse_level(text: &str) -> Result<Compression, String> {
    if text == "auto" {
        return Ok(Compression::Auto);
    }
    let level: i32 = text.parse().map_err(|e| format!("{text:?}: {e} (expected 0–22 or auto)"))?;
    let c = if level == 0 { Compression::None } else { Compression::Zstd(level) };
    c.check().map(|()| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// libzstd's frames declare their size, inflate with the readers' ruzstd within a limit that
    /// fits and are refused by one that does not; the same input gives the same bytes, also
    /// above the size compressed on worker threads, at any thread count.
    #[test]
    fn frames_inflate_with_the_readers_decoder() {
        for n in [200_000u32, 3 << 20] {
            let data: Vec<u8> = (0..n).map(|i| ((i * 31) % 253) as u8 ^ (i >> 9) as u8).collect();
            for level in [1, 3, 19] {
                let frame = zstd_frame(&data, level);
                for threads in [1, 2, 3] {
                    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                    assert!(pool.install(|| zstd_frame(&data, level)) == frame, "level {level}, {threads} threads");
                }
                assert!(frame.len() < data.len() / 2, "level {level}: {} bytes", frame.len());
                assert!(hikage_bundle::zstd::inflate(&frame, n as u64).unwrap() == data);
                let refused = hikage_bundle::zstd::inflate(&frame, n as u64 - 1).unwrap_err();
                assert!(refused.contains(&format!("declares {n} bytes")), "{refused}");
            }
        }
        assert_eq!(parse_level("0"), Ok(Compression::None));
        assert_eq!(parse_level("19"), Ok(Compression::Zstd(19)));
        assert_eq!(parse_level("auto"), Ok(Compression::Auto));
        assert!(parse_level("23").unwrap_err().contains("outside 1–22"));
        assert_eq!(Compression::default().level_for(AssetKind::Horizon), Some(1));
        assert_eq!(Compression::default().level_for(AssetKind::Heightfield), Some(DEFAULT_LEVEL));
        assert_eq!(Compression::Zstd(19).level_for(AssetKind::Horizon), Some(19));
        assert_eq!(Compression::None.level_for(AssetKind::Mesh), None);
    }
}
