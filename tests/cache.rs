//! The shared cache of baked payloads: shards in separate checkouts sharing one cache, a
//! checkout with an empty bundle taking everything from it, a damaged entry found and rebaked,
//! and the size bound.

use crate::util::{Dir, counts, stdout};

const PIPELINE: &str = r#"(output: "bundle", jobs: [
    Horizon(id: "cylinders", input: "data/cylinders.png", height_scale: 4, directions: 8, edge: Wrap),
    Heightfield(id: "reptile", input: "data/reptile.png", height_scale: 3),
    Curvature(id: "sphere", input: "data/sphere.obj"),
    Relief(id: "bricks", input: "data/relief_bricks.png", theta: 4, phi: 4),
])"#;

fn checkout(name: &str) -> Dir {
    Dir::with_pipeline(name, PIPELINE)
}

fn payloads(dir: &Dir) -> std::collections::BTreeMap<String, Vec<u8>> {
    let mut files = dir.bundle_files("bundle");
    files.remove("shard.ron");
    files
}

#[test]
fn shards_share_a_cache_and_a_fresh_checkout_bakes_nothing() {
    let shared = Dir::new("cache_shared");
    let cache = shared.path("cache").display().to_string();
    let parts: Vec<Dir> = (0..3).map(|k| checkout(&format!("cache_shard_{k}"))).collect();
    for (k, part) in parts.iter().enumerate() {
        part.run(&["bake", "--shard", &format!("{k}/3"), "--cache", &cache]);
    }
    // A second machine: a fresh checkout of shard 1, empty bundle, warm cache.
    let again = checkout("cache_shard_1_again");
    let line = stdout(&again.run(&["bake", "--shard", "1/3", "--cache", &cache]));
    assert_eq!(counts(&line).0, 0, "{line}");
    assert!(counts(&line).1 > 0, "{line}");
    assert_eq!(payloads(&again), payloads(&parts[1]), "the cached assets are the baked ones, byte for byte");
    // The whole pipeline from the cache alone equals a bake without one.
    let whole = checkout("cache_whole");
    let line = stdout(&whole.run(&["bake", "--cache", &cache]));
    assert_eq!(counts(&line), (0, 4), "{line}");
    let plain = checkout("cache_plain");
    plain.run(&["bake"]);
    assert_eq!(payloads(&whole), payloads(&plain));
}

#[test]
fn a_damaged_entry_is_found_and_baked_again() {
    let dir = checkout("cache_damaged");
    dir.run(&["bake", "--cache", "cache"]);
    // Flip a byte of one cached payload.
    let mut payloads_in_cache = Vec::new();
    let mut stack = vec![dir.path("cache")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "ktx2" || x == "bin") {
                payloads_in_cache.push(p);
            }
        }
    }
    payloads_in_cache.sort();
    assert!(payloads_in_cache.len() >= 5);
    let victim = &payloads_in_cache[0];
    let mut bytes = std::fs::read(victim).unwrap();
    bytes[80] ^= 0xff;
    std::fs::write(victim, bytes).unwrap();
    std::fs::remove_dir_all(dir.path("bundle")).unwrap();
    let line = stdout(&dir.run(&["bake", "--cache", "cache"]));
    assert_eq!(counts(&line), (1, 3), "one job rebaked, the others from the cache: {line}");
    dir.run(&["validate", "bundle"]);
    // Rewritten: now all four come from the cache.
    std::fs::remove_dir_all(dir.path("bundle")).unwrap();
    assert_eq!(counts(&stdout(&dir.run(&["bake", "--cache", "cache"]))), (0, 4));
}

#[test]
fn the_cache_keeps_to_its_size_bound() {
    let dir = checkout("cache_bound");
    // A bound of 0 GiB keeps nothing once the bake is over.
    dir.run(&["bake", "--cache", "cache", "--cache-max-gib", "0"]);
    std::fs::remove_dir_all(dir.path("bundle")).unwrap();
    assert_eq!(counts(&stdout(&dir.run(&["bake", "--cache", "cache", "--cache-max-gib", "0"]))), (4, 0));
    // The pipeline can name the cache itself.
    dir.write(
        "pipeline.ron",
        PIPELINE.replace("(output: \"bundle\",", "(output: \"bundle\", cache: Some(\"shared_cache\"),"),
    );
    std::fs::remove_dir_all(dir.path("bundle")).unwrap();
    dir.run(&["bake"]);
    std::fs::remove_dir_all(dir.path("bundle")).unwrap();
    assert_eq!(counts(&stdout(&dir.run(&["bake"]))), (0, 4));
}
