//! Bundles under concurrent writers and live readers: no lost assets, no torn reads, hot
//! reload; and writes that fail part way leave the previous bundle as it was.

use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use hikage_runtime::CpuBundle;

use crate::util::{Dir, snapshot, stderr, stdout};

/// A small PNG of 48² whose heights depend on `seed`.
fn png(seed: u32) -> Vec<u8> {
    let n = 48u32;
    let px: Vec<u16> = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32, (i / n) as f32);
            let v = ((x * 0.37 + seed as f32).sin() * (y * 0.23 + 2.0 * seed as f32).cos() * 0.5 + 0.5) * 65535.0;
            v as u16
        })
        .collect();
    let mut bytes = Vec::new();
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(n, n, px)
        .unwrap()
        .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .unwrap();
    bytes
}

fn spawn(dir: &Dir, args: &[&str]) -> Child {
    dir.command(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap()
}

/// Eight one-shot bakes with distinct ids into one bundle at once, twenty times: every asset
/// of every bake is in the bundle, and it validates (before locking, five of six were lost).
#[test]
fn concurrent_one_shots_lose_nothing() {
    let dir = Dir::new("concurrent_one_shots");
    for i in 0..8 {
        dir.write(&format!("h{i}.png"), png(i));
    }
    for round in 0..20 {
        let bundle = format!("b{round}");
        let children: Vec<Child> = (0..8)
            .map(|i| spawn(&dir, &["horizon", &format!("h{i}.png"), "--out", &bundle, "--directions", "8"]))
            .collect();
        for c in children {
            let out = c.wait_with_output().unwrap();
            assert!(out.status.success(), "round {round}: {}", String::from_utf8_lossy(&out.stderr));
        }
        dir.run(&["validate", &bundle]);
        let cpu = CpuBundle::read(&dir.path(&bundle)).unwrap();
        let mut ids: Vec<&str> = cpu.assets.iter().map(|a| a.asset.id.as_str()).collect();
        ids.sort();
        let want: Vec<String> = (0..8).flat_map(|i| [format!("h{i}.height"), format!("h{i}.horizon")]).collect();
        assert_eq!(ids, want.iter().map(String::as_str).collect::<Vec<_>>(), "round {round}");
    }
}

/// Two different pipelines baking into one bundle at once: the first to commit owns it, and
/// the other is refused by name (never a silent overwrite); the bundle is always exactly the
/// owner's, and valid.
#[test]
fn concurrent_pipelines_leave_exactly_the_owners() {
    let dir = Dir::new("concurrent_pipelines");
    dir.write("a/x.png", png(1));
    dir.write("b/y.png", png(2));
    let pipeline = |job: &str| format!("(output: \"../common\", jobs: [{job}])");
    dir.write("a/pipeline.ron", pipeline("Horizon(id: \"x\", input: \"x.png\", directions: 16)"));
    dir.write(
        "b/pipeline.ron",
        pipeline("Horizon(id: \"y\", input: \"y.png\", directions: 8), Heightfield(id: \"z\", input: \"y.png\")"),
    );
    // Each pipeline alone, for reference.
    let reference = |p: &str| {
        let r = Dir::new(&format!("concurrent_pipelines_reference_{}", &p[..1]));
        r.write("a/x.png", png(1));
        r.write("b/y.png", png(2));
        r.write(p, dir.read(p));
        r.run(&["bake", p]);
        std::fs::read(r.path("common/bundle.ron")).unwrap()
    };
    let (ra, rb) = (reference("a/pipeline.ron"), reference("b/pipeline.ron"));
    let mut owner = None;
    for round in 0..10 {
        let children = [spawn(&dir, &["bake", "a/pipeline.ron"]), spawn(&dir, &["bake", "b/pipeline.ron"])];
        let outs: Vec<_> = children.into_iter().map(|c| c.wait_with_output().unwrap()).collect();
        let ok: Vec<usize> = (0..2).filter(|&i| outs[i].status.success()).collect();
        assert_eq!(ok.len(), 1, "round {round}: exactly one pipeline commits");
        let refused = &outs[1 - ok[0]];
        assert_eq!(refused.status.code(), Some(1), "round {round}");
        let err = String::from_utf8_lossy(&refused.stderr);
        assert!(
            err.contains("a/pipeline.ron") && err.contains("b/pipeline.ron") && err.contains("belongs to"),
            "{err}"
        );
        assert_eq!(*owner.get_or_insert(ok[0]), ok[0], "round {round}: the owner keeps its bundle");
        dir.run(&["validate", "common"]);
        let manifest = std::fs::read(dir.path("common/bundle.ron")).unwrap();
        assert_eq!(manifest, if ok[0] == 0 { ra.clone() } else { rb.clone() }, "round {round}");
    }
}

/// A reader loop (500 whole reads, every payload's hash checked) beside a loop of forced
/// rebakes whose inputs change each time: no read fails, and each sees one whole bundle.
#[test]
fn readers_never_see_a_torn_bundle() {
    let dir = Dir::new("readers_and_writers");
    let variants: Vec<Vec<u8>> = (0..3).map(|k| png(10 + k)).collect();
    dir.write("in.png", &variants[0]);
    dir.write(
        "pipeline.ron",
        "(output: \"bundle\", jobs: [Horizon(id: \"t\", input: \"in.png\", directions: 8, ao: true), \
         Heightfield(id: \"h\", input: \"in.png\", height_scale: 2)])",
    );
    dir.run(&["bake"]);
    let stop = AtomicBool::new(false);
    let bakes = std::thread::scope(|scope| {
        let writer = scope.spawn(|| {
            let mut n = 0;
            while !stop.load(Ordering::Relaxed) {
                n += 1;
                dir.write("in.png", &variants[n % variants.len()]);
                let out = dir.command(&["bake", "--force"]).output().unwrap();
                assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            }
            n
        });
        let mut distinct = std::collections::BTreeSet::new();
        for i in 0..500 {
            let cpu = CpuBundle::read(&dir.path("bundle")).unwrap_or_else(|e| panic!("read {i}: {e}"));
            assert_eq!(cpu.assets.len(), 4, "read {i}");
            // Every asset from the same manifest: the horizon names the heightfield read with it.
            let height = cpu.asset("t.height").unwrap();
            assert_eq!(cpu.bundle.manifest().asset("t.height"), Some(&height.asset));
            distinct.insert(height.asset.blake3.clone());
        }
        stop.store(true, Ordering::Relaxed);
        let bakes = writer.join().unwrap();
        assert!(distinct.len() >= 2, "the reads should have seen several bakes");
        bakes
    });
    eprintln!("500 reads beside {bakes} rebakes, none failed");
    assert!(bakes >= 5);
}

/// Hot reload: after a rebake that changes one input, the changed assets are exactly that
/// job's, and the held bundle is the new one.
#[test]
fn hot_reload_names_exactly_the_changed_job() {
    let dir = Dir::new("hot_reload");
    dir.write("a.png", png(20));
    dir.write("b.png", png(21));
    dir.write(
        "pipeline.ron",
        "(output: \"bundle\", jobs: [Horizon(id: \"a\", input: \"a.png\", directions: 8, ao: true), \
         Horizon(id: \"b\", input: \"b.png\", directions: 8)])",
    );
    dir.run(&["bake"]);
    let mut all = CpuBundle::read(&dir.path("bundle")).unwrap();
    let mut only_b = CpuBundle::read_prefix(&dir.path("bundle"), "b.").unwrap();
    assert!(all.reload().unwrap().is_empty(), "nothing changed yet");
    dir.write("a.png", png(22));
    let out = dir.run(&["bake"]);
    assert!(stdout(&out).contains("baked 1 ("), "{}", stdout(&out));
    let changes = all.reload().unwrap();
    assert_eq!(changes.changed, ["a.ao", "a.height", "a.horizon"]);
    assert!(changes.added.is_empty() && changes.removed.is_empty());
    let fresh = CpuBundle::read(&dir.path("bundle")).unwrap();
    assert_eq!(all.assets, fresh.assets, "the reloaded bundle is the new one");
    assert!(only_b.reload().unwrap().is_empty(), "b's assets did not change");
    // A job removed from the pipeline: its assets are removed from a held bundle.
    dir.write(
        "pipeline.ron",
        "(output: \"bundle\", jobs: [Horizon(id: \"a\", input: \"a.png\", directions: 8, ao: true)])",
    );
    dir.run(&["bake"]);
    let changes = all.reload().unwrap();
    assert_eq!(changes.removed, ["b.height", "b.horizon"]);
    assert!(changes.changed.is_empty());
}

/// A writer waiting for another's lock says so on stderr, then commits.
#[test]
fn a_waiting_writer_says_so() {
    let dir = Dir::new("waiting_writer");
    dir.write("a.png", png(30));
    dir.run(&["horizon", "a.png", "--out", "bundle", "--directions", "4"]);
    let lock =
        std::fs::File::options().write(true).open(dir.path(&format!("bundle/{}", hikage_bundle::LOCK_FILE))).unwrap();
    lock.lock().unwrap();
    dir.write("b.png", png(31));
    let child = spawn(&dir, &["horizon", "b.png", "--out", "bundle", "--directions", "4"]);
    std::thread::sleep(Duration::from_millis(1500));
    drop(lock);
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    assert!(
        stderr(&out).contains("waiting for") && stderr(&out).contains(hikage_bundle::LOCK_FILE),
        "{}",
        stderr(&out)
    );
    dir.run(&["validate", "bundle"]);
    assert!(CpuBundle::read(&dir.path("bundle")).unwrap().asset("b.horizon").is_some());
}

/// A bundle, baked, and a change of input that will make the next bake write new payloads.
fn baked_then_changed(name: &str) -> Dir {
    let dir = Dir::new(name);
    dir.write("in.png", png(40));
    dir.write("pipeline.ron", "(output: \"bundle\", jobs: [Horizon(id: \"t\", input: \"in.png\", directions: 32)])");
    dir.run(&["bake"]);
    dir.write("in.png", png(41));
    dir
}

/// After a failed write: exit 3, the error names a file in the bundle, and the bundle is
/// exactly as it was and valid.
fn assert_failed_cleanly(dir: &Dir, out: &std::process::Output, before: &std::collections::BTreeMap<String, Vec<u8>>) {
    assert_eq!(out.status.code(), Some(3), "{}", dir.explain(&["bake"], out, "exit code 3"));
    let err = stderr(out);
    assert!(err.contains("bundle/"), "the error names the file: {err}");
    assert_eq!(&snapshot(&dir.path("bundle")), before, "the bundle changed");
    dir.run(&["validate", "bundle"]);
}

/// A file-size limit (`ulimit -f`) hit half way through writing a payload.
#[test]
fn a_file_size_limit_leaves_the_bundle_as_it_was() {
    let dir = baked_then_changed("write_fails_size_limit");
    let before = snapshot(&dir.path("bundle"));
    // 48² × 32 rg16f is 295 KB: a 64 KB limit stops it part way.
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -f 128 && exec '{}' bake", env!("CARGO_BIN_EXE_hikage")))
        .current_dir(&dir.root)
        .output()
        .unwrap();
    assert!(stderr(&out).to_lowercase().contains("too large"), "{}", stderr(&out));
    assert_failed_cleanly(&dir, &out, &before);
}

/// A read-only bundle directory. Where the tests run as root, whom permissions do not stop, the
/// bake runs as `nobody` from a directory under the system's temporary directory (the
/// repository's own may not be reachable by another user).
#[test]
fn a_read_only_bundle_leaves_the_bundle_as_it_was() {
    use std::os::unix::fs::PermissionsExt;
    let base = std::env::temp_dir().join(format!("hikage-read-only-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    std::fs::create_dir_all(&base).unwrap();
    let dir = Dir { root: base.clone() };
    let hikage = base.join("hikage");
    std::fs::copy(env!("CARGO_BIN_EXE_hikage"), &hikage).unwrap();
    dir.write("in.png", png(40));
    dir.write("pipeline.ron", "(output: \"bundle\", jobs: [Horizon(id: \"t\", input: \"in.png\", directions: 32)])");
    let run = |cmd: &mut Command| cmd.current_dir(&base).output().unwrap();
    assert!(run(Command::new(&hikage).arg("bake")).status.success());
    dir.write("in.png", png(41));
    let before = snapshot(&dir.path("bundle"));
    for p in [&base, &dir.path("bundle")] {
        std::fs::set_permissions(p, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    std::fs::set_permissions(dir.path("bundle"), std::fs::Permissions::from_mode(0o555)).unwrap();
    let root = Command::new("id").arg("-u").output().map(|o| stdout(&o).trim() == "0").unwrap_or(false);
    let out = if root {
        run(Command::new("setpriv").args(["--reuid=65534", "--regid=65534", "--clear-groups"]).arg(&hikage).arg("bake"))
    } else {
        run(Command::new(&hikage).arg("bake"))
    };
    std::fs::set_permissions(dir.path("bundle"), std::fs::Permissions::from_mode(0o755)).unwrap();
    assert!(stderr(&out).contains("ermission denied"), "{}", stderr(&out));
    assert_failed_cleanly(&dir, &out, &before);
    std::fs::remove_dir_all(&base).unwrap();
}

/// A payload's name already taken by a directory.
#[test]
fn a_directory_in_a_payloads_place_leaves_the_bundle_as_it_was() {
    let dir = baked_then_changed("write_fails_directory");
    // The payload names the new inputs give, from a bake elsewhere.
    let scratch = Dir::new("write_fails_directory_names");
    scratch.write("in.png", dir.read("in.png"));
    scratch.write("pipeline.ron", dir.read("pipeline.ron"));
    scratch.run(&["bake"]);
    let horizon =
        hikage_bundle::Bundle::open(&scratch.path("bundle")).unwrap().asset("t.horizon").unwrap().file.clone();
    std::fs::create_dir(dir.path(&format!("bundle/{horizon}"))).unwrap();
    let before = snapshot(&dir.path("bundle"));
    let out = dir.command(&["bake"]).output().unwrap();
    assert!(stderr(&out).contains(&horizon), "{}", stderr(&out));
    assert_failed_cleanly(&dir, &out, &before);
}
