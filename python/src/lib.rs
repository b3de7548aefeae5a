//! `mapgauge._mapgauge`: the Rust side of the Python package. Each function
//! here is a thin shim over the library: arguments are checked, the GIL is
//! released while Rust works, and every `mapgauge::Error` becomes a
//! `MapgaugeError` (or a subclass: `errors.rs`) carrying the CLI's one-line
//! message. The public API (argument normalisation, result objects) is
//! `python/mapgauge/__init__.py`; `survey.rs` holds the survey object,
//! `convert.rs` the arguments' conversions.

use mapgauge::accuracy::{self, ScoreOptions};
use mapgauge::cloud::{self, MapSource};
use mapgauge::pipeline::{self, Config, Evaluation, MetricsConfig};
use mapgauge::record::{ResultFile, SCHEMA, refuse_overwrite};
use mapgauge::render::{self, OutputFormat};
use mapgauge::report;
use mapgauge::survey::{Estimate, EstimateStatus};
use mapgauge::synth::{self, SynthParams};
use mapgauge::{Error, Point};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

mod batch;
mod convert;
mod errors;
mod survey;

use convert::{Progress, config_from_json, points_array, points_from_any, points_of};
use errors::{
    FileError, FrameNotFoundError, MapgaugeError, NotMetresError, ParamError, ParseError,
    TooFewFoundError, err, input_err, json_msg,
};
use survey::PySurvey;

/// An evaluation's Rust side: the pipeline's output, its result file and
/// what is needed to write the report.
#[pyclass(frozen, module = "mapgauge._mapgauge")]
struct EvalCore {
    ev: Evaluation,
    result: ResultFile,
    cfg: Config,
    map_path: Option<PathBuf>,
    survey_path: Option<PathBuf>,
}

#[pymethods]
impl EvalCore {
    /// result.json's exact text.
    fn to_json(&self) -> String {
        self.result.to_json()
    }
    /// The loose or tight crop of target `index` (survey order), (K, 3).
    fn crop<'py>(
        &self,
        py: Python<'py>,
        index: usize,
        kind: &str,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let t = self
            .ev
            .targets
            .get(index)
            .ok_or_else(|| input_err(format!("target index {index} out of range")))?;
        match kind {
            "loose" => Ok(points_array(py, &t.loose)),
            "tight" => Ok(points_array(py, &t.tight)),
            k => Err(input_err(format!("crop kind `{k}`: loose or tight"))),
        }
    }
    /// The accepted sample corners of target `index`, (S, 3), map frame.
    fn samples<'py>(&self, py: Python<'py>, index: usize) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let t = self
            .ev
            .targets
            .get(index)
            .ok_or_else(|| input_err(format!("target index {index} out of range")))?;
        Ok(match &t.outcome {
            Ok(f) => points_array(py, &f.located.samples),
            Err(_) => points_array(py, &[]),
        })
    }
    /// Writes result.json, targets.csv, pairs.csv and (with `report`)
    /// report.html into `out`, as `mapgauge eval --out` does.
    fn write(&self, py: Python<'_>, out: PathBuf, report: bool) -> PyResult<()> {
        py.detach(|| {
            let mut inputs: Vec<(&str, &Path)> = Vec::new();
            if let Some(m) = &self.map_path {
                inputs.push(("map", m));
            }
            if let Some(s) = &self.survey_path {
                inputs.push(("survey", s));
            }
            let in_paths: Vec<&Path> = inputs.iter().map(|i| i.1).collect();
            std::fs::create_dir_all(&out).map_err(|e| Error::io(&out, e))?;
            render::refuse_overwriting_inputs(&out, &in_paths)?;
            refuse_overwrite(&out.join("report.html"), &in_paths)?;
            render::write_outputs(&self.result, &out)?;
            if report {
                let hashed = report::hash_inputs(&inputs, &AtomicBool::new(false))?;
                let html = out.join("report.html");
                report::write_report(
                    &self.ev,
                    &self.result,
                    &self.cfg,
                    hashed,
                    &in_paths,
                    Some(&html),
                    None,
                    None,
                )?;
            }
            Ok(())
        })
        .map_err(err)
    }
    /// Writes the checkpoints file, as `eval --checkpoints` does.
    #[pyo3(signature = (path, crs=None))]
    fn write_checkpoints(
        &self,
        py: Python<'_>,
        path: PathBuf,
        crs: Option<String>,
    ) -> PyResult<String> {
        let inputs: Vec<&Path> = [&self.map_path, &self.survey_path]
            .into_iter()
            .flatten()
            .map(|p| p.as_path())
            .collect();
        write_checkpoints(py, &self.result, &inputs, &path, crs)
    }
}

/// `eval`'s and `errors`' `--checkpoints`: refuses an input, then writes;
/// returns the CRS the positions are in.
fn write_checkpoints(
    py: Python<'_>,
    result: &ResultFile,
    inputs: &[&Path],
    path: &Path,
    crs: Option<String>,
) -> PyResult<String> {
    py.detach(|| {
        let epsg = crs
            .as_deref()
            .map(mapgauge::checkpoints::parse_epsg)
            .transpose()?;
        mapgauge::checkpoints::check_path(path)?;
        refuse_overwrite(path, inputs)?;
        mapgauge::checkpoints::write(path, result, epsg).map(|c| c.label())
    })
    .map_err(err)
}

/// Runs the whole pipeline (`mapgauge eval`) on a map file or an (N, 3) array.
#[pyfunction]
#[pyo3(signature = (map, survey, config_json=None, crops=None, progress=None))]
fn _evaluate(
    py: Python<'_>,
    map: &Bound<'_, PyAny>,
    survey: &Bound<'_, PySurvey>,
    config_json: Option<&str>,
    crops: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<EvalCore> {
    let cfg = config_from_json(config_json)?;
    let (pts, map_path) = match map.extract::<PathBuf>() {
        Ok(p) => (None, Some(p)),
        Err(_) => (Some(points_from_any(map, "map")?), None),
    };
    let survey = survey.get();
    let mut prog = Progress::new(progress);
    let run = py.detach(|| {
        let source = match (&pts, &map_path) {
            (Some(p), _) => MapSource::Points(p),
            (None, Some(path)) => MapSource::File(path),
            (None, None) => unreachable!("a map is either points or a path"),
        };
        let cb = |b, t| prog.call(b, t);
        match &crops {
            Some(dir) => pipeline::run_with_crops(source, &survey.inner, dir, &cfg, cb),
            None => pipeline::run(source, &survey.inner, &cfg, cb),
        }
    });
    prog.finish()?;
    let ev = run.map_err(err)?;
    // The same file as the CLI's, caveats included.
    let mut result = ResultFile::from_evaluation(&ev, &survey.inner, &survey.name);
    // The scores and gates as `eval` gives them, so `to_dict()` stays its
    // result.json.
    cfg.finish(&mut result);
    Ok(EvalCore {
        ev,
        result,
        cfg,
        map_path,
        survey_path: survey.path.clone(),
    })
}

/// The full configuration (defaults merged with `config_json`) as JSON and as
/// the TOML `--print-config` prints.
#[pyfunction]
#[pyo3(signature = (config_json=None))]
fn _config(config_json: Option<&str>) -> PyResult<(String, String)> {
    let cfg = config_from_json(config_json)?;
    let json = serde_json::to_string(&cfg).map_err(|e| input_err(e.to_string()))?;
    Ok((json, cfg.to_toml()))
}

/// Scores given positions against a survey (`mapgauge errors`).
#[pyclass(frozen, module = "mapgauge._mapgauge")]
struct ScoreCore {
    result: ResultFile,
    inputs: Vec<PathBuf>,
}

#[pymethods]
impl ScoreCore {
    /// result.json's exact text.
    fn to_json(&self) -> String {
        self.result.to_json()
    }
    /// Writes result.json, targets.csv and pairs.csv into `out`.
    fn write(&self, py: Python<'_>, out: PathBuf) -> PyResult<()> {
        py.detach(|| {
            std::fs::create_dir_all(&out).map_err(|e| Error::io(&out, e))?;
            let inputs: Vec<&Path> = self.inputs.iter().map(|p| p.as_path()).collect();
            render::refuse_overwriting_inputs(&out, &inputs)?;
            render::write_outputs(&self.result, &out)
        })
        .map_err(err)
    }
    /// Writes the checkpoints file, as `errors --checkpoints` does.
    #[pyo3(signature = (path, crs=None))]
    fn write_checkpoints(
        &self,
        py: Python<'_>,
        path: PathBuf,
        crs: Option<String>,
    ) -> PyResult<String> {
        let inputs: Vec<&Path> = self.inputs.iter().map(|p| p.as_path()).collect();
        write_checkpoints(py, &self.result, &inputs, &path, crs)
    }
}

/// `estimates` is an estimates CSV path, or `(ids, (K, 3) array, has_z,
/// reasons)` where a reason marks a target not found.
#[pyfunction]
#[pyo3(signature = (survey, estimates, metrics_json=None))]
fn _errors(
    py: Python<'_>,
    survey: &Bound<'_, PySurvey>,
    estimates: &Bound<'_, PyAny>,
    metrics_json: Option<&str>,
) -> PyResult<ScoreCore> {
    let m: MetricsConfig = match metrics_json {
        None => MetricsConfig::default(),
        Some(s) => {
            serde_json::from_str(s).map_err(|e| input_err(format!("metrics: {}", json_msg(&e))))?
        }
    };
    m.validate().map_err(err)?;
    let opts = ScoreOptions {
        method: m.align,
        dim: m.dim,
        survey_sigma: m.survey_sigma_h.map(|h| (h, m.survey_sigma_v)),
        vertical: None,
        threshold: m.threshold_m,
    };
    let survey = survey.get();
    let mut inputs: Vec<PathBuf> = survey.path.iter().cloned().collect();
    let est: Vec<Estimate> = if let Ok(path) = estimates.extract::<PathBuf>() {
        let e = py
            .detach(|| mapgauge::survey::read_estimates(&path))
            .map_err(err)?;
        inputs.push(path);
        e
    } else {
        let (ids, xyz, has_z, reasons): (
            Vec<String>,
            PyReadonlyArray2<'_, f64>,
            bool,
            Vec<Option<String>>,
        ) = estimates.extract()?;
        let pts = points_of(xyz.as_array(), "estimates")?;
        if pts.len() != ids.len() || reasons.len() != ids.len() {
            return Err(input_err(format!(
                "estimates: {} ids for {} positions",
                ids.len(),
                pts.len()
            )));
        }
        let mut seen = HashSet::new();
        let mut v = Vec::with_capacity(ids.len());
        for ((id, p), reason) in ids.into_iter().zip(pts).zip(reasons) {
            if !seen.insert(id.clone()) {
                return Err(input_err(format!("estimates: duplicate target id `{id}`")));
            }
            let status = match reason {
                Some(reason) => EstimateStatus::NotFound { reason },
                None => {
                    if !(p.x.is_finite() && p.y.is_finite() && (!has_z || p.z.is_finite())) {
                        return Err(input_err(format!(
                            "estimates: target `{id}` has a non-finite coordinate"
                        )));
                    }
                    EstimateStatus::Found(Point::new(p.x, p.y, if has_z { p.z } else { 0.0 }))
                }
            };
            v.push(Estimate { id, status, has_z });
        }
        v
    };
    let acc = py
        .detach(|| accuracy::score(&survey.inner, &est, &opts))
        .map_err(err)?;
    let mut result = ResultFile::from_accuracy(&acc, &survey.inner);
    // As `errors --score`: the scores its metrics ask for.
    mapgauge::scores::apply(&m.scores, &mut result);
    Ok(ScoreCore { result, inputs })
}

/// Reads every point of a map file (any format), streamed chunk by chunk and
/// kept only inside `bounds` = (min, max), each (x, y) or (x, y, z).
#[pyfunction]
#[pyo3(signature = (path, bounds=None))]
fn read_points<'py>(
    py: Python<'py>,
    path: PathBuf,
    bounds: Option<(Vec<f64>, Vec<f64>)>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (lo, hi) = match &bounds {
        None => ([f64::NEG_INFINITY; 3], [f64::INFINITY; 3]),
        Some((a, b)) if a.len() == b.len() && (a.len() == 2 || a.len() == 3) => {
            let (mut lo, mut hi) = ([f64::NEG_INFINITY; 3], [f64::INFINITY; 3]);
            lo[..a.len()].copy_from_slice(a);
            hi[..b.len()].copy_from_slice(b);
            if lo
                .iter()
                .zip(&hi)
                .any(|(l, h)| l.is_nan() || h.is_nan() || l > h)
            {
                return Err(input_err(
                    "bounds: each minimum must be a number no larger than its maximum",
                ));
            }
            (lo, hi)
        }
        Some(_) => {
            return Err(input_err(
                "bounds: expected (min, max) with min and max both (x, y) or (x, y, z)",
            ));
        }
    };
    let flat = py
        .detach(|| -> mapgauge::Result<Vec<f64>> {
            let mut r = cloud::open(&path)?;
            let (mut buf, mut flat) = (Vec::new(), Vec::new());
            while r.next_chunk(&mut buf)? {
                for p in &buf {
                    let c = [p.x, p.y, p.z];
                    if (0..3).all(|k| c[k] >= lo[k] && c[k] <= hi[k]) {
                        flat.extend_from_slice(&c);
                    }
                }
            }
            Ok(flat)
        })
        .map_err(err)?;
    let n = flat.len() / 3;
    Ok(Array2::from_shape_vec((n, 3), flat)
        .expect("3 values per point")
        .into_pyarray(py))
}

/// The paper's localisation on a tight crop: a dict of the located target.
#[pyfunction]
#[pyo3(signature = (points, up=None, params_json=None))]
fn _locate<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    up: Option<[f64; 3]>,
    params_json: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let params: mapgauge::locate::LocateParams = match params_json {
        None => Default::default(),
        Some(s) => {
            serde_json::from_str(s).map_err(|e| input_err(format!("locate: {}", json_msg(&e))))?
        }
    };
    let pts = points_from_any(points, "points")?;
    let up = up.map(|u| Point::new(u[0], u[1], u[2]).coords);
    let l = py
        .detach(|| mapgauge::locate::locate(&pts, up, &params))
        .map_err(|e| input_err(format!("localisation failed: {e}")))?;
    let d = PyDict::new(py);
    d.set_item("corner", vec![l.corner.x, l.corner.y, l.corner.z])?;
    d.set_item("std", l.std.to_vec())?;
    d.set_item("spread", l.spread())?;
    d.set_item("accepted", l.accepted)?;
    d.set_item("attempts", l.attempts)?;
    d.set_item("plate_angle_deg", l.plate_angle_deg)?;
    d.set_item(
        "normals",
        vec![l.plates[0].normal.to_vec(), l.plates[1].normal.to_vec()],
    )?;
    d.set_item("inliers", vec![l.plates[0].inliers, l.plates[1].inliers])?;
    d.set_item("samples", points_array(py, &l.samples))?;
    Ok(d)
}

/// A synthetic LiDAR scene with known truth (`mapgauge synth`, in memory):
/// points, its exact survey and the truth as JSON.
#[pyfunction]
#[pyo3(signature = (params_json=None))]
fn _synth<'py>(
    py: Python<'py>,
    params_json: Option<&str>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, PySurvey, String)> {
    let params: SynthParams = match params_json {
        None => SynthParams::default(),
        Some(s) => {
            serde_json::from_str(s).map_err(|e| input_err(format!("synth: {}", json_msg(&e))))?
        }
    };
    let (pts, truth) = py
        .detach(|| -> mapgauge::Result<_> {
            let mut pts = Vec::new();
            let truth = synth::generate(&params, &mut |p| {
                pts.extend_from_slice(p);
                Ok(())
            })?;
            Ok((pts, truth))
        })
        .map_err(err)?;
    let survey = PySurvey {
        inner: truth.survey(),
        name: "<memory>".into(),
        path: None,
    };
    let truth_json = serde_json::to_string(&truth).map_err(|e| input_err(e.to_string()))?;
    Ok((points_array(py, &pts), survey, truth_json))
}

/// The paper's Tables I and II over several results, as `mapgauge table`
/// prints them, and the warnings it prints (runs scored against different
/// surveys). Each run is (name, "path" | "json", path or JSON text).
#[pyfunction]
fn _table(
    py: Python<'_>,
    runs: Vec<(String, String, String)>,
    format: &str,
    which: &str,
) -> PyResult<(String, Vec<String>)> {
    let fmt: OutputFormat = format.parse().map_err(err)?;
    let which: render::Which = which.parse().map_err(err)?;
    let results = py
        .detach(|| {
            runs.iter()
                .map(|(name, kind, payload)| match kind.as_str() {
                    "path" => ResultFile::from_json_file(Path::new(payload)),
                    _ => {
                        let r: ResultFile = serde_json::from_str(payload).map_err(|e| {
                            Error::Input(format!("{name}: not a mapgauge result: {}", json_msg(&e)))
                        })?;
                        if r.schema != SCHEMA {
                            return Err(Error::Input(format!(
                                "{name}: schema `{}`, expected `{SCHEMA}`",
                                r.schema
                            )));
                        }
                        Ok(r)
                    }
                })
                .collect::<mapgauge::Result<Vec<_>>>()
        })
        .map_err(err)?;
    let named: Vec<(String, &ResultFile)> = runs
        .iter()
        .map(|r| r.0.clone())
        .zip(results.iter())
        .collect();
    Ok((
        render::tables_page(&named, fmt, which, false, &render::stored_scores(&named)),
        render::survey_mismatches(&named),
    ))
}

/// The extension module.
#[pymodule]
fn _mapgauge(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("MapgaugeError", m.py().get_type::<MapgaugeError>())?;
    m.add("TooFewFoundError", m.py().get_type::<TooFewFoundError>())?;
    m.add(
        "FrameNotFoundError",
        m.py().get_type::<FrameNotFoundError>(),
    )?;
    m.add("NotMetresError", m.py().get_type::<NotMetresError>())?;
    m.add("ParseError", m.py().get_type::<ParseError>())?;
    m.add("ParamError", m.py().get_type::<ParamError>())?;
    m.add("FileError", m.py().get_type::<FileError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<PySurvey>()?;
    m.add_class::<EvalCore>()?;
    m.add_class::<ScoreCore>()?;
    m.add_function(wrap_pyfunction!(survey::read_survey, m)?)?;
    m.add_function(wrap_pyfunction!(survey::_survey_from_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(_evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(_config, m)?)?;
    m.add_function(wrap_pyfunction!(_errors, m)?)?;
    m.add_function(wrap_pyfunction!(read_points, m)?)?;
    m.add_function(wrap_pyfunction!(_locate, m)?)?;
    m.add_function(wrap_pyfunction!(_synth, m)?)?;
    m.add_function(wrap_pyfunction!(_table, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_plan, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_run, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_summary, m)?)?;
    Ok(())
}
