//! The README's two commands share one build: `cargo run --release -- bake` compiles the
//! command, and `cargo test --release --workspace` must find every crate that build compiled
//! with the same features, or it compiles image, exr, tiff and the bake a second time. The
//! features are read from `cargo tree` for both selections, as Cargo resolves them.

use std::collections::BTreeMap;
use std::process::Command;

/// Each package of the build of `args` (`name version`) with its enabled features.
fn features(args: &[&str]) -> BTreeMap<String, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args(["tree", "--prefix", "none", "--format", "{p} [{f}]"])
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo runs");
    assert!(out.status.success(), "cargo tree {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout)
        .expect("cargo tree prints UTF-8")
        .lines()
        .filter_map(|line| {
            let (package, rest) = line.split_once(" [")?;
            let package: Vec<&str> = package.split_whitespace().take(2).collect();
            Some((package.join(" "), rest.split(']').next()?.to_string()))
        })
        .collect()
}

#[test]
fn the_test_build_reuses_every_crate_the_bake_compiled() {
    let bake = features(&["--package", "hikage", "--edges", "no-dev"]);
    let tests = features(&["--workspace"]);
    assert!(bake.contains_key("hikage-bake v0.1.0") && bake.len() > 20, "{bake:?}");
    let differ: Vec<String> = bake
        .iter()
        .filter(|(package, f)| tests.get(*package) != Some(f))
        .map(|(package, f)| format!("{package}: the bake builds [{f}], the tests [{}]", tests[package]))
        .collect();
    assert!(
        differ.is_empty(),
        "the test command would compile these again; ask for the tests' features in the root \
         Cargo.toml's [dependencies]:\n{}",
        differ.join("\n")
    );
}
