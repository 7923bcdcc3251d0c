//! Loading a bundle at run time: `CpuBundle::read` (every payload read, hashed with BLAKE3 and
//! decoded, payloads in parallel) on the default bundle and on a 2048²×64 horizon bundle, raw
//! and zstd, against reading the same payload files from the page cache alone.

use std::path::{Path, PathBuf};

use hikage_bake::heightfield::Heightfield;
use hikage_bake::horizon::{self, HorizonParams};
use hikage_bake::run::{RunOptions, run_pipeline};
use hikage_bundle::{BundleWriter, Settings, Supercompression, WriteMode};
use hikage_devkit::synth;
use hikage_runtime::CpuBundle;

use crate::best_of;

/// The load rows (issue 21).
pub fn run() {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!("Bundle loading: CpuBundle::read, best of 3, {threads} threads, the files in the page cache\n");
    println!(
        "| bundle | payload on disk | decoded | read + hash + decode | MiB/s of payload | baseline: plain file reads | ratio |"
    );
    println!("|---|---|---|---|---|---|---|");
    let scratch = std::env::temp_dir().join(format!("hikage-bench-load-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);

    // The default pipeline, baked fresh from data/.
    let default = scratch.join("default");
    std::fs::create_dir_all(&default).expect("a scratch directory");
    std::fs::copy("pipeline.ron", default.join("pipeline.ron")).expect("run from the repository root");
    copy_dir(Path::new("data"), &default.join("data"));
    run_pipeline(&default.join("pipeline.ron"), &RunOptions::default()).expect("the default pipeline bakes");
    let assets = hikage_bundle::Bundle::open(&default.join("bundle")).map_or(0, |b| b.manifest().assets.len());
    row(&format!("default pipeline ({assets} assets)"), &default.join("bundle"));

    // One large horizon map, raw and zstd.
    let n = 2048;
    let mut hf = Heightfield::from_samples(n, n, synth::terrain(n));
    hf.texel_size = (30.0, 30.0);
    hf.height_scale = 1500.0;
    let params = HorizonParams { directions: 64, ..HorizonParams::default() };
    let baked = horizon::bake(&hf, &params, &|_, _| {}).expect("valid settings");
    drop(hf);
    for supercompression in [Supercompression::None, Supercompression::Zstd] {
        let dir = scratch.join(format!("{supercompression:?}"));
        let mut texture = baked.texture.clone();
        texture.desc.supercompression = supercompression;
        let mut writer = BundleWriter::open(&dir, WriteMode::Replace).expect("a scratch bundle");
        writer.put_texture("terrain.horizon", Settings::Generic, "bench", &texture).expect("written");
        writer.commit().expect("committed");
        row(&format!("2048²×64 rg16f horizon, {supercompression:?}"), &dir);
    }
    let _ = std::fs::remove_dir_all(&scratch);
    println!();
}

fn row(name: &str, dir: &Path) {
    let files: Vec<PathBuf> = hikage_bundle::Bundle::open(dir)
        .expect("the bundle opens")
        .manifest()
        .assets
        .iter()
        .map(|a| dir.join(&a.file))
        .collect();
    let on_disk: u64 = files.iter().map(|f| std::fs::metadata(f).map_or(0, |m| m.len())).sum();
    let (t_plain, _) = best_of(3, || files.iter().map(|f| std::fs::read(f).map_or(0, |b| b.len())).sum::<usize>());
    let (t, cpu) = best_of(3, || CpuBundle::read(dir).expect("the bundle reads"));
    let decoded = decoded_bytes(&cpu);
    let mib = |b: f64| b / (1024.0 * 1024.0);
    println!(
        "| {name} | {:.1} MiB | {:.1} MiB | {:.3} s | {:.0} | {:.3} s ({:.0} MiB/s) | {:.1}× its time |",
        mib(on_disk as f64),
        mib(decoded as f64),
        t,
        mib(on_disk as f64) / t,
        t_plain,
        mib(on_disk as f64) / t_plain,
        t / t_plain
    );
}

/// The bytes of every payload of `cpu` as decoded: texture levels and mesh buffers.
pub fn decoded_bytes(cpu: &CpuBundle) -> usize {
    cpu.assets
        .iter()
        .map(|a| match &a.payload {
            hikage_runtime::PayloadData::Texture(t) => t.levels.iter().map(Vec::len).sum(),
            hikage_runtime::PayloadData::Mesh(m) => m.bytes.len(),
        })
        .sum()
}

pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("a scratch directory");
    for e in std::fs::read_dir(from).expect("data/ exists").flatten() {
        if e.file_type().is_ok_and(|t| t.is_file()) {
            std::fs::copy(e.path(), to.join(e.file_name())).expect("copied");
        }
    }
}
