//! The benchmark tables of docs/benchmarks.md. Run from the repository root:
//!
//! ```text
//! cargo run --release --example bench              # every table
//! cargo run --release --example bench -- relief    # one: horizon, relief, hair, grooms, fit, load, size, tiles, tile-cost, pyramid, stream, raised, field, fourier, bc
//! cargo run --release --example bench -- scale     # tiled bakes: ~40 min, ~50 GiB of disk
//! cargo run --release --example bench -- pyramid-scale   # a 16384² pyramid: ~20 min, ~8 GiB
//! cargo run --release --example bench -- build-script   # clean builds of a game crate: ~15 min
//! ```
//!
//! `scale`, `pyramid-scale` and `build-script` run only when named: their bakes and builds take minutes each.
//!
//! Every figure is the best of several runs (machines here are noisy), with its baseline
//! measured in the same run. Set `RAYON_NUM_THREADS` to change the thread count.

mod bc;
mod build_script;
mod edit;
mod field;
mod fit;
mod fourier;
mod grooms;
mod hair;
mod horizon;
mod load;
mod pyramid;
mod raised;
mod relief;
mod scale;
mod size;
mod stream;
mod tile_cost;
mod tiles;

use std::time::Instant;

/// Runs `f` `runs` times; the shortest time in seconds and the last result.
pub fn best_of<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..runs {
        drop(out.take()); // never hold two results at once (peak memory is measured)
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.expect("at least one run"))
}

/// Peak resident memory of this process so far, MiB (Linux).
pub fn peak_rss_mib() -> Option<f64> {
    status_mib("VmHWM:")
}

/// Resident memory of this process now, MiB (Linux).
pub fn rss_mib() -> Option<f64> {
    status_mib("VmRSS:")
}

/// A memory line of `/proc/self/status`, in MiB.
fn status_mib(key: &str) -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Resets this process's peak resident memory to its current size (Linux, `clear_refs` 5), so a
/// later [`peak_rss_mib`] measures one phase; false when the kernel refuses.
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let [flag, pipeline] = args.as_slice()
        && (flag == "--bake-child" || flag == "--rebake-child")
    {
        scale::bake_child(std::path::Path::new(pipeline), flag == "--rebake-child");
        return;
    }
    if let [flag, input, out, zstd] = args.as_slice()
        && flag == "--one-shot-child"
    {
        size::one_shot_child(std::path::Path::new(input), std::path::Path::new(out), zstd);
        return;
    }
    if let [flag, scratch, md] = args.as_slice()
        && flag == "--bake-whole-child"
    {
        scale::bake_whole_child(std::path::Path::new(scratch), md.parse().expect("a max_distance"));
        return;
    }
    let wanted = |name: &str| args.is_empty() || args.iter().any(|a| a == name);
    let threads = rayon::current_num_threads();
    println!("hikage benchmarks — {threads} threads, best of N runs\n");
    if wanted("horizon") {
        println!("| figure | input | time | throughput | baseline | ratio |");
        println!("|---|---|---|---|---|---|");
        horizon::run();
        println!();
    }
    if wanted("relief") {
        relief::run();
    }
    if wanted("hair") {
        hair::run();
    }
    if wanted("hair") || wanted("skin") {
        hair::skinned_frames();
    }
    if wanted("fit") {
        fit::run();
    }
    if wanted("load") {
        load::run();
    }
    if wanted("size") {
        size::run();
    }
    if wanted("pyramid") {
        pyramid::run();
    }
    if wanted("stream") {
        stream::run();
    }
    if wanted("raised") {
        raised::run();
    }
    if wanted("field") {
        field::run();
    }
    if wanted("tiles") {
        tiles::run();
    }
    if wanted("grooms") {
        grooms::run();
    }
    if wanted("tile-cost") {
        tile_cost::run();
    }
    if wanted("fourier") {
        fourier::run();
    }
    if wanted("bc") && !wanted("size") {
        bc::run();
    }
    if args.iter().any(|a| a == "scale") {
        scale::run();
    }
    if args.iter().any(|a| a == "pyramid-scale") {
        scale::run_pyramid();
    }
    if let Some(at) = args.iter().position(|a| a == "edit") {
        edit::run(args.get(at + 1).and_then(|n| n.parse().ok()).unwrap_or(4096));
    }
    if args.iter().any(|a| a == "build-script") {
        build_script::run();
    }
}
