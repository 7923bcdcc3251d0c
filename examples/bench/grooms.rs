//! Grooms from USD and Alembic against the same groom from `.hair` (issue 52): 100,000 generated
//! strands of 22 points with per-point widths, written as a `.hair` file, as a binary USD `.usdc`
//! (`BasisCurves`, vertex widths, through the `openusd` crate's writer) and as an Alembic `.abc`
//! (one `AbcGeom_Curve_v2` object with `P`, `nVertices` and `width`, by
//! [`hikage_devkit::alembic`]), each baked by a
//! `Strands` job in a process of its own under `/usr/bin/time` (wall time, peak RSS), best of
//! 3; then the read alone (`StrandsJob::load`) in this process, best of 3.

use std::path::Path;

use hikage_bake::jobs::StrandsJob;
use hikage_bake::strands::Strands;
use openusd::gf::Vec3f;
use openusd::schemas::geom::{self, Curves, PointBased};
use openusd::sdf;
use openusd::usd;

use crate::best_of;
use crate::scale::timed;

const STRANDS: u32 = 100_000;
const POINTS: u16 = 22;

/// `s` as one linear `BasisCurves` prim with vertex widths, in a binary crate file.
fn write_usdc(s: &Strands, path: &Path) {
    let stage = usd::Stage::builder().in_memory("groom.usdc").expect("an in-memory stage");
    let curves = geom::BasisCurves::define(&stage, "/Groom").expect("a prim");
    let counts: Vec<i32> = s.segments.iter().map(|&n| n as i32 + 1).collect();
    curves.create_curve_vertex_counts_attr().and_then(|a| Ok(a.set(sdf::Value::IntVec(counts))?)).expect("counts");
    let points: Vec<Vec3f> = s.points.iter().map(|p| Vec3f { x: p[0], y: p[1], z: p[2] }).collect();
    curves.create_points_attr().and_then(|a| Ok(a.set(sdf::Value::Vec3fVec(points))?)).expect("points");
    curves.create_type_attr().and_then(|a| Ok(a.set(sdf::Value::Token("linear".into()))?)).expect("type");
    let widths = s.thickness.clone().unwrap_or_else(|| vec![s.default_thickness; s.points.len()]);
    curves.create_widths_attr().and_then(|a| Ok(a.set(sdf::Value::FloatVec(widths))?)).expect("widths");
    stage.root_layer().export(path.to_str().expect("a UTF-8 path")).expect("the stage is written");
}

/// `s` as an Alembic archive: one curves object with `P`, `nVertices` and a vertex `width`.
fn write_abc(s: &Strands, path: &Path) {
    use hikage_devkit::alembic::{Prop, archive, curves};
    let counts: Vec<i32> = s.segments.iter().map(|&n| n as i32 + 1).collect();
    let widths = s.thickness.clone().unwrap_or_else(|| vec![s.default_thickness; s.points.len()]);
    let width = Prop::floats("width", 1, "geoScope=vtx;isGeomParam=true", &widths);
    std::fs::write(path, archive(&[curves("groom", &s.points, &counts, vec![width])])).expect("the .abc file");
}

pub fn run() {
    let threads = rayon::current_num_threads();
    let scratch = std::env::temp_dir().join(format!("hikage-bench-grooms-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(&scratch).expect("a scratch directory");
    let mut s = hikage_devkit::synth::hair(STRANDS, POINTS, 7);
    // Widths a groom has: per point, tapering from the root.
    let per_strand = POINTS as usize;
    s.thickness =
        Some((0..s.points.len()).map(|i| s.default_thickness * (1.0 - 0.7 * (i % per_strand) as f32 / 21.0)).collect());
    let hair = scratch.join("groom.hair");
    std::fs::write(&hair, hikage_bake::strands::cyhair::encode(&s, "bench")).expect("the .hair file");
    let usdc = scratch.join("groom.usdc");
    write_usdc(&s, &usdc);
    let abc = scratch.join("groom.abc");
    write_abc(&s, &abc);
    let size = |p: &Path| std::fs::metadata(p).map_or(0, |m| m.len()) as f64 / 1048576.0;
    println!(
        "Grooms: {STRANDS} strands × {POINTS} points with per-point widths; each bake a process under /usr/bin/time, \
         best of 3 (wall time, peak RSS); the read alone in this process, best of 3; {threads} threads\n"
    );
    println!("| input | file | bake | peak RSS | read | baseline | bake ratio | memory ratio | read ratio |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    for (name, input) in [(".hair", &hair), (".usdc", &usdc), (".abc", &abc)] {
        let pipeline = scratch.join(format!("pipeline{}.ron", rows.len()));
        std::fs::write(
            &pipeline,
            format!(r#"(output: "bundle{}", jobs: [Strands(id: "groom", input: "{}")])"#, rows.len(), input.display()),
        )
        .expect("the pipeline is written");
        let runs: Vec<(f64, f64)> = (0..3).map(|_| timed(&["--bake-child".as_ref(), pipeline.as_os_str()])).collect();
        let bake = runs.iter().map(|r| r.0).fold(f64::INFINITY, f64::min);
        let peak = runs.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
        let job = StrandsJob::new("groom", input.clone());
        let (read, loaded) = best_of(3, || job.load(input).expect("the groom reads"));
        assert_eq!(loaded.points.len(), s.points.len());
        rows.push((name, size(input), bake, peak, read));
    }
    let (_, _, hair_bake, hair_peak, hair_read) = rows[0];
    for (name, mib, bake, peak, read) in rows {
        println!(
            "| {name} | {mib:.1} MiB | {bake:.2} s | {peak:.0} MiB | {read:.3} s | .hair | **{:.2}×** | **{:.2}×** | {:.2}× |",
            bake / hair_bake,
            peak / hair_peak,
            read / hair_read
        );
    }
    println!();
    let _ = std::fs::remove_dir_all(&scratch);
}
