//! One run of a batch: reused when its inputs are the ones it was made from,
//! else evaluated as `mapgauge eval` does, its files in `<sequence>/<method>/`.

use super::Run;
use crate::cloud::{self, MapSource};
use crate::record::{ResultFile, write_atomic};
use crate::report::{self, HashedInputs};
use crate::survey::{Geodetic, SurveyOptions, read_survey_for_map};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// What became of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Evaluated now.
    Evaluated,
    /// Its earlier result was kept: same inputs, settings and version.
    Reused,
    /// It could not produce a result (`error` says why).
    Failed,
}

/// A run's outcome: its result, or why there is none.
#[derive(Debug, Clone)]
pub struct RunRecord {
    /// Sequence.
    pub sequence: String,
    /// Method.
    pub method: String,
    /// Evaluated, reused or failed.
    pub status: Status,
    /// Why it failed.
    pub error: Option<String>,
    /// The result, unless it failed.
    pub result: Option<ResultFile>,
    /// Wall time of the run, hashing included (s).
    pub seconds: f64,
}

/// What a finished run was made from: the file that marks it finished,
/// written last, so a run stopped half-way is evaluated again.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Made {
    mapgauge_version: String,
    /// (role, BLAKE3) of the map, the survey and the configuration file.
    inputs: Vec<(String, String)>,
    /// BLAKE3 of the effective configuration (overrides included).
    config: String,
    /// BLAKE3 of the `result.json` it wrote: a result written over it since
    /// (an `eval --out` into the folder) is not this run's.
    #[serde(default)]
    result: String,
}

/// The marker's name in a run's folder.
pub(super) const MADE: &str = "batch-run.json";

/// Evaluates `run` into `out/<sequence>/<method>/`, or reuses what is there.
/// Never panics: a bug in one run is that run's failure, not the batch's.
pub fn run_one(run: &Run, out: &Path) -> RunRecord {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run_or_reuse(run, out)))
        .unwrap_or_else(|_| RunRecord {
            sequence: run.sequence.clone(),
            method: run.method.clone(),
            status: Status::Failed,
            error: Some("internal error: the run panicked (please report it)".into()),
            result: None,
            seconds: 0.0,
        })
}

fn run_or_reuse(run: &Run, out: &Path) -> RunRecord {
    let t0 = std::time::Instant::now();
    let outcome = evaluate_or_reuse(run, &out.join(run.dir()));
    let (status, result, error) = match outcome {
        Ok((status, r)) => (status, Some(r), None),
        Err(e) => {
            let dir = out.join(run.dir());
            let _ = std::fs::remove_file(dir.join(MADE));
            let _ = write_atomic(&dir.join("error.txt"), format!("{e}\n").as_bytes());
            (Status::Failed, None, Some(e.to_string()))
        }
    };
    RunRecord {
        sequence: run.sequence.clone(),
        method: run.method.clone(),
        status,
        error,
        result,
        seconds: t0.elapsed().as_secs_f64(),
    }
}

fn evaluate_or_reuse(run: &Run, dir: &Path) -> Result<(Status, ResultFile)> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let inputs = [&run.map, &run.survey];
    let inputs: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
    crate::render::refuse_overwriting_inputs(dir, &inputs)?;
    // Every file the result depends on: the map (a tiled map's tiles and
    // metadata), the survey, the configuration file, the hints it names and
    // a tiled map's projector.
    let projector = cloud::map_projector(&run.map)?;
    let mut roles: Vec<(&str, &Path)> = vec![("map", &run.map), ("survey", &run.survey)];
    if let Some(c) = &run.config_file {
        roles.push(("config", c));
    }
    if let Some(h) = &run.config.frame.hints {
        roles.push(("hints", h));
    }
    if let Some(p) = &projector {
        roles.push(("projector", p));
    }
    let never = AtomicBool::new(false);
    let hashed = report::hash_inputs(&roles, &never)?
        .ok_or_else(|| Error::Input("hashing the inputs was stopped".into()))?;
    let mut made = Made {
        mapgauge_version: env!("CARGO_PKG_VERSION").into(),
        inputs: hashed
            .files
            .iter()
            .map(|f| (f.role.clone(), f.blake3.clone()))
            .collect(),
        config: run.config.settings_hash(),
        result: String::new(),
    };
    if let Some(r) = reusable(dir, &made) {
        return Ok((Status::Reused, r));
    }
    let _ = std::fs::remove_file(dir.join(MADE));
    let _ = std::fs::remove_file(dir.join("error.txt"));
    let result = evaluate(run, dir, hashed, &inputs)?;
    made.result = blake3::hash(result.to_json().as_bytes())
        .to_hex()
        .to_string();
    let json = serde_json::to_string_pretty(&made).unwrap_or_default() + "\n";
    write_atomic(&dir.join(MADE), json.as_bytes())?;
    Ok((Status::Evaluated, result))
}

/// The earlier result in `dir`, when it was made from the same inputs,
/// settings and version.
fn reusable(dir: &Path, made: &Made) -> Option<ResultFile> {
    let text = std::fs::read_to_string(dir.join(MADE)).ok()?;
    let before: Made = serde_json::from_str(&text).ok()?;
    let same_inputs = Made {
        result: before.result.clone(),
        ..made.clone()
    };
    if before != same_inputs {
        return None;
    }
    let bytes = std::fs::read(dir.join("result.json")).ok()?;
    if blake3::hash(&bytes).to_hex().as_str() != before.result {
        return None;
    }
    ResultFile::from_json_file(&dir.join("result.json")).ok()
}

/// The pipeline on one map, its outputs written as `eval --out` writes them.
fn evaluate(run: &Run, dir: &Path, hashed: HashedInputs, inputs: &[&Path]) -> Result<ResultFile> {
    let cfg = &run.config;
    let origin = cfg
        .frame
        .origin
        .map(|[lat, lon, alt]| Geodetic { lat, lon, alt });
    let projector = cloud::map_projector(&run.map)?;
    let survey = read_survey_for_map(&run.survey, &SurveyOptions { origin }, projector.as_deref())?;
    if origin.is_some() && survey.frame == crate::survey::SurveyFrame::Local {
        return Err(Error::Param(format!(
            "frame.origin applies to WGS84 (lat,lon) surveys, but {} is in local x,y coordinates",
            run.survey.display()
        )));
    }
    let ev = crate::pipeline::run(MapSource::File(&run.map), &survey, cfg, |_, _| {})?;
    let mut result = ResultFile::from_evaluation(&ev, &survey, &run.survey.display().to_string());
    cfg.finish(&mut result);
    crate::render::write_outputs(&result, dir)?;
    let html = dir.join("report.html");
    report::write_report(
        &ev,
        &result,
        cfg,
        Some(hashed),
        inputs,
        Some(&html),
        None,
        None,
    )?;
    Ok(result)
}
