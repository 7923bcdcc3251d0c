//! Strands → strip meshes (seed 004): two vertices per point (the centre line and a side sign)
//! that a vertex shader expands into a view-facing ribbon, and a triangle list of 6 indices per
//! segment. One vertex buffer carries both sets of the paper — the thin **shading** set and
//! the wide, faint **opacity** set drawn into the opacity maps — as two widths and two
//! opacities per vertex, so both sets share positions, tangents and indices.
//!
//! Each strand keeps its own width and opacity: the set values are those of a strand with the
//! source's default thickness and transparency, scaled per point by the point's own values.
//! Written straight into the payload bytes in parallel, in fixed chunks (byte-identical at any
//! thread count), so peak memory stays near the output's size.

use glam::Vec3;
use hikage_bundle::{Accessor, ComponentType, MeshData, MeshDesc, STRANDS_STREAMS, Stream};
use rayon::prelude::*;

use super::Strands;

/// The paper's sets (Ikeda et al.): shading strips 0.16 wide at opacity 0.366, opacity strips
/// 1.40 wide at 0.0165. Without explicit settings the opacity set is the shading set scaled by
/// these ratios.
pub const PAPER_WIDTH_RATIO: f32 = 1.40 / 0.16;
/// See [`PAPER_WIDTH_RATIO`].
pub const PAPER_ALPHA_RATIO: f32 = 0.0165 / 0.366;

/// Width and opacity of both sets for a default strand, and the taper.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StripSets {
    /// Shading set: full width (world units) and opacity.
    pub shading: (f32, f32),
    /// Opacity set: full width and opacity.
    pub opacity: (f32, f32),
    /// Width × (1 − taper × param), param 0 at the root and 1 at the tip.
    pub taper: f32,
}

impl StripSets {
    /// The sets implied by a source: shading = its default thickness and opacity; opacity set
    /// by the paper's ratios.
    pub fn from_source(s: &Strands) -> StripSets {
        let shading = (s.default_thickness, (1.0 - s.default_transparency).clamp(0.0, 1.0));
        StripSets { shading, opacity: (shading.0 * PAPER_WIDTH_RATIO, shading.1 * PAPER_ALPHA_RATIO), taper: 0.0 }
    }
}

/// Points per parallel chunk.
const CHUNK: usize = 4096;

/// First point of each strand, and the total.
pub fn strand_starts(s: &Strands) -> Vec<usize> {
    let mut starts = Vec::with_capacity(s.segments.len() + 1);
    let mut at = 0usize;
    for &seg in &s.segments {
        starts.push(at);
        at += seg as usize + 1;
    }
    starts.push(at);
    starts
}

/// Per point: the strand it belongs to is found by a binary search once per chunk, then walked.
fn for_points(starts: &[usize], first: usize, count: usize, mut f: impl FnMut(usize, usize)) {
    let mut strand = starts.partition_point(|&st| st <= first) - 1;
    for p in first..first + count {
        while starts[strand + 1] <= p {
            strand += 1;
        }
        f(p, strand);
    }
}

/// Unit tangent at point `p` of the strand `[a, b)`: the normalised sum of the unit directions
/// of the segments meeting there (one at the ends); a zero-length neighbourhood gives +y.
pub fn tangent(points: &[[f32; 3]], a: usize, b: usize, p: usize) -> Vec3 {
    let dir = |i: usize, j: usize| unit_or(Vec3::from(points[j]) - Vec3::from(points[i]), Vec3::ZERO);
    let mut t = Vec3::ZERO;
    if p > a {
        t += dir(p - 1, p);
    }
    if p + 1 < b {
        t += dir(p, p + 1);
    }
    unit_or(t, Vec3::Y)
}

/// `v / |v|`, or `fallback` for a zero vector. (A division, not glam's multiplication by the
/// reciprocal, whose rounding differs: the strips' bytes must not change with the refactor.)
pub(crate) fn unit_or(v: Vec3, fallback: Vec3) -> Vec3 {
    let l = v.length();
    if l > 0.0 { v / l } else { fallback }
}

/// The strip mesh of `s` with `sets`, and its bounds (centre lines grown by the wider set's half
/// width).
pub fn build(s: &Strands, sets: &StripSets) -> (MeshData, [f32; 3], [f32; 3]) {
    let starts = strand_starts(s);
    let n = s.points.len();
    let vertices = 2 * n;
    let segments = n - s.segments.len();
    let index_count = 6 * segments;
    // Layout: the streams one after another (each 4-byte aligned), then the indices.
    let mut attributes = Vec::new();
    let mut offset = 0u64;
    for &Stream { name, components: c, .. } in &STRANDS_STREAMS {
        attributes.push(Accessor {
            name: name.into(),
            offset,
            stride: 4 * c as u32,
            component: ComponentType::F32,
            components: c,
            count: vertices as u32,
        });
        offset += vertices as u64 * 4 * c as u64;
    }
    let indices = Accessor {
        name: "index".into(),
        offset,
        stride: 4,
        component: ComponentType::U32,
        components: 1,
        count: index_count as u32,
    };
    let total = offset as usize + index_count * 4;
    let mut bytes = vec![0u8; total];
    let (thick_ref, alpha_ref) = (s.default_thickness, 1.0 - s.default_transparency);
    let ratio = |v: f32, r: f32| if r > 0.0 { v / r } else { 1.0 };
    let (mut rest, index_bytes) = bytes.split_at_mut(offset as usize);
    for (stream_index, &Stream { components: c, .. }) in STRANDS_STREAMS.iter().enumerate() {
        let (stream, tail) = rest.split_at_mut(vertices * 4 * c as usize);
        rest = tail;
        let per_point = 2 * 4 * c as usize;
        stream.par_chunks_mut(CHUNK * per_point).enumerate().for_each(|(chunk, out)| {
            let first = chunk * CHUNK;
            let count = out.len() / per_point;
            let mut w = 0usize;
            let mut put = |v: f32| {
                out[w..w + 4].copy_from_slice(&v.to_le_bytes());
                w += 4;
            };
            for_points(&starts, first, count, |p, strand| {
                let (a, b) = (starts[strand], starts[strand + 1]);
                let param = if b - a > 1 { (p - a) as f32 / (b - a - 1) as f32 } else { 0.0 };
                for side in [-1.0f32, 1.0] {
                    match stream_index {
                        0 => s.points[p].iter().for_each(|&x| put(x)),
                        1 => put(side),
                        2 => tangent(&s.points, a, b, p).to_array().into_iter().for_each(&mut put),
                        3 => put(param),
                        4 => {
                            let k = ratio(s.thickness.as_ref().map_or(thick_ref, |t| t[p]), thick_ref)
                                * (1.0 - sets.taper * param);
                            put(sets.shading.0 * k);
                            put(sets.opacity.0 * k);
                        }
                        5 => {
                            let alpha = 1.0 - s.transparency.as_ref().map_or(s.default_transparency, |t| t[p]);
                            let k = ratio(alpha, alpha_ref);
                            put((sets.shading.1 * k).clamp(0.0, 1.0));
                            put((sets.opacity.1 * k).clamp(0.0, 1.0));
                        }
                        _ => s.color.as_ref().map_or(s.default_color, |c| c[p]).iter().for_each(|&x| put(x)),
                    }
                }
            });
        });
    }
    // Indices: segment j joins point j + (its strand) and the next one.
    let seg_starts: Vec<usize> = starts.iter().enumerate().map(|(k, &st)| st - k).collect();
    index_bytes.par_chunks_mut(CHUNK * 24).enumerate().for_each(|(chunk, out)| {
        let first = chunk * CHUNK;
        let count = out.len() / 24;
        let mut w = 0usize;
        for_points(&seg_starts, first, count, |j, strand| {
            let v = 2 * (j + strand) as u32;
            for i in [v, v + 1, v + 2, v + 1, v + 3, v + 2] {
                out[w..w + 4].copy_from_slice(&i.to_le_bytes());
                w += 4;
            }
        });
    });
    // Bounds: the centre lines, grown by the widest half width.
    let (lo, hi, half) = s
        .points
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(chunk, pts)| {
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            let mut half = 0.0f32;
            for (i, p) in pts.iter().enumerate() {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
                let t = s.thickness.as_ref().map_or(thick_ref, |t| t[chunk * CHUNK + i]);
                half = half.max(0.5 * sets.shading.0.max(sets.opacity.0) * ratio(t, thick_ref));
            }
            (lo, hi, half)
        })
        .reduce(
            || ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3], 0.0),
            |a, b| {
                (std::array::from_fn(|k| a.0[k].min(b.0[k])), std::array::from_fn(|k| a.1[k].max(b.1[k])), a.2.max(b.2))
            },
        );
    let mesh = MeshData { desc: MeshDesc { vertex_count: vertices as u32, attributes, indices: Some(indices) }, bytes };
    (mesh, lo.map(|x| x - half), hi.map(|x| x + half))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_strands() -> Strands {
        Strands {
            segments: vec![2, 1],
            points: vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [5.0, 0.0, 0.0], [5.0, 0.0, 2.0]],
            thickness: Some(vec![0.1, 0.1, 0.1, 0.2, 0.2]),
            transparency: None,
            color: None,
            default_thickness: 0.1,
            default_transparency: 0.5,
            default_color: [0.3, 0.2, 0.1],
        }
    }

    /// Every stream of a 3-point and a 2-point strand, computed by hand.
    #[test]
    fn hand_computed_strips() {
        let s = two_strands();
        let sets = StripSets { shading: (0.1, 0.5), opacity: (0.8, 0.02), taper: 0.5 };
        let (mesh, lo, hi) = build(&s, &sets);
        assert_eq!(mesh.desc.vertex_count, 10);
        assert_eq!(mesh.read_indices().unwrap(), vec![0, 1, 2, 1, 3, 2, 2, 3, 4, 3, 5, 4, 6, 7, 8, 7, 9, 8]);
        let f = |name: &str| mesh.read_f32(name).unwrap();
        assert_eq!(f("side"), vec![-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0]);
        assert_eq!(f("param"), vec![0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0]);
        let r = std::f32::consts::FRAC_1_SQRT_2;
        let tangent = f("tangent");
        let expected = [[0.0, 1.0, 0.0], [r, r, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]];
        for (p, e) in expected.iter().enumerate() {
            for v in 0..2 {
                for k in 0..3 {
                    assert!((tangent[(2 * p + v) * 3 + k] - e[k]).abs() < 1e-6, "point {p}");
                }
            }
        }
        // Widths: (shading, opacity set) × own thickness / default × (1 − 0.5 × param).
        let width = f("width");
        let expected = [(0.1, 0.8), (0.075, 0.6), (0.05, 0.4), (0.2, 1.6), (0.1, 0.8)];
        for (p, (ws, wo)) in expected.iter().enumerate() {
            assert!((width[4 * p] - ws).abs() < 1e-6 && (width[4 * p + 1] - wo).abs() < 1e-6, "point {p}: {width:?}");
            assert_eq!(width[4 * p..4 * p + 2], width[4 * p + 2..4 * p + 4]);
        }
        assert_eq!(f("opacity")[..4], [0.5, 0.02, 0.5, 0.02]);
        assert_eq!(f("color")[..3], [0.3, 0.2, 0.1]);
        assert_eq!(f("position")[6..12], [0.0, 1.0, 0.0, 0.0, 1.0, 0.0]);
        // Bounds: the points grown by the widest half width (1.6 / 2).
        assert_eq!(lo, [-0.8, -0.8, -0.8]);
        assert_eq!(hi, [5.8, 1.8, 2.8]);
    }
}
