//! Asset ids and payload file names.
//!
//! Payload files live flat in the bundle directory under a content-derived name
//! `<id>.<first 16 hex digits of the BLAKE3>.<ext>`, so a new bake never overwrites a file the
//! current manifest points at, and a manifest can never name a file outside the directory.

/// True when `id` may name an asset: 1 to 128 characters from `A–Z a–z 0–9 _ - .`, not
/// starting with `.`.
pub fn is_valid_asset_id(id: &str) -> bool {
    !id.is_empty()
        && id.len() <= 128
        && !id.starts_with('.')
        && id.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-' || b == b'.')
}

/// [`is_valid_asset_id`] as a result whose error says what an id may be; the one message every
/// reader and writer of ids gives.
pub fn check_asset_id(id: &str) -> Result<(), String> {
    if is_valid_asset_id(id) {
        Ok(())
    } else {
        Err(format!("id {id:?} is not valid: expected 1–128 of A–Z a–z 0–9 _ - . not starting with ."))
    }
}

/// True when `file` is a plain file name inside the bundle directory: no separators, no `..`,
/// not absolute, not hidden, only the characters of an asset id.
pub fn is_safe_file_name(file: &str) -> bool {
    is_valid_asset_id(file) && file != ".." && !file.contains("..")
}

/// The content-derived file name of a payload: `<id>.<16 hex digits of hash>.<ext>`.
pub fn payload_file_name(id: &str, blake3_hex: &str, ext: &str) -> String {
    format!("{id}.{}.{ext}", &blake3_hex[..16.min(blake3_hex.len())])
}

/// True when `file` is a content-derived payload name of these bytes: `<id>.<16 hex digits of
/// blake3_hex>.<ext>` for any valid id. An asset's own payload is named after its own id; since
/// format 1.10 assets with identical payloads share one file, named after the first of their ids.
pub fn is_payload_file_of(file: &str, blake3_hex: &str, ext: &str) -> bool {
    let Some(stem) = file.strip_suffix(ext).and_then(|s| s.strip_suffix('.')) else {
        return false;
    };
    stem.rsplit_once('.').is_some_and(|(id, hash)| {
        is_valid_asset_id(id) && hash.len() == 16 && blake3_hex.len() >= 16 && hash == &blake3_hex[..16]
    })
}

/// True when `name` has the shape of a payload file this crate writes (used to find stale
/// payloads; other files in the directory are never touched).
pub(crate) fn looks_like_payload(name: &str) -> bool {
    let Some((stem, ext)) = name.rsplit_once('.') else {
        return false;
    };
    if !matches!(ext, "ktx2" | "bin") {
        return false;
    }
    let Some((id, hash)) = stem.rsplit_once('.') else {
        return false;
    };
    is_valid_asset_id(id) && hash.len() == 16 && hash.bytes().all(|b| b.is_ascii_hexdigit())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_and_file_names() {
        assert!(is_valid_asset_id("terrain.horizon"));
        assert!(is_valid_asset_id("a-b_c1"));
        for bad in ["", ".hidden", "a/b", "a\\b", "../x", "/abs", "a b", "é"] {
            assert!(!is_valid_asset_id(bad), "{bad:?} accepted");
        }
        assert!(!is_safe_file_name(".."));
        assert!(!is_safe_file_name("a..b"));
        assert!(is_safe_file_name("t.0123456789abcdef.ktx2"));
        let name = payload_file_name("t", "0123456789abcdef0123", "ktx2");
        assert_eq!(name, "t.0123456789abcdef.ktx2");
        assert!(looks_like_payload(&name));
        assert!(!looks_like_payload("notes.txt"));
        assert!(!looks_like_payload("t.0123.ktx2"));
        let hash = "0123456789abcdef0123";
        assert!(is_payload_file_of(&name, hash, "ktx2"));
        assert!(is_payload_file_of("other.id.0123456789abcdef.ktx2", hash, "ktx2"));
        for bad in
            ["t.0123456789abcdef.bin", "t.0123456789abcdee.ktx2", "0123456789abcdef.ktx2", "../t.0123456789abcdef.ktx2"]
        {
            assert!(!is_payload_file_of(bad, hash, "ktx2"), "{bad}");
        }
    }
}
