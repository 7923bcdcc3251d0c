//! Baking from a build script (`build.rs`), the way cargo expects.
//!
//! ```no_run
//! // build.rs (its `fn main`), with hikage-bake as a build-dependency
//! hikage_bake::build::BuildScript::new("assets/pipeline.ron").bake();
//! ```
//!
//! ```ignore
//! // src/main.rs: the bundle's directory, known at compile time
//! let bundle = std::path::Path::new(env!("HIKAGE_BUNDLE"));
//! ```
//!
//! By default the bundle goes into cargo's `OUT_DIR` (named as the pipeline's `output` names
//! it), so the source tree is never written to: `cargo package` and docs.rs accept the crate and
//! `cargo clean` removes the bundle. [`BuildScript::into_pipeline_output`] bakes where the
//! pipeline says instead, into the source tree on purpose (a bundle committed or shipped from
//! the repository).
//!
//! A run tells cargo everything it needs:
//! - `cargo::rerun-if-changed` for the pipeline, every input, and what it wrote (the manifest
//!   and every payload), so an edited input rebakes its job and a deleted payload or bundle is
//!   baked again on the next build;
//! - `cargo::rustc-env=HIKAGE_BUNDLE=<the bundle's absolute path>` (the name is
//!   [`BuildScript::env_var`]'s), for `env!` in the crate;
//! - a one-line summary (`hikage: baked 1, skipped 3, from the cache 0 …`), which cargo shows
//!   with `-vv`;
//! - on failure, `cargo::error=` with the error's message (`assets/pipeline.ron:10:24: …`).
//!
//! It bakes on `NUM_JOBS` threads (cargo's `-j`), and shares a cache of baked payloads in the
//! target directory between profiles, so `cargo check` (rust-analyzer), `cargo build` and
//! `cargo build --release` bake each job once. This module is the one place the library
//! prints, and only what a build script is asked to print.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::cache::{self, Cache};
use crate::error::BakeError;
use crate::pipeline::Pipeline;
use crate::run::{RunOptions, RunReport, run_loaded, with_threads};

/// A bake run from a build script; see the [module docs](self).
#[derive(Clone, Debug)]
pub struct BuildScript {
    pipeline: PathBuf,
    output: Output,
    env_var: String,
}

/// Where a build script's bundle goes.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Output {
    /// `$OUT_DIR/<the last component of the pipeline's output>`.
    OutDir,
    /// Where the pipeline's `output` says.
    Pipeline,
    /// A directory the caller names.
    Dir(PathBuf),
}

/// What a build-script bake did.
#[derive(Clone, Debug)]
pub struct BuildReport {
    /// The bundle directory (absolute when baked into `OUT_DIR`).
    pub bundle: PathBuf,
    /// What the run did, job by job.
    pub run: RunReport,
}

impl BuildScript {
    /// A bake of the pipeline file `pipeline` (relative to the crate's directory, where cargo
    /// runs build scripts) into `OUT_DIR`, announced as `HIKAGE_BUNDLE`.
    pub fn new(pipeline: impl AsRef<Path>) -> BuildScript {
        BuildScript {
            pipeline: pipeline.as_ref().to_path_buf(),
            output: Output::OutDir,
            env_var: "HIKAGE_BUNDLE".into(),
        }
    }

    /// Bakes where the pipeline's `output` says, in the source tree: for a bundle kept in the
    /// repository on purpose. (`cargo package` then refuses the crate unless the bundle is
    /// already up to date.)
    pub fn into_pipeline_output(mut self) -> BuildScript {
        self.output = Output::Pipeline;
        self
    }

    /// Bakes into `dir` (relative to the crate's directory).
    pub fn into_dir(mut self, dir: impl AsRef<Path>) -> BuildScript {
        self.output = Output::Dir(dir.as_ref().to_path_buf());
        self
    }

    /// The environment variable the crate reads the bundle's path from with `env!`
    /// (default `HIKAGE_BUNDLE`; a crate baking two pipelines names each).
    pub fn env_var(mut self, name: &str) -> BuildScript {
        self.env_var = name.to_string();
        self
    }

    /// Runs the bake and prints cargo's instructions; the error, if any, is returned for the
    /// caller to report (see [`bake`](Self::bake) for the usual entry).
    pub fn run(&self) -> Result<BuildReport, BakeError> {
        let started = Instant::now();
        let mut loaded = Pipeline::load(&self.pipeline)?;
        let out_dir = std::env::var_os("OUT_DIR").map(PathBuf::from);
        // When cargo started this run: it compares watched files against this time.
        let invoked = out_dir.as_ref().and_then(|o| invocation_time(o));
        let bundle = match &self.output {
            Output::Pipeline => loaded.output_dir(),
            Output::Dir(dir) => dir.clone(),
            Output::OutDir => {
                let out_dir = out_dir.as_ref().ok_or_else(|| BakeError::Setting {
                    path: self.pipeline.clone(),
                    place: None,
                    job: "build script".into(),
                    message: "OUT_DIR is not set: run this from a build script, or bake into_dir".into(),
                })?;
                let name = loaded.pipeline.output.file_name().map_or_else(|| "bundle".into(), |n| n.to_os_string());
                out_dir.join(name)
            }
        };
        // Bundles in OUT_DIR share a cache in the target directory, so each profile's bake
        // (check, dev, release) takes what another already baked.
        let cache = match (&self.output, &loaded.pipeline.cache, &out_dir) {
            (Output::OutDir, None, Some(out)) => target_dir(out)
                .and_then(|target| Cache::open(&target.join("hikage-cache"), cache::DEFAULT_MAX_GIB).ok()),
            _ => None,
        };
        loaded.pipeline.output = std::path::absolute(&bundle).unwrap_or(bundle);
        let threads = std::env::var("NUM_JOBS").ok().and_then(|n| n.parse::<usize>().ok());
        let options = RunOptions { threads, cache, ..RunOptions::default() };
        let run = with_threads(threads, || run_loaded(&loaded, &options))?;
        let bundle = run.bundle.clone();
        let watched_outputs = written_files(&bundle);
        // Files this run wrote are dated at cargo's start of the run, not after it: the next
        // build then sees them unchanged (and still newer than the crate's last compile, for an
        // `include_bytes!` of them), instead of running the bake once more.
        if let Some(t0) = invoked {
            for path in &watched_outputs {
                let newer = std::fs::metadata(path).and_then(|m| m.modified()).is_ok_and(|m| m > t0);
                if newer && let Ok(f) = std::fs::File::options().write(true).open(path) {
                    let _ = f.set_modified(t0);
                }
            }
        }

        for path in &run.watched {
            println!("cargo::rerun-if-changed={}", path.display());
        }
        // What it wrote: a deleted manifest or payload reruns the script, which repairs it.
        for path in &watched_outputs {
            println!("cargo::rerun-if-changed={}", path.display());
        }
        println!("cargo::rustc-env={}={}", self.env_var, bundle.display());
        println!(
            "hikage: baked {}, skipped {}, from the cache {}: {} ({:.2} s)",
            run.baked.len(),
            run.skipped.len(),
            run.cached.len(),
            bundle.display(),
            started.elapsed().as_secs_f64()
        );
        Ok(BuildReport { bundle, run })
    }

    /// [`run`](Self::run), reporting an error to cargo (`cargo::error=`, which fails the build
    /// with the error's message: file, line and column, and what was expected). Returns the
    /// report, or `None` after an error.
    pub fn bake(&self) -> Option<BuildReport> {
        match self.run() {
            Ok(report) => Some(report),
            Err(e) => {
                // One instruction per line of the message.
                for line in e.to_string().lines() {
                    println!("cargo::error={line}");
                }
                None
            }
        }
    }
}

/// The manifest and payload files of the bundle in `dir`.
fn written_files(dir: &Path) -> Vec<PathBuf> {
    let mut files = vec![dir.join(hikage_bundle::MANIFEST_FILE)];
    if let Ok(b) = hikage_bundle::Bundle::open(dir) {
        files.extend(b.manifest().assets.iter().map(|a| b.payload_path(a)));
    }
    files
}

/// When cargo started the build script whose `OUT_DIR` is `out_dir`: the time of the
/// `invoked.timestamp` it writes beside it just before the run.
fn invocation_time(out_dir: &Path) -> Option<std::time::SystemTime> {
    std::fs::metadata(out_dir.parent()?.join("invoked.timestamp")).ok()?.modified().ok()
}

/// The target directory an `OUT_DIR` lies in: the nearest ancestor holding the
/// `CACHEDIR.TAG` cargo writes there.
fn target_dir(out_dir: &Path) -> Option<&Path> {
    out_dir.ancestors().find(|d| d.join("CACHEDIR.TAG").is_file())
}
