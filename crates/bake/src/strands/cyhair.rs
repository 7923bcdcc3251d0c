//! Cem Yuksel's `.hair` format (cemyuksel.com/research/hairmodels): a 128-byte little-endian
//! header — `HAIR`, strand count, point count, a flag word (bit 0 segments array, bit 1 points,
//! bit 2 thickness, bit 3 transparency, bit 4 colour), default segment count, thickness,
//! transparency and colour, 88 bytes of text — then the arrays the flags name, in that order:
//! segments (u16 per strand), points (3 × f32), thickness (f32), transparency (f32), colour
//! (3 × f32) per point.

use super::Strands;

/// Flag bits of the header.
pub const HAS_SEGMENTS: u32 = 1;
/// Points array present.
pub const HAS_POINTS: u32 = 2;
/// Thickness array present.
pub const HAS_THICKNESS: u32 = 4;
/// Transparency array present.
pub const HAS_TRANSPARENCY: u32 = 8;
/// Colour array present.
pub const HAS_COLOR: u32 = 16;

/// Encodes strands as a `.hair` file. The segments array is omitted when every strand has the
/// same segment count (it becomes the header default); `info` fills the 88-byte text field
/// (truncated, NUL-padded).
pub fn encode(strands: &Strands, info: &str) -> Vec<u8> {
    let uniform = strands.segments.first().copied().filter(|&f| strands.segments.iter().all(|&s| s == f));
    let mut flags = HAS_POINTS;
    if uniform.is_none() {
        flags |= HAS_SEGMENTS;
    }
    if strands.thickness.is_some() {
        flags |= HAS_THICKNESS;
    }
    if strands.transparency.is_some() {
        flags |= HAS_TRANSPARENCY;
    }
    if strands.color.is_some() {
        flags |= HAS_COLOR;
    }
    let mut out = Vec::with_capacity(128 + strands.points.len() * 12);
    out.extend_from_slice(b"HAIR");
    for v in [strands.segments.len() as u32, strands.points.len() as u32, flags, uniform.unwrap_or(0) as u32] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&strands.default_thickness.to_le_bytes());
    out.extend_from_slice(&strands.default_transparency.to_le_bytes());
    for c in strands.default_color {
        out.extend_from_slice(&c.to_le_bytes());
    }
    let mut text = [0u8; 88];
    let n = info.len().min(87);
    text[..n].copy_from_slice(&info.as_bytes()[..n]);
    out.extend_from_slice(&text);
    if uniform.is_none() {
        for s in &strands.segments {
            out.extend_from_slice(&s.to_le_bytes());
        }
    }
    for p in &strands.points {
        p.iter().for_each(|c| out.extend_from_slice(&c.to_le_bytes()));
    }
    for v in strands.thickness.iter().chain(strands.transparency.iter()).flatten() {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for c in strands.color.iter().flatten() {
        c.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
    }
    out
}

/// Limits a `.hair` file is checked against before anything is allocated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HairLimits {
    /// Most strands accepted.
    pub max_strands: u64,
    /// Most points accepted.
    pub max_points: u64,
}

impl HairLimits {
    /// The largest strand file these limits allow: a `.hair` header, segments and every
    /// per-point array; other formats are held to the same size before they are read.
    pub fn max_file_bytes(&self) -> u64 {
        128 + 2 * self.max_strands + 32 * self.max_points
    }
}

impl Default for HairLimits {
    fn default() -> Self {
        HairLimits { max_strands: 4_000_000, max_points: 100_000_000 }
    }
}

/// What is wrong with a `.hair` file, and where.
#[derive(Clone, Debug, PartialEq)]
pub struct HairError {
    /// Where (`byte 4`, `strand 12`, `point 88`, `header`).
    pub place: String,
    /// What was expected and what was found.
    pub message: String,
    /// `(claimed, limit)` when a configured limit was exceeded (rather than the file being
    /// malformed).
    pub over_limit: Option<(u64, u64)>,
}

fn bad(place: impl Into<String>, message: impl Into<String>) -> HairError {
    HairError { place: place.into(), message: message.into(), over_limit: None }
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// Decodes a `.hair` file. The signature may be `HAIR` or `hair`; flag bits beyond the five
/// known ones are ignored. Counts are checked against `limits` and against the file's length
/// before any array is allocated; the segments must account for every point exactly; positions
/// must be finite and thickness finite and non-negative, transparency and colour finite.
pub fn decode(bytes: &[u8], limits: &HairLimits) -> Result<Strands, HairError> {
    if bytes.len() < 128 {
        return Err(bad("header", format!("expected a 128-byte header, found a {}-byte file", bytes.len())));
    }
    if &bytes[..4] != b"HAIR" && &bytes[..4] != b"hair" {
        return Err(bad(
            "byte 0",
            format!("expected the signature \"HAIR\", found {:?}", String::from_utf8_lossy(&bytes[..4])),
        ));
    }
    let (strands, points, flags, default_segments) =
        (u32_at(bytes, 4) as u64, u32_at(bytes, 8) as u64, u32_at(bytes, 12), u32_at(bytes, 16));
    for (what, n, max) in [("strand count", strands, limits.max_strands), ("point count", points, limits.max_points)] {
        if n > max {
            return Err(HairError { place: "header".into(), message: what.into(), over_limit: Some((n, max)) });
        }
    }
    if flags & HAS_POINTS == 0 {
        return Err(bad("header", "the flags name no points array: there is no geometry"));
    }
    if strands == 0 {
        return Err(bad("header", "expected at least one strand, found 0"));
    }
    // Array sizes, in the file's order, checked against the length before reading.
    let seg_bytes = if flags & HAS_SEGMENTS != 0 { strands * 2 } else { 0 };
    let per_point = 12
        + if flags & HAS_THICKNESS != 0 { 4 } else { 0 }
        + if flags & HAS_TRANSPARENCY != 0 { 4 } else { 0 }
        + if flags & HAS_COLOR != 0 { 12 } else { 0 };
    let needed = 128 + seg_bytes + points * per_point;
    if (bytes.len() as u64) < needed {
        return Err(bad(
            "header",
            format!(
                "{strands} strands and {points} points with flags {flags:#x} need {needed} bytes, the file has {}",
                bytes.len()
            ),
        ));
    }
    let default_thickness = f32_at(bytes, 20);
    let default_transparency = f32_at(bytes, 24);
    let default_color = [f32_at(bytes, 28), f32_at(bytes, 32), f32_at(bytes, 36)];
    if !(default_thickness.is_finite() && default_thickness >= 0.0) {
        return Err(bad(
            "byte 20",
            format!("expected a finite non-negative default thickness, found {default_thickness}"),
        ));
    }
    if !default_transparency.is_finite() || default_color.iter().any(|c| !c.is_finite()) {
        return Err(bad("byte 24", "expected a finite default transparency and colour"));
    }
    let mut at = 128usize;
    let segments: Vec<u16> = if flags & HAS_SEGMENTS != 0 {
        let s = (0..strands as usize).map(|k| u16::from_le_bytes([bytes[at + 2 * k], bytes[at + 2 * k + 1]])).collect();
        at += seg_bytes as usize;
        s
    } else {
        if default_segments > u16::MAX as u32 {
            return Err(bad("byte 16", format!("default segment count {default_segments} does not fit 16 bits")));
        }
        vec![default_segments as u16; strands as usize]
    };
    let total: u64 = segments.iter().map(|&s| s as u64 + 1).sum();
    if total != points {
        return Err(bad(
            "segments",
            format!("the strands' segments account for {total} points, the header says {points}"),
        ));
    }
    let n = points as usize;
    let mut pts = Vec::with_capacity(n);
    for k in 0..n {
        let p = [f32_at(bytes, at), f32_at(bytes, at + 4), f32_at(bytes, at + 8)];
        if p.iter().any(|c| !c.is_finite()) {
            return Err(bad(format!("point {k} (byte {at})"), format!("expected a finite position, found {p:?}")));
        }
        pts.push(p);
        at += 12;
    }
    let mut floats = |flag: u32, what: &str, check: fn(f32) -> bool| -> Result<Option<Vec<f32>>, HairError> {
        if flags & flag == 0 {
            return Ok(None);
        }
        let mut v = Vec::with_capacity(n);
        for k in 0..n {
            let x = f32_at(bytes, at);
            if !check(x) {
                return Err(bad(format!("point {k} (byte {at})"), format!("expected a valid {what}, found {x}")));
            }
            v.push(x);
            at += 4;
        }
        Ok(Some(v))
    };
    let thickness = floats(HAS_THICKNESS, "thickness (finite, ≥ 0)", |x| x.is_finite() && x >= 0.0)?;
    let transparency = floats(HAS_TRANSPARENCY, "transparency (finite)", f32::is_finite)?;
    let color = if flags & HAS_COLOR != 0 {
        let mut v = Vec::with_capacity(n);
        for k in 0..n {
            let c = [f32_at(bytes, at), f32_at(bytes, at + 4), f32_at(bytes, at + 8)];
            if c.iter().any(|x| !x.is_finite()) {
                return Err(bad(format!("point {k} (byte {at})"), format!("expected a finite colour, found {c:?}")));
            }
            v.push(c);
            at += 12;
        }
        Some(v)
    } else {
        None
    };
    Ok(Strands {
        segments,
        points: pts,
        thickness,
        transparency,
        color,
        default_thickness,
        default_transparency,
        default_color,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Strands {
        Strands {
            segments: vec![2, 1],
            points: vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, 0.5], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
            thickness: Some(vec![0.1, 0.09, 0.08, 0.2, 0.1]),
            transparency: None,
            color: Some(vec![[1.0, 0.5, 0.25]; 5]),
            default_thickness: 0.1,
            default_transparency: 0.5,
            default_color: [0.2, 0.3, 0.4],
        }
    }

    #[test]
    fn round_trip_and_lowercase_signature_and_unknown_flags() {
        let s = sample();
        let mut bytes = encode(&s, "test");
        assert_eq!(decode(&bytes, &HairLimits::default()).unwrap(), s);
        bytes[..4].copy_from_slice(b"hair");
        let flags = u32_at(&bytes, 12) | 0x100;
        bytes[12..16].copy_from_slice(&flags.to_le_bytes());
        assert_eq!(decode(&bytes, &HairLimits::default()).unwrap(), s);
    }

    #[test]
    fn lying_headers_are_refused_before_allocating() {
        let s = sample();
        let good = encode(&s, "");
        let with = |at: usize, v: u32| {
            let mut b = good.clone();
            b[at..at + 4].copy_from_slice(&v.to_le_bytes());
            b
        };
        let limits = HairLimits::default();
        let e = decode(&with(8, 4_000_000_000), &limits).unwrap_err();
        assert_eq!((e.message.as_str(), e.over_limit), ("point count", Some((4_000_000_000, 100_000_000))), "{e:?}");
        let e = decode(&with(8, 50), &limits).unwrap_err();
        assert!(e.message.contains("need") && e.message.contains("bytes"), "{e:?}");
        let e = decode(&with(8, 4), &limits).unwrap_err();
        assert!(e.message.contains("account for 5 points, the header says 4"), "{e:?}");
        let e = decode(&good[..100], &limits).unwrap_err();
        assert!(e.message.contains("128-byte header"), "{e:?}");
        let e = decode(&good[..good.len() - 1], &limits).unwrap_err();
        assert!(e.message.contains("the file has"), "{e:?}");
        let mut nan = s.clone();
        nan.points[3][1] = f32::NAN;
        let e = decode(&encode(&nan, ""), &limits).unwrap_err();
        assert!(e.place.starts_with("point 3") && e.message.contains("finite position"), "{e:?}");
        let mut neg = s.clone();
        neg.thickness.as_mut().unwrap()[2] = -1.0;
        let e = decode(&encode(&neg, ""), &limits).unwrap_err();
        assert!(e.place.starts_with("point 2") && e.message.contains("thickness"), "{e:?}");
        let mut sig = good.clone();
        sig[..4].copy_from_slice(b"HAIX");
        assert!(decode(&sig, &limits).unwrap_err().message.contains("signature"));
    }
}
