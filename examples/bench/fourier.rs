//! Fourier-compressed horizon maps (Fritsch et al., "Fast Planetary Shadows using
//! Fourier-Compressed Horizon Maps", HPG 2025) against plain horizon maps at equal bytes, before
//! any format is written for them: each texel's horizon profile as K coefficients of a truncated
//! Fourier series of the horizon angle, against K stored directions interpolated linearly as the
//! runtime's sampler does, both judged by the shadow test against a 256-direction bake of the
//! same terrain (linearly interpolated: the nearest to exact the baker gives).

use std::f64::consts::TAU;

use hikage_bake::heightfield::{Heightfield, LoadOptions, load_samples};
use hikage_bake::horizon::{self, HorizonFormat, HorizonParams};
use hikage_bundle::EdgeMode;
use hikage_devkit::synth;

/// Directions of the reference bake.
const REFERENCE: usize = 256;
/// Sun elevations tested (degrees) — low suns, where horizons decide — each at `AZIMUTHS`
/// azimuths.
const ELEVATIONS: [f64; 5] = [2.0, 5.0, 10.0, 20.0, 30.0];
const AZIMUTHS: usize = 24;

pub fn run() {
    println!("Fourier-compressed horizons vs plain horizon maps at equal bytes (one value per direction or");
    println!("coefficient): the shadow test against a {REFERENCE}-direction bake, 512² texels, suns at");
    println!("{ELEVATIONS:?}° × {AZIMUTHS} azimuths; angle errors over the same sun directions:\n");
    println!(
        "| terrain | values per texel | encoding | shadow test agrees | lit ↔ shadowed flips | max angle error | p99 |"
    );
    println!("|---|---|---|---|---|---|---|");
    let samples = load_samples(std::path::Path::new("data/terrain.png"), &LoadOptions::default())
        .expect("run from the repository root (data/ is read)");
    let mut default = Heightfield::from_samples(samples.width, samples.height, samples.values);
    default.texel_size = (80.0, 60.0);
    default.height_scale = 1500.0;
    let mut rough = Heightfield::from_samples(512, 512, synth::terrain(512));
    rough.texel_size = (30.0, 30.0);
    rough.height_scale = 1500.0;
    for (name, hf) in [("default (data/terrain.png)", default), ("rough DEM-like (devkit, 30 m)", rough)] {
        let params = HorizonParams {
            directions: REFERENCE as u32,
            edge: EdgeMode::Clamp,
            format: HorizonFormat::Rg32Float,
            ..HorizonParams::default()
        };
        let baked = horizon::bake(&hf, &params, &|_, _| {}).expect("valid settings");
        let texels = (hf.width * hf.height) as usize;
        let level = &baked.texture.levels[0];
        // β per texel per direction (radians); open sky (the most negative slope) is −90°.
        let mut profiles = vec![0f64; texels * REFERENCE];
        for k in 0..REFERENCE {
            for t in 0..texels {
                let o = ((k * texels + t) * 2) * 4;
                let slope = f32::from_le_bytes([level[o], level[o + 1], level[o + 2], level[o + 3]]) as f64;
                profiles[t * REFERENCE + k] = slope.atan();
            }
        }
        for k in [8usize, 16] {
            let plain = evaluate(&profiles, texels, |p| subsample(p, k), interpolate);
            let fourier = evaluate(&profiles, texels, |p| coefficients(p, k), series);
            for (encoding, r) in
                [(format!("plain, {k} directions"), plain), (format!("Fourier, {k} coefficients"), fourier)]
            {
                println!(
                    "| {name} | {k} | {encoding} | {:.2}% | {} | {:.2}° | {:.2}° |",
                    100.0 * r.agree as f64 / r.tests as f64,
                    r.tests - r.agree,
                    r.max.to_degrees(),
                    r.p99.to_degrees()
                );
            }
        }
    }
    println!();
}

/// The shadow test of one encoding over every texel and sun direction.
struct Outcome {
    tests: usize,
    agree: usize,
    max: f64,
    p99: f64,
}

/// The horizon angle `at(encode(profile), φ)` of an encoding against the reference's, for every
/// texel and sun direction: lit when the sun is above the horizon.
fn evaluate(
    profiles: &[f64],
    texels: usize,
    encode: impl Fn(&[f64]) -> Vec<f64> + Sync,
    at: impl Fn(&[f64], f64) -> f64 + Sync,
) -> Outcome {
    use rayon::prelude::*;
    let suns: Vec<(f64, f64)> = ELEVATIONS
        .iter()
        .flat_map(|&e| (0..AZIMUTHS).map(move |a| (e.to_radians(), TAU * (a as f64 + 0.37) / AZIMUTHS as f64)))
        .collect();
    let per_texel: Vec<(usize, Vec<f32>)> = (0..texels)
        .into_par_iter()
        .map(|t| {
            let p = &profiles[t * REFERENCE..(t + 1) * REFERENCE];
            let stored = encode(p);
            let mut agree = 0;
            let mut errors = Vec::with_capacity(suns.len());
            for &(elevation, phi) in &suns {
                let exact = interpolate(p, phi);
                let got = at(&stored, phi);
                agree += ((elevation > exact) == (elevation > got)) as usize;
                errors.push((got - exact).abs() as f32);
            }
            (agree, errors)
        })
        .collect();
    let agree = per_texel.iter().map(|(a, _)| a).sum();
    let mut errors: Vec<f32> = per_texel.into_iter().flat_map(|(_, e)| e).collect();
    errors.sort_by(f32::total_cmp);
    Outcome {
        tests: texels * suns.len(),
        agree,
        max: *errors.last().unwrap_or(&0.0) as f64,
        p99: errors[errors.len() * 99 / 100] as f64,
    }
}

/// Every (REFERENCE / k)-th direction: the profile a k-direction bake stores.
fn subsample(p: &[f64], k: usize) -> Vec<f64> {
    (0..k).map(|i| p[i * REFERENCE / k]).collect()
}

/// A profile of n directions φ_i = 2πi/n at φ, linearly between its neighbours, wrapping; in
/// slope (tan β) as the sampler filters the stored slopes, returned as an angle.
fn interpolate(p: &[f64], phi: f64) -> f64 {
    let n = p.len();
    let x = phi.rem_euclid(TAU) / TAU * n as f64;
    let (i, f) = (x.floor() as usize % n, x.fract());
    let (a, b) = (p[i].tan().max(-1e4), p[(i + 1) % n].tan().max(-1e4));
    (a + (b - a) * f).atan()
}

/// The first k real Fourier coefficients of a profile: a₀, then (aⱼ, bⱼ) pairs, then a last
/// cosine where k is even (the truncated series is the least-squares fit of its order).
fn coefficients(p: &[f64], k: usize) -> Vec<f64> {
    let n = p.len() as f64;
    let mut c = Vec::with_capacity(k);
    c.push(p.iter().sum::<f64>() / n);
    let mut j = 1;
    while c.len() < k {
        let (mut a, mut b) = (0.0, 0.0);
        for (i, &v) in p.iter().enumerate() {
            let x = TAU * (j * i) as f64 / n;
            a += v * x.cos();
            b += v * x.sin();
        }
        c.push(2.0 * a / n);
        if c.len() < k {
            c.push(2.0 * b / n);
        }
        j += 1;
    }
    c
}

/// The truncated series of `coefficients` at φ.
fn series(c: &[f64], phi: f64) -> f64 {
    let mut v = c[0];
    for (m, pair) in c[1..].chunks(2).enumerate() {
        let x = (m + 1) as f64 * phi;
        v += pair[0] * x.cos() + pair.get(1).map_or(0.0, |b| b * x.sin());
    }
    v
}
