//! An edit of a tiled pyramid (issue 51): the scale rows' DEM at `n`² in `n/16`² tiles with
//! every level (341 tiles), BC5, 16 directions, baked whole; then a 20×20-texel square raised
//! and the pipeline baked again, which rebakes only the tiles whose windows hold an edited
//! sample. Each bake a process of its own under `/usr/bin/time` (wall time, peak RSS), one run.

use std::os::unix::fs::FileExt;

use hikage_bundle::Bundle;

use crate::scale::{texel, timed, write_dem};

/// The edit rows at `n`² (4096 by default; the issue's 16384 takes the full bake's half hour).
pub fn run(n: u32) {
    let threads = rayon::current_num_threads();
    let scratch = std::env::temp_dir().join(format!("hikage-bench-edit-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(&scratch).expect("a scratch directory");
    let tile = n / 16;
    let (md, halo) = write_dem(&scratch, n);
    let pipeline = scratch.join("pipeline.ron");
    std::fs::write(
        &pipeline,
        format!(
            r#"(output: "bundle", jobs: [Horizon(id: "dem", input: "dem.r32", texel_size: ({t}, {t}), directions: 16,
                format: Bc5RgUnorm, ao: true, edge: Clamp, max_distance: {md}, tile: {tile}, levels: 16)])"#,
            t = texel(n)
        ),
    )
    .expect("the pipeline is written");
    let hashes = || -> Vec<(String, String)> {
        let bundle = Bundle::open(&scratch.join("bundle")).expect("the bundle opens");
        let mut h: Vec<_> = bundle
            .manifest()
            .assets
            .iter()
            .filter(|a| a.settings.horizon().is_some())
            .map(|a| (a.id.clone(), a.input_hash.clone()))
            .collect();
        h.sort();
        h
    };
    let (full_s, full_peak) = timed(&["--bake-child".as_ref(), pipeline.as_os_str()]);
    let before = hashes();
    // A 20×20-texel square a third of the way in, raised by 30 m.
    let dem = std::fs::OpenOptions::new().read(true).write(true).open(scratch.join("dem.r32")).expect("the DEM");
    let (x0, y0) = (n as u64 / 3, n as u64 / 3);
    for y in y0..y0 + 20 {
        let at = (y * n as u64 + x0) * 4;
        let mut row = vec![0u8; 80];
        dem.read_exact_at(&mut row, at).expect("a row of the DEM");
        let raised: Vec<u8> = row
            .chunks_exact(4)
            .flat_map(|b| (f32::from_le_bytes(b.try_into().expect("4 bytes")) + 30.0).to_le_bytes())
            .collect();
        dem.write_all_at(&raised, at).expect("the edit is written");
    }
    let (edit_s, edit_peak) = timed(&["--rebake-child".as_ref(), pipeline.as_os_str()]);
    let after = hashes();
    let rebaked = before.iter().zip(&after).filter(|(a, b)| a != b).count();
    println!(
        "An edit of a {n}² pyramid: {n}² DEM (.r32), {tile}² tiles with every level ({} tiles), BC5, 16 directions, \
         ao, max_distance {md} m (halo {halo} texels), {threads} threads; one run each, wall time and peak RSS from \
         /usr/bin/time\n",
        before.len()
    );
    println!("| bake | tiles baked | time | peak RSS | baseline | ratio |");
    println!("|---|---|---|---|---|---|");
    println!("| the whole pyramid | {} | {full_s:.1} s | {full_peak:.0} MiB | — | — |", before.len());
    println!(
        "| after a 20×20-texel edit | {rebaked} ({:.2}%) | {edit_s:.2} s | {edit_peak:.0} MiB | the whole pyramid, {full_s:.1} s | **1/{:.0}** of its time |",
        100.0 * rebaked as f64 / before.len() as f64,
        full_s / edit_s
    );
    println!();
    let _ = std::fs::remove_dir_all(&scratch);
}
