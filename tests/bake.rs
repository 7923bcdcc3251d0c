//! Baking the default pipeline, incremental re-runs, determinism, crash safety, export.

use std::time::Duration;

use crate::util::{Dir, default_bake, snapshot, stderr, stdout};

fn job_ids(pipeline: &str) -> Vec<String> {
    // Independent of the library's parser: every `id: "..."` in the file.
    pipeline.split("id: \"").skip(1).map(|s| s.split('"').next().unwrap().to_string()).collect()
}

#[test]
fn default_pipeline_bakes_validates_and_inspects() {
    let (root, out) = default_bake();
    let dir = Dir::with_default_pipeline("default_pipeline");
    let ids = job_ids(&String::from_utf8(dir.read("pipeline.ron")).unwrap());
    assert!(ids.len() >= 7, "{ids:?}");
    // Every job baked, each said new.
    assert!(out.contains(&format!("baked {} (", ids.len())) && out.contains("), skipped 0"), "{out}");
    assert!(out.contains(&format!("{} (new)", ids[0])), "{out}");
    let bundle = root.join("bundle").display().to_string();
    let bundle = bundle.as_str();
    dir.run(&["validate", bundle]);

    let out = dir.run(&["inspect", bundle, "--format", "json"]);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let assets = json["assets"].as_array().unwrap();
    for id in &ids {
        // A job makes the asset `id` or assets `id.<part>`.
        let made: Vec<_> = assets
            .iter()
            .filter(|a| a["id"] == id.as_str() || a["id"].as_str().unwrap().starts_with(&format!("{id}.")))
            .collect();
        assert!(!made.is_empty(), "{id} made nothing");
        for a in made {
            match a["kind"].as_str().unwrap() {
                "heightfield" | "horizon" | "ambient_occlusion" => {
                    assert!(a["format"].as_str().unwrap().ends_with("Float"));
                    assert_eq!(a["dimensions"].as_array().unwrap().len(), 4);
                }
                "curvature" => {
                    assert_eq!(a["format"], "mesh");
                    assert!(a["vertex_count"].as_u64().unwrap() > 1000, "{a}");
                    assert_eq!(a["index_count"].as_u64().unwrap() % 3, 0);
                }
                "relief" => {
                    assert_eq!(a["format"], "R8Unorm");
                    assert_eq!(a["dimensions"], serde_json::json!([32, 32, 1, 512]), "{a}");
                }
                "max_mip" => assert_eq!(a["levels"], 9, "{a}"),
                "strands" => {
                    // One 32-byte record per point, no indices.
                    assert_eq!(a["vertex_count"], 220_000, "{a}");
                    assert_eq!(a["index_count"], 0, "{a}");
                    assert_eq!(a["gpu_bytes"], 32 * 220_000, "{a}");
                    // Stored as a zstd frame (the default compression): smaller on disk.
                    assert!(a["byte_length"].as_u64().unwrap() < 32 * 220_000, "{a}");
                    let sets = a["sets"].as_array().unwrap();
                    assert_eq!(sets[0]["name"], "shading");
                    assert!(sets[1]["width"].as_f64().unwrap() > sets[0]["width"].as_f64().unwrap());
                }
                "mesh" => assert_eq!(a["vertex_count"], 440_000, "{a}"),
                other => panic!("unexpected kind {other}"),
            }
        }
    }
    let find = |id: &str| assets.iter().find(|a| a["id"] == id).unwrap_or_else(|| panic!("{id} missing"));
    assert_eq!(find("terrain.height")["dimensions"], serde_json::json!([512, 512, 1, 1]));
    assert_eq!(find("terrain.horizon")["dimensions"], serde_json::json!([512, 512, 32, 1]));
    assert_eq!(find("terrain.horizon")["dimension"], "D3");
    assert_eq!(find("terrain.horizon")["channels"], serde_json::json!(["slope", "distance"]));
    assert_eq!(find("reptile.ao")["kind"], "ambient_occlusion");
    // GPU memory as uploaded: 512 × 512 × 32 texels of two half floats; on disk zstd (the
    // default compression) stores less; the max-mip pyramid is 256² + 128² + … + 1² half floats.
    assert_eq!(find("terrain.horizon")["gpu_bytes"], 512 * 512 * 32 * 4);
    assert!(find("terrain.horizon")["byte_length"].as_u64().unwrap() < 512 * 512 * 32 * 4);
    let pyramid: u64 = (0..9).map(|k| (256u64 >> k).pow(2) * 2).sum();
    assert_eq!(find("relief_fbm.maxmip")["gpu_bytes"], pyramid);
    let sum = |key: &str| assets.iter().map(|a| a[key].as_u64().unwrap()).sum::<u64>();
    // On disk a file shared by identical payloads counts once.
    let files: std::collections::BTreeMap<&str, u64> =
        assets.iter().map(|a| (a["file"].as_str().unwrap(), a["byte_length"].as_u64().unwrap())).collect();
    assert!(files.len() < assets.len(), "head.strips and head_auto.strips share a file");
    assert_eq!(json["disk_bytes"], files.values().sum::<u64>());
    assert_eq!(json["gpu_bytes"], sum("gpu_bytes"));

    // `validate PIPELINE` checks without baking.
    let out = dir.run(&["validate", "pipeline.ron", "--format", "json"]);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["valid"], true);
    assert_eq!(json["jobs"].as_array().unwrap().len(), ids.len());
}

#[test]
fn rebake_skips_everything_and_leaves_the_bundle_byte_identical() {
    let dir = Dir::with_default_bundle("rebake");
    let first = dir.bundle_files("bundle");
    let out = dir.run(&["bake"]);
    assert!(stdout(&out).contains("baked 0, skipped"), "{}", stdout(&out));
    assert_eq!(dir.bundle_files("bundle"), first);
    // Now owned by this pipeline, a second rebake leaves every file as it is, records included.
    let owned = snapshot(&dir.path("bundle"));
    dir.run(&["bake"]);
    assert_eq!(snapshot(&dir.path("bundle")), owned);
}

#[test]
fn thread_count_does_not_change_a_byte() {
    let one = Dir::with_default_pipeline("jobs1");
    let two = Dir { root: default_bake().0.clone() }; // baked with --jobs 2
    // The default pipeline holds every kind of job, so this covers them all.
    let kinds: std::collections::BTreeSet<&str> = hikage_bake::Pipeline::load(&one.path("pipeline.ron"))
        .unwrap()
        .pipeline
        .jobs
        .iter()
        .map(|j| j.baker().kind())
        .collect();
    assert_eq!(kinds.into_iter().collect::<Vec<_>>(), ["curvature", "heightfield", "horizon", "relief", "strands"]);
    one.run(&["bake", "--jobs", "1"]);
    assert_eq!(one.bundle_files("bundle"), two.bundle_files("bundle"));
    // And `hikage diff` says so.
    let other = two.path("bundle");
    let text = crate::util::stdout(&one.run_expecting(&["diff", other.to_str().unwrap(), "bundle"], 0));
    assert!(text.contains("0 changed, 0 beyond tolerance"), "{text}");
}

#[test]
fn flipped_payload_byte_fails_validation_naming_the_asset() {
    let dir = Dir::with_default_bundle("flip");
    let payload = std::fs::read_dir(dir.path("bundle"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .find(|n| n.starts_with("relief_bricks.maxmip."))
        .unwrap();
    let mut bytes = dir.read(&format!("bundle/{payload}"));
    let i = bytes.len() / 2;
    bytes[i] ^= 0x01;
    dir.write(&format!("bundle/{payload}"), bytes);
    let out = dir.run_expecting(&["validate", "bundle"], 1);
    assert!(stdout(&out).contains("`relief_bricks.maxmip`") && stdout(&out).contains("BLAKE3"), "{}", stdout(&out));
    let out = dir.run_expecting(&["validate", "bundle", "--format", "json"], 1);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["valid"], false);
    assert_eq!(json["problems"][0]["asset"], "relief_bricks.maxmip");
    // The tampered asset is baked again rather than reused.
    let out = dir.run(&["bake"]);
    assert!(stdout(&out).contains("baked 1 (relief_bricks (payload damaged))"), "{}", stdout(&out));
    dir.run(&["validate", "bundle"]);
}

#[test]
fn changed_input_rebakes_one_job_and_removes_its_stale_payloads_once_no_reader_holds_them() {
    let dir = Dir::with_default_bundle("changed_input");
    let before = dir.bundle_files("bundle");
    let old = |snap: &std::collections::BTreeMap<String, Vec<u8>>| -> Vec<String> {
        snap.keys().filter(|k| k.starts_with("relief_fbm.")).cloned().collect()
    };
    // New heights for relief_fbm: the image mirrored (a copy of another job's image would
    // bake payloads that job already stores, which the bundle then stores once).
    let source = image::open(dir.path("data/relief_fbm.png")).unwrap();
    let rewrite = |img: image::DynamicImage| img.save(dir.path("data/relief_fbm.png")).unwrap();
    // Replace relief_fbm.png by another valid grayscale PNG: with no reader, the replaced
    // payloads go in the same commit (the bundle holds one generation, not two).
    rewrite(source.fliph());
    let out = dir.run(&["bake"]);
    assert!(
        stdout(&out).contains("baked 1 (relief_fbm (input changed))") && stdout(&out).contains("removed 2"),
        "{}",
        stdout(&out)
    );
    let after = dir.bundle_files("bundle");
    assert!(old(&before).iter().all(|k| !after.contains_key(k)), "stale payload kept");
    assert_eq!(after.len(), before.len());
    dir.run(&["validate", "bundle"]);

    // A reader holding the bundle (a game that opened it) keeps the payloads it may still
    // read until the next commit after it lets go.
    let reader = hikage_bundle::Bundle::open(&dir.path("bundle")).unwrap();
    rewrite(source.flipv());
    let out = dir.run(&["bake"]);
    assert!(stdout(&out).contains("baked 1 (") && !stdout(&out).contains("removed"), "{}", stdout(&out));
    for asset in &reader.manifest().assets {
        reader.read_payload(asset).expect("a reader of the replaced manifest finds every payload");
    }
    drop(reader);
    let out = dir.run(&["bake"]);
    assert!(stdout(&out).contains("baked 0,") && stdout(&out).contains("removed 2"), "{}", stdout(&out));
    assert_eq!(dir.bundle_files("bundle").len(), before.len());
    dir.run(&["validate", "bundle"]);
}

/// `head.strips` and `head_auto.strips` are the same bytes (their jobs differ only in the
/// opacity set, which the settings hold): the bundle stores them once, in a file named after the
/// first id, counts it once on disk, and validates. When one changes, the other gets its own
/// file again (copied from the shared one) and the shared file goes.
#[test]
fn identical_payloads_are_stored_once_until_one_changes() {
    let dir = Dir::with_default_bundle("shared_payloads");
    let manifest = || hikage_bundle::Bundle::open(&dir.path("bundle")).unwrap().manifest().clone();
    let file = |m: &hikage_bundle::Manifest, id: &str| m.assets.iter().find(|a| a.id == id).unwrap().file.clone();
    let before = manifest();
    let shared = file(&before, "head.strips");
    assert!(shared.starts_with("head.strips."), "{shared}");
    assert_eq!(file(&before, "head_auto.strips"), shared);
    let on_disk: u64 = dir
        .bundle_files("bundle")
        .iter()
        .filter(|(k, _)| k.ends_with(".ktx2") || k.ends_with(".bin"))
        .map(|(_, v)| v.len() as u64)
        .sum();
    let json: serde_json::Value =
        serde_json::from_slice(&dir.run(&["inspect", "bundle", "--format", "json"]).stdout).unwrap();
    assert_eq!(json["disk_bytes"].as_u64().unwrap(), on_disk, "a shared file is counted once");
    let bytes = dir.read(&format!("bundle/{shared}"));

    // A colour for `head` changes its records; `head_auto` is not baked again. (Stored twice,
    // the strips take the bundle over its disk budget: that budget is left out.)
    let pipeline = String::from_utf8(dir.read("pipeline.ron")).unwrap();
    let pipeline: String =
        pipeline.lines().filter(|l| !l.trim_start().starts_with("budget:")).map(|l| format!("{l}\n")).collect();
    let from = r#"Strands(id: "head", input: "data/head.hair", ribbons: true)"#;
    assert!(pipeline.contains(from));
    let to = r#"Strands(id: "head", input: "data/head.hair", ribbons: true, color: (0.5, 0.4, 0.3))"#;
    dir.write("pipeline.ron", pipeline.replace(from, to));
    let out = dir.run(&["bake"]);
    assert!(stdout(&out).contains("baked 1 ("), "{}", stdout(&out));
    let after = manifest();
    let (own, head) = (file(&after, "head_auto.strips"), file(&after, "head.strips"));
    assert!(own.starts_with("head_auto.strips.") && head.starts_with("head.strips.") && head != shared, "{own} {head}");
    assert_eq!(dir.read(&format!("bundle/{own}")), bytes);
    assert!(!dir.path(&format!("bundle/{shared}")).exists(), "the shared file is no longer named and goes");
    dir.run(&["validate", "bundle"]);
}

#[test]
fn build_script_entry_watches_the_pipeline_and_every_input() {
    let dir = Dir::with_default_bundle("build_script");
    let report = hikage_bake::run::run_pipeline(&dir.path("pipeline.ron"), &Default::default()).unwrap();
    let watched: Vec<String> = report.watched.iter().map(|p| p.display().to_string()).collect();
    assert!(watched[0].ends_with("pipeline.ron"));
    for f in ["cylinders.png", "dunes.exr", "terrain.png"] {
        assert!(watched.iter().any(|w| w.ends_with(f)), "{f} not watched: {watched:?}");
    }
}

#[test]
fn killed_bake_leaves_the_old_or_the_new_bundle() {
    let dir = Dir::new("killed");
    dir.copy_data();
    // Many jobs over the largest input so a kill lands in the middle of the run.
    let jobs: String = (0..24)
        .map(|i| format!("Heightfield(id: \"t{i}\", input: \"data/terrain.png\", height_scale: {}),\n", i + 1))
        .collect();
    dir.write("pipeline.ron", format!("(output: \"bundle\", jobs: [{jobs}])"));
    dir.run(&["bake"]);
    let old = snapshot(&dir.path("bundle"));
    // The new bundle: every input changed.
    let old_png = dir.read("data/terrain.png");
    let new_png = dir.read("data/reptile.png");
    let reference = Dir::new("killed_reference");
    reference.write("data/terrain.png", &new_png);
    reference.write("pipeline.ron", dir.read("pipeline.ron"));
    reference.run(&["bake"]);
    let new = reference.bundle_files("bundle");
    assert_ne!(old.get("bundle.ron"), new.get("bundle.ron"));

    for (i, delay_ms) in [0u64, 5, 15, 30, 60, 120, 250].into_iter().enumerate() {
        // Alternate the inputs so kills land both on old→new and new→old bakes.
        dir.write("data/terrain.png", if i % 2 == 0 { &new_png } else { &old_png });
        let mut child = dir.command(&["bake", "--jobs", "1"]).spawn().unwrap();
        std::thread::sleep(Duration::from_millis(delay_ms));
        let _ = child.kill(); // SIGKILL on unix
        let _ = child.wait();
        dir.run(&["validate", "bundle"]);
        let manifest = std::fs::read(dir.path("bundle/bundle.ron")).unwrap();
        assert!(
            Some(&manifest) == old.get("bundle.ron") || Some(&manifest) == new.get("bundle.ron"),
            "after a kill at {delay_ms} ms the manifest is neither the old nor the new one"
        );
    }
    // A rerun completes; with the next one (which sweeps the previous generation and what the
    // killed writers staged), the bundle is exactly the reference for the current inputs.
    dir.write("data/terrain.png", &new_png);
    dir.run(&["bake"]);
    dir.run(&["validate", "bundle"]);
    dir.run(&["bake"]);
    assert_eq!(dir.bundle_files("bundle"), new);
}

#[test]
fn raw_and_exr_export_give_back_the_source_heights() {
    let dir = Dir::with_default_bundle("export");
    // Independent reference: decode the PNG with the image crate.
    let png = image::open(dir.path("data/terrain.png")).unwrap().into_luma16();
    let expected: Vec<f32> = png.pixels().map(|p| p.0[0] as f32 / 65535.0).collect();

    dir.run(&["export", "bundle", "terrain.height", "--out", "terrain.f32", "--raw", "--channel", "height"]);
    let raw = dir.read("terrain.f32");
    assert_eq!(raw.len(), 512 * 512 * 4);
    let values: Vec<f32> = raw.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    assert_eq!(values, expected);

    dir.run(&["export", "bundle", "terrain.height", "--out", "terrain.exr"]);
    let image = exr::prelude::read_first_flat_layer_from_file(dir.path("terrain.exr")).unwrap();
    let ch = &image.layer_data.channel_data.list[0];
    assert_eq!(ch.name.to_string(), "height");
    match &ch.sample_data {
        exr::prelude::FlatSamples::F32(v) => assert_eq!(v, &expected),
        other => panic!("expected f32 samples, found {other:?}"),
    }

    let out =
        dir.run_expecting(&["export", "bundle", "terrain.height", "--out", "x.f32", "--raw", "--channel", "slope"], 1);
    assert!(stderr(&out).contains("no channel \"slope\""), "{}", stderr(&out));
    let out = dir.run_expecting(&["export", "bundle", "nope", "--out", "x.f32"], 1);
    assert!(stderr(&out).contains("no asset `nope`"), "{}", stderr(&out));
}

#[test]
fn usage_errors_exit_2_and_help_documents_exit_codes() {
    let dir = Dir::new("usage");
    dir.run_expecting(&["frobnicate"], 2);
    dir.run_expecting(&["bake", "--jobs", "0"], 2);
    let out = dir.run(&["--help"]);
    assert!(stdout(&out).contains("3  I/O error"), "{}", stdout(&out));
}

#[test]
fn horizon_one_shot_exports_direction_major_maps() {
    let dir = Dir::new("horizon_one_shot");
    dir.copy_data();
    for format in ["rg32f", "rg16f", "rg8"] {
        let out = format!("b_{format}");
        let args = [
            "horizon",
            "data/cylinders.png",
            "--out",
            &out,
            "--directions",
            "8",
            "--height-scale",
            "4",
            "--format",
            format,
            "--ao",
        ];
        dir.run(&args);
        dir.run(&["validate", &out]);
        for channel in ["slope", "distance"] {
            let file = format!("{out}/{channel}.f32");
            dir.run(&["export", &out, "cylinders.horizon", "--raw", "--channel", channel, "--out", &file]);
            let raw = dir.read(&file);
            assert_eq!(raw.len(), 8 * 128 * 128 * 4, "D×H×W f32");
        }
    }
    // The three formats agree within their precision: direction-major layout, same values.
    let read = |f: &str| -> Vec<f32> {
        dir.read(f).chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
    };
    let exact = read("b_rg32f/slope.f32");
    let half = read("b_rg16f/slope.f32");
    let byte = read("b_rg8/slope.f32");
    for i in 0..exact.len() {
        let (e, h, b) = (exact[i].atan().to_degrees(), half[i].atan().to_degrees(), byte[i].atan().to_degrees());
        assert!((e - h).abs() < 0.1, "texel {i}: rg16f {h}° vs rg32f {e}°");
        assert!((e - b).abs() <= 0.36, "texel {i}: rg8 {b}° vs rg32f {e}° (step 0.71°)");
    }
    // Direction 0 looks along +u: at row 64, the texel left of a cylinder wall sees it.
    let texel = |k: usize, row: usize, col: usize| exact[(k * 128 + row) * 128 + col];
    assert!(texel(0, 16, 2) > 0.0, "a cylinder ahead along +u");
    // Rebaking the same command skips; other assets in the bundle are kept.
    let out = dir.run(&[
        "horizon",
        "data/cylinders.png",
        "--out",
        "b_rg8",
        "--directions",
        "8",
        "--height-scale",
        "4",
        "--format",
        "rg8",
        "--ao",
    ]);
    assert!(stdout(&out).contains("skipped 1"), "{}", stdout(&out));
}

#[test]
fn horizon_one_shot_refuses_bad_settings() {
    let dir = Dir::new("horizon_bad");
    dir.copy_data();
    for (args, needle) in [
        (vec!["--directions", "0"], "directions must be 1 to 256"),
        (vec!["--directions", "257"], "directions must be 1 to 256"),
        (vec!["--texel-size", "0,1"], "texel_size"),
        (vec!["--texel-size", "inf"], "texel_size"),
        (vec!["--max-distance", "-1"], "max_distance"),
    ] {
        let mut full = vec!["horizon", "data/cylinders.png", "--out", "b"];
        full.extend(args);
        let out = dir.run_expecting(&full, 1);
        assert!(stderr(&out).contains(needle), "{}", dir.explain(&full, &out, needle));
        assert!(!dir.path("b/bundle.ron").exists());
    }
}

#[test]
fn relief_one_shot_adds_depth_maps_and_refuses_bad_settings() {
    let dir = Dir::new("relief_one_shot");
    dir.copy_data();
    for (args, needle) in [
        (vec!["--theta", "0"], "theta must be 1–128"),
        (vec!["--phi", "100000"], "phi must be 1–128"),
        (vec!["--theta", "128", "--phi", "128"], "at most 2048 directions"),
        (vec!["--size", "48"], "power of two"),
        (vec!["--size", "512"], "at most the map width 256"),
        (vec!["--depth-scale", "0"], "depth_scale"),
        (vec!["--preset", "paper-192k", "--theta", "8"], "sets theta, phi, size and format"),
    ] {
        let mut full = vec!["relief", "data/relief_bricks.png", "--out", "b"];
        full.extend(args);
        let out = dir.run_expecting(&full, 1);
        assert!(stderr(&out).contains(needle), "{}", dir.explain(&full, &out, needle));
        assert!(!dir.path("b/bundle.ron").exists());
    }
    let args = ["relief", "data/terrain.png", "--out", "c", "--theta", "2", "--phi", "3", "--size", "64"];
    dir.run(&args);
    let json = dir.run(&["inspect", "c", "--format", "json"]);
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    let text = v.to_string();
    assert!(text.contains("terrain.relief") && text.contains("terrain.maxmip"), "{text}");
    dir.run(&["validate", "c"]);
    // 2 × 3 layers of 64 × 64 8-bit depths, the direction table alongside.
    dir.run(&["export", "c", "terrain.relief", "--raw", "--out", "d.f32"]);
    assert_eq!(dir.read("d.f32").len(), 6 * 64 * 64 * 4);
    let manifest = String::from_utf8(dir.read("c/bundle.ron")).unwrap();
    let table: String = manifest.split_whitespace().collect();
    assert!(table.contains("directions:[(22.5,0.0),(22.5,120.0),(22.5,240.0),(67.5,0.0),"), "{manifest}");
    // The paper's 192 KB: 192 one-byte 32² maps, 12 zenith rows (3.75° apart) × 16 azimuths.
    // Stored raw (`--zstd 0`) so the file is the maps' memory.
    dir.run(&["relief", "data/relief_bricks.png", "--out", "e", "--preset", "paper-192k", "--zstd", "0"]);
    dir.run(&["export", "e", "relief_bricks.relief", "--raw", "--out", "e.f32"]);
    assert_eq!(dir.read("e.f32").len(), 192 * 32 * 32 * 4);
    let manifest: String = String::from_utf8(dir.read("e/bundle.ron")).unwrap().split_whitespace().collect();
    assert!(manifest.contains("theta:12,phi:16,") && manifest.contains("(3.75,0.0),(3.75,22.5),"), "{manifest}");
    let ktx = std::fs::read_dir(dir.path("e")).unwrap().map(|e| e.unwrap().path());
    let payload = ktx.filter(|p| p.to_string_lossy().contains(".relief.")).map(|p| std::fs::metadata(p).unwrap().len());
    let bytes: u64 = payload.sum();
    assert!((192 * 1024..192 * 1024 + 1024).contains(&bytes), "{bytes} bytes: 192 KiB of maps and a KTX2 header");
}

/// `export --gltf` of the ribbon mesh: a well-formed GLB whose accessors describe exactly the
/// streams of the asset (positions with min/max, `TANGENT`, `COLOR_0` with the opacity), the
/// same file as the export of the strips themselves, and — when
/// `HIKAGE_GLTF_VALIDATOR` names a Node script running the Khronos glTF validator on its argument
/// — a file that validator accepts.
#[test]
fn ribbons_export_as_valid_gltf() {
    let dir = Dir::new("gltf");
    dir.copy_data();
    dir.run(&["strands", "data/head.hair", "--out", "b", "--ribbons"]);
    dir.run(&["export", "b", "head.ribbons", "--gltf", "head.glb"]);
    let glb = dir.read("head.glb");
    let u32_at = |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().unwrap());
    assert_eq!(&glb[..4], b"glTF");
    assert_eq!(u32_at(4), 2);
    assert_eq!(u32_at(8) as usize, glb.len());
    let json_len = u32_at(12) as usize;
    assert_eq!(&glb[16..20], b"JSON");
    let doc: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    assert_eq!(&glb[bin_at + 4..bin_at + 8], b"BIN\0");
    let bin = &glb[bin_at + 8..bin_at + 8 + u32_at(bin_at) as usize];
    let attrs = &doc["meshes"][0]["primitives"][0]["attributes"];
    for name in ["POSITION", "NORMAL", "TANGENT", "TEXCOORD_0", "COLOR_0", "_STRAND_ID"] {
        assert!(attrs[name].is_u64(), "{name} missing: {attrs}");
    }
    // 8-bit normals and tangents are beyond core glTF: the file says it needs the extension.
    for key in ["extensionsUsed", "extensionsRequired"] {
        assert_eq!(doc[key], serde_json::json!(["KHR_mesh_quantization"]), "{key}");
    }
    let bundle = hikage_bundle::Bundle::open(&dir.path("b")).unwrap();
    let mesh = bundle.read_mesh("head.ribbons").unwrap();
    // Each attribute: glTF's component type (BYTE 5120, UNSIGNED_SHORT 5123, FLOAT 5126),
    // `normalized` for the integers, elements 4-byte aligned, and the stored bytes.
    for (gltf, stream, code, size, components) in [
        ("POSITION", "position", 5126, 4, 3),
        ("NORMAL", "normal", 5120, 1, 3),
        ("TANGENT", "tangent", 5120, 1, 4),
        ("TEXCOORD_0", "uv", 5123, 2, 2),
        ("COLOR_0", "color", 5123, 2, 4),
        ("_STRAND_ID", "strand_id", 5126, 4, 1),
    ] {
        let acc = &doc["accessors"][attrs[gltf].as_u64().unwrap() as usize];
        assert_eq!(acc["componentType"], code, "{gltf}");
        assert_eq!(acc["normalized"].as_bool().unwrap_or(false), code != 5126, "{gltf}");
        let view = &doc["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
        let (off, len) = (view["byteOffset"].as_u64().unwrap() as usize, view["byteLength"].as_u64().unwrap() as usize);
        let element = size * components;
        let stride = view["byteStride"].as_u64().map_or(element, |s| s as usize);
        assert!(
            stride.is_multiple_of(4) && stride >= element && off.is_multiple_of(4),
            "{gltf}: stride {stride}, offset {off}"
        );
        let count = acc["count"].as_u64().unwrap() as usize;
        assert_eq!(count, 440_000);
        let a = mesh.desc.attribute(stream).unwrap();
        let stored: Vec<&[u8]> = mesh.elements(a).collect();
        for (i, e) in stored.iter().enumerate().step_by(997) {
            assert_eq!(&bin[off + i * stride..off + i * stride + element], *e, "{gltf} element {i}");
        }
        assert!(off + (count - 1) * stride + element <= len + off);
        if gltf == "POSITION" {
            let values = mesh.read_f32("position").unwrap();
            let min: Vec<f32> =
                (0..3).map(|k| values.iter().skip(k).step_by(3).fold(f32::INFINITY, |m, &v| m.min(v))).collect();
            let got: Vec<f32> = acc["min"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap() as f32).collect();
            assert_eq!(got, min);
        }
    }
    // 36 bytes a vertex (68 in floats): the quantized streams, as KHR_mesh_quantization has them.
    let per_vertex: usize = mesh.desc.attributes.iter().map(|a| a.stride as usize).sum();
    assert_eq!(per_vertex, 36);
    dir.run(&["export", "b", "head.strips", "--gltf", "strips.glb"]);
    assert!(dir.read("strips.glb") == glb, "the strips export as their ribbons");
    if let Ok(script) = std::env::var("HIKAGE_GLTF_VALIDATOR") {
        let out = std::process::Command::new("node").arg(&script).arg(dir.path("head.glb")).output().unwrap();
        assert!(out.status.success(), "glTF validator: {}", String::from_utf8_lossy(&out.stdout));
    } else {
        eprintln!("not running the Khronos glTF validator: set HIKAGE_GLTF_VALIDATOR to a Node script (docs/hair.md)");
    }
    // A texture is not a mesh.
    let out = dir.run_expecting(&["export", "b", "head.strips", "--gltf", "x.glb", "--out", "y"], 2);
    assert!(stderr(&out).contains("cannot be used with"), "{}", stderr(&out));
}

/// A curvature asset exported with `export --gltf` (TEXCOORD_0 from its `uv` stream) is itself a
/// valid `Curvature` input: baked again from the GLB, which repeats positions at the UV seam,
/// it gives the same vertices and, up to the f32 positions, the same curvature.
#[test]
fn curvature_bakes_from_gltf_as_from_obj() {
    let dir = Dir::new("curvature_gltf");
    dir.copy_data();
    dir.write("p.ron", r#"(output: "b", jobs: [Curvature(id: "obj", input: "data/sphere.obj")])"#);
    dir.run(&["bake", "p.ron"]);
    dir.run(&["export", "b", "obj", "--gltf", "sphere.glb"]);
    let glb = dir.read("sphere.glb");
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    assert!(doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"].is_u64(), "{doc}");
    dir.write(
        "q.ron",
        r#"(output: "b", jobs: [Curvature(id: "obj", input: "data/sphere.obj"), Curvature(id: "glb", input: "sphere.glb")])"#,
    );
    // Another pipeline into the same bundle takes it over only when told to.
    dir.run_expecting(&["bake", "q.ron"], 1);
    dir.run(&["bake", "q.ron", "--force"]);
    let bundle = hikage_bundle::Bundle::open(&dir.path("b")).unwrap();
    let (a, b) = (bundle.read_mesh("obj").unwrap(), bundle.read_mesh("glb").unwrap());
    assert_eq!(a.read_f32("uv").unwrap(), b.read_f32("uv").unwrap());
    assert_eq!(a.desc.indices.as_ref().map(|i| i.count), b.desc.indices.as_ref().map(|i| i.count));
    let (ka, kb) = (a.read_f32("curvature").unwrap(), b.read_f32("curvature").unwrap());
    let worst = ka.iter().zip(&kb).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    assert!(worst < 1e-3, "largest curvature difference {worst}");

    // The same mesh as `.gltf` + `.bin`: the buffer file is an input, so changing it rebakes.
    let bin_at = 20 + json_len;
    let mut doc = doc;
    doc["buffers"][0]["uri"] = serde_json::json!("s.bin");
    dir.write("s.gltf", serde_json::to_vec(&doc).unwrap());
    let mut bin = glb[bin_at + 8..].to_vec();
    dir.write("s.bin", &bin);
    dir.write("r.ron", r#"(output: "c", jobs: [Curvature(id: "s", input: "s.gltf")])"#);
    dir.run(&["bake", "r.ron"]);
    let curvature = |dir: &Dir| {
        let bundle = hikage_bundle::Bundle::open(&dir.path("c")).unwrap();
        bundle.read_mesh("s").unwrap().read_f32("curvature").unwrap()
    };
    let before = curvature(&dir);
    assert!(before == kb, "the .gltf + .bin bake differs from the GLB bake");
    let y = f32::from_le_bytes(bin[4..8].try_into().unwrap());
    bin[4..8].copy_from_slice(&(y * 1.5).to_le_bytes()); // lift vertex 0 (a pole)
    dir.write("s.bin", &bin);
    dir.run(&["bake", "r.ron"]);
    assert!(curvature(&dir) != before, "a changed buffer file did not rebake");
}

/// A raw engine heightmap through the one-shot horizon bake: `--raw-size` gives its shape, the
/// heights are taken as stored (the height asset holds them exactly), and a wrong size is
/// refused naming the file.
#[test]
fn raw_heightmaps_bake_with_their_size() {
    let dir = Dir::new("raw_heightmap");
    let (w, h) = (8u32, 4u32);
    let values: Vec<u16> = (0..w * h).map(|i| (i * 37 % 500) as u16).collect();
    dir.write("map.r16", values.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>());
    dir.run(&["horizon", "map.r16", "--raw-size", "8x4", "--out", "b", "--directions", "4", "--edge", "clamp"]);
    dir.run(&["export", "b", "map.height", "--raw", "--out", "h.f32"]);
    let got: Vec<f32> = dir.read("h.f32").chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    assert_eq!(got, values.iter().map(|&v| v as f32).collect::<Vec<_>>());
    let args = ["horizon", "map.r16", "--raw-size", "8x5", "--out", "c"];
    let out = dir.run_expecting(&args, 1);
    assert!(stderr(&out).contains("map.r16") && stderr(&out).contains("80 bytes, found 64"), "{}", stderr(&out));
}

/// A job's `compression` (and a one-shot's `--zstd`): raw, zstd 1 and zstd 19 bundles of the
/// same strands and relief maps hold the same data once read — texture levels and mesh buffers
/// byte for byte — in files of half the size (strips gain nothing from level 19 over 1: their
/// floats leave little for a longer search); the manifest says which meshes are
/// compressed; a level outside 1–22 is refused by name; and a mesh frame claiming more than a
/// reader's limit is refused before it is inflated.
#[test]
fn compression_levels_keep_the_data_and_shrink_the_files() {
    let dir = Dir::new("compression");
    dir.write("head.hair", std::fs::read("data/head.hair").unwrap());
    dir.write("bricks.png", std::fs::read("data/relief_bricks.png").unwrap());
    let mut sizes = Vec::new();
    let mut read = Vec::new();
    for level in ["0", "1", "19", "auto"] {
        let out = format!("b{level}");
        dir.run(&["strands", "head.hair", "--out", &out, "--zstd", level]);
        dir.run(&["relief", "bricks.png", "--out", &out, "--zstd", level]);
        dir.run(&["validate", &out]);
        let bundle = hikage_runtime::CpuBundle::read(&dir.path(&out)).unwrap();
        let manifest = String::from_utf8(dir.read(&format!("{out}/bundle.ron"))).unwrap();
        assert_eq!(manifest.contains("supercompression: zstd"), level != "0", "{manifest}");
        sizes.push(dir.bundle_files(&out).values().map(Vec::len).sum::<usize>());
        read.push(bundle.assets.into_iter().map(|a| (a.asset.id, a.payload)).collect::<Vec<_>>());
    }
    for other in &read[1..] {
        assert_eq!(other.len(), read[0].len());
        for ((id, raw), (_, inflated)) in read[0].iter().zip(other) {
            match (raw, inflated) {
                (hikage_bundle::PayloadData::Texture(a), hikage_bundle::PayloadData::Texture(b)) => {
                    assert_eq!(a.levels, b.levels, "{id}")
                }
                (hikage_bundle::PayloadData::Mesh(a), hikage_bundle::PayloadData::Mesh(b)) => {
                    assert_eq!((&a.desc, &a.bytes), (&b.desc, &b.bytes), "{id}")
                }
                _ => panic!("{id}: the payload changed kind"),
            }
        }
    }
    assert!(sizes[1..].iter().all(|&s| s < sizes[0] * 6 / 10), "bytes raw, zstd 1, zstd 19, auto: {sizes:?}");
    let out = dir.run_expecting(&["strands", "head.hair", "--out", "x", "--zstd", "23"], 2);
    assert!(stderr(&out).contains("outside 1–22"), "{}", stderr(&out));

    // A compressed mesh whose frame declares 8 GiB: the manifest made to match the file, the
    // reader refuses it by its declared size.
    let payload = dir.bundle_files("b19").into_keys().find(|n| n.starts_with("head.strips.")).unwrap();
    let bomb = {
        // Magic; descriptor: an 8-byte content size; a 1 KiB window.
        let mut frame = vec![0x28, 0xB5, 0x2F, 0xFD, 0xC0, 0x00];
        frame.extend_from_slice(&(8u64 << 30).to_le_bytes());
        frame.extend_from_slice(&[0x01, 0x00, 0x00]); // one empty raw last block
        frame
    };
    let manifest = String::from_utf8(dir.read("b19/bundle.ron")).unwrap();
    let old = std::fs::read(dir.path(&format!("b19/{payload}"))).unwrap();
    let manifest = manifest
        .replace(blake3::hash(&old).to_hex().as_str(), blake3::hash(&bomb).to_hex().as_str())
        .replace(&format!("byte_length: {},", old.len()), &format!("byte_length: {},", bomb.len()));
    dir.write("b19/bundle.ron", manifest);
    dir.write(&format!("b19/{payload}"), bomb);
    let out = dir.run_expecting(&["validate", "b19"], 1);
    assert!(
        stdout(&out).contains("head.strips") && stdout(&out).contains("declares 8589934592 bytes"),
        "{}",
        stdout(&out)
    );
}

/// The same pipeline baked in two checkouts gives byte-identical bundles, every file included
/// (the owner record is the pipeline's path relative to the bundle, not the machine's path),
/// and the record still keeps a second pipeline from replacing the bundle.
#[test]
fn two_checkouts_bake_byte_identical_bundles_and_ownership_holds() {
    let pipeline = r#"(output: "out/bundle", jobs: [Heightfield(id: "t", input: "data/cylinders.png")])"#;
    let (a, b) = (Dir::with_pipeline("checkout_a", pipeline), Dir::with_pipeline("checkout_b", pipeline));
    a.run(&["bake"]);
    b.run(&["bake"]);
    assert_eq!(snapshot(&a.path("out/bundle")), snapshot(&b.path("out/bundle")));
    assert_eq!(a.read("out/bundle/.hikage-owner"), b"../../pipeline.ron\n");
    // A bundle of an older hikage records its owner's absolute path: still the same pipeline.
    let absolute = std::fs::canonicalize(a.path("pipeline.ron")).unwrap();
    a.write("out/bundle/.hikage-owner", format!("{}\n", absolute.display()));
    a.run(&["bake"]);
    assert_eq!(a.read("out/bundle/.hikage-owner"), b"../../pipeline.ron\n");

    a.write("other.ron", pipeline);
    let out = a.run_expecting(&["bake", "other.ron"], 1);
    // Both named as the bundle's path names them (here relative to the working directory).
    assert!(stderr(&out).contains("belongs to the pipeline pipeline.ron, and other.ron may not"), "{}", stderr(&out));
    a.run(&["bake", "other.ron", "--force"]);
    assert_eq!(a.read("out/bundle/.hikage-owner"), b"../../other.ron\n");
}

/// A pipeline's budget: a bake over it commits nothing and exits 4, naming the bundle, job or
/// asset, the figure and the budget; a bake within it records it in the manifest, where
/// `validate BUNDLE` checks it again; `validate PIPELINE` checks the bundle at the output; a
/// budget naming no job of the pipeline is a setting error.
#[test]
fn budgets_refuse_to_commit_and_validate_checks_them() {
    let pipeline = |budget: &str| {
        format!(
            r#"(output: "bundle", budget: ({budget}), jobs: [
                Horizon(id: "t", input: "data/cylinders.png", directions: 4),
                Heightfield(id: "h", input: "data/relief_bricks.png"),
            ])"#
        )
    };
    let dir = Dir::with_pipeline("budget", &pipeline(r#"disk: Some(100000000), gpu: Some(100000000)"#));
    dir.run(&["bake"]);
    dir.run(&["validate", "bundle"]);
    let manifest = String::from_utf8(dir.read("bundle/bundle.ron")).unwrap();
    assert!(manifest.contains("budget: Some((") && manifest.contains("disk: Some(100000000)"), "{manifest}");
    let before = snapshot(&dir.path("bundle"));
    // The horizon texture's GPU bytes: 128² texels × 4 directions × 2 half floats.
    let horizon_gpu = 128 * 128 * 4 * 4;
    for (budget, names) in [
        (
            "gpu: Some(1000)".to_string(),
            ["bundle: ", "bytes in GPU memory, over its budget of 1000", "largest: `t.horizon`"],
        ),
        (
            r#"jobs: {"t": (gpu: Some(1000))}"#.to_string(),
            ["job `t`: ", "bytes in GPU memory, over its budget of 1000", "largest: `t.horizon`"],
        ),
        (
            format!(r#"assets: {{"t.horizon": (gpu: Some({}))}}"#, horizon_gpu - 1),
            ["asset `t.horizon`: ", &format!("{horizon_gpu} bytes in GPU memory"), "over its budget"],
        ),
    ] {
        dir.write("pipeline.ron", pipeline(&budget));
        for args in [&["bake"][..], &["validate", "pipeline.ron"]] {
            let out = dir.run_expecting(args, 4);
            let text = stderr(&out);
            assert!(names.iter().all(|n| text.contains(n)), "{budget}: {text}");
        }
        assert_eq!(snapshot(&dir.path("bundle")), before, "{budget}: nothing committed");
    }
    // Exactly at the asset's budget is within it.
    dir.write("pipeline.ron", pipeline(&format!(r#"assets: {{"t.horizon": (gpu: Some({horizon_gpu}))}}"#)));
    dir.run(&["bake"]);
    // A shipped bundle whose recorded budget it no longer meets fails `validate` with 4 too.
    let manifest = String::from_utf8(dir.read("bundle/bundle.ron")).unwrap();
    dir.write("bundle/bundle.ron", manifest.replace(&format!("gpu: Some({horizon_gpu})"), "gpu: Some(5)"));
    let out = dir.run_expecting(&["validate", "bundle", "--format", "json"], 4);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["valid"], true);
    assert_eq!(json["over_budget"][0]["scope"], "asset `t.horizon`");
    assert_eq!(json["over_budget"][0]["budget"], 5);
    // A budget naming what the pipeline does not make is refused before anything is read.
    for (budget, word) in
        [(r#"jobs: {"tt": (disk: Some(1))}"#, "job `tt`"), (r#"assets: {"x.ao": (disk: Some(1))}"#, "`x.ao`")]
    {
        dir.write("pipeline.ron", pipeline(budget));
        let out = dir.run_expecting(&["validate", "pipeline.ron"], 1);
        assert!(stderr(&out).contains(word) && stderr(&out).contains("budget"), "{}", stderr(&out));
    }
}

/// `export --gltf` of a skinned scalp: its joint indices are `JOINTS_0`, unsigned and not
/// normalized (a reader gets the joint numbers, not fractions), its weights `WEIGHTS_0`, under a
/// skin naming the scalp's joints.
#[test]
fn a_scalp_exports_its_joints_as_integers_under_a_skin() {
    let character = hikage_devkit::synth::character(400, 8, 5);
    let dir = Dir::new("gltf_scalp");
    dir.write("character.glb", &character.glb);
    dir.write("head.hair", hikage_bake::strands::cyhair::encode(&character.hair, "skinned character"));
    dir.run(&["strands", "head.hair", "--out", "b", "--scalp", "character.glb"]);
    let bundle = hikage_bundle::Bundle::open(&dir.path("b")).unwrap();
    let scalp = bundle.manifest().assets.iter().find(|a| a.kind == hikage_bundle::AssetKind::Scalp).unwrap().clone();
    let joints = scalp.settings.scalp().unwrap().joints.clone();
    dir.run(&["export", "b", &scalp.id, "--gltf", "scalp.glb"]);
    let glb = dir.read("scalp.glb");
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let attrs = &doc["meshes"][0]["primitives"][0]["attributes"];
    let accessor = |name: &str| &doc["accessors"][attrs[name].as_u64().unwrap() as usize];
    assert_eq!(accessor("JOINTS_0")["componentType"], 5123, "{doc}");
    assert!(accessor("JOINTS_0").get("normalized").is_none(), "{doc}");
    assert_eq!(accessor("WEIGHTS_0")["normalized"], true, "{doc}");
    assert!(attrs.get("_JOINTS").is_none() && attrs.get("_WEIGHTS").is_none(), "{doc}");
    let names: Vec<&str> = doc["skins"][0]["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| doc["nodes"][n.as_u64().unwrap() as usize]["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, joints.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(doc["nodes"][0]["skin"], 0);
    // The joint numbers read back as the scalp holds them, every one a joint of the skin.
    let scalp_mesh = bundle.read_mesh(&scalp.id).unwrap();
    let read = hikage_bundle::Scalp::read(&scalp_mesh).unwrap();
    let bin_at = 20 + json_len;
    let bin = &glb[bin_at + 8..];
    let view = &doc["bufferViews"][accessor("JOINTS_0")["bufferView"].as_u64().unwrap() as usize];
    let offset = view["byteOffset"].as_u64().unwrap() as usize;
    let stride = view.get("byteStride").and_then(|s| s.as_u64()).unwrap_or(8) as usize;
    for (v, want) in read.joints.iter().enumerate() {
        let at = offset + v * stride;
        let j: [u16; 4] = std::array::from_fn(|k| u16::from_le_bytes([bin[at + 2 * k], bin[at + 2 * k + 1]]));
        assert_eq!(&j, want, "vertex {v}");
        assert!(j.iter().all(|&x| (x as usize) < joints.len()), "vertex {v}: joints {j:?}");
    }
}
