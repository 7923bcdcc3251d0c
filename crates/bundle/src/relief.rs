//! Relief-mapping geometry (seed 003) that the baker and the runtime must agree on: the
//! hemisphere direction table of the depth maps, the surface a heightfield describes, and the
//! max-mip pyramid with the traversal that finds a ray's first hit on it.
//!
//! Space: `u`, `v` in texels (texel `(i, j)` covers `[i, i+1) × [j, j+1)`, the map repeats),
//! depth `z` normalised to `[0, 1]` from the top plane down. The relief is `thickness` texels
//! thick, so a depth of `z` lies `z × thickness` texels below the top plane. The surface is the
//! box surface of the samples: texel `(i, j)` is solid below depth `1 − h(i, j)` (`h` in
//! `[0, 1]`), which is what `textureLoad` sees on the GPU and what a max-mip pyramid bounds
//! exactly.
//!
//! A ray is parameterised by its length `s` in texel units: `uv(s) = origin + s × dir_uv`,
//! `z(s) = s × dir_z / thickness`, with `dir = (dir_uv, dir_z)` a unit vector, `dir_z > 0`
//! pointing down into the relief.

use std::f32::consts::{FRAC_PI_2, TAU};

/// The sample directions of a depth-map set: `theta` rows from the zenith times `phi`
/// azimuths. Layer `i × phi + j` holds `θ_i = (i + ½)·(π/2)/theta` and `φ_j = 2πj/phi` (azimuth
/// in texel space from +u toward +v, as everywhere in hikage); it is the direction a ray travels
/// into the relief.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReliefDirections {
    /// Rows of zenith angle.
    pub theta: u32,
    /// Azimuths per row.
    pub phi: u32,
}

impl ReliefDirections {
    /// Number of directions (layers of the depth-map array).
    pub fn layers(&self) -> u32 {
        self.theta * self.phi
    }

    /// `(θ, φ)` of a layer, radians.
    pub fn angles(&self, layer: u32) -> (f32, f32) {
        let (i, j) = (layer / self.phi, layer % self.phi);
        ((i as f32 + 0.5) * FRAC_PI_2 / self.theta as f32, TAU * j as f32 / self.phi as f32)
    }

    /// Unit travel direction of a layer (`z` positive = down into the relief).
    pub fn direction(&self, layer: u32) -> [f32; 3] {
        let (theta, phi) = self.angles(layer);
        [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()]
    }

    /// The layer whose stored hit a ray along `dir` (any length, `z` down) starts from, by
    /// `rule`; the azimuth is always the nearest.
    pub fn pick(&self, dir: [f32; 3], rule: DirectionRule) -> u32 {
        let horizontal = (dir[0] * dir[0] + dir[1] * dir[1]).sqrt();
        let theta = horizontal.atan2(dir[2].max(0.0));
        let rows = theta / FRAC_PI_2 * self.theta as f32;
        let row = match rule {
            // The band holding θ; a tie goes to the row nearer the zenith.
            DirectionRule::Nearest => rows.ceil() as i64 - 1,
            // The nearest row whose θ is not larger than the ray's.
            DirectionRule::Zenith => (rows - 0.5).floor() as i64,
        };
        let row = row.clamp(0, self.theta as i64 - 1) as u32;
        // Written the way the WGSL mirror computes it (no rem_euclid, round half up).
        let phi = dir[1].atan2(dir[0]);
        let phi = if phi < 0.0 { phi + TAU } else { phi };
        let col = ((phi / TAU * self.phi as f32 + 0.5).floor() as u32) % self.phi;
        row * self.phi + col
    }
}

/// Which zenith row of the direction table a ray's depth-map estimate is read from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum DirectionRule {
    /// The row nearest the ray's zenith angle.
    Nearest,
    /// The nearest row at or above the ray (closer to the zenith), as seed 003 prescribes: a
    /// steeper sample ray meets the relief no later along the view ray, so the estimate tends
    /// to land before the nearest bump rather than beyond it.
    #[default]
    Zenith,
}

impl DirectionRule {
    /// The value of the WGSL uniform's `direction_rule` field.
    pub fn code(self) -> u32 {
        match self {
            DirectionRule::Nearest => 0,
            DirectionRule::Zenith => 1,
        }
    }
}

/// A max-mip pyramid of a heightfield: level 0 holds the samples, each further level the
/// largest of the 2×2 texels below it, down to a single row or column. Both sides must be
/// powers of two so the pyramid tiles like the map.
#[derive(Clone, Debug, PartialEq)]
pub struct MaxMip {
    width: u32,
    height: u32,
    levels: Vec<Vec<f32>>,
}

impl MaxMip {
    /// Builds the pyramid of row-major samples in `[0, 1]`.
    pub fn new(width: u32, height: u32, samples: Vec<f32>) -> Result<MaxMip, String> {
        check_power_of_two(width, height)?;
        if samples.len() != width as usize * height as usize {
            return Err(format!("{} samples for a {width}×{height} map", samples.len()));
        }
        let mut levels = vec![samples];
        let (mut w, mut h) = (width as usize, height as usize);
        while w > 1 && h > 1 {
            let prev = levels.last().expect("level 0 exists");
            let (nw, nh) = (w / 2, h / 2);
            let mut next = Vec::with_capacity(nw * nh);
            for j in 0..nh {
                for i in 0..nw {
                    let a = &prev[2 * j * w + 2 * i..];
                    let b = &prev[(2 * j + 1) * w + 2 * i..];
                    next.push(a[0].max(a[1]).max(b[0]).max(b[1]));
                }
            }
            levels.push(next);
            (w, h) = (nw, nh);
        }
        Ok(MaxMip { width, height, levels })
    }

    /// A pyramid from levels read back from a texture (level 0 first), checked for shape.
    pub fn from_levels(width: u32, height: u32, levels: Vec<Vec<f32>>) -> Result<MaxMip, String> {
        let expected = MaxMip::level_count_for(width, height);
        check_power_of_two(width, height)?;
        if levels.len() != expected as usize {
            return Err(format!("{} levels for a {width}×{height} max-mip pyramid, expected {expected}", levels.len()));
        }
        for (l, data) in levels.iter().enumerate() {
            let n = (width >> l) as usize * (height >> l) as usize;
            if data.len() != n {
                return Err(format!("level {l} holds {} samples, expected {n}", data.len()));
            }
        }
        Ok(MaxMip { width, height, levels })
    }

    /// Levels of the pyramid of a `width × height` map.
    pub fn level_count_for(width: u32, height: u32) -> u32 {
        width.min(height).max(1).ilog2() + 1
    }

    /// Width of level 0.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height of level 0.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Number of levels.
    pub fn levels(&self) -> u32 {
        self.levels.len() as u32
    }

    /// The samples of a level, row-major.
    pub fn level(&self, level: u32) -> &[f32] {
        &self.levels[level as usize]
    }

    /// Largest sample of block `(i, j)` of `level` (block size `2^level`), wrapping.
    #[inline]
    pub fn max_height(&self, level: u32, i: i64, j: i64) -> f32 {
        let (w, h) = ((self.width >> level) as i64, (self.height >> level) as i64);
        // Sides are powers of two, so a mask is the Euclidean remainder (negatives included).
        self.levels[level as usize][((j & (h - 1)) * w + (i & (w - 1))) as usize]
    }

    /// Height of the texel under a point (level 0, wrapping).
    #[inline]
    pub fn height_at(&self, u: f32, v: f32) -> f32 {
        self.max_height(0, u.floor() as i64, v.floor() as i64)
    }
}

fn check_power_of_two(width: u32, height: u32) -> Result<(), String> {
    if !width.is_power_of_two() || !height.is_power_of_two() {
        return Err(format!("relief maps need power-of-two sides (they tile), found {width}×{height}"));
    }
    Ok(())
}

/// A ray into the relief (see the module docs for its parameterisation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReliefRay {
    /// Entry point on the top plane, texels.
    pub origin: [f32; 2],
    /// Unit travel direction, `z` down (> 0).
    pub dir: [f32; 3],
    /// Relief thickness, texels.
    pub thickness: f32,
}

impl ReliefRay {
    /// Depth per unit of `s`.
    #[inline]
    pub fn dz(&self) -> f32 {
        self.dir[2] / self.thickness
    }

    /// Length at which the ray reaches the bottom plane (depth 1), where every ray ends.
    #[inline]
    pub fn s_bottom(&self) -> f32 {
        self.thickness / self.dir[2]
    }

    /// `(u, v, z)` at length `s`.
    #[inline]
    pub fn at(&self, s: f32) -> [f32; 3] {
        [self.origin[0] + s * self.dir[0], self.origin[1] + s * self.dir[1], s * self.dz()]
    }

    /// True when the point at length `s` is inside the solid (a height-map read).
    #[inline]
    pub fn inside(&self, mm: &MaxMip, s: f32) -> bool {
        let [u, v, z] = self.at(s);
        z >= 1.0 - mm.height_at(u, v)
    }
}

/// How far ahead (texels along the ray) a traversal looks to decide which block a point on a
/// boundary belongs to; far above f32 rounding of texel positions, far below a texel.
pub const BOUNDARY_NUDGE: f32 = 1e-3;

/// Safety cap on traversal steps; a ray never needs more than a few per texel it crosses.
pub const MAX_TRAVERSAL_STEPS: u32 = 1 << 16;

/// First hit of `ray` on the box surface with length in `span = (start, stop)`, by max-mip traversal
/// (Tevs et al. 2008): above a block's top the ray skips to the block's top or exit, whichever
/// comes first; leaving a block it climbs one level, meeting a top it descends. Exact on the box
/// surface up to f32 rounding. Starts at `start_level` (clamped to the pyramid), stops refining
/// at `stop_level` (0 for the exact hit; higher gives the hit on that level's blocks):
/// `levels = (start_level, stop_level)`. Returns the hit length, or `stop` (at most the bottom
/// plane, where every ray ends) when there is none before it, and adds the samples read to
/// `reads`.
pub fn first_hit_maxmip(mm: &MaxMip, ray: &ReliefRay, span: (f32, f32), levels: (u32, u32), reads: &mut u32) -> f32 {
    let top = mm.levels() - 1;
    let stop = levels.1.min(top);
    let mut level = levels.0.clamp(stop, top);
    let dz = ray.dz();
    let s_end = span.1.min(ray.s_bottom());
    let s_start = span.0;
    let [dx, dy, _] = ray.dir;
    let mut s = s_start.max(0.0);
    // Reciprocals keep divisions out of the loop; an axis the ray does not move along never
    // exits (infinite time).
    let inv = |d: f32| if d == 0.0 { f32::INFINITY } else { 1.0 / d };
    let (ix, iy) = (inv(dx), inv(dy));
    let [ox, oy] = ray.origin;
    for _ in 0..MAX_TRAVERSAL_STEPS {
        if s >= s_end {
            return s_end;
        }
        let size = (1u32 << level) as f32;
        let inv_size = 1.0 / size; // exact: a power of two
        // A point on a block boundary belongs to the block the ray goes into: look a hair ahead.
        let ahead = s + BOUNDARY_NUDGE;
        let ci = ((ox + ahead * dx) * inv_size).floor();
        let cj = ((oy + ahead * dy) * inv_size).floor();
        *reads += 1;
        let top_depth = 1.0 - mm.max_height(level, ci as i64, cj as i64);
        if s * dz >= top_depth {
            if level == stop {
                return s;
            }
            level -= 1;
            continue;
        }
        let s_top = top_depth / dz;
        let wall_x = if dx > 0.0 { (ci + 1.0) * size } else { ci * size };
        let wall_y = if dy > 0.0 { (cj + 1.0) * size } else { cj * size };
        let tx = if dx == 0.0 { f32::INFINITY } else { (wall_x - ox) * ix };
        let ty = if dy == 0.0 { f32::INFINITY } else { (wall_y - oy) * iy };
        let s_exit = tx.min(ty);
        if s_top <= s_exit {
            s = s_top;
            if level == stop {
                return s.min(s_end);
            }
            level -= 1;
        } else {
            s = s_exit.max(s);
            level = (level + 1).min(top);
        }
    }
    s.min(s_end)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f32 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 40) as f32 / (1u64 << 24) as f32
    }

    #[test]
    fn pyramid_levels_hold_block_maxima() {
        let mut seed = 1;
        let samples: Vec<f32> = (0..16 * 8).map(|_| lcg(&mut seed)).collect();
        let mm = MaxMip::new(16, 8, samples.clone()).unwrap();
        assert_eq!(mm.levels(), 4);
        for l in 1..mm.levels() {
            let size = 1usize << l;
            for j in 0..(8 >> l) {
                for i in 0..(16 >> l) {
                    let mut m: f32 = 0.0;
                    for y in j * size..(j + 1) * size {
                        for x in i * size..(i + 1) * size {
                            m = m.max(samples[y * 16 + x]);
                        }
                    }
                    assert_eq!(mm.max_height(l, i as i64, j as i64), m);
                }
            }
        }
        assert!(MaxMip::new(12, 8, vec![0.0; 96]).is_err());
    }

    /// The traversal against a march in steps of 1/64 texel on random maps and rays.
    #[test]
    fn traversal_matches_a_fine_march() {
        let mut seed = 7;
        let n = 32;
        let samples: Vec<f32> = (0..n * n).map(|_| lcg(&mut seed).powi(3)).collect();
        let mm = MaxMip::new(n as u32, n as u32, samples).unwrap();
        let mut worst: f32 = 0.0;
        for _ in 0..2000 {
            let theta = lcg(&mut seed) * 1.45;
            let phi = lcg(&mut seed) * TAU;
            let ray = ReliefRay {
                origin: [lcg(&mut seed) * n as f32, lcg(&mut seed) * n as f32],
                dir: [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()],
                thickness: 6.0,
            };
            let mut reads = 0;
            let fast = first_hit_maxmip(&mm, &ray, (0.0, f32::INFINITY), (99, 0), &mut reads);
            let step = 1.0 / 64.0;
            let mut s = 0.0;
            while s < ray.s_bottom() && !ray.inside(&mm, s) {
                s += step;
            }
            let slow = s.min(ray.s_bottom());
            // Never later than the march (nothing missed), and a real hit: inside just after
            // it. It may be earlier where the ray clips a corner between two march steps.
            assert!(fast <= slow + 0.01, "fast {fast} slow {slow} ray {ray:?}");
            let hit = [0.0, 1e-4, 1e-3].iter().any(|e| ray.inside(&mm, fast + e));
            assert!(fast >= ray.s_bottom() - 1e-3 || hit, "fast {fast} not inside, {ray:?}");
            worst = worst.max(slow - fast);
        }
        assert!(worst > 0.0);
    }

    #[test]
    fn a_table_direction_picks_its_own_layer_by_the_nearest_rule() {
        let dirs = ReliefDirections { theta: 8, phi: 12 };
        for layer in 0..dirs.layers() {
            assert_eq!(dirs.pick(dirs.direction(layer), DirectionRule::Nearest), layer);
        }
        // Straight down falls in the first row by either rule.
        assert_eq!(dirs.pick([0.0, 0.0, 1.0], DirectionRule::Nearest) / 12, 0);
        assert_eq!(dirs.pick([0.0, 0.0, 1.0], DirectionRule::Zenith) / 12, 0);
    }

    /// Rows by hand on a 4-row table (rows at 11.25°, 33.75°, 56.25°, 78.75°, bands 22.5° wide):
    /// the nearest rule takes the band, the zenith rule the row at or above.
    #[test]
    fn row_choice_of_both_rules() {
        let dirs = ReliefDirections { theta: 4, phi: 1 };
        let at = |deg: f32| {
            let t = deg.to_radians();
            [t.sin(), 0.0, t.cos()]
        };
        for (deg, nearest, zenith) in [
            (5.0, 0, 0),
            (11.0, 0, 0),
            (12.0, 0, 0),
            (20.0, 0, 0),
            (23.0, 1, 0),
            (33.0, 1, 0),
            (34.5, 1, 1),
            (50.0, 2, 1),
            (57.0, 2, 2),
            (70.0, 3, 2),
            (80.0, 3, 3),
            (89.9, 3, 3),
        ] {
            assert_eq!(dirs.pick(at(deg), DirectionRule::Nearest), nearest, "nearest at {deg}°");
            assert_eq!(dirs.pick(at(deg), DirectionRule::Zenith), zenith, "zenith at {deg}°");
        }
    }
}
