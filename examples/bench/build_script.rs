//! Baking from `build.rs` (issue 32): a game crate whose build script bakes the default
//! pipeline over `data/`, built from a clean target directory under several `[profile]`
//! settings. For each: the clean `cargo build` (the whole dependency graph of a build script
//! at that profile) and the bake as the build script ran it, against the release baker on the
//! same pipeline in this process (what `hikage bake` runs).
//!
//! Runs only when named (`bench -- build-script`): each row is a clean build, minutes each.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use hikage_bake::run::{RunOptions, run_pipeline};

use crate::best_of;

/// The `[profile]` settings compared, by name.
const VARIANTS: [(&str, &str); 5] = [
    ("none (cargo's defaults: opt-level 0)", ""),
    ("hikage-bake at opt-level 2", "[profile.dev.package.hikage-bake]\nopt-level = 2\n"),
    ("hikage-bake and hikage-bundle at opt-level 2", BAKER),
    ("the same and zstd-sys (libzstd) at opt-level 2 (recommended)", RECOMMENDED),
    ("every build dependency at opt-level 3", "[profile.dev.build-override]\nopt-level = 3\n"),
];

/// The two crates of the baker at opt-level 2, for `cargo build` (dev).
const BAKER: &str =
    "[profile.dev.package.hikage-bake]\nopt-level = 2\n[profile.dev.package.hikage-bundle]\nopt-level = 2\n";

/// The lines the README and docs/pipeline.md recommend, for `cargo build` (dev): the baker's
/// two crates and libzstd (the sample pipeline compresses its horizons at level 19); the release
/// profile takes the same three with `release` in place of `dev`.
const RECOMMENDED: &str = "[profile.dev.package.hikage-bake]\nopt-level = 2\n[profile.dev.package.hikage-bundle]\nopt-level = 2\n[profile.dev.package.zstd-sys]\nopt-level = 2\n";

pub fn run() {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let scratch = std::env::temp_dir().join(format!("hikage-bench-build-script-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    let game = scratch.join("game");
    super::load::copy_dir(Path::new("data"), &game.join("data"));
    std::fs::copy("pipeline.ron", game.join("pipeline.ron")).expect("run from the repository root");
    std::fs::copy("Cargo.lock", game.join("Cargo.lock")).expect("the workspace lock file");
    std::fs::create_dir_all(game.join("src")).expect("a scratch crate");
    std::fs::write(
        game.join("build.rs"),
        "fn main() {\n    hikage_bake::build::BuildScript::new(\"pipeline.ron\").bake();\n}\n",
    )
    .expect("written");
    std::fs::write(game.join("src/main.rs"), "fn main() {\n    println!(\"{}\", env!(\"HIKAGE_BUNDLE\"));\n}\n")
        .expect("written");
    let bake = std::fs::canonicalize("crates/bake").expect("the baker's crate").display().to_string();

    // The release baker on the same pipeline: the baseline.
    let (release, _) = best_of(3, || {
        let options = RunOptions { force: true, ..RunOptions::default() };
        run_pipeline(&game.join("pipeline.ron"), &options).expect("the default pipeline bakes")
    });
    let _ = std::fs::remove_dir_all(game.join("bundle"));

    println!("Baking from build.rs: the default pipeline (data/), `cargo build` (dev) of a game crate");
    println!("whose build script bakes it, from a clean target directory; {threads} threads, one run each\n");
    println!("| [profile] lines | clean build | build-script bake | ratio to the release baker ({release:.2} s) |");
    println!("|---|---|---|---|");
    for (name, profile) in VARIANTS {
        let manifest = format!(
            "[package]\nname = \"bench-game\"\nversion = \"0.1.0\"\nedition = \"2024\"\npublish = false\n\n\
             [build-dependencies]\nhikage-bake = {{ path = \"{bake}\" }}\n\n{profile}\n[workspace]\n"
        );
        std::fs::write(game.join("Cargo.toml"), manifest).expect("written");
        let target = scratch.join("target");
        let _ = std::fs::remove_dir_all(&target);
        let started = Instant::now();
        let out = Command::new("cargo")
            .args(["build", "--offline", "-vv"])
            .current_dir(&game)
            .env("CARGO_TARGET_DIR", &target)
            .output()
            .expect("cargo runs");
        let build = started.elapsed().as_secs_f64();
        let log = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
        let baked = log
            .lines()
            .find_map(|l| l.split("hikage: ").nth(1))
            .and_then(|s| s.rsplit('(').next())
            .and_then(|s| s.trim_end_matches(" s)").parse::<f64>().ok());
        match baked {
            Some(b) if out.status.success() => {
                println!("| {name} | {build:.0} s | {b:.2} s | {:.1}× |", b / release)
            }
            _ => println!("| {name} | failed | — | — |\n\n{log}"),
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
    println!();
}
