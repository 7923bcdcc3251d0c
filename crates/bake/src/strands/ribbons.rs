//! Fixed-orientation ribbons for engines and tools that cannot widen strips in a shader: each
//! strand becomes a flat ribbon of the shading set's (tapered) width whose orientation follows
//! a minimum-twist (parallel-transport) frame along the strand, so it does not corkscrew.
//!
//! Built from a strands asset's records, so the `ribbons` job option and `hikage export --gltf`
//! of a strands asset give the same mesh. Streams: `position` (3), `normal` (3, the ribbon's
//! face), `tangent` (4: the strand's direction, w = 1, as glTF's `TANGENT` wants), `uv` (2:
//! 0 or 1 across, `param` along), `color` (4: linear RGB and the shading opacity), `strand_id`
//! (1, exact up to 2²⁴ strands); U32 triangle indices, 6 per segment. glTF export names them
//! `POSITION`, `NORMAL`, `TANGENT`, `TEXCOORD_0`, `COLOR_0` and `_STRAND_ID`.

use glam::Vec3;
use hikage_bundle::{MeshData, StrandPoint};

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

/// The ribbon mesh of strand records (in record order, each strand's points consecutive from
/// index 0), tapered by `taper`.
pub fn build(points: &[StrandPoint], taper: f32) -> MeshData {
    let n = points.len();
    let (mut position, mut normal, mut tangent, mut uv, mut color, mut strand_id) = (
        Vec::with_capacity(6 * n),
        Vec::with_capacity(6 * n),
        Vec::with_capacity(8 * n),
        Vec::with_capacity(4 * n),
        Vec::with_capacity(8 * n),
        Vec::with_capacity(2 * n),
    );
    let mut indices = Vec::with_capacity(6 * n);
    let mut across = Vec3::X;
    for (i, p) in points.iter().enumerate() {
        let t = Vec3::from(p.tangent);
        if p.index == 0 {
            across = any_across(t);
        }
        // Parallel transport: the previous side vector with its component along the new
        // tangent removed (the smallest rotation that keeps it across the strand).
        across = unit(across - t * across.dot(t)).unwrap_or_else(|| any_across(t));
        let param = p.param();
        let w = p.width * (1.0 - taper * param);
        let face = unit(t.cross(across)).unwrap_or(Vec3::Z);
        for side in [0.0f32, 1.0] {
            position.extend((Vec3::from(p.position) + across * w * (side - 0.5)).to_array());
            normal.extend(face.to_array());
            tangent.extend(t.extend(1.0).to_array());
            uv.extend([side, param]);
            color.extend([p.color[0], p.color[1], p.color[2], p.alpha]);
            strand_id.push(p.strand_id as f32);
        }
        if p.index < p.segments && i + 1 < n {
            let v = 2 * i as u32;
            indices.extend([v, v + 1, v + 2, v + 1, v + 3, v + 2]);
        }
    }
    let mut mesh = MeshData::new(2 * n as u32);
    let streams: [(&str, u8, &[f32]); 6] = [
        ("position", 3, &position),
        ("normal", 3, &normal),
        ("tangent", 4, &tangent),
        ("uv", 2, &uv),
        ("color", 4, &color),
        ("strand_id", 1, &strand_id),
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
    use crate::strands::Strands;
    use crate::strands::strips::{self, StripSets};

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
        let strips = strips::build(&s, &sets);
        let records: Vec<StrandPoint> =
            strips.mesh.bytes.chunks_exact(32).map(|r| StrandPoint::decode(r, strips.max_width)).collect();
        let mesh = build(&records, 0.0);
        let pos = mesh.read_f32("position").unwrap();
        let mut previous: Option<Vec3> = None;
        for p in 0..40 {
            let side = Vec3::from_slice(&pos[6 * p + 3..]) - Vec3::from_slice(&pos[6 * p..]);
            assert!((side.length() - 0.02).abs() < 1e-6);
            let across = side.normalize();
            let t = strips::tangent(&s.points, 0, 40, p);
            assert!(across.dot(t).abs() < 1e-3, "side not across the strand at {p}");
            if let Some(prev) = previous {
                // Consecutive sides differ by at most the tangent's turn (0.3 rad per step here).
                assert!(across.dot(prev) > 0.3f32.cos() - 1e-3, "twist at {p}");
            }
            previous = Some(across);
        }
        assert_eq!(mesh.read_indices().unwrap().len(), 39 * 6);
        // Every triangle has area: the strips are not degenerate.
        let idx = mesh.read_indices().unwrap();
        for tri in idx.chunks_exact(3) {
            let v = |k: usize| Vec3::from_slice(&pos[3 * tri[k] as usize..]);
            assert!((v(1) - v(0)).cross(v(2) - v(0)).length() > 1e-5);
        }
    }
}
