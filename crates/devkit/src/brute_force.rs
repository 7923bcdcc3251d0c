//! Brute-force references the bakers are measured against, written independently of them.
//!
//! Horizons: a ray per texel over the bilinear surface, sampled at every
//! grid-line crossing, in plain texel space. `O(N·D·R)`; for tests and benchmarks on small maps.
//!
//! Written independently of the baker (no canonical orientation, no hulls, no stencil, no
//! tables) so that it can serve as its oracle.

use hikage_bundle::EdgeMode;

use hikage_bake::Heightfield;
use hikage_bake::horizon::HorizonParams;

/// World height of sample (row, col), or `None` outside a clamped map.
fn sample(hf: &Heightfield, wrap: bool, row: i64, col: i64) -> Option<f64> {
    let (w, h) = (hf.width as i64, hf.height as i64);
    let (r, c) = if wrap { (row.rem_euclid(h), col.rem_euclid(w)) } else { (row, col) };
    if r < 0 || r >= h || c < 0 || c >= w {
        return None;
    }
    Some(hf.samples[(r * w + c) as usize] as f64 * hf.height_scale as f64)
}

/// Linear interpolation along a grid line at fractional position `x` between integer knots,
/// `at(knot)` giving heights; snaps positions within 1e-9 of a knot onto it.
fn along(x: f64, at: impl Fn(i64) -> Option<f64>) -> Option<f64> {
    let mut k = x.floor();
    let mut f = x - k;
    if f > 1.0 - 1e-9 {
        k += 1.0;
        f = 0.0;
    }
    if f < 1e-9 {
        return at(k as i64);
    }
    Some(at(k as i64)? * (1.0 - f) + at(k as i64 + 1)? * f)
}

/// Brute-force `(tan β, d)` of texel (`row`, `col`) in direction `phi` (radians, texel space,
/// from +u toward +v); `tan β` is `-∞` when the ray has no sample.
pub fn horizon(hf: &Heightfield, s: &HorizonParams, row: usize, col: usize, phi: f64) -> (f64, f64) {
    let wrap = s.edge == EdgeMode::Wrap;
    let (c, sn) = (phi.cos(), phi.sin());
    let c = if c.abs() < 1e-12 { 0.0 } else { c };
    let sn = if sn.abs() < 1e-12 { 0.0 } else { sn };
    let (sx, sy) = (hf.texel_size.0 as f64, hf.texel_size.1 as f64);
    let len = ((sx * c).powi(2) + (sy * sn).powi(2)).sqrt();
    // Largest ray parameter (texels along the ray).
    let mut s_max = match (s.max_distance, wrap) {
        (Some(md), _) => md as f64 / len,
        (None, true) => {
            if c.abs() >= sn.abs() {
                hf.width as f64 / c.abs()
            } else {
                hf.height as f64 / sn.abs()
            }
        }
        (None, false) => f64::INFINITY,
    };
    if !wrap {
        // Stop at the edge of the surface's domain [0.5, W-0.5] x [0.5, H-0.5].
        let (u0, v0) = (col as f64 + 0.5, row as f64 + 0.5);
        let exit = |p0: f64, d: f64, hi: f64| {
            if d > 0.0 {
                (hi - 0.5 - p0) / d
            } else if d < 0.0 {
                (0.5 - p0) / d
            } else {
                f64::INFINITY
            }
        };
        s_max = s_max.min(exit(u0, c, hf.width as f64)).min(exit(v0, sn, hf.height as f64));
    }
    let h0 = sample(hf, wrap, row as i64, col as i64).unwrap();
    let mut params = Vec::new();
    for (d, is_u) in [(c, true), (sn, false)] {
        if d != 0.0 {
            let mut n = 1.0;
            while n / d.abs() <= s_max + 1e-9 {
                params.push((n / d.abs(), is_u));
                n += 1.0;
            }
        }
    }
    let (mut best, mut best_d) = (f64::NEG_INFINITY, 0.0);
    for (t, on_vertical_line) in params {
        let (du, dv) = (t * c, t * sn);
        let h = if on_vertical_line {
            let colx = col as i64 + du.round() as i64;
            along(row as f64 + dv, |r| sample(hf, wrap, r, colx))
        } else {
            let rowx = row as i64 + dv.round() as i64;
            along(col as f64 + du, |cc| sample(hf, wrap, rowx, cc))
        };
        if let Some(h) = h {
            let slope = (h - h0) / (t * len);
            if slope > best {
                best = slope;
                best_d = t * len;
            }
        }
    }
    (best, best_d)
}

/// The height above the ground at texel `(i, j)` of a `w`×`h` grid of world `heights` (texel
/// centres at `((i + ½)·sx, (j + ½)·sy)`) above which a sun at `elevation` and `azimuth`
/// (radians, from +u toward +v) is seen ([`sun_shadow_height`] from the texel's centre, less its
/// height). Negative where the ground itself sees the sun. The reference of a raised point's sun
/// visibility (`horizon_raised_sun_visible`): lit when it stands higher than this.
pub fn raised_shadow_height(
    heights: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f32, f32),
    (i, j): (usize, usize),
    sun: (f32, f32),
    reach: f32,
) -> f32 {
    let centre = ((i as f32 + 0.5) * sx, (j as f32 + 0.5) * sy);
    sun_shadow_height(heights, (w, h), (sx, sy), centre, sun, reach) - heights[j * w + i]
}

/// The world height above which a sun at `elevation` and `azimuth` (radians, from +u toward +v)
/// is seen from above map point `(x, y)` (world units along u and v) of a `w`×`h` grid of world
/// `heights` (texel centres at `((i + ½)·sx, (j + ½)·sy)`): quarter-texel steps over the bilinear
/// surface through the texel centres, within `reach` and up to the edge texels' centres (a
/// clamped map's rays stop there). −∞ when no step is on the map. The reference of a receiver's
/// sun visibility (`SunField`): lit when it stands higher than this.
pub fn sun_shadow_height(
    heights: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f32, f32),
    (x, y): (f32, f32),
    (elevation, azimuth): (f32, f32),
    reach: f32,
) -> f32 {
    let step = 0.25 * sx.min(sy);
    let (mut t, mut above) = (step, f32::NEG_INFINITY);
    while t <= reach {
        let Some(z) = bilinear_height(heights, (w, h), (sx, sy), (x + t * azimuth.cos(), y + t * azimuth.sin())) else {
            break;
        };
        above = above.max(z - t * elevation.tan());
        t += step;
    }
    above
}

/// The height of the bilinear surface through the texel centres of a `w`×`h` grid of `heights`
/// at map point `(x, y)`, or `None` past the edge texels' centres.
pub fn bilinear_height(
    heights: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f32, f32),
    (x, y): (f32, f32),
) -> Option<f32> {
    let (fx, fy) = (x / sx - 0.5, y / sy - 0.5);
    if !(fx >= 0.0 && fy >= 0.0 && fx <= (w - 1) as f32 && fy <= (h - 1) as f32) {
        return None;
    }
    let (x0, y0) = ((fx as usize).min(w - 2), (fy as usize).min(h - 2));
    let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
    let z = |x: usize, y: usize| heights[y * w + x];
    let top = z(x0, y0) + (z(x0 + 1, y0) - z(x0, y0)) * tx;
    let bottom = z(x0, y0 + 1) + (z(x0 + 1, y0 + 1) - z(x0, y0 + 1)) * tx;
    Some(top + (bottom - top) * ty)
}

/// The relief baker's reference: the first-hit depth of the ray from texel (`i`, `j`) of a
/// tiling heightfield along `dir` (`z` down, the relief `thickness` texels deep), by a march in steps of `1/steps_per_texel`
/// texel from the texel centre, every step a height read, then the depth at the first step
/// inside (no max-mip, no shared traversal).
pub fn relief_depth(
    heights: &[f32],
    (w, h): (u32, u32),
    (i, j): (u32, u32),
    dir: [f32; 3],
    thickness: f32,
    steps_per_texel: f32,
) -> f32 {
    let step = 1.0 / steps_per_texel;
    let dz = dir[2] / thickness;
    let mut s = 0.0f32;
    loop {
        let z = s * dz;
        if z >= 1.0 {
            return 1.0;
        }
        let u = (i as f32 + 0.5 + s * dir[0]).floor() as i64;
        let v = (j as f32 + 0.5 + s * dir[1]).floor() as i64;
        let height = heights[(v.rem_euclid(h as i64) * w as i64 + u.rem_euclid(w as i64)) as usize];
        if z >= 1.0 - height {
            return z;
        }
        s += step;
    }
}
