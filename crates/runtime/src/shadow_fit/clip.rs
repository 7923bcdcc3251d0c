//! What the camera sees: the view volume's clip-space tests, triangles clipped to it
//! (Sutherland–Hodgman), and whether a caster's shadow ray enters it (Liang–Barsky).

use glam::{Mat4, Vec3, Vec4};

use super::{MeshRef, Scratch, VisibleTest};

fn outcode(c: Vec4) -> u8 {
    (c.x < -c.w) as u8
        | ((c.x > c.w) as u8) << 1
        | ((c.y < -c.w) as u8) << 2
        | ((c.y > c.w) as u8) << 3
        | ((c.z < 0.0) as u8) << 4
        | ((c.z > c.w) as u8) << 5
}

/// Signed distance of a clip-space point to boundary plane `k` (≥ 0 inside).
pub(super) fn plane_distance(c: Vec4, k: usize) -> f32 {
    match k {
        0 => c.w + c.x,
        1 => c.w - c.x,
        2 => c.w + c.y,
        3 => c.w - c.y,
        4 => c.z,
        _ => c.w - c.z,
    }
}

/// Clips a polygon (clip-space and world-space corners together) against the view volume,
/// Sutherland–Hodgman, and appends the corners it creates on the boundary to `out`.
fn clip_polygon(mut poly: Vec<(Vec4, Vec3)>, out: &mut Vec<Vec3>) {
    for k in 0..6 {
        if poly.is_empty() {
            return;
        }
        let mut next = Vec::with_capacity(poly.len() + 2);
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let (da, db) = (plane_distance(a.0, k), plane_distance(b.0, k));
            if da >= 0.0 {
                next.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                let t = da / (da - db);
                next.push((a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t));
            }
        }
        poly = next;
    }
    out.extend(poly.into_iter().map(|(_, w)| w));
}

/// World positions of the geometry `camera_view_proj` sees: vertices inside the view volume,
/// and, with [`VisibleTest::ClippedTriangles`], the corners of every triangle crossing its boundary clipped
/// to it. Left in `scratch.points`.
pub fn visible_points(camera_view_proj: Mat4, meshes: &[MeshRef], test: VisibleTest, scratch: &mut Scratch) {
    let Scratch { clip, codes, points, .. } = scratch;
    points_inside(camera_view_proj, meshes, test, (clip, codes), points);
}

/// [`visible_points`] into `out`, with `buffers` for the clip-space corners and outcodes.
pub(super) fn points_inside(
    view_proj: Mat4,
    meshes: &[MeshRef],
    test: VisibleTest,
    (clip, codes): (&mut Vec<Vec4>, &mut Vec<u8>),
    out: &mut Vec<Vec3>,
) {
    out.clear();
    for mesh in meshes {
        let m = view_proj * mesh.world;
        clip.clear();
        codes.clear();
        for &p in mesh.positions {
            let c = m * p.extend(1.0);
            let code = outcode(c);
            clip.push(c);
            codes.push(code);
            if code == 0 {
                out.push(mesh.world.transform_point3(p));
            }
        }
        if test == VisibleTest::VerticesOnly {
            continue;
        }
        for tri in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
            let (Some(&ca), Some(&cb), Some(&cc)) = (codes.get(a), codes.get(b), codes.get(c)) else {
                continue; // an index out of range names no vertex
            };
            // Entirely inside (its corners are kept already) or entirely beyond one plane.
            if ca | cb | cc == 0 || ca & cb & cc != 0 {
                continue;
            }
            let corner = |i: usize| (clip[i], mesh.world.transform_point3(mesh.positions[i]));
            clip_polygon(vec![corner(a), corner(b), corner(c)], out);
        }
    }
}

/// Whether the shadow ray from `q` along `away` (unit), from just past `q` to `reach`, passes
/// through the box `[lo, hi]` inside the view volume of `view_proj`: only then can `q` shade
/// something the camera sees.
pub(super) fn shadow_enters(q: Vec3, away: Vec3, reach: f32, (lo, hi): (Vec3, Vec3), view_proj: Mat4) -> bool {
    let (mut t0, mut t1) = (1e-3 * reach.max(1e-3) / 4.0, reach);
    for axis in 0..3 {
        if away[axis].abs() < 1e-12 {
            if q[axis] < lo[axis] || q[axis] > hi[axis] {
                return false;
            }
            continue;
        }
        let (a, b) = ((lo[axis] - q[axis]) / away[axis], (hi[axis] - q[axis]) / away[axis]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    if t0 > t1 {
        return false;
    }
    // The segment left, clipped to the view volume in clip space (Liang–Barsky).
    let (c0, c1) = (view_proj * (q + away * t0).extend(1.0), view_proj * (q + away * t1).extend(1.0));
    let (mut s0, mut s1) = (0.0f32, 1.0f32);
    for k in 0..6 {
        let (d0, d1) = (plane_distance(c0, k), plane_distance(c1, k));
        if d0 < 0.0 && d1 < 0.0 {
            return false;
        }
        if d0 < 0.0 {
            s0 = s0.max(d0 / (d0 - d1));
        } else if d1 < 0.0 {
            s1 = s1.min(d0 / (d0 - d1));
        }
    }
    s0 <= s1
}
