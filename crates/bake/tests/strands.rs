//! Strips and the automatic opacity set on generated hair (the generators live in the devkit,
//! so these are integration tests).

use hikage_bake::strands::auto::{LightView, choose, directions};
use hikage_bake::strands::strips::{StripSets, build};
use hikage_devkit::synth;

/// The criterion as a test, on views it never saw: along the eight diagonals (the choice looks
/// along the six axes only), the automatic opacity set's shadow is nearer the reference than
/// the seed's fixed-ratio set's and than the shading set's own (plain deep opacity maps), and
/// it is wider and fainter than the shading set with the same width × opacity.
#[test]
fn auto_opacity_set_is_nearest_the_reference_shadow() {
    for (name, s) in [("head", synth::hair(1500, 12, 11)), ("combed", synth::combed(1500, 12, 5))] {
        let base = StripSets::from_source(&s);
        let resolution = 96;
        let (sets, rms) = choose(&s, &base, resolution);
        let plain = StripSets { opacity: base.shading, ..base };
        let (mut auto_err, mut seed_err, mut plain_err) = (0.0, 0.0, 0.0);
        for d in &directions()[6..] {
            let view = LightView::new(&s, *d, resolution, &base);
            auto_err += view.squared_error(&s, &sets).0;
            seed_err += view.squared_error(&s, &base).0;
            plain_err += view.squared_error(&s, &plain).0;
        }
        eprintln!(
            "{name}: auto {:?} (rms {rms:.4} on the axes); diagonals: auto {auto_err:.4}, seed {seed_err:.4}, plain {plain_err:.4}",
            sets.opacity
        );
        assert!(
            auto_err < seed_err && auto_err < plain_err,
            "{name}: auto {auto_err} seed {seed_err} plain {plain_err}"
        );
        assert!(sets.opacity.0 > base.shading.0 && sets.opacity.1 < base.shading.1, "{name}: {sets:?}");
        let (a, b) = (sets.opacity.0 * sets.opacity.1, base.shading.0 * base.shading.1);
        assert!((a / b - 1.0).abs() < 1e-4, "{name}: width × opacity {a} vs {b}");
    }
}

#[test]
fn same_bytes_at_any_thread_count() {
    let s = synth::hair(3000, 9, 4);
    let sets = StripSets::from_source(&s);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| build(&s, &sets));
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap().install(|| build(&s, &sets));
    assert_eq!(one, three);
    assert_eq!(one.mesh.desc.check(one.mesh.bytes.len() as u64), Ok(()));
}

/// The one-walk scoring of every candidate gives exactly what scoring each alone gives.
#[test]
fn scoring_candidates_together_equals_scoring_each() {
    let s = synth::hair(800, 10, 3);
    let base = StripSets::from_source(&s);
    let view = LightView::new(&s, directions()[7], 64, &base);
    let candidates: Vec<(f32, f32)> = (0..9)
        .map(|k| base.shading.0 * 2f32.powi(k))
        .map(|w| (w, hikage_bake::strands::auto::matching_alpha(&base, w)))
        .collect();
    let together = view.squared_errors(&s, &candidates);
    for (k, &opacity) in candidates.iter().enumerate() {
        let alone = view.squared_error(&s, &StripSets { opacity, ..base });
        assert_eq!(together[k], alone, "candidate {k}");
    }
    assert!(together.iter().any(|e| e.0 > 0.0) && together[0] != together[8]);
}
