//! A real crate whose `build.rs` bakes with `hikage_bake::build` (`tests/fixtures/build_script`),
//! compiled here with cargo: the bundle goes to `OUT_DIR` and the source tree stays as it was
//! (`cargo package` accepts the crate), an unchanged build does not run the bake, a deleted
//! payload is baked again on the next build, `cargo check` takes the bake from the target's
//! cache, errors name `file:line:col`, and two pipelines cannot share an output.
//!
//! The fixture builds in a target directory of its own under the tests' temporary directory,
//! kept between runs, so only the first run compiles the baker for it. That first compile takes
//! about two minutes on two cores, so these tests are left out of the README's test command and
//! run as their own step of `.ci/run`:
//! `cargo test --release --test integration build_script -- --ignored`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::util::{Dir, repo, snapshot};

/// The fixture crate copied into a fresh directory, its dependency on the baker pointed at
/// this repository, the workspace's lock file beside it (so cargo resolves offline).
fn fixture(name: &str) -> Dir {
    let dir = Dir::new(name);
    let src = repo().join("tests/fixtures/build_script");
    for rel in ["build.rs", "src/main.rs", "assets/pipeline.ron", "assets/hair.obj", "assets/terrain.r16"] {
        dir.write(rel, std::fs::read(src.join(rel)).unwrap());
    }
    let manifest = std::fs::read_to_string(src.join("Cargo.toml.in")).unwrap();
    let bake = repo().join("crates/bake").display().to_string();
    // One package name per test: packages of one name and version share artifacts in a
    // target directory, whatever their paths.
    let package = format!("fixture-{}", name.replace('_', "-"));
    dir.write("Cargo.toml", manifest.replace("@HIKAGE_BAKE@", &bake).replace("hikage-fixture-game", &package));
    dir.write("Cargo.lock", std::fs::read(repo().join("Cargo.lock")).unwrap());
    dir
}

/// Runs `cargo args` in the fixture, with the fixture's own target directory.
fn cargo(dir: &Dir, args: &[&str]) -> Output {
    let target = target_dir();
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .args(args)
        .arg("--offline")
        .current_dir(&dir.root)
        .env("CARGO_TARGET_DIR", target)
        .env_remove("RUSTC_WORKSPACE_WRAPPER")
        .output()
        .unwrap()
}

fn text(out: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

/// The fixtures' target directory, kept between runs.
fn target_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("build-script-target")
}

/// `cargo args` must succeed; its output.
fn cargo_ok(dir: &Dir, args: &[&str]) -> String {
    let out = cargo(dir, args);
    assert!(out.status.success(), "cargo {}:\n{}", args.join(" "), text(&out));
    text(&out)
}

/// The fixture's files, without cargo's `target/` and lock file.
fn sources(dir: &Dir) -> std::collections::BTreeMap<String, Vec<u8>> {
    let mut files = snapshot(&dir.root);
    files.retain(|name, _| !name.starts_with("target") && name != "Cargo.lock");
    files
}

/// `(baked, skipped, from the cache)` of the build script's summary in a `-vv` log.
fn summary(log: &str) -> (usize, usize, usize) {
    let line = log.lines().find_map(|l| l.split("hikage: ").nth(1)).expect("the -vv summary");
    let count = |key: &str| line.split(key).nth(1).and_then(|s| s.split([',', ':']).next()).unwrap().parse().unwrap();
    (count("baked "), count("skipped "), count("from the cache "))
}

/// Whether a `cargo build -v` ran the fixture's build script.
fn ran_build_script(log: &str) -> bool {
    log.lines()
        .any(|l| l.contains("Running") && l.contains("fixture-build-script-game") && l.contains("build-script-build"))
}

#[test]
#[ignore = "compiles a crate against hikage-bake (minutes): its own step of .ci/run"]
fn a_build_script_bakes_into_out_dir_and_repairs_what_was_deleted() {
    let dir = fixture("build_script_game");
    let before = sources(&dir);
    // The summary cargo shows with -vv (an earlier run of this test may have left the bundle
    // in the kept target directory: then its jobs are skipped).
    let log = cargo_ok(&dir, &["build", "-vv"]);
    let (baked, skipped, cached) = summary(&log);
    assert_eq!(baked + skipped + cached, 2, "{log}");
    // The game finds its bundle in OUT_DIR; the source tree is as it was.
    let run = cargo_ok(&dir, &["run", "-q"]);
    let mut lines = run.lines();
    let bundle = PathBuf::from(lines.next().unwrap());
    assert!(bundle.starts_with(target_dir()), "{run}");
    assert!(bundle.components().any(|c| c.as_os_str() == "out"), "the bundle lies in OUT_DIR: {run}");
    assert_eq!(lines.next().unwrap(), "hair.strips terrain.ao terrain.height terrain.horizon");
    assert_eq!(sources(&dir), before, "the build wrote into the source tree");
    let package = cargo(&dir, &["package", "--no-verify", "--allow-dirty", "--list"]);
    assert!(package.status.success(), "{}", text(&package));
    assert!(!text(&package).contains("bundle"), "the package holds no bundle: {}", text(&package));
    assert_eq!(sources(&dir), before);

    // Unchanged: the bake does not run again, not even once after a bake that wrote.
    let log = cargo_ok(&dir, &["build", "-v"]);
    assert!(!ran_build_script(&log), "an unchanged build reran the bake:\n{log}");

    // A deleted payload is baked again on the next build.
    let payload = std::fs::read_dir(&bundle)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.file_name().unwrap().to_string_lossy().starts_with("terrain.horizon."))
        .unwrap();
    std::fs::remove_file(&payload).unwrap();
    let log = cargo_ok(&dir, &["build", "-vv"]);
    let (baked, skipped, cached) = summary(&log);
    assert!(ran_build_script(&log) && (baked + cached, skipped) == (1, 1), "{log}");
    assert!(payload.exists(), "the deleted payload was not baked again");
    hikage_bundle::validate(&bundle).map(|r| assert!(r.is_valid(), "{:?}", r.problems)).unwrap();
    // A deleted bundle too.
    std::fs::remove_dir_all(&bundle).unwrap();
    cargo_ok(&dir, &["build"]);
    assert!(bundle.join("bundle.ron").is_file());
    assert!(!ran_build_script(&cargo_ok(&dir, &["build", "-v"])), "a rebuilt bundle reran the bake");

    assert_eq!(sources(&dir), before);

    // Another bake of the same pipeline in the same target (another profile's OUT_DIR, or here
    // another crate's) takes its payloads from the target's cache instead of baking again.
    let other = fixture("build_script_game_again");
    let run = cargo_ok(&other, &["run", "-q"]);
    std::fs::remove_dir_all(run.lines().next().unwrap()).unwrap();
    let log = cargo_ok(&other, &["build", "-vv"]);
    assert!(log.contains("hikage: baked 0, skipped 0, from the cache 2"), "{log}");
}

#[test]
#[ignore = "compiles a crate against hikage-bake (minutes): its own step of .ci/run"]
fn a_build_script_reports_errors_with_their_place() {
    let dir = fixture("build_script_errors");
    let cases = [
        (
            "        Horizon(id: \"terrain\", input: \"terrain.r16\", directions: 0),",
            "assets/pipeline.ron:4:54",
            "directions must be 1 to 256, found 0",
        ),
        (
            "        Horizon(id: \"terrain\", input: \"terrain.r16\", directions: \"eight\"),",
            "assets/pipeline.ron:4:65",
            "Expected integer",
        ),
        (
            "        Horizon(id: \"terrain\", input: \"terrain.r16\", max_distance: -3),",
            "assets/pipeline.ron:4:54",
            "max_distance must be finite and above 0",
        ),
    ];
    for (job, place, message) in cases {
        dir.write("assets/pipeline.ron", format!("(\n    output: \"bundle\",\n    jobs: [\n{job}\n    ],\n)"));
        let out = cargo(&dir, &["build"]);
        let log = text(&out);
        assert!(!out.status.success(), "{log}");
        assert!(log.contains(place) && log.contains(message), "expected `{place}` and `{message}`:\n{log}");
        assert!(!log.contains("Pipeline {") && !log.contains("Setting {"), "a Debug struct, not the message:\n{log}");
    }
}

#[test]
#[ignore = "compiles a crate against hikage-bake (minutes): its own step of .ci/run"]
fn two_pipelines_cannot_share_one_output() {
    let dir = fixture("build_script_shared_output");
    let shared = dir.path("shared");
    dir.write(
        "assets/other.ron",
        "(output: \"bundle\", jobs: [Strands(id: \"fur\", input: \"hair.obj\", shading_width: Some(0.02))])",
    );
    dir.write(
        "build.rs",
        format!(
            "fn main() {{\n    let shared = {shared:?};\n    \
             hikage_bake::build::BuildScript::new(\"assets/pipeline.ron\").into_dir(shared).bake();\n    \
             hikage_bake::build::BuildScript::new(\"assets/other.ron\").into_dir(shared).env_var(\"OTHER\").bake();\n}}\n"
        ),
    );
    let out = cargo(&dir, &["build"]);
    let log = text(&out);
    assert!(!out.status.success(), "{log}");
    assert!(
        log.contains("belongs to the pipeline")
            && log.contains("assets/pipeline.ron")
            && log.contains("assets/other.ron"),
        "the error names both pipelines:\n{log}"
    );
    // The first pipeline's bundle is intact.
    let report = hikage_bundle::validate(Path::new(&shared)).unwrap();
    assert!(report.is_valid() && report.assets == 4, "{report:?}");
}
