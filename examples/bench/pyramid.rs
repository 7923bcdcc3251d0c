//! Levels of detail of a tiled horizon bake (issue 38): how often level `k` disagrees with
//! level 0 about a point being lit, at the same points (level `k`'s node `(i, j)` is level 0's
//! texel `(i·2^k, j·2^k)`), for suns at 2–30° at every baked azimuth. Level `k` is baked from
//! the map reduced by `2^k`: with the mean height of each node's footprint (the rule the
//! baker uses) and, for comparison, with the largest; and, as the conservative alternative, as
//! the largest level-0 slope of the footprint (its time is the reduction's alone: it needs
//! level 0's horizons first). "False light": lit at level `k` where level 0 shadows; "false
//! shadow": the reverse. Then the time of each level against level 0's bake.

use hikage_bake::heightfield::Heightfield;
use hikage_bake::horizon::{self, HorizonFormat, HorizonParams};
use hikage_bundle::EdgeMode;

use crate::best_of;

const ELEVATIONS: [f64; 5] = [2.0, 5.0, 10.0, 20.0, 30.0];
const DIRECTIONS: u32 = 32;

/// `tan β` of every texel and direction, `[direction][row][column]`.
fn slopes(hf: &Heightfield, max_distance: f32) -> (f64, Vec<f32>) {
    let params = HorizonParams {
        directions: DIRECTIONS,
        edge: EdgeMode::Clamp,
        max_distance: Some(max_distance),
        format: HorizonFormat::Rg32Float,
        ..HorizonParams::default()
    };
    let (t, baked) = best_of(2, || horizon::bake(hf, &params, &|_, _| {}).expect("valid settings"));
    let level = &baked.texture.levels[0];
    (t, level.chunks_exact(8).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
}

/// `hf` reduced by `2^k` on a clamped map, each node the largest (`max`) or mean height of
/// the texels within `2^(k-1)` of it along each axis.
fn reduce(hf: &Heightfield, k: u32, max: bool) -> Heightfield {
    let s = 1i64 << k;
    let (w, h) = (hf.width as i64, hf.height as i64);
    let (cw, ch) = ((w - 1) / s + 1, (h - 1) / s + 1);
    let mut out = Vec::with_capacity((cw * ch) as usize);
    for j in 0..ch {
        for i in 0..cw {
            let (mut m, mut sum, mut n) = (f32::NEG_INFINITY, 0.0f64, 0u32);
            for y in (j * s - s / 2).max(0)..=(j * s + s / 2).min(h - 1) {
                let mut row = 0.0f64;
                for x in (i * s - s / 2).max(0)..=(i * s + s / 2).min(w - 1) {
                    let v = hf.samples[(y * w + x) as usize];
                    m = m.max(v);
                    row += v as f64;
                    n += 1;
                }
                sum += row;
            }
            out.push(if max { m } else { (sum / n as f64) as f32 });
        }
    }
    let mut r = Heightfield::from_samples(cw as u32, ch as u32, out);
    r.texel_size = (hf.texel_size.0 * s as f32, hf.texel_size.1 * s as f32);
    r.height_scale = hf.height_scale;
    r
}

#[derive(Clone, Copy, PartialEq)]
enum Rule {
    /// Baked from the map reduced by the largest height.
    MaxHeights,
    /// Baked from the map reduced by the mean height (the baker's rule).
    MeanHeights,
    /// The largest level-0 slope of the node's footprint, per direction: never lights a node
    /// level 0 shadows, but needs level 0's horizons over the footprint.
    MaxHorizons,
}

impl Rule {
    fn name(self) -> &'static str {
        match self {
            Rule::MaxHeights => "bake of max heights",
            Rule::MeanHeights => "bake of mean heights (the baker's)",
            Rule::MaxHorizons => "max of level-0 slopes",
        }
    }
}

/// Level 0's slopes (`[direction][row][column]` of an `n`² map) reduced by `2^k`: each node
/// the largest of its footprint's, per direction.
fn max_horizons(base: &[f32], n: usize, k: u32) -> Vec<f32> {
    let s = 1i64 << k;
    let c = ((n as i64 - 1) / s + 1) as usize;
    let mut out = Vec::with_capacity(DIRECTIONS as usize * c * c);
    for d in 0..DIRECTIONS as usize {
        for j in 0..c as i64 {
            for i in 0..c as i64 {
                let mut m = f32::NEG_INFINITY;
                for y in (j * s - s / 2).max(0)..=(j * s + s / 2).min(n as i64 - 1) {
                    for x in (i * s - s / 2).max(0)..=(i * s + s / 2).min(n as i64 - 1) {
                        m = m.max(base[(d * n + y as usize) * n + x as usize]);
                    }
                }
                out.push(m);
            }
        }
    }
    out
}

pub fn run() {
    let threads = rayon::current_num_threads();
    let n = 1024u32;
    let mut hf = Heightfield::from_samples(n, n, hikage_devkit::synth::terrain(n));
    // 30 m texels, 1.2 km of relief; horizons searched 6 km out.
    hf.texel_size = (30.0, 30.0);
    hf.height_scale = 1200.0;
    let max_distance = 6000.0;
    println!(
        "Pyramid levels against level 0 at the same points: devkit terrain {n}² (30 m texels, 1.2 km relief), \
         {DIRECTIONS} directions, max_distance 6 km, clamped; suns at {ELEVATIONS:?}° at every azimuth; {threads} threads\n"
    );
    let (t0, base) = slopes(&hf, max_distance);
    println!(
        "| level | nodes | reduction | false light | false shadow | false light at 2° | 5° | 10° | 20° | 30° | bake | vs level 0 |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for k in 1..=4u32 {
        for rule in [Rule::MeanHeights, Rule::MaxHeights, Rule::MaxHorizons] {
            let coarse = reduce(&hf, k, rule == Rule::MaxHeights);
            let (cw, ch) = (coarse.width as usize, coarse.height as usize);
            let s = 1usize << k;
            let (t, slopes_k) = match rule {
                Rule::MaxHorizons => best_of(2, || max_horizons(&base, n as usize, k)),
                _ => slopes(&coarse, max_distance),
            };
            let (mut light, mut shadow, mut tests) = (0usize, 0usize, 0usize);
            let mut light_at = [0usize; ELEVATIONS.len()];
            for d in 0..DIRECTIONS as usize {
                for j in 0..ch {
                    for i in 0..cw {
                        let fine = base[(d * n as usize + j * s) * n as usize + i * s] as f64;
                        let coarse = slopes_k[(d * ch + j) * cw + i] as f64;
                        for (e, at) in ELEVATIONS.iter().zip(light_at.iter_mut()) {
                            let sun = e.to_radians().tan();
                            let (lit0, litk) = (sun > fine, sun > coarse);
                            tests += 1;
                            if litk && !lit0 {
                                light += 1;
                                *at += 1;
                            } else if lit0 && !litk {
                                shadow += 1;
                            }
                        }
                    }
                }
            }
            let per_sun = tests / ELEVATIONS.len();
            let at: String =
                light_at.iter().map(|&c| format!(" {:.2}% |", 100.0 * c as f64 / per_sun as f64)).collect();
            println!(
                "| {k} | {cw}×{ch} | {} | {:.2}% | {:.2}% |{at} {:.2} s | {:.3}× |",
                rule.name(),
                100.0 * light as f64 / tests as f64,
                100.0 * shadow as f64 / tests as f64,
                t,
                t / t0,
            );
        }
    }
    println!("\nLevel 0: {n}², {t0:.2} s.\n");
}
