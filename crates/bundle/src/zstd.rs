//! Zstandard frames of payload data: how a writer compresses a texture's levels or a mesh's
//! bytes (an [`Encoder`] of the caller's choosing, so a baker can bring libzstd at any level
//! while readers stay pure Rust), and how readers inflate a frame within their limits.

/// Compresses bytes into one Zstandard frame. Must give the same bytes for the same input.
pub type Encoder<'a> = &'a (dyn Fn(&[u8]) -> Vec<u8> + Sync);

/// The built-in encoder: ruzstd's fastest level (about zstd's level 1).
pub fn fastest(data: &[u8]) -> Vec<u8> {
    ruzstd::encoding::compress_to_vec(data, ruzstd::encoding::CompressionLevel::Fastest)
}

/// Inflates `frame` (one or more Zstandard frames) to at most `max` bytes: a frame that declares
/// its content size is checked against `max` before anything is allocated; one that does not is
/// inflated until it passes `max`, and refused there.
pub fn inflate(frame: &[u8], max: u64) -> Result<Vec<u8>, String> {
    let mut probe = ruzstd::decoding::FrameDecoder::new();
    probe.init(frame).map_err(|e| format!("zstd frame header refused: {e}"))?;
    let declared = probe.content_size();
    if declared > max {
        return Err(format!("zstd frame declares {declared} bytes, above the limit of {max}"));
    }
    if declared > 0 {
        let mut out = vec![0u8; declared as usize];
        let n = ruzstd::decoding::FrameDecoder::new()
            .decode_all(frame, &mut out)
            .map_err(|e| format!("zstd data is corrupt: {e}"))?;
        if n as u64 != declared {
            return Err(format!("zstd frame inflates to {n} bytes, it declares {declared}"));
        }
        return Ok(out);
    }
    use std::io::Read;
    let decoder = ruzstd::decoding::StreamingDecoder::new(frame).map_err(|e| format!("zstd data is corrupt: {e}"))?;
    let mut out = Vec::new();
    decoder.take(max + 1).read_to_end(&mut out).map_err(|e| format!("zstd data is corrupt: {e}"))?;
    if out.len() as u64 > max {
        return Err(format!("zstd data inflates past the limit of {max} bytes"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame without a declared size (ruzstd's) round-trips and is refused past the limit;
    /// what is not a frame is refused. (Frames with a declared size: hikage-bake's tests, whose
    /// libzstd writes them.)
    #[test]
    fn frames_inflate_within_the_limit() {
        let data: Vec<u8> = (0..100_000u32).map(|i| (i * 7 % 251) as u8).collect();
        let undeclared = fastest(&data);
        assert_eq!(inflate(&undeclared, 100_000).unwrap(), data);
        assert!(inflate(&undeclared, 99_999).unwrap_err().contains("past the limit"));
        assert!(inflate(&undeclared[..undeclared.len() / 2], 100_000).is_err());
        assert!(inflate(b"not zstd at all", 10).unwrap_err().contains("zstd frame header refused"));
    }
}
