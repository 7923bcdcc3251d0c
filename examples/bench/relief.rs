//! Relief depth maps: bake time against a brute-force march, and reads per ray of the four
//! tracers at equal accuracy on the three heightfield families of `data/`.

use std::path::Path;

use hikage_bake::heightfield::{Heightfield, LoadOptions, load_samples};
use hikage_bake::relief::{self, ReliefParams};
use hikage_bundle::relief::{MaxMip, ReliefRay, first_hit_maxmip};
use hikage_devkit::brute_force;
use hikage_devkit::synth;
use hikage_runtime::relief::{Reads, ReliefMaps, Tracer, fine_march};
use rayon::prelude::*;

use crate::best_of;

/// View angles from the normal, degrees, and rays per angle (9 × 2,500 = 22,500 per family).
const ANGLES: [f32; 9] = [0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0];
const RAYS_PER_ANGLE: usize = 2500;
/// The accuracy bar: at most this share of rays ends more than one texel from the ground truth.
const BAR: f64 = 0.01;

fn load(name: &str) -> Heightfield {
    let path = Path::new("data").join(format!("relief_{name}.png"));
    let s = load_samples(&path, &LoadOptions::default()).expect("run from the repository root (data/ is read)");
    Heightfield::from_samples(s.width, s.height, s.values)
}

fn rays(maps: &ReliefMaps) -> Vec<ReliefRay> {
    let mut seed = 0x9e3779b97f4a7c15u64;
    let mut next = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 40) as f32 / (1u64 << 24) as f32
    };
    let (w, h) = (maps.max_mip.width() as f32, maps.max_mip.height() as f32);
    let mut out = Vec::new();
    for angle in ANGLES {
        let theta = angle.to_radians();
        for _ in 0..RAYS_PER_ANGLE {
            let (u, v, phi) = (next() * w, next() * h, next() * std::f32::consts::TAU);
            out.push(maps.ray([u, v], [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()]));
        }
    }
    out
}

/// The relief baker before square floors: every ray traced from the top plane, capped at its
/// block's shallowest hit so far; the same maps.
fn previous_bake(hf: &Heightfield, params: &ReliefParams) -> Vec<f32> {
    let mm = MaxMip::new(hf.width, hf.height, relief::stored_heights(hf).expect("in range")).expect("power of two");
    let dirs = params.directions();
    let thickness = params.depth_scale * hf.width as f32;
    let factor = hf.width / params.output_width(hf.width);
    let (ow, oh) = (hf.width / factor, hf.height / factor);
    let layers: Vec<Vec<f32>> = (0..dirs.layers())
        .into_par_iter()
        .map(|layer| {
            let dir = dirs.direction(layer);
            let dz = dir[2] / thickness;
            let mut out = Vec::with_capacity((ow * oh) as usize);
            for bj in 0..oh {
                for bi in 0..ow {
                    let mut block_min = 1.0f32;
                    for j in bj * factor..(bj + 1) * factor {
                        for i in bi * factor..(bi + 1) * factor {
                            let ray = ReliefRay { origin: [i as f32 + 0.5, j as f32 + 0.5], dir, thickness };
                            let stop = block_min / dz;
                            let s = first_hit_maxmip(&mm, &ray, (0.0, stop), (3, 0), &mut 0);
                            if s < stop {
                                block_min = block_min.min(s * dz);
                            }
                        }
                    }
                    out.push(params.format.round_down(block_min));
                }
            }
            out
        })
        .collect();
    layers.concat()
}

/// Share of rays more than a texel off, and the mean reads.
fn evaluate(maps: &ReliefMaps, tracer: Tracer, rays: &[ReliefRay], truth: &[f32]) -> (f64, f64, f64) {
    let (bad, height, depth) = rays
        .par_iter()
        .zip(truth)
        .map(|(ray, &t)| {
            let mut reads = Reads::default();
            let s = maps.trace(tracer, ray, &mut reads);
            (((s - t).abs() > 1.0) as u64, reads.height as u64, reads.depth as u64)
        })
        .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
    let n = rays.len() as f64;
    (bad as f64 / n, height as f64 / n, depth as f64 / n)
}

fn candidates(top: u32) -> Vec<Vec<Tracer>> {
    // Steps about 1.2× apart from 4 to 2048.
    let steps: Vec<u32> = (0..35).map(|k| (4.0 * 1.2f64.powi(k)).round() as u32).filter(|&s| s <= 2048).collect();
    let binary = [0u32, 1, 2, 3, 4, 6, 8];
    let grid = |f: fn(u32, u32) -> Tracer| -> Vec<Tracer> {
        steps.iter().flat_map(|&s| binary.iter().map(move |&b| f(s, b))).collect()
    };
    vec![
        grid(|steps, binary| Tracer::Linear { steps, binary }),
        grid(|steps, binary| Tracer::DepthMap { steps, binary }),
        (0..=top).flat_map(|s| (0..=1).map(move |e| Tracer::MaxMip { start_level: s, stop_level: e })).collect(),
        [0.0f32, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5]
            .iter()
            .flat_map(|&m| (0..=top).map(move |s| Tracer::Combined { margin: m, start_level: s }))
            .collect(),
    ]
}

fn setting(t: &Tracer) -> String {
    match *t {
        Tracer::Linear { steps, binary } | Tracer::DepthMap { steps, binary } => {
            format!("{steps} steps, {binary} halvings")
        }
        Tracer::MaxMip { start_level, stop_level } => format!("levels {start_level} → {stop_level}"),
        Tracer::Combined { margin, start_level } => format!("margin {margin}, from level {start_level}"),
    }
}

/// The relief tables: bake time, reads per ray at equal accuracy, shadows and occlusion,
/// map sizes.
pub fn run() {
    let threads = rayon::current_num_threads();
    println!("Relief bake ({threads} threads; 32 θ × 16 φ = 512 directions, 32² 8-bit maps, depth 0.1 × width)\n");
    let defaults = ReliefParams::default();
    println!("| input | bake | previous algorithm (every ray from the top plane) | speed-up | of the 10 s target |");
    println!("|---|---|---|---|---|");
    for name in ["fbm", "bricks", "spikes", "ridged terrain"] {
        let n = 512;
        let samples = match name {
            "fbm" => synth::fbm_relief(n),
            "bricks" => synth::bricks(n),
            "spikes" => synth::spikes_and_walls(n),
            _ => synth::terrain(n),
        };
        let hf = Heightfield::from_samples(n, n, samples);
        let (t, baked) = best_of(2, || relief::bake(&hf, &defaults, &|_, _| {}).expect("valid"));
        let (t_prev, prev) = best_of(2, || previous_bake(&hf, &defaults));
        let same = baked.depth.channel_f32(0, 0) == prev;
        println!(
            "| {name} 512² × 512 | {t:.2} s | {t_prev:.2} s{} | {:.2}× | {:.2}× |",
            if same { "" } else { " (maps differ!)" },
            t_prev / t,
            t / 10.0
        );
    }
    println!();
    println!("| input | bake | brute-force march (½-texel steps; 1/8 of the directions timed, ×8) | ratio |");
    println!("|---|---|---|---|");
    // Brute force: a march in half-texel steps from every texel centre (every texel a ray
    // crosses is read about twice), at 256² over every 8th direction, scaled to all 512.
    let hf = load("fbm");
    let (t_fast, _) = best_of(2, || relief::bake(&hf, &defaults, &|_, _| {}).expect("valid"));
    let heights = relief::stored_heights(&hf).expect("in range");
    let dirs = defaults.directions();
    let thickness = defaults.depth_scale * hf.width as f32;
    let (t_brute, _) = best_of(1, || {
        (0..dirs.layers())
            .step_by(8)
            .flat_map(|l| (0..hf.width * hf.height).map(move |t| (l, t)))
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|(l, t)| {
                brute_force::relief_depth(
                    &heights,
                    (hf.width, hf.height),
                    (t % hf.width, t / hf.width),
                    dirs.direction(l),
                    thickness,
                    2.0,
                )
            })
            .sum::<f32>()
    });
    let t_brute = t_brute * 8.0;
    println!("| fbm 256² × 512 | {t_fast:.2} s | {t_brute:.1} s | {:.0}× |", t_brute / t_fast);
    println!();
    if std::env::var_os("HIKAGE_BENCH_BAKE_ONLY").is_some() {
        return;
    }

    println!(
        "Reads per ray at equal accuracy (≤ 1% of rays more than 1 texel from a 1/16-texel march; 22,500 rays per family, view angles 0–80°, 256² maps, 512 directions, 32² 8-bit depth maps)\n"
    );
    println!(
        "| family | tracer | cheapest setting meeting the bar | rays > 1 texel | height reads | depth-map reads | total | vs (a) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for name in ["fbm", "bricks", "spikes"] {
        let hf = load(name);
        let mut baseline = f64::NAN;
        // The paper's 32² maps for every tracer, then coarser and finer maps for the two that
        // read them.
        for size in [32u32, 16, 128] {
            let settings = ReliefParams { size: Some(size), ..defaults.clone() };
            let baked = relief::bake(&hf, &settings, &|_, _| {}).expect("valid");
            let info = hikage_bundle::ReliefSettings {
                max_mip: String::new(),
                theta: settings.theta,
                phi: settings.phi,
                depth_scale: settings.depth_scale,
                source_size: (hf.width, hf.height),
                directions: Vec::new(),
            };
            let maps = ReliefMaps::from_textures(&info, &baked.depth, &baked.max_mip).expect("consistent");
            let rays = rays(&maps);
            let truth: Vec<f32> = rays.par_iter().map(|r| fine_march(&maps.max_mip, r)).collect();
            for list in candidates(maps.max_mip.levels() - 1) {
                let reads_maps = matches!(list[0], Tracer::DepthMap { .. } | Tracer::Combined { .. });
                if size != 32 && !reads_maps {
                    continue;
                }
                let label =
                    if reads_maps { format!("{} [{size}² maps]", list[0].name()) } else { list[0].name().to_string() };
                let results: Vec<_> = list.iter().map(|&t| (t, evaluate(&maps, t, &rays, &truth))).collect();
                let best = results
                    .iter()
                    .filter(|(_, (bad, _, _))| *bad <= BAR)
                    .min_by(|a, b| (a.1.1 + a.1.2).total_cmp(&(b.1.1 + b.1.2)));
                match best {
                    Some(&(t, (bad, height, depth))) => {
                        let total = height + depth;
                        if matches!(t, Tracer::Linear { .. }) {
                            baseline = total;
                        }
                        println!(
                            "| {name} | {label} | {} | {:.2}% | {height:.1} | {depth:.1} | {total:.1} | {:.2}× |",
                            setting(&t),
                            100.0 * bad,
                            total / baseline
                        );
                    }
                    None => {
                        let &(t, (bad, h, d)) =
                            results.iter().min_by(|a, b| a.1.0.total_cmp(&b.1.0)).expect("candidates");
                        println!(
                            "| {name} | {label} | none reaches the bar; best: {} | {:.2}% | {h:.1} | {d:.1} | {:.1} | — |",
                            setting(&t),
                            100.0 * bad,
                            h + d
                        );
                    }
                }
            }
        }
    }
    println!();
}
