//! Running a pipeline: incremental, transactional, observable.
//!
//! For each job in order: hash its inputs and settings; when every asset it makes is in the
//! existing bundle with that input hash and an intact payload, keep them (skipped); otherwise
//! bake. The bundle is replaced only after every job succeeded (see
//! [`hikage_bundle::BundleWriter`]); on any error the previous bundle stays as it was.

use std::path::{Path, PathBuf};

use hikage_bundle::{Asset, BundleWriter, WriteMode};

use crate::cache::Cache;
use crate::error::BakeError;
use crate::jobs::{self, BakedPayload, Baker, Job, JobContext};
use crate::limits::InputLimits;
use crate::pipeline::{LoadedPipeline, Pipeline};
use crate::shard::{Shard, ShardRecord};

/// The cache's size bound when a pipeline names a cache directory: 20 GiB.
pub const DEFAULT_CACHE_BYTES: u64 = 20 << 30;

/// Receives progress while a pipeline runs. Implementations must be cheap: `progress` may be
/// called often and from worker threads.
pub trait Observer: Sync {
    /// A job is about to be hashed and baked or skipped.
    fn job_started(&self, _index: usize, _total: usize, _id: &str, _kind: &str) {}
    /// Units of work done out of `total` for the current job.
    fn progress(&self, _id: &str, _done: u64, _total: u64) {}
    /// A job ended; `skipped` when its assets were reused.
    fn job_finished(&self, _id: &str, _skipped: bool) {}
    /// Another writer holds the bundle's lock (`lock`); the commit waits for it.
    fn waiting_for_lock(&self, _lock: &Path) {}
}

/// An observer that ignores everything.
pub struct Silent;
impl Observer for Silent {}

/// How to run a pipeline.
pub struct RunOptions<'a> {
    /// Bake every job even when its input hash matches, and replace an unreadable bundle.
    pub force: bool,
    /// Worker threads (`None`: one per core). Outputs are identical for any value.
    pub threads: Option<usize>,
    /// Progress receiver.
    pub observer: &'a dyn Observer,
    /// Bake only this shard's jobs into a partial bundle ([`crate::shard`]).
    pub shard: Option<Shard>,
    /// A shared cache of baked payloads ([`crate::cache`]); the pipeline's `cache` when `None`.
    pub cache: Option<Cache>,
}

impl Default for RunOptions<'_> {
    fn default() -> Self {
        RunOptions { force: false, threads: None, observer: &Silent, shard: None, cache: None }
    }
}

/// What a run did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RunReport {
    /// The bundle directory.
    pub bundle: PathBuf,
    /// Jobs baked.
    pub baked: Vec<String>,
    /// Jobs skipped because their inputs had not changed.
    pub skipped: Vec<String>,
    /// Jobs whose assets came from the cache.
    pub cached: Vec<String>,
    /// Stale payload files removed.
    pub removed: Vec<String>,
    /// The pipeline file and every input file (for `cargo:rerun-if-changed`).
    pub watched: Vec<PathBuf>,
    /// True when `bundle.ron` was rewritten.
    pub manifest_written: bool,
}

/// Runs the pipeline file at `path`.
pub fn run_pipeline(path: &Path, options: &RunOptions) -> Result<RunReport, BakeError> {
    let loaded = Pipeline::load(path)?;
    with_threads(options.threads, || run_loaded(&loaded, options))
}

/// Runs `f` on a rayon pool of `threads` workers (or the global pool).
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> T {
    match threads {
        Some(n) => match rayon::ThreadPoolBuilder::new().num_threads(n.max(1)).build() {
            Ok(pool) => pool.install(f),
            Err(_) => f(),
        },
        None => f(),
    }
}

/// Runs an already loaded pipeline on the current rayon pool.
pub fn run_loaded(loaded: &LoadedPipeline, options: &RunOptions) -> Result<RunReport, BakeError> {
    let out = loaded.output_dir();
    let mut writer = if options.force {
        BundleWriter::open_ignoring_previous(&out, WriteMode::Replace)?
    } else {
        BundleWriter::open(&out, WriteMode::Replace)?
    };
    let mut report = RunReport { bundle: out.clone(), ..Default::default() };
    report.watched.push(loaded.path.clone());
    // Jobs split into their parts first, so that every shard agrees on the parts it takes.
    let mut units = Vec::new();
    for job in loaded.pipeline.jobs.iter().map(Job::baker) {
        report.watched.extend(job.inputs(&loaded.base_dir));
        units.extend(
            jobs::units(job, &loaded.base_dir, &loaded.pipeline.limits)?
                .into_iter()
                .filter(|unit| options.shard.is_none_or(|s| s.has(unit.baker().id()))),
        );
    }
    let total = units.len();
    let cache = match (&options.cache, &loaded.pipeline.cache) {
        (Some(c), _) => Some(c.clone()),
        (None, Some(dir)) => Some(Cache::open(&loaded.resolve(dir), DEFAULT_CACHE_BYTES)?),
        (None, None) => None,
    };
    let mut baked = Vec::new();
    for (index, unit) in units.iter().enumerate() {
        let run = JobRun { base_dir: &loaded.base_dir, limits: &loaded.pipeline.limits, cache: cache.as_ref() };
        if let Some(made) = run_job(&mut writer, unit.baker(), &run, options, (index, total), &mut report)? {
            baked.push(made);
        }
    }
    let summary = writer.commit_waiting(&|lock| options.observer.waiting_for_lock(lock))?;
    if let Some(cache) = &cache {
        for (hash, assets) in &baked {
            cache.put(hash, assets, &out)?;
        }
        cache.evict()?;
    }
    report.removed = summary.removed;
    report.manifest_written = summary.manifest_written;
    // A partial bundle says which pipeline and split it is; a whole one says nothing.
    match options.shard {
        Some(shard) => ShardRecord::new(&loaded.path, shard)?.write(&out)?,
        None => ShardRecord::clear(&out)?,
    }
    Ok(report)
}

/// Where a job runs: its inputs' directory, the limits, the cache.
struct JobRun<'a> {
    base_dir: &'a Path,
    limits: &'a InputLimits,
    cache: Option<&'a Cache>,
}

/// Bakes one job into `writer`, or keeps its assets when its input hash is unchanged, or takes
/// them from the cache. Returns the input hash and assets of a job it baked, for the cache.
fn run_job(
    writer: &mut BundleWriter,
    job: &dyn Baker,
    run: &JobRun,
    options: &RunOptions,
    (index, total): (usize, usize),
    report: &mut RunReport,
) -> Result<Option<(String, Vec<Asset>)>, BakeError> {
    let id = job.id().to_string();
    options.observer.job_started(index, total, &id, job.kind());
    let hash = crate::hash::job_hash(job, run.base_dir, run.limits)?;
    let reusable: Option<Vec<_>> =
        if options.force { None } else { job.outputs().iter().map(|o| writer.reusable(o, &hash)).collect() };
    if let Some(assets) = reusable {
        for a in assets {
            writer.keep(a);
        }
        report.skipped.push(id.clone());
        options.observer.job_finished(&id, true);
        return Ok(None);
    }
    if let Some(found) = run.cache.filter(|_| !options.force).and_then(|c| c.get(&hash)) {
        for (asset, bytes) in found {
            writer.put_existing(asset, &bytes)?;
        }
        report.cached.push(id.clone());
        options.observer.job_finished(&id, true);
        return Ok(None);
    }
    let progress = |done: u64, all: u64| options.observer.progress(&id, done, all);
    let ctx = JobContext { base_dir: run.base_dir, limits: run.limits, progress: &progress };
    let mut made = Vec::new();
    for asset in job.bake(&ctx)? {
        made.push(match &asset.payload {
            BakedPayload::Texture(t) => writer.put_texture(&asset.id, asset.settings, &hash, t)?,
            BakedPayload::Mesh(m) => writer.put_mesh(&asset.id, asset.settings, &hash, m)?,
        });
    }
    report.baked.push(id.clone());
    options.observer.job_finished(&id, false);
    Ok(Some((hash, made)))
}

/// Runs one job against the bundle in `bundle` (created if missing), adding or replacing the
/// job's assets and keeping every other asset: the one-shot commands (`hikage horizon …`).
/// Relative input paths are resolved against the current directory.
pub fn run_one_job(job: &Job, bundle: &Path, options: &RunOptions) -> Result<RunReport, BakeError> {
    let job = job.baker();
    crate::jobs::check(job).map_err(|message| BakeError::Setting {
        path: PathBuf::from("<command line>"),
        job: job.id().to_string(),
        message,
    })?;
    with_threads(options.threads, || {
        let mut writer = if options.force {
            BundleWriter::open_ignoring_previous(bundle, WriteMode::Update)?
        } else {
            BundleWriter::open(bundle, WriteMode::Update)?
        };
        let mut report = RunReport { bundle: bundle.to_path_buf(), ..Default::default() };
        let limits = InputLimits::default();
        let run = JobRun { base_dir: Path::new(""), limits: &limits, cache: options.cache.as_ref() };
        report.watched.extend(job.inputs(run.base_dir));
        let units = jobs::units(job, run.base_dir, &limits)?;
        for (index, unit) in units.iter().enumerate() {
            run_job(&mut writer, unit.baker(), &run, options, (index, units.len()), &mut report)?;
        }
        let summary = writer.commit_waiting(&|lock| options.observer.waiting_for_lock(lock))?;
        report.removed = summary.removed;
        report.manifest_written = summary.manifest_written;
        Ok(report)
    })
}

/// What `validate PIPELINE` found: the jobs and inputs it checked.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PipelineCheck {
    /// Job ids checked.
    pub jobs: Vec<String>,
    /// Input files opened and decoded.
    pub inputs: Vec<PathBuf>,
}

/// Checks a pipeline without baking: it parses, every setting is valid, and every input opens
/// and decodes.
pub fn check_pipeline(path: &Path, observer: &dyn Observer) -> Result<PipelineCheck, BakeError> {
    let loaded = Pipeline::load(path)?;
    let mut check = PipelineCheck::default();
    let total = loaded.pipeline.jobs.len();
    for (index, job) in loaded.pipeline.jobs.iter().enumerate() {
        let job = job.baker();
        observer.job_started(index, total, job.id(), job.kind());
        let progress = |_: u64, _: u64| {};
        let ctx = JobContext { base_dir: &loaded.base_dir, limits: &loaded.pipeline.limits, progress: &progress };
        job.check_inputs(&ctx)?;
        check.jobs.push(job.id().to_string());
        check.inputs.extend(job.inputs(&loaded.base_dir));
        observer.job_finished(job.id(), false);
    }
    Ok(check)
}

/// The one call a `build.rs` needs: runs the pipeline and prints `cargo:rerun-if-changed=` for
/// the pipeline file and every input, so Cargo re-runs the build script when one changes.
pub fn run_for_build_script(path: &Path) -> Result<RunReport, BakeError> {
    let report = run_pipeline(path, &RunOptions::default())?;
    for p in &report.watched {
        println!("cargo:rerun-if-changed={}", p.display());
    }
    Ok(report)
}
