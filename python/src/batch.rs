//! `mapgauge.batch`: a manifest's runs one at a time, in whatever process
//! the caller's executor picks, then the summary from what they wrote.

use crate::errors::err;
use mapgauge::Error;
use mapgauge::batch::{
    Manifest, RawManifest, RunRecord, Status, run_one, summarise, write_summary,
};
use mapgauge::record::ResultFile;
use pyo3::prelude::*;
use std::path::Path;

/// The manifest: a TOML file (`kind` "path") or the runs as JSON, their
/// paths relative to `base`.
fn manifest(kind: &str, payload: &str, base: &str) -> mapgauge::Result<Manifest> {
    match kind {
        "path" => Manifest::read(Path::new(payload)),
        _ => {
            let raw: RawManifest = serde_json::from_str(payload)
                .map_err(|e| Error::Param(format!("batch runs: {e}")))?;
            Manifest::from_raw(raw, Path::new(base))
        }
    }
}

/// The runs as (sequence, method), and the manifest's out, baseline, jobs.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub(crate) fn _batch_plan(
    kind: &str,
    payload: &str,
    base: &str,
) -> PyResult<(
    Vec<(String, String)>,
    Option<String>,
    Option<String>,
    Option<usize>,
)> {
    let m = manifest(kind, payload, base).map_err(err)?;
    Ok((
        m.runs
            .iter()
            .map(|r| (r.sequence.clone(), r.method.clone()))
            .collect(),
        m.out.map(|p| p.display().to_string()),
        m.baseline,
        m.jobs,
    ))
}

/// Runs (or reuses) run `index` into `out`; its record as JSON.
#[pyfunction]
pub(crate) fn _batch_run(
    py: Python<'_>,
    kind: &str,
    payload: &str,
    base: &str,
    index: usize,
    out: &str,
) -> PyResult<String> {
    let m = manifest(kind, payload, base).map_err(err)?;
    let Some(run) = m.runs.get(index) else {
        return Err(err(Error::Param(format!("no run {index} in the manifest"))));
    };
    let r = py.detach(|| run_one(run, Path::new(out)));
    Ok(serde_json::json!({
        "sequence": r.sequence,
        "method": r.method,
        "status": r.status,
        "error": r.error,
        "seconds": r.seconds,
    })
    .to_string())
}

/// The summary of the records `_batch_run` returned (in the manifest's
/// order), written into `out`; the summary as JSON.
#[pyfunction]
pub(crate) fn _batch_summary(
    py: Python<'_>,
    kind: &str,
    payload: &str,
    base: &str,
    out: &str,
    records: Vec<String>,
) -> PyResult<String> {
    let m = manifest(kind, payload, base).map_err(err)?;
    let out = Path::new(out);
    let recs: Vec<RunRecord> = records
        .iter()
        .zip(&m.runs)
        .map(|(j, run)| {
            let v: serde_json::Value = serde_json::from_str(j)
                .map_err(|e| Error::Param(format!("a batch record: {e}")))?;
            let status: Status = serde_json::from_value(v["status"].clone())
                .map_err(|e| Error::Param(format!("a batch record's status: {e}")))?;
            let result = match status {
                Status::Failed => None,
                _ => Some(ResultFile::from_json_file(
                    &out.join(run.dir()).join("result.json"),
                )?),
            };
            Ok(RunRecord {
                sequence: run.sequence.clone(),
                method: run.method.clone(),
                status,
                error: v["error"].as_str().map(String::from),
                result,
                seconds: v["seconds"].as_f64().unwrap_or(0.0),
            })
        })
        .collect::<mapgauge::Result<_>>()
        .map_err(err)?;
    py.detach(|| {
        let s = summarise(&m, &recs);
        write_summary(out, &s, &recs)?;
        Ok(serde_json::to_string(&s).unwrap_or_default())
    })
    .map_err(err)
}
