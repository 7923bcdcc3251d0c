//! Fixed-orientation ribbons for engines that cannot expand strips in a shader: each strand
//! becomes a flat ribbon of the shading set's width whose orientation follows a minimum-twist
//! (parallel-transport) frame along the strand, so it does not corkscrew.
//!
//! Streams: `position` (3), `normal` (3, the ribbon's face normal), `param` (1), `width` (1, the
//! shading width at the point), `opacity` (1, the shading opacity), `color` (3); U32 triangle
//! indices, 6 per segment. `hikage export --gltf` writes them as glTF `POSITION`, `NORMAL`,
//! `COLOR_0`, `_PARAM`, `_WIDTH` and `_OPACITY`.

use glam::Vec3;
use hikage_bundle::MeshData;

use super::Strands;
use super::strips::{StripSets, strand_starts, tangent};

/// `v / |v|`, or `None` when `v` is shorter than 1e-12.
fn unit(v: Vec3) -> Option<Vec3> {
    let l = v.length();
    (l > 1e-12).then(|| v / l)
}

/// A unit vector across `t`.
fn any_across(t: Vec3) -> Vec3 {
    let helper = if t.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
    unit(t.cross(helper)).unwrap_or(Vec3::X)
}

/// The ribbon mesh.
pub fn build(s: &Strands, sets: &StripSets) -> MeshData {
    let starts = strand_starts(s);
    let n = s.points.len();
    let (mut position, mut normal, mut param, mut width, mut opacity, mut color) = (
        Vec::with_capacity(6 * n),
        Vec::with_capacity(6 * n),
        Vec::with_capacity(2 * n),
        Vec::with_capacity(2 * n),
        Vec::with_capacity(2 * n),
        Vec::with_capacity(6 * n),
    );
    let mut indices = Vec::with_capacity(6 * n);
    let thick_ref = s.default_thickness;
    let alpha_ref = 1.0 - s.default_transparency;
    for strand in 0..s.segments.len() {
        let (a, b) = (starts[strand], starts[strand + 1]);
        let mut across = any_across(tangent(&s.points, a, b, a));
        for p in a..b {
            let t = tangent(&s.points, a, b, p);
            // Parallel transport: the previous side vector with its component along the new
            // tangent removed (the smallest rotation that keeps it across the strand).
            across = unit(across - t * across.dot(t)).unwrap_or_else(|| any_across(t));
            let u = if b - a > 1 { (p - a) as f32 / (b - a - 1) as f32 } else { 0.0 };
            let k = if thick_ref > 0.0 { s.thickness.as_ref().map_or(thick_ref, |x| x[p]) / thick_ref } else { 1.0 };
            let w = sets.shading.0 * k * (1.0 - sets.taper * u);
            let alpha_k = if alpha_ref > 0.0 {
                (1.0 - s.transparency.as_ref().map_or(s.default_transparency, |x| x[p])) / alpha_ref
            } else {
                1.0
            };
            let face = unit(t.cross(across)).unwrap_or(Vec3::Z);
            let c = s.color.as_ref().map_or(s.default_color, |x| x[p]);
            for side in [-0.5f32, 0.5] {
                position.extend((Vec3::from(s.points[p]) + across * w * side).to_array());
                normal.extend(face.to_array());
                param.push(u);
                width.push(w);
                opacity.push((sets.shading.1 * alpha_k).clamp(0.0, 1.0));
                color.extend(c);
            }
            if p + 1 < b {
                let v = 2 * p as u32;
                indices.extend([v, v + 1, v + 2, v + 1, v + 3, v + 2]);
            }
        }
    }
    let mut mesh = MeshData::new(2 * n as u32);
    let streams: [(&str, u8, &[f32]); 6] = [
        ("position", 3, &position),
        ("normal", 3, &normal),
        ("param", 1, &param),
        ("width", 1, &width),
        ("opacity", 1, &opacity),
        ("color", 3, &color),
    ];
    for (name, c, v) in streams {
        mesh.push_f32(name, c, v).expect("sizes follow the vertex count");
    }
    mesh.set_indices(&indices).expect("indices stay below the vertex count");
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A helix: the side vectors stay across the strand, unit, and turn only as much as the
    /// tangent does (no twist added), and the ribbon's width is the shading width.
    #[test]
    fn minimum_twist_frames_follow_a_helix() {
        let points: Vec<[f32; 3]> =
            (0..40).map(|i| [(i as f32 * 0.3).cos(), i as f32 * 0.1, (i as f32 * 0.3).sin()]).collect();
        let s = Strands {
            segments: vec![39],
            points,
            thickness: None,
            transparency: None,
            color: None,
            default_thickness: 0.02,
            default_transparency: 0.5,
            default_color: [1.0; 3],
        };
        let sets = StripSets { shading: (0.02, 0.5), opacity: (0.2, 0.05), taper: 0.0 };
        let mesh = build(&s, &sets);
        let pos = mesh.read_f32("position").unwrap();
        let mut previous: Option<Vec3> = None;
        for p in 0..40 {
            let side = Vec3::from_slice(&pos[6 * p + 3..]) - Vec3::from_slice(&pos[6 * p..]);
            assert!((side.length() - 0.02).abs() < 1e-6);
            let across = side.normalize();
            let t = tangent(&s.points, 0, 40, p);
            assert!(across.dot(t).abs() < 1e-4, "side not across the strand at {p}");
            if let Some(prev) = previous {
                // Consecutive sides differ by at most the tangent's turn (0.3 rad per step here).
                assert!(across.dot(prev) > 0.3f32.cos() - 1e-3, "twist at {p}");
            }
            previous = Some(across);
        }
        assert_eq!(mesh.read_indices().unwrap().len(), 39 * 6);
    }
}
