//! The batch manifest: which map, of which method and sequence, against
//! which survey, with which settings. Paths are relative to the manifest.
//!
//! ```toml
//! baseline = "fast-lio2"          # compared against every other method
//! config = "common.toml"          # settings of every run (optional)
//!
//! [[run]]
//! method = "fast-lio2"
//! sequence = "campus-01"
//! map = "campus-01/fast-lio2.pcd"
//! survey = "campus-01/survey.csv"
//! overrides = { metrics = { align = "rigid3d" } }   # optional, on top of the config
//! ```

use crate::pipeline::Config;
use crate::{Error, Result};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The manifest as written (TOML, or JSON from Python).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawManifest {
    /// Output directory [default: given on the command line].
    #[serde(default)]
    pub out: Option<PathBuf>,
    /// The method every other one is compared against, sequence by sequence.
    #[serde(default)]
    pub baseline: Option<String>,
    /// Runs evaluated at once (maps open at once) [default: the cores].
    #[serde(default)]
    pub jobs: Option<usize>,
    /// A TOML configuration file for every run (as `eval --config`).
    #[serde(default)]
    pub config: Option<PathBuf>,
    /// Settings on top of it for every run: tables of the config's sections.
    #[serde(default)]
    pub overrides: Option<toml::Table>,
    /// The runs.
    #[serde(default, rename = "run")]
    pub runs: Vec<RawRun>,
}

/// One `[[run]]` as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawRun {
    /// The SLAM method (a row of the tables, a column of the leaderboard).
    pub method: String,
    /// The sequence (dataset, drive) the map was built from.
    pub sequence: String,
    /// The map file or tiled-map folder.
    pub map: PathBuf,
    /// The survey CSV.
    pub survey: PathBuf,
    /// Its own configuration file, in place of the manifest's.
    #[serde(default)]
    pub config: Option<PathBuf>,
    /// Settings on top of the configuration, for this run only.
    #[serde(default)]
    pub overrides: Option<toml::Table>,
}

/// One run, its paths resolved and its configuration built and checked.
#[derive(Debug, Clone)]
pub struct Run {
    /// SLAM method.
    pub method: String,
    /// Sequence.
    pub sequence: String,
    /// Map path.
    pub map: PathBuf,
    /// Survey path.
    pub survey: PathBuf,
    /// The configuration file the settings came from, if any.
    pub config_file: Option<PathBuf>,
    /// The effective configuration.
    pub config: Config,
}

impl Run {
    /// The run's folder under the output directory: `<sequence>/<method>`.
    pub fn dir(&self) -> PathBuf {
        Path::new(&self.sequence).join(&self.method)
    }
}

/// A checked manifest.
#[derive(Debug, Clone)]
pub struct Manifest {
    /// Output directory named by the manifest (relative paths resolved).
    pub out: Option<PathBuf>,
    /// Baseline method.
    pub baseline: Option<String>,
    /// Runs at once.
    pub jobs: Option<usize>,
    /// The runs, in the manifest's order.
    pub runs: Vec<Run>,
}

impl Manifest {
    /// Reads and checks a TOML manifest.
    pub fn read(path: &Path) -> Result<Manifest> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let raw: RawManifest = toml::from_str(&text).map_err(|e| {
            let line = e.span().map_or(0, |s| line_of(&text, s.start));
            Error::table(path, line, e.message().to_string())
        })?;
        let base = path.parent().unwrap_or(Path::new("."));
        Manifest::check(raw, base).map_err(|(i, msg)| {
            let msg = match i {
                Some(i) => format!("run {}: {msg}", i + 1),
                None => msg,
            };
            Error::table(path, run_line(&text, i), msg)
        })
    }

    /// Checks a manifest given as data (Python's list of runs): paths
    /// relative to `base`. `Err` names the run (0-based) and what is wrong.
    pub fn from_raw(raw: RawManifest, base: &Path) -> Result<Manifest> {
        Manifest::check(raw, base).map_err(|(i, msg)| match i {
            Some(i) => Error::Param(format!("run {}: {msg}", i + 1)),
            None => Error::Param(msg),
        })
    }

    fn check(
        raw: RawManifest,
        base: &Path,
    ) -> std::result::Result<Manifest, (Option<usize>, String)> {
        if raw.runs.is_empty() {
            return Err((
                None,
                "no runs: add [[run]] tables (method, sequence, map, survey)".into(),
            ));
        }
        if raw.jobs == Some(0) {
            return Err((None, "jobs must be 1 or more".into()));
        }
        let resolve = |p: &Path| {
            if p.is_absolute() {
                p.to_path_buf()
            } else {
                base.join(p)
            }
        };
        let shared = raw.config.as_deref().map(resolve);
        let mut runs: Vec<Run> = Vec::with_capacity(raw.runs.len());
        for (i, r) in raw.runs.into_iter().enumerate() {
            let at = |m: String| (Some(i), m);
            name_ok("method", &r.method).map_err(at)?;
            name_ok("sequence", &r.sequence).map_err(at)?;
            // Folder names: equal when only their case differs (macOS,
            // Windows), or two runs would write one folder at once.
            let same = |a: &str, b: &str| a.to_lowercase() == b.to_lowercase();
            if let Some(o) = runs
                .iter()
                .position(|o| same(&o.method, &r.method) && same(&o.sequence, &r.sequence))
            {
                return Err(at(format!(
                    "method `{}` on sequence `{}` is run {} too: each pair once",
                    r.method,
                    r.sequence,
                    o + 1
                )));
            }
            let config_file = r.config.as_deref().map(resolve).or_else(|| shared.clone());
            let config = build_config(config_file.as_deref(), [&raw.overrides, &r.overrides])
                .map_err(|e| at(e.to_string()))?;
            runs.push(Run {
                method: r.method,
                sequence: r.sequence,
                map: resolve(&r.map),
                survey: resolve(&r.survey),
                config_file,
                config,
            });
        }
        if let Some(b) = &raw.baseline
            && !runs.iter().any(|r| &r.method == b)
        {
            return Err((None, format!("baseline `{b}` is not the method of any run")));
        }
        Ok(Manifest {
            out: raw.out.as_deref().map(resolve),
            baseline: raw.baseline,
            jobs: raw.jobs,
            runs,
        })
    }

    /// The sequences, in the order they first appear.
    pub fn sequences(&self) -> Vec<&str> {
        let mut v: Vec<&str> = Vec::new();
        for r in &self.runs {
            if !v.contains(&r.sequence.as_str()) {
                v.push(&r.sequence);
            }
        }
        v
    }

    /// The methods, in the order they first appear.
    pub fn methods(&self) -> Vec<&str> {
        let mut v: Vec<&str> = Vec::new();
        for r in &self.runs {
            if !v.contains(&r.method.as_str()) {
                v.push(&r.method);
            }
        }
        v
    }
}

/// A method or sequence name is a folder name: not empty, no separators,
/// not `.`/`..`, printable.
fn name_ok(what: &str, s: &str) -> std::result::Result<(), String> {
    // The summary's own files sit beside the sequences' and methods' folders.
    const TAKEN: [&str; 7] = [
        "batch.json",
        "leaderboard.csv",
        "leaderboard.md",
        "index.html",
        "tables.md",
        "compare.md",
        "error.txt",
    ];
    if TAKEN.iter().any(|t| t.eq_ignore_ascii_case(s)) {
        return Err(format!(
            "{what} `{s}` is the name of a file the batch writes"
        ));
    }
    let bad = s.is_empty()
        || s == "."
        || s == ".."
        || s.len() > 100
        || s.chars().any(|c| c == '/' || c == '\\' || c.is_control());
    if bad {
        Err(format!(
            "{what} `{s}` cannot name a folder (1–100 printable characters, no `/` or `\\`, not `.` or `..`)"
        ))
    } else {
        Ok(())
    }
}

/// The configuration of a run: the file's settings (or the defaults), then
/// each table of overrides merged key by key, then the range checks.
fn build_config(file: Option<&Path>, overrides: [&Option<toml::Table>; 2]) -> Result<Config> {
    let mut table = match file {
        Some(p) => {
            // Read as eval reads it first: its errors carry the file's line.
            Config::from_toml_file(p)?;
            let text = std::fs::read_to_string(p).map_err(|e| Error::io(p, e))?;
            toml::from_str::<toml::Table>(&text).map_err(|e| Error::format(p, e.to_string()))?
        }
        None => toml::Table::new(),
    };
    for o in overrides.into_iter().flatten() {
        merge(&mut table, o);
    }
    let cfg: Config = toml::Value::Table(table)
        .try_into()
        .map_err(|e: toml::de::Error| Error::Param(format!("overrides: {}", e.message())))?;
    cfg.validate()?;
    Ok(cfg)
}

/// `over` on top of `base`, tables merged key by key.
fn merge(base: &mut toml::Table, over: &toml::Table) {
    for (k, v) in over {
        match (base.get_mut(k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            _ => {
                base.insert(k.clone(), v.clone());
            }
        }
    }
}

/// 1-based line of byte `at` in `text`.
fn line_of(text: &str, at: usize) -> u64 {
    text.as_bytes()[..at.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count() as u64
        + 1
}

/// The line of the `i`-th `[[run]]` (0 when unknown or not a run's error).
fn run_line(text: &str, i: Option<usize>) -> u64 {
    let Some(i) = i else { return 0 };
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with("[[run]]"))
        .nth(i)
        .map_or(0, |(n, _)| n as u64 + 1)
}
