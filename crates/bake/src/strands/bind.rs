//! Binding strands to a skinned scalp: each root to the nearest point of the scalp's triangles,
//! kept as the triangle and two barycentric weights (8 bytes a strand), and the scalp cut down to
//! the triangles a root is bound to.
//!
//! The nearest triangle is found in a uniform grid of the triangles' boxes, searched in rings of
//! cells around the root until no unsearched cell can hold a nearer point; ties go to the lower
//! triangle index, so the result does not depend on the thread count.

use glam::DVec3;
use hikage_bundle::{Scalp, StrandBinding};
use rayon::prelude::*;

use super::Strands;
use super::strips::strand_starts;
use crate::mesh::gltf::SkinnedMesh;

/// The strands bound to a scalp.
#[derive(Clone, Debug, PartialEq)]
pub struct Bound {
    /// One binding per strand, in strand order.
    pub bindings: Vec<StrandBinding>,
    /// The triangles bound to, with their vertices, joints, weights and reach.
    pub scalp: Scalp,
    /// The farthest any root lies from its bound point.
    pub max_distance: f32,
}

/// A root's nearest scalp point: the triangle, its barycentric weights, the distance.
type Nearest = (u32, [f64; 3], f64);

/// A root that lies too far from the scalp.
#[derive(Clone, Debug, PartialEq)]
pub struct TooFar {
    /// The strand (source order).
    pub strand: usize,
    /// Its root's distance to the nearest scalp point, or `None` when no triangle lies within
    /// the limit at all.
    pub distance: Option<f64>,
}

/// Binds every strand of `s` to `mesh`: its root to the nearest point of a non-degenerate
/// triangle, which must lie within `max_distance`. `pad` is added to every strand's reach (the
/// widest half strip width).
pub fn bind(s: &Strands, mesh: &SkinnedMesh, max_distance: f64, pad: f32) -> Result<Bound, TooFar> {
    let grid = Grid::new(mesh);
    let starts = strand_starts(s);
    let found: Vec<Result<Nearest, TooFar>> = (0..s.segments.len())
        .into_par_iter()
        .map(|strand| {
            let root = DVec3::from(s.points[starts[strand]].map(f64::from));
            match grid.nearest(mesh, root, max_distance) {
                Some((t, bary, d)) if d <= max_distance => Ok((t, bary, d)),
                Some((_, _, d)) => Err(TooFar { strand, distance: Some(d) }),
                None => Err(TooFar { strand, distance: None }),
            }
        })
        .collect();
    let found = found.into_iter().collect::<Result<Vec<_>, _>>()?;
    // Keep the triangles and vertices bound to, in source order.
    let mut used_triangles: Vec<u32> = found.iter().map(|f| f.0).collect();
    used_triangles.sort_unstable();
    used_triangles.dedup();
    let mut used_vertices: Vec<u32> = used_triangles.iter().flat_map(|&t| mesh.triangles[t as usize]).collect();
    used_vertices.sort_unstable();
    used_vertices.dedup();
    let vertex_of = |v: u32| used_vertices.binary_search(&v).expect("kept above") as u32;
    let triangle_of = |t: u32| used_triangles.binary_search(&t).expect("kept above") as u32;
    let mut reach = vec![0.0f32; used_vertices.len()];
    let mut max_root = 0.0f64;
    let mut bindings = Vec::with_capacity(found.len());
    for (strand, &(t, bary, d)) in found.iter().enumerate() {
        let tri = mesh.triangles[t as usize];
        let corner = |k: usize| DVec3::from(mesh.positions[tri[k] as usize].map(f64::from));
        let surface = corner(0) * bary[0] + corner(1) * bary[1] + corner(2) * bary[2];
        let far = s.points[starts[strand]..starts[strand + 1]]
            .iter()
            .map(|p| (DVec3::from(p.map(f64::from)) - surface).length())
            .fold(0.0f64, f64::max);
        for &v in &tri {
            let r = &mut reach[vertex_of(v) as usize];
            *r = r.max(far as f32 + pad);
        }
        max_root = max_root.max(d);
        bindings.push(StrandBinding { triangle: triangle_of(t), barycentric: [bary[1] as f32, bary[2] as f32] });
    }
    let scalp = Scalp {
        positions: used_vertices.iter().map(|&v| mesh.positions[v as usize]).collect(),
        joints: used_vertices.iter().map(|&v| mesh.joints[v as usize]).collect(),
        weights: used_vertices.iter().map(|&v| mesh.weights[v as usize]).collect(),
        reach,
        triangles: used_triangles.iter().map(|&t| mesh.triangles[t as usize].map(vertex_of)).collect(),
    };
    Ok(Bound { bindings, scalp, max_distance: max_root as f32 })
}

/// The point of triangle `(a, b, c)` nearest `p`, as barycentric weights of `a`, `b`, `c`
/// (Ericson, Real-Time Collision Detection §5.1.5).
pub fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    [1.0 - v - w, v, w]
}

/// A uniform grid over the mesh's non-degenerate triangles, each listed in every cell its box
/// overlaps.
struct Grid {
    lo: DVec3,
    cell: f64,
    dims: [i64; 3],
    cells: Vec<Vec<u32>>,
}

impl Grid {
    fn new(mesh: &SkinnedMesh) -> Grid {
        let corner = |v: u32| DVec3::from(mesh.positions[v as usize].map(f64::from));
        let live: Vec<u32> = (0..mesh.triangles.len() as u32)
            .filter(|&t| {
                let [a, b, c] = mesh.triangles[t as usize].map(corner);
                (b - a).cross(c - a).length() > 1e-12 * (b - a).length_squared().max((c - a).length_squared())
            })
            .collect();
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &t in &live {
            for v in mesh.triangles[t as usize] {
                (lo, hi) = (lo.min(corner(v)), hi.max(corner(v)));
            }
        }
        if live.is_empty() {
            return Grid { lo: DVec3::ZERO, cell: 1.0, dims: [0; 3], cells: Vec::new() };
        }
        let size = (hi - lo).max(DVec3::splat(1e-9));
        // About one triangle a cell, at most 128 cells a side; coarser while the triangles
        // would be listed more than 32 times each on average (large triangles over fine cells),
        // so the grid's size stays bounded by the mesh's.
        let mut cell = (size.x * size.y * size.z / live.len() as f64).cbrt().max(size.max_element() / 128.0);
        let grid = loop {
            let dims: [i64; 3] = std::array::from_fn(|k| ((size[k] / cell).ceil() as i64).max(1));
            let grid = Grid { lo, cell, dims, cells: Vec::new() };
            let entries: u64 = live
                .iter()
                .map(|&t| {
                    let [a, b, c] = mesh.triangles[t as usize].map(corner);
                    let (cl, ch) = (grid.coords(a.min(b).min(c)), grid.coords(a.max(b).max(c)));
                    (0..3).map(|k| (ch[k] - cl[k] + 1) as u64).product::<u64>()
                })
                .sum();
            if entries <= 32 * live.len() as u64 + (1 << 20) || dims == [1, 1, 1] {
                break grid;
            }
            cell *= 2.0;
        };
        let dims = grid.dims;
        let mut cells = vec![Vec::new(); (dims[0] * dims[1] * dims[2]) as usize];
        for &t in &live {
            let [a, b, c] = mesh.triangles[t as usize].map(corner);
            let (cl, ch) = (grid.coords(a.min(b).min(c)), grid.coords(a.max(b).max(c)));
            for z in cl[2]..=ch[2] {
                for y in cl[1]..=ch[1] {
                    for x in cl[0]..=ch[0] {
                        cells[grid.index([x, y, z])].push(t);
                    }
                }
            }
        }
        Grid { cells, ..grid }
    }

    /// The cell holding `p`, clamped into the grid.
    fn coords(&self, p: DVec3) -> [i64; 3] {
        let c = ((p - self.lo) / self.cell).floor();
        std::array::from_fn(|k| (c[k] as i64).clamp(0, self.dims[k] - 1))
    }

    fn index(&self, [x, y, z]: [i64; 3]) -> usize {
        ((z * self.dims[1] + y) * self.dims[0] + x) as usize
    }

    /// The nearest triangle to `p` with the barycentric weights of the nearest point and its
    /// distance; the search stops past `limit` (`None` when nothing lies within it).
    fn nearest(&self, mesh: &SkinnedMesh, p: DVec3, limit: f64) -> Option<(u32, [f64; 3], f64)> {
        if self.cells.is_empty() {
            return None;
        }
        let corner = |v: u32| DVec3::from(mesh.positions[v as usize].map(f64::from));
        // Distances are bounded below from the grid's box: the point clamped into it.
        let hi = self.lo + DVec3::new(self.dims[0] as f64, self.dims[1] as f64, self.dims[2] as f64) * self.cell;
        let outside = (p.clamp(self.lo, hi) - p).length();
        let c = self.coords(p);
        let mut best: Option<(f64, u32, [f64; 3])> = None;
        let rings = self.dims.iter().copied().max().unwrap_or(0);
        for k in 0..=rings {
            // Every unsearched cell lies at least k − 1 cells away (ring k − 1 was the last).
            let bound = outside.max((k - 1).max(0) as f64 * self.cell);
            if best.is_some_and(|(d, ..)| d <= bound) || bound > limit {
                break;
            }
            for z in c[2] - k..=c[2] + k {
                for y in c[1] - k..=c[1] + k {
                    for x in c[0] - k..=c[0] + k {
                        let on_ring = (x - c[0]).abs() == k || (y - c[1]).abs() == k || (z - c[2]).abs() == k;
                        let inside = (0..3).all(|i| (0..self.dims[i]).contains(&[x, y, z][i]));
                        if !on_ring || !inside {
                            continue;
                        }
                        for &t in &self.cells[self.index([x, y, z])] {
                            let [a, b, cc] = mesh.triangles[t as usize].map(corner);
                            let w = closest_on_triangle(p, a, b, cc);
                            let d = (a * w[0] + b * w[1] + cc * w[2] - p).length();
                            if best.is_none_or(|(bd, bt, _)| (d, t) < (bd, bt)) {
                                best = Some((d, t, w));
                            }
                        }
                    }
                }
            }
        }
        best.map(|(d, t, w)| (t, w, d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bumpy sheet of triangles with two joints.
    fn sheet(n: usize) -> SkinnedMesh {
        let mut m = SkinnedMesh {
            positions: Vec::new(),
            joints: Vec::new(),
            weights: Vec::new(),
            triangles: Vec::new(),
            joint_names: vec!["a".into(), "b".into()],
        };
        for j in 0..=n {
            for i in 0..=n {
                let (x, z) = (i as f32 / n as f32, j as f32 / n as f32);
                m.positions.push([x, 0.1 * (7.0 * x).sin() * (5.0 * z).cos(), z]);
                m.joints.push([0, 1, 0, 0]);
                m.weights.push([1.0 - x, x, 0.0, 0.0]);
            }
        }
        for j in 0..n as u32 {
            for i in 0..n as u32 {
                let v = j * (n as u32 + 1) + i;
                m.triangles.push([v, v + 1, v + n as u32 + 1]);
                m.triangles.push([v + 1, v + n as u32 + 2, v + n as u32 + 1]);
            }
        }
        m
    }

    /// The distance from `p` to the mesh, every triangle tried.
    fn brute_force_distance(mesh: &SkinnedMesh, p: DVec3) -> f64 {
        let corner = |v: u32| DVec3::from(mesh.positions[v as usize].map(f64::from));
        mesh.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(corner);
                let w = closest_on_triangle(p, a, b, c);
                (a * w[0] + b * w[1] + c * w[2] - p).length()
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The grid finds the same nearest point as a search of every triangle, for roots on,
    /// above, below and beside the sheet.
    #[test]
    fn the_grid_finds_what_a_brute_force_search_finds() {
        let mesh = sheet(24);
        let grid = Grid::new(&mesh);
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..2000 {
            let p = DVec3::new(next() * 1.6 - 0.3, next() * 0.8 - 0.4, next() * 1.6 - 0.3);
            let brute = brute_force_distance(&mesh, p);
            let (_, _, d) = grid.nearest(&mesh, p, 10.0).expect("a triangle within 10");
            assert!((d - brute).abs() < 1e-12, "{p}: grid {d}, brute force {brute}");
        }
    }

    /// Triangles that each span the whole box (a hostile scalp) keep the grid's listing within
    /// 32 entries a triangle, and the search still finds what a brute-force search finds.
    #[test]
    fn large_triangles_keep_the_grid_small() {
        let mut mesh = sheet(2);
        mesh.triangles.clear();
        let mut corners = Vec::new();
        for i in 0..3000u32 {
            let f = i as f32 / 3000.0;
            corners.extend([[0.0, f, 0.0], [1.0, 1.0 - f, 0.0], [0.5 * f, 0.5, 1.0]]);
            mesh.triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        mesh.joints = vec![[0, 0, 0, 0]; corners.len()];
        mesh.weights = vec![[1.0, 0.0, 0.0, 0.0]; corners.len()];
        mesh.positions = corners;
        let grid = Grid::new(&mesh);
        let entries: usize = grid.cells.iter().map(Vec::len).sum();
        assert!(entries <= 32 * 3000 + (1 << 20), "{entries} entries for 3000 triangles");
        for p in [DVec3::new(0.3, 0.2, 0.9), DVec3::new(1.2, -0.3, 0.4), DVec3::new(0.5, 0.5, 0.5)] {
            let brute = brute_force_distance(&mesh, p);
            let (_, _, d) = grid.nearest(&mesh, p, 10.0).unwrap();
            assert!((d - brute).abs() < 1e-12, "{p}: {d} against {brute}");
        }
    }

    /// The closest point of a triangle against a dense sampling of it, from every region.
    #[test]
    fn closest_point_matches_a_sampled_triangle() {
        let (a, b, c) = (DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), DVec3::new(0.5, 1.5, 0.3));
        for p in [
            DVec3::new(-1.0, -1.0, 0.2),
            DVec3::new(3.0, -0.5, 0.0),
            DVec3::new(0.4, 3.0, 1.0),
            DVec3::new(1.0, -2.0, 0.5),
            DVec3::new(2.0, 2.0, -1.0),
            DVec3::new(-1.0, 1.0, 0.0),
            DVec3::new(0.8, 0.5, 1.0),
        ] {
            let w = closest_on_triangle(p, a, b, c);
            let d = (a * w[0] + b * w[1] + c * w[2] - p).length();
            let mut sampled = f64::INFINITY;
            for i in 0..=400 {
                for j in 0..=400 - i {
                    let (u, v) = (i as f64 / 400.0, j as f64 / 400.0);
                    sampled = sampled.min((a * (1.0 - u - v) + b * u + c * v - p).length());
                }
            }
            assert!(w.iter().all(|&x| x >= -1e-12) && (w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            assert!(d <= sampled + 1e-12 && sampled - d < 0.01, "{p}: {d} against sampled {sampled}");
        }
    }

    /// Roots placed on known triangles bind to them with their weights; the scalp keeps only
    /// those triangles; a root far off the sheet is refused by strand.
    #[test]
    fn roots_bind_to_their_triangles() {
        let mesh = sheet(8);
        let corner = |v: u32| mesh.positions[v as usize];
        let picks = [(5usize, [0.2f32, 0.3, 0.5]), (77, [0.6, 0.2, 0.2]), (5, [0.1, 0.1, 0.8])];
        let mut s = Strands {
            segments: Vec::new(),
            points: Vec::new(),
            thickness: None,
            transparency: None,
            color: None,
            default_thickness: 0.01,
            default_transparency: 0.0,
            default_color: [0.5; 3],
        };
        for &(t, w) in &picks {
            let root: [f32; 3] =
                std::array::from_fn(|k| (0..3).map(|i| w[i] * corner(mesh.triangles[t][i])[k]).sum::<f32>());
            s.segments.push(1);
            s.points.extend([root, [root[0], root[1] + 0.5, root[2]]]);
        }
        let bound = bind(&s, &mesh, 0.01, 0.005).unwrap();
        assert_eq!(bound.scalp.triangles.len(), 2);
        for (b, &(t, w)) in bound.bindings.iter().zip(&picks) {
            let kept = bound.scalp.triangles[b.triangle as usize].map(|v| bound.scalp.positions[v as usize]);
            assert_eq!(kept, mesh.triangles[t].map(corner));
            assert!((b.weights()[1] - w[1]).abs() < 1e-5 && (b.weights()[2] - w[2]).abs() < 1e-5, "{b:?} {w:?}");
        }
        // Reach: the strand's 0.5 tip plus the pad, at every vertex of its triangle.
        assert!(bound.scalp.reach.iter().all(|&r| (r - 0.505).abs() < 1e-4), "{:?}", bound.scalp.reach);
        s.points[3][1] += 5.0;
        s.points[2][1] += 5.0;
        assert_eq!(bind(&s, &mesh, 0.01, 0.0).unwrap_err().strand, 1);
    }
}
