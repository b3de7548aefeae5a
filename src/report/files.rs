//! Writing a report: hashing the inputs for its provenance (alongside the
//! run, since it reads the whole map once more) and writing the page and the
//! figure files.

use super::{InputFile, Provenance, Report};
use crate::Result;
use crate::pipeline::{Config, Evaluation};
use crate::record::{ResultFile, refuse_overwrite};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// The inputs' sizes and BLAKE3 hashes, and the seconds hashing took.
#[derive(Debug, Clone)]
pub struct HashedInputs {
    /// Per input, in the order given.
    pub files: Vec<InputFile>,
    /// Seconds spent hashing.
    pub seconds: f64,
}

/// Hashes `(role, path)` inputs, or gives up with `Ok(None)` once `stop` is
/// set (a run that failed needs no report).
pub fn hash_inputs(inputs: &[(&str, &Path)], stop: &AtomicBool) -> Result<Option<HashedInputs>> {
    let t0 = std::time::Instant::now();
    let mut files = Vec::new();
    for (role, p) in inputs {
        match InputFile::hash_unless(role, p, stop)? {
            Some(f) => files.push(f),
            None => return Ok(None),
        }
    }
    Ok(Some(HashedInputs {
        files,
        seconds: t0.elapsed().as_secs_f64(),
    }))
}

/// What [`write_report`] wrote.
#[derive(Debug, Clone, Default)]
pub struct Written {
    /// Seconds spent on the page, when written.
    pub html_seconds: Option<f64>,
    /// Figure files written, and the seconds they took.
    pub plots: Option<(Vec<PathBuf>, f64)>,
}

/// Writes report.html (when `html` is given; `hashed` names the inputs in its
/// provenance) and the figures as SVG and PNG under `plots`, refusing to
/// write over any of `inputs`; with the sensor's `route` (map frame), errors
/// against the distance driven too.
#[allow(clippy::too_many_arguments)]
pub fn write_report(
    ev: &Evaluation,
    result: &ResultFile,
    cfg: &Config,
    hashed: Option<HashedInputs>,
    inputs: &[&Path],
    html: Option<&Path>,
    plots: Option<&Path>,
    route: Option<&crate::trajectory::Trajectory>,
) -> Result<Written> {
    let mut written = Written::default();
    if html.is_none() && plots.is_none() {
        return Ok(written);
    }
    let t0 = std::time::Instant::now();
    let mut prov = Provenance::new(Some(cfg.locate.seed), Some(cfg.to_toml()));
    if html.is_some() {
        prov.inputs = hashed.map(|h| h.files).unwrap_or_default();
    }
    let mut report = Report::from_evaluation(ev, result, prov);
    if let Some(t) = route {
        report = report.with_trajectory(t, &ev.frame.levelling);
    }
    if let Some(h) = html {
        refuse_overwrite(h, inputs)?;
        report.write_html(h)?;
        written.html_seconds = Some(t0.elapsed().as_secs_f64());
    }
    if let Some(dir) = plots {
        let t1 = std::time::Instant::now();
        let files = report.write_plots(dir)?;
        written.plots = Some((files, t1.elapsed().as_secs_f64()));
    }
    Ok(written)
}
