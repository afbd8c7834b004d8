//! One error type for the core crate. Every variant that comes from a file names the file, and
//! every variant that comes from a field of a file names the field, so that a user with a corrupt
//! download knows what to look at.

use std::path::PathBuf;

/// Errors from loading, validating and writing FieldProbe data.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or writing a file failed at the OS level.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file was read but its content is not what the format requires.
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    /// A mesh is unusable (no faces, non-finite vertices, degenerate extent).
    #[error("{path}: invalid mesh: {message}")]
    Mesh { path: PathBuf, message: String },
    /// A parameter passed by the caller is out of range.
    #[error("invalid argument: {0}")]
    Invalid(String),
}

impl Error {
    /// An [`Error::Io`] for `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }

    /// An [`Error::Format`] for `path`.
    pub fn format(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Self::Format {
            path: path.into(),
            message: message.into(),
        }
    }
}

/// Result with the core [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
