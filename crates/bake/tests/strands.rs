//! Strips and the automatic opacity set on generated hair (the generators live in the devkit,
//! so these are integration tests).

use hikage_bake::strands::auto::{LightView, choose, directions, optical_depth};
use hikage_bake::strands::strips::{StripSets, build};
use hikage_devkit::synth;

/// The criterion as a test: the automatic opacity set leaves no hole in the silhouette along
/// the axes it was chosen for nor along the eight diagonals it never saw (at most 0.5% there),
/// keeps the shading set's optical depth within 10%, while the shading set itself used as the
/// opacity set (plain deep opacity maps) leaves holes.
#[test]
fn auto_opacity_set_has_no_holes_and_the_same_optical_depth() {
    let s = synth::hair(1500, 12, 11);
    let base = StripSets::from_source(&s);
    let resolution = 128;
    let (sets, left) = choose(&s, &base, resolution);
    assert_eq!(left, 0.0);
    let ratio = optical_depth(sets.opacity.0, sets.opacity.1) / optical_depth(sets.shading.0, sets.shading.1);
    assert!((ratio - 1.0).abs() <= 0.1, "optical depth ratio {ratio}");
    let plain = StripSets { opacity: base.shading, ..base };
    let mut plain_holes = 0.0f64;
    for (k, d) in directions().into_iter().enumerate() {
        let view = LightView::new(&s, d, resolution);
        let holes = view.hole_share(&s, &sets);
        assert!(holes <= if k < 6 { 0.0 } else { 0.005 }, "direction {d:?}: {holes}");
        plain_holes = plain_holes.max(view.hole_share(&s, &plain));
    }
    assert!(plain_holes > 0.05, "the shading set alone should leave holes: {plain_holes}");
    assert!(sets.opacity.0 > base.shading.0 && sets.opacity.1 < base.shading.1);
}

#[test]
fn same_bytes_at_any_thread_count() {
    let s = synth::hair(3000, 9, 4);
    let sets = StripSets::from_source(&s);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| build(&s, &sets));
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap().install(|| build(&s, &sets));
    assert_eq!(one, three);
    assert_eq!(one.0.desc.check(one.0.bytes.len() as u64), Ok(()));
}
