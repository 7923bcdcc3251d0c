//! Running a pipeline: incremental, transactional, observable.
//!
//! For each job in order: hash its inputs and settings; when every asset it makes is in the
//! existing bundle with that input hash and an intact payload, keep them (skipped); otherwise
//! bake. The bundle is replaced only after every job succeeded (see
//! [`hikage_bundle::BundleWriter`]); on any error the previous bundle stays as it was.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use hikage_bundle::{Asset, BundleWriter, WriteMode};

use crate::cache::{self, Cache};
use crate::error::BakeError;
use hikage_bundle::PayloadData;

use crate::jobs::{self, Baker, Job, Unit};
use crate::pipeline::{LoadedPipeline, Pipeline};
use crate::shard::{Shard, ShardRecord};

/// Most assets one bake may make: as many as a reader accepts ([`hikage_bundle::Limits`]'s
/// default `max_assets`). A map's tiles are written as a tile table (100 bytes a payload), so
/// the manifest's size no longer bounds them: a 65536² map in 512² tiles with every level
/// makes 65,535. The split refuses more, before anything is baked.
pub const MAX_ASSETS: usize = 100_000;

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
    /// Something went wrong that does not fail the run (the shared cache could not be read or
    /// written); `message` names the file.
    fn warning(&self, _message: &str) {}
}

/// An observer that ignores everything.
pub struct Silent;
impl Observer for Silent {}

/// How to run a pipeline.
pub struct RunOptions<'a> {
    /// Bake every job even when its input hash matches, and replace an unreadable bundle.
    pub force: bool,
    /// Worker threads (`None`: one per core; at most one per core). Outputs are identical for
    /// any value.
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
    /// Why each job of `baked` was baked, and where it lies when it is a tile.
    pub rebaked: Vec<crate::report::Rebaked>,
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

/// Runs `f` on a rayon pool of `threads` workers (at most one per core: more only adds
/// threads to start), or on the global pool.
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> T {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    match threads {
        Some(n) => match rayon::ThreadPoolBuilder::new().num_threads(n.clamp(1, cores)).build() {
            Ok(pool) => pool.install(f),
            Err(_) => f(),
        },
        None => f(),
    }
}

/// Runs an already loaded pipeline on the current rayon pool: the pipeline owns its bundle,
/// which afterwards holds exactly the assets its jobs make.
pub fn run_loaded(loaded: &LoadedPipeline, options: &RunOptions) -> Result<RunReport, BakeError> {
    let report = run_jobs(loaded, options, WriteMode::Replace)?;
    // A partial bundle says which pipeline and split it is; a whole one says nothing.
    match options.shard {
        Some(shard) => ShardRecord::new(&loaded.path, shard)?.write(&report.bundle)?,
        None => ShardRecord::clear(&report.bundle)?,
    }
    Ok(report)
}

/// Runs one job against the bundle in `bundle` (created if missing), adding or replacing the
/// job's assets and keeping every other asset: the one-shot commands (`hikage horizon …`), a
/// pipeline of one job named `<command line>`. Relative input paths are resolved against the
/// current directory.
pub fn run_one_job(job: &Job, bundle: &Path, options: &RunOptions) -> Result<RunReport, BakeError> {
    let loaded = LoadedPipeline::one_job(job.clone(), bundle);
    loaded.check()?;
    with_threads(options.threads, || run_jobs(&loaded, options, WriteMode::Update))
}

/// The one bake path: split the jobs into the units they are baked as, then for each unit skip
/// it, take it from the cache or bake it, then commit.
fn run_jobs(loaded: &LoadedPipeline, options: &RunOptions, mode: WriteMode) -> Result<RunReport, BakeError> {
    let out = loaded.output_dir();
    let mut writer =
        if options.force { BundleWriter::open_ignoring_previous(&out, mode)? } else { BundleWriter::open(&out, mode)? };
    if mode == WriteMode::Replace {
        // A pipeline owns its bundle: another pipeline's is refused by name at the commit,
        // unless that pipeline file is gone (a moved checkout) or --force takes the bundle over.
        writer.set_owner(&owner_record(&out, &loaded.path), options.force);
        // The budget is the whole bundle's: a shard's part records it (a merge gives it to the
        // merged bundle) and is refused, as a bake is, when it alone already overruns it.
        let budget = &loaded.pipeline.budget;
        if *budget != hikage_bundle::Budget::default() {
            writer.set_budget(Some(budget.clone()));
        }
    }
    let mut report = RunReport { bundle: out.clone(), ..Default::default() };
    report.watched.push(loaded.path.clone());
    report.watched.extend(loaded.pipeline.jobs.iter().flat_map(|j| j.baker().inputs(&loaded.base_dir)));
    let units: Vec<(usize, Unit)> =
        split(loaded)?.into_iter().filter(|(_, unit)| options.shard.is_none_or(|s| s.has(unit.baker().id()))).collect();
    let cache = match (&options.cache, &loaded.pipeline.cache) {
        (Some(c), _) => Some(c.clone()),
        (None, Some(dir)) => match Cache::open(&loaded.resolve(dir), cache::DEFAULT_MAX_GIB) {
            Ok(c) => Some(c),
            Err(e) => {
                options.observer.warning(&format!("the cache is not used: {e}"));
                None
            }
        },
        (None, None) => None,
    };
    let mut baked = Vec::new();
    for (position, (index, unit)) in units.iter().enumerate() {
        let run = UnitRun { job: unit.baker(), index: *index, position: (position, units.len()) };
        if let Some(made) = run_job(&mut writer, &run, loaded, cache.as_ref(), options, &mut report)? {
            baked.push(made);
        }
    }
    let summary = writer.commit_waiting(&|lock| options.observer.waiting_for_lock(lock))?;
    // The cache is an optimisation: once the bundle is committed, nothing it does fails the bake.
    if let Some(cache) = &cache {
        for (hash, assets) in &baked {
            if let Err(e) = cache.put(hash, assets, &out, &summary.shared) {
                options.observer.warning(&format!("could not store in the cache: {e}"));
            }
        }
        if let Err(e) = cache.evict() {
            options.observer.warning(&format!("could not evict from the cache: {e}"));
        }
    }
    report.removed = summary.removed;
    report.manifest_written = summary.manifest_written;
    Ok(report)
}

/// The units the pipeline's jobs are baked as (a tiled job's tiles, every other job whole),
/// with every asset id made once and no more than [`MAX_ASSETS`] in all: what `bake` and
/// `validate PIPELINE` both check before baking anything.
pub(crate) fn split(loaded: &LoadedPipeline) -> Result<Vec<(usize, Unit<'_>)>, BakeError> {
    let mut units = Vec::new();
    let mut made: BTreeMap<String, String> = BTreeMap::new();
    for (index, job) in loaded.pipeline.jobs.iter().map(Job::baker).enumerate() {
        let progress = |_: u64, _: u64| {};
        let ctx = loaded.context(index, &progress);
        for unit in jobs::units(job, &ctx)? {
            for id in unit.baker().outputs() {
                if let Some(other) = made.insert(id.clone(), job.id().to_string()) {
                    let message = format!("asset id `{id}` is also made by job `{other}`");
                    return Err(loaded.setting(index, job.id(), message));
                }
            }
            units.push((index, unit));
        }
        if made.len() > MAX_ASSETS {
            let message = format!(
                "the pipeline would make {} assets with this job, above the {MAX_ASSETS} a bundle's manifest can hold: \
                 use larger tiles",
                made.len()
            );
            return Err(loaded.setting(index, job.id(), message));
        }
    }
    Ok(units)
}

/// A unit of work of a run: its baker, the index of the pipeline job it belongs to, and its
/// position among the run's units (for progress).
struct UnitRun<'a> {
    job: &'a dyn Baker,
    index: usize,
    position: (usize, usize),
}

/// Bakes one unit into `writer`, or keeps its assets when its input hash is unchanged, or takes
/// them from the cache. Returns the input hash and assets of a unit it baked, for the cache.
fn run_job(
    writer: &mut BundleWriter,
    run: &UnitRun,
    loaded: &LoadedPipeline,
    cache: Option<&Cache>,
    options: &RunOptions,
    report: &mut RunReport,
) -> Result<Option<(String, Vec<Asset>)>, BakeError> {
    let job = run.job;
    let id = job.id().to_string();
    let compression = loaded.pipeline.jobs[run.index].compression();
    options.observer.job_started(run.position.0, run.position.1, &id, job.kind());
    // The input limits are part of the settings: a tightened limit re-checks inputs baked before.
    let hash = crate::hash::job_hash(&crate::hash::HashedJob {
        kind: job.kind(),
        algorithm_version: job.algorithm_version(),
        settings: format!(
            "{};max_dimension={};compression={}",
            job.canonical_settings(),
            loaded.pipeline.limits.max_dimension,
            compression.canonical()
        ),
        inputs: job.inputs(&loaded.base_dir),
    })?;
    let outputs = job.outputs();
    let reusable: Option<Vec<_>> =
        if options.force { None } else { outputs.iter().map(|o| writer.reusable(o, &hash)).collect() };
    if let Some(assets) = reusable {
        for a in assets {
            writer.keep(a);
        }
        report.skipped.push(id.clone());
        options.observer.job_finished(&id, true);
        return Ok(None);
    }
    if let Some(found) = cache.filter(|_| !options.force).and_then(|c| c.get(&hash, &outputs)) {
        for (asset, bytes) in found {
            writer.put_existing(asset, &bytes)?;
        }
        report.cached.push(id.clone());
        options.observer.job_finished(&id, true);
        return Ok(None);
    }
    let progress = |done: u64, all: u64| options.observer.progress(&id, done, all);
    let ctx = loaded.context(run.index, &progress);
    let mut made = Vec::new();
    for mut asset in job.bake(&ctx)? {
        let payload = match &asset.payload {
            PayloadData::Texture(t) => hikage_bundle::Payload::Texture(t.desc.clone()),
            PayloadData::Mesh(m) => hikage_bundle::Payload::Mesh(m.desc.clone()),
        };
        let level = compression.level_for(asset.settings.kind(&payload));
        let zstd =
            |data: &[u8]| level.map_or_else(|| data.to_vec(), |level| crate::compression::zstd_frame(data, level));
        made.push(
            match &mut asset.payload {
                PayloadData::Texture(t) => {
                    t.desc.supercompression = compression.supercompression();
                    writer.put_texture_with(&asset.id, asset.settings, &hash, t, &zstd)
                }
                PayloadData::Mesh(m) => {
                    m.desc.supercompression = compression.supercompression();
                    writer.put_mesh_with(&asset.id, asset.settings, &hash, m, &zstd)
                }
            }
            .map_err(|e| loaded.baked_error(run.index, &id, e))?,
        );
    }
    let previous: Vec<_> = outputs
        .iter()
        .filter_map(|o| writer.previous().and_then(|m| m.asset(o)).map(|a| a.input_hash.clone()))
        .collect();
    use crate::report::{Reason, Rebaked};
    let reason = if options.force {
        Reason::Forced
    } else if previous.is_empty() {
        Reason::New
    } else if previous.iter().any(|h| *h != hash) || previous.len() < outputs.len() {
        Reason::Changed
    } else {
        Reason::Damaged
    };
    report.rebaked.push(Rebaked { id: id.clone(), reason, tile: job.tile_area() });
    report.baked.push(id.clone());
    options.observer.job_finished(&id, false);
    Ok(Some((hash, made)))
}

/// What `validate PIPELINE` found: the jobs and inputs it checked.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PipelineCheck {
    /// Job ids checked.
    pub jobs: Vec<String>,
    /// Input files opened and decoded.
    pub inputs: Vec<PathBuf>,
}

/// Checks a pipeline without baking: it parses, every setting is valid, the jobs split into
/// their units with every asset id made once, and every input opens and decodes as a bake
/// would read it (elevation grids a block at a time, so the check needs little memory).
pub fn check_pipeline(path: &Path, observer: &dyn Observer) -> Result<PipelineCheck, BakeError> {
    let loaded = Pipeline::load(path)?;
    split(&loaded)?;
    let mut check = PipelineCheck::default();
    let total = loaded.pipeline.jobs.len();
    for (index, job) in loaded.pipeline.jobs.iter().enumerate() {
        let job = job.baker();
        observer.job_started(index, total, job.id(), job.kind());
        let progress = |_: u64, _: u64| {};
        job.check_inputs(&loaded.context(index, &progress))?;
        check.jobs.push(job.id().to_string());
        check.inputs.extend(job.inputs(&loaded.base_dir));
        observer.job_finished(job.id(), false);
    }
    // The bundle now at the output, against the pipeline's budget (a bake would refuse it).
    let out = loaded.output_dir();
    if loaded.pipeline.budget != hikage_bundle::Budget::default()
        && let Ok(bundle) = hikage_bundle::Bundle::open(&out)
    {
        let overruns = loaded.pipeline.budget.overruns(&bundle.manifest().weights());
        if !overruns.is_empty() {
            return Err(BakeError::Bundle(hikage_bundle::BundleError::OverBudget { path: out, overruns }));
        }
    }
    Ok(check)
}

/// How bundle `bundle` records `pipeline` as its owner: the pipeline's path relative to the
/// bundle directory (`../pipeline.ron`), both canonical, with `/` between parts. The same
/// pipeline baked in two checkouts then writes the same record, and a shipped bundle carries no
/// machine's path; where no relative path exists (another drive) the canonical path is kept.
fn owner_record(bundle: &Path, pipeline: &Path) -> String {
    let canonical = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let pipeline = canonical(pipeline);
    // The bundle may not exist yet: its parent does once the writer has opened it.
    let bundle = match (bundle.parent(), bundle.file_name()) {
        (Some(parent), Some(name)) if !bundle.exists() => canonical(parent).join(name),
        _ => canonical(bundle),
    };
    let (from, to): (Vec<_>, Vec<_>) = (bundle.components().collect(), pipeline.components().collect());
    let common = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
    if common == 0 {
        return pipeline.display().to_string();
    }
    let up = std::iter::repeat_n("..".to_string(), from.len() - common);
    let down = to[common..].iter().map(|c| c.as_os_str().to_string_lossy().into_owned());
    up.chain(down).collect::<Vec<_>>().join("/")
}
