//! `hikage`: bakes pipelines into bundles, validates, inspects and exports them.
//!
//! Thin by design: parse arguments, call `hikage-bake` / `hikage-bundle`, report. Exit codes:
//! 0 success, 1 invalid input or failed validation, 2 usage error, 3 I/O error.

mod progress;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Parser, Subcommand, ValueEnum};
use hikage_bake::BakeError;
use hikage_bake::export::{ExportFormat, export_texture};
use hikage_bake::horizon::HorizonFormat;
use hikage_bake::pipeline::{HorizonJob, Job, ReliefJob, StrandsJob};
use hikage_bake::relief::ReliefFormat;
use hikage_bake::run::{RunOptions, check_pipeline, run_one_job, run_pipeline};
use hikage_bundle::EdgeMode;
use hikage_bundle::{Bundle, BundleError};

const EXIT_CODES: &str = "\
Exit codes:
  0  success
  1  invalid input, invalid settings, or a bundle that failed validation
  2  usage error (unknown command or option, missing argument)
  3  I/O error (a file or directory that cannot be read or written)";

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
    /// Bake horizon and distance maps of one heightfield into BUNDLE (created, or its assets
    /// `<id>.height`, `<id>.horizon`, `<id>.ao` added or replaced).
    #[command(after_help = EXIT_CODES)]
    Horizon {
        /// Heightfield image (PNG 8/16-bit or OpenEXR).
        input: PathBuf,
        #[command(flatten)]
        target: OneShot,
        /// Azimuths D (1–256); direction k has φ = 2πk/D.
        #[arg(long, default_value_t = 32)]
        directions: u32,
        /// World units per texel: SX or SX,SY.
        #[arg(long, value_name = "SX[,SY]", value_parser = parse_texel_size)]
        texel_size: Option<(f32, f32)>,
        /// World height = offset + scale × sample (integer images normalised to [0, 1] first).
        #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
        height_scale: f32,
        /// See --height-scale.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        height_offset: f32,
        /// wrap: rays continue on the torus (tileable maps); clamp: rays stop at the edge.
        #[arg(long, value_enum, default_value_t = EdgeArg::Wrap)]
        edge: EdgeArg,
        /// Largest horizon distance in world units.
        #[arg(long, allow_negative_numbers = true)]
        max_distance: Option<f32>,
        /// Storage: rg16f (default), rg32f, or rg8 (the paper's memory; β step 0.71°).
        #[arg(long, value_enum, default_value_t = FormatArg::Rg16f)]
        format: FormatArg,
        /// Also write an ambient-occlusion map derived from the horizons.
        #[arg(long)]
        ao: bool,
        /// Texels per ray traced exactly before the line sweep takes over (0–64).
        #[arg(long, default_value_t = hikage_bake::horizon::DEFAULT_NEAR_FIELD)]
        near_field: u32,
        /// Channel of the input image to take.
        #[arg(long)]
        channel: Option<String>,
    },
    /// Bake relief-mapping depth maps (one per hemisphere direction) and the max-mip pyramid of
    /// one heightfield into BUNDLE (assets `<id>.relief` and `<id>.maxmip` added or replaced).
    #[command(after_help = EXIT_CODES)]
    Relief {
        /// Heightfield image (PNG 8/16-bit or OpenEXR; samples in [0, 1], power-of-two sides).
        input: PathBuf,
        #[command(flatten)]
        target: OneShot,
        /// Rows of zenith angle θ (1–128); θ_i = (i + ½)·90°/N.
        #[arg(long, default_value_t = 32)]
        theta: u32,
        /// Azimuths φ per row (1–128); φ_j = 360°·j/M.
        #[arg(long, default_value_t = 16)]
        phi: u32,
        /// Width of the stored maps: a power of two up to the map width (MIN-downscaled);
        /// default 32, or the map width when smaller.
        #[arg(long)]
        size: Option<u32>,
        /// Relief thickness as a share of the map width.
        #[arg(long, default_value_t = 0.1)]
        depth_scale: f32,
        /// Storage: r8 (default, the paper's memory) or r16f; both rounded down.
        #[arg(long, value_enum, default_value_t = ReliefFormatArg::R8)]
        format: ReliefFormatArg,
        /// Channel of the input image to take.
        #[arg(long)]
        channel: Option<String>,
    },
    /// Bake hair strip meshes from a `.hair` file or OBJ polylines into BUNDLE (`<id>.strips`,
    /// and `<id>.ribbons` with --ribbons). Widths are full widths in the input's units.
    #[command(after_help = EXIT_CODES)]
    Strands {
        /// Cem Yuksel `.hair` file or Wavefront OBJ with `l` polylines.
        input: PathBuf,
        #[command(flatten)]
        target: OneShot,
        /// Opacity set width (default: shading width × 1.40/0.16, the paper's ratio).
        #[arg(long)]
        opacity_width: Option<f32>,
        /// Opacity set opacity (default: shading opacity × 0.0165/0.366).
        #[arg(long)]
        opacity_alpha: Option<f32>,
        /// Shading set width (default: the input's default thickness).
        #[arg(long)]
        shading_width: Option<f32>,
        /// Shading set opacity (default: 1 − the input's default transparency).
        #[arg(long)]
        shading_alpha: Option<f32>,
        /// Choose the opacity set from the strand density for an opacity map of N² texels.
        #[arg(long, value_name = "N", num_args = 0..=1, default_missing_value = "256")]
        auto: Option<u32>,
        /// Share of the width lost at the tip (0–1).
        #[arg(long, default_value_t = 0.0)]
        taper: f32,
        /// Also bake a fixed-orientation ribbon mesh (minimum-twist frames).
        #[arg(long)]
        ribbons: bool,
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
enum EdgeArg {
    Wrap,
    Clamp,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum FormatArg {
    Rg16f,
    Rg32f,
    Rg8,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ReliefFormatArg {
    R8,
    R16f,
}

fn parse_texel_size(s: &str) -> Result<(f32, f32), String> {
    let parts: Vec<&str> = s.split(',').collect();
    let num = |p: &str| p.trim().parse::<f32>().map_err(|e| format!("{p:?}: {e}"));
    match parts.as_slice() {
        [x] => num(x).map(|x| (x, x)),
        [x, y] => Ok((num(x)?, num(y)?)),
        _ => Err("expected SX or SX,SY".into()),
    }
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
        let io = error.chain().any(|c| {
            c.downcast_ref::<BakeError>().is_some_and(BakeError::is_io)
                || c.downcast_ref::<BundleError>().is_some_and(BundleError::is_io)
        });
        Failure { code: if io { 3 } else { 1 }, error }
    }
}

fn main() -> ExitCode {
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
            eprintln!("error: {:#}", f.error);
            ExitCode::from(f.code)
        }
    }
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Bake { pipeline, force, jobs } => bake(&pipeline, force, jobs),
        Command::Validate { path, format } => validate(&path, format),
        Command::Inspect { bundle, format } => inspect(&bundle, format),
        Command::Export { bundle, asset, out, gltf, raw, channel } => match (out, gltf) {
            (_, Some(path)) => export_gltf(&bundle, &asset, &path),
            (Some(out), None) => export(&bundle, &asset, &out, raw, channel.as_deref()),
            (None, None) => unreachable!("clap requires --out or --gltf"),
        },
        Command::Horizon {
            input,
            target,
            directions,
            texel_size,
            height_scale,
            height_offset,
            edge,
            max_distance,
            format,
            ao,
            near_field,
            channel,
        } => {
            let mut job = HorizonJob::new(&target.id_for(&input), input);
            job.channel = channel;
            job.texel_size = texel_size.unwrap_or((1.0, 1.0));
            job.height_scale = height_scale;
            job.height_offset = height_offset;
            job.directions = directions;
            job.edge = match edge {
                EdgeArg::Wrap => EdgeMode::Wrap,
                EdgeArg::Clamp => EdgeMode::Clamp,
            };
            job.max_distance = max_distance;
            job.format = match format {
                FormatArg::Rg16f => HorizonFormat::Rg16Float,
                FormatArg::Rg32f => HorizonFormat::Rg32Float,
                FormatArg::Rg8 => HorizonFormat::Rg8Unorm,
            };
            job.ao = ao;
            job.near_field = near_field;
            one_shot(Job::Horizon(job), &target)
        }
        Command::Relief { input, target, theta, phi, size, depth_scale, format, channel } => {
            let mut job = ReliefJob::new(&target.id_for(&input), input);
            job.channel = channel;
            job.theta = theta;
            job.phi = phi;
            job.size = size;
            job.depth_scale = depth_scale;
            job.format = match format {
                ReliefFormatArg::R8 => ReliefFormat::R8Unorm,
                ReliefFormatArg::R16f => ReliefFormat::R16Float,
            };
            one_shot(Job::Relief(job), &target)
        }
        Command::Strands {
            input,
            target,
            opacity_width,
            opacity_alpha,
            shading_width,
            shading_alpha,
            auto,
            taper,
            ribbons,
        } => {
            let job = StrandsJob {
                opacity_width,
                opacity_alpha,
                shading_width,
                shading_alpha,
                auto,
                taper,
                ribbons,
                ..StrandsJob::new(&target.id_for(&input), input)
            };
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
    let options = RunOptions { force: target.force, threads: target.jobs.map(usize::from), observer: &observer };
    let report =
        run_one_job(&job, out, &options).with_context(|| format!("baking `{}` into {}", job.id(), out.display()));
    observer.finish();
    let report = report?;
    println!("{}: baked {}, skipped {}", report.bundle.display(), report.baked.len(), report.skipped.len());
    Ok(())
}

fn bake(pipeline: &Path, force: bool, jobs: Option<u16>) -> Result<(), Failure> {
    let observer = progress::Bars::new();
    let options = RunOptions { force, threads: jobs.map(usize::from), observer: &observer };
    let report = run_pipeline(pipeline, &options).with_context(|| format!("baking {}", pipeline.display()));
    observer.finish();
    let report = report?;
    println!(
        "{}: baked {}, skipped {}{}",
        report.bundle.display(),
        report.baked.len(),
        report.skipped.len(),
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
            println!("{}", serde_json::json!({ "valid": false, "error": format!("{:#}", e) }));
            return Err(e.into());
        }
        (Err(e), OutputFormat::Text) => return Err(e.into()),
    };
    match format {
        OutputFormat::Json => println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "valid": report.is_valid(),
                "assets": report.assets,
                "problems": report.problems,
            }))?
        ),
        OutputFormat::Text => {
            for p in &report.problems {
                println!("{}: asset `{}`: {}", p.file.display(), p.asset, p.message);
            }
            if report.is_valid() {
                println!("{}: valid ({} assets)", path.display(), report.assets);
            }
        }
    }
    if report.is_valid() {
        Ok(())
    } else {
        Err(Failure {
            code: 1,
            error: anyhow::anyhow!("{}: {} problem(s) found", path.display(), report.problems.len()),
        })
    }
}

fn validate_pipeline(path: &Path, format: OutputFormat) -> Result<(), Failure> {
    let observer = progress::Bars::new();
    let check = check_pipeline(path, &observer).with_context(|| format!("checking {}", path.display()));
    observer.finish();
    match (check, format) {
        (Ok(c), OutputFormat::Json) => {
            println!(
                "{}",
                serde_json::to_string_pretty(
                    &serde_json::json!({ "valid": true, "jobs": c.jobs, "inputs": c.inputs })
                )?
            );
            Ok(())
        }
        (Ok(c), OutputFormat::Text) => {
            println!("{}: valid ({} jobs, {} inputs)", path.display(), c.jobs.len(), c.inputs.len());
            Ok(())
        }
        (Err(e), OutputFormat::Json) => {
            println!("{}", serde_json::json!({ "valid": false, "error": format!("{:#}", e) }));
            Err(e.into())
        }
        (Err(e), OutputFormat::Text) => Err(e.into()),
    }
}

fn inspect(dir: &Path, format: OutputFormat) -> Result<(), Failure> {
    let bundle = Bundle::open(dir).with_context(|| format!("opening {}", dir.display()))?;
    let summary = hikage_bundle::inspect::summarize(bundle.manifest());
    match format {
        OutputFormat::Json => println!("{}", serde_json::to_string_pretty(&summary)?),
        OutputFormat::Text => {
            println!("{} — format {}, written by {}", dir.display(), summary.format, summary.generator);
            for a in &summary.assets {
                let dims = a.dimensions.iter().map(u64::to_string).collect::<Vec<_>>().join("×");
                println!(
                    "  {:<28} {:<12} {:<12} {:<8} {:<16} {:>10} B  [{}]",
                    a.id,
                    a.kind,
                    a.format,
                    a.dimension,
                    dims,
                    a.byte_length,
                    a.channels.join(", ")
                );
            }
        }
    }
    Ok(())
}

fn export_gltf(dir: &Path, asset: &str, out: &Path) -> Result<(), Failure> {
    let bundle = Bundle::open(dir).with_context(|| format!("opening {}", dir.display()))?;
    let (vertices, indices) = hikage_bake::gltf::export_gltf(&bundle, asset, out)
        .with_context(|| format!("exporting `{asset}` from {} as glTF", dir.display()))?;
    println!("{}: {vertices} vertices, {indices} indices", out.display());
    Ok(())
}

fn export(dir: &Path, asset: &str, out: &Path, raw: bool, channel: Option<&str>) -> Result<(), Failure> {
    let bundle = Bundle::open(dir).with_context(|| format!("opening {}", dir.display()))?;
    let format = if raw { ExportFormat::Raw } else { ExportFormat::Exr };
    let s = export_texture(&bundle, asset, channel, format, out)
        .with_context(|| format!("exporting `{asset}` from {}", dir.display()))?;
    println!(
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
