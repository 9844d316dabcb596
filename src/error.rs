//! The crate's one error type.
//!
//! Errors about files name the file, the place in it (object / polygon, or byte
//! offset) and what was expected against what was found. Context strings are added
//! only in the binary (`main.rs`, with anyhow); the library returns [`Error`].

use std::path::PathBuf;

/// Every failure the library reports.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An I/O failure on a named file. (The cause is part of the message, not a
    /// chained source, so that `{:#}` does not print it twice.)
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        cause: std::io::Error,
    },
    /// Input that does not satisfy its format: names the file, the place, what was
    /// expected and what was found.
    #[error("{path}: {place}: expected {expected}, found {found}")]
    Invalid {
        /// The file (or a pseudo-name such as `<embedded cornell box>`).
        path: PathBuf,
        /// Where in the file: `object "room", polygon 3`, `byte 1024`, `line 7`…
        place: String,
        /// What the format requires there.
        expected: String,
        /// What the file holds there.
        found: String,
    },
    /// A request that cannot be carried out with the given arguments.
    #[error("{0}")]
    Usage(String),
    /// A solve whose answer cannot be right (its power balance or its linear solve
    /// says so); the message gives the measures.
    #[error("{0}")]
    Unsound(String),
}

/// Shorthand for results of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An [`Error::Io`] on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            cause: source,
        }
    }

    /// An [`Error::Invalid`] with every part named.
    pub fn invalid(
        path: impl Into<PathBuf>,
        place: impl Into<String>,
        expected: impl Into<String>,
        found: impl Into<String>,
    ) -> Self {
        Error::Invalid {
            path: path.into(),
            place: place.into(),
            expected: expected.into(),
            found: found.into(),
        }
    }
}
