//! Per-vertex principal curvatures and directions of a mesh (seed 000 §3.1).
//!
//! For each position: a local frame from the area-weighted normal, then a least-squares fit of
//! the height field `z = a x² + b xy + c y² + d x + e y` to its 2-ring neighbours (Goldfeather
//! & Interrante 2004 use the same quadric). The shape operator `−[[2a, b], [b, 2c]]` (scaled by
//! the fitted slope) gives `κ1 ≥ κ2` and the principal directions; convex surfaces seen from the
//! side the normals point to have positive curvature, as seed 000 requires (κ > 0 is convex).
//! Directions are then expressed in each vertex's texture frame: the unit tangents along +u and
//! +v (`P_u`, `P_v`, from the UV gradients), the frame in which the runtime expresses the light.
//!
//! Cost: `O(V · k)` with `k` the 2-ring size.

use glam::{DVec2, DVec3};

use crate::mesh::Mesh;

/// Curvature at one vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexCurvature {
    /// Larger principal curvature (1 / world units).
    pub k1: f64,
    /// Smaller principal curvature.
    pub k2: f64,
    /// First principal direction as its dot products with the unit tangents of +u and +v,
    /// `(V1·P̂_u, V1·P̂_v)`, normalised (components only where those are orthogonal).
    pub dir1_uv: DVec2,
    /// Second principal direction, likewise.
    pub dir2_uv: DVec2,
    /// Unit normal.
    pub normal: DVec3,
    /// `P_u = ∂P/∂u`, world units per texture unit: the area-weighted mean over the vertex's
    /// triangles (the frame the runtime takes the light into).
    pub pu: DVec3,
    /// `P_v = ∂P/∂v`, likewise.
    pub pv: DVec3,
}

/// Why curvature cannot be computed.
#[derive(Clone, Debug, PartialEq)]
pub enum CurvatureError {
    /// A triangle has (nearly) zero area.
    Degenerate {
        /// Triangle index (order of the faces, polygons fanned).
        triangle: usize,
    },
    /// A triangle's texture coordinates have (nearly) zero area, so `P_u`, `P_v` are undefined.
    DegenerateUv {
        /// Triangle index.
        triangle: usize,
    },
}

impl std::fmt::Display for CurvatureError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CurvatureError::Degenerate { triangle } => write!(f, "triangle {triangle} has zero area"),
            CurvatureError::DegenerateUv { triangle } => {
                write!(f, "triangle {triangle} has zero area in texture space (its UVs are collinear)")
            }
        }
    }
}

/// Computes curvature at every vertex of `mesh`.
pub fn compute(mesh: &Mesh) -> Result<Vec<VertexCurvature>, CurvatureError> {
    let np = mesh.positions.len();
    let pos = |v: u32| mesh.positions[mesh.vertex_position[v as usize] as usize];

    // Scale for degeneracy tests: the mean edge length.
    let mut edge_sum = 0.0;
    for t in &mesh.triangles {
        edge_sum += (pos(t[1]) - pos(t[0])).length();
    }
    let scale = (edge_sum / mesh.triangles.len() as f64).max(1e-300);

    // Area-weighted normals and 1-ring adjacency, per position.
    let mut normals = vec![DVec3::ZERO; np];
    let mut ring: Vec<Vec<u32>> = vec![Vec::new(); np];
    for (ti, t) in mesh.triangles.iter().enumerate() {
        let p = t.map(|v| mesh.vertex_position[v as usize]);
        let (a, b, c) = (mesh.positions[p[0] as usize], mesh.positions[p[1] as usize], mesh.positions[p[2] as usize]);
        let n = (b - a).cross(c - a);
        if n.length() <= 1e-12 * scale * scale {
            return Err(CurvatureError::Degenerate { triangle: ti });
        }
        for k in 0..3 {
            normals[p[k] as usize] += n;
            for j in 0..3 {
                if j != k && !ring[p[k] as usize].contains(&p[j]) {
                    ring[p[k] as usize].push(p[j]);
                }
            }
        }
    }

    // Per position: fit the quadric over the 2-ring.
    let mut per_position = Vec::with_capacity(np);
    for i in 0..np {
        let n = normals[i].normalize_or_zero();
        let mut neighbours: Vec<u32> = ring[i].clone();
        for &j in &ring[i] {
            for &k in &ring[j as usize] {
                if k as usize != i && !neighbours.contains(&k) {
                    neighbours.push(k);
                }
            }
        }
        let (t1, t2) = n.any_orthonormal_pair();
        per_position.push(fit(mesh.positions[i], n, t1, t2, neighbours.iter().map(|&j| mesh.positions[j as usize])));
    }

    // Per vertex: texture frame from the UV gradients of its triangles.
    let mut pu = vec![DVec3::ZERO; mesh.vertex_uv.len()];
    let mut pv = vec![DVec3::ZERO; mesh.vertex_uv.len()];
    let mut weight = vec![0.0f64; mesh.vertex_uv.len()];
    for (ti, t) in mesh.triangles.iter().enumerate() {
        let (p0, p1, p2) = (pos(t[0]), pos(t[1]), pos(t[2]));
        let (w0, w1, w2) =
            (mesh.vertex_uv[t[0] as usize], mesh.vertex_uv[t[1] as usize], mesh.vertex_uv[t[2] as usize]);
        let (e1, e2) = (p1 - p0, p2 - p0);
        let (d1, d2) = (w1 - w0, w2 - w0);
        let det = d1.x * d2.y - d2.x * d1.y;
        if det.abs() <= 1e-14 {
            return Err(CurvatureError::DegenerateUv { triangle: ti });
        }
        let dpdu = (e1 * d2.y - e2 * d1.y) / det;
        let dpdv = (e2 * d1.x - e1 * d2.x) / det;
        let area = e1.cross(e2).length();
        for &v in t {
            pu[v as usize] += dpdu * area;
            pv[v as usize] += dpdv * area;
            weight[v as usize] += area;
        }
    }

    // Copies of one position split by a periodic UV seam (a torus's u = 0 and u = 1) each saw
    // the triangles on one side only; where their frames agree they are one frame, and get the
    // mean over both sides. Copies whose frames differ (a mirrored island) keep their own.
    let mut copies: Vec<Vec<usize>> = vec![Vec::new(); np];
    for v in 0..mesh.vertex_uv.len() {
        copies[mesh.vertex_position[v] as usize].push(v);
    }
    let agree = |a: DVec3, b: DVec3| a.normalize_or_zero().dot(b.normalize_or_zero()) > 0.9;
    let (mut pu_seamless, mut pv_seamless, mut weight_seamless) = (pu.clone(), pv.clone(), weight.clone());
    for group in copies.iter().filter(|g| g.len() > 1) {
        for &v in group {
            for &w in group.iter().filter(|&&w| w != v) {
                if agree(pu[v], pu[w]) && agree(pv[v], pv[w]) {
                    pu_seamless[v] += pu[w];
                    pv_seamless[v] += pv[w];
                    weight_seamless[v] += weight[w];
                }
            }
        }
    }
    let (pu, pv, weight) = (pu_seamless, pv_seamless, weight_seamless);

    Ok((0..mesh.vertex_uv.len())
        .map(|v| {
            let (k1, k2, v1, v2, n) = per_position[mesh.vertex_position[v] as usize];
            // Unit tangents along +u and +v, projected into the tangent plane.
            let project = |x: DVec3| (x - n * x.dot(n)).normalize_or_zero();
            let (eu, ev) = (project(pu[v]), project(pv[v]));
            let in_frame = |d: DVec3| DVec2::new(d.dot(eu), d.dot(ev)).normalize_or_zero();
            let w = weight[v].max(1e-300);
            VertexCurvature {
                k1,
                k2,
                dir1_uv: in_frame(v1),
                dir2_uv: in_frame(v2),
                normal: n,
                pu: pu[v] / w,
                pv: pv[v] / w,
            }
        })
        .collect())
}

/// Fits the quadric around `p` and returns `(κ1, κ2, V1, V2, n)`.
fn fit(
    p: DVec3,
    n: DVec3,
    t1: DVec3,
    t2: DVec3,
    neighbours: impl Iterator<Item = DVec3>,
) -> (f64, f64, DVec3, DVec3, DVec3) {
    // Normal equations of z = a x² + b xy + c y² + d x + e y.
    let mut ata = [[0.0f64; 5]; 5];
    let mut atz = [0.0f64; 5];
    let mut count = 0;
    for q in neighbours {
        let r = q - p;
        let (x, y, z) = (r.dot(t1), r.dot(t2), r.dot(n));
        let row = [x * x, x * y, y * y, x, y];
        for i in 0..5 {
            atz[i] += row[i] * z;
            for j in 0..5 {
                ata[i][j] += row[i] * row[j];
            }
        }
        count += 1;
    }
    if count < 5 {
        return (0.0, 0.0, t1, t2, n);
    }
    let Some([a, b, c, d, e]) = solve5(ata, atz) else { return (0.0, 0.0, t1, t2, n) };
    // Second fundamental form over the first, at the origin of z(x, y).
    let norm = (1.0 + d * d + e * e).sqrt();
    let (e11, e12, e22) = (1.0 + d * d, d * e, 1.0 + e * e); // first fundamental form
    let (l11, l12, l22) = (-2.0 * a / norm, -b / norm, -2.0 * c / norm); // second (sign: convex > 0)
    // Shape operator W = I⁻¹ II.
    let det = e11 * e22 - e12 * e12;
    let w11 = (e22 * l11 - e12 * l12) / det;
    let w12 = (e22 * l12 - e12 * l22) / det;
    let w21 = (e11 * l12 - e12 * l11) / det;
    let w22 = (e11 * l22 - e12 * l12) / det;
    let tr = w11 + w22;
    let disc = ((w11 - w22).powi(2) + 4.0 * w12 * w21).max(0.0).sqrt();
    let (k1, k2) = ((tr + disc) / 2.0, (tr - disc) / 2.0);
    // Eigenvector of k1 in (x, y).
    let e1 = if w12.abs() > 1e-12 {
        DVec2::new(w12, k1 - w11)
    } else if w21.abs() > 1e-12 {
        DVec2::new(k1 - w22, w21)
    } else if w11 >= w22 {
        DVec2::X
    } else {
        DVec2::Y
    };
    let e1 = e1.normalize_or_zero();
    let v1 = (t1 * e1.x + t2 * e1.y).normalize_or_zero();
    let v2 = n.cross(v1).normalize_or_zero();
    (k1, k2, v1, v2, n)
}

/// Solves a 5×5 linear system by Gaussian elimination with partial pivoting.
fn solve5(mut m: [[f64; 5]; 5], mut r: [f64; 5]) -> Option<[f64; 5]> {
    for col in 0..5 {
        let pivot = (col..5).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
        if m[pivot][col].abs() < 1e-300 {
            return None;
        }
        m.swap(col, pivot);
        r.swap(col, pivot);
        let (top, bottom) = m.split_at_mut(col + 1);
        let pivot_row = &top[col];
        for (i, row) in bottom.iter_mut().enumerate() {
            let f = row[col] / pivot_row[col];
            for (x, p) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * p;
            }
            r[col + 1 + i] -= f * r[col];
        }
    }
    let mut x = [0.0; 5];
    for i in (0..5).rev() {
        let s: f64 = (i + 1..5).map(|k| m[i][k] * x[k]).sum();
        x[i] = (r[i] - s) / m[i][i];
    }
    Some(x)
}
