//! `hikage diff OLD NEW`: the tolerances from a pipeline and the flags, then
//! `hikage_bundle::diff` and its report as a table or JSON.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use hikage_bundle::Bundle;
use hikage_bundle::diff::{Status, TOLERANCES, Tolerance, Tolerances, diff};

use crate::{Failure, OutputFormat};

/// The exit codes of `hikage diff`.
pub const EXIT_CODES: &str = "\
Exit codes:
  0  every asset the same, or changed within tolerance
  1  a change beyond tolerance, an asset added or removed, or one that cannot be compared (the
     report says which); also an invalid bundle (the message says so)
  2  usage error (unknown command or option, missing argument)
  3  I/O error (a file or directory that cannot be read)";

/// What `hikage diff` takes.
#[derive(Args)]
pub struct DiffArgs {
    /// The bundle before (e.g. the last release's).
    old: PathBuf,
    /// The bundle after.
    new: PathBuf,
    /// Take the tolerances from this pipeline's `tolerances` (the flags override them).
    #[arg(long, value_name = "PIPELINE")]
    pipeline: Option<PathBuf>,
    /// The tolerances given as flags, one per tolerance of the library's table.
    #[command(flatten)]
    flags: ToleranceFlags,
    /// List every asset, the unchanged ones too.
    #[arg(long)]
    all: bool,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
}

impl DiffArgs {
    /// The pipeline's tolerances (or none) with each flag given put over them.
    fn tolerances(&self) -> Result<Tolerances, Failure> {
        let mut t = match &self.pipeline {
            Some(path) => {
                let loaded = hikage_bake::pipeline::Pipeline::load(path)
                    .with_context(|| format!("reading the tolerances of {}", path.display()))?;
                loaded.check().with_context(|| format!("reading the tolerances of {}", path.display()))?;
                loaded.pipeline.tolerances
            }
            None => Tolerances::default(),
        };
        for (tolerance, v) in &self.flags.0 {
            if !(*v >= 0.0 && v.is_finite()) {
                return Err(Failure {
                    code: 2, error: anyhow::anyhow!("a tolerance is a finite number ≥ 0, not {v}")
                });
            }
            *(tolerance.field)(&mut t) = *v;
        }
        Ok(t)
    }
}

/// `--horizon-degrees`, `--sun-flips`, …: a flag for each entry of the library's
/// [`TOLERANCES`], with its unit and help, and the values given.
#[derive(Clone, Debug, Default)]
struct ToleranceFlags(Vec<(&'static Tolerance, f32)>);

impl clap::FromArgMatches for ToleranceFlags {
    fn from_arg_matches(matches: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let given = TOLERANCES.iter().filter_map(|t| matches.get_one::<f32>(t.name).map(|v| (t, *v))).collect();
        Ok(ToleranceFlags(given))
    }

    fn update_from_arg_matches(&mut self, matches: &clap::ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(matches)?;
        Ok(())
    }
}

impl clap::Args for ToleranceFlags {
    fn augment_args(command: clap::Command) -> clap::Command {
        TOLERANCES.iter().fold(command, |command, t| {
            command.arg(
                clap::Arg::new(t.name)
                    .long(t.flag)
                    .value_name(t.unit)
                    .help(t.doc)
                    .value_parser(clap::value_parser!(f32))
                    .allow_negative_numbers(true),
            )
        })
    }

    fn augment_args_for_update(command: clap::Command) -> clap::Command {
        Self::augment_args(command)
    }
}

/// Compares the bundles and prints the report; a change beyond tolerance is exit 1. With
/// `--format json` every outcome prints one JSON object: a bundle that cannot be opened or
/// compared, or a bad tolerance, is `"error"` with `"within_tolerance": false`, so a CI step that
/// keeps the output keeps why.
pub fn run(args: &DiffArgs) -> Result<(), Failure> {
    match compare(args) {
        Ok(beyond) if beyond.is_empty() => Ok(()),
        Ok(beyond) => Err(Failure {
            code: 1,
            error: anyhow::anyhow!("{} asset(s) changed beyond tolerance: {}", beyond.len(), beyond.join(", ")),
        }),
        Err(failure) => {
            if args.format == OutputFormat::Json {
                out!(
                    "{}",
                    serde_json::to_string_pretty(&serde_json::json!({
                        "old": args.old,
                        "new": args.new,
                        "within_tolerance": false,
                        "error": format!("{:#}", failure.error),
                    }))?
                );
            }
            Err(failure)
        }
    }
}

/// The comparison itself: prints the report and gives the ids beyond tolerance.
fn compare(args: &DiffArgs) -> Result<Vec<String>, Failure> {
    let tolerances = args.tolerances()?;
    let open = |p: &PathBuf| Bundle::open(p).with_context(|| format!("opening {}", p.display()));
    let (old, new) = (open(&args.old)?, open(&args.new)?);
    let report = diff(&old, &new, &tolerances)
        .with_context(|| format!("comparing {} with {}", args.old.display(), args.new.display()))?;
    let beyond: Vec<&str> = report.iter().filter(|d| d.beyond()).map(|d| d.id.as_str()).collect();
    let changed = report.iter().filter(|d| d.status != Status::Same).count();
    match args.format {
        OutputFormat::Json => out!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "old": args.old,
                "new": args.new,
                "tolerances": tolerances,
                "within_tolerance": beyond.is_empty(),
                "assets": report.iter().filter(|d| args.all || d.status != Status::Same).map(|d| {
                    serde_json::json!({
                        "id": d.id,
                        "kind": d.kind,
                        "status": d.status,
                        "beyond_tolerance": d.beyond(),
                        "note": d.note,
                        "measures": d.measures,
                        "tile": tile_of(&new, &d.id).or_else(|| tile_of(&old, &d.id)),
                    })
                }).collect::<Vec<_>>(),
            }))?
        ),
        OutputFormat::Text => {
            for d in report.iter().filter(|d| args.all || d.status != Status::Same) {
                let verdict = if d.beyond() { "BEYOND" } else { "ok" };
                out!("{verdict:<7}{:<9}{:<32}{:?}", format!("{:?}", d.status).to_lowercase(), d.id, d.kind);
                if let Some(note) = &d.note {
                    out!("         {note}");
                }
                for m in d.measures.iter().filter(|m| m.limit.is_none() || d.status != Status::Same) {
                    let limit = m.limit.map_or(String::new(), |l| format!(" (tolerance {l})"));
                    let at = m.at.as_ref().map_or(String::new(), |a| format!(" at {a}"));
                    let flag = if m.beyond() { "  ← beyond" } else { "" };
                    out!("         {:<30} {:>12} {}{limit}{at}{flag}", m.name, figure(m.value), m.unit);
                }
            }
            out!(
                "{} assets: {} changed, {} beyond tolerance{}",
                report.len(),
                changed,
                beyond.len(),
                if beyond.is_empty() { String::new() } else { format!(": {}", beyond.join(", ")) }
            );
        }
    }
    Ok(beyond.into_iter().map(String::from).collect())
}

/// Where asset `id` of `bundle` lies when it is a tile (its map, level, index, and its texels at
/// its level: first column and row, width, height), for a build that republishes only the
/// changed tiles' files; `None` for any other asset.
fn tile_of(bundle: &Bundle, id: &str) -> Option<serde_json::Value> {
    let asset = bundle.asset(id).ok()?;
    let (place, texture) = (asset.settings.tile()?, asset.payload.texture()?);
    Some(serde_json::json!({
        "map": place.map,
        "level": place.level,
        "index": [place.index.0, place.index.1],
        "rect": [place.origin.0, place.origin.1, texture.width, texture.height],
        "file": asset.file,
    }))
}

/// A figure with as many digits as it needs: counts whole, others to 4 significant digits.
fn figure(v: f64) -> String {
    if v == v.trunc() && v.abs() < 1e12 { format!("{v}") } else { format!("{v:.4}") }
}
