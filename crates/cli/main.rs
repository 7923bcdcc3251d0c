//! `hikage`: bakes pipelines into bundles, validates, inspects, compares and exports them.
//!
//! Thin by design: parse arguments, call `hikage-bake` / `hikage-bundle`, report. Exit codes:
//! 0 success, 1 invalid input or failed validation, 2 usage error, 3 I/O error, 4 over budget.

#[macro_use]
mod output;
mod diff;
mod progress;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Parser, Subcommand, ValueEnum};
use hikage_bake::cache::Cache;
use hikage_bake::export::{ExportFormat, export_gltf, export_texture};
use hikage_bake::jobs::{HorizonJob, ReliefJob, StrandsJob};
use hikage_bake::run::{RunOptions, check_pipeline, run_one_job, run_pipeline};
use hikage_bake::shard::Shard;
use hikage_bake::{BakeError, Job};
use hikage_bundle::{Bundle, BundleError};

const EXIT_CODES: &str = "\
Exit codes:
  0  success
  1  invalid input, invalid settings, or a bundle that failed validation
  2  usage error (unknown command or option, missing argument)
  3  I/O error (a file or directory that cannot be read or written)
  4  over budget: the bundle is valid but bigger than its pipeline's `budget` (a bake then
     commits nothing)";

/// Bakes, validates, inspects and exports hikage bundles.
#[derive(Parser)]
#[command(name = "hikage", version, about, after_help = EXIT_CODES)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Bake a pipeline into its bundle, skipping jobs whose inputs and settings are unchanged.
    #[command(after_help = EXIT_CODES)]
    Bake {
        /// Pipeline file.
        #[arg(default_value = "pipeline.ron")]
        pipeline: PathBuf,
        /// Bake every job even if unchanged; replace an unreadable bundle.
        #[arg(long)]
        force: bool,
        /// Worker threads (default: one per core). Output is identical for any value.
        #[arg(long, short = 'j', value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
        jobs: Option<u16>,
        /// Bake only shard K of an N-way split into a partial bundle (`hikage merge` joins the
        /// parts); `env/N` takes K from JOB_COMPLETION_INDEX or SLURM_ARRAY_TASK_ID.
        #[arg(long, value_name = "K/N", value_parser = Shard::parse)]
        shard: Option<Shard>,
        /// A cache of baked payloads shared between checkouts and machines (overrides the
        /// pipeline's `cache`).
        #[arg(long, value_name = "DIR")]
        cache: Option<PathBuf>,
        /// The cache's size bound, GiB; the least recently used entries go first.
        #[arg(long, value_name = "GIB", default_value_t = hikage_bake::cache::DEFAULT_MAX_GIB,
              value_parser = clap::value_parser!(u64).range(0..=hikage_bake::cache::MAX_GIB))]
        cache_max_gib: u64,
    },
    /// Merge the partial bundles of every shard of one pipeline into OUT: the bundle one
    /// machine would have baked.
    #[command(after_help = EXIT_CODES)]
    Merge {
        /// The bundle directory to write.
        out: PathBuf,
        /// The partial bundles, one per shard.
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Replace an OUT whose manifest cannot be read.
        #[arg(long)]
        force: bool,
    },
    /// Validate a bundle directory, or a pipeline file without baking it.
    #[command(after_help = EXIT_CODES)]
    Validate {
        /// A bundle directory or a pipeline `.ron` file.
        path: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
        format: OutputFormat,
    },
    /// List a bundle's assets.
    #[command(after_help = EXIT_CODES)]
    Inspect {
        /// Bundle directory.
        bundle: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
        format: OutputFormat,
    },
    /// Compare two bundles asset by asset, each change measured in its method's own terms
    /// (horizon angles and sun tests flipped, metres, texels, …); exit 1 when a change is beyond
    /// tolerance, an asset is added or removed, or two cannot be compared.
    #[command(after_help = diff::EXIT_CODES)]
    Diff(diff::DiffArgs),
    /// Write a contact sheet of BUNDLE into OUT: one HTML page with a picture of every asset,
    /// rendered on the CPU; with --old, the assets changed since OLD shown old, new and their
    /// difference.
    #[command(after_help = EXIT_CODES)]
    Sheet {
        /// Bundle directory.
        bundle: PathBuf,
        /// The directory to write `index.html` and the PNGs into (created).
        #[arg(long)]
        out: PathBuf,
        /// The bundle to compare with (e.g. the last release's).
        #[arg(long)]
        old: Option<PathBuf>,
    },
    /// Bake horizon and distance maps of one heightfield into BUNDLE (created, or its assets
    /// `<id>.height`, `<id>.horizon`, `<id>.ao` added or replaced; with --tile, one of each per
    /// tile, `<id>.horizon.<tx>_<ty>`).
    #[command(after_help = EXIT_CODES)]
    Horizon {
        #[command(flatten)]
        job: HorizonJob,
        #[command(flatten)]
        target: OneShot,
    },
    /// Bake relief-mapping depth maps (one per hemisphere direction) and the max-mip pyramid of
    /// one heightfield into BUNDLE (assets `<id>.relief` and `<id>.maxmip` added or replaced).
    #[command(after_help = EXIT_CODES)]
    Relief {
        #[command(flatten)]
        job: ReliefJob,
        #[command(flatten)]
        target: OneShot,
    },
    /// Bake hair strip meshes from a USD groom, a `.hair` file or OBJ polylines into BUNDLE (`<id>.strips`,
    /// and `<id>.ribbons` with --ribbons). Widths are full widths in the input's units.
    #[command(after_help = EXIT_CODES)]
    Strands {
        #[command(flatten)]
        job: StrandsJob,
        #[command(flatten)]
        target: OneShot,
    },
    /// Export a texture asset as OpenEXR (one layer per slice) or raw little-endian f32.
    #[command(after_help = EXIT_CODES)]
    Export {
        /// Bundle directory.
        bundle: PathBuf,
        /// Asset id.
        asset: String,
        /// Output file (textures: OpenEXR, or raw with --raw).
        #[arg(long, required_unless_present = "gltf", conflicts_with = "gltf")]
        out: Option<PathBuf>,
        /// Write a mesh asset as binary glTF 2.0 to this file (custom streams as `_NAME`
        /// attributes).
        #[arg(long, value_name = "OUT")]
        gltf: Option<PathBuf>,
        /// Write raw little-endian f32 in `[slice][row][col]` order (channels interleaved last
        /// when no channel is picked).
        #[arg(long)]
        raw: bool,
        /// Channel to export, by name (as `inspect` lists them), letter (r, g, b, a) or index.
        #[arg(long)]
        channel: Option<String>,
    },
}

/// Where a one-shot bake goes and how it runs.
#[derive(Args)]
struct OneShot {
    /// Bundle directory (created if missing; other assets are kept).
    #[arg(long)]
    out: PathBuf,
    /// Asset id prefix (default: the input's file stem).
    #[arg(long)]
    id: Option<String>,
    /// Worker threads (default: one per core).
    #[arg(long, short = 'j', value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    jobs: Option<u16>,
    /// Bake even if unchanged; replace an unreadable bundle.
    #[arg(long)]
    force: bool,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum OutputFormat {
    Text,
    Json,
}

/// An error with the exit code it maps to.
struct Failure {
    code: u8,
    error: anyhow::Error,
}

impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(e: E) -> Self {
        let error = e.into();
        let bundle_error = |c: &(dyn std::error::Error + 'static)| match c.downcast_ref::<BakeError>() {
            Some(BakeError::Bundle(e)) => Some(e.class()),
            _ => c.downcast_ref::<BundleError>().map(BundleError::class),
        };
        let io = error.chain().any(|c| {
            c.downcast_ref::<BakeError>().is_some_and(BakeError::is_io)
                || c.downcast_ref::<BundleError>().is_some_and(BundleError::is_io)
        });
        let over_budget = error.chain().any(|c| bundle_error(c) == Some("budget"));
        Failure {
            code: if io {
                3
            } else if over_budget {
                4
            } else {
                1
            },
            error,
        }
    }
}

/// A file-size limit (`ulimit -f`) must end a write with an error naming the file (exit 3),
/// not kill the process half way: with SIGXFSZ ignored, the write returns `EFBIG` instead.
#[cfg(any(target_os = "linux", target_os = "macos"))]
fn ignore_file_size_signal() {
    unsafe extern "C" {
        fn signal(signum: i32, handler: usize) -> usize;
    }
    const SIGXFSZ: i32 = 25;
    const SIG_IGN: usize = 1;
    // SAFETY: setting one signal's disposition to SIG_IGN has no memory-safety preconditions,
    // and nothing else in the process installs a handler for it.
    unsafe {
        signal(SIGXFSZ, SIG_IGN);
    }
}

#[cfg(not(any(target_os = "linux", target_os = "macos")))]
fn ignore_file_size_signal() {}

fn main() -> ExitCode {
    ignore_file_size_signal();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            output::emit_err(&format!("error: {:#}", f.error));
            ExitCode::from(f.code)
        }
    }
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Bake { pipeline, force, jobs, shard, cache, cache_max_gib } => {
            // The cache is an optimisation: one that cannot be opened is a warning.
            let cache = cache.and_then(|dir| match Cache::open(&dir, cache_max_gib) {
                Ok(c) => Some(c),
                Err(e) => {
                    output::emit_err(&format!("warning: the cache is not used: {e}"));
                    None
                }
            });
            bake(&pipeline, force, jobs, shard, cache)
        }
        Command::Merge { out, parts, force } => merge(&out, &parts, force),
        Command::Validate { path, format } => validate(&path, format),
        Command::Inspect { bundle, format } => inspect(&bundle, format),
        Command::Diff(args) => diff::run(&args),
        Command::Sheet { bundle, out, old } => sheet(&bundle, &out, old.as_deref()),
        Command::Export { bundle, asset, out, gltf, raw, channel } => match (out, gltf) {
            (_, Some(path)) => export_mesh(&bundle, &asset, &path),
            (Some(out), None) => export(&bundle, &asset, &out, raw, channel.as_deref()),
            (None, None) => unreachable!("clap requires --out or --gltf"),
        },
        Command::Horizon { mut job, target } => {
            job.id = target.id_for(&job.source.input);
            one_shot(Job::Horizon(job), &target)
        }
        Command::Relief { mut job, target } => {
            job.id = target.id_for(&job.source.input);
            one_shot(Job::Relief(job), &target)
        }
        Command::Strands { mut job, target } => {
            job.id = target.id_for(&job.input);
            one_shot(Job::Strands(job), &target)
        }
    }
}

impl OneShot {
    /// The asset id prefix: `--id`, else the input's file stem.
    fn id_for(&self, input: &Path) -> String {
        self.id
            .clone()
            .unwrap_or_else(|| input.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default())
    }
}

fn one_shot(job: Job, target: &OneShot) -> Result<(), Failure> {
    let out = &target.out;
    let observer = progress::Bars::new();
    let options = RunOptions {
        force: target.force,
        threads: target.jobs.map(usize::from),
        observer: &observer,
        ..Default::default()
    };
    let report = run_one_job(&job, out, &options)
        .with_context(|| format!("baking `{}` into {}", job.baker().id(), out.display()));
    observer.finish();
    let report = report?;
    out!("{}: baked {}, skipped {}", report.bundle.display(), report.baked.len(), report.skipped.len());
    Ok(())
}

fn merge(out: &Path, parts: &[PathBuf], force: bool) -> Result<(), Failure> {
    let report =
        hikage_bake::shard::merge(out, parts, force).with_context(|| format!("merging into {}", out.display()))?;
    out!("{}: merged {} assets from {} parts", out.display(), report.assets, report.parts.len());
    Ok(())
}

fn bake(
    pipeline: &Path,
    force: bool,
    jobs: Option<u16>,
    shard: Option<Shard>,
    cache: Option<Cache>,
) -> Result<(), Failure> {
    let observer = progress::Bars::new();
    let options = RunOptions { force, threads: jobs.map(usize::from), observer: &observer, shard, cache };
    let report = run_pipeline(pipeline, &options).with_context(|| format!("baking {}", pipeline.display()));
    observer.finish();
    let report = report?;
    out!(
        "{}: baked {}{}, skipped {}{}{}",
        report.bundle.display(),
        report.baked.len(),
        report.rebaked_summary().map_or(String::new(), |s| format!(" ({s})")),
        report.skipped.len(),
        if report.cached.is_empty() { String::new() } else { format!(", from the cache {}", report.cached.len()) },
        if report.removed.is_empty() {
            String::new()
        } else {
            format!(", removed {} stale payloads", report.removed.len())
        }
    );
    Ok(())
}

fn validate(path: &Path, format: OutputFormat) -> Result<(), Failure> {
    if path.is_file() {
        return validate_pipeline(path, format);
    }
    let report = hikage_bundle::validate(path).with_context(|| format!("validating {}", path.display()));
    let report = match (report, format) {
        (Ok(r), _) => r,
        (Err(e), OutputFormat::Json) => {
            out!("{}", serde_json::json!({ "valid": false, "error": format!("{:#}", e) }));
            return Err(e.into());
        }
        (Err(e), OutputFormat::Text) => return Err(e.into()),
    };
    match format {
        OutputFormat::Json => out!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "valid": report.is_valid(),
                "assets": report.assets,
                "problems": report.problems,
                "over_budget": report.over_budget,
            }))?
        ),
        OutputFormat::Text => {
            for p in &report.problems {
                out!("{}: asset `{}`: {}", p.file.display(), p.asset, p.message);
            }
            for o in &report.over_budget {
                out!("{}: over budget: {o}", path.display());
            }
            if report.is_valid() {
                out!("{}: valid ({} assets)", path.display(), report.assets);
            }
        }
    }
    if !report.is_valid() {
        Err(Failure {
            code: 1,
            error: anyhow::anyhow!("{}: {} problem(s) found", path.display(), report.problems.len()),
        })
    } else if !report.over_budget.is_empty() {
        Err(Failure {
            code: 4,
            error: anyhow::anyhow!("{}: {} figure(s) over budget", path.display(), report.over_budget.len()),
        })
    } else {
        Ok(())
    }
}

fn validate_pipeline(path: &Path, format: OutputFormat) -> Result<(), Failure> {
    let observer = progress::Bars::new();
    let check = check_pipeline(path, &observer).with_context(|| format!("checking {}", path.display()));
    observer.finish();
    match (check, format) {
        (Ok(c), OutputFormat::Json) => {
            out!(
                "{}",
                serde_json::to_string_pretty(
                    &serde_json::json!({ "valid": true, "jobs": c.jobs, "inputs": c.inputs })
                )?
            );
            Ok(())
        }
        (Ok(c), OutputFormat::Text) => {
            out!("{}: valid ({} jobs, {} inputs)", path.display(), c.jobs.len(), c.inputs.len());
            Ok(())
        }
        (Err(e), OutputFormat::Json) => {
            out!("{}", serde_json::json!({ "valid": false, "error": format!("{:#}", e) }));
            Err(e.into())
        }
        (Err(e), OutputFormat::Text) => Err(e.into()),
    }
}

fn inspect(dir: &Path, format: OutputFormat) -> Result<(), Failure> {
    let bundle = Bundle::open(dir).with_context(|| format!("opening {}", dir.display()))?;
    let summary = hikage_bundle::inspect::summarize(bundle.manifest());
    match format {
        OutputFormat::Json => out!("{}", serde_json::to_string_pretty(&summary)?),
        OutputFormat::Text => {
            out!("{} — format {}, written by {}", dir.display(), summary.format, summary.generator);
            for a in &summary.assets {
                let dims = a.dimensions.iter().map(u64::to_string).collect::<Vec<_>>().join("×");
                out!(
                    "  {:<28} {:<12} {:<12} {:<8} {:<16} {:>10} B  GPU {:>10} B  [{}]",
                    a.id,
                    a.kind,
                    a.format,
                    a.dimension,
                    dims,
                    a.byte_length,
                    a.gpu_bytes,
                    a.channels.join(", ")
                );
            }
            out!(
                "  {} assets: {} B on disk ({:.1} MiB), {} B in GPU memory ({:.1} MiB)",
                summary.assets.len(),
                summary.disk_bytes,
                summary.disk_bytes as f64 / 1048576.0,
                summary.gpu_bytes,
                summary.gpu_bytes as f64 / 1048576.0
            );
        }
    }
    Ok(())
}

fn sheet(dir: &Path, out: &Path, old: Option<&Path>) -> Result<(), Failure> {
    let open = |p: &Path| Bundle::open(p).with_context(|| format!("opening {}", p.display()));
    let bundle = open(dir)?;
    let old = old.map(open).transpose()?;
    let report = hikage_bake::export::sheet::write_sheet(&bundle, old.as_ref(), out)
        .with_context(|| format!("writing the contact sheet of {} into {}", dir.display(), out.display()))?;
    out!(
        "{}: {} images, {:.2} MiB{}",
        report.page.display(),
        report.images,
        report.bytes as f64 / 1048576.0,
        if old.is_some() { format!(", {} assets changed", report.changed) } else { String::new() }
    );
    Ok(())
}

fn export_mesh(dir: &Path, asset: &str, out: &Path) -> Result<(), Failure> {
    let bundle = Bundle::open(dir).with_context(|| format!("opening {}", dir.display()))?;
    let (vertices, indices) = export_gltf(&bundle, asset, out)
        .with_context(|| format!("exporting `{asset}` from {} as glTF", dir.display()))?;
    out!("{}: {vertices} vertices, {indices} indices", out.display());
    Ok(())
}

fn export(dir: &Path, asset: &str, out: &Path, raw: bool, channel: Option<&str>) -> Result<(), Failure> {
    let bundle = Bundle::open(dir).with_context(|| format!("opening {}", dir.display()))?;
    let format = if raw { ExportFormat::Raw } else { ExportFormat::Exr };
    let s = export_texture(&bundle, asset, channel, format, out)
        .with_context(|| format!("exporting `{asset}` from {}", dir.display()))?;
    out!(
        "{}: {} slice(s) of {}×{}, channels [{}], {} bytes",
        out.display(),
        s.slices,
        s.width,
        s.height,
        s.channels.join(", "),
        s.bytes
    );
    Ok(())
}
