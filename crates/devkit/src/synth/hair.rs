//! Procedural hair: strands grown from a head-like ellipsoid, with gravity, curl, and a width
//! and opacity of their own.

use super::noise::hash01;
use hikage_bake::strands::Strands;
use hikage_bake::strands::strips::StripSets;

/// Half-axes of the head ellipsoid (x across, y up, z forward), in centimetres.
const HEAD: [f32; 3] = [8.0, 10.5, 9.5];

/// `count` strands of `points` points each. Roots cover the scalp (the ellipsoid above the
/// ears, the face left bare); each strand leaves along the normal, bends down under gravity,
/// curls around its growth direction, and is pushed out of the head. Per-strand width (0.8–1.2 ×
/// the base 0.016 cm) and opacity (0.6–1.0 × 0.366) go into per-point arrays, tapered to 40% at
/// the tip. Deterministic in `seed`.
pub fn hair(count: u32, points: u16, seed: u32) -> Strands {
    grow(count, points, seed, Curl { radius: (0.25, 0.5), turns: (1.5, 2.5) })
}

/// Curly hair: [`hair`]'s head and growth with tight ringlets — each strand circles its growth
/// direction 6–10 times, the circle growing from nothing at the root to 0.6–1.0 cm at the tip.
/// Deterministic in `seed`.
pub fn curly(count: u32, points: u16, seed: u32) -> Strands {
    grow(count, points, seed, Curl { radius: (0.6, 0.4), turns: (6.0, 4.0) })
}

/// The curl of a head of hair: radius and turns, each `base + spread × random`.
struct Curl {
    radius: (f32, f32),
    turns: (f32, f32),
}

fn grow(count: u32, points: u16, seed: u32, curl: Curl) -> Strands {
    let n = points as usize;
    let mut out = empty(count, points);
    let mut s = 0u32;
    let mut attempt = 0i32;
    while s < count {
        attempt += 1;
        let r = |k: u32| hash01(attempt, k as i32, seed);
        // Uniform direction on the sphere, mapped onto the ellipsoid.
        let (zu, az) = (2.0 * r(1) - 1.0, std::f32::consts::TAU * r(2));
        let ring = (1.0 - zu * zu).sqrt();
        let d = [ring * az.cos(), zu, ring * az.sin()];
        // Scalp: above the ears, and not the face (front, below the brow).
        if d[1] < -0.1 || (d[2] > 0.55 && d[1] < 0.55) {
            continue;
        }
        let root = [d[0] * HEAD[0], d[1] * HEAD[1], d[2] * HEAD[2]];
        let mut normal = [root[0] / (HEAD[0] * HEAD[0]), root[1] / (HEAD[1] * HEAD[1]), root[2] / (HEAD[2] * HEAD[2])];
        let len = (normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]).sqrt();
        normal.iter_mut().for_each(|c| *c /= len);
        let length = 14.0 + 14.0 * r(3);
        let step = length / (n - 1) as f32;
        let (curl_r, curl_f, curl_p) =
            (curl.radius.0 + curl.radius.1 * r(4), curl.turns.0 + curl.turns.1 * r(5), std::f32::consts::TAU * r(6));
        let width = 0.016 * (0.8 + 0.4 * r(7));
        let transparency = 1.0 - 0.366 * (0.6 + 0.4 * r(8));
        let mut p = root;
        let mut dir = normal;
        for i in 0..n {
            let t = i as f32 / (n - 1) as f32;
            // Curl: a small circle in the plane across the growth direction.
            let a = curl_p + curl_f * std::f32::consts::TAU * t;
            let curl = [curl_r * a.cos() * t, 0.0, curl_r * a.sin() * t];
            let mut q = [p[0] + curl[0], p[1] + curl[1], p[2] + curl[2]];
            push_out(&mut q);
            out.points.push(q);
            out.thickness.as_mut().expect("set above").push(width * (1.0 - 0.6 * t));
            out.transparency.as_mut().expect("set above").push(transparency);
            // Gravity turns the direction downward as the strand grows.
            dir[1] -= 0.18;
            let l = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
            dir.iter_mut().for_each(|c| *c /= l);
            for k in 0..3 {
                p[k] += dir[k] * step;
            }
            push_out(&mut p);
        }
        s += 1;
    }
    out
}

/// Moves a point that is inside the head (slightly inflated) onto its surface, radially.
fn push_out(p: &mut [f32; 3]) {
    let e = ((p[0] / (HEAD[0] * 1.03)).powi(2) + (p[1] / (HEAD[1] * 1.03)).powi(2) + (p[2] / (HEAD[2] * 1.03)).powi(2))
        .sqrt();
    if e < 1.0 && e > 0.0 {
        p.iter_mut().for_each(|c| *c /= e);
    }
}

/// Straight, long, combed strands: `count` strands of `points` points hanging from a band
/// across the back of the head (roots on an arc 24 cm wide, a few millimetres deep), combed
/// parallel and falling straight down 36–40 cm, with a slight sideways drift so neighbours do
/// not coincide. Seen from a light above, they make a sheet of near-parallel lines with gaps
/// between them — the layout where an opacity map can see through the hair. Widths and
/// opacities as [`hair`]'s (0.016 cm at 0.366, varied per strand). Deterministic in `seed`.
pub fn combed(count: u32, points: u16, seed: u32) -> Strands {
    let n = points as usize;
    let mut out = empty(count, points);
    for s in 0..count {
        let r = |k: u32| hash01(s as i32, k as i32, seed);
        // Around the back of the head: angle from −90° to +90° (z < 0 is the back).
        let a = (r(1) - 0.5) * std::f32::consts::PI;
        let depth = 0.4 * r(2);
        let root = [(HEAD[0] + depth) * a.sin(), 2.0 + 0.5 * r(3), -(HEAD[2] + depth) * a.cos()];
        let length = 36.0 + 4.0 * r(4);
        let drift = [0.3 * (r(5) - 0.5), 0.3 * (r(6) - 0.5)];
        let width = 0.016 * (0.8 + 0.4 * r(7));
        let transparency = 1.0 - 0.366 * (0.6 + 0.4 * r(8));
        for i in 0..n {
            let t = i as f32 / (n - 1) as f32;
            out.points.push([root[0] + drift[0] * t, root[1] - length * t, root[2] + drift[1] * t]);
            out.thickness.as_mut().expect("set above").push(width * (1.0 - 0.6 * t));
            out.transparency.as_mut().expect("set above").push(transparency);
        }
    }
    out
}

/// `count` strands of `points` points with room for them, and the defaults of the generated
/// hair: 0.016 cm strands at opacity 0.366, brown.
fn empty(count: u32, points: u16) -> Strands {
    let total = count as usize * points as usize;
    Strands {
        segments: vec![points - 1; count as usize],
        points: Vec::with_capacity(total),
        thickness: Some(Vec::with_capacity(total)),
        transparency: Some(Vec::with_capacity(total)),
        color: None,
        default_thickness: 0.016,
        default_transparency: 1.0 - 0.366,
        default_color: [0.35, 0.22, 0.12],
    }
}

/// Strands `s` with sets `sets` as if modelled where the affine matrix `model` (column-major
/// columns, as glam's `to_cols_array_2d`) carries them: every point through the matrix, both
/// sets' widths times `width_scale` (the matrix's uniform scale). What a renderer drawing `s`
/// through `model` must match once these are baked.
pub fn carried(s: &Strands, sets: &StripSets, model: [[f32; 4]; 4], width_scale: f32) -> (Strands, StripSets) {
    let [a, b, c, t] = model;
    let point = |p: &[f32; 3]| std::array::from_fn(|k| a[k] * p[0] + b[k] * p[1] + c[k] * p[2] + t[k]);
    let moved = Strands { points: s.points.iter().map(point).collect(), ..s.clone() };
    let widened = StripSets {
        shading: (width_scale * sets.shading.0, sets.shading.1),
        opacity: (width_scale * sets.opacity.0, sets.opacity.1),
        ..*sets
    };
    (moved, widened)
}
