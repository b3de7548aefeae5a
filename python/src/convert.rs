//! Arguments from Python: the configuration as JSON, point arrays, and the
//! progress callback called from Rust's threads.

use crate::errors::{ParamError, err, input_err, json_msg};
use mapgauge::Point;
use mapgauge::pipeline::Config;
use numpy::ndarray::{Array2, ArrayView2};
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use std::time::{Duration, Instant};

/// A configuration from the JSON of a Python dict: keys exactly those of
/// `mapgauge eval --print-config`, unknown keys are errors, ranges checked.
pub(crate) fn config_from_json(json: Option<&str>) -> PyResult<Config> {
    let cfg: Config = match json {
        None => Config::default(),
        Some(s) => serde_json::from_str(s)
            .map_err(|e| ParamError::new_err(format!("config: {}", json_msg(&e))))?,
    };
    cfg.validate().map_err(err)?;
    Ok(cfg)
}

/// Copies an (N, 3) array into points (the pipeline runs without the GIL,
/// so it cannot borrow memory Python may change meanwhile).
pub(crate) fn points_of<T: Copy + Into<f64>>(
    a: ArrayView2<'_, T>,
    what: &str,
) -> PyResult<Vec<Point>> {
    if a.ncols() != 3 {
        return Err(input_err(format!(
            "{what}: expected an (N, 3) array, got shape ({}, {})",
            a.nrows(),
            a.ncols()
        )));
    }
    Ok(a.rows()
        .into_iter()
        .map(|r| Point::new(r[0].into(), r[1].into(), r[2].into()))
        .collect())
}

/// Points from a float64 or float32 (N, 3) array.
pub(crate) fn points_from_any(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<Point>> {
    if let Ok(a) = obj.extract::<PyReadonlyArray2<'_, f64>>() {
        return points_of(a.as_array(), what);
    }
    if let Ok(a) = obj.extract::<PyReadonlyArray2<'_, f32>>() {
        return points_of(a.as_array(), what);
    }
    Err(input_err(format!(
        "{what}: expected a 2-D float64 or float32 numpy array of shape (N, 3)"
    )))
}

/// (N, 3) float64 array of points.
pub(crate) fn points_array<'py>(py: Python<'py>, pts: &[Point]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = pts.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    Array2::from_shape_vec((pts.len(), 3), flat)
        .expect("3 values per point")
        .into_pyarray(py)
}

/// Calls a Python progress callback at most every 0.1 s from Rust code that
/// runs without the GIL; the first exception it raises is kept for the end
/// (the pipeline itself cannot be interrupted) and stops further calls.
pub(crate) struct Progress {
    cb: Option<Py<PyAny>>,
    last: Option<Instant>,
    error: Option<PyErr>,
}

impl Progress {
    pub(crate) fn new(cb: Option<Py<PyAny>>) -> Self {
        Progress {
            cb,
            last: None,
            error: None,
        }
    }
    pub(crate) fn call(&mut self, done: u64, total: u64) {
        let Some(cb) = &self.cb else { return };
        if total == 0 {
            return; // points in memory: nothing streams
        }
        if self.error.is_some() {
            return;
        }
        let now = Instant::now();
        let end = total > 0 && done >= total;
        if !end
            && self
                .last
                .is_some_and(|l| now - l < Duration::from_millis(100))
        {
            return;
        }
        self.last = Some(now);
        if let Err(e) = Python::attach(|py| cb.call1(py, (done, total)).map(drop)) {
            self.error = Some(e);
        }
    }
    pub(crate) fn finish(self) -> PyResult<()> {
        match self.error {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}
