//! Fixed-orientation ribbons for engines and tools that cannot widen strips in a shader: each
//! strand becomes a flat ribbon of the shading set's (tapered) width whose orientation follows
//! a minimum-twist (parallel-transport) frame along the strand, so it does not corkscrew.
//!
//! Built from a strands asset's records, so the `ribbons` job option and `hikage export --gltf`
//! of a strands asset give the same mesh. Streams, quantized as KHR_mesh_quantization allows
//! (36 bytes a vertex instead of 68 in floats):
//! - `position`: F32 × 3, exact (the ribbon is a fraction of a millimetre wide);
//! - `normal`: the ribbon's face, I8 × 3 normalized (padded to 4 bytes);
//! - `tangent`: the strand's direction and w = 1 (as glTF's `TANGENT` wants), I8 × 4 normalized;
//! - `uv`: 0 or 1 across, `param` along, U16 × 2 normalized;
//! - `color`: linear RGB and the shading opacity, U16 × 4 normalized (16 bits keep the records'
//!   sRGB 8-bit colours exact to 1/65535 in linear, dark hair included);
//! - `strand_id`: F32 × 1, exact up to 2²⁴ strands;
//!
//! and U32 triangle indices, 6 per segment. The normal and tangent are within 1/127 per
//! component (under half a degree) of the frame's; glTF export names the streams `POSITION`,
//! `NORMAL`, `TANGENT`, `TEXCOORD_0`, `COLOR_0` and `_STRAND_ID`.

use glam::Vec3;
use hikage_bundle::{ComponentType, MeshData, StrandPoint};

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
    let streams: [(&str, ComponentType, u8, &[f32]); 6] = [
        ("position", ComponentType::F32, 3, &position),
        ("normal", ComponentType::I8, 3, &normal),
        ("tangent", ComponentType::I8, 4, &tangent),
        ("uv", ComponentType::U16, 2, &uv),
        ("color", ComponentType::U16, 4, &color),
        ("strand_id", ComponentType::F32, 1, &strand_id),
    ];
    for (name, component, c, v) in streams {
        match component {
            ComponentType::F32 => mesh.push_f32(name, c, v),
            _ => mesh.push_normalized(name, component, c, v),
        }
        .expect("sizes follow the vertex count");
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
        // The quantized streams against the frame: the tangent within half an 8-bit step (and
        // the records' 16-bit octahedral rounding), w = 1; the normal across both the strand and
        // the ribbon; `uv` 0 or 1 across and the point's place along within half a 16-bit step.
        let (normal, tangent, uv) = (
            mesh.read_normalized("normal").unwrap(),
            mesh.read_normalized("tangent").unwrap(),
            mesh.read_normalized("uv").unwrap(),
        );
        for v in 0..80 {
            let p = v / 2;
            let t = strips::tangent(&s.points, 0, 40, p);
            let got = Vec3::from_slice(&tangent[4 * v..]);
            assert!((got - t).abs().max_element() <= 0.5 / 127.0 + 1e-3, "tangent {got} against {t} at {v}");
            assert_eq!(tangent[4 * v + 3], 1.0);
            let side = (Vec3::from_slice(&pos[6 * p + 3..]) - Vec3::from_slice(&pos[6 * p..])).normalize();
            let face = Vec3::from_slice(&normal[3 * v..]);
            assert!(face.dot(t).abs() < 0.02 && face.dot(side).abs() < 0.02, "normal {face} at {v}");
            assert!((face.length() - 1.0).abs() < 0.02, "normal {face} at {v}");
            assert_eq!(uv[2 * v], (v % 2) as f32);
            assert!((uv[2 * v + 1] - p as f32 / 39.0).abs() <= 0.5 / 65535.0 + 1e-7);
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
