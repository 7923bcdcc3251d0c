//! The one error type of hikage-bundle.

use std::path::PathBuf;

use crate::version::FormatVersion;

/// Everything that can go wrong reading, writing or checking a bundle.
///
/// Each variant names the file and, where one exists, the place in it (line and column of the
/// manifest, asset id, byte offset) and what was expected.
#[derive(Debug, thiserror::Error)]
pub enum BundleError {
    /// The operating system refused a read, write, rename or listing.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file or directory involved.
        path: PathBuf,
        /// The underlying error (shown in the message, so not chained again).
        error: std::io::Error,
    },
    /// `bundle.ron` is not valid RON or does not match the manifest schema.
    #[error("{}:{line}:{col}: {message}", path.display())]
    ManifestSyntax {
        /// The manifest file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        col: usize,
        /// What the parser expected and found.
        message: String,
    },
    /// The manifest was written by a format this reader does not understand.
    #[error(
        "{}: bundle format {found} is not supported by this reader (format {supported}); \
         re-bake the bundle or upgrade hikage",
        path.display()
    )]
    UnsupportedVersion {
        /// The manifest file.
        path: PathBuf,
        /// The version in the file.
        found: FormatVersion,
        /// The version this reader writes.
        supported: FormatVersion,
    },
    /// The manifest parsed but says something impossible (a bad id, a path leaving the bundle,
    /// inconsistent dimensions).
    #[error("{}: asset `{asset}`: {message}", path.display())]
    InvalidAsset {
        /// The manifest file.
        path: PathBuf,
        /// The asset id (or its index when the id itself is the problem).
        asset: String,
        /// What is wrong.
        message: String,
    },
    /// A payload file does not match what the manifest says about it.
    #[error("{}: asset `{asset}`: {message}", path.display())]
    Payload {
        /// The payload file.
        path: PathBuf,
        /// The asset id.
        asset: String,
        /// What differs.
        message: String,
    },
    /// A KTX2 file is malformed or uses something hikage does not read.
    #[error("{}: {message}", path.display())]
    Ktx2 {
        /// The KTX2 file (or `<memory>`).
        path: PathBuf,
        /// What is wrong, with the header field or byte offset.
        message: String,
    },
    /// A size exceeds a configured [`crate::Limits`] value; nothing was allocated for it.
    #[error("{}: {what} is {value}, above the limit of {limit}", path.display())]
    Limit {
        /// The file that claims the size.
        path: PathBuf,
        /// What was measured.
        what: String,
        /// The claimed value.
        value: u64,
        /// The configured limit.
        limit: u64,
    },
    /// An asset that a caller asked for is not in the bundle, or has the wrong payload type.
    #[error("{}: {message}", path.display())]
    Lookup {
        /// The manifest file.
        path: PathBuf,
        /// What was asked for and what exists.
        message: String,
    },
    /// A pipeline tried to replace a bundle another pipeline owns.
    #[error(
        "{}: the bundle belongs to the pipeline {owner}, and {writer} may not replace it: give one of \
         them another output, or bake with --force to take the bundle over",
        path.display()
    )]
    Owned {
        /// The bundle directory.
        path: PathBuf,
        /// The pipeline that owns it.
        owner: String,
        /// The pipeline that tried to write it.
        writer: String,
    },
    /// Data handed to a writer is inconsistent (wrong byte count, duplicate id).
    #[error("{0}")]
    InvalidData(String),
    /// A bundle (the one a commit would make, or one on disk) is over its budget; a commit
    /// then commits nothing.
    #[error(
        "{}: over its budget (a bake commits nothing over it): {}",
        path.display(),
        overruns.iter().map(ToString::to_string).collect::<Vec<_>>().join("; ")
    )]
    OverBudget {
        /// The bundle directory.
        path: PathBuf,
        /// Every figure over its budget.
        overruns: Vec<crate::budget::Overrun>,
    },
}

impl BundleError {
    /// A short stable name of the error's class (`input`, `limit`, …), for tests and tools
    /// that sort errors without parsing messages.
    pub fn class(&self) -> &'static str {
        match self {
            BundleError::Io { .. } => "io",
            BundleError::ManifestSyntax { .. } => "manifest_syntax",
            BundleError::UnsupportedVersion { .. } => "unsupported_version",
            BundleError::InvalidAsset { .. } => "invalid_asset",
            BundleError::Payload { .. } => "payload",
            BundleError::Ktx2 { .. } => "ktx2",
            BundleError::Limit { .. } => "limit",
            BundleError::Lookup { .. } => "lookup",
            BundleError::Owned { .. } => "owned",
            BundleError::InvalidData(_) => "invalid_data",
            BundleError::OverBudget { .. } => "budget",
        }
    }

    /// True when the error comes from the operating system (missing file, permissions, full
    /// disk) rather than from the content of a file.
    pub fn is_io(&self) -> bool {
        matches!(self, BundleError::Io { .. })
    }

    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        BundleError::Io { path: path.into(), error: source }
    }
}
