//! The record of one strand point in a `Strands` mesh, written by the baker and read by the
//! runtime's shaders and CPU reference: one definition of the encoding (octahedral tangents,
//! unorm widths and opacities, sRGB colour bytes) on both sides.

use crate::asset::{STRANDS_RECORD_BYTES, STRANDS_STREAMS};
use crate::mesh::{Accessor, MeshData, MeshDesc};
use crate::settings::StrandsSettings;

/// One strand point as a `Strands` record holds it (see [`crate::AssetKind::Strands`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrandPoint {
    /// Centre-line position (world units).
    pub position: [f32; 3],
    /// Unit tangent (stored octahedral, 16 bits a component).
    pub tangent: [f32; 3],
    /// Shading width before taper (world units; stored as a share of the asset's `max_width`).
    pub width: f32,
    /// Shading opacity, 0–1.
    pub alpha: f32,
    /// Linear RGB, 0–1 (stored sRGB-encoded, 8 bits a channel).
    pub color: [f32; 3],
    /// The point's index in its strand.
    pub index: u16,
    /// The strand's segment count (its points − 1).
    pub segments: u16,
    /// The strand's index in the source file.
    pub strand_id: u32,
}

impl StrandPoint {
    /// 0 at the root, 1 at the tip.
    pub fn param(&self) -> f32 {
        if self.segments == 0 { 0.0 } else { self.index as f32 / self.segments as f32 }
    }

    /// The record of this point, widths as a share of `max_width`.
    pub fn encode(&self, max_width: f32) -> [u8; STRANDS_RECORD_BYTES as usize] {
        let mut out = [0u8; STRANDS_RECORD_BYTES as usize];
        let mut at = 0;
        let mut put = |bytes: &[u8]| {
            out[at..at + bytes.len()].copy_from_slice(bytes);
            at += bytes.len();
        };
        self.position.iter().for_each(|x| put(&x.to_le_bytes()));
        oct_encode(self.tangent).iter().for_each(|x| put(&x.to_le_bytes()));
        let share = if max_width > 0.0 { self.width / max_width } else { 0.0 };
        put(&unorm16(share).to_le_bytes());
        put(&unorm16(self.alpha).to_le_bytes());
        put(&self.color.map(linear_to_srgb8));
        put(&[255]);
        put(&self.index.to_le_bytes());
        put(&self.segments.to_le_bytes());
        put(&self.strand_id.to_le_bytes());
        out
    }

    /// The point a record holds, widths scaled back by `max_width`.
    pub fn decode(record: &[u8], max_width: f32) -> StrandPoint {
        let u16_at = |i: usize| u16::from_le_bytes([record[i], record[i + 1]]);
        let f32_at = |i: usize| f32::from_le_bytes([record[i], record[i + 1], record[i + 2], record[i + 3]]);
        StrandPoint {
            position: [f32_at(0), f32_at(4), f32_at(8)],
            tangent: oct_decode([u16_at(12), u16_at(14)]),
            width: u16_at(16) as f32 / 65535.0 * max_width,
            alpha: u16_at(18) as f32 / 65535.0,
            color: [record[20], record[21], record[22]].map(srgb8_to_linear),
            index: u16_at(24),
            segments: u16_at(26),
            strand_id: u32::from_le_bytes([record[28], record[29], record[30], record[31]]),
        }
    }
}

/// The mesh layout of `points` records: the streams of [`STRANDS_STREAMS`] interleaved, no
/// indices.
pub fn strands_desc(points: u32) -> MeshDesc {
    let mut offset = 0u64;
    let attributes = STRANDS_STREAMS
        .iter()
        .map(|s| {
            let a = Accessor {
                name: s.name.into(),
                offset,
                stride: STRANDS_RECORD_BYTES,
                component: s.component,
                components: s.components,
                count: points,
            };
            offset += (s.component.bytes() * s.components as usize) as u64;
            a
        })
        .collect();
    MeshDesc { vertex_count: points, attributes, indices: None, supercompression: crate::Supercompression::None }
}

/// Every point of a `Strands` mesh, in record order; `None` when its layout is not
/// [`strands_desc`]'s.
pub fn read_strand_points(mesh: &MeshData, settings: &StrandsSettings) -> Option<Vec<StrandPoint>> {
    if mesh.desc != strands_desc(mesh.desc.vertex_count) {
        return None;
    }
    let bytes = mesh.bytes.get(..mesh.desc.vertex_count as usize * STRANDS_RECORD_BYTES as usize)?;
    Some(
        bytes.chunks_exact(STRANDS_RECORD_BYTES as usize).map(|r| StrandPoint::decode(r, settings.max_width)).collect(),
    )
}

/// `x` in 0–1 as a 16-bit unorm, rounded to nearest.
fn unorm16(x: f32) -> u16 {
    (x.clamp(0.0, 1.0) * 65535.0).round() as u16
}

/// A unit vector's octahedral encoding, each component a 16-bit unorm (the WGSL decodes it
/// with `hair_oct_decode`).
pub fn oct_encode(v: [f32; 3]) -> [u16; 2] {
    let l1 = v[0].abs() + v[1].abs() + v[2].abs();
    if l1 <= 0.0 {
        return [32768, 32768];
    }
    let (mut x, mut y) = (v[0] / l1, v[1] / l1);
    if v[2] < 0.0 {
        let sign = |a: f32| if a >= 0.0 { 1.0 } else { -1.0 };
        (x, y) = ((1.0 - y.abs()) * sign(x), (1.0 - x.abs()) * sign(y));
    }
    [unorm16(x * 0.5 + 0.5), unorm16(y * 0.5 + 0.5)]
}

/// The unit vector of an octahedral encoding ([`oct_encode`]).
pub fn oct_decode(e: [u16; 2]) -> [f32; 3] {
    let (x, y) = (e[0] as f32 / 65535.0 * 2.0 - 1.0, e[1] as f32 / 65535.0 * 2.0 - 1.0);
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    let x = if x >= 0.0 { x - t } else { x + t };
    let y = if y >= 0.0 { y - t } else { y + t };
    let l = (x * x + y * y + z * z).sqrt();
    [x / l, y / l, z / l]
}

/// A linear value in 0–1 as an sRGB-encoded byte.
pub fn linear_to_srgb8(c: f32) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0).round() as u8
}

/// The linear value of an sRGB-encoded byte.
pub fn srgb8_to_linear(b: u8) -> f32 {
    let c = b as f32 / 255.0;
    if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unit vectors over the sphere survive the octahedral encoding to within 1e-4 rad.
    #[test]
    fn octahedral_tangents_round_trip() {
        let mut worst = 0.0f32;
        for i in 0..200 {
            for j in 0..100 {
                let (a, z) = (i as f32 * 0.0314159, -1.0 + 2.0 * (j as f32 + 0.5) / 100.0);
                let r = (1.0 - z * z).sqrt();
                let v = [r * a.cos(), r * a.sin(), z];
                let d = oct_decode(oct_encode(v));
                // The chord, which is the angle at this size (acos loses it to rounding).
                let chord = ((v[0] - d[0]).powi(2) + (v[1] - d[1]).powi(2) + (v[2] - d[2]).powi(2)).sqrt();
                worst = worst.max(chord);
            }
        }
        assert!(worst < 1e-4, "{worst} rad");
        for axis in [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]] {
            let d = oct_decode(oct_encode(axis));
            assert!((0..3).all(|k| (d[k] - axis[k]).abs() < 1e-4), "{axis:?} → {d:?}");
        }
    }

    /// A record decodes to its point: positions exact, the rest within its quantisation.
    #[test]
    fn a_record_round_trips() {
        let p = StrandPoint {
            position: [1.5, -2.25, 1e-3],
            tangent: [0.6, 0.0, -0.8],
            width: 0.012,
            alpha: 0.37,
            color: [0.05, 0.5, 1.0],
            index: 7,
            segments: 21,
            strand_id: 123_456,
        };
        let back = StrandPoint::decode(&p.encode(0.02), 0.02);
        assert_eq!((back.position, back.index, back.segments, back.strand_id), (p.position, 7, 21, 123_456));
        assert!((back.width - 0.012).abs() < 0.02 / 65535.0 && (back.alpha - 0.37).abs() < 1.0 / 65535.0);
        assert!((0..3).all(|k| (back.tangent[k] - p.tangent[k]).abs() < 1e-4));
        // sRGB bytes: within half a step of the encoded value.
        for k in 0..3 {
            let s = |c: f32| if c <= 0.0031308 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
            assert!((s(back.color[k]) - s(p.color[k])).abs() <= 0.5 / 255.0 + 1e-6);
        }
        assert!((back.param() - 7.0 / 21.0).abs() < 1e-7);
    }
}
