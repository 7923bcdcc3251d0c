//! Hostile inputs against the newest surfaces — shard parts and merge, the shared cache, tiles,
//! elevation grids, and the command's own output — each built here (byte by byte where that is
//! clearer). Each is refused by name with its exit code (1 content, 2 usage, 3 I/O), never a
//! panic or a hang, and the previous bundle and cache are byte-identical afterwards.

use std::collections::BTreeMap;
use std::path::Path;

use crate::util::{Dir, counts, snapshot, stderr, stdout};

/// A little-endian TIFF of one sample per pixel, `bits` deep, of `SampleFormat` `format`
/// (1 unsigned, 2 signed, 3 float), its `data` in strips of `rows_per_strip` rows, with a
/// GDAL no-data tag when given (its text, or a claimed length with no text behind it).
fn tiff(w: u32, h: u32, bits: u16, format: u16, data: &[u8], rows_per_strip: u32, no_data: NoData) -> Vec<u8> {
    let strip_bytes = (w as usize * rows_per_strip as usize * bits as usize).div_ceil(8);
    let mut out = b"II*\0\0\0\0\0".to_vec();
    let (mut offsets, mut counts) = (Vec::new(), Vec::new());
    for s in data.chunks(strip_bytes.max(1)) {
        offsets.push(out.len() as u32);
        counts.push(s.len() as u32);
        out.extend_from_slice(s);
    }
    tiff_ifd(&mut out, (w, h, bits, format, rows_per_strip), &offsets, &counts, no_data);
    out
}

/// Appends the image directory of a [`tiff`] (and its out-of-line values) to `out`, whose
/// first eight bytes are the header, and points the header at it. `shape` is width, height,
/// bits, sample format and rows per strip; `offsets` and `counts` the strips'.
fn tiff_ifd(out: &mut Vec<u8>, shape: (u32, u32, u16, u16, u32), offsets: &[u32], counts: &[u32], no_data: NoData) {
    let (w, h, bits, format, rows_per_strip) = shape;
    let extra = |bytes: &[u8], out: &mut Vec<u8>| {
        let at = out.len() as u32;
        out.extend_from_slice(bytes);
        at
    };
    let table = |values: &[u32], out: &mut Vec<u8>| match values {
        [one] => *one,
        _ => extra(&values.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>(), out),
    };
    let (offsets_at, counts_at) = (table(offsets, out), table(counts, out));
    // (tag, type, count, value or offset); types: 2 ASCII, 3 SHORT, 4 LONG.
    let mut entries: Vec<(u16, u16, u32, u32)> = vec![
        (256, 4, 1, w),
        (257, 4, 1, h),
        (258, 3, 1, bits as u32),
        (259, 3, 1, 1),
        (262, 3, 1, 1),
        (273, 4, offsets.len() as u32, offsets_at),
        (277, 3, 1, 1),
        (278, 4, 1, rows_per_strip),
        (279, 4, counts.len() as u32, counts_at),
        (339, 3, 1, format as u32),
    ];
    match no_data {
        NoData::None => {}
        NoData::Text(t) => {
            let mut text = t.as_bytes().to_vec();
            text.push(0);
            let at = if text.len() <= 4 {
                text.resize(4, 0);
                u32::from_le_bytes(text[..4].try_into().unwrap())
            } else {
                extra(&text, out)
            };
            entries.push((42113, 2, t.len() as u32 + 1, at));
        }
        NoData::Claimed(count) => entries.push((42113, 2, count, 8)),
    }
    if out.len() % 2 == 1 {
        out.push(0);
    }
    let ifd = out.len() as u32;
    out[4..8].copy_from_slice(&ifd.to_le_bytes());
    out.extend_from_slice(&(entries.len() as u16).to_le_bytes());
    for (tag, ty, count, value) in entries {
        out.extend_from_slice(&tag.to_le_bytes());
        out.extend_from_slice(&ty.to_le_bytes());
        out.extend_from_slice(&count.to_le_bytes());
        out.extend_from_slice(&value.to_le_bytes());
    }
    out.extend_from_slice(&0u32.to_le_bytes());
}

/// The GDAL no-data tag of a [`tiff`].
#[derive(Clone, Copy)]
enum NoData {
    None,
    Text(&'static str),
    /// A tag claiming this many bytes of text.
    Claimed(u32),
}

/// Little-endian f32 bytes.
fn f32s(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// A smooth 32×32 `.r32` map.
fn map32() -> Vec<u8> {
    f32s((0..32 * 32).map(|i| ((i % 32) as f32 * 0.3).sin() * 4.0 + ((i / 32) as f32 * 0.2).cos() * 3.0))
}

/// A directory with a valid bundle baked from `pipeline`; the bake must succeed.
fn baked(name: &str, pipeline: &str, files: &[(&str, Vec<u8>)]) -> Dir {
    let dir = Dir::new(name);
    for (rel, bytes) in files {
        dir.write(rel, bytes);
    }
    dir.write("pipeline.ron", pipeline);
    dir.run(&["bake"]);
    dir
}

/// Asserts that running `args` exits with `code` (within a minute), that stderr names every
/// needle, and that the files under `kept` are byte-identical afterwards.
fn refused(dir: &Dir, args: &[&str], code: i32, needles: &[&str], kept: &[&str]) -> String {
    let before: Vec<_> = kept.iter().map(|k| snapshot(&dir.path(k))).collect();
    let out = dir.run_guarded(args, 60);
    let err = stderr(&out);
    if out.status.code() != Some(code) || needles.iter().any(|n| !err.contains(n)) {
        panic!("{}", dir.explain(args, &out, &format!("exit code {code} and stderr naming {needles:?}")));
    }
    for (k, b) in kept.iter().zip(before) {
        assert_eq!(snapshot(&dir.path(k)), b, "{k} changed after `hikage {}`", args.join(" "));
    }
    err
}

/// `bake` and `validate PIPELINE` both refuse the pipeline now in `dir`, by the same name.
fn bake_and_check_refuse(dir: &Dir, code: i32, needles: &[&str]) {
    refused(dir, &["bake"], code, needles, &["bundle"]);
    refused(dir, &["validate", "pipeline.ron"], code, needles, &["bundle"]);
}

const SHARDED: &str = r#"(output: "bundle", jobs: [
    Heightfield(id: "a", input: "map.r32"),
    Heightfield(id: "b", input: "map.r32", height_scale: 2),
    Heightfield(id: "c", input: "map.r32", height_scale: 3),
])"#;

/// Two shard parts of [`SHARDED`] and their merge `out`, in one directory.
fn parts(name: &str) -> Dir {
    let dir = Dir::new(name);
    dir.write("map.r32", map32());
    dir.write("pipeline.ron", SHARDED);
    for k in 0..2 {
        dir.run(&["bake", "--shard", &format!("{k}/2")]);
        std::fs::rename(dir.path("bundle"), dir.path(&format!("part{k}"))).unwrap();
    }
    dir.run(&["merge", "out", "part0", "part1"]);
    dir
}

#[test]
fn tampered_shard_records_are_refused_by_name() {
    let dir = parts("hostile_shard_records");
    let good = String::from_utf8(dir.read("part1/shard.ron")).unwrap();
    let hash = good.split('"').nth(1).unwrap().to_string();
    let record = |index: &str, count: &str| format!("(pipeline: \"{hash}\", shard: (index: {index}, count: {count}))");
    let cases: Vec<(String, Vec<&str>)> = vec![
        (record("2", "2"), vec!["index must be below the count"]),
        (record("0", "0"), vec!["1 to 65536 shards, found 0"]),
        (record("1", "4294967295"), vec!["1 to 65536 shards, found 4294967295"]),
        ("(pipeline: \"../../x\", shard: (index: 1, count: 2))".into(), vec!["pipeline", "64-digit BLAKE3"]),
        (good.replace("shard:", "extra: 1, shard:"), vec!["extra"]),
        ("\u{0}\u{1}not ron".into(), vec!["expected a shard record"]),
    ];
    for (text, needles) in cases {
        dir.write("part1/shard.ron", &text);
        let mut needles = needles;
        needles.push("part1/shard.ron");
        refused(&dir, &["merge", "out", "part0", "part1"], 1, &needles, &["out", "part0"]);
    }
    // A 1 GiB record (sparse: no disk) is refused by its size before it is read.
    let f = std::fs::File::create(dir.path("part1/shard.ron")).unwrap();
    f.set_len(1 << 30).unwrap();
    let (out, text, peak) = dir.run_measured(&["merge", "out", "part0", "part1"]);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(text.contains("shard.ron") && text.contains("above the limit"), "{text}");
    assert!(peak.is_none_or(|kib| kib < 200 * 1024), "merge peaked at {peak:?} KiB");
    // The part's record restored, the merge goes through.
    dir.write("part1/shard.ron", good);
    dir.run(&["merge", "out", "part0", "part1"]);
    dir.run(&["validate", "out"]);
}

#[test]
fn merge_leaves_files_not_its_own_and_an_unreadable_bundle_without_force() {
    let dir = parts("hostile_merge_foreign");
    // Files of the user's that merely look like payloads.
    dir.write("out/x.0123456789abcdef.ktx2", b"mine");
    dir.write("out/notes.0123456789abcdef.bin", b"mine too");
    dir.run(&["merge", "out", "part0", "part1"]);
    dir.run(&["merge", "out", "part0", "part1"]);
    assert_eq!(dir.read("out/x.0123456789abcdef.ktx2"), b"mine");
    assert_eq!(dir.read("out/notes.0123456789abcdef.bin"), b"mine too");
    // An unreadable manifest is replaced only with --force, as `bake` does.
    dir.write("out/bundle.ron", b"(not a manifest");
    refused(&dir, &["merge", "out", "part0", "part1"], 1, &["out/bundle.ron"], &["out"]);
    dir.run(&["merge", "out", "part0", "part1", "--force"]);
    dir.run(&["validate", "out"]);
    assert_eq!(dir.read("out/x.0123456789abcdef.ktx2"), b"mine");
}

#[test]
fn a_bundle_in_the_pipelines_own_directory_keeps_the_users_files() {
    let pipeline = r#"(output: ".", jobs: [Horizon(id: "t", input: "map.r32", directions: 4)])"#;
    let dir = baked("hostile_output_dot", pipeline, &[("map.r32", map32())]);
    dir.write("x.0123456789abcdef.ktx2", b"a user's file");
    dir.write("t.horizon.0123456789abcdef.ktx2", b"another, named like ours");
    // A changed input replaces both payloads: only those a manifest named are removed.
    dir.write("map.r32", f32s((0..32 * 32).map(|i| ((i * 7) % 13) as f32)));
    let out = dir.run(&["bake"]);
    assert!(stdout(&out).contains("baked 1") && stdout(&out).contains("removed 2"), "{}", stdout(&out));
    assert_eq!(dir.read("x.0123456789abcdef.ktx2"), b"a user's file");
    assert_eq!(dir.read("t.horizon.0123456789abcdef.ktx2"), b"another, named like ours");
    dir.run(&["validate", "."]);
}

#[test]
fn grids_of_depths_no_reader_takes_are_refused_by_name() {
    let pipeline = r#"(output: "bundle", jobs: [Heightfield(id: "good", input: "map.r32")])"#;
    let dir = baked("hostile_tiff_depths", pipeline, &[("map.r32", map32())]);
    for bits in [1u16, 2, 4] {
        // An 8×8 grid of `bits`-bit samples: a 200-byte file.
        let data = vec![0b1010_0101u8; (64 * bits as usize).div_ceil(8)];
        dir.write(&format!("d{bits}.tif"), tiff(8, 8, bits, 1, &data, 8, NoData::None));
        let needle = format!("found {bits}-bit unsigned integer samples");
        let name = format!("d{bits}.tif");
        for job in [
            format!(r#"Heightfield(id: "h", input: "{name}")"#),
            format!(r#"Horizon(id: "h", input: "{name}", directions: 4)"#),
            format!(r#"Horizon(id: "h", input: "{name}", directions: 4, max_distance: 3, tile: 4)"#),
            format!(r#"Relief(id: "h", input: "{name}", theta: 2, phi: 2)"#),
        ] {
            dir.write("pipeline.ron", format!(r#"(output: "bundle", jobs: [{job}])"#));
            bake_and_check_refuse(&dir, 1, &[&name, "header", &needle]);
        }
    }
    // A no-data tag claiming 4 GiB of text is refused from the directory entry, and nothing of
    // the tiff crate's own diagnostics reaches stderr.
    dir.write("claim.tif", tiff(4, 4, 8, 1, &[1; 16], 4, NoData::Claimed(u32::MAX)));
    dir.write("pipeline.ron", r#"(output: "bundle", jobs: [Heightfield(id: "h", input: "claim.tif")])"#);
    let err = refused(&dir, &["bake"], 1, &["claim.tif", "GDAL_NODATA", "4294967295"], &["bundle"]);
    assert!(!err.contains("LimitsExceeded") && !err.contains("[crates/"), "{err}");
}

#[test]
fn signed_bytes_and_nan_voids_read_as_documented() {
    let i8s: Vec<u8> = (0..16).map(|i: i16| (i * 9 - 70) as i8 as u8).collect();
    let mut floats: Vec<f32> = (0..16).map(|i| i as f32 * 0.5 + 10.0).collect();
    floats[5] = f32::NAN;
    floats[9] = f32::NAN;
    let pipeline = r#"(output: "bundle", jobs: [
        Heightfield(id: "i8", input: "i8.tif"),
        Heightfield(id: "nan", input: "nan.tif"),
    ])"#;
    let dir = baked(
        "hostile_tiff_kinds",
        pipeline,
        &[
            ("i8.tif", tiff(4, 4, 8, 2, &i8s, 4, NoData::None)),
            ("nan.tif", tiff(4, 4, 32, 3, &f32s(floats.clone()), 2, NoData::Text("nan"))),
        ],
    );
    let exported = |id: &str| -> Vec<f32> {
        dir.run(&["export", "bundle", id, "--raw", "--out", "x.f32"]);
        dir.read("x.f32").chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
    };
    assert_eq!(exported("i8"), (0..16).map(|i: i16| (i * 9 - 70) as i8 as f32).collect::<Vec<_>>());
    // NaN is GDAL's usual float no-data: the voids take the lowest valid height (10).
    let expected: Vec<f32> = floats.iter().map(|v| if v.is_nan() { 10.0 } else { *v }).collect();
    assert_eq!(exported("nan"), expected);
}

#[test]
fn heights_and_horizons_that_would_not_be_finite_are_refused_or_saturated_before_commit() {
    let mut tall = map32();
    tall[4 * (3 * 32 + 7)..][..4].copy_from_slice(&70_000f32.to_le_bytes());
    let pipeline = r#"(output: "bundle", jobs: [Heightfield(id: "good", input: "map.r32")])"#;
    let dir = baked("hostile_storage", pipeline, &[("map.r32", map32()), ("cm.r32", tall)]);
    // 70000 does not fit a half float: refused at the pixel, by both commands, whatever reads it.
    for job in [
        r#"Heightfield(id: "cm", input: "cm.r32", format: R16Float)"#,
        r#"Horizon(id: "cm", input: "cm.r32", height_format: R16Float, directions: 4)"#,
        r#"Horizon(id: "cm", input: "cm.r32", height_format: R16Float, directions: 4, max_distance: 5, tile: 16)"#,
    ] {
        dir.write("pipeline.ron", format!(r#"(output: "bundle", jobs: [{job}])"#));
        bake_and_check_refuse(&dir, 1, &["cm.r32", "pixel (7, 3)", "70000", "R16Float"]);
    }
    // A scale that takes world heights past f32.
    dir.write("pipeline.ron", r#"(output: "bundle", jobs: [Horizon(id: "x", input: "map.r32", height_scale: 1e38)])"#);
    bake_and_check_refuse(&dir, 1, &["map.r32", "world height", "finite"]);
    // Slopes past f32 (heights of 1e10 over texels of 1e-30) saturate: the bake is committed
    // and the bundle validates.
    dir.write("steep.r32", f32s((0..256).map(|i| if i % 3 == 0 { 1e10 } else { 0.0 })));
    dir.write(
        "pipeline.ron",
        r#"(output: "bundle", jobs: [Horizon(id: "s", input: "steep.r32", texel_size: (1e-30, 1e-30), directions: 4, format: Rg32Float, ao: true)])"#,
    );
    dir.run(&["bake"]);
    dir.run(&["validate", "bundle"]);
}

#[test]
fn tiles_are_checked_at_the_split() {
    let pipeline = r#"(output: "bundle", jobs: [Heightfield(id: "good", input: "map.r32")])"#;
    let big: Vec<u8> = f32s((0..200 * 200).map(|i| (i % 7) as f32));
    let dir = baked("hostile_tiles", pipeline, &[("map.r32", map32()), ("big.r32", big)]);
    // One tile per texel of a 200² map: 118,803 assets, more than a reader accepts.
    dir.write(
        "pipeline.ron",
        r#"(output: "bundle", jobs: [Horizon(id: "t", input: "big.r32", directions: 4, max_distance: 2, tile: 1, ao: true)])"#,
    );
    bake_and_check_refuse(&dir, 1, &["pipeline.ron", "job `t`", "above the 100000", "larger tiles"]);
    // A tile's ids are checked against every other job's.
    dir.write(
        "pipeline.ron",
        r#"(output: "bundle", jobs: [
            Horizon(id: "t", input: "map.r32", directions: 4, max_distance: 4, tile: 16),
            Heightfield(id: "t.height.0_0", input: "map.r32"),
        ])"#,
    );
    bake_and_check_refuse(&dir, 1, &["pipeline.ron", "asset id `t.height.0_0` is also made by job `t`"]);
}

#[test]
fn inputs_that_are_not_regular_files_are_refused_without_reading() {
    let pipeline = r#"(output: "bundle", jobs: [Heightfield(id: "good", input: "map.r32")])"#;
    let dir = baked("hostile_special_files", pipeline, &[("map.r32", map32())]);
    std::os::unix::fs::symlink("/dev/zero", dir.path("zero.png")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.path("zero.hair")).unwrap();
    std::fs::create_dir(dir.path("dir.hgt")).unwrap();
    let fifo = std::process::Command::new("mkfifo").arg(dir.path("pipe.png")).status();
    let mut cases = vec![
        (r#"Heightfield(id: "z", input: "/dev/zero")"#, "/dev/zero", "character device"),
        (r#"Heightfield(id: "z", input: "zero.png")"#, "zero.png", "character device"),
        (r#"Horizon(id: "z", input: "dir.hgt", directions: 4)"#, "dir.hgt", "directory"),
        (r#"Horizon(id: "z", input: "dir.hgt", directions: 4, max_distance: 4, tile: 8)"#, "dir.hgt", "directory"),
        (r#"Strands(id: "z", input: "zero.hair")"#, "zero.hair", "character device"),
        (r#"Curvature(id: "z", input: "/dev/zero")"#, "/dev/zero", "character device"),
    ];
    if fifo.is_ok_and(|s| s.success()) {
        cases.push((r#"Heightfield(id: "z", input: "pipe.png")"#, "pipe.png", "FIFO"));
    }
    for (job, name, what) in cases {
        dir.write("pipeline.ron", format!(r#"(output: "bundle", jobs: [{job}])"#));
        bake_and_check_refuse(&dir, 3, &[name, "expected a regular file", what]);
    }
    // A pipeline or a bundle manifest that is not a file.
    refused(&dir, &["bake", "/dev/zero"], 3, &["/dev/zero", "regular file"], &["bundle"]);
    std::fs::create_dir_all(dir.path("b2")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.path("b2/bundle.ron")).unwrap();
    refused(&dir, &["validate", "b2"], 3, &["b2/bundle.ron", "regular file"], &[]);
}

/// The cache entries of a cache directory: entry directory → the ids its records name.
fn entries(cache: &Path) -> BTreeMap<std::path::PathBuf, Vec<String>> {
    let mut found = BTreeMap::new();
    for shard in std::fs::read_dir(cache).unwrap().flatten() {
        if shard.file_name() == "tmp" || !shard.path().is_dir() {
            continue;
        }
        for e in std::fs::read_dir(shard.path()).unwrap().flatten() {
            let text = std::fs::read_to_string(e.path().join("entry.ron")).unwrap();
            let ids = text.split("id: \"").skip(1).map(|s| s.split('"').next().unwrap().to_string()).collect();
            found.insert(e.path(), ids);
        }
    }
    found
}

const CACHED: &str = r#"(output: "bundle", jobs: [
    Horizon(id: "t", input: "map.r32", directions: 4, ao: true),
    Heightfield(id: "h", input: "map.r32"),
])"#;

#[test]
fn cache_entries_that_are_not_exactly_the_jobs_assets_are_misses() {
    let dir = baked("hostile_cache_entries", CACHED, &[("map.r32", map32())]);
    let plain = dir.bundle_files("bundle");
    std::fs::remove_dir_all(dir.path("bundle")).unwrap();
    dir.run(&["bake", "--cache", "cache"]);
    let (entry, ids) = entries(&dir.path("cache")).into_iter().find(|(_, ids)| ids.len() == 3).unwrap();
    let good = std::fs::read_to_string(entry.join("entry.ron")).unwrap();
    let records: Vec<&str> = good.trim().trim_start_matches('[').trim_end_matches(']').split("\n    (").collect();
    assert_eq!(records.len(), ids.len() + 1, "{good}");
    let first_file = good.split("file: \"").nth(1).unwrap().split('"').next().unwrap().to_string();
    let tampered = [
        // A record missing: the job's asset would silently go missing.
        good.replacen(&format!("\n    ({}", records[1]), "", 1),
        // A record of an asset no job makes, beside the job's own.
        good.replacen("[", &format!("[\n    ({}", records[1].replacen("id: \"t.", "id: \"t.extra.", 1)), 1),
        // A record naming its payload differently.
        good.replacen(&first_file, &first_file.replacen(".ktx2", "x.ktx2", 1), 1),
    ];
    for text in tampered {
        std::fs::write(entry.join("entry.ron"), &text).unwrap();
        std::fs::remove_dir_all(dir.path("bundle")).unwrap();
        let line = stdout(&dir.run(&["bake", "--cache", "cache"]));
        assert_eq!(counts(&line), (1, 1), "the horizon job baked again, the other from the cache: {line}");
        assert_eq!(dir.bundle_files("bundle"), plain, "exactly the pipeline's assets");
        // The entry was replaced by a sound one: the next bake takes everything from the cache.
        std::fs::remove_dir_all(dir.path("bundle")).unwrap();
        assert_eq!(counts(&stdout(&dir.run(&["bake", "--cache", "cache"]))), (0, 2));
    }
}

#[test]
fn the_cache_never_follows_links_out_of_itself() {
    let dir = baked("hostile_cache_links", CACHED, &[("map.r32", map32())]);
    // Outside the cache: directories holding what looks like entries.
    let hash_a = format!("ab{}", "0".repeat(62));
    let hash_b = format!("cd{}", "1".repeat(62));
    dir.write(&format!("outside/{hash_a}/entry.ron"), b"[]");
    dir.write(&format!("outside/{hash_a}/keep.ktx2"), b"keep me");
    dir.write("outside2/entry.ron", b"[]");
    std::fs::create_dir_all(dir.path("cache/cd")).unwrap();
    std::os::unix::fs::symlink(dir.path("outside"), dir.path("cache/ab")).unwrap();
    std::os::unix::fs::symlink(dir.path("outside2"), dir.path(&format!("cache/cd/{hash_b}"))).unwrap();
    let outside = (snapshot(&dir.path("outside")), snapshot(&dir.path("outside2")));
    // A bound of 0 evicts every entry it may.
    dir.run(&["bake", "--force", "--cache", "cache", "--cache-max-gib", "0"]);
    assert_eq!((snapshot(&dir.path("outside")), snapshot(&dir.path("outside2"))), outside);
    assert!(dir.path("cache/ab").is_symlink() && dir.path(&format!("cache/cd/{hash_b}")).is_symlink());
}

#[test]
fn cache_failures_are_warnings_and_never_fail_or_half_finish_a_bake() {
    let dir = baked("hostile_cache_failures", CACHED, &[("map.r32", map32())]);
    // Every place an entry could go is taken by a file: storing fails.
    std::fs::create_dir_all(dir.path("blocked/tmp")).unwrap();
    for b in 0..=255u8 {
        dir.write(&format!("blocked/{b:02x}"), b"not a directory");
    }
    let blocked = snapshot(&dir.path("blocked"));
    std::fs::remove_dir_all(dir.path("bundle")).unwrap();
    let out = dir.run(&["bake", "--cache", "blocked"]);
    assert!(stderr(&out).contains("warning") && stderr(&out).contains("blocked/"), "{}", stderr(&out));
    dir.run(&["validate", "bundle"]);
    assert_eq!(snapshot(&dir.path("blocked")), blocked, "the cache is as it was");
    // A shard part still gets its record, so merge takes it.
    std::fs::remove_dir_all(dir.path("bundle")).unwrap();
    let out = dir.run(&["bake", "--shard", "0/1", "--cache", "blocked"]);
    assert!(stderr(&out).contains("warning"), "{}", stderr(&out));
    assert!(dir.path("bundle/shard.ron").is_file());
    // A cache that cannot even be opened (its tmp/ is a file) is a warning too.
    dir.write("nocache/tmp", b"a file");
    let out = dir.run(&["bake", "--force", "--cache", "nocache"]);
    assert!(stderr(&out).contains("warning") && stderr(&out).contains("nocache/tmp"), "{}", stderr(&out));
    // What a killed baker left in tmp/ goes once it is an hour old.
    dir.run(&["bake", "--cache", "cache"]);
    dir.write("cache/tmp/half.1.2/t.horizon.0123456789abcdef.ktx2", b"half");
    dir.write("cache/tmp/fresh.1.3/x", b"a baker still writing");
    let hour_ago = std::time::SystemTime::now() - std::time::Duration::from_secs(7200);
    std::fs::File::open(dir.path("cache/tmp/half.1.2")).unwrap().set_modified(hour_ago).unwrap();
    dir.run(&["bake", "--force", "--cache", "cache"]);
    assert!(!dir.path("cache/tmp/half.1.2").exists(), "a stale scratch entry stays");
    assert!(dir.path("cache/tmp/fresh.1.3/x").exists(), "a fresh scratch entry went");
    // A size bound past what 64 bits hold is a usage error, not a bound of 0.
    refused(&dir, &["bake", "--cache", "cache", "--cache-max-gib", "17179869184"], 2, &["17179869184"], &["cache"]);
    dir.run(&["bake", "--cache", "cache", "--cache-max-gib", "17179869183"]);
    assert_eq!(entries(&dir.path("cache")).len(), 2);
}

#[test]
fn limits_threads_and_exit_codes_stay_in_range() {
    let pipeline = r#"(output: "bundle", jobs: [Heightfield(id: "good", input: "map.r32")])"#;
    let dir = baked("hostile_limits", pipeline, &[("map.r32", map32())]);
    dir.write(
        "pipeline.ron",
        r#"(output: "bundle", limits: (max_dimension: 4294967295), jobs: [Heightfield(id: "good", input: "map.r32")])"#,
    );
    bake_and_check_refuse(&dir, 1, &["pipeline.ron", "max_dimension must be 1 to 65536", "4294967295"]);
    // A thread count far past the machine's is bounded by it; the output is the same.
    dir.write("pipeline.ron", r#"(output: "bundle", jobs: [Horizon(id: "t", input: "map.r32", directions: 8)])"#);
    dir.run_guarded(&["bake", "--jobs", "65535"], 60);
    let many = dir.bundle_files("bundle");
    dir.run(&["bake", "--force", "--jobs", "1"]);
    assert_eq!(dir.bundle_files("bundle"), many);
    // Control characters in an id are escaped, never sent to the terminal.
    dir.write(
        "pipeline.ron",
        "(output: \"bundle\", jobs: [Heightfield(id: \"a\u{1b}[2J\u{0}b\", input: \"map.r32\")])",
    );
    let err = refused(&dir, &["bake"], 1, &["not valid", "\\u{1b}"], &["bundle"]);
    assert!(!err.contains('\u{1b}') && !err.contains('\0'), "{err:?}");
}

#[test]
fn merge_past_a_file_size_limit_is_an_io_error() {
    let dir = parts("hostile_merge_ulimit");
    std::fs::remove_dir_all(dir.path("out")).unwrap();
    let out = std::process::Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -f 2 && exec '{}' merge out part0 part1", env!("CARGO_BIN_EXE_hikage")))
        .current_dir(&dir.root)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3), "{}", dir.explain(&["merge"], &out, "exit code 3"));
    assert!(stderr(&out).contains("out/"), "{}", stderr(&out));
}

#[test]
fn output_that_goes_away_ends_quietly_and_a_failed_write_is_an_io_error() {
    let pipeline = r#"(output: "bundle", jobs: [Heightfield(id: "good", input: "map.r32")])"#;
    let dir = baked("hostile_stdout", pipeline, &[("map.r32", map32())]);
    // `hikage inspect bundle | head -0`: the reader is gone before the first line.
    let mut child = dir
        .command(&["inspect", "bundle", "--format", "json"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(stderr(&out).is_empty(), "{}", stderr(&out));
    // `> /dev/full`.
    let full = std::fs::File::create("/dev/full");
    if let Ok(full) = full {
        let out = dir.command(&["inspect", "bundle"]).stdout(full).output().unwrap();
        assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
        assert!(stderr(&out).contains("standard output") && !stderr(&out).contains("panicked"), "{}", stderr(&out));
    }
}

#[test]
fn validate_pipeline_checks_grids_a_block_at_a_time() {
    let dir = Dir::new("hostile_grid_memory");
    // A 16384² SRTM tile (512 MiB, sparse: no disk), and a 16384² 8-bit TIFF of 256 strips whose
    // data lies in a sparse hole: each 1 GiB of heights if read whole.
    std::fs::File::create(dir.path("big.hgt")).unwrap().set_len(16384 * 16384 * 2).unwrap();
    let (strips, strip_bytes, data_at) = (256u32, 16384 * 64, 1u32 << 20);
    let offsets: Vec<u32> = (0..strips).map(|k| data_at + k * strip_bytes).collect();
    let mut t = b"II*\0\0\0\0\0".to_vec();
    tiff_ifd(&mut t, (16384, 16384, 8, 1, 64), &offsets, &vec![strip_bytes; strips as usize], NoData::None);
    let f = std::fs::File::create(dir.path("big.tif")).unwrap();
    use std::io::Write;
    (&f).write_all(&t).unwrap();
    f.set_len(data_at as u64 + strips as u64 * strip_bytes as u64).unwrap();
    for input in ["big.hgt", "big.tif"] {
        dir.write(
            "pipeline.ron",
            format!(r#"(output: "b", jobs: [Horizon(id: "t", input: "{input}", directions: 4)])"#),
        );
        let (out, text, peak) = dir.run_measured(&["validate", "pipeline.ron"]);
        assert_eq!(out.status.code(), Some(0), "{text}");
        if let Some(kib) = peak {
            eprintln!("validate {input}: peak {} MB", kib / 1024);
            assert!(kib < 200 * 1024, "validate {input} peaked at {kib} KiB");
        }
    }
}

/// A 16384² 8-bit TIFF stored as one 16384² tile (or one strip) of 256 MiB — a decompression
/// bomb, whatever its compression, for any reader that decodes a chunk whole — is refused from
/// its header, naming the file and the chunk, in little memory.
#[test]
fn tiff_chunks_too_large_to_decode_are_refused_from_the_header() {
    let dir = Dir::new("hostile_tiff_chunk");
    let (side, data_at) = (16384u32, 4096u32);
    // (tag, type, count, value): SHORT 3, LONG 4; entries in ascending tag order.
    let ifd = |layout: &[(u16, u16, u32, u32)]| {
        let mut entries = vec![(256, 4, 1, side), (257, 4, 1, side), (258, 3, 1, 8), (259, 3, 1, 1), (262, 3, 1, 1)];
        entries.extend_from_slice(layout);
        entries.push((339, 3, 1, 1));
        entries.sort_by_key(|e| e.0);
        let mut t = b"II*\0\x08\0\0\0".to_vec();
        t.extend_from_slice(&(entries.len() as u16).to_le_bytes());
        for (tag, ty, count, value) in entries {
            for bytes in [&tag.to_le_bytes()[..], &ty.to_le_bytes(), &count.to_le_bytes(), &value.to_le_bytes()] {
                t.extend_from_slice(bytes);
            }
        }
        t.extend_from_slice(&0u32.to_le_bytes());
        t
    };
    let bytes = side * side;
    let tiled = ifd(&[(322, 4, 1, side), (323, 4, 1, side), (324, 4, 1, data_at), (325, 4, 1, bytes)]);
    let striped = ifd(&[(273, 4, 1, data_at), (277, 3, 1, 1), (278, 4, 1, side), (279, 4, 1, bytes)]);
    for (name, header, chunk) in [("tile.tif", tiled, "tile"), ("strip.tif", striped, "strip")] {
        let f = std::fs::File::create(dir.path(name)).unwrap();
        use std::io::Write;
        (&f).write_all(&header).unwrap();
        f.set_len(data_at as u64 + bytes as u64).unwrap();
        dir.write(
            "pipeline.ron",
            format!(r#"(output: "b", jobs: [Horizon(id: "t", input: "{name}", directions: 4)])"#),
        );
        for args in [&["validate", "pipeline.ron"][..], &["bake", "pipeline.ron"]] {
            let (out, text, peak) = dir.run_measured(args);
            assert_eq!(out.status.code(), Some(1), "{}", dir.explain(args, &out, "refused"));
            assert!(text.contains(name) && text.contains(&format!("one {chunk}'s samples (16384×16384")), "{text}");
            assert!(!text.contains("panicked"), "{text}");
            if let Some(kib) = peak {
                assert!(kib < 200 * 1024, "{} {name} peaked at {kib} KiB", args[0]);
            }
        }
        assert!(!dir.path("b/bundle.ron").exists(), "nothing committed");
    }
}

/// TIFF headers claiming a grid past `max_dimension` — wide, tall or both, in strips or tiles
/// whose tables the claim makes inconsistent, little- or big-endian, classic or BigTIFF — are
/// refused for their size, naming the file and the dimension, by `validate` and by a bake.
#[test]
fn tiff_headers_of_huge_grids_are_refused_for_their_size() {
    let dir = Dir::new("hostile_tiff_dimensions");
    // (tag, type, value): SHORT 3, LONG 4, LONG8 16.
    let header = |little: bool, big: bool, entries: &[(u16, u16, u64)]| {
        let put = |out: &mut Vec<u8>, v: u64, n: usize| {
            let b = v.to_le_bytes();
            let mut b = b[..n].to_vec();
            if !little {
                b.reverse();
            }
            out.extend_from_slice(&b);
        };
        let mut t = if little { b"II".to_vec() } else { b"MM".to_vec() };
        let (count, value) = if big { (8, 8) } else { (2, 4) };
        if big {
            put(&mut t, 43, 2);
            put(&mut t, 8, 2);
            put(&mut t, 0, 2);
            put(&mut t, 16, 8);
        } else {
            put(&mut t, 42, 2);
            put(&mut t, 8, 4);
        }
        put(&mut t, entries.len() as u64, count);
        for &(tag, ty, v) in entries {
            put(&mut t, u64::from(tag), 2);
            put(&mut t, u64::from(ty), 2);
            put(&mut t, 1, value);
            // A value sits at the start of its field.
            let width = match ty {
                3 => 2,
                4 => 4,
                _ => 8,
            };
            put(&mut t, v, width);
            t.resize(t.len() + (value - width), 0);
        }
        put(&mut t, 0, value);
        t
    };
    let shape = |w: u64, h: u64, tiled: bool, long: u16| {
        let mut e =
            vec![(256, long, w), (257, long, h), (258, 3, 8), (259, 3, 1), (262, 3, 1), (277, 3, 1), (339, 3, 1)];
        if tiled {
            e.extend([(322, 4, 256), (323, 4, 256), (324, 4, 64), (325, 4, 1)]);
        } else {
            e.extend([(273, 4, 64), (278, 4, 1), (279, 4, 1)]);
        }
        e.sort_by_key(|x| x.0);
        e
    };
    let cases = [
        ("wide.tif", true, false, shape(4_000_000_000, 1, false, 4), "4000000000×1"),
        ("tall.tif", true, false, shape(1, 4_000_000_000, false, 4), "1×4000000000"),
        ("tiles.tif", true, false, shape(70_000, 70_000, true, 4), "70000×70000"),
        ("short.tif", false, false, shape(40_000, 8, false, 3), "40000×8"),
        ("motorola.tif", false, false, shape(8, 3_000_000_000, true, 4), "8×3000000000"),
        ("big.tif", true, true, shape(1 << 40, 1 << 40, true, 16), "1099511627776×1099511627776"),
    ];
    for (name, little, big, entries, size) in &cases {
        dir.write(name, header(*little, *big, entries));
        dir.write(
            "pipeline.ron",
            format!(r#"(output: "b", jobs: [Horizon(id: "t", input: "{name}", directions: 4)])"#),
        );
        for args in [&["validate", "pipeline.ron"][..], &["bake", "pipeline.ron"]] {
            let err = refused(&dir, args, 1, &[name, &format!("image dimension ({size})"), "above the limit"], &[]);
            assert!(!err.contains("panicked"), "{err}");
        }
        assert!(!dir.path("b/bundle.ron").exists(), "nothing committed");
    }
}

/// A map within `max_dimension` but wider than one texture may be is refused, naming the input,
/// by `validate PIPELINE` and by the bake of each job that would write it whole, before
/// baking; a tiled horizon bake of it is fine.
#[test]
fn maps_wider_than_a_texture_are_refused_naming_the_input() {
    let dir = Dir::new("hostile_wide_map");
    dir.write("wide.r32", vec![0u8; 20000 * 4 * 4]);
    let source = r#"input: "wide.r32", raw_size: (20000, 4)"#;
    for job in [format!("Heightfield(id: \"t\", {source})"), format!("Horizon(id: \"t\", {source}, directions: 4)")] {
        dir.write("pipeline.ron", format!("(output: \"b\", limits: (max_dimension: 30000), jobs: [{job}])"));
        for args in [&["validate", "pipeline.ron"][..], &["bake", "pipeline.ron"]] {
            let out = dir.run_expecting(args, 1);
            let text = stderr(&out);
            assert!(text.contains("wide.r32") && text.contains("20000×4") && text.contains("16384"), "{job}: {text}");
        }
        assert!(!dir.path("b/bundle.ron").exists(), "nothing committed");
    }
    let tiled = format!("Horizon(id: \"t\", {source}, directions: 4, tile: Some(4096), max_distance: Some(8.0))");
    dir.write("pipeline.ron", format!("(output: \"b\", limits: (max_dimension: 30000), jobs: [{tiled}])"));
    dir.run(&["validate", "pipeline.ron"]);
}
