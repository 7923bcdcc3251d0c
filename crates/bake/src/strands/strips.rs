//! Strands → strip records (seed 004): one 32-byte record per point ([`StrandPoint`]) that the
//! runtime draws as one instanced quad per segment, widened in the vertex shader into a
//! view-facing strip. The records carry the thin **shading** set's width and opacity per point;
//! the wide, faint **opacity** set drawn into the opacity maps is the same strips scaled by the
//! sets' ratios, so both sets share everything else.
//!
//! Each strand keeps its own width and opacity: the set values are those of a strand with the
//! source's default thickness and transparency, scaled per point by the point's own values.
//! Strands are stored in a fixed pseudo-random order, so the first half of them is an even
//! thinning of the whole — what a level of detail draws. Written straight into the payload
//! bytes in parallel, in fixed chunks (byte-identical at any thread count).

use glam::Vec3;
use hikage_bundle::{MeshData, StrandPoint, StrandsSettings, strands_desc};
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

/// The most levels of detail a strip mesh lists (the last draws 1/128 of the strands).
pub const MAX_LEVELS: usize = 8;

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

/// The order strands are stored in: sorted by a hash of their index, so every prefix is an
/// even thinning (SplitMix64, fixed: the same file gives the same order everywhere).
pub fn storage_order(strands: usize) -> Vec<u32> {
    let mix = |i: u64| {
        let mut z = i.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    let mut order: Vec<u32> = (0..strands as u32).collect();
    order.sort_by_key(|&i| (mix(i as u64), i));
    order
}

/// The levels of detail of strands stored in `order`: level `l` draws the first
/// ⌈strands / 2^l⌉ of them; `[strands, points]` per level while a level still drops strands.
pub fn levels(s: &Strands, order: &[u32]) -> Vec<[u32; 2]> {
    // Points of the first k stored strands.
    let mut prefix = Vec::with_capacity(order.len() + 1);
    prefix.push(0u64);
    for &src in order {
        prefix.push(prefix.last().expect("starts with 0") + s.segments[src as usize] as u64 + 1);
    }
    let mut out: Vec<[u32; 2]> = Vec::new();
    for level in 0..MAX_LEVELS {
        let kept = order.len().div_ceil(1 << level);
        if level > 0 && out.last().is_some_and(|l| l[0] as usize == kept) {
            break;
        }
        out.push([kept as u32, prefix[kept] as u32]);
    }
    out
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

/// `v / |v|`, or `fallback` for a zero vector.
pub(crate) fn unit_or(v: Vec3, fallback: Vec3) -> Vec3 {
    let l = v.length();
    if l > 0.0 { v / l } else { fallback }
}

/// A strands asset's payload and what its settings record of it.
#[derive(Clone, Debug, PartialEq)]
pub struct StripMesh {
    /// The records, in storage order.
    pub mesh: MeshData,
    /// The box around every strip of the wider set: lower corner.
    pub bounds_min: [f32; 3],
    /// Upper corner.
    pub bounds_max: [f32; 3],
    /// The widest shading width of any point before taper.
    pub max_width: f32,
    /// Levels of detail ([`levels`]).
    pub levels: Vec<[u32; 2]>,
    /// Σ over segments of length × shading width (tapered) × shading opacity, both the mean of
    /// the segment's ends.
    pub opacity_area: f32,
}

impl StripMesh {
    /// The manifest settings of these strips, baked from `s` with `sets` (and `auto`'s
    /// opacity-map resolution when it chose them).
    pub fn settings(&self, s: &Strands, sets: &StripSets, auto: Option<u32>) -> StrandsSettings {
        StrandsSettings {
            strands: s.segments.len() as u32,
            points: s.points.len() as u32,
            shading: sets.shading,
            opacity: sets.opacity,
            taper: sets.taper,
            auto_resolution: auto,
            bounds_min: self.bounds_min,
            bounds_max: self.bounds_max,
            max_width: self.max_width,
            levels: self.levels.clone(),
            opacity_area: self.opacity_area,
        }
    }
}

/// The strip records of `s` with `sets`.
pub fn build(s: &Strands, sets: &StripSets) -> StripMesh {
    let starts = strand_starts(s);
    let order = storage_order(s.segments.len());
    let n = s.points.len();
    let (thick_ref, alpha_ref) = (s.default_thickness, 1.0 - s.default_transparency);
    let ratio = |v: f32, r: f32| if r > 0.0 { v / r } else { 1.0 };
    let thickness = |p: usize| ratio(s.thickness.as_ref().map_or(thick_ref, |t| t[p]), thick_ref);
    let width = |p: usize| sets.shading.0 * thickness(p);
    let alpha = |p: usize| {
        let own = 1.0 - s.transparency.as_ref().map_or(s.default_transparency, |t| t[p]);
        (sets.shading.1 * ratio(own, alpha_ref)).clamp(0.0, 1.0)
    };
    let max_width = (0..n).into_par_iter().with_min_len(CHUNK).map(width).reduce(|| 0.0, f32::max);
    // Storage order: strand k of the payload is source strand order[k], starting at point
    // out_starts[k].
    let mut out_starts = Vec::with_capacity(order.len() + 1);
    let mut at = 0usize;
    for &src in &order {
        out_starts.push(at);
        at += s.segments[src as usize] as usize + 1;
    }
    out_starts.push(at);
    let desc = strands_desc(n as u32);
    let record = hikage_bundle::STRANDS_RECORD_BYTES as usize;
    let mut bytes = vec![0u8; n * record];
    bytes.par_chunks_mut(CHUNK * record).enumerate().for_each(|(chunk, out)| {
        let first = chunk * CHUNK;
        let count = out.len() / record;
        let mut records = out.chunks_exact_mut(record);
        for_points(&out_starts, first, count, |q, k| {
            let src = order[k] as usize;
            let (a, b) = (starts[src], starts[src + 1]);
            let p = a + (q - out_starts[k]);
            let point = StrandPoint {
                position: s.points[p],
                tangent: tangent(&s.points, a, b, p).to_array(),
                width: width(p),
                alpha: alpha(p),
                color: s.color.as_ref().map_or(s.default_color, |c| c[p]),
                index: (p - a) as u16,
                segments: s.segments[src],
                strand_id: src as u32,
            };
            records.next().expect("one record per point").copy_from_slice(&point.encode(max_width));
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
                half = half.max(0.5 * sets.shading.0.max(sets.opacity.0) * thickness(chunk * CHUNK + i));
            }
            (lo, hi, half)
        })
        .reduce(
            || ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3], 0.0),
            |a, b| {
                (std::array::from_fn(|k| a.0[k].min(b.0[k])), std::array::from_fn(|k| a.1[k].max(b.1[k])), a.2.max(b.2))
            },
        );
    // Summed per fixed chunk, then in order: the same total at any thread count.
    let chunk_areas: Vec<f64> = (0..n)
        .collect::<Vec<usize>>()
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut area = 0.0f64;
            for_points(&starts, chunk[0], chunk.len(), |p, strand| {
                let (a, b) = (starts[strand], starts[strand + 1]);
                if p + 1 < b {
                    let param = |q: usize| (q - a) as f32 / (b - a - 1) as f32;
                    let w = |q: usize| width(q) * (1.0 - sets.taper * param(q));
                    let len = (Vec3::from(s.points[p + 1]) - Vec3::from(s.points[p])).length();
                    area += (len * 0.5 * (w(p) + w(p + 1)) * 0.5 * (alpha(p) + alpha(p + 1))) as f64;
                }
            });
            area
        })
        .collect();
    StripMesh {
        opacity_area: chunk_areas.iter().sum::<f64>() as f32,
        mesh: MeshData { desc, bytes },
        bounds_min: lo.map(|x| x - half),
        bounds_max: hi.map(|x| x + half),
        max_width,
        levels: levels(s, &order),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hikage_bundle::read_strand_points;

    fn two_strands() -> Strands {
        Strands {
            segments: vec![2, 1],
            points: vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [5.0, 0.0, 0.0], [5.0, 0.0, 2.0]],
            thickness: Some(vec![0.1, 0.1, 0.1, 0.2, 0.2]),
            transparency: Some(vec![0.5, 0.5, 0.5, 0.75, 0.75]),
            color: None,
            default_thickness: 0.1,
            default_transparency: 0.5,
            default_color: [0.3, 0.2, 0.1],
        }
    }

    /// Every field of the records of a 3-point and a 2-point strand, computed by hand, in the
    /// stored order.
    #[test]
    fn hand_computed_records() {
        let s = two_strands();
        let sets = StripSets { shading: (0.1, 0.5), opacity: (0.8, 0.02), taper: 0.5 };
        let strips = build(&s, &sets);
        assert_eq!(strips.mesh.desc.vertex_count, 5);
        assert_eq!(strips.mesh.bytes.len(), 5 * 32);
        assert!(strips.mesh.desc.indices.is_none());
        // The second strand is twice as thick: the widest shading width is 0.2.
        assert_eq!(strips.max_width, 0.2);
        let points = read_strand_points(&strips.mesh, &strips.settings(&s, &sets, None)).unwrap();
        let r = std::f32::consts::FRAC_1_SQRT_2;
        // Per source point: tangent, shading width, shading opacity (own opacity / default
        // × 0.5), index, segments.
        let expected: [([f32; 3], f32, f32, u16, u16); 5] = [
            ([0.0, 1.0, 0.0], 0.1, 0.5, 0, 2),
            ([r, r, 0.0], 0.1, 0.5, 1, 2),
            ([1.0, 0.0, 0.0], 0.1, 0.5, 2, 2),
            ([0.0, 0.0, 1.0], 0.2, 0.25, 0, 1),
            ([0.0, 0.0, 1.0], 0.2, 0.25, 1, 1),
        ];
        let order = storage_order(2);
        let mut q = 0;
        for &src in &order {
            let first = [0, 3][src as usize];
            for i in 0..=s.segments[src as usize] as usize {
                let (p, e) = (&points[q], expected[first + i]);
                assert_eq!(p.position, s.points[first + i]);
                assert!((0..3).all(|k| (p.tangent[k] - e.0[k]).abs() < 1e-4), "point {q}: {:?}", p.tangent);
                assert!((p.width - e.1).abs() < 1e-5 && (p.alpha - e.2).abs() < 1e-4, "point {q}: {p:?}");
                assert_eq!((p.index, p.segments, p.strand_id), (e.3, e.4, src));
                assert!((p.color[0] - 0.3).abs() < 3e-3 && (p.color[2] - 0.1).abs() < 2e-3);
                q += 1;
            }
        }
        // Levels: both strands, then the first stored one.
        let first_points = s.segments[order[0] as usize] as u32 + 1;
        assert_eq!(strips.levels, vec![[2, 5], [1, first_points]]);
        // Opacity-weighted area: 1 × (0.1 + 0.075)/2 × 0.5 + 1 × (0.075 + 0.05)/2 × 0.5 for the
        // first strand (tapered by half at the tip), 2 × (0.2 + 0.1)/2 × 0.25 for the second.
        assert!((strips.opacity_area - 0.15).abs() < 1e-6, "{}", strips.opacity_area);
        // Bounds: the points grown by the widest half width (0.8 × 2 / 2).
        assert_eq!(strips.bounds_min, [-0.8, -0.8, -0.8]);
        assert_eq!(strips.bounds_max, [5.8, 1.8, 2.8]);
    }

    /// Each level keeps about half the strands of the one before, and the storage order is a
    /// permutation that mixes the source order.
    #[test]
    fn levels_halve_and_the_order_is_a_permutation() {
        let n = 1000;
        let order = storage_order(n);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..n as u32).collect::<Vec<_>>());
        // The first half holds strands from all over the source: each tenth of it has 30–70.
        for tenth in 0..10 {
            let count = order[..n / 2].iter().filter(|&&i| i as usize * 10 / n == tenth).count();
            assert!((30..=70).contains(&count), "tenth {tenth}: {count}");
        }
        let s = Strands { segments: (0..n).map(|i| (i % 7) as u16).collect(), ..two_strands() };
        let levels = levels(&s, &order);
        assert_eq!(levels.len(), MAX_LEVELS);
        for (l, w) in levels.iter().enumerate() {
            assert_eq!(w[0] as usize, n.div_ceil(1 << l));
            let points: u32 = order[..w[0] as usize].iter().map(|&i| s.segments[i as usize] as u32 + 1).sum();
            assert_eq!(w[1], points);
        }
    }
}
