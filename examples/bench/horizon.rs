//! Horizon and distance maps: throughput, brute force, GRASS r.horizon, peak memory.

use crate::{best_of, peak_rss_mib, reset_peak_rss, rss_mib};
use hikage_bake::heightfield::Heightfield;
use hikage_bake::horizon::{self, HorizonFormat, HorizonParams, OPEN_SKY_SLOPE};
use hikage_bundle::EdgeMode;
use hikage_devkit::brute_force;
use hikage_devkit::synth;

fn terrain(n: u32) -> Heightfield {
    let mut hf = Heightfield::from_samples(n, n, synth::terrain(n));
    hf.texel_size = (30.0, 30.0);
    hf.height_scale = 1500.0;
    hf
}

/// The horizon rows (issue 3).
pub fn run() {
    brute_force_rows();
    throughput_rows();
    // At the throughput rows' 1024²×16 too: r.horizon's time grows faster than the map (its rays
    // are longer), so the ratio depends on the size. One r.horizon run there takes ~30 s.
    for size in [512, 1024] {
        grass_row(size);
    }
}

/// Brute force vs the baker at 256², same input and settings, with the accuracy it reaches.
fn brute_force_rows() {
    let hf = terrain(256);
    let s =
        HorizonParams { directions: 16, edge: EdgeMode::Clamp, format: HorizonFormat::Rg32Float, ..Default::default() };
    let (t_fast, baked) = best_of(3, || horizon::bake(&hf, &s, &|_, _| {}).expect("valid settings"));
    let (t_brute, brute) = best_of(1, || {
        use rayon::prelude::*;
        (0..256 * 256 * 16)
            .into_par_iter()
            .map(|i| {
                let phi = std::f64::consts::TAU * (i / (256 * 256)) as f64 / 16.0;
                brute_force::horizon(&hf, &s, i / 256 % 256, i % 256, phi).0
            })
            .collect::<Vec<f64>>()
    });
    let td = 256.0 * 256.0 * 16.0;
    println!(
        "| horizon bake vs brute force | 256²×16, clamp | {:.3} s | {:.2e} texel-dir/s | brute force {:.2} s (same threads) | {:.0}× |",
        t_fast,
        td / t_fast,
        t_brute,
        t_brute / t_fast
    );
    let mut errs: Vec<f64> = (0..brute.len())
        .map(|i| {
            let k = i / (256 * 256);
            let (row, col) = (i / 256 % 256, i % 256);
            let b = horizon::decode(&baked, k, row, col).0;
            match (b <= OPEN_SKY_SLOPE, brute[i] == f64::NEG_INFINITY) {
                (true, true) => 0.0,
                (false, false) => ((b as f64).atan() - brute[i].atan()).abs().to_degrees(),
                _ => 180.0,
            }
        })
        .collect();
    errs.sort_by(f64::total_cmp);
    let n = errs.len();
    println!(
        "| horizon error vs brute force (β) | 256²×16, rough terrain | mean {:.4}° | p99 {:.4}° | max {:.3}° | — |",
        errs.iter().sum::<f64>() / n as f64,
        errs[n * 99 / 100],
        errs[n - 1]
    );
}

/// Throughput at the sizes, f16 output, and the peak memory of the larger bake; the other
/// formats against f16 at the smaller size, and their peak memory.
fn throughput_rows() {
    let mut t_rg16f = 0.0;
    for (size, dirs, runs) in [(1024u32, 16u32, 3usize), (2048, 64, 2)] {
        let hf = terrain(size);
        let s = HorizonParams { directions: dirs, edge: EdgeMode::Clamp, ..Default::default() };
        // The peak of the bakes alone: above what the process holds with the input made (the
        // allocator may keep memory that making it or earlier rows freed).
        let base = rss_mib();
        let reset = reset_peak_rss();
        let (t, out) = best_of(runs, || horizon::bake(&hf, &s, &|_, _| {}).expect("valid settings"));
        let peak = peak_rss_mib().filter(|_| reset);
        let td = size as f64 * size as f64 * dirs as f64;
        let out_mib = out.texture.levels[0].len() as f64 / (1 << 20) as f64;
        drop(out);
        println!(
            "| horizon bake, rg16f | {size}²×{dirs}, clamp | {t:.2} s | {:.2e} texel-dir/s ({:.1} ns each) | target 1e8/s | {:.2}× of target |",
            td / t,
            t * 1e9 / td,
            td / t / 1e8
        );
        if size == 2048 {
            memory_row("rg16f", size, dirs, peak.zip(base).map(|(p, b)| p - b), out_mib);
        } else {
            t_rg16f = t;
        }
    }
    let (size, dirs) = (1024u32, 16u32);
    let hf = terrain(size);
    // The other formats, and wrap (the default edge mode, for tileable bump maps: rays run one
    // map length on the torus), against the rg16f clamp bake above.
    let td = size as f64 * size as f64 * dirs as f64;
    for (format, edge) in [
        (HorizonFormat::Rg8Unorm, EdgeMode::Clamp),
        (HorizonFormat::Rg32Float, EdgeMode::Clamp),
        (HorizonFormat::Rg16Float, EdgeMode::Wrap),
    ] {
        let s = HorizonParams { directions: dirs, edge, format, ..Default::default() };
        let (t, _) = best_of(3, || horizon::bake(&hf, &s, &|_, _| {}).expect("valid settings"));
        println!(
            "| horizon bake, {} | {size}²×{dirs}, {} | {t:.2} s | {:.2e} texel-dir/s | rg16f, clamp {t_rg16f:.2} s (above) | {:.2}× its time |",
            format.texture_format().short_name(),
            if edge == EdgeMode::Wrap { "wrap" } else { "clamp" },
            td / t,
            t / t_rg16f
        );
    }
    // The other formats: one bake each.
    for format in [HorizonFormat::Rg8Unorm, HorizonFormat::Rg32Float] {
        let (size, dirs) = (2048u32, 64u32);
        let hf = terrain(size);
        let s = HorizonParams { directions: dirs, edge: EdgeMode::Clamp, format, ..Default::default() };
        let base = rss_mib();
        let reset = reset_peak_rss();
        let out = horizon::bake(&hf, &s, &|_, _| {}).expect("valid settings");
        let peak = peak_rss_mib().filter(|_| reset);
        let out_mib = out.texture.levels[0].len() as f64 / (1 << 20) as f64;
        drop(out);
        memory_row(format.texture_format().short_name(), size, dirs, peak.zip(base).map(|(p, b)| p - b), out_mib);
    }
}

/// The peak-memory row of a `size`² bake, from the bake's own peak (MiB above the process with
/// its input made, if measurable) plus the input.
fn memory_row(format: &str, size: u32, dirs: u32, bake_peak: Option<f64>, out_mib: f64) {
    let input_mib = size as f64 * size as f64 * 4.0 / (1 << 20) as f64;
    let target = out_mib + 2.0 * input_mib;
    match bake_peak {
        Some(bake) => println!(
            "| peak memory of the bake, {format} | {size}²×{dirs} | {:.0} MiB: the bake's {bake:.0} MiB + the input | output {out_mib:.0} MiB, input {input_mib:.0} MiB (f32) | target ≤ output + 2× input = {target:.0} MiB | {:.3}× of target |",
            bake + input_mib,
            (bake + input_mib) / target
        ),
        None => println!(
            "| peak memory of the bake, {format} | {size}²×{dirs} | — | — | not measurable here (needs Linux /proc/self/clear_refs) | — |"
        ),
    }
}

/// GRASS GIS `r.horizon` on the same heightfield and directions, when `grass` is installed
/// (`apt-get install grass-core`): the same 30 m terrain written as an ASCII grid into a
/// temporary UTM project; only the `r.horizon` call is timed (it runs on one thread; its own
/// pruning makes it far faster than a plain brute force).
fn grass_row(size: u32) {
    let dirs = 16u32;
    let installed = std::process::Command::new("grass").arg("--version").output().is_ok_and(|o| o.status.success());
    if !installed {
        println!("| GRASS r.horizon | {size}²×{dirs} | — | — | not installed (apt-get install grass-core) | — |");
        return;
    }
    let hf = terrain(size);
    let s = HorizonParams { directions: dirs, edge: EdgeMode::Clamp, ..Default::default() };
    let (t_ours, _) = best_of(3, || horizon::bake(&hf, &s, &|_, _| {}).expect("valid settings"));
    let dir = std::env::temp_dir().join(format!("hikage-bench-grass-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut asc = format!(
        "north: {}\nsouth: 5000000\neast: {}\nwest: 500000\nrows: {size}\ncols: {size}\n",
        5_000_000 + size * 30,
        500_000 + size * 30
    );
    for row in 0..size as usize {
        let line: Vec<String> = (0..size as usize)
            .map(|col| format!("{:.3}", hf.samples[row * size as usize + col] * hf.height_scale))
            .collect();
        asc.push_str(&line.join(" "));
        asc.push('\n');
    }
    std::fs::write(dir.join("dem.asc"), asc).expect("write grid");
    let script = format!(
        "cd {} && r.in.ascii input=dem.asc output=dem --quiet && g.region raster=dem && \
         s=$(date +%s.%N) && r.horizon elevation=dem step={} output=hor --quiet && e=$(date +%s.%N) && \
         echo RHORIZON $s $e",
        dir.display(),
        360.0 / dirs as f64
    );
    let out = std::process::Command::new("grass")
        .args(["--tmp-location", "EPSG:32633", "--exec", "bash", "-c", &script])
        .output();
    let _ = std::fs::remove_dir_all(&dir);
    let text = out.map(|o| String::from_utf8_lossy(&o.stdout).into_owned()).unwrap_or_default();
    let times: Vec<f64> = text
        .lines()
        .find(|l| l.starts_with("RHORIZON"))
        .map(|l| l.split_whitespace().skip(1).filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_default();
    match times.as_slice() {
        [start, end] => {
            let t_grass = end - start;
            println!(
                "| horizon bake vs GRASS r.horizon | {size}²×{dirs}, clamp | {t_ours:.3} s | {:.2e} texel-dir/s | r.horizon {t_grass:.2} s (1 thread) | {:.0}× |",
                (size * size * dirs) as f64 / t_ours,
                t_grass / t_ours
            );
        }
        _ => println!("| GRASS r.horizon | {size}²×{dirs} | — | — | installed, but the run failed | — |"),
    }
}
