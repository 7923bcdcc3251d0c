//! Grooms from the tools artists use: the fixtures in `data/grooms/` were written by Pixar's
//! usd-core and by Blender 5.0 (`data/grooms/make_grooms.py`), in their own units and axes,
//! from one groom that the script also wrote as a `.hair` file. Read through the `Strands` job
//! (which brings each file's units and up axis into the bundle's frame), every one gives the
//! `.hair` file's strands. Then mistakes, each named with the file and the prim.
#![cfg(feature = "usd")]

use std::path::{Path, PathBuf};

use hikage_bake::jobs::StrandsJob;
use hikage_bake::strands::{Strands, UpAxis};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/grooms").join(name)
}

fn load(name: &str) -> Strands {
    StrandsJob::new("groom", data(name)).load(&data(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The largest difference between two lists of equal length.
fn worst<const N: usize>(a: &[[f32; N]], b: &[[f32; N]]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).flat_map(|(p, q)| p.iter().zip(q).map(|(x, y)| (x - y).abs())).fold(0.0, f32::max)
}

#[test]
fn one_groom_reads_the_same_from_hair_usd_alembic_and_blender() {
    let hair = load("groom.hair");
    assert_eq!(hair.segments, vec![7; 48]);
    let widths =
        |s: &Strands| -> Vec<[f32; 1]> { s.thickness.as_ref().expect("widths").iter().map(|&w| [w]).collect() };
    for name in ["groom_linear.usda", "groom_cm_zup.usdc", "groom_blender.usdc", "groom_blender.abc"] {
        let usd = load(name);
        assert_eq!(usd.segments, hair.segments, "{name}");
        // Metres: a micrometre covers float rounding through centimetres, Z up and a parent
        // Xform's translation.
        let (dp, dw) = (worst(&usd.points, &hair.points), worst(&widths(&usd), &widths(&hair)));
        eprintln!("{name}: points within {dp:e} m, widths within {dw:e} m");
        assert!(dp < 1e-6, "{name}: points differ by {dp} m");
        assert!(dw < 1e-9, "{name}: widths differ by {dw} m");
        assert!((usd.default_thickness - hair.default_thickness).abs() < 1e-9, "{name}");
        if !name.starts_with("groom_blender") {
            // Blender's exporter writes its own displayColor, not the script's colours.
            let dc = worst(usd.color.as_ref().expect("colours"), hair.color.as_ref().expect("colours"));
            assert!(dc < 1e-6, "{name}: colours differ by {dc}");
        }
    }
}

#[test]
fn the_jobs_units_and_axis_override_the_files() {
    let hair = load("groom.hair");
    let name = "groom_cm_zup.usdc";
    // Telling the job what the file already says changes nothing.
    let mut job = StrandsJob::new("groom", data(name));
    (job.options.units, job.options.up) = (Some(0.01), Some(UpAxis::Z));
    let same = job.load(&data(name)).unwrap();
    assert_eq!(same, load(name));
    // Read as metres and Y up, the file's own numbers come through as they are: a hundred
    // times the size, with the file's Z where the bundle's Y is.
    (job.options.units, job.options.up) = (Some(1.0), Some(UpAxis::Y));
    let raw = job.load(&data(name)).unwrap();
    let (p, q) = (raw.points[5], hair.points[5]);
    let want = [100.0 * q[0], -100.0 * q[2], 100.0 * q[1]];
    assert!((0..3).all(|k| (p[k] - want[k]).abs() < 1e-3), "{p:?} against {want:?}");
}

#[test]
fn widths_and_colours_in_every_interpolation() {
    let hair = load("groom.hair");
    let s = load("groom_interpolations.usda");
    // Three prims of the first two strands each: constant, uniform, varying.
    assert_eq!(s.segments, vec![7; 6]);
    assert!(worst(&s.points[..16], &hair.points[..16]) < 1e-6);
    let w = s.thickness.as_ref().unwrap();
    let near = |a: f32, b: f32| (a - b).abs() < 1e-9;
    assert!(w[..16].iter().all(|&v| near(v, 0.0006)), "constant: {:?}", &w[..16]);
    assert!(w[16..24].iter().all(|&v| near(v, 0.0004)) && w[24..32].iter().all(|&v| near(v, 0.0007)), "uniform");
    let hw = hair.thickness.as_ref().unwrap();
    assert!(w[32..].iter().zip(&hw[..16]).all(|(&a, &b)| near(a, b)), "varying");
    // Colours are on the first two prims only: a stage whose prims disagree keeps none.
    assert_eq!(s.color, None);
}

/// For each strand of `s`, the strand of `reference` with the same points (within `tol`); each
/// reference strand is matched at most once.
fn match_strands(s: &Strands, reference: &Strands, tol: f32, name: &str) -> Vec<usize> {
    let points = |s: &Strands, i: usize| s.points[8 * i..8 * i + 8].to_vec();
    let mut taken = vec![false; reference.segments.len()];
    (0..s.segments.len())
        .map(|i| {
            let own = points(s, i);
            let j = (0..reference.segments.len())
                .find(|&j| !taken[j] && worst(&own, &points(reference, j)) < tol)
                .unwrap_or_else(|| panic!("{name}: strand {i} ({:?}…) is none of the reference's", own[0]));
            taken[j] = true;
            j
        })
        .collect()
}

/// A groom as a character artist hands it over, from Blender as USD and as Alembic: two hair
/// objects (groups 0 and 1: the even and the odd strands), a guides object, per-point
/// `groom_color` (USD only: Blender's Alembic exporter drops curve attributes), and a parent
/// that moves 5 cm up between frames 1 and 2.
#[test]
fn guides_groups_colours_and_time_from_blender() {
    let hair = load("groom.hair");
    let colors = |s: &Strands, i: usize| s.color.as_ref().expect("colours")[8 * i..8 * i + 8].to_vec();
    for name in ["groom_guides_blender.usdc", "groom_guides_blender.abc"] {
        // Every strand but the guides, each the .hair file's, with its widths.
        let s = load(name);
        assert_eq!(s.segments, vec![7; 48], "{name}: the guides are left out");
        let mut matched = match_strands(&s, &hair, 1e-6, name);
        let widths = |s: &Strands, i: usize| s.thickness.as_ref().expect("widths")[8 * i..8 * i + 8].to_vec();
        for (i, &j) in matched.iter().enumerate() {
            assert_eq!(widths(&s, i), widths(&hair, j), "{name}: strand {i}");
            if name.ends_with(".usdc") {
                let d = worst(&colors(&s, i), &colors(&hair, j));
                assert!(d < 1e-6, "{name}: strand {i}'s groom_color differs by {d}");
            }
        }
        matched.sort_unstable();
        assert_eq!(matched, (0..48).collect::<Vec<_>>(), "{name}");

        // One group: the odd strands alone.
        let mut job = StrandsJob::new("groom", data(name));
        job.options.group = Some(1);
        let odd = job.load(&data(name)).unwrap();
        let mut matched = match_strands(&odd, &hair, 1e-6, name);
        matched.sort_unstable();
        assert_eq!(matched, (1..48).step_by(2).collect::<Vec<_>>(), "{name}: group 1");
        job.options.group = Some(5);
        let e = job.load(&data(name)).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains("no strand in group 5") && e.contains("[0, 1]"), "{e}");

        // Frame 2 (2/24 s): the parent's move, 5 cm up in the bundle's frame.
        job.options.group = None;
        job.options.time = Some(2.0 / 24.0);
        let later = job.load(&data(name)).unwrap();
        let moved = Strands { points: s.points.iter().map(|p| [p[0], p[1] + 0.05, p[2]]).collect(), ..s.clone() };
        let d = worst(&later.points, &moved.points);
        assert!(d < 1e-6, "{name}: at frame 2 the points are off the moved ones by {d} m");
        // Between frames, Alembic takes the nearer sample and USD interpolates, as each format's
        // own readers do.
        job.options.time = Some(1.4 / 24.0);
        let between = job.load(&data(name)).unwrap();
        let rise = if name.ends_with(".abc") { 0.0 } else { 0.4 * 0.05 };
        let want: Vec<[f32; 3]> = s.points.iter().map(|p| [p[0], p[1] + rise, p[2]]).collect();
        let d = worst(&between.points, &want);
        assert!(d < 1e-6, "{name}: at frame 1.4 the points are off by {d} m");
    }
}

/// A `.usda` file in a scratch directory.
fn usda(name: &str, text: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("grooms");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// One linear `BasisCurves` prim at `/Groom/Hair` with these attribute lines.
fn curves(attributes: &str) -> String {
    format!(
        "#usda 1.0\n(\n    upAxis = \"Y\"\n)\n\ndef Xform \"Groom\"\n{{\n    def BasisCurves \"Hair\"\n    {{\n        \
         uniform token type = \"linear\"\n{attributes}\n    }}\n}}\n"
    )
}

fn error(path: &Path) -> String {
    match StrandsJob::new("groom", path.to_path_buf()).load(path) {
        Ok(s) => panic!("{} read as {} strands", path.display(), s.segments.len()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn mistakes_are_named_with_the_file_and_the_prim() {
    let points = "        point3f[] points = [(0, 0, 0), (0, 1, 0), (1, 0, 0), (1, 1, 0)]";
    for (name, attributes, want) in [
        ("counts.usda", format!("        int[] curveVertexCounts = [2, 3]\n{points}"), "add up to 5 points"),
        ("one_point.usda", format!("        int[] curveVertexCounts = [1, 3]\n{points}"), "curve 0 has 1 points"),
        (
            "nan.usda",
            "        int[] curveVertexCounts = [2]\n        point3f[] points = [(0, 0, 0), (0, nan, 0)]".into(),
            "point 1",
        ),
        (
            "negative.usda",
            format!(
                "        int[] curveVertexCounts = [2, 2]\n{points}\n        float[] widths = [0.1, -0.1, 0.1, 0.1] (interpolation = \"vertex\")"
            ),
            "widths[1] is -0.1",
        ),
        (
            "short_widths.usda",
            format!(
                "        int[] curveVertexCounts = [2, 2]\n{points}\n        float[] widths = [0.1, 0.1] (interpolation = \"vertex\")"
            ),
            "widths holds 2 values for vertex interpolation, expected 4",
        ),
        ("no_points.usda", "        int[] curveVertexCounts = [2]".into(), "no points"),
    ] {
        let path = usda(name, &curves(&attributes));
        let e = error(&path);
        assert!(e.contains(name) && e.contains("/Groom/Hair") && e.contains(want), "{name}: {e}");
    }
    let none = usda("none.usda", "#usda 1.0\n\ndef Xform \"Groom\"\n{\n}\n");
    let e = error(&none);
    assert!(e.contains("none.usda") && e.contains("no BasisCurves"), "{e}");
}

#[test]
fn damaged_files_are_errors_not_panics() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("grooms");
    std::fs::create_dir_all(&dir).unwrap();
    for source in ["groom_cm_zup.usdc", "groom_linear.usda", "groom_blender.usdc"] {
        let bytes = std::fs::read(data(source)).unwrap();
        let ext = source.rsplit('.').next().unwrap();
        // Cut short at many lengths, and with a stretch of bytes overwritten.
        let mut cases: Vec<Vec<u8>> = [0, 7, 16, 88, bytes.len() / 3, bytes.len() / 2, bytes.len() - 9]
            .iter()
            .map(|&n| bytes[..n].to_vec())
            .collect();
        for at in [24, bytes.len() / 4, bytes.len() / 2, bytes.len() - 200] {
            let mut b = bytes.clone();
            b[at..at + 64].iter_mut().enumerate().for_each(|(i, v)| *v = (i as u8).wrapping_mul(37) ^ 0xa5);
            cases.push(b);
        }
        for (i, case) in cases.iter().enumerate() {
            let path = dir.join(format!("damaged_{i}_{source}"));
            std::fs::write(&path, case).unwrap();
            // A file cut short is an error that names it; an overwritten stretch is too, unless
            // the format cannot notice (text in a string, say): then it reads as strands.
            match StrandsJob::new("groom", path.clone()).load(&path) {
                Err(e) => {
                    let e = e.to_string();
                    assert!(e.contains(&format!("damaged_{i}_{source}")), "{source} case {i} ({ext}): {e}");
                }
                Ok(_) => assert!(i >= 7, "{source} cut to {} bytes read as a groom", case.len()),
            }
        }
    }
}

/// The character too: Blender's USD (and Alembic) groom bound to the skinned head Blender
/// exported as glTF (`character_blender.glb`, a one-bone rig), through a pipeline as a game's
/// would run it.
/// Every strand is bound to the triangle nearest its root, found here by brute force over every
/// triangle of the glTF's mesh, and its root lies on that triangle within the sphere's
/// tessellation.
#[test]
fn a_blender_groom_binds_to_blenders_skinned_head() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("grooms_bound");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let pipeline = dir.join("pipeline.ron");
    std::fs::write(
        &pipeline,
        format!(
            r#"(output: "bundle", jobs: [Strands(id: "head", input: "{}", scalp: Some("{glb}")), Strands(id: "head_abc", input: "{}", scalp: Some("{glb}"))])"#,
            data("groom_blender.usdc").display(),
            data("groom_blender.abc").display(),
            glb = data("character_blender.glb").display()
        ),
    )
    .unwrap();
    hikage_bake::run_pipeline(&pipeline, &hikage_bake::RunOptions::default()).unwrap();
    let bundle = hikage_bundle::Bundle::open(&dir.join("bundle")).unwrap();
    let bindings = hikage_bundle::binding::read_binding(&bundle.read_mesh("head.binding").unwrap()).unwrap();
    let scalp = hikage_bundle::Scalp::read(&bundle.read_mesh("head.scalp").unwrap()).unwrap();
    let hair = load("groom_blender.usdc");
    assert_eq!(bindings.len(), 48);
    // Blender's Alembic export of the same groom binds the same: byte for byte.
    assert_eq!(bundle.read_mesh("head_abc.binding").unwrap(), bundle.read_mesh("head.binding").unwrap());
    assert_eq!(bundle.read_mesh("head_abc.scalp").unwrap(), bundle.read_mesh("head.scalp").unwrap());
    let head = hikage_bake::mesh::gltf::load_skinned(&data("character_blender.glb"), Default::default()).unwrap();
    let sub = |a: [f32; 3], b: [f32; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    // The nearest point of triangle `t` to `p`, by projecting onto the plane and clamping the
    // barycentric weights over a fine grid (a brute force, not the baker's algorithm).
    let nearest = |[a, b, c]: [[f32; 3]; 3], p: [f32; 3]| -> f32 {
        let mut best = f32::INFINITY;
        for i in 0..=200 {
            for j in 0..=(200 - i) {
                let (u, v) = (i as f32 / 200.0, j as f32 / 200.0);
                let q = [0, 1, 2].map(|k| a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]));
                let d = sub(p, q);
                best = best.min(dot(d, d).sqrt());
            }
        }
        best
    };
    for (s, bind) in bindings.iter().enumerate() {
        let root = hair.points[s * 8];
        let bound = nearest(scalp.triangles[bind.triangle as usize].map(|i| scalp.positions[i as usize]), root);
        let all = head.triangles.iter().map(|t| t.map(|i| head.positions[i as usize]));
        let closest = all.map(|t| nearest(t, root)).fold(f32::INFINITY, f32::min);
        assert!(bound <= closest + 1e-4, "strand {s}: bound {bound} m away, the nearest triangle {closest} m");
        // A 24 × 12 sphere lies at most 1.8 mm inside the 0.1 m sphere the roots are on.
        assert!(bound < 0.002, "strand {s}: root {bound} m from its triangle");
    }
}

/// Layers a groom names are opened only when they are regular files: a sublayer that is
/// missing, a FIFO (which would block the bake) or a device is an error naming it, not strands
/// quietly left out.
#[test]
fn layers_the_stage_names_must_be_regular_files() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("grooms");
    std::fs::create_dir_all(&dir).unwrap();
    let fifo = dir.join("pipe.usda");
    let _ = std::fs::remove_file(&fifo);
    let made = std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success());
    let mut cases = vec![("missing.usda", "unresolved sublayer @missing.usda@"), ("/dev/zero", "/dev/zero")];
    if made {
        cases.push((fifo.to_str().unwrap(), "expected a regular file, found a FIFO"));
    }
    for (i, (layer, want)) in cases.into_iter().enumerate() {
        let path = usda(&format!("sublayer_{i}.usda"), &format!("#usda 1.0\n(\n    subLayers = [@{layer}@]\n)\n"));
        let e = error(&path);
        assert!(e.contains(&format!("sublayer_{i}.usda")) && e.contains(want), "{layer}: {e}");
    }
}
