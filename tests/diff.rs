//! `hikage diff`: bakes compared in each method's terms. One raised texel of a terrain is
//! caught and named in its heights, horizons and AO; tolerances from flags or a pipeline let
//! it pass; an added asset is beyond tolerance. (Bakes at two thread counts diff as the same:
//! `bake::thread_count_does_not_change_a_byte`.)

use crate::util::{Dir, stdout};

/// A 64² ramp-and-bumps terrain as raw f32, with texel (20, 30) raised by `bump`.
fn terrain(bump: f32) -> Vec<u8> {
    let mut h: Vec<f32> =
        (0..64 * 64).map(|i| ((i % 64) as f32 * 0.3).sin() * 0.2 + ((i / 64) as f32 * 0.2).cos() * 0.2 + 0.5).collect();
    h[30 * 64 + 20] += bump;
    h.into_iter().flat_map(f32::to_le_bytes).collect()
}

const JOB: &str = r#"Horizon(id: "t", input: "t.r32", texel_size: (10, 10), height_scale: 100, directions: 16,
    edge: Clamp, ao: true)"#;

/// Two bakes of the terrain, the second with texel (20, 30) raised 0.3 (30 world units);
/// `extra` jobs in the second.
fn two_bakes(name: &str, extra: &str) -> Dir {
    let dir = Dir::new(name);
    for (sub, bump, jobs) in [("old", 0.0, JOB.to_string()), ("new", 0.3, format!("{JOB}, {extra}"))] {
        dir.write(&format!("{sub}/t.r32"), terrain(bump));
        dir.write(&format!("{sub}/pipeline.ron"), format!(r#"(output: "bundle", jobs: [{jobs}])"#));
        dir.run(&["bake", &format!("{sub}/pipeline.ron")]);
    }
    dir
}

#[test]
fn one_raised_texel_is_caught_and_named() {
    let dir = two_bakes("diff_texel", "");
    let out = dir.run_expecting(&["diff", "old/bundle", "new/bundle"], 1);
    let text = stdout(&out);
    assert!(text.contains("t.height") && text.contains("texel (20, 30)"), "{text}");
    assert!(text.contains("t.horizon") && text.contains("t.ao") && text.contains("beyond tolerance"), "{text}");

    let out = dir.run_expecting(&["diff", "old/bundle", "new/bundle", "--format", "json"], 1);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["within_tolerance"], false);
    let asset = |id: &str| json["assets"].as_array().unwrap().iter().find(|a| a["id"] == id).unwrap().clone();
    let measure = |id: &str, name: &str| {
        asset(id)["measures"].as_array().unwrap().iter().find(|m| m["name"] == name).unwrap().clone()
    };
    let height = measure("t.height", "height max");
    assert!((height["value"].as_f64().unwrap() - 30.0).abs() < 1e-3, "{height}");
    assert_eq!(height["at"], "texel (20, 30)");
    // A 30 m spike on 10 m texels casts shadows nearby: some sun tests flip, not most.
    let flips = measure("t.horizon", "sun tests flipped")["value"].as_f64().unwrap();
    assert!(flips > 0.0 && flips < 0.05, "{flips}");
    let angle = measure("t.horizon", "horizon angle max")["value"].as_f64().unwrap();
    assert!(angle > 10.0 && angle < 90.0, "{angle}");
    assert_eq!(asset("t.ao")["status"], "changed");
}

#[test]
fn tolerances_from_flags_or_the_pipeline_let_a_change_pass() {
    let dir = two_bakes("diff_tolerance", "");
    // Loose enough for the spike: within tolerance, exit 0, the change still listed.
    let loose =
        ["--height", "31", "--horizon-degrees", "90", "--sun-flips", "0.05", "--distance-texels", "1000", "--ao", "1"];
    let mut args = vec!["diff", "old/bundle", "new/bundle"];
    args.extend(loose);
    let text = stdout(&dir.run_expecting(&args, 0));
    assert!(text.contains("t.height") && text.contains("0 beyond tolerance"), "{text}");
    // One figure held tighter than the change fails again, naming it.
    args[4] = "29";
    let text = stdout(&dir.run_expecting(&args, 1));
    assert!(text.contains("height max") && text.contains("← beyond"), "{text}");
    // The same tolerances from a pipeline.
    dir.write(
        "gate.ron",
        format!(
            r#"(output: "x", tolerances: (height: 31, horizon_degrees: 90, sun_flips: 0.05, distance_texels: 1000,
               ao: 1), jobs: [{JOB}])"#
        ),
    );
    dir.run_expecting(&["diff", "old/bundle", "new/bundle", "--pipeline", "gate.ron"], 0);
    // A bad tolerance is a usage error.
    dir.run_expecting(&["diff", "old/bundle", "new/bundle", "--height", "-1"], 2);
    // In a pipeline, NaN (which would turn the gate off) and a negative tolerance (which would
    // fail everything) are refused at their place, and so is a pipeline that `validate` checks.
    for (name, value, place) in [("nan.ron", "NaN", "nan.ron:2:5"), ("negative.ron", "-0.5", "negative.ron:2:5")] {
        dir.write(name, format!("(output: \"x\", tolerances: (height: 31,\n    sun_flips: {value}), jobs: [{JOB}])"));
        for args in [vec!["diff", "old/bundle", "new/bundle", "--pipeline", name], vec!["validate", name]] {
            let out = dir.run_expecting(&args, 1);
            let err = String::from_utf8_lossy(&out.stderr).into_owned();
            assert!(err.contains(place) && err.contains("sun_flips must be a finite number ≥ 0"), "{err}");
        }
    }
}

#[test]
fn an_added_asset_is_beyond_tolerance_and_the_same_bundle_is_not() {
    let dir = two_bakes("diff_added", r#"Heightfield(id: "h", input: "t.r32", texel_size: (10, 10))"#);
    let text = stdout(&dir.run_expecting(&["diff", "old/bundle", "new/bundle", "--height", "100", "--ao", "1"], 1));
    assert!(text.contains("added") && text.contains(" h "), "{text}");
    let text = stdout(&dir.run_expecting(&["diff", "new/bundle", "new/bundle"], 0));
    assert!(text.contains("0 changed, 0 beyond tolerance"), "{text}");
}

/// `--format json` prints one JSON object in every outcome: a bundle that cannot be opened and a
/// bad tolerance are an `error` with `within_tolerance: false`, as a CI step that keeps the
/// output wants, with the exit code of the failure.
#[test]
fn json_says_why_when_there_is_nothing_to_compare() {
    let dir = two_bakes("diff_json_errors", "");
    for (args, code, words) in [
        (vec!["diff", "old/bundle", "missing", "--format", "json"], 3, "missing"),
        (vec!["diff", "old/bundle", "new/bundle", "--format", "json", "--ao", "NaN"], 2, "finite"),
    ] {
        let out = dir.run_expecting(&args, code);
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {out:?}"));
        assert_eq!(json["within_tolerance"], false);
        let error = json["error"].as_str().unwrap();
        assert!(error.contains(words), "{error}");
    }
}

/// A manifest listing its assets out of id order (readers and `validate` accept one) is compared
/// by id: against the same bundle sorted, nothing changed, nothing added or removed.
#[test]
fn a_manifest_out_of_id_order_is_compared_by_id() {
    let dir = Dir::with_default_bundle("diff_order");
    for (file, bytes) in dir.bundle_files("bundle") {
        dir.write(&format!("reversed/{file}"), bytes);
    }
    // The assets' entries (each `(` … `),` at the list's indentation) in reverse order.
    let text = String::from_utf8(dir.read("bundle/bundle.ron")).unwrap();
    let start = text.find("    assets: [\n").unwrap() + "    assets: [\n".len();
    let end = start + text[start..].find("\n    ],").unwrap() + 1;
    let mut entries: Vec<&str> = text[start..end].split_inclusive("\n        ),\n").collect();
    assert!(entries.len() > 10, "{} entries", entries.len());
    entries.reverse();
    dir.write("reversed/bundle.ron", format!("{}{}{}", &text[..start], entries.concat(), &text[end..]));
    assert_ne!(dir.read("reversed/bundle.ron"), dir.read("bundle/bundle.ron"));
    let out = stdout(&dir.run_expecting(&["diff", "bundle", "reversed"], 0));
    assert!(out.contains("0 changed, 0 beyond tolerance") && !out.contains("removed"), "{out}");
}
