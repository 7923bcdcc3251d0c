//! Choosing the opacity set from the strands themselves (the paper's stated future work): the
//! narrowest width at which the opacity set, rasterised in light space at the opacity map's
//! resolution, leaves no hole inside the hair's silhouette, with the opacity that keeps its total
//! optical depth equal to the shading set's.
//!
//! Light space here is an orthographic view along a light direction, the hair's bounding box
//! filling `resolution` pixels. The silhouette is the shading set's centre-line coverage closed
//! by a disc of [`CLOSING_RADIUS`] pixels (gaps narrower than that are inside the hair). Optical
//! depth of a strip is `width × length × −ln(1 − α)`; matching it keeps what the opacity maps
//! accumulate the same whichever set is drawn.

use glam::Vec3;
use rayon::prelude::*;

use super::Strands;
use super::strips::StripSets;

/// Gaps in the centre-line coverage narrower than twice this (pixels) count as inside the hair.
pub const CLOSING_RADIUS: i32 = 2;

/// Light directions the choice is made for: the six axes and the eight diagonals.
pub fn directions() -> Vec<[f32; 3]> {
    let mut d =
        vec![[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]];
    let r = 1.0 / 3f32.sqrt();
    for k in 0..8 {
        d.push([if k & 1 == 0 { r } else { -r }, if k & 2 == 0 { r } else { -r }, if k & 4 == 0 { r } else { -r }]);
    }
    d
}

/// An orthographic light view: two axes across the direction and the pixel size.
struct View {
    u: Vec3,
    v: Vec3,
    origin: (f32, f32),
    pixel: f32,
    n: i32,
}

impl View {
    fn new(s: &Strands, dir: [f32; 3], resolution: u32) -> View {
        let dir = Vec3::from(dir);
        let helper = if dir.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
        let across = dir.cross(helper);
        // Divided by the length (not glam's reciprocal multiply): the chosen sets stay the same.
        let u = across / across.length();
        let v = dir.cross(u);
        let (mut lo, mut hi) = ((f32::INFINITY, f32::INFINITY), (f32::NEG_INFINITY, f32::NEG_INFINITY));
        for &p in &s.points {
            let p = Vec3::from(p);
            let (a, b) = (p.dot(u), p.dot(v));
            lo = (lo.0.min(a), lo.1.min(b));
            hi = (hi.0.max(a), hi.1.max(b));
        }
        let extent = (hi.0 - lo.0).max(hi.1 - lo.1).max(1e-6);
        // One pixel of margin all round.
        let pixel = extent / (resolution as f32 - 2.0).max(1.0);
        View { u, v, origin: (lo.0 - pixel, lo.1 - pixel), pixel, n: resolution as i32 }
    }

    fn project(&self, p: [f32; 3]) -> (f32, f32) {
        let p = Vec3::from(p);
        ((p.dot(self.u) - self.origin.0) / self.pixel, (p.dot(self.v) - self.origin.1) / self.pixel)
    }
}

/// Pixels covered by the strands drawn `width(point)` world units wide (0: the centre line, one
/// pixel), and the summed optical depth per pixel when `alpha` is given.
fn rasterise(s: &Strands, view: &View, width: &dyn Fn(usize) -> f32) -> Vec<bool> {
    let n = view.n as usize;
    let mut covered = vec![false; n * n];
    let mut first = 0usize;
    for &seg in &s.segments {
        let last = first + seg as usize;
        for p in first..last {
            let (a, b) = (view.project(s.points[p]), view.project(s.points[p + 1]));
            let half = 0.5 * width(p).max(0.0) / view.pixel;
            let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
            // Stamps overlap by half: contiguous, without redrawing a wide strip per half pixel.
            let steps = (len / half.max(0.5)).ceil().max(1.0) as usize;
            for k in 0..=steps {
                let t = k as f32 / steps as f32;
                let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
                let (x0, x1) = ((x - half).floor() as i32, (x + half).floor() as i32);
                let (y0, y1) = ((y - half).floor() as i32, (y + half).floor() as i32);
                for yy in y0.max(0)..=y1.min(view.n - 1) {
                    for xx in x0.max(0)..=x1.min(view.n - 1) {
                        covered[yy as usize * n + xx as usize] = true;
                    }
                }
            }
        }
        first = last + 1;
    }
    covered
}

/// Dilates (`grow`) or erodes a mask by a disc of `r` pixels.
fn morph(mask: &[bool], n: usize, r: i32, grow: bool) -> Vec<bool> {
    let mut out = vec![!grow; n * n];
    for y in 0..n as i32 {
        for x in 0..n as i32 {
            let mut hit = !grow;
            'disc: for dy in -r..=r {
                for dx in -r..=r {
                    if dx * dx + dy * dy > r * r {
                        continue;
                    }
                    let (xx, yy) = (x + dx, y + dy);
                    let inside = xx >= 0 && yy >= 0 && xx < n as i32 && yy < n as i32;
                    let v = inside && mask[yy as usize * n + xx as usize];
                    if grow && v {
                        hit = true;
                        break 'disc;
                    }
                    if !grow && !v {
                        hit = false;
                        break 'disc;
                    }
                }
            }
            out[y as usize * n + x as usize] = hit;
        }
    }
    out
}

/// A light direction's view with the hair's silhouette in it.
pub struct LightView {
    view: View,
    silhouette: Vec<bool>,
    inside: usize,
}

impl LightView {
    /// The view along `dir` at `resolution` and the silhouette (closed centre-line coverage).
    pub fn new(s: &Strands, dir: [f32; 3], resolution: u32) -> LightView {
        let view = View::new(s, dir, resolution);
        let n = resolution as usize;
        let centre = rasterise(s, &view, &|_| 0.0);
        let silhouette = morph(&morph(&centre, n, CLOSING_RADIUS, true), n, CLOSING_RADIUS, false);
        let inside = silhouette.iter().filter(|&&x| x).count();
        LightView { view, silhouette, inside }
    }

    /// Share of the silhouette's pixels the opacity set of `sets` (each point's width scaled by
    /// its own thickness) leaves uncovered.
    pub fn hole_share(&self, s: &Strands, sets: &StripSets) -> f64 {
        let thick_ref = s.default_thickness;
        let width = |p: usize| {
            let t = s.thickness.as_ref().map_or(thick_ref, |t| t[p]);
            sets.opacity.0 * if thick_ref > 0.0 { t / thick_ref } else { 1.0 }
        };
        let covered = rasterise(s, &self.view, &width);
        let holes = self.silhouette.iter().zip(&covered).filter(|&(&si, &c)| si && !c).count();
        holes as f64 / self.inside.max(1) as f64
    }
}

/// Optical depth of a strip `width` wide at opacity `alpha`, per unit length.
pub fn optical_depth(width: f32, alpha: f32) -> f64 {
    -(width as f64) * (1.0 - (alpha as f64).min(0.999_999)).ln()
}

/// The opacity at which a set `width` wide has the optical depth of the shading set.
pub fn matching_alpha(sets: &StripSets, width: f32) -> f32 {
    let tau = optical_depth(sets.shading.0, sets.shading.1) / width as f64;
    (1.0 - (-tau).exp()) as f32
}

/// Widest opacity set tried, as a multiple of the shading width.
pub const MAX_WIDTH_RATIO: f32 = 64.0;

/// The automatic choice: the narrowest opacity-set width (bisected in log scale between the
/// shading width and [`MAX_WIDTH_RATIO`] times it or the width that bridges any gap the
/// silhouette closes, to 2%) that leaves no hole seen along any of
/// the six axes at `resolution`, with [`matching_alpha`]. Returns the sets and the largest hole
/// share left (0 unless even the widest leaves holes).
pub fn choose(s: &Strands, base: &StripSets, resolution: u32) -> (StripSets, f64) {
    let views: Vec<LightView> = directions()[..6].par_iter().map(|&d| LightView::new(s, d, resolution)).collect();
    let with = |width: f32| StripSets { opacity: (width, matching_alpha(base, width)), ..*base };
    let worst = |sets: &StripSets| views.par_iter().map(|v| v.hole_share(s, sets)).reduce(|| 0.0, f64::max);
    // Wide enough to bridge any gap the closing fills, whatever the pixel size, at the
    // thinnest point (tips are tapered).
    let pixel = views.iter().map(|v| v.view.pixel).fold(0.0f32, f32::max);
    let thinnest = match (&s.thickness, s.default_thickness > 0.0) {
        (Some(t), true) => t.iter().fold(f32::INFINITY, |m, &x| m.min(x)) / s.default_thickness,
        _ => 1.0,
    }
    .max(0.05);
    let bridge = pixel * (2 * CLOSING_RADIUS + 2) as f32 / thinnest;
    let (mut lo, mut hi) = (base.shading.0, (base.shading.0 * MAX_WIDTH_RATIO).max(bridge));
    let widest = worst(&with(hi));
    if widest > 0.0 {
        return (with(hi), widest);
    }
    if worst(&with(lo)) == 0.0 {
        return (with(lo), 0.0);
    }
    while hi / lo > 1.02 {
        let mid = (lo * hi).sqrt();
        if worst(&with(mid)) == 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    (with(hi), 0.0)
}
