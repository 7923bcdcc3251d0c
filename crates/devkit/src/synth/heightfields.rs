//! The sample heightfields. Sizes are parameters; `data/` uses the sizes in its README.

use super::noise::{fbm, hash01, value_noise};

fn grid(n: u32, f: impl Fn(f32, f32) -> f32) -> Vec<f32> {
    let mut out = Vec::with_capacity(n as usize * n as usize);
    for y in 0..n {
        for x in 0..n {
            out.push(f(x as f32 + 0.5, y as f32 + 0.5).clamp(0.0, 1.0));
        }
    }
    out
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Seed 000's "cylinder bumps" (Fig. 4/5): a 4×4 grid of upright round cylinders (radius 0.28
/// of the cell, flat tops at height 1, a one-texel soft edge) on a flat base; tileable.
pub fn cylinder_bumps(n: u32) -> Vec<f32> {
    let cell = n as f32 / 4.0;
    grid(n, |x, y| {
        let (cx, cy) = ((x / cell).fract() - 0.5, (y / cell).fract() - 0.5);
        let r = (cx * cx + cy * cy).sqrt() * cell;
        1.0 - smoothstep(0.28 * cell - 0.5, 0.28 * cell + 0.5, r)
    })
}

/// A reptile-skin pattern: domed cells of a jittered grid (Voronoi) separated by grooves;
/// tileable with `n / 16` cells per side.
pub fn reptile_cells(n: u32) -> Vec<f32> {
    let cells = (n / 16).max(2) as i32;
    let cell = n as f32 / cells as f32;
    grid(n, |x, y| {
        let (gx, gy) = ((x / cell).floor() as i32, (y / cell).floor() as i32);
        let (mut f1, mut f2) = (f32::MAX, f32::MAX);
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (ix, iy) = (gx + dx, gy + dy);
                let (wx, wy) = (ix.rem_euclid(cells), iy.rem_euclid(cells));
                let px = (ix as f32 + 0.15 + 0.7 * hash01(wx, wy, 11)) * cell;
                let py = (iy as f32 + 0.15 + 0.7 * hash01(wx, wy, 12)) * cell;
                let d = ((x - px).powi(2) + (y - py).powi(2)).sqrt();
                if d < f1 {
                    f2 = f1;
                    f1 = d;
                } else if d < f2 {
                    f2 = d;
                }
            }
        }
        let edge = (f2 - f1) / cell; // 0 on the groove, grows toward the centre
        let dome = smoothstep(0.0, 0.45, edge).sqrt();
        0.85 * dome + 0.15 * value_noise(x / 4.0, y / 4.0, (n / 4) as i32, 13)
    })
}

/// Wind ripples on dunes (seed 000's closing example): two long asymmetric dunes across the
/// tile, ripples at ~1/16 of the tile across them, bent by low-frequency noise; tileable.
pub fn dune_ripples(n: u32) -> Vec<f32> {
    let nf = n as f32;
    let tau = std::f32::consts::TAU;
    grid(n, |x, y| {
        let bend = fbm(x / nf * 4.0, y / nf * 4.0, 3, 0.5, 4, 21) - 0.5;
        let phase = (x / nf + 0.08 * (tau * y / nf).sin() + 0.1 * bend) * 2.0;
        let t = phase.rem_euclid(1.0);
        // Gentle windward slope over 80% of the period, steep lee face after the crest.
        let dune = if t < 0.8 { (t / 0.8).powf(1.5) } else { 1.0 - smoothstep(0.8, 1.0, t) };
        let ripple_phase = (x / nf * 16.0 + 0.6 * bend + 0.05 * (tau * y / nf * 2.0).sin()) * tau;
        let ripple = 0.5 + 0.5 * ripple_phase.sin();
        0.75 * dune + 0.2 * ripple * (0.4 + 0.6 * dune) + 0.05 * value_noise(x / 2.0, y / 2.0, (n / 2) as i32, 22)
    })
}

/// Rough terrain (not tileable): ridged multi-fractal mountains band-limited to wavelengths of
/// 4 texels and more (as a real DEM is), two fault scarps (height steps of 0.08 and 0.05 over
/// about one texel) and a cliff band. With a height scale of ~20 texel sizes, neighbouring
/// texels differ by about a texel spacing, and scarps and cliffs by many.
pub fn terrain(n: u32) -> Vec<f32> {
    let nf = n as f32;
    let raw = grid(n, |x, y| {
        let (u, v) = (x / nf, y / nf);
        let mut ridged = 0.0;
        let (mut amp, mut freq, mut norm) = (1.0, 4.0, 0.0);
        // Band-limited like a real DEM: the finest octave spans at least 4 texels.
        let octaves = ((nf / 16.0).log2().floor() as u32 + 1).max(1);
        for o in 0..octaves {
            let r = 1.0 - (2.0 * value_noise(u * freq, v * freq, 0, 31 + o) - 1.0).abs();
            ridged += amp * r * r;
            norm += amp;
            amp *= 0.5;
            freq *= 2.0;
        }
        let mut h = 0.7 * ridged / norm + 0.3 * fbm(u * 3.0, v * 3.0, 4, 0.5, 0, 41);
        // Fault scarps: steps across two lines.
        let f1 = 0.8 * u - 0.6 * v + 0.1;
        h += 0.08 * smoothstep(-0.5 / nf, 0.5 / nf, f1);
        let f2 = 0.3 * u + 0.95 * v - 0.7 + 0.03 * (u * 20.0).sin();
        h += 0.05 * smoothstep(-0.5 / nf, 0.5 / nf, f2);
        // A cliff band: a plateau edge following a noisy contour.
        let contour = fbm(u * 2.0, v * 2.0, 3, 0.5, 0, 51);
        h += 0.12 * smoothstep(0.52, 0.53, contour);
        h
    });
    let (lo, hi) = raw.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    raw.iter().map(|v| (v - lo) / (hi - lo)).collect()
}

/// Relief family "smooth": 6-octave fBm, tileable.
pub fn fbm_relief(n: u32) -> Vec<f32> {
    grid(n, |x, y| {
        let s = 8.0 / n as f32;
        let v = fbm(x * s, y * s, 6, 0.5, 8, 61);
        smoothstep(0.15, 0.85, v)
    })
}

/// Relief family "bricks": running-bond bricks 32×16 texels (at 256²), mortar 2 texels deep to
/// 0, brick faces at 0.85–1.0 with a bevel and slight per-brick tilt; tileable.
pub fn bricks(n: u32) -> Vec<f32> {
    let bw = n as f32 / 8.0;
    let bh = n as f32 / 16.0;
    grid(n, |x, y| {
        let row = (y / bh).floor();
        let shift = if row as i32 % 2 == 0 { 0.0 } else { bw * 0.5 };
        let col = ((x + shift) / bw).floor();
        let (lx, ly) = ((x + shift) - col * bw, y - row * bh);
        let edge = lx.min(bw - lx).min(ly).min(bh - ly);
        let brick = smoothstep(1.0, 2.5, edge);
        let wc = (col as i32).rem_euclid(8);
        let wr = (row as i32).rem_euclid(16);
        let tilt = 0.06 * (hash01(wc, wr, 71) - 0.5) * (lx / bw - 0.5);
        let top = 0.9 + 0.1 * hash01(wc, wr, 72) + tilt;
        brick * top + 0.03 * value_noise(x / 2.0, y / 2.0, (n / 2) as i32, 73) * brick
    })
}

/// Relief family "thin features": a low base with thin spikes (2–3 texels wide, full height)
/// on a jittered grid and a few one-texel walls; the hard case for depth-map search.
pub fn spikes_and_walls(n: u32) -> Vec<f32> {
    let cells = (n / 16).max(2) as i32;
    let cell = n as f32 / cells as f32;
    grid(n, |x, y| {
        let (gx, gy) = ((x / cell).floor() as i32, (y / cell).floor() as i32);
        let (wx, wy) = (gx.rem_euclid(cells), gy.rem_euclid(cells));
        let px = (gx as f32 + 0.25 + 0.5 * hash01(wx, wy, 81)) * cell;
        let py = (gy as f32 + 0.25 + 0.5 * hash01(wx, wy, 82)) * cell;
        let r = ((x - px).powi(2) + (y - py).powi(2)).sqrt();
        let radius = 1.0 + 0.6 * hash01(wx, wy, 83);
        let spike = (1.0 - smoothstep(radius - 0.5, radius + 0.5, r)) * (0.6 + 0.4 * hash01(wx, wy, 84));
        let nf = n as f32;
        let wall_a = 1.0 - smoothstep(0.5, 1.0, (x - nf * 0.3).abs());
        let wall_b = 1.0 - smoothstep(0.5, 1.0, (y - nf * 0.7).abs());
        let walls = 0.8 * wall_a.max(wall_b) * if (y / nf * 6.0).fract() < 0.7 { 1.0 } else { 0.0 };
        let base = 0.1 * value_noise(x / 8.0, y / 8.0, (n / 8) as i32, 85);
        base.max(spike).max(walls)
    })
}
