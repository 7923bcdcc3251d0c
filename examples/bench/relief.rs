//! Relief depth maps: bake time against a brute-force march, and reads per ray of the four
//! tracers at equal accuracy on the three heightfield families of `data/`.

use std::path::Path;

use hikage_bake::heightfield::{Heightfield, LoadOptions, load_samples};
use hikage_bake::jobs::ReliefPreset;
use hikage_bake::relief::{self, ReliefFormat, ReliefParams};
use hikage_bundle::relief::{MaxMip, ReliefRay, first_hit_maxmip};
use hikage_devkit::brute_force;
use hikage_devkit::synth;
use hikage_runtime::relief::reference::{Reads, ReliefMaps, fine_march};
use hikage_runtime::relief::{DirectionRule, Tracer, VisibilityPath};
use rayon::prelude::*;

use crate::best_of;

/// View angles from the normal, degrees, and rays per angle (9 × 2,500 = 22,500 per family).
const ANGLES: [f32; 9] = [0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0];
const RAYS_PER_ANGLE: usize = 2500;
/// The accuracy bar: at most this share of rays ends more than one texel from the ground truth.
const BAR: f64 = 0.01;

pub(crate) fn load(name: &str) -> Heightfield {
    let path = Path::new("data").join(format!("relief_{name}.png"));
    let s = load_samples(&path, &LoadOptions::default()).expect("run from the repository root (data/ is read)");
    Heightfield::from_samples(s.width, s.height, s.values)
}

pub(crate) fn rays(maps: &ReliefMaps) -> Vec<ReliefRay> {
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

pub(crate) fn candidates(top: u32) -> Vec<Vec<Tracer>> {
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
    reads_table(&defaults);
    visibility_table(&defaults);
    sizes_table(&defaults);
}

/// The runtime's maps from a bake, read by `rule`.
pub(crate) fn maps_of(hf: &Heightfield, params: &ReliefParams, rule: DirectionRule) -> ReliefMaps {
    let baked = relief::bake(hf, params, &|_, _| {}).expect("valid");
    let info = hikage_bundle::ReliefSettings {
        max_mip: String::new(),
        theta: params.theta,
        phi: params.phi,
        depth_scale: params.depth_scale,
        source_size: (hf.width, hf.height),
        directions: Vec::new(),
    };
    let maps = ReliefMaps::from_textures(&info, &baked.depth, &baked.max_mip).expect("consistent");
    ReliefMaps { rule, ..maps }
}

/// The cheapest tracer of `list` meeting the bar, as (tracer, share off, height reads, depth
/// reads), or the most accurate one when none does (`Err`).
pub(crate) type Outcome = (Tracer, (f64, f64, f64));
pub(crate) fn cheapest(
    maps: &ReliefMaps,
    list: &[Tracer],
    rays: &[ReliefRay],
    truth: &[f32],
) -> Result<Outcome, Outcome> {
    let results: Vec<_> = list.iter().map(|&t| (t, evaluate(maps, t, rays, truth))).collect();
    let best = results
        .iter()
        .filter(|(_, (bad, _, _))| *bad <= BAR)
        .min_by(|a, b| (a.1.1 + a.1.2).total_cmp(&(b.1.1 + b.1.2)));
    match best {
        Some(&b) => Ok(b),
        None => Err(*results.iter().min_by(|a, b| a.1.0.total_cmp(&b.1.0)).expect("candidates")),
    }
}

/// One row of a reads table; returns the total reads when the bar was met. A baseline row
/// (`baseline` NaN) is its own baseline.
fn reads_row(first: &str, label: &str, outcome: Result<Outcome, Outcome>, baseline: f64) -> Option<f64> {
    match outcome {
        Ok((t, (bad, height, depth))) => {
            let total = height + depth;
            let baseline = if baseline.is_nan() { total } else { baseline };
            println!(
                "| {first} | {label} | {} | {:.2}% | {height:.1} | {depth:.1} | {total:.1} | {:.2}× |",
                setting(&t),
                100.0 * bad,
                total / baseline
            );
            Some(total)
        }
        Err((t, (bad, h, d))) => {
            println!(
                "| {first} | {label} | none reaches the bar; best: {} | {:.2}% | {h:.1} | {d:.1} | {:.1} | — |",
                setting(&t),
                100.0 * bad,
                h + d
            );
            None
        }
    }
}

fn rule_name(rule: DirectionRule) -> &'static str {
    match rule {
        DirectionRule::Nearest => "nearest row",
        DirectionRule::Zenith => "zenith rule",
    }
}

/// Reads per ray at the accuracy bar: every tracer on the paper's 32² maps, the two tracers
/// that read depth maps by both direction rules, on coarser and finer maps, and on the
/// 192 KiB preset.
fn reads_table(defaults: &ReliefParams) {
    println!(
        "Reads per ray at equal accuracy (≤ 1% of rays more than 1 texel from a 1/16-texel march; 22,500 rays per family, view angles 0–80°, 256² maps, 512 directions, 32² 8-bit depth maps unless named)\n"
    );
    println!(
        "| family | tracer | cheapest setting meeting the bar | rays > 1 texel | height reads | depth-map reads | total | vs (a) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let preset = ReliefPreset::Paper192K.params();
    for name in ["fbm", "bricks", "spikes"] {
        let hf = load(name);
        let mut baseline = f64::NAN;
        let mut configs: Vec<(ReliefParams, DirectionRule, String)> = Vec::new();
        for rule in [DirectionRule::Nearest, DirectionRule::Zenith] {
            configs.push((defaults.clone(), rule, format!("32² maps, {}", rule_name(rule))));
        }
        let rule = DirectionRule::default();
        for size in [16u32, 128] {
            configs.push((
                ReliefParams { size: Some(size), ..defaults.clone() },
                rule,
                format!("{size}² maps, {}", rule_name(rule)),
            ));
        }
        configs.push((preset.clone(), rule, format!("paper-192k: 12 × 16 directions, {}", rule_name(rule))));
        for (k, (params, rule, what)) in configs.iter().enumerate() {
            let maps = maps_of(&hf, params, *rule);
            let rays = rays(&maps);
            let truth: Vec<f32> = rays.par_iter().map(|r| fine_march(&maps.max_mip, r)).collect();
            for list in candidates(maps.max_mip.levels() - 1) {
                let reads_maps = matches!(list[0], Tracer::DepthMap { .. } | Tracer::Combined { .. });
                if k > 0 && !reads_maps {
                    continue;
                }
                let label =
                    if reads_maps { format!("{} [{what}]", list[0].name()) } else { list[0].name().to_string() };
                let total = reads_row(name, &label, cheapest(&maps, &list, &rays, &truth), baseline);
                if matches!(list[0], Tracer::Linear { .. }) {
                    baseline = total.unwrap_or(f64::NAN);
                }
            }
        }
    }
    println!();
}

/// Shadows and ambient occlusion by both visibility paths against the exact answer on the
/// full-resolution surface: agreement and reads per test.
fn visibility_table(defaults: &ReliefParams) {
    let bias = 0.02;
    println!(
        "Shadows and ambient occlusion against the exact answer (max-mip on the full-resolution surface; bias {bias} depth; 32² 8-bit maps, 512 directions, {}; points: the view rays' hits; lights 0–75° from the normal; AO over 32 directions)\n",
        rule_name(DirectionRule::default())
    );
    println!(
        "| family | path | shadow: agrees | height reads | depth reads | AO: mean abs error | height reads | depth reads |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for name in ["fbm", "bricks", "spikes"] {
        let hf = load(name);
        let mut maps = maps_of(&hf, defaults, DirectionRule::default());
        let rays = rays(&maps);
        let mut seed = 0x2545f4914f6cdd1du64;
        let mut next = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let cases: Vec<([f32; 3], [f32; 3])> = rays
            .iter()
            .map(|r| {
                let p = r.at(fine_march(&maps.max_mip, r));
                let (theta, phi) = (next() * 75f32.to_radians(), next() * std::f32::consts::TAU);
                (p, [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()])
            })
            .collect();
        let exact: Vec<bool> = cases.par_iter().map(|(p, l)| maps.lit_exact(*p, *l, bias)).collect();
        let ao_cases = &cases[..cases.len() / 9];
        let ao_exact: Vec<f32> = ao_cases.par_iter().map(|(p, _)| maps.ambient_occlusion_exact(*p, 16, bias)).collect();
        let lit_share = exact.iter().filter(|&&l| l).count() as f64 / exact.len() as f64;
        // The ambient occlusion before the visibility paths: one read per direction, open when
        // the stored hit is not above the point.
        let err: f64 = ao_cases
            .par_iter()
            .zip(&ao_exact)
            .map(|((p, _), &e)| {
                let (mut open, mut total) = (0.0f32, 0.0f32);
                for layer in (0..maps.dirs.layers()).step_by(16) {
                    let k = maps.dirs.direction(layer);
                    let w = k[2] * k[0].hypot(k[1]);
                    let back = p[2] * maps.thickness / k[2];
                    let stored = maps.depth_at(layer, p[0] - back * k[0], p[1] - back * k[1]);
                    open += if stored >= p[2] - bias { w } else { 0.0 };
                    total += w;
                }
                (open / total - e).abs() as f64
            })
            .sum();
        println!(
            "| {name} ({:.0}% lit) | previous ambient occlusion: one read per direction | — | — | — | {:.4} | 0.0 | 32.0 |",
            100.0 * lit_share,
            err / ao_cases.len() as f64
        );
        for path in [
            VisibilityPath::MaxMip,
            VisibilityPath::Seed { steps: 16, binary: 4 },
            VisibilityPath::Seed { steps: 32, binary: 6 },
            VisibilityPath::Seed { steps: 64, binary: 6 },
        ] {
            maps.visibility = path;
            let (agree, h, d) = cases
                .par_iter()
                .zip(&exact)
                .map(|((p, l), &e)| {
                    let mut reads = Reads::default();
                    let lit = maps.lit(*p, *l, bias, &mut reads);
                    ((lit == e) as u64, reads.height as u64, reads.depth as u64)
                })
                .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
            let (err, ah, ad) = ao_cases
                .par_iter()
                .zip(&ao_exact)
                .map(|((p, _), &e)| {
                    let mut reads = Reads::default();
                    let ao = maps.ambient_occlusion(*p, 16, bias, &mut reads);
                    ((ao - e).abs() as f64, reads.height as u64, reads.depth as u64)
                })
                .reduce(|| (0.0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
            let (n, m) = (cases.len() as f64, ao_cases.len() as f64);
            let label = match path {
                VisibilityPath::MaxMip => path.name().to_string(),
                VisibilityPath::Seed { steps, binary } => format!("{} ({steps} steps, {binary} halvings)", path.name()),
            };
            println!(
                "| {name} ({:.0}% lit) | {label} | {:.2}% | {:.1} | {:.1} | {:.4} | {:.1} | {:.1} |",
                100.0 * lit_share,
                100.0 * agree as f64 / n,
                h as f64 / n,
                d as f64 / n,
                err / m,
                ah as f64 / m,
                ad as f64 / m
            );
        }
    }
    println!();
}

/// Seed 003's Fig. 11: maps MIN-downscaled from 512² full-resolution maps to each size, and
/// the reads of the seed's tracer at the bar against plain relief mapping's, per size.
fn sizes_table(defaults: &ReliefParams) {
    let n = 512u32;
    let hf = Heightfield::from_samples(n, n, synth::fbm_relief(n));
    let full = ReliefParams { size: Some(n), format: ReliefFormat::R16Float, ..defaults.clone() };
    let (t, base) = best_of(1, || maps_of(&hf, &full, DirectionRule::default()));
    println!(
        "Map size (seed 003 Fig. 11): fbm 512², 512 directions, full-resolution maps ({t:.1} s) MIN-downscaled to each size and stored in 8 bits; reads per ray at the bar as above\n"
    );
    println!(
        "| maps | memory | (b) setting | (b) height reads | (b) depth reads | (b) total | (a) total | (b) vs (a) | (d) total | (d) vs (a) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let rays = rays(&base);
    let truth: Vec<f32> = rays.par_iter().map(|r| fine_march(&base.max_mip, r)).collect();
    let lists = candidates(base.max_mip.levels() - 1);
    let linear = cheapest(&base, &lists[0], &rays, &truth);
    let a_total = linear.map(|(_, (_, h, d))| h + d).unwrap_or(f64::NAN);
    let layers = base.dirs.layers() as usize;
    for size in [512u32, 256, 128, 64, 32, 16] {
        let factor = n / size;
        let per = (n * n) as usize;
        let depth: Vec<f32> = (0..layers)
            .flat_map(|l| relief::min_downscale(&base.depth[l * per..(l + 1) * per], n, n, factor))
            .map(|d| ReliefFormat::R8Unorm.round_down(d))
            .collect();
        let maps = ReliefMaps { depth, depth_size: (size, size), ..base.clone() };
        let b = cheapest(&maps, &lists[1], &rays, &truth);
        let d = cheapest(&maps, &lists[3], &rays, &truth);
        let total = |o: &Result<Outcome, Outcome>| o.as_ref().ok().map(|(_, (_, h, d))| h + d);
        let memory = (size * size) as f64 * layers as f64 / 1024.0;
        let memory = if memory >= 1024.0 { format!("{:.0} MiB", memory / 1024.0) } else { format!("{memory:.0} KiB") };
        let (bs, bh, bd) = match &b {
            Ok((t, (_, h, d))) => (setting(t), format!("{h:.1}"), format!("{d:.1}")),
            Err(_) => ("none reaches the bar".into(), "—".into(), "—".into()),
        };
        let fmt = |v: Option<f64>| v.map(|v| format!("{v:.1}")).unwrap_or("—".into());
        let ratio = |v: Option<f64>| v.map(|v| format!("{:.2}×", v / a_total)).unwrap_or("—".into());
        println!(
            "| {size}² | {memory} | {bs} | {bh} | {bd} | {} | {a_total:.1} | {} | {} | {} |",
            fmt(total(&b)),
            ratio(total(&b)),
            fmt(total(&d)),
            ratio(total(&d))
        );
    }
    println!();
}
