//! A small harness in the manner of ripgrep's `tests/util.rs`: a fresh directory per test, a
//! command for the built binary, and assertion failures that print the command, the working
//! directory and its files, the exit status, stdout and stderr.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root (where `data/` and `pipeline.ron` live).
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A fresh working directory for one test.
pub struct Dir {
    pub root: PathBuf,
}

impl Dir {
    /// Creates (or empties) `target/tmp/hikage-tests/<name>`.
    pub fn new(name: &str) -> Dir {
        let root = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("hikage-tests").join(name);
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).unwrap();
        Dir { root }
    }

    /// A directory holding the default `pipeline.ron` and a copy of `data/`.
    pub fn with_default_pipeline(name: &str) -> Dir {
        Dir::with_pipeline(name, &std::fs::read_to_string(repo().join("pipeline.ron")).unwrap())
    }

    /// A directory holding the default pipeline, `data/` and the bundle of
    /// [`default_bake`] — a bundle as the previous bake left it, without its owner record (the
    /// first bake here takes it over) — so a test of what follows a bake does not bake again.
    pub fn with_default_bundle(name: &str) -> Dir {
        let dir = Dir::with_default_pipeline(name);
        let baked = Dir { root: default_bake().0.clone() };
        for (file, bytes) in baked.bundle_files("bundle") {
            dir.write(&format!("bundle/{file}"), bytes);
        }
        // The readers' lock a commit leaves (without it the next commit keeps what it retires).
        dir.write("bundle/.hikage-readers.lock", "");
        dir
    }

    /// A directory holding `pipeline` as `pipeline.ron` and a copy of `data/`.
    pub fn with_pipeline(name: &str, pipeline: &str) -> Dir {
        let dir = Dir::new(name);
        dir.copy_data();
        dir.write("pipeline.ron", pipeline);
        dir
    }

    /// The files of the bundle at `rel`: the manifest, payloads and any shard record, without
    /// the lock and staging files writers share.
    pub fn bundle_files(&self, rel: &str) -> BTreeMap<String, Vec<u8>> {
        let mut files = snapshot(&self.path(rel));
        files.retain(|name, _| !name.starts_with(".hikage"));
        files
    }

    /// Copies every file of the repository's `data/` into `data/` here.
    pub fn copy_data(&self) {
        std::fs::create_dir_all(self.root.join("data")).unwrap();
        for e in std::fs::read_dir(repo().join("data")).unwrap() {
            let e = e.unwrap();
            if e.file_type().unwrap().is_file() {
                std::fs::copy(e.path(), self.root.join("data").join(e.file_name())).unwrap();
            }
        }
    }

    pub fn path(&self, rel: &str) -> PathBuf {
        self.root.join(rel)
    }

    pub fn write(&self, rel: &str, bytes: impl AsRef<[u8]>) {
        let p = self.root.join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }

    pub fn read(&self, rel: &str) -> Vec<u8> {
        std::fs::read(self.root.join(rel)).unwrap()
    }

    /// A command running the built `hikage` in this directory.
    pub fn command(&self, args: &[&str]) -> Command {
        let mut c = Command::new(env!("CARGO_BIN_EXE_hikage"));
        c.args(args).current_dir(&self.root);
        c
    }

    /// Runs `hikage args`, asserting exit code 0.
    pub fn run(&self, args: &[&str]) -> Output {
        self.run_expecting(args, 0)
    }

    /// Runs `hikage args`, asserting the exit code and that nothing panicked.
    pub fn run_expecting(&self, args: &[&str], code: i32) -> Output {
        let out = self.command(args).output().unwrap();
        if out.status.code() != Some(code) || String::from_utf8_lossy(&out.stderr).contains("panicked") {
            panic!("{}", self.explain(args, &out, &format!("expected exit code {code} and no panic")));
        }
        out
    }

    /// Runs `hikage args` and waits at most `seconds` for it: a run still going then is killed
    /// and the test fails with "hung" (a guard against reads that never end, not a timing).
    pub fn run_guarded(&self, args: &[&str], seconds: u64) -> Output {
        use std::process::Stdio;
        let mut child = self.command(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(seconds);
        while child.try_wait().unwrap().is_none() {
            if std::time::Instant::now() > deadline {
                let _ = child.kill();
                let out = child.wait_with_output().unwrap();
                panic!("{}", self.explain(args, &out, &format!("hung: still running after {seconds} s")));
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let out = child.wait_with_output().unwrap();
        if String::from_utf8_lossy(&out.stderr).contains("panicked") {
            panic!("{}", self.explain(args, &out, "no panic"));
        }
        out
    }

    /// Runs `hikage args` under `/usr/bin/time` (installed by `.ci/run`): the output, with
    /// stdout and stderr joined, and the peak resident memory in KiB when it could be measured.
    pub fn run_measured(&self, args: &[&str]) -> (Output, String, Option<u64>) {
        let time = Path::new("/usr/bin/time");
        if !time.exists() {
            eprintln!("/usr/bin/time not installed: peak memory not measured");
            let out = self.command(args).output().unwrap();
            let text = format!("{}{}", stdout(&out), stderr(&out));
            return (out, text, None);
        }
        let out = Command::new(time)
            .args(["-f", "PEAK_KIB %M"])
            .arg(env!("CARGO_BIN_EXE_hikage"))
            .args(args)
            .current_dir(&self.root)
            .output()
            .unwrap();
        let err = stderr(&out);
        let peak = err.lines().find_map(|l| l.strip_prefix("PEAK_KIB ")).and_then(|v| v.trim().parse::<u64>().ok());
        let text = format!("{}{err}", stdout(&out));
        (out, text, peak)
    }

    /// A report of a command's run for assertion messages.
    pub fn explain(&self, args: &[&str], out: &Output, expectation: &str) -> String {
        format!(
            "\n\n==== {expectation} ====\ncommand: hikage {}\ncwd: {}\nfiles:\n{}\nstatus: {:?}\n---- stdout ----\n{}\n---- stderr ----\n{}\n",
            args.join(" "),
            self.root.display(),
            self.listing().join("\n"),
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        )
    }

    /// Every file under the directory with its size.
    pub fn listing(&self) -> Vec<String> {
        snapshot(&self.root).iter().map(|(p, b)| format!("  {p} ({} bytes)", b.len())).collect()
    }
}

/// Every file under `dir` (relative path → bytes).
pub fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(base: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        let Ok(entries) = std::fs::read_dir(dir) else { return };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.insert(p.strip_prefix(base).unwrap().display().to_string(), std::fs::read(&p).unwrap_or_default());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// stdout of a run as text.
pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// stderr of a run as text.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A device, or `None` with the reason printed when there is none and it is not required
/// (`HIKAGE_REQUIRE_GPU=1` turns a missing device into a failure).
pub fn gpu(test: &str) -> Option<hikage_scenes::headless::Headless> {
    gpu_with(test, hikage_runtime::wgpu::Features::FLOAT32_BLENDABLE)
}

/// Whether `HIKAGE_REQUIRE_GPU=1`.
pub fn gpu_required() -> bool {
    hikage_scenes::headless::gpu_required()
}

/// [`gpu`] with the features of `wanted` the adapter has, and no others.
pub fn gpu_with(test: &str, wanted: hikage_runtime::wgpu::Features) -> Option<hikage_scenes::headless::Headless> {
    use hikage_scenes::headless::{Headless, gpu_required};
    match Headless::with_features(wanted) {
        Ok(g) => Some(g),
        Err(e) if !gpu_required() => {
            eprintln!("skipping {test}: {e} (set HIKAGE_REQUIRE_GPU=1 to make this a failure)");
            None
        }
        Err(e) => panic!("{test}: HIKAGE_REQUIRE_GPU=1 but {e}"),
    }
}

/// A bundle baked once per test process from the default pipeline's jobs named in `ids`, shared
/// by the GPU tests (read-only).
pub fn shared_bundle(name: &str, pipeline: &str) -> PathBuf {
    use std::collections::HashMap;
    use std::sync::{Mutex, OnceLock};
    static BAKED: OnceLock<Mutex<HashMap<String, PathBuf>>> = OnceLock::new();
    let mut baked = BAKED.get_or_init(Default::default).lock().unwrap_or_else(|e| e.into_inner());
    baked
        .entry(name.to_string())
        .or_insert_with(|| {
            let dir = Dir::new(name);
            dir.copy_data();
            dir.write("pipeline.ron", pipeline);
            dir.run(&["bake"]);
            dir.path("bundle")
        })
        .clone()
}

/// The default pipeline baked once per test process with `--jobs 2`: its directory (the
/// pipeline, `data/`, `bundle/`; read-only to the tests) and the bake's standard output.
pub fn default_bake() -> &'static (PathBuf, String) {
    use std::sync::OnceLock;
    static BAKED: OnceLock<(PathBuf, String)> = OnceLock::new();
    BAKED.get_or_init(|| {
        let dir = Dir::with_default_pipeline("default_bake");
        let out = dir.run(&["bake", "--jobs", "2"]);
        (dir.root, stdout(&out))
    })
}

/// `(baked, from the cache)` of a bake's report line.
pub fn counts(line: &str) -> (usize, usize) {
    let after = |key: &str| {
        line.split(key)
            .nth(1)
            .map_or(0, |s| s.trim_start().split(|c: char| !c.is_ascii_digit()).next().unwrap().parse().unwrap())
    };
    (after("baked"), after("from the cache"))
}

/// A compute pipeline of `shader`'s `main`, its bind groups 0, 1, … laid out by `layouts`.
pub fn compute_pipeline(
    g: &hikage_scenes::headless::Headless,
    shader: &str,
    layouts: &[&hikage_runtime::wgpu::BindGroupLayout],
) -> hikage_runtime::wgpu::ComputePipeline {
    use hikage_runtime::wgpu;
    let module = g.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("test compute"),
        source: wgpu::ShaderSource::Wgsl(shader.into()),
    });
    let groups: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(|&l| Some(l)).collect();
    let layout = g.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &groups,
        immediate_size: 0,
    });
    g.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: None,
        layout: Some(&layout),
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// A compute shader's read-write storage buffer at `binding`.
pub fn storage_entry(binding: u32) -> hikage_runtime::wgpu::BindGroupLayoutEntry {
    use hikage_runtime::wgpu;
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: false },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}
