//! Block compression's accuracy cost (issue 31): relief depth maps through BC4 and horizon
//! angles through BC5, each with the plain (nearest) encoder and the conservative one the
//! `Bc4RUnorm` and `Bc5RgUnorm` formats bake with (`hikage_bake::bc4`), against the maps as
//! baked.

use hikage_bake::bc4::{self, Side};
use hikage_bake::heightfield::{Heightfield, LoadOptions, load_samples};
use hikage_bake::horizon::{self, HorizonFormat, HorizonParams};
use hikage_bake::relief::{self, ReliefParams};
use hikage_bundle::EdgeMode;

/// Sun elevations (degrees) of the horizon shadow test.
const ELEVATIONS: [f64; 5] = [2.0, 5.0, 10.0, 20.0, 30.0];

pub fn run() {
    relief_rows();
    relief_reads_rows();
    horizon_rows();
}

fn heightfield(path: &str) -> Heightfield {
    let s = load_samples(std::path::Path::new(path), &LoadOptions::default())
        .expect("run from the repository root (data/ is read)");
    Heightfield::from_samples(s.width, s.height, s.values)
}

/// Relief depth maps (R8, the default 32 × 16 directions of 32² maps) through BC4: texels
/// decoded deeper than the stored depth (the promise: never a hit deeper than the true first
/// hit), and the error.
fn relief_rows() {
    println!("Relief depth maps through BC4 (0.5× the R8 maps' memory), against the maps as baked:\n");
    println!("| map | encoder | texels decoded deeper (promise broken) | mean error | max error |");
    println!("|---|---|---|---|---|");
    for name in ["bricks", "fbm", "spikes"] {
        let hf = heightfield(&format!("data/relief_{name}.png"));
        let baked = relief::bake(&hf, &ReliefParams::default(), &|_, _| {}).expect("valid settings");
        let d = &baked.depth.desc;
        let (w, h) = (d.width as usize, d.height as usize);
        let layers: Vec<&[u8]> = baked.depth.levels[0].chunks_exact(w * h).collect();
        for (encoder, side) in [("plain (nearest)", Side::Nearest), ("conservative (never deeper)", Side::Below)] {
            let (mut deeper, mut sum, mut max, mut n) = (0usize, 0f64, 0f32, 0usize);
            for layer in &layers {
                for (decoded, &t) in bc4::round_trip(layer, w, h, side).into_iter().zip(layer.iter()) {
                    deeper += (decoded > t as f32) as usize;
                    sum += (decoded - t as f32).abs() as f64;
                    max = max.max((decoded - t as f32).abs());
                    n += 1;
                }
            }
            println!(
                "| {name} | {encoder} | {deeper} of {n} ({:.1}%) | {:.2}/255 | {:.1}/255 |",
                100.0 * deeper as f64 / n as f64,
                sum / n as f64,
                max
            );
        }
    }
    println!();
}

/// What BC4 costs the relief tracers: the cheapest depth-map and combined tracer settings that
/// meet the relief table's bar (≤ 1% of rays more than a texel from a 1/16-texel march) on the
/// maps as baked and through BC4, and how many rays of that setting stop deeper than the march's
/// first hit (by more than a texel).
fn relief_reads_rows() {
    use hikage_runtime::relief::reference::{Reads, fine_march};
    use hikage_runtime::relief::{DirectionRule, Tracer};
    use rayon::prelude::*;
    println!(
        "Relief reads per ray through BC4 (the relief table's rays and bar; 32² 8-bit maps, 512 directions):
"
    );
    println!(
        "| map | depth maps | cheapest setting meeting the bar | rays > 1 texel | height reads | depth-map reads | total | rays past the first hit |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for name in ["fbm", "bricks", "spikes"] {
        let hf = crate::relief::load(name);
        let params = ReliefParams::default();
        let baked = crate::relief::maps_of(&hf, &params, DirectionRule::default());
        let rays = crate::relief::rays(&baked);
        let truth: Vec<f32> = rays.par_iter().map(|r| fine_march(&baked.max_mip, r)).collect();
        let (w, h) = (baked.depth_size.0 as usize, baked.depth_size.1 as usize);
        let families: Vec<Vec<Tracer>> = crate::relief::candidates(baked.max_mip.levels() - 1)
            .into_iter()
            .filter(|l| matches!(l[0], Tracer::DepthMap { .. } | Tracer::Combined { .. }))
            .collect();
        for (label, side) in
            [("as baked", None), ("BC4, plain", Some(Side::Nearest)), ("BC4, conservative", Some(Side::Below))]
        {
            let mut maps = baked.clone();
            if let Some(side) = side {
                let bytes: Vec<u8> = baked.depth.iter().map(|&d| (d * 255.0).round() as u8).collect();
                maps.depth = bytes
                    .chunks_exact(w * h)
                    .flat_map(|layer| bc4::round_trip(layer, w, h, side))
                    .map(|v| v / 255.0)
                    .collect();
            }
            for list in &families {
                let outcome = crate::relief::cheapest(&maps, list, &rays, &truth);
                let tracer = match &outcome {
                    Ok((t, _)) | Err((t, _)) => *t,
                };
                let past = rays
                    .par_iter()
                    .zip(&truth)
                    .filter(|(ray, t)| maps.trace(tracer, ray, &mut Reads::default()) > **t + 1.0)
                    .count();
                let row = format!("{label}, {}", list[0].name());
                // The relief table's row, then the overshooting rays.
                print!("{}", capture_row(name, &row, outcome));
                println!(" {past} |");
            }
        }
    }
    println!();
}

/// The relief table's row for `outcome`, without its last column or line end.
fn capture_row(map: &str, label: &str, outcome: Result<crate::relief::Outcome, crate::relief::Outcome>) -> String {
    let (met, (t, (bad, height, depth))) = match outcome {
        Ok(o) => ("", o),
        Err(o) => ("none reaches the bar; best: ", o),
    };
    format!("| {map} | {label} | {met}{t:?} | {:.2}% | {height:.1} | {depth:.1} | {:.1} |", 100.0 * bad, height + depth)
}

/// Horizon angles of the default terrain (512² × 32 directions) through BC5's angle channel
/// (stored as rg8's β/π + 0.5): angle errors against the float bake, and the shadow test's
/// flips, light leaks among them (shadowed by the float bake, lit after compression).
fn horizon_rows() {
    let mut hf = heightfield("data/terrain.png");
    hf.texel_size = (80.0, 60.0);
    hf.height_scale = 1500.0;
    let params = HorizonParams {
        directions: 32,
        edge: EdgeMode::Clamp,
        format: HorizonFormat::Rg32Float,
        ..HorizonParams::default()
    };
    let baked = horizon::bake(&hf, &params, &|_, _| {}).expect("valid settings");
    let (w, h) = (hf.width as usize, hf.height as usize);
    let level = &baked.texture.levels[0];
    let beta: Vec<f64> = (0..w * h * 32)
        .map(|i| {
            let o = i * 8;
            (f32::from_le_bytes([level[o], level[o + 1], level[o + 2], level[o + 3]]) as f64).atan()
        })
        .collect();
    let unorm = |b: f64| (b / std::f64::consts::PI + 0.5) * 255.0;
    println!("Horizon angles through BC5 (1 byte a texel for angle and distance: 0.25× rg16f, 0.5× rg8),");
    println!("default terrain 512² × 32 directions, against the float bake; suns at {ELEVATIONS:?}°:\n");
    println!("| storage | max angle error | p99 | shadow flips | light leaks among them |");
    println!("|---|---|---|---|---|");
    let cases: [(&str, Store); 4] = [
        ("rg8 (β rounded)", Box::new(move |s: &[f64]| s.iter().map(|&b| unorm(b).round()).collect())),
        (
            "BC5, plain (β rounded, nearest)",
            Box::new(move |s: &[f64]| {
                through_bc4(s.iter().map(|&b| unorm(b).round() as u8).collect(), w, h, Side::Nearest)
            }),
        ),
        ("rg8, β rounded up", Box::new(move |s: &[f64]| s.iter().map(|&b| unorm(b).ceil()).collect())),
        (
            "BC5, conservative (β rounded up, never below)",
            Box::new(move |s: &[f64]| {
                through_bc4(s.iter().map(|&b| unorm(b).ceil().min(255.0) as u8).collect(), w, h, Side::Above)
            }),
        ),
    ];
    let mut by_elevation = Vec::new();
    for (name, store) in cases {
        let (mut errors, mut flips, mut leaks) = (Vec::with_capacity(beta.len()), 0usize, 0usize);
        let mut flips_at = [0usize; ELEVATIONS.len()];
        for slice in beta.chunks_exact(w * h) {
            for (&b, stored) in slice.iter().zip(store(slice)) {
                let got = (stored / 255.0 - 0.5) * std::f64::consts::PI;
                errors.push((got - b).abs().to_degrees() as f32);
                for (k, e) in ELEVATIONS.map(f64::to_radians).into_iter().enumerate() {
                    if (e > b) != (e > got) {
                        flips += 1;
                        flips_at[k] += 1;
                        leaks += (e > got) as usize;
                    }
                }
            }
        }
        errors.sort_by(f32::total_cmp);
        println!(
            "| {name} | {:.2}° | {:.2}° | {flips} ({:.2}%) | {leaks} |",
            errors.last().copied().unwrap_or(0.0),
            errors[errors.len() * 99 / 100],
            100.0 * flips as f64 / (beta.len() * ELEVATIONS.len()) as f64
        );
        by_elevation.push((name, flips_at));
    }
    // The average hides the low suns, where horizons are tested at the angles they are stored
    // at and most flips happen: each sun on its own.
    println!("\nShadow tests flipped at each sun elevation (share of {} tests per sun):\n", beta.len());
    println!("| storage |{}", ELEVATIONS.map(|e| format!(" sun {e}° |")).concat());
    println!("|---|{}", "---|".repeat(ELEVATIONS.len()));
    for (name, flips_at) in by_elevation {
        let cells = flips_at.map(|f| format!(" {:.2}% |", 100.0 * f as f64 / beta.len() as f64)).concat();
        println!("| {name} |{cells}");
    }
    println!();
}

/// How one storage turns a slice of true angles into what it reads back (units of 1/255).
type Store = Box<dyn Fn(&[f64]) -> Vec<f64>>;

/// A slice of 8-bit values through BC4 with `side`, back in units of 1/255.
fn through_bc4(v: Vec<u8>, w: usize, h: usize, side: Side) -> Vec<f64> {
    bc4::round_trip(&v, w, h, side).into_iter().map(f64::from).collect()
}
