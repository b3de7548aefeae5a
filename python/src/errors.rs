//! mapgauge's errors as Python exceptions: `MapgaugeError` (a `ValueError`)
//! and the subclasses a caller may act on, with their numbers as attributes.

use mapgauge::Error;
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::Path;

create_exception!(
    mapgauge,
    MapgaugeError,
    PyValueError,
    "Bad input or a failed evaluation; the message is the CLI's one-line error."
);

create_exception!(
    mapgauge,
    TooFewFoundError,
    MapgaugeError,
    "Too few targets were located to align the map to the survey (`found`, `need`)."
);
create_exception!(
    mapgauge,
    FrameNotFoundError,
    MapgaugeError,
    "Map-wide detection could not match the map to the survey: its frame is unknown."
);
create_exception!(
    mapgauge,
    ParseError,
    MapgaugeError,
    "A file's contents do not follow its format, or a table has a bad row (`path`, `line`: 0 when not tied to a line)."
);
create_exception!(
    mapgauge,
    ParamError,
    MapgaugeError,
    "A parameter or configuration value is out of range or unknown."
);
create_exception!(
    mapgauge,
    FileError,
    MapgaugeError,
    "The operating system refused a read or write (`path`, `errno`: None when it gave none)."
);
create_exception!(
    mapgauge,
    NotMetresError,
    MapgaugeError,
    "The map's points are spread too thin for metres (a map in millimetres?)."
);

/// The CLI's message as a Python exception: a subclass of `MapgaugeError`
/// for the failures a caller may act on, with their numbers as attributes.
pub(crate) fn err(e: Error) -> PyErr {
    let msg = e.to_string();
    match e {
        Error::TooFewFound { found, need, .. } => {
            let pe = TooFewFoundError::new_err(msg);
            Python::attach(|py| {
                let v = pe.value(py);
                let _ = v.setattr("found", found);
                let _ = v.setattr("need", need);
            });
            pe
        }
        Error::FrameNotFound { detections, .. } => {
            let pe = FrameNotFoundError::new_err(msg);
            Python::attach(|py| {
                let _ = pe.value(py).setattr("detections", detections);
            });
            pe
        }
        Error::NotMetres { .. } => NotMetresError::new_err(msg),
        Error::Format { path, .. } => with_path(ParseError::new_err(msg), &path, Some(0)),
        Error::Table { path, line, .. } => with_path(ParseError::new_err(msg), &path, Some(line)),
        Error::Param(_) => ParamError::new_err(msg),
        Error::Io { path, source } => {
            let pe = with_path(FileError::new_err(msg), &path, None);
            Python::attach(|py| {
                let _ = pe.value(py).setattr("errno", source.raw_os_error());
            });
            pe
        }
        _ => MapgaugeError::new_err(msg),
    }
}

/// `e` with the file it is about as `path` (and, for a parse error, `line`).
pub(crate) fn with_path(e: PyErr, path: &Path, line: Option<u64>) -> PyErr {
    Python::attach(|py| {
        let v = e.value(py);
        let _ = v.setattr("path", path.display().to_string());
        if let Some(line) = line {
            let _ = v.setattr("line", line);
        }
    });
    e
}

pub(crate) fn input_err(msg: impl Into<String>) -> PyErr {
    MapgaugeError::new_err(msg.into())
}

/// A serde_json error without its " at line 1 column 42" (the JSON was made
/// from a Python dict the user never saw as text).
pub(crate) fn json_msg(e: &serde_json::Error) -> String {
    let s = e.to_string();
    match s.rfind(" at line ") {
        Some(i) => s[..i].to_string(),
        None => s,
    }
}
