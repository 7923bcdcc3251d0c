//! A generated skinned character for hair bound to a scalp: a head on a neck, two joints, a
//! skinned GLB written here, hair rooted on the mesh's own triangles, and a looping animation
//! in which the head turns and nods.

use glam::{Mat4, Vec3};
use hikage_bake::strands::Strands;
use serde_json::json;

use super::noise::hash01;

/// Half-axes of the head ellipsoid (x across, y up, z forward), centimetres.
const HEAD: Vec3 = Vec3::new(8.0, 10.5, 9.5);
/// Centre of the head ellipsoid in the bind pose.
const HEAD_CENTRE: Vec3 = Vec3::new(0.0, 14.0, 0.0);
/// Where the head joint sits (the neck joint is at the origin).
const HEAD_JOINT: Vec3 = Vec3::new(0.0, 6.0, 0.0);

/// The character in its bind pose.
#[derive(Clone, Debug)]
pub struct Character {
    /// The skinned mesh as a binary glTF: one node with the mesh and a skin of two joints,
    /// `neck` (at the origin) and `head` (6 cm above), with their inverse bind matrices.
    pub glb: Vec<u8>,
    /// Vertex positions of the mesh (bind pose).
    pub positions: Vec<[f32; 3]>,
    /// Per vertex: the weights of `neck` and `head`.
    pub weights: Vec<[f32; 2]>,
    /// Triangles over the vertices.
    pub triangles: Vec<[u32; 3]>,
    /// Hair whose roots lie on the mesh's triangles (top, sides and back of the head, and the
    /// nape, where the two joints blend).
    pub hair: Strands,
    /// Per strand: the triangle its root was placed on and the root's barycentric weights.
    pub roots: Vec<(u32, [f32; 3])>,
}

/// The joint matrices (joint's world matrix × its inverse bind matrix, `neck` then `head`) at
/// `t` of the loop (0–1, periodic): the neck turns ±40° about y once a loop and the head nods
/// ±25° about x twice, as a game's animation would hand them to the skin.
pub fn pose(t: f32) -> [Mat4; 2] {
    let tau = std::f32::consts::TAU;
    let neck = Mat4::from_rotation_y(40f32.to_radians() * (tau * t).sin());
    let head =
        neck * Mat4::from_translation(HEAD_JOINT) * Mat4::from_rotation_x(25f32.to_radians() * (2.0 * tau * t).sin());
    [neck, head * Mat4::from_translation(-HEAD_JOINT)]
}

/// The character with `strands` strands of `points` points each (deterministic in `seed`).
pub fn character(strands: u32, points: u16, seed: u32) -> Character {
    let (segments, rings) = (48u32, 32u32);
    let (mut positions, mut weights, mut triangles) = (Vec::new(), Vec::new(), Vec::new());
    let pi = std::f32::consts::PI;
    for r in 0..=rings {
        let theta = pi * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = std::f32::consts::TAU * (s % segments) as f32 / segments as f32;
            let (st, ct) = theta.sin_cos();
            let p = HEAD_CENTRE + HEAD * Vec3::new(st * phi.sin(), ct, st * phi.cos());
            let w = smoothstep(6.0, 14.0, p.y);
            positions.push(p.to_array());
            weights.push([1.0 - w, w]);
        }
    }
    let at = |r: u32, s: u32| r * (segments + 1) + s;
    for r in 0..rings {
        for s in 0..segments {
            // Counter-clockwise seen from outside; no triangle at the poles' collapsed edges.
            if r > 0 {
                triangles.push([at(r, s), at(r + 1, s), at(r, s + 1)]);
            }
            if r + 1 < rings {
                triangles.push([at(r, s + 1), at(r + 1, s), at(r + 1, s + 1)]);
            }
        }
    }
    let (hair, roots) = grow(&positions, &triangles, strands, points, seed);
    let glb = glb(&positions, &weights, &triangles);
    Character { glb, positions, weights, triangles, hair, roots }
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Strands rooted at random points of the scalp's triangles: out along the face normal, then
/// down under gravity, 12–18 cm long.
fn grow(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    count: u32,
    points: u16,
    seed: u32,
) -> (Strands, Vec<(u32, [f32; 3])>) {
    let corner = |v: u32| Vec3::from(positions[v as usize]);
    // Scalp triangles: above the ears, or behind them down to the nape; never the face.
    let scalp: Vec<(usize, &[u32; 3])> = triangles
        .iter()
        .enumerate()
        .filter(|(_, t)| {
            let c = (corner(t[0]) + corner(t[1]) + corner(t[2])) / 3.0 - HEAD_CENTRE;
            (c.y > 2.0 || (c.z < -2.0 && c.y > -5.0)) && !(c.z > 4.0 && c.y < 6.0)
        })
        .collect();
    let mut roots = Vec::with_capacity(count as usize);
    let segments = points.saturating_sub(1).max(1);
    let mut out = Strands {
        segments: Vec::with_capacity(count as usize),
        points: Vec::with_capacity(count as usize * (segments as usize + 1)),
        thickness: None,
        transparency: None,
        color: None,
        default_thickness: 0.03,
        default_transparency: 0.5,
        default_color: [0.35, 0.22, 0.12],
    };
    for s in 0..count as i32 {
        let rnd = |k: i32| hash01(s, k, seed);
        let (index, t) = scalp[((rnd(0) * scalp.len() as f32) as usize).min(scalp.len() - 1)];
        let (mut u, mut v) = (rnd(1), rnd(2));
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        roots.push((index as u32, [1.0 - u - v, u, v]));
        let [a, b, c] = t.map(corner);
        let root = a * (1.0 - u - v) + b * u + c * v;
        let normal = (b - a).cross(c - a).normalize();
        let length = 12.0 + 6.0 * rnd(3);
        let step = length / segments as f32;
        let mut p = root;
        out.segments.push(segments);
        out.points.push(p.to_array());
        for i in 1..=segments {
            let f = i as f32 / segments as f32;
            let sway = Vec3::new(rnd(4) - 0.5, 0.0, rnd(5) - 0.5) * 0.6;
            let dir = (normal * 2.0 * (1.0 - f) + Vec3::new(0.0, -1.6, 0.0) * f + sway).normalize();
            p += dir * step;
            out.points.push(p.to_array());
        }
    }
    (out, roots)
}

/// The skinned GLB: positions, JOINTS_0 (u8), WEIGHTS_0 (f32), indices, two joint nodes and a
/// skin with its inverse bind matrices.
fn glb(positions: &[[f32; 3]], weights: &[[f32; 2]], triangles: &[[u32; 3]]) -> Vec<u8> {
    let mut bin = Vec::new();
    let mut views = Vec::new();
    let mut view = |bin: &mut Vec<u8>, data: &[u8]| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": data.len() }));
        bin.extend_from_slice(data);
        views.len() - 1
    };
    let f32s = |v: &mut dyn Iterator<Item = f32>| v.flat_map(f32::to_le_bytes).collect::<Vec<u8>>();
    let pos = view(&mut bin, &f32s(&mut positions.iter().flatten().copied()));
    let joints = view(&mut bin, &positions.iter().flat_map(|_| [0u8, 1, 0, 0]).collect::<Vec<u8>>());
    let w = view(&mut bin, &f32s(&mut weights.iter().flat_map(|w| [w[0], w[1], 0.0, 0.0])));
    let ix = view(&mut bin, &triangles.iter().flatten().flat_map(|i| i.to_le_bytes()).collect::<Vec<u8>>());
    let inverse = [Mat4::IDENTITY, Mat4::from_translation(-HEAD_JOINT)];
    let ibm = view(&mut bin, &f32s(&mut inverse.iter().flat_map(|m| m.to_cols_array())));
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in positions {
        for k in 0..3 {
            (lo[k], hi[k]) = (lo[k].min(p[k]), hi[k].max(p[k]));
        }
    }
    let n = positions.len();
    let doc = json!({
        "asset": { "version": "2.0", "generator": "hikage_devkit::synth::character" },
        "scene": 0,
        "scenes": [{ "nodes": [0, 1] }],
        "nodes": [
            { "name": "character", "mesh": 0, "skin": 0 },
            { "name": "neck", "children": [2] },
            { "name": "head", "translation": HEAD_JOINT.to_array() },
        ],
        "skins": [{ "joints": [1, 2], "inverseBindMatrices": 4, "skeleton": 1 }],
        "meshes": [{ "primitives": [{
            "attributes": { "POSITION": 0, "JOINTS_0": 1, "WEIGHTS_0": 2 },
            "indices": 3,
            "mode": 4,
        }] }],
        "buffers": [{ "byteLength": bin.len() }],
        "bufferViews": views,
        "accessors": [
            { "bufferView": pos, "componentType": 5126, "count": n, "type": "VEC3", "min": lo, "max": hi },
            { "bufferView": joints, "componentType": 5121, "count": n, "type": "VEC4" },
            { "bufferView": w, "componentType": 5126, "count": n, "type": "VEC4" },
            { "bufferView": ix, "componentType": 5125, "count": triangles.len() * 3, "type": "SCALAR" },
            { "bufferView": ibm, "componentType": 5126, "count": 2, "type": "MAT4" },
        ],
    });
    let mut text = serde_json::to_vec(&doc).expect("plain JSON");
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    for word in [0x4654_6C67u32, 2, total as u32, text.len() as u32, 0x4E4F_534A] {
        out.extend_from_slice(&word.to_le_bytes());
    }
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}
