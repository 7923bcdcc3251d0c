//! The one error type of hikage-bake.

use std::path::PathBuf;

use hikage_bundle::BundleError;

/// Everything that can go wrong loading inputs, checking settings or baking.
///
/// Every variant names the file and, where one exists, the place in it.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// The operating system refused to read or write a file.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying error (shown in the message, so not chained again).
        error: std::io::Error,
    },
    /// An input file is malformed or holds values hikage cannot use.
    #[error("{}: {place}{message}", path.display(), place = place.as_ref().map(|p| format!("{p}: ")).unwrap_or_default())]
    Input {
        /// The input file.
        path: PathBuf,
        /// Where in the file (`pixel (3, 7)`, `line 12`, `byte 128`), when known.
        place: Option<String>,
        /// What was expected and what was found.
        message: String,
    },
    /// `pipeline.ron` has a syntax or type error.
    #[error("{}:{line}:{col}: {message}", path.display())]
    Pipeline {
        /// The pipeline file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        col: usize,
        /// What the parser expected.
        message: String,
    },
    /// A job's settings are out of range or inconsistent.
    #[error("{}{}: job `{job}`: {message}", path.display(), place.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
    Setting {
        /// The pipeline file (or `<command line>`).
        path: PathBuf,
        /// 1-based line and column of the setting (or of the job) in the pipeline file, when
        /// known.
        place: Option<(usize, usize)>,
        /// The job id.
        job: String,
        /// What is wrong and what is accepted.
        message: String,
    },
    /// A size claimed by an input exceeds a configured limit; nothing was allocated for it.
    #[error("{}: {what} is {value}, above the limit of {limit}", path.display())]
    Limit {
        /// The input file.
        path: PathBuf,
        /// What was measured.
        what: String,
        /// The claimed value.
        value: u64,
        /// The limit.
        limit: u64,
    },
    /// Reading or writing the bundle failed.
    #[error(transparent)]
    Bundle(#[from] BundleError),
}

impl BakeError {
    /// A short stable name of the error's class (`input`, `limit`, …), for tests and tools
    /// that sort errors without parsing messages.
    pub fn class(&self) -> &'static str {
        match self {
            BakeError::Io { .. } => "io",
            BakeError::Input { .. } => "input",
            BakeError::Pipeline { .. } => "pipeline",
            BakeError::Setting { .. } => "setting",
            BakeError::Limit { .. } => "limit",
            BakeError::Bundle(e) => e.class(),
        }
    }

    /// True when the error comes from the operating system (missing file, permissions, full
    /// disk) rather than from the content of a file.
    pub fn is_io(&self) -> bool {
        match self {
            BakeError::Io { .. } => true,
            BakeError::Bundle(e) => e.is_io(),
            _ => false,
        }
    }

    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        BakeError::Io { path: path.into(), error: source }
    }

    pub(crate) fn input(path: impl Into<PathBuf>, place: Option<String>, message: impl Into<String>) -> Self {
        BakeError::Input { path: path.into(), place, message: message.into() }
    }
}
