//! The committed corpus of hand-made bad inputs (`tests/corpus/`, made by `make.py`, listed
//! in `index.txt`): each is read by the reader the CLI uses for it and must give an error of
//! the listed class whose message names the file and contains the listed words. Then the fuzz
//! regression corpus (`fuzz/regressions/<target>/`) is replayed through the fuzz targets' own
//! entry points: none may panic.

use std::path::Path;

fn corpus() -> std::path::PathBuf {
    crate::util::repo().join("tests/corpus")
}

/// (class, message) of reading `path` with `reader`, or `None` if it was accepted.
fn read(reader: &str, path: &Path) -> Option<(&'static str, String)> {
    let bake = |e: hikage_bake::BakeError| (e.class(), e.to_string());
    let bundle = |e: hikage_bundle::BundleError| (e.class(), e.to_string());
    match reader {
        "strands" => hikage_bake::strands::load_groom(path, &Default::default()).err().map(bake),
        "heightfield" => hikage_bake::heightfield::load_samples(path, &Default::default()).err().map(bake),
        "pipeline" => hikage_bake::Pipeline::load(path).err().map(bake),
        "mesh" => hikage_bake::mesh::load(path, Default::default()).err().map(bake),
        "ktx2" => {
            let bytes = std::fs::read(path).unwrap();
            hikage_bundle::ktx2_file::decode(&bytes, path, &Default::default()).err().map(bundle)
        }
        "bundle" => {
            let b = match hikage_bundle::Bundle::open(path) {
                Ok(b) => b,
                Err(e) => return Some(bundle(e)),
            };
            for a in &b.manifest().assets {
                if let Err(e) = b.read_texture(&a.id) {
                    return Some(bundle(e));
                }
            }
            None
        }
        other => panic!("index.txt names an unknown reader {other:?}"),
    }
}

#[test]
fn every_bad_input_gives_its_error_class() {
    let index = std::fs::read_to_string(corpus().join("index.txt")).unwrap();
    let mut failures = Vec::new();
    let mut cases = 0;
    for line in index.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty()) {
        let fields: Vec<&str> = line.split(" | ").map(str::trim).collect();
        let (reader, rel, class, words) = (fields[0], fields[1], fields[2], &fields[3..]);
        let path = corpus().join(rel);
        cases += 1;
        match read(reader, &path) {
            None => failures.push(format!("{rel}: accepted, expected a {class} error")),
            Some((got, message)) => {
                let names_file = message.contains(rel.rsplit('/').next().unwrap());
                let has_words = words.iter().all(|w| message.contains(w));
                if got != class || !names_file || !has_words {
                    failures
                        .push(format!("{rel}: expected {class} naming the file with {words:?}, got {got}: {message}"));
                }
            }
        }
    }
    assert!(cases >= 30, "{cases} cases");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn fuzz_regressions_replay_without_panicking() {
    let root = crate::util::repo().join("fuzz/regressions");
    let mut replayed = 0;
    for (target, run) in hikage_devkit::fuzzing::TARGETS {
        let Ok(entries) = std::fs::read_dir(root.join(target)) else { continue };
        for entry in entries {
            let path = entry.unwrap().path();
            run(&std::fs::read(&path).unwrap());
            replayed += 1;
        }
    }
    // The committed corpus files go through the fuzz entry points too.
    for (dir, target) in [
        ("hair", "hair"),
        ("obj", "obj_polylines"),
        ("png", "heightfield"),
        ("exr", "heightfield"),
        ("ktx2", "ktx2"),
        ("pipeline", "pipeline"),
        ("../../data/grooms", "usd_groom"),
        ("../../data/grooms", "alembic_groom"),
    ] {
        let run = hikage_devkit::fuzzing::TARGETS.iter().find(|t| t.0 == target).unwrap().1;
        for entry in std::fs::read_dir(corpus().join(dir)).unwrap() {
            run(&std::fs::read(entry.unwrap().path()).unwrap());
            replayed += 1;
        }
    }
    eprintln!("replayed {replayed} inputs");
    assert!(replayed > 20);
}
