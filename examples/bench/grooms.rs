//! Grooms from USD and Alembic against the same groom from `.hair` (issue 52): 100,000 generated
//! strands of 22 points with per-point widths, written as a `.hair` file, as a binary USD `.usdc`
//! (`BasisCurves`, vertex widths, through the `openusd` crate's writer) and as an Alembic `.abc`
//! (one `AbcGeom_Curve_v2` object with `P`, `nVertices` and `width`, laid out as Alembic's Ogawa
//! writer lays it out, by the small writer below), each baked by a
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

/// `s` as an Ogawa Alembic archive: the top object holding one curves object whose `.geom`
/// holds `P`, `nVertices` and a vertex-scope `width`, each one sample at time 0.
fn write_abc(s: &Strands, path: &Path) {
    const DATA: u64 = 1 << 63;
    let mut out = b"Ogawa\xff\x00\x01".to_vec();
    out.extend([0; 8]);
    let data = |out: &mut Vec<u8>, bytes: &[u8]| {
        let at = out.len() as u64;
        out.extend((bytes.len() as u64).to_le_bytes());
        out.extend(bytes);
        at | DATA
    };
    let group = |out: &mut Vec<u8>, children: &[u64]| {
        let at = out.len() as u64;
        out.extend((children.len() as u64).to_le_bytes());
        children.iter().for_each(|c| out.extend(c.to_le_bytes()));
        at
    };
    // A sample: a 16-byte digest (unchecked by readers), then the values.
    let sample = |values: Vec<u8>| [vec![0; 16], values].concat();
    // A property header: kind (1 scalar, 2 array, 0 compound), 4-byte sizes, inline metadata.
    let header = |kind: u32, pod: u32, extent: u32, name: &str, meta: &str| {
        let h = if kind == 0 { 8 | 0xff << 20 } else { kind | 8 | pod << 4 | 0x800 | extent << 12 | 0xff << 20 };
        let mut b = h.to_le_bytes().to_vec();
        if kind != 0 {
            b.extend(1u32.to_le_bytes());
        }
        b.extend((name.len() as u32).to_le_bytes());
        b.extend(name.as_bytes());
        b.extend((meta.len() as u32).to_le_bytes());
        b.extend(meta.as_bytes());
        b
    };
    let points: Vec<u8> = s.points.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    let counts: Vec<u8> = s.segments.iter().flat_map(|&n| (n as i32 + 1).to_le_bytes()).collect();
    let widths = s.thickness.clone().unwrap_or_else(|| vec![s.default_thickness; s.points.len()]);
    let widths: Vec<u8> = widths.iter().flat_map(|v| v.to_le_bytes()).collect();
    let mut geom = Vec::new();
    let mut headers = Vec::new();
    for (name, pod, extent, values, meta) in [
        ("P", 10, 3, points, "geoScope=vtx;interpretation=point"),
        ("nVertices", 6, 1, counts, ""),
        ("width", 10, 1, widths, "geoScope=vtx;isGeomParam=true"),
    ] {
        let (d, dims) = (data(&mut out, &sample(values)), data(&mut out, &[]));
        geom.push(group(&mut out, &[d, dims]));
        headers.extend(header(2, pod, extent, name, meta));
    }
    geom.push(data(&mut out, &headers));
    let geom = group(&mut out, &geom);
    let geom_header = header(0, 0, 0, ".geom", "schema=AbcGeom_Curve_v2");
    let props = [geom, data(&mut out, &geom_header)];
    let props = group(&mut out, &props);
    let no_children = data(&mut out, &[0; 32]);
    let curves = group(&mut out, &[props, no_children]);
    let meta = "schema=AbcGeom_Curve_v2";
    let mut child = (5u32).to_le_bytes().to_vec();
    child.extend(b"groom");
    child.push(0xff);
    child.extend((meta.len() as u32).to_le_bytes());
    child.extend(meta.as_bytes());
    child.extend([0; 32]);
    let top = [0, curves, data(&mut out, &child)];
    let top = group(&mut out, &top);
    let root = [
        data(&mut out, &0i32.to_le_bytes()),
        data(&mut out, &10803i32.to_le_bytes()),
        top,
        data(&mut out, &[]),
        data(
            &mut out,
            &[[1u32.to_le_bytes().as_slice(), &1f64.to_le_bytes(), &1u32.to_le_bytes(), &0f64.to_le_bytes()].concat()]
                .concat(),
        ),
        data(&mut out, &[]),
    ];
    let root = group(&mut out, &root);
    out[8..16].copy_from_slice(&root.to_le_bytes());
    std::fs::write(path, out).expect("the .abc file");
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
