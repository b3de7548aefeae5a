//! The one error type of the library.

use std::path::PathBuf;

/// Everything that can go wrong in mapgauge.
///
/// Messages are one line and name the file (and line or field) they are about,
/// so the CLI can print `error: {err}` and the user knows where to look.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The operating system refused a read or write.
    #[error("{}: {source}", path.display())]
    Io {
        /// File being read or written.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// A file's contents do not follow its format.
    #[error("{}: {msg}", path.display())]
    Format {
        /// File being parsed.
        path: PathBuf,
        /// What is wrong, and where in the file (line, field, byte offset).
        msg: String,
    },
    /// A text table (survey, estimates) has a bad row or column.
    #[error("{}{}: {msg}", path.display(), line_suffix(*line))]
    Table {
        /// File being parsed.
        path: PathBuf,
        /// 1-based line number, 0 when the problem is not tied to a line.
        line: u64,
        /// What is wrong.
        msg: String,
    },
    /// The input is well formed but cannot produce a result (too few targets, ...).
    #[error("{0}")]
    Input(String),
    /// A parameter or configuration value is out of range.
    #[error("invalid parameter: {0}")]
    Param(String),
    /// Too few targets were located to align the map to the survey: the run
    /// cannot score. `msg` says why each was not found and what to try.
    #[error("{msg}")]
    TooFewFound {
        /// Targets located.
        found: usize,
        /// Targets the alignment needs.
        need: usize,
        /// The whole explanation, one line.
        msg: String,
    },
    /// Map-wide detection could not match the map's target-shaped objects to
    /// the survey, so the map's frame is unknown.
    #[error("{msg}")]
    FrameNotFound {
        /// Target-shaped objects detected in the map.
        detections: usize,
        /// What was seen and what to try.
        msg: String,
    },
    /// The map's points are spread too thin for coordinates in metres (a
    /// map in millimetres or another unit): reading stopped before its
    /// memory grew with that extent.
    #[error("{msg}")]
    NotMetres {
        /// The points' horizontal spread when reading stopped (m).
        extent: [f64; 2],
        /// What was seen and what to do.
        msg: String,
    },
}

impl Error {
    /// Wraps an I/O error with the path it concerns.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
    /// A format error in `path`.
    pub fn format(path: impl Into<PathBuf>, msg: impl Into<String>) -> Self {
        Error::Format {
            path: path.into(),
            msg: msg.into(),
        }
    }
    /// A table error in `path` at 1-based `line`.
    pub fn table(path: impl Into<PathBuf>, line: u64, msg: impl Into<String>) -> Self {
        Error::Table {
            path: path.into(),
            line,
            msg: msg.into(),
        }
    }
}

/// `:<line>` after a file name, or nothing when the line is unknown (0).
fn line_suffix(line: u64) -> String {
    if line == 0 {
        String::new()
    } else {
        format!(":{line}")
    }
}

/// `Result` with [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
