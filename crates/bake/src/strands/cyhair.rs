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
