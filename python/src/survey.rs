//! The survey as a Python object, read from a CSV or built from arrays.

use crate::convert::{points_array, points_of};
use crate::errors::{err, input_err};
use mapgauge::Point;
use mapgauge::survey::{Geodetic, Survey, SurveyFrame, SurveyOptions, SurveyTarget};
use numpy::{PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use std::collections::HashSet;
use std::path::PathBuf;

/// A survey: the ground truth every map is measured against.
#[pyclass(frozen, name = "Survey", module = "mapgauge")]
pub(crate) struct PySurvey {
    pub(crate) inner: Survey,
    /// How result.json names it: the path as given, or `<memory>`.
    pub(crate) name: String,
    pub(crate) path: Option<PathBuf>,
}

#[pymethods]
impl PySurvey {
    /// Target ids in survey order.
    #[getter]
    fn ids(&self) -> Vec<String> {
        self.inner.targets.iter().map(|t| t.id.clone()).collect()
    }
    /// (M, 3) float64 reference points (antenna height removed), z = NaN where
    /// the survey gives no height.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let pts: Vec<Point> = self
            .inner
            .targets
            .iter()
            .map(|t| {
                let mut p = t.reference();
                if !t.has_z {
                    p.z = f64::NAN;
                }
                p
            })
            .collect();
        points_array(py, &pts)
    }
    /// True when every target has a height.
    #[getter]
    fn has_z(&self) -> bool {
        self.inner.has_z()
    }
    /// `local`, `wgs84_enu` or `wgs84_map`.
    #[getter]
    fn frame(&self) -> &'static str {
        match self.inner.frame {
            SurveyFrame::Local => "local",
            SurveyFrame::Wgs84Enu => "wgs84_enu",
            SurveyFrame::Wgs84Map => "wgs84_map",
        }
    }
    /// The survey as result.json names it: the file as given, or `<memory>`.
    #[getter]
    fn name(&self) -> String {
        self.name.clone()
    }
    fn __len__(&self) -> usize {
        self.inner.targets.len()
    }
    fn __repr__(&self) -> String {
        format!(
            "Survey({}, {} targets, {})",
            self.name,
            self.inner.targets.len(),
            if self.inner.has_z() { "3d" } else { "2d" }
        )
    }
}

/// An ENU origin, checked as the CLI's `--origin` is.
pub(crate) fn geodetic(lat: f64, lon: f64, alt: f64) -> PyResult<Geodetic> {
    if !(-90.0..=90.0).contains(&lat) || !(-180.0..=360.0).contains(&lon) || !alt.is_finite() {
        return Err(input_err(
            "origin: latitude must be within ±90° and longitude within ±180°",
        ));
    }
    Ok(Geodetic { lat, lon, alt })
}

/// Reads a survey CSV exactly as `mapgauge eval --survey` does.
#[pyfunction]
#[pyo3(signature = (path, origin=None))]
pub(crate) fn read_survey(
    py: Python<'_>,
    path: PathBuf,
    origin: Option<Vec<f64>>,
) -> PyResult<PySurvey> {
    let origin = match origin.as_deref() {
        None => None,
        Some(&[lat, lon]) => Some(geodetic(lat, lon, 0.0)?),
        Some(&[lat, lon, alt]) => Some(geodetic(lat, lon, alt)?),
        Some(_) => return Err(input_err("origin: expected (lat, lon) or (lat, lon, alt)")),
    };
    let inner = py
        .detach(|| mapgauge::survey::read_survey(&path, &SurveyOptions { origin }))
        .map_err(err)?;
    Ok(PySurvey {
        inner,
        name: path.display().to_string(),
        path: Some(path),
    })
}

/// A local-frame survey from ids and an (M, 3) array (`has_z` false: heights unknown).
#[pyfunction]
pub(crate) fn _survey_from_arrays(
    ids: Vec<String>,
    xyz: PyReadonlyArray2<'_, f64>,
    has_z: bool,
) -> PyResult<PySurvey> {
    let pts = points_of(xyz.as_array(), "survey")?;
    if pts.len() != ids.len() {
        return Err(input_err(format!(
            "survey: {} ids for {} positions",
            ids.len(),
            pts.len()
        )));
    }
    let mut seen = HashSet::new();
    let mut targets = Vec::with_capacity(ids.len());
    for (i, (id, p)) in ids.into_iter().zip(pts).enumerate() {
        if id.trim().is_empty() {
            return Err(input_err(format!(
                "survey: target {} has an empty id",
                i + 1
            )));
        }
        if !seen.insert(id.clone()) {
            return Err(input_err(format!("survey: duplicate target id `{id}`")));
        }
        let z_ok = !has_z || p.z.is_finite();
        if !(p.x.is_finite() && p.y.is_finite() && z_ok) {
            return Err(input_err(format!(
                "survey: target `{id}` has a non-finite coordinate"
            )));
        }
        targets.push(SurveyTarget {
            id,
            position: Point::new(p.x, p.y, if has_z { p.z } else { 0.0 }),
            has_z,
            role: None,
            antenna_height: 0.0,
            model: Default::default(),
            size: None,
            line: i as u64 + 2,
        });
    }
    Ok(PySurvey {
        inner: Survey {
            targets,
            frame: SurveyFrame::Local,
            origin: None,
            exchanged: None,
        },
        name: "<memory>".into(),
        path: None,
    })
}
