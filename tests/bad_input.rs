//! Bad input: each case exits non-zero with a message naming the file and the place, never
//! panics, and leaves the previous bundle byte-identical.

use crate::util::{Dir, snapshot, stderr, stdout};

/// A directory with a good bundle baked from one job, ready to receive a bad second job.
fn baked(name: &str) -> Dir {
    let dir = Dir::new(name);
    dir.copy_data();
    dir.write("pipeline.ron", GOOD);
    dir.run(&["bake"]);
    dir
}

const GOOD: &str = "(output: \"bundle\", jobs: [Heightfield(id: \"good\", input: \"data/cylinders.png\")])";

/// Adds a job reading `input` and asserts the bake fails with `code`, a message containing
/// every needle, and an unchanged bundle.
fn bake_fails_with(dir: &Dir, extra_job: &str, code: i32, needles: &[&str]) -> String {
    let pipeline =
        format!("(output: \"bundle\", jobs: [Heightfield(id: \"good\", input: \"data/cylinders.png\"), {extra_job}])");
    dir.write("pipeline.ron", &pipeline);
    let before = snapshot(&dir.path("bundle"));
    let out = dir.run_expecting(&["bake"], code);
    let err = stderr(&out);
    for n in needles {
        assert!(err.contains(n), "{}", dir.explain(&["bake"], &out, &format!("stderr should contain {n:?}")));
    }
    assert_eq!(snapshot(&dir.path("bundle")), before, "the bundle changed after a failed bake");
    // The pre-check reports the same problem without baking.
    let out = dir.run_expecting(&["validate", "pipeline.ron"], code);
    assert!(stderr(&out).contains(needles[0]), "{}", stderr(&out));
    err
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// A PNG signature and IHDR chunk claiming `w`×`h` 16-bit grayscale, with no image data.
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    let mut png = vec![0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];
    let mut chunk = b"IHDR".to_vec();
    chunk.extend_from_slice(&w.to_be_bytes());
    chunk.extend_from_slice(&h.to_be_bytes());
    chunk.extend_from_slice(&[16, 0, 0, 0, 0]); // depth 16, grayscale, deflate, filter 0, no interlace
    png.extend_from_slice(&13u32.to_be_bytes());
    png.extend_from_slice(&chunk);
    png.extend_from_slice(&crc32(&chunk).to_be_bytes());
    png
}

fn write_exr(dir: &Dir, rel: &str, w: usize, h: usize, values: Vec<f32>, channel: &str) {
    use exr::prelude::*;
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    channels.push(AnyChannel::new(channel, FlatSamples::F32(values)));
    let image = Image::from_layer(Layer::new(
        (w, h),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(channels),
    ));
    image.write().to_file(dir.path(rel)).unwrap();
}

#[test]
fn truncated_and_corrupt_png() {
    let dir = baked("bad_png");
    let png = dir.read("data/reptile.png");
    dir.write("data/cut.png", &png[..png.len() / 2]);
    bake_fails_with(&dir, "Heightfield(id: \"cut\", input: \"data/cut.png\")", 1, &["data/cut.png", "PNG"]);
    let mut bad = png.clone();
    bad[24] = 7; // IHDR bit depth 7 does not exist
    dir.write("data/corrupt.png", &bad);
    bake_fails_with(&dir, "Heightfield(id: \"c\", input: \"data/corrupt.png\")", 1, &["data/corrupt.png", "PNG"]);
    dir.write("data/empty.png", b"");
    bake_fails_with(&dir, "Heightfield(id: \"e\", input: \"data/empty.png\")", 1, &["data/empty.png", "0-byte"]);
    dir.write("data/text.png", b"hello, this is not an image");
    bake_fails_with(&dir, "Heightfield(id: \"t\", input: \"data/text.png\")", 1, &["data/text.png", "signature"]);
}

#[test]
fn rgb_png_needs_a_channel_and_then_takes_it() {
    let dir = baked("rgb_png");
    let mut img = image::RgbImage::new(4, 3);
    for (x, y, p) in img.enumerate_pixels_mut() {
        *p = image::Rgb([10 * x as u8, 100 + y as u8, 255]);
    }
    img.save(dir.path("data/rgb.png")).unwrap();
    bake_fails_with(
        &dir,
        "Heightfield(id: \"rgb\", input: \"data/rgb.png\")",
        1,
        &["data/rgb.png", "grayscale", "channel"],
    );
    bake_fails_with(
        &dir,
        "Heightfield(id: \"rgb\", input: \"data/rgb.png\", channel: \"Q\")",
        1,
        &["data/rgb.png", "\"Q\""],
    );

    dir.write(
        "pipeline.ron",
        "(output: \"bundle\", jobs: [Heightfield(id: \"rgb\", input: \"data/rgb.png\", channel: \"G\", format: R32Float)])",
    );
    dir.run(&["bake"]);
    dir.run(&["export", "bundle", "rgb", "--raw", "--out", "g.f32"]);
    let v: Vec<f32> = dir.read("g.f32").chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    let expected: Vec<f32> = (0..3).flat_map(|y| (0..4).map(move |_| (100 + y) as f32 / 255.0)).collect();
    assert_eq!(v, expected);
}

#[test]
fn exr_with_nan_or_truncated() {
    let dir = baked("bad_exr");
    let mut values = vec![0.5f32; 8 * 6];
    values[2 * 8 + 3] = f32::NAN;
    write_exr(&dir, "data/nan.exr", 8, 6, values, "Y");
    bake_fails_with(
        &dir,
        "Heightfield(id: \"nan\", input: \"data/nan.exr\")",
        1,
        &["data/nan.exr", "pixel (3, 2)", "finite"],
    );
    let mut values = vec![0.5f32; 8 * 6];
    values[0] = f32::INFINITY;
    write_exr(&dir, "data/inf.exr", 8, 6, values, "Y");
    bake_fails_with(&dir, "Heightfield(id: \"inf\", input: \"data/inf.exr\")", 1, &["data/inf.exr", "pixel (0, 0)"]);
    // The relief baker reads through the same loader, and wants heights in [0, 1].
    bake_fails_with(&dir, "Relief(id: \"nan\", input: \"data/nan.exr\")", 1, &["data/nan.exr", "pixel (3, 2)"]);
    write_exr(&dir, "data/odd.exr", 8, 6, vec![0.5f32; 48], "Y");
    bake_fails_with(&dir, "Relief(id: \"odd\", input: \"data/odd.exr\")", 1, &["data/odd.exr", "power-of-two", "8×6"]);
    write_exr(&dir, "data/tall.exr", 8, 8, vec![2.0f32; 64], "Y");
    bake_fails_with(&dir, "Relief(id: \"tall\", input: \"data/tall.exr\")", 1, &["data/tall.exr", "[0, 1]", "is 2"]);

    let exr = std::fs::read(crate::util::repo().join("data/dunes.exr")).unwrap();
    dir.write("data/cut.exr", &exr[..exr.len() * 2 / 3]);
    bake_fails_with(&dir, "Heightfield(id: \"cut\", input: \"data/cut.exr\")", 1, &["data/cut.exr", "OpenEXR"]);

    // Several channels and none of Y/R: an error listing them, or the named one.
    write_exr(&dir, "data/z.exr", 2, 2, vec![1.0, 2.0, 3.0, 4.0], "Z");
    dir.write("pipeline.ron", "(output: \"b2\", jobs: [Heightfield(id: \"z\", input: \"data/z.exr\")])");
    dir.run(&["bake"]); // a single channel is taken whatever its name
}

#[test]
fn zero_sized_and_over_limit_dimensions_are_refused_before_decoding() {
    let dir = baked("dimensions");
    dir.write("data/zero.png", png_header_only(0, 16));
    bake_fails_with(&dir, "Heightfield(id: \"z\", input: \"data/zero.png\")", 1, &["data/zero.png"]);
    // 100000² 16-bit would need 20 GB: refused from the header alone.
    dir.write("data/huge.png", png_header_only(100_000, 100_000));
    bake_fails_with(&dir, "Heightfield(id: \"h\", input: \"data/huge.png\")", 1, &["data/huge.png", "limit of 16384"]);
    // The limit is configurable.
    dir.write(
        "pipeline.ron",
        "(output: \"bundle\", limits: (max_dimension: 64), jobs: [Heightfield(id: \"good\", input: \"data/cylinders.png\")])",
    );
    let before = snapshot(&dir.path("bundle"));
    let out = dir.run_expecting(&["bake"], 1);
    assert!(stderr(&out).contains("data/cylinders.png") && stderr(&out).contains("limit of 64"), "{}", stderr(&out));
    assert_eq!(snapshot(&dir.path("bundle")), before);
}

#[test]
fn pipeline_syntax_type_and_setting_errors() {
    let dir = baked("pipeline_errors");
    let before = snapshot(&dir.path("bundle"));
    let cases: [(&str, &[&str]); 6] = [
        (
            "(output: \"bundle\",\n jobs: [\n Heightfield(id: \"x\" input: \"data/cylinders.png\")])",
            &["pipeline.ron:3:"],
        ),
        (
            "(output: \"bundle\",\n jobs: [\n Heightfield(id: \"x\", input: \"data/cylinders.png\", height_scale: \"tall\")])",
            &["pipeline.ron:3:"],
        ),
        (
            "(output: \"bundle\",\n jobs: [\n Heightfield(id: \"x\", input: \"data/cylinders.png\", texel_sise: (1, 1))])",
            &["pipeline.ron:3:", "texel_sise"],
        ),
        ("(output: \"bundle\", jobs: [Horizonn(id: \"x\")])", &["pipeline.ron:1:", "Horizonn"]),
        (
            "(output: \"bundle\", jobs: [Heightfield(id: \"x\", input: \"data/cylinders.png\", texel_size: (0, 1))])",
            &["pipeline.ron", "job `x`", "texel_size"],
        ),
        (
            "(output: \"bundle\", jobs: [Heightfield(id: \"a/b\", input: \"data/cylinders.png\")])",
            &["pipeline.ron", "not valid"],
        ),
    ];
    for (text, needles) in cases {
        dir.write("pipeline.ron", text);
        for args in [&["bake"][..], &["validate", "pipeline.ron"][..]] {
            let out = dir.run_expecting(args, 1);
            for n in needles {
                assert!(
                    stderr(&out).contains(n),
                    "{}",
                    dir.explain(args, &out, &format!("stderr should contain {n:?}"))
                );
            }
        }
    }
    dir.write("pipeline.ron", "(output: \"bundle\", jobs: [Heightfield(id: \"a\", input: \"data/cylinders.png\"), Heightfield(id: \"a\", input: \"data/reptile.png\")])");
    let out = dir.run_expecting(&["bake"], 1);
    assert!(stderr(&out).contains("also made by job `a`"), "{}", stderr(&out));
    assert_eq!(snapshot(&dir.path("bundle")), before);
}

#[test]
fn missing_input_is_an_io_error_naming_the_file() {
    let dir = baked("missing_input");
    bake_fails_with(&dir, "Heightfield(id: \"m\", input: \"data/missing.png\")", 3, &["data/missing.png"]);
    let out = Dir::new("missing_pipeline").run_expecting(&["bake", "nowhere.ron"], 3);
    assert!(stderr(&out).contains("nowhere.ron"));
}

fn edit_manifest(dir: &Dir, from: &str, to: &str) {
    let text = String::from_utf8(dir.read("bundle/bundle.ron")).unwrap();
    assert!(text.contains(from), "{from:?} not in manifest");
    dir.write("bundle/bundle.ron", text.replacen(from, to, 1));
}

#[test]
fn unknown_major_version_is_refused_and_never_overwritten() {
    let dir = baked("major");
    edit_manifest(&dir, "major: 1", "major: 9");
    let out = dir.run_expecting(&["validate", "bundle"], 1);
    let current = hikage_bundle::FormatVersion::CURRENT;
    assert!(
        stderr(&out).contains(&format!("format 9.{}", current.minor))
            && stderr(&out).contains(&format!("format {current}")),
        "{}",
        stderr(&out)
    );
    let out = dir.run_expecting(&["inspect", "bundle"], 1);
    assert!(stderr(&out).contains("bundle.ron"), "{}", stderr(&out));
    let before = snapshot(&dir.path("bundle"));
    dir.write("pipeline.ron", GOOD);
    dir.run_expecting(&["bake"], 1);
    assert_eq!(snapshot(&dir.path("bundle")), before);
    // --force replaces it.
    dir.run(&["bake", "--force"]);
    dir.run(&["validate", "bundle"]);
}

#[test]
fn manifest_paths_escaping_the_bundle_are_refused() {
    for (name, bad) in [("escape_rel", "../x.ktx2"), ("escape_abs", "/etc/passwd"), ("escape_sub", "sub/x.ktx2")] {
        let dir = baked(name);
        let text = String::from_utf8(dir.read("bundle/bundle.ron")).unwrap();
        let file = text.split("file: \"").nth(1).unwrap().split('"').next().unwrap().to_string();
        edit_manifest(&dir, &file, bad);
        let out = dir.run_expecting(&["validate", "bundle"], 1);
        assert!(
            stdout(&out).contains("not a plain file name") && stdout(&out).contains(bad),
            "{}",
            dir.explain(&["validate", "bundle"], &out, "escape named")
        );
        dir.run_expecting(&["export", "bundle", "good", "--raw", "--out", "x"], 1);
    }
}

#[test]
fn truncated_ktx2_with_a_matching_hash_is_caught_by_the_header_check() {
    let dir = baked("truncated_ktx2");
    let text = String::from_utf8(dir.read("bundle/bundle.ron")).unwrap();
    let file = text.split("file: \"").nth(1).unwrap().split('"').next().unwrap().to_string();
    let bytes = dir.read(&format!("bundle/{file}"));
    let cut = &bytes[..bytes.len() - 100];
    dir.write(&format!("bundle/{file}"), cut);
    // Make size and hash agree so that only the KTX2 structure is wrong.
    let old_hash = text.split("blake3: \"").nth(1).unwrap().split('"').next().unwrap().to_string();
    edit_manifest(&dir, &old_hash, blake3::hash(cut).to_hex().as_str());
    edit_manifest(&dir, &format!("byte_length: {}", bytes.len()), &format!("byte_length: {}", cut.len()));
    let out = dir.run_expecting(&["validate", "bundle"], 1);
    assert!(stdout(&out).contains("`good`") && stdout(&out).contains("KTX2"), "{}", stdout(&out));
    // A byte-length lie alone is named as such.
    edit_manifest(&dir, &format!("byte_length: {}", cut.len()), "byte_length: 5");
    let out = dir.run_expecting(&["validate", "bundle"], 1);
    assert!(stdout(&out).contains("bytes, the manifest says 5"), "{}", stdout(&out));
}

#[test]
fn duplicate_ids_and_missing_payloads_are_reported() {
    let dir = Dir::new("dup_ids");
    dir.copy_data();
    dir.write(
        "pipeline.ron",
        "(output: \"bundle\", jobs: [Heightfield(id: \"a\", input: \"data/cylinders.png\"), Heightfield(id: \"b\", input: \"data/cylinders.png\")])",
    );
    dir.run(&["bake"]);
    edit_manifest(&dir, "id: \"b\"", "id: \"a\"");
    let out = dir.run_expecting(&["validate", "bundle"], 1);
    assert!(stdout(&out).contains("duplicate asset id"), "{}", stdout(&out));
    edit_manifest(&dir, "id: \"a\"", "id: \"c\"");
    let text = String::from_utf8(dir.read("bundle/bundle.ron")).unwrap();
    let file = text.split("file: \"").nth(1).unwrap().split('"').next().unwrap().to_string();
    std::fs::remove_file(dir.path(&format!("bundle/{file}"))).unwrap();
    let out = dir.run_expecting(&["validate", "bundle"], 1);
    assert!(stdout(&out).contains(&file), "{}", stdout(&out));
}

#[test]
fn meshes_without_uvs_or_with_degenerate_triangles_are_refused() {
    let dir = baked("bad_mesh");
    dir.write("data/no_uv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    bake_fails_with(
        &dir,
        "Curvature(id: \"m\", input: \"data/no_uv.obj\")",
        1,
        &["data/no_uv.obj", "line 4", "texture coordinate"],
    );
    dir.write("data/flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n");
    bake_fails_with(
        &dir,
        "Curvature(id: \"m\", input: \"data/flat.obj\")",
        1,
        &["data/flat.obj", "triangle 0 has zero area"],
    );
    dir.write("data/range.obj", "v 0 0 0\nvt 0 0\nf 1/1 2/1 3/1\n");
    bake_fails_with(
        &dir,
        "Curvature(id: \"m\", input: \"data/range.obj\")",
        1,
        &["data/range.obj", "line 3", "out of range"],
    );
}

/// A small valid `.hair` file: two strands of 3 and 2 points, thickness per point.
fn hair_bytes() -> Vec<u8> {
    let s = hikage_bake::strands::Strands {
        segments: vec![2, 1],
        points: vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, 0.5], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
        thickness: Some(vec![0.1; 5]),
        transparency: None,
        color: None,
        default_thickness: 0.1,
        default_transparency: 0.5,
        default_color: [0.5; 3],
    };
    hikage_bake::strands::cyhair::encode(&s, "crafted")
}

#[test]
fn crafted_hair_files_are_refused_with_their_place() {
    let dir = Dir::new("bad_hair");
    let good = hair_bytes();
    let patch = |at: usize, v: &[u8]| {
        let mut b = good.clone();
        b[at..at + v.len()].copy_from_slice(v);
        b
    };
    let mut nan = good.clone();
    let first_point = 128 + 4; // after the segments array (two u16)
    nan[first_point + 12 + 4..first_point + 12 + 8].copy_from_slice(&f32::NAN.to_le_bytes());
    let mut negative = good.clone();
    let thickness = first_point + 5 * 12;
    negative[thickness + 8..thickness + 12].copy_from_slice(&(-0.5f32).to_le_bytes());
    let cases: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        ("counts.hair", patch(8, &500u32.to_le_bytes()), vec!["header", "need", "the file has"]),
        ("overrun.hair", patch(128, &7u16.to_le_bytes()), vec!["segments", "account for 10 points, the header says 5"]),
        ("nan.hair", nan, vec!["point 1", "finite position"]),
        ("negative.hair", negative, vec!["point 2", "thickness"]),
        (
            "huge.hair",
            patch(8, &4_000_000_000u32.to_le_bytes()),
            vec!["point count in the header", "limit", "4000000000"],
        ),
        ("short.hair", good[..60].to_vec(), vec!["128-byte header"]),
        ("empty.hair", Vec::new(), vec!["expected a .hair signature or OBJ", "at least one"]),
        ("lines.obj", b"v 0 0 0\nv 1 0 0\nl 1 5\n".to_vec(), vec!["line 3", "out of range"]),
    ];
    for (name, bytes, needles) in cases {
        dir.write(name, &bytes);
        let args = ["strands", name, "--out", "b"];
        let out = dir.run_expecting(&args, 1);
        let err = stderr(&out);
        let found = needles.iter().filter(|n| err.contains(*n)).count();
        // The empty file is read as OBJ text with no polyline: either wording names it.
        let needed = if name == "empty.hair" { 1 } else { needles.len() };
        assert!(err.contains(name) && found >= needed, "{}", dir.explain(&args, &out, needles[0]));
        assert!(!dir.path("b/bundle.ron").exists());
    }
    dir.write("ok.hair", &good);
    dir.run(&["strands", "ok.hair", "--out", "b", "--taper", "0.5"]);
    let out = dir.run_expecting(&["strands", "ok.hair", "--out", "b", "--taper", "2"], 1);
    assert!(stderr(&out).contains("taper"), "{}", stderr(&out));
}

/// Hair no one could see is refused, naming the file, where the value came from and the
/// settings that fix it: strands wider than a tenth of the hair's box (a header asking for
/// 1-wide strands on 2-unit hair), strands with no opacity, strands with no width; the job's own
/// settings make the same file bake. `validate PIPELINE` says the same before any bake.
#[test]
fn invisible_hair_is_refused_with_the_value_and_the_fix() {
    let dir = Dir::new("invisible_hair");
    let strands = |thickness: Option<Vec<f32>>, default_thickness: f32, default_transparency: f32| {
        let s = hikage_bake::strands::Strands {
            segments: vec![2, 1],
            points: vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, 0.5], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
            thickness,
            transparency: None,
            color: None,
            default_thickness,
            default_transparency,
            default_color: [0.5; 3],
        };
        hikage_bake::strands::cyhair::encode(&s, "crafted")
    };
    let cases: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        (
            "wide.hair",
            strands(None, 1.0, 0.0),
            vec!["the header's default thickness", "wider than a tenth", "shading_width"],
        ),
        (
            "clear.hair",
            strands(None, 0.01, 1.0),
            vec!["the header's default transparency", "opacity 0", "shading_alpha"],
        ),
        ("thin.hair", strands(Some(vec![0.0; 5]), 0.01, 0.5), vec!["the per-point thickness", "cannot be seen"]),
    ];
    for (name, bytes, needles) in cases {
        dir.write(name, &bytes);
        let args = ["strands", name, "--out", "b"];
        let out = dir.run_expecting(&args, 1);
        let err = stderr(&out);
        for n in needles.iter().chain([&name]) {
            assert!(err.contains(n), "{}", dir.explain(&args, &out, n));
        }
        assert!(!dir.path("b/bundle.ron").exists());
        dir.write("pipeline.ron", format!("(output: \"p\", jobs: [Strands(id: \"h\", input: \"{name}\")])"));
        let out = dir.run_expecting(&["validate", "pipeline.ron"], 1);
        assert!(stderr(&out).contains(needles[0]), "{}", stderr(&out));
    }
    dir.run(&["strands", "wide.hair", "--out", "b", "--shading-width", "0.01"]);
    dir.run(&["strands", "clear.hair", "--out", "b", "--shading-alpha", "0.4"]);
}

/// Strands baked before format 1.5 (the strip layout) are reported by `validate` with the way
/// out, rather than drawn wrong.
#[test]
fn strands_of_an_older_format_are_reported_with_the_fix() {
    let dir = Dir::new("old_strands");
    dir.write("ok.hair", hair_bytes());
    dir.run(&["strands", "ok.hair", "--out", "bundle"]);
    dir.run(&["validate", "bundle"]);
    edit_manifest(&dir, &format!("minor: {}", hikage_bundle::FormatVersion::CURRENT.minor), "minor: 4");
    let out = dir.run_expecting(&["validate", "bundle"], 1);
    let said = format!("{}{}", stdout(&out), stderr(&out));
    assert!(said.contains("ok.strips") && said.contains("bake them again"), "{said}");
}

/// Hostile sizes are refused before anything is allocated, and the process stays small: a
/// manifest claiming ten million assets (a 3 GB sparse file), a PNG header claiming
/// 100000×100000, a KTX2 level claiming 2^40 bytes, a `.hair` header claiming 4 billion points.
/// Peak memory of each `hikage` run is measured with `/usr/bin/time` (installed by `.ci/run`)
/// and must stay under 200 MB.
#[test]
fn hostile_sizes_are_refused_in_little_memory() {
    let dir = Dir::new("hostile_sizes");
    // Ten million assets: the manifest's size alone exceeds the limit; the file is sparse.
    std::fs::create_dir_all(dir.path("ten_million")).unwrap();
    let mut text = String::from("(format: (major: 1, minor: 2), generator: \"x\", assets: [\n");
    for k in 0..1000 {
        text.push_str(&format!("(id: \"a{k}\", kind: Texture, file: \"f{k}\", byte_length: 1, blake3: \"{}\", input_hash: \"\", payload: Texture((format: R8Unorm, dimension: D2, width: 1, height: 1, depth: 1, layers: 1, levels: 1, supercompression: None, channels: [\"x\"])), settings: Generic),\n", "0".repeat(64)));
    }
    let f = std::fs::File::create(dir.path("ten_million/bundle.ron")).unwrap();
    use std::io::Write;
    (&f).write_all(text.as_bytes()).unwrap();
    f.set_len(3 << 30).unwrap();
    // The PNG and the pipeline that reads it.
    dir.write("data/huge.png", png_header_only(100_000, 100_000));
    dir.write("huge.ron", "(output: \"b\", jobs: [Heightfield(id: \"h\", input: \"data/huge.png\")])");
    // A bundle whose texture's level index claims 2^40 bytes (the manifest agrees with it).
    let ktx = std::fs::read(crate::util::repo().join("tests/corpus/ktx2/level_of_2e40_bytes.ktx2")).unwrap();
    std::fs::create_dir_all(dir.path("ktx")).unwrap();
    let src = crate::util::repo().join("tests/corpus/bundle_hash_mismatch");
    let manifest = std::fs::read_to_string(src.join("bundle.ron")).unwrap();
    let payload = std::fs::read_dir(&src)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .find(|n| n.to_string_lossy().ends_with(".ktx2"))
        .unwrap();
    std::fs::write(dir.path("ktx").join(&payload), &ktx).unwrap();
    let hash = blake3::hash(&ktx).to_hex().to_string();
    let old_hash = manifest.split("blake3: \"").nth(1).unwrap()[..64].to_string();
    let manifest =
        manifest.replace(&old_hash, &hash).replace("byte_length: 208", &format!("byte_length: {}", ktx.len()));
    dir.write("ktx/bundle.ron", manifest);
    // Four billion points.
    let mut hair = hair_bytes();
    hair[8..12].copy_from_slice(&4_000_000_000u32.to_le_bytes());
    dir.write("huge.hair", &hair);

    for (args, needle) in [
        (vec!["validate", "ten_million"], "manifest size"),
        (vec!["validate", "huge.ron"], "100000"),
        (vec!["validate", "ktx"], "level 0 claims 1099511627776 uncompressed bytes"),
        (vec!["strands", "huge.hair", "--out", "b"], "4000000000"),
    ] {
        let (out, stderr, peak_kib) = dir.run_measured(&args);
        let status = out.status;
        assert_eq!(status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
        if let Some(kib) = peak_kib {
            eprintln!("{args:?}: peak {} MB", kib / 1024);
            assert!(kib < 200 * 1024, "{args:?} peaked at {kib} KiB");
        }
    }
}

/// A scalp that cannot take the hair is refused before anything is written, by file and place:
/// a glTF without a skin, a skinned mesh without weights, a file that is not glTF, and roots
/// that lie away from the scalp (named by strand, with the setting that allows more).
#[test]
fn a_scalp_that_cannot_take_the_hair_is_refused() {
    let dir = Dir::new("bad_scalp");
    let character = hikage_devkit::synth::character(40, 4, 3);
    dir.write("head.hair", hikage_bake::strands::cyhair::encode(&character.hair, "skinned"));
    dir.write("character.glb", &character.glb);
    dir.write("torus.glb", hikage_devkit::synth::torus_glb(2.0, 0.5, 12, 8, (1.0, 1.0)));
    let text = String::from_utf8_lossy(&character.glb[20..]).into_owned();
    let at = text.find("\"WEIGHTS_0\"").expect("the GLB names its weights") + 20;
    let mut unweighted = character.glb.clone();
    unweighted[at..at + 11].copy_from_slice(b"\"WEIGHTS_9\"");
    dir.write("unweighted.glb", &unweighted);
    dir.write("text.glb", b"solid nothing");
    let mut far = character.hair.clone();
    let first_of_strand_3: usize = far.segments[..3].iter().map(|&s| s as usize + 1).sum();
    for p in &mut far.points[first_of_strand_3..=first_of_strand_3 + far.segments[3] as usize] {
        p[0] += 30.0;
    }
    dir.write("far.hair", hikage_bake::strands::cyhair::encode(&far, "one strand moved aside"));
    let cases: [(&str, &str, &[&str]); 4] = [
        ("head.hair", "torus.glb", &["torus.glb", "a node with a mesh and a skin"]),
        ("head.hair", "unweighted.glb", &["unweighted.glb", "primitive 0", "has no WEIGHTS_0"]),
        ("head.hair", "text.glb", &["text.glb"]),
        ("far.hair", "character.glb", &["far.hair", "strand 3", "farther than", "scalp_distance"]),
    ];
    for (hair, scalp, needles) in cases {
        let args = ["strands", hair, "--out", "b", "--scalp", scalp];
        let out = dir.run_expecting(&args, 1);
        let err = stderr(&out);
        assert!(needles.iter().all(|n| err.contains(n)), "{}", dir.explain(&args, &out, needles[0]));
        assert!(!dir.path("b/bundle.ron").exists());
    }
    // Allowed once the distance says so.
    dir.run(&["strands", "far.hair", "--out", "b", "--scalp", "character.glb", "--scalp-distance", "40"]);
    dir.run(&["validate", "b"]);
    let out = dir.run_expecting(&["strands", "head.hair", "--out", "c", "--scalp-distance", "1"], 1);
    assert!(stderr(&out).contains("no scalp"), "{}", stderr(&out));
}
