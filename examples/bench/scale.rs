//! Tiled horizon bakes (issue 22). An 8k² synthetic DEM (a raw `.r32`, generated, not committed)
//! baked whole and in 1k² tiles, each bake a separate process measured by `/usr/bin/time`
//! (wall time, peak RSS), every tile compared byte for byte with the whole map's region; then a
//! 16k² × 32-direction map in tiles, whose 32 GiB of output this 24 GiB machine cannot hold.
//!
//! The whole 8k² × 32 map is 8 GiB of rg16f: above the bundle's 4 GiB per texture (and a GPU's
//! 3D texture limits), so it can only be a bundle asset as tiles. The baseline is therefore the
//! library's whole-map bake (`horizon::bake` on the same input, settings and threads), its
//! texels written to a plain file; the tiled bake is `run_pipeline` writing a bundle.
//!
//! Each bake takes minutes, so each runs once (peak memory is not noisy; the times are wall
//! times of one run). The scratch directory needs ~50 GiB of free disk.

use std::os::unix::fs::FileExt;
use std::path::Path;
use std::process::Command;

use hikage_bake::horizon::{self, HorizonParams};
use hikage_bundle::{Bundle, EdgeMode};
use hikage_devkit::synth;

/// Texels per tile side.
const TILE: u32 = 1024;
/// Directions of every bake.
const DIRECTIONS: u32 = 32;

/// The scale rows.
pub fn run() {
    let threads = rayon::current_num_threads();
    let scratch = std::env::temp_dir().join(format!("hikage-bench-scale-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(&scratch).expect("a scratch directory");
    println!(
        "Tiled horizon bakes: rg16f, clamp, {DIRECTIONS} directions, {TILE}² tiles, {threads} threads; each bake a process of its own, one run, wall time and peak RSS from /usr/bin/time\n"
    );
    println!("| bake | input | time | peak RSS | output | baseline | ratio |");
    println!("|---|---|---|---|---|---|---|");

    let n = 8192;
    let (md, halo) = write_dem(&scratch, n);
    let whole = bake_whole(&scratch, n, md);
    let tiled = bake(&scratch, "tiled", n, md, TILE);
    let (tiles, texels) = compare(&scratch.join("whole.raw"), n, &scratch.join("tiled"));
    let input = format!("{n}² DEM (.r32, 256 MiB), max_distance {md} m (halo {halo} texels)");
    println!(
        "| whole map | {input} | {:.0} s | {:.0} MiB | {:.0} MiB | — | — |",
        whole.seconds, whole.peak_mib, whole.output_mib
    );
    println!(
        "| {} tiles | {input} | {:.0} s | {:.0} MiB | {:.0} MiB | whole map {:.0} MiB peak, {:.0} s | **{:.3}×** its peak RSS, {:.2}× its time |",
        tiled.tiles,
        tiled.seconds,
        tiled.peak_mib,
        tiled.output_mib,
        whole.peak_mib,
        whole.seconds,
        tiled.peak_mib / whole.peak_mib,
        tiled.seconds / whole.seconds
    );
    println!(
        "| tiles = whole map | {tiles} tiles, {texels} texel-directions | — | — | — | the whole map's regions, byte for byte | all identical |"
    );
    let _ = std::fs::remove_file(scratch.join("whole.raw"));
    let _ = std::fs::remove_dir_all(scratch.join("tiled"));

    let n = 16384;
    let (md, halo) = write_dem(&scratch, n);
    let big = bake(&scratch, "big", n, md, TILE);
    let whole_mib = n as f64 * n as f64 * DIRECTIONS as f64 * 4.0 / (1 << 20) as f64;
    println!(
        "| {} tiles | {n}² DEM (.r32, 1 GiB), max_distance {md} m (halo {halo} texels) | {:.0} s | {:.0} MiB | {:.0} MiB | a whole-map bake holds its {:.0} MiB output (machine: {:.0} MiB) | {:.3}× of the output |",
        big.tiles,
        big.seconds,
        big.peak_mib,
        big.output_mib,
        whole_mib,
        machine_mib(),
        big.peak_mib / whole_mib
    );
    let _ = std::fs::remove_dir_all(&scratch);
    println!();
}

/// Writes an `n`² DEM: the devkit's rough terrain at texels of `3.75 · 8192 / n` m and 1500 m of
/// relief. Returns `max_distance` (64 texels) and the halo a tile reads.
pub(crate) fn write_dem(scratch: &Path, n: u32) -> (f32, u32) {
    let samples = synth::terrain(n);
    let bytes: Vec<u8> = samples.iter().flat_map(|v| (v * 1500.0).to_le_bytes()).collect();
    drop(samples);
    std::fs::write(scratch.join("dem.r32"), bytes).expect("the DEM is written");
    let texel = texel(n);
    let md = 64.0 * texel;
    (md, (md / texel).ceil() as u32 + 3)
}

pub(crate) fn texel(n: u32) -> f32 {
    3.75 * 8192.0 / n as f32
}

/// One bake's figures.
struct Measured {
    /// Horizon assets written (tiles).
    tiles: usize,
    seconds: f64,
    peak_mib: f64,
    output_mib: f64,
}

/// A 16384² pyramid (issue 38): the DEM of the scale rows baked in 1024² tiles with every
/// level of detail, 16 directions in BC5 (the disk here holds its 6 GiB), against the same bake
/// of level 0 alone; a process each under `/usr/bin/time`.
pub fn run_pyramid() {
    let threads = rayon::current_num_threads();
    let scratch = std::env::temp_dir().join(format!("hikage-bench-pyramid-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(&scratch).expect("a scratch directory");
    println!(
        "A 16384² pyramid: BC5, clamp, 16 directions, {TILE}² tiles, {threads} threads; one run each, wall time and peak RSS from /usr/bin/time\n"
    );
    println!("| bake | tiles | time | tiles/s | peak RSS | output | baseline | ratio |");
    println!("|---|---|---|---|---|---|---|---|");
    let n = 16384;
    let (md, halo) = write_dem(&scratch, n);
    let extra = "directions: 16, format: Bc5RgUnorm, ao: true";
    let level0 = bake_with(&scratch, "level0", n, md, TILE, extra);
    let _ = std::fs::remove_dir_all(scratch.join("level0"));
    let pyramid = bake_with(&scratch, "pyramid", n, md, TILE, &format!("{extra}, levels: 16"));
    for (name, m) in [("level 0 only", &level0), ("every level", &pyramid)] {
        println!(
            "| {name} | {} | {:.0} s | {:.2} | {:.0} MiB | {:.0} MiB | level 0 only, {:.0} s | {:.2}× its time, {:.2}× its peak |",
            m.tiles,
            m.seconds,
            m.tiles as f64 / m.seconds,
            m.peak_mib,
            m.output_mib,
            level0.seconds,
            m.seconds / level0.seconds,
            m.peak_mib / level0.peak_mib
        );
    }
    println!("\n{n}² DEM (.r32, 1 GiB), max_distance {md} m (halo {halo} texels).\n");
    let _ = std::fs::remove_dir_all(&scratch);
}

/// Bakes the DEM in `scratch` in `tile`² tiles into bundle `name`, in a child process under
/// `/usr/bin/time`.
fn bake(scratch: &Path, name: &str, n: u32, md: f32, tile: u32) -> Measured {
    bake_with(scratch, name, n, md, tile, &format!("directions: {DIRECTIONS}"))
}

/// [`bake`] with `extra` settings (`directions` among them).
fn bake_with(scratch: &Path, name: &str, n: u32, md: f32, tile: u32, extra: &str) -> Measured {
    let pipeline = format!(
        r#"(output: "{name}", jobs: [Horizon(id: "dem", input: "dem.r32", texel_size: ({t}, {t}),
            {extra}, edge: Clamp, max_distance: {md}, tile: {tile})])"#,
        t = texel(n)
    );
    let path = scratch.join(format!("{name}.ron"));
    std::fs::write(&path, pipeline).expect("the pipeline is written");
    let (seconds, peak_mib) = timed(&["--bake-child".as_ref(), path.as_os_str()]);
    let bundle = Bundle::open(&scratch.join(name)).expect("the bundle opens");
    let assets = &bundle.manifest().assets;
    let output: u64 = assets.iter().map(|a| a.byte_length).sum();
    let tiles = assets.iter().filter(|a| a.settings.horizon().is_some()).count();
    Measured { tiles, seconds, peak_mib, output_mib: output as f64 / (1 << 20) as f64 }
}

/// Bakes the DEM in `scratch` whole with the library, in a child process under
/// `/usr/bin/time`, its texels written to `whole.raw`.
fn bake_whole(scratch: &Path, n: u32, md: f32) -> Measured {
    let (seconds, peak_mib) = timed(&["--bake-whole-child".as_ref(), scratch.as_os_str(), md.to_string().as_ref()]);
    let bytes = std::fs::metadata(scratch.join("whole.raw")).expect("the whole map is written").len();
    assert_eq!(bytes, n as u64 * n as u64 * DIRECTIONS as u64 * 4);
    Measured { tiles: 1, seconds, peak_mib, output_mib: bytes as f64 / (1 << 20) as f64 }
}

/// Runs this bench's executable with `args` under `/usr/bin/time`: wall seconds and peak RSS
/// in MiB.
pub(crate) fn timed(args: &[&std::ffi::OsStr]) -> (f64, f64) {
    let exe = std::env::current_exe().expect("the bench's own path");
    let out = Command::new("/usr/bin/time")
        .args(["-f", "%e %M"])
        .arg(exe)
        .args(args)
        .output()
        .expect("/usr/bin/time runs (apt-get install time)");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?} failed: {stderr}");
    let last = stderr.lines().last().unwrap_or_default();
    let mut fields = last.split_whitespace().map(|f| f.parse::<f64>().unwrap_or(f64::NAN));
    let (seconds, kib) = (fields.next().unwrap_or(f64::NAN), fields.next().unwrap_or(f64::NAN));
    (seconds, kib / 1024.0)
}

/// A child process: bakes the pipeline at `path`, everything forced (or, `again`, only what
/// changed).
pub fn bake_child(path: &Path, again: bool) {
    let options = hikage_bake::RunOptions { force: !again, ..Default::default() };
    hikage_bake::run_pipeline(path, &options).expect("the pipeline bakes");
}

/// A child process: the whole-map bake of `scratch/dem.r32` with the tiled bake's settings, its
/// texels written to `scratch/whole.raw`.
pub fn bake_whole_child(scratch: &Path, md: f32) {
    let options = hikage_bake::LoadOptions::default();
    let samples = hikage_bake::heightfield::load_samples(&scratch.join("dem.r32"), &options).expect("the DEM reads");
    let n = samples.width;
    let mut hf = hikage_bake::Heightfield::from_samples(n, samples.height, samples.values);
    hf.texel_size = (texel(n), texel(n));
    let params = HorizonParams {
        directions: DIRECTIONS,
        edge: EdgeMode::Clamp,
        max_distance: Some(md),
        ..HorizonParams::default()
    };
    let baked = horizon::bake(&hf, &params, &|_, _| {}).expect("valid settings");
    drop(hf);
    std::fs::write(scratch.join("whole.raw"), &baked.texture.levels[0]).expect("the whole map is written");
}

/// Compares every horizon tile of bundle `tiled` with the same region of the whole `n`² map's
/// texels in `whole`, read a row at a time. Returns the tiles and texel-directions compared;
/// panics on the first differing byte.
fn compare(whole: &Path, n: u32, tiled: &Path) -> (usize, u64) {
    let file = std::fs::File::open(whole).expect("the whole map");
    let (w, h) = (n as u64, n as u64);
    let tiled = Bundle::open(tiled).expect("the tiled bundle opens");
    let mut tiles = 0;
    let mut texels = 0u64;
    let ids: Vec<String> =
        tiled.manifest().assets.iter().filter(|a| a.id.starts_with("dem.horizon.")).map(|a| a.id.clone()).collect();
    for id in ids {
        let Some(hikage_bundle::Settings::Horizon(s)) = tiled.asset(&id).ok().map(|a| a.settings.clone()) else {
            panic!("{id} is a horizon")
        };
        let place = s.tile.expect("a tile has a placement");
        let tile = tiled.read_texture(&id).expect("the tile reads");
        let (tw, th, tb) = (tile.desc.width as u64, tile.desc.height as u64, 4u64);
        let mut row = vec![0u8; (tw * tb) as usize];
        for k in 0..DIRECTIONS as u64 {
            for y in 0..th {
                let at = ((k * h + place.origin.1 as u64 + y) * w + place.origin.0 as u64) * tb;
                file.read_exact_at(&mut row, at).expect("the whole map's row");
                let from = ((k * th + y) * tw * tb) as usize;
                assert!(
                    tile.levels[0][from..from + row.len()] == row[..],
                    "{id}: direction {k}, row {y} differs from the whole map"
                );
            }
        }
        tiles += 1;
        texels += tw * th * DIRECTIONS as u64;
    }
    (tiles, texels)
}

/// This machine's memory, MiB.
fn machine_mib() -> f64 {
    let info = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    let kib = info.lines().find(|l| l.starts_with("MemTotal:")).and_then(|l| l.split_whitespace().nth(1)?.parse().ok());
    kib.unwrap_or(0.0) / 1024.0
}
