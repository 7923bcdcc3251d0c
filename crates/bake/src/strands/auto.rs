//! Choosing the opacity set from the strands themselves (the paper's stated future work).
//!
//! What the opacity set is for is a hair shadow that converges to the right one: the shading
//! set's own shadow seen at a far higher resolution. So the choice is judged against exactly
//! that, in light space: an orthographic view along a light direction with the hair's bounding
//! box filling `resolution` pixels, the shadow (`1 − min(Σ α, 1)` over the strips covering each
//! pixel centre, as the opacity maps accumulate it) of a candidate set at `resolution` against
//! the shading set's at [`REFERENCE_FACTOR`]× the resolution box-filtered down, RMS over the
//! pixels in or beside shadow. Each candidate width keeps `width × α` — what the additive maps
//! sum per unit length — equal to the shading set's, so a set only trades sharpness for the
//! holes it fills, never darkness.

use glam::Vec3;
use rayon::prelude::*;

use super::Strands;
use super::strips::StripSets;

/// The reference shadow's resolution, as a multiple of the opacity map's.
pub const REFERENCE_FACTOR: u32 = 8;

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

impl View {
    /// Every pixel centre a strip covers: `hit(pixel, point, across)` for each segment (from
    /// `point` to the next) whose strip, `2 × half(point)` pixels wide, holds the pixel's centre
    /// — along the segment in [0, 1) (each joint counted once), `across` pixels from it. Rows
    /// are walked over only the span where both conditions can hold.
    fn cover(&self, s: &Strands, half: &dyn Fn(usize) -> f32, mut hit: impl FnMut(usize, usize, f32)) {
        let n = self.n as usize;
        let mut first = 0usize;
        for &seg in &s.segments {
            let last = first + seg as usize;
            for p in first..last {
                let (a, b) = (self.project(s.points[p]), self.project(s.points[p + 1]));
                let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                let len2 = dx * dx + dy * dy;
                if len2 <= 0.0 {
                    continue;
                }
                let half = half(p);
                let (x0, x1) = (floor(a.0.min(b.0) - half), ceil(a.0.max(b.0) + half));
                let (y0, y1) = (floor(a.1.min(b.1) - half), ceil(a.1.max(b.1) + half));
                let len = len2.sqrt();
                let inv_len = 1.0 / len;
                for y in y0.max(0)..y1.min(self.n) {
                    // The pixels of this row that can pass the test below: where both linear
                    // conditions hold, widened by a pixel against rounding (the test decides).
                    let py = y as f32 + 0.5 - a.1;
                    let (s0, s1) = solve(dx, -py * dy, len2 - py * dy);
                    let (c0, c1) = solve(dy, py * dx - half * len, py * dx + half * len);
                    let (from, to) = (s0.max(c0) + a.0 - 0.5, s1.min(c1) + a.0 - 0.5);
                    if from > to {
                        continue;
                    }
                    let clamp = |v: f32| v.clamp(x0 as f32 - 2.0, x1 as f32 + 2.0);
                    let (from, to) = ((floor(clamp(from)) - 1).max(x0), (ceil(clamp(to)) + 2).min(x1));
                    for x in from.max(0)..to.min(self.n) {
                        let px = x as f32 + 0.5 - a.0;
                        let t = (px * dx + py * dy) / len2;
                        let across = (px * dy - py * dx).abs() * inv_len;
                        if (0.0..1.0).contains(&t) && across <= half {
                            hit(y as usize * n + x as usize, p, across);
                        }
                    }
                }
            }
            first = last + 1;
        }
    }

    /// The shadow of the strands in this view: per pixel `1 − min(Σ α, 1)` over the strips
    /// (`width(point)` wide, opacity `alpha(point)`) covering its centre.
    fn shadow(
        &self,
        s: &Strands,
        width: &(dyn Fn(usize) -> f32 + Sync),
        alpha: &(dyn Fn(usize) -> f32 + Sync),
    ) -> Vec<f32> {
        let n = self.n as usize;
        let mut sum = vec![0.0f32; n * n];
        self.cover(s, &|p| 0.5 * width(p).max(0.0) / self.pixel, |i, p, _| sum[i] += alpha(p));
        sum.into_iter().map(|o| 1.0 - o.min(1.0)).collect()
    }

    /// The shadows of several sets in one walk over the strips: `sets[k]` is (width, opacity)
    /// of candidate `k`, widths increasing. The widest strips are walked once; each covered
    /// pixel adds, in the same order as [`View::shadow`] would, the opacity of every
    /// candidate whose strip also holds it — the same sums, without a walk per candidate.
    fn shadows(&self, s: &Strands, sets: &[(f32, f32)]) -> Vec<Vec<f32>> {
        let n = self.n as usize;
        let k_count = sets.len();
        let per_point: Vec<_> = sets.iter().map(|&set| per_point(s, set)).collect();
        let halves =
            |p: usize| -> Vec<f32> { per_point.iter().map(|(w, _)| 0.5 * w(p).max(0.0) / self.pixel).collect() };
        let widest = |p: usize| halves(p).into_iter().fold(0.0f32, f32::max);
        let mut sums = vec![0.0f32; n * n * k_count];
        let mut cached: Option<(usize, Vec<f32>, Vec<f32>)> = None;
        self.cover(s, &widest, |i, p, across| {
            if cached.as_ref().is_none_or(|c| c.0 != p) {
                cached = Some((p, halves(p), per_point.iter().map(|(_, a)| a(p)).collect()));
            }
            let (_, half, alpha) = cached.as_ref().expect("set above");
            for k in 0..k_count {
                if across <= half[k] {
                    sums[i * k_count + k] += alpha[k];
                }
            }
        });
        (0..k_count).map(|k| (0..n * n).map(|i| 1.0 - sums[i * k_count + k].min(1.0)).collect()).collect()
    }
}

/// `⌊v⌋` for values well inside the i32 range (no libm call).
fn floor(v: f32) -> i32 {
    let i = v as i32;
    if (i as f32) > v { i - 1 } else { i }
}

/// `⌈v⌉` for values well inside the i32 range.
fn ceil(v: f32) -> i32 {
    let i = v as i32;
    if (i as f32) < v { i + 1 } else { i }
}

/// The `px` with `lo ≤ px · c ≤ hi`, as an interval (everything or nothing when `c` is 0).
fn solve(c: f32, lo: f32, hi: f32) -> (f32, f32) {
    if c > 0.0 {
        (lo / c, hi / c)
    } else if c < 0.0 {
        (hi / c, lo / c)
    } else if lo <= 0.0 && 0.0 <= hi {
        (f32::NEG_INFINITY, f32::INFINITY)
    } else {
        (f32::INFINITY, f32::NEG_INFINITY)
    }
}

/// Per-point width and opacity of a set: the set's values scaled by the point's own thickness
/// and opacity, as the strips are built.
fn per_point(
    s: &Strands,
    (width, alpha): (f32, f32),
) -> (impl Fn(usize) -> f32 + Sync + '_, impl Fn(usize) -> f32 + Sync + '_) {
    let (thick_ref, alpha_ref) = (s.default_thickness, 1.0 - s.default_transparency);
    let w = move |p: usize| {
        let t = s.thickness.as_ref().map_or(thick_ref, |t| t[p]);
        width * if thick_ref > 0.0 { t / thick_ref } else { 1.0 }
    };
    let a = move |p: usize| {
        let own = 1.0 - s.transparency.as_ref().map_or(s.default_transparency, |t| t[p]);
        (alpha * if alpha_ref > 0.0 { own / alpha_ref } else { 1.0 }).clamp(0.0, 1.0)
    };
    (w, a)
}

/// One light direction: its view and the reference shadow (the shading set at
/// [`REFERENCE_FACTOR`]× the resolution, box-filtered down).
pub struct LightView {
    view: View,
    reference: Vec<f32>,
}

impl LightView {
    /// The view along `dir` at `resolution` and its reference shadow for `base`'s shading set.
    pub fn new(s: &Strands, dir: [f32; 3], resolution: u32, base: &StripSets) -> LightView {
        let view = View::new(s, dir, resolution);
        let fine = View {
            pixel: view.pixel / REFERENCE_FACTOR as f32,
            n: view.n * REFERENCE_FACTOR as i32,
            ..View::new(s, dir, resolution)
        };
        let (w, a) = per_point(s, base.shading);
        let detailed = fine.shadow(s, &w, &a);
        let (n, f) = (resolution as usize, REFERENCE_FACTOR as usize);
        let mut reference = vec![0.0f32; n * n];
        for (y, row) in detailed.chunks_exact(n * f).enumerate() {
            for (x, v) in row.iter().enumerate() {
                reference[(y / f) * n + x / f] += v;
            }
        }
        reference.iter_mut().for_each(|v| *v /= (f * f) as f32);
        LightView { view, reference }
    }

    /// The opacity set of `sets` against the reference: mean squared difference of shadow over
    /// the pixels in or beside shadow in either (visibility below 0.98), and that pixel count.
    pub fn squared_error(&self, s: &Strands, sets: &StripSets) -> (f64, usize) {
        let (w, a) = per_point(s, sets.opacity);
        self.error_of(&self.view.shadow(s, &w, &a))
    }

    /// [`LightView::squared_error`] of each opacity set of `candidates` (widths increasing), in
    /// one walk over the strips per group of candidates that fits in 256 MiB of sums.
    pub fn squared_errors(&self, s: &Strands, candidates: &[(f32, f32)]) -> Vec<(f64, usize)> {
        let pixels = (self.view.n as usize).pow(2);
        let group = ((64 << 20) / pixels).clamp(1, candidates.len().max(1));
        candidates
            .chunks(group)
            .flat_map(|sets| self.view.shadows(s, sets))
            .map(|shadow| self.error_of(&shadow))
            .collect()
    }

    fn error_of(&self, shadow: &[f32]) -> (f64, usize) {
        let (mut sq, mut n) = (0.0f64, 0usize);
        for (&c, &r) in shadow.iter().zip(&self.reference) {
            if c < 0.98 || r < 0.98 {
                sq += ((c - r) as f64).powi(2);
                n += 1;
            }
        }
        (sq / n.max(1) as f64, n)
    }
}

/// The opacity at which a set `width` wide accumulates what the shading set does per unit
/// length (`width × α` equal).
pub fn matching_alpha(sets: &StripSets, width: f32) -> f32 {
    (sets.shading.1 * sets.shading.0 / width).clamp(0.0, 1.0)
}

/// Widest opacity set tried, as a multiple of the shading width.
pub const MAX_WIDTH_RATIO: f32 = 64.0;

/// Candidate widths per doubling of the width.
const STEPS_PER_DOUBLING: u32 = 4;

/// The automatic choice: among widths from the shading width to [`MAX_WIDTH_RATIO`] times it
/// (four per doubling), each with [`matching_alpha`], the one whose light-space shadow at
/// `resolution` is nearest the reference along the six axes (mean squared error over the
/// views). Returns the sets and that RMS error.
pub fn choose(s: &Strands, base: &StripSets, resolution: u32) -> (StripSets, f64) {
    let with = |width: f32| StripSets { opacity: (width, matching_alpha(base, width)), ..*base };
    let count = (MAX_WIDTH_RATIO.log2() * STEPS_PER_DOUBLING as f32).round() as u32;
    let widths: Vec<f32> =
        (0..=count).map(|k| base.shading.0 * 2f32.powf(k as f32 / STEPS_PER_DOUBLING as f32)).collect();
    let candidates: Vec<(f32, f32)> = widths.iter().map(|&w| with(w).opacity).collect();
    let errors: Vec<Vec<(f64, usize)>> = directions()[..6]
        .par_iter()
        .map(|&d| LightView::new(s, d, resolution, base).squared_errors(s, &candidates))
        .collect();
    let scored: Vec<(f32, f64)> = widths
        .iter()
        .enumerate()
        .map(|(k, &width)| (width, errors.iter().map(|e| e[k].0).sum::<f64>() / errors.len() as f64))
        .collect();
    // The narrowest of the best (candidates are in increasing width).
    let &(width, mse) = scored.iter().min_by(|a, b| a.1.total_cmp(&b.1)).expect("at least one candidate");
    (with(width), mse.sqrt())
}
