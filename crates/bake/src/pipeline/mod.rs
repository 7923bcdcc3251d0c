//! `pipeline.ron`: where the bundle goes and the jobs that fill it.
//!
//! ```ron
//! (
//!     output: "bundle",                 // relative to the pipeline file's directory
//!     limits: (max_dimension: 16384),   // optional
//!     jobs: [
//!         Heightfield(id: "terrain", input: "data/terrain.png", texel_size: (80, 80), height_scale: 1200),
//!     ],
//! )
//! ```
//!
//! Unknown fields are errors (a typo must not silently fall back to a default). Paths are
//! relative to the directory holding the pipeline file.

mod spans;

use std::path::{Path, PathBuf};

use serde::Deserialize;

pub use spans::{Fields, Place, Spans};

use crate::error::BakeError;
use crate::jobs::{Job, JobContext};
use crate::limits::InputLimits;

/// A parsed pipeline file.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pipeline {
    /// Output bundle directory.
    pub output: PathBuf,
    /// Limits applied to inputs before they are decoded.
    #[serde(default)]
    pub limits: InputLimits,
    /// A shared cache of baked payloads (relative to the pipeline file), kept to 20 GiB;
    /// `hikage bake --cache` overrides it.
    #[serde(default)]
    pub cache: Option<PathBuf>,
    /// Bytes on disk and in GPU memory the bundle, a job or an asset may take: a bake over it
    /// commits nothing (exit 4), and the manifest records it for `hikage validate`.
    #[serde(default)]
    pub budget: hikage_bundle::Budget,
    /// How far a rebake may move what a player sees before `hikage diff --pipeline` fails
    /// (all 0 by default: any change of a decoded value).
    #[serde(default)]
    pub tolerances: hikage_bundle::diff::Tolerances,
    /// The jobs, baked in order.
    pub jobs: Vec<Job>,
}

/// A pipeline with the file it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadedPipeline {
    /// The pipeline file.
    pub path: PathBuf,
    /// Directory that relative paths are resolved against.
    pub base_dir: PathBuf,
    /// The parsed content.
    pub pipeline: Pipeline,
    /// Where each job and setting is in the file (empty for a one-shot).
    pub spans: Spans,
}

impl LoadedPipeline {
    /// The output bundle directory, resolved.
    pub fn output_dir(&self) -> PathBuf {
        self.base_dir.join(&self.pipeline.output)
    }

    /// Resolves a path written in the pipeline.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        self.base_dir.join(p)
    }

    /// A pipeline of the one job `job` writing into `bundle`, its source `<command line>` and
    /// its inputs relative to the current directory: what the one-shot commands run.
    pub fn one_job(job: Job, bundle: &Path) -> LoadedPipeline {
        LoadedPipeline {
            path: PathBuf::from(COMMAND_LINE),
            base_dir: PathBuf::new(),
            pipeline: Pipeline {
                output: bundle.to_path_buf(),
                limits: InputLimits::default(),
                cache: None,
                budget: hikage_bundle::Budget::default(),
                tolerances: hikage_bundle::diff::Tolerances::default(),
                jobs: vec![job],
            },
            spans: Spans::default(),
        }
    }

    /// What job `index` of this pipeline runs with.
    pub fn context<'a>(&'a self, index: usize, progress: &'a (dyn Fn(u64, u64) + Sync)) -> JobContext<'a> {
        JobContext {
            source: &self.path,
            place: self.spans.jobs.get(index),
            base_dir: &self.base_dir,
            limits: &self.pipeline.limits,
            progress,
        }
    }

    /// A setting error of job `index` (id `job`), at the field `message` names first, else at
    /// the job.
    pub(crate) fn setting(&self, index: usize, job: &str, message: String) -> BakeError {
        let place = self.spans.jobs.get(index).and_then(|f| f.place_of(&message));
        BakeError::Setting { path: self.path.clone(), place, job: job.to_string(), message }
    }

    /// An error the bundle writer gave for what job `index` (id `job`) baked: data it refuses
    /// to commit is the job's (named with it), anything else passes through.
    pub(crate) fn baked_error(&self, index: usize, job: &str, e: hikage_bundle::BundleError) -> BakeError {
        match e {
            hikage_bundle::BundleError::InvalidData(message) => self.setting(index, job, message),
            e => BakeError::Bundle(e),
        }
    }

    /// Checks settings ([`Pipeline::check`]), each error at its place in the file.
    pub fn check(&self) -> Result<(), BakeError> {
        self.pipeline.check_at(&self.path, &self.spans)
    }
}

/// The source named in the errors of a one-shot command's job.
pub const COMMAND_LINE: &str = "<command line>";

/// Largest `pipeline.ron` read.
const MAX_PIPELINE_BYTES: u64 = 16 << 20;

impl Pipeline {
    /// Reads and parses a pipeline file, then checks every job's settings.
    pub fn load(path: &Path) -> Result<LoadedPipeline, BakeError> {
        let bytes = hikage_bundle::files::read_limited(path, MAX_PIPELINE_BYTES, "pipeline size")?;
        // Not UTF-8 is malformed content, not an I/O failure.
        let text = std::str::from_utf8(&bytes).map_err(|e| BakeError::Pipeline {
            path: path.to_path_buf(),
            line: 1 + bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count(),
            col: 1 + bytes[..e.valid_up_to()].iter().rev().take_while(|&&b| b != b'\n').count(),
            message: "expected UTF-8 text".into(),
        })?;
        let pipeline = Pipeline::parse(text, path)?;
        let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let loaded = LoadedPipeline { path: path.to_path_buf(), base_dir, pipeline, spans: spans::scan(text) };
        loaded.check()?;
        Ok(loaded)
    }

    /// Parses pipeline text; `path` is used in error messages. Errors carry line and column.
    pub fn parse(text: &str, path: &Path) -> Result<Pipeline, BakeError> {
        ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::UNWRAP_VARIANT_NEWTYPES)
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
            .from_str::<Pipeline>(text)
            .map_err(|e| BakeError::Pipeline {
                path: path.to_path_buf(),
                line: e.span.start.line,
                col: e.span.start.col,
                message: e.code.to_string(),
            })
    }

    /// Checks settings: each job's ranges, and that no two jobs make the same asset id.
    pub fn check(&self, path: &Path) -> Result<(), BakeError> {
        self.check_at(path, &Spans::default())
    }

    /// [`check`](Self::check), each error placed by `spans`.
    fn check_at(&self, path: &Path, spans: &Spans) -> Result<(), BakeError> {
        let setting = |fields: Option<&Fields>, job: &str, message: String| BakeError::Setting {
            path: path.to_path_buf(),
            place: fields.and_then(|f| f.place_of(&message)),
            job: job.to_string(),
            message,
        };
        if !(1..=InputLimits::MAX_DIMENSION).contains(&self.limits.max_dimension) {
            let message = format!(
                "max_dimension must be 1 to {} (the largest side a reader can hold), found {}",
                InputLimits::MAX_DIMENSION,
                self.limits.max_dimension
            );
            return Err(setting(Some(&spans.limits), "limits", message));
        }
        let mut seen = std::collections::BTreeMap::new();
        for (index, job) in self.jobs.iter().enumerate() {
            let compression = job.compression();
            let job = job.baker();
            let fields = spans.jobs.get(index);
            crate::jobs::check(job)
                .and_then(|()| compression.check())
                .map_err(|message| setting(fields, job.id(), message))?;
            for out in job.outputs() {
                if let Some(other) = seen.insert(out.clone(), job.id().to_string()) {
                    return Err(BakeError::Setting {
                        path: path.to_path_buf(),
                        place: fields.and_then(|f| f.place("id")),
                        job: job.id().to_string(),
                        message: format!("asset id `{out}` is also made by job `{other}`"),
                    });
                }
            }
        }
        self.tolerances.check().map_err(|message| BakeError::Setting {
            path: path.to_path_buf(),
            place: spans.tolerances.place_of(&message),
            job: "tolerances".into(),
            message,
        })?;
        // What the budget names must be the pipeline's: a typo must not leave a job unbounded.
        let budget = |message: String| BakeError::Setting {
            path: path.to_path_buf(),
            place: None,
            job: "budget".into(),
            message,
        };
        let ids: Vec<&str> = self.jobs.iter().map(|j| j.baker().id()).collect();
        if let Some(job) = self.budget.jobs.keys().find(|k| !ids.contains(&k.as_str())) {
            return Err(budget(format!("`jobs` names job `{job}`, which the pipeline does not have")));
        }
        if let Some(asset) =
            self.budget.assets.keys().find(|a| !ids.iter().any(|job| hikage_bundle::budget::made_by(a, job)))
        {
            return Err(budget(format!("`assets` names `{asset}`, which no job of the pipeline makes")));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_defaults_and_reports_typos_with_position() {
        let p = Pipeline::parse(
            "(output: \"b\", jobs: [Heightfield(id: \"t\", input: \"t.png\", channel: \"R\")])",
            Path::new("p.ron"),
        )
        .unwrap();
        let Job::Heightfield(h) = &p.jobs[0] else { panic!("expected a heightfield job") };
        assert_eq!(h.source.texel_size, (1.0, 1.0));
        assert_eq!(h.source.channel.as_deref(), Some("R"));

        let err = Pipeline::parse(
            "(\n output: \"b\",\n jobs: [Heightfield(id: \"t\", input: \"t.png\", hieght_scale: 2)],\n)",
            Path::new("p.ron"),
        )
        .unwrap_err();
        match err {
            BakeError::Pipeline { line, message, .. } => {
                assert_eq!(line, 3);
                assert!(message.contains("hieght_scale"), "{message}");
            }
            e => panic!("{e}"),
        }
        let err = Pipeline::parse(
            "(output: \"b\", jobs: [Heightfield(id: \"t\", input: \"t.png\", height_scale: \"x\")])",
            Path::new("p.ron"),
        );
        assert!(matches!(err, Err(BakeError::Pipeline { line: 1, .. })));
    }
}
