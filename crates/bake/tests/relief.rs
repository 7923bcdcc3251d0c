//! Relief depth maps against an independent brute-force march.

use hikage_bake::heightfield::Heightfield;
use hikage_bake::relief::{self, ReliefFormat, ReliefParams, min_downscale};
use hikage_bundle::relief::{MaxMip, ReliefDirections};
use hikage_devkit::brute_force;
use hikage_devkit::synth;

fn families(n: u32) -> Vec<(&'static str, Vec<f32>)> {
    vec![("fbm", synth::fbm_relief(n)), ("bricks", synth::bricks(n)), ("spikes", synth::spikes_and_walls(n))]
}

/// Full-resolution maps (size = map width, f16) against a march in 1/32-texel steps: the march
/// finds the first step inside, at most one step after the true hit, and can miss a corner the
/// ray clips between two steps; so the baked depth must never be deeper than the march's, and
/// agree within a step on nearly all texel-directions.
#[test]
fn full_resolution_maps_agree_with_a_brute_force_march() {
    let n = 64;
    for (name, samples) in families(n) {
        let hf = Heightfield::from_samples(n, n, samples);
        let s = ReliefParams { theta: 6, phi: 8, size: Some(n), depth_scale: 0.1, format: ReliefFormat::R16Float };
        let baked = relief::bake(&hf, &s, &|_, _| {}).unwrap();
        let stored = baked.depth.to_f32(0);
        let heights = relief::stored_heights(&hf).unwrap();
        let dirs = s.directions();
        let thickness = s.depth_scale * n as f32;
        let steps = 32.0;
        let (mut close, mut total, mut worst) = (0usize, 0usize, 0.0f32);
        for layer in 0..dirs.layers() {
            let dir = dirs.direction(layer);
            // One march step in depth units, plus the f16 round-down step.
            let tol = dir[2] / thickness / steps + 2e-3;
            for j in 0..n {
                for i in 0..n {
                    let baked = stored[(layer * n * n + j * n + i) as usize];
                    let brute = brute_force::relief_depth(&heights, (n, n), (i, j), dir, thickness, steps);
                    assert!(baked <= brute + 1e-4, "{name} layer {layer} texel ({i},{j}): baked {baked} brute {brute}");
                    worst = worst.max(brute - baked);
                    total += 1;
                    if brute - baked <= tol {
                        close += 1;
                    }
                }
            }
        }
        let share = close as f64 / total as f64;
        println!("{name}: {:.3}% within a march step, largest gap {worst:.4}", 100.0 * share);
        assert!(share >= 0.995, "{name}: only {:.2}% agree", 100.0 * share);
    }
}

/// A flat map: every ray hits at the plane's depth; a single step: analytic depths.
#[test]
fn flat_map_and_step_have_analytic_depths() {
    let n = 32;
    let hf = Heightfield::from_samples(n, n, vec![0.25; (n * n) as usize]);
    let s = ReliefParams { theta: 4, phi: 4, size: Some(n), depth_scale: 0.25, format: ReliefFormat::R16Float };
    let baked = relief::bake(&hf, &s, &|_, _| {}).unwrap();
    for d in baked.depth.to_f32(0) {
        assert_eq!(d, 0.75);
    }
    // Columns 16..32 stand at height 1, the rest at 0 (depth 1). A ray at φ = 0 (+u) from
    // texel i < 16 reaches the wall after 16 − (i + ½) texels horizontally.
    let samples: Vec<f32> = (0..n * n).map(|k| if k % n >= 16 { 1.0 } else { 0.0 }).collect();
    let hf = Heightfield::from_samples(n, n, samples);
    let s = ReliefParams { theta: 3, phi: 4, size: Some(n), depth_scale: 0.25, format: ReliefFormat::R16Float };
    let baked = relief::bake(&hf, &s, &|_, _| {}).unwrap();
    let values = baked.depth.to_f32(0);
    let dirs = s.directions();
    let thickness = 8.0;
    for row in 0..3 {
        let layer = row * 4; // φ = 0
        let (theta, _) = dirs.angles(layer);
        for i in 0..16u32 {
            let horizontal = 16.0 - (i as f32 + 0.5);
            let expected = (horizontal / theta.tan() / thickness).min(1.0);
            let got = values[(layer * n * n + 5 * n + i) as usize];
            assert!(got <= expected + 1e-6 && expected - got < 2e-3, "θ {theta} i {i}: {got} vs {expected}");
        }
    }
}

/// The stored maps are the 2×2 MIN chain of the full-resolution maps, rounded down. A
/// downscaled bake skips rays and starts others deep in the relief (square floors); a
/// full-resolution one traces every ray from the top plane, so this checks the shortcuts on
/// every family, including rough terrain, at factors that use one and two floor levels.
#[test]
fn downscaled_maps_are_the_min_of_the_full_maps() {
    let n = 64;
    let mut maps = families(n);
    maps.push(("ridged terrain", synth::terrain(n)));
    for (name, samples) in maps {
        let hf = Heightfield::from_samples(n, n, samples);
        let full = ReliefParams { theta: 6, phi: 8, size: Some(n), depth_scale: 0.1, format: ReliefFormat::R16Float };
        let a = relief::bake(&hf, &full, &|_, _| {}).unwrap().depth.to_f32(0);
        let per = (n * n) as usize;
        for size in [16u32, 4] {
            let small = ReliefParams { size: Some(size), ..full.clone() };
            let b = relief::bake(&hf, &small, &|_, _| {}).unwrap().depth.to_f32(0);
            let cells = (size * size) as usize;
            let mut equal = 0;
            for layer in 0..full.directions().layers() as usize {
                let mut expected = a[layer * per..(layer + 1) * per].to_vec();
                // Eq. (2), by hand, until the map is `size` wide.
                let mut w = n;
                while w > size {
                    expected = min_downscale(&expected, w, w, 2);
                    w /= 2;
                }
                let got = &b[layer * cells..(layer + 1) * cells];
                for (k, (&g, &e)) in got.iter().zip(&expected).enumerate() {
                    assert!((g - e).abs() <= 1e-3, "{name} {size}² layer {layer} texel {k}: {g} vs {e}");
                    equal += (g == e) as usize;
                }
            }
            let total = cells * full.directions().layers() as usize;
            assert!(equal as f64 >= 0.999 * total as f64, "{name} {size}²: {equal} of {total} equal");
        }
    }
}

#[test]
fn max_mip_texture_holds_the_pyramid() {
    let n = 16;
    let hf = Heightfield::from_samples(n, n, synth::spikes_and_walls(n));
    let baked = relief::bake(&hf, &ReliefParams { size: Some(4), ..Default::default() }, &|_, _| {}).unwrap();
    let heights = relief::stored_heights(&hf).unwrap();
    let mm = MaxMip::new(n, n, heights).unwrap();
    assert_eq!(baked.max_mip.desc.levels, 5);
    for l in 0..5 {
        let got: Vec<f32> = baked.max_mip.channel_f32(l, 0);
        assert_eq!(got, mm.level(l), "level {l}");
    }
    // Level 1 by hand: the largest of each 2×2.
    let l1 = baked.max_mip.channel_f32(1, 0);
    let h0 = baked.max_mip.channel_f32(0, 0);
    let by_hand = h0[0].max(h0[1]).max(h0[16]).max(h0[17]);
    assert_eq!(l1[0], by_hand);
}

#[test]
fn bad_settings_are_refused() {
    let hf = Heightfield::from_samples(64, 64, vec![0.5; 64 * 64]);
    let base = ReliefParams::default();
    for (s, needle) in [
        (ReliefParams { theta: 0, ..base.clone() }, "theta"),
        (ReliefParams { phi: 100_000, ..base.clone() }, "phi"),
        (ReliefParams { theta: 128, phi: 128, ..base.clone() }, "directions"),
        (ReliefParams { size: Some(24), ..base.clone() }, "power of two"),
        (ReliefParams { size: Some(128), ..base.clone() }, "at most the map width"),
        (ReliefParams { depth_scale: f32::NAN, ..base.clone() }, "depth_scale"),
    ] {
        let e = relief::bake(&hf, &s, &|_, _| {}).unwrap_err();
        assert!(e.contains(needle), "{e}");
    }
    let odd = Heightfield::from_samples(48, 64, vec![0.5; 48 * 64]);
    assert!(relief::bake(&odd, &base, &|_, _| {}).unwrap_err().contains("power-of-two"));
    let high = Heightfield::from_samples(64, 64, vec![1.5; 64 * 64]);
    assert!(relief::bake(&high, &base, &|_, _| {}).unwrap_err().contains("[0, 1]"));
}

#[test]
fn the_direction_table_matches_the_layers() {
    let dirs = ReliefDirections { theta: 32, phi: 16 };
    let (t0, p0) = dirs.angles(0);
    assert!((t0.to_degrees() - 90.0 / 64.0).abs() < 1e-4 && p0 == 0.0);
    let (t, p) = dirs.angles(16 * 31 + 4);
    assert!((t.to_degrees() - 88.59375).abs() < 1e-3 && (p.to_degrees() - 90.0).abs() < 1e-4);
}

/// BC4 depth maps keep the maps' promise: against the R8 maps of the same bake (the depths
/// rounded down), no decoded texel is deeper, on every family; half the bytes; each block's
/// texels within one palette step (a seventh of the block's spread) and the encoder's spare step
/// of their 8-bit depths, on the whole.
#[test]
fn bc4_maps_are_never_deeper_than_the_r8_maps() {
    let n = 64;
    for (name, samples) in families(n) {
        let hf = Heightfield::from_samples(n, n, samples);
        let params = ReliefParams { size: Some(16), ..Default::default() };
        let r8 = relief::bake(&hf, &params, &|_, _| {}).unwrap();
        let bc4 = relief::bake(&hf, &ReliefParams { format: ReliefFormat::Bc4RUnorm, ..params }, &|_, _| {}).unwrap();
        assert_eq!(bc4.depth.desc.format, hikage_bundle::TextureFormat::Bc4RUnorm);
        assert_eq!(bc4.depth.levels[0].len() * 2, r8.depth.levels[0].len(), "{name}: half the bytes");
        assert_eq!(bc4.max_mip, r8.max_mip, "{name}: the pyramid is not block-compressed");
        let (want, got) = (r8.depth.channel_f32(0, 0), bc4.depth.channel_f32(0, 0));
        let deeper = want.iter().zip(&got).filter(|(w, g)| g > w).count();
        eprintln!("{name}: BC4 {deeper} texels deeper");
        assert_eq!(deeper, 0, "{name}");
        let m = 16;
        for (layer, (want, got)) in want.chunks_exact(m * m).zip(got.chunks_exact(m * m)).enumerate() {
            for (bx, by) in (0..m * m / 16).map(|b| (b % (m / 4) * 4, b / (m / 4) * 4)) {
                let at = |i: usize| (by + i / 4) * m + bx + i % 4;
                let (lo, hi) = (0..16).fold((1f32, 0f32), |(lo, hi), i| (lo.min(want[at(i)]), hi.max(want[at(i)])));
                // A palette step, the encoder's spare step for imprecise decoders, and half a
                // byte for the decoded value rounded to 8 bits, per texel on the whole block.
                let step = ((hi - lo) / 7.0).max(1.0 / 255.0) + 1.5 / 255.0 + 1e-6;
                let error: f32 = (0..16).map(|i| want[at(i)] - got[at(i)]).sum();
                assert!(error <= 16.0 * step, "{name} layer {layer} block ({bx}, {by}): {error} off");
            }
        }
    }
}
