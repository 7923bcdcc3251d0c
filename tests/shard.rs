//! A pipeline split over machines: `hikage bake --shard K/N` in separate copies of the inputs,
//! then `hikage merge`, against one machine's `hikage bake`.

use crate::util::{Dir, stderr};

const PIPELINE: &str = r#"(output: "bundle", jobs: [
    Horizon(id: "cylinders", input: "data/cylinders.png", height_scale: 4, directions: 8, edge: Wrap),
    Heightfield(id: "reptile", input: "data/reptile.png", height_scale: 3),
    Curvature(id: "sphere", input: "data/sphere.obj"),
    Curvature(id: "torus", input: "data/torus.glb"),
    Relief(id: "bricks", input: "data/relief_bricks.png", theta: 4, phi: 4),
])"#;

fn copy(name: &str) -> Dir {
    Dir::with_pipeline(name, PIPELINE)
}

#[test]
fn three_shards_merge_into_the_one_machine_bundle() {
    let whole = copy("shard_whole");
    whole.run(&["bake"]);
    let parts: Vec<Dir> = (0..3).map(|k| copy(&format!("shard_part_{k}"))).collect();
    let mut baked = 0;
    for (k, part) in parts.iter().enumerate() {
        let out = part.run(&["bake", "--shard", &format!("{k}/3")]);
        let line = crate::util::stdout(&out);
        baked +=
            line.split("baked ").nth(1).and_then(|s| s.split([',', ' ']).next()).unwrap().parse::<usize>().unwrap();
        assert!(part.path("bundle/shard.ron").exists());
        // Rerunning a shard bakes nothing.
        assert!(crate::util::stdout(&part.run(&["bake", "--shard", &format!("{k}/3")])).contains("baked 0"));
    }
    assert_eq!(baked, 5, "every job in exactly one shard");
    let merged = Dir::new("shard_merged");
    let paths: Vec<String> = parts.iter().map(|p| p.path("bundle").display().to_string()).collect();
    let mut args = vec!["merge", "out"];
    args.extend(paths.iter().map(String::as_str));
    merged.run(&args);
    assert_eq!(merged.bundle_files("out"), whole.bundle_files("bundle"), "merged bundle differs from one machine's");
    merged.run(&["validate", "out"]);

    // Refusals, by name: a missing shard, a repeated one, another pipeline's shard.
    let refuse = |parts: &[&str], needle: &str| {
        let mut args = vec!["merge", "bad"];
        args.extend(parts);
        let out = merged.run_expecting(&args, 1);
        assert!(stderr(&out).contains(needle), "{}", merged.explain(&args, &out, needle));
    };
    refuse(&[&paths[0], &paths[1]], "shard 2 of 3 is missing");
    refuse(&[&paths[0], &paths[1], &paths[1]], "again");
    let other = Dir::new("shard_other");
    other.copy_data();
    other.write("pipeline.ron", PIPELINE.replace("directions: 8", "directions: 16"));
    other.run(&["bake", "--shard", "2/3"]);
    let other_path = other.path("bundle").display().to_string();
    refuse(&[&paths[0], &paths[1], &other_path], "another pipeline");
    // Kubernetes' Indexed Job and Slurm's array give the index through the environment.
    let from_env = copy("shard_env");
    let out = from_env.command(&["bake", "--shard", "env/3"]).env("JOB_COMPLETION_INDEX", "1").output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(from_env.bundle_files("bundle"), parts[1].bundle_files("bundle"));
}

#[test]
fn shard_indices_come_from_the_command_line_or_the_environment() {
    use hikage_bake::shard::{Shard, shard_of};
    assert_eq!(Shard::parse("2/5"), Ok(Shard::new(2, 5).unwrap()));
    for bad in ["5/5", "x/3", "1/0", "3", "1/y"] {
        assert!(Shard::parse(bad).is_err(), "{bad}");
    }
    // The split is a pure function of the id: stable, and spread over the shards.
    let counts = (0..300).fold([0u32; 3], |mut c, i| {
        c[shard_of(&format!("asset{i}"), 3) as usize] += 1;
        c
    });
    assert!(counts.iter().all(|&c| (70..=130).contains(&c)), "{counts:?}");
    assert_eq!(shard_of("terrain", 7), shard_of("terrain", 7));
}

/// A pipeline's budget reaches the merged bundle as it reaches one machine's (byte-identical
/// bundles), and a shard whose own part already overruns it is refused as a bake is.
#[test]
fn shards_and_merge_keep_the_budget() {
    let budgeted = PIPELINE.replace(r#"(output: "bundle","#, r#"(output: "bundle", budget: (disk: Some(50000000)),"#);
    assert_ne!(budgeted, PIPELINE);
    let whole = Dir::with_pipeline("shard_budget_whole", &budgeted);
    whole.run(&["bake"]);
    let parts: Vec<Dir> = (0..3).map(|k| Dir::with_pipeline(&format!("shard_budget_{k}"), &budgeted)).collect();
    for (k, part) in parts.iter().enumerate() {
        part.run(&["bake", "--shard", &format!("{k}/3")]);
    }
    let merged = Dir::new("shard_budget_merged");
    let paths: Vec<String> = parts.iter().map(|p| p.path("bundle").display().to_string()).collect();
    let mut args = vec!["merge", "out"];
    args.extend(paths.iter().map(String::as_str));
    merged.run(&args);
    assert_eq!(merged.bundle_files("out"), whole.bundle_files("bundle"), "merged bundle differs from one machine's");
    let manifest = String::from_utf8(merged.read("out/bundle.ron")).unwrap();
    assert!(manifest.contains("disk: Some(50000000)"), "{manifest}");
    // A budget one shard's part alone overruns: that shard is refused, naming the budget.
    let tight = PIPELINE.replace(r#"(output: "bundle","#, r#"(output: "bundle", budget: (disk: Some(1000)),"#);
    let part = Dir::with_pipeline("shard_budget_tight", &tight);
    let out = part.run_expecting(&["bake", "--shard", "0/3"], 4);
    assert!(stderr(&out).contains("over its budget of 1000"), "{}", stderr(&out));
    assert!(!part.path("bundle/bundle.ron").exists(), "nothing committed");
}
