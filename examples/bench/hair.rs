//! Hair strips: strands per second for the 10,000-strand sample and a 1,000,000-strand set, and
//! peak memory against the output's size.

use hikage_bake::strands::strips::{self, StripSets};
use hikage_devkit::synth;

use crate::best_of;

/// Resets the process's peak-RSS mark (Linux: `5` to `/proc/self/clear_refs`).
fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// The hair rows (issue 5).
pub fn run() {
    let threads = rayon::current_num_threads();
    println!("Hair strips ({threads} threads; both sets in one mesh, 60 bytes a vertex)\n");
    println!("| input | build | strands/s | baseline | ratio | peak memory | output |");
    println!("|---|---|---|---|---|---|---|");
    let bytes = std::fs::read("data/head.hair").expect("run from the repository root (data/ is read)");
    let (t_read, s) =
        best_of(5, || hikage_bake::strands::cyhair::decode(&bytes, &Default::default()).expect("the sample is valid"));
    let sets = StripSets::from_source(&s);
    let (t, mesh) = best_of(5, || strips::build(&s, &sets));
    println!(
        "| data/head.hair: 10,000 × 22 = 220,000 points | {:.1} ms (+ {:.1} ms reading) | {:.2e} | target 50 ms | {:.2}× of the budget | — | {:.0} MiB |",
        t * 1e3,
        t_read * 1e3,
        s.segments.len() as f64 / t,
        (t + t_read) / 0.050,
        mesh.0.bytes.len() as f64 / (1 << 20) as f64
    );
    drop(mesh);
    let (t_auto, _) = best_of(2, || hikage_bake::strands::auto::choose(&s, &sets, 256));
    println!("| auto opacity set for a 256² map, same input | {:.0} ms | — | — | — | — | — |", t_auto * 1e3);
    drop(s);

    let big = synth::hair(1_000_000, 22, 99);
    let input = big.points.len() * 12 + big.points.len() * 8;
    let sets = StripSets::from_source(&big);
    let mut peak = f64::NAN;
    let (t, out) = best_of(2, || {
        let fresh = reset_peak();
        let before = crate::peak_rss_mib().unwrap_or(f64::NAN);
        let r = strips::build(&big, &sets);
        if fresh {
            peak = crate::peak_rss_mib().unwrap_or(f64::NAN) - before;
        }
        r
    });
    let out_mib = out.0.bytes.len() as f64 / (1 << 20) as f64;
    println!(
        "| generated: 1,000,000 × 22 = 22,000,000 points | {t:.2} s | {:.2e} | target 5 s | {:.2}× of the budget | +{peak:.0} MiB over the {:.0} MiB input (target ≤ 2× output) | {out_mib:.0} MiB |",
        big.segments.len() as f64 / t,
        t / 5.0,
        input as f64 / (1 << 20) as f64,
    );
    println!();
}
