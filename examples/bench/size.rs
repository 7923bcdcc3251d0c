//! What a game ships and holds (issue 31): the default pipeline baked with each payload
//! compression — none, zstd's default level and zstd 19 — with and without block compression
//! (BC5 horizons, BC4 relief depth maps), its size on disk and in GPU memory (all of it, and the
//! horizon maps'), the bake's time, and the load (`CpuBundle::read`: read, hash, inflate,
//! decode) in MiB/s, each against the raw bundle of the same run; then what block compression
//! costs in accuracy (`bench -- bc`).

use std::path::Path;

use hikage_bake::run::{RunOptions, run_pipeline};
use hikage_runtime::CpuBundle;

use crate::best_of;
use crate::load::{copy_dir, decoded_bytes};

/// The job kinds of `pipeline.ron`, each given a `compression:` in front of its fields.
const KINDS: [&str; 5] = ["Heightfield(", "Horizon(", "Curvature(", "Relief(", "Strands("];

pub fn run() {
    let threads = rayon::current_num_threads();
    println!("Bundle size: the default pipeline, {threads} threads; load = CpuBundle::read, best of 3, page cache\n");
    println!(
        "| payloads | on disk | vs raw | in GPU memory | horizon maps in GPU memory | bake | load | MiB/s of payload | MiB/s inflated | load vs raw |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let scratch = std::env::temp_dir().join(format!("hikage-bench-size-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    let text = std::fs::read_to_string("pipeline.ron").expect("run from the repository root");
    let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
    let mut raw: Option<(u64, f64, u64)> = None;
    let cases = [
        ("raw", "None", false),
        ("zstd 3 (default)", "Zstd(3)", false),
        ("zstd 19", "Zstd(19)", false),
        ("BC", "None", true),
        ("BC + zstd 3", "Zstd(3)", true),
        ("BC + zstd 19", "Zstd(19)", true),
    ];
    for (name, compression, bc) in cases {
        let dir = scratch.join(format!("{}{}", compression.replace(['(', ')'], ""), if bc { "-bc" } else { "" }));
        copy_dir(Path::new("data"), &dir.join("data"));
        let mut pipeline = text.clone();
        for kind in KINDS {
            let format = match (bc, kind) {
                (true, "Horizon(") => "format: Bc5RgUnorm, ",
                (true, "Relief(") => "format: Bc4RUnorm, ",
                _ => "",
            };
            pipeline = pipeline.replace(kind, &format!("{kind}{format}compression: {compression}, "));
        }
        std::fs::write(dir.join("pipeline.ron"), pipeline).expect("a scratch pipeline");
        let t = std::time::Instant::now();
        run_pipeline(&dir.join("pipeline.ron"), &RunOptions::default()).expect("the default pipeline bakes");
        let bake = t.elapsed().as_secs_f64();
        let bundle = dir.join("bundle");
        let summary =
            hikage_bundle::inspect::summarize(hikage_bundle::Bundle::open(&bundle).expect("opens").manifest());
        let (load, cpu) = best_of(3, || CpuBundle::read(&bundle).expect("the bundle reads"));
        let inflated = decoded_bytes(&cpu);
        let horizons: u64 = summary.assets.iter().filter(|a| a.kind == "horizon").map(|a| a.gpu_bytes).sum();
        let (raw_disk, raw_load, raw_horizons) = *raw.get_or_insert((summary.disk_bytes, load, horizons));
        println!(
            "| {name} | {:.1} MiB | {:.2}× | {:.1} MiB | {:.1} MiB ({:.2}×) | {bake:.1} s | {load:.3} s | {:.0} | {:.0} | {:.2}× |",
            mib(summary.disk_bytes),
            summary.disk_bytes as f64 / raw_disk as f64,
            mib(summary.gpu_bytes),
            mib(horizons),
            horizons as f64 / raw_horizons as f64,
            mib(summary.disk_bytes) / load,
            mib(inflated as u64) / load,
            load / raw_load,
        );
    }
    let _ = std::fs::remove_dir_all(&scratch);
    println!();
    crate::bc::run();
}
