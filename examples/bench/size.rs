//! What a game ships and holds (issue 31): the default pipeline baked with each payload
//! compression — none, a level per kind (the default), zstd 3 and zstd 19 — with and without block compression
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
        ("pipeline.ron as it is (horizons zstd 19, the rest auto)", "", false),
        ("auto (default)", "Auto", false),
        ("zstd 3", "Zstd(3)", false),
        ("zstd 19", "Zstd(19)", false),
        ("BC", "None", true),
        ("BC + auto", "Auto", true),
        ("BC + zstd 19", "Zstd(19)", true),
    ];
    for (name, compression, bc) in cases {
        let stem = if compression.is_empty() { "as-is".to_string() } else { compression.replace(['(', ')'], "") };
        let dir = scratch.join(format!("{stem}{}", if bc { "-bc" } else { "" }));
        copy_dir(Path::new("data"), &dir.join("data"));
        // The pipeline as it is; or without its budget (the raw bundle is over it by design)
        // and its horizons' own compression, every job given this case's.
        let mut pipeline = text.clone();
        if !compression.is_empty() {
            pipeline = text
                .lines()
                .filter(|l| !l.trim_start().starts_with("budget:"))
                .map(|l| format!("{l}\n"))
                .collect::<String>()
                .replace(", compression: Zstd(19)", "")
                .replace("compression: Zstd(19),", "");
        }
        for kind in KINDS.iter().filter(|_| !compression.is_empty()) {
            let format = match (bc, *kind) {
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
    println!();
    one_shot(&scratch);
    let _ = std::fs::remove_dir_all(&scratch);
    println!();
    crate::bc::run();
}

/// What compression costs a one-shot bake: `hikage horizon` of a 1024² map, 16 directions,
/// rg16f (heights and horizons), each setting a whole process of its own, run in turn so the
/// machine's drift hits all alike, best of 7.
fn one_shot(scratch: &Path) {
    const SIDE: u32 = 1024;
    let input = scratch.join("one-shot.png");
    let heights = hikage_devkit::synth::terrain(SIDE);
    let samples: Vec<u16> = heights.iter().map(|h| (h * 65535.0).round() as u16).collect();
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(SIDE, SIDE, samples)
        .expect("a full map")
        .save(&input)
        .expect("a scratch PNG");
    let exe = std::env::current_exe().expect("the bench's own path");
    let settings = [("none (`--zstd 0`)", "0"), ("auto (default)", "auto"), ("zstd 3 for all", "3")];
    let mut best = [f64::INFINITY; 3];
    let mut sizes = [0u64; 3];
    for _ in 0..7 {
        for (k, (_, zstd)) in settings.iter().enumerate() {
            let out = scratch.join(format!("one-shot-{zstd}"));
            let _ = std::fs::remove_dir_all(&out);
            let t = std::time::Instant::now();
            let status = std::process::Command::new(&exe)
                .args(["--one-shot-child", input.to_str().unwrap(), out.to_str().unwrap(), zstd])
                .status()
                .expect("the bench runs itself");
            best[k] = best[k].min(t.elapsed().as_secs_f64());
            assert!(status.success(), "the one-shot bake failed");
            let summary =
                hikage_bundle::inspect::summarize(hikage_bundle::Bundle::open(&out).expect("opens").manifest());
            sizes[k] = summary.disk_bytes;
        }
    }
    let threads = rayon::current_num_threads();
    println!(
        "One-shot horizon bake, {SIDE}² × 16 directions, rg16f, {threads} threads, whole process, best of 7 (target: the default ≤ 1.1× none):\n"
    );
    println!("| payloads | bake | vs none | on disk | vs none |");
    println!("|---|---|---|---|---|");
    for (k, (name, _)) in settings.iter().enumerate() {
        println!(
            "| {name} | {:.3} s | {:.2}× | {:.1} MiB | {:.2}× |",
            best[k],
            best[k] / best[0],
            sizes[k] as f64 / (1024.0 * 1024.0),
            sizes[k] as f64 / sizes[0] as f64
        );
    }
}

/// The child of [`one_shot`]: the horizon job `hikage horizon INPUT --out OUT --zstd ZSTD` runs.
pub fn one_shot_child(input: &Path, out: &Path, zstd: &str) {
    let mut job = hikage_bake::jobs::HorizonJob::new("one_shot", input.to_path_buf());
    job.options.directions = 16;
    job.source.height_scale = 200.0;
    job.options.compression = hikage_bake::compression::parse_level(zstd).expect("a level");
    hikage_bake::run::run_one_job(&hikage_bake::jobs::Job::Horizon(job), out, &RunOptions::default())
        .expect("the one-shot bake");
}
