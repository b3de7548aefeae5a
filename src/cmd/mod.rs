//! One module per subcommand: its flags, the library calls, and what it
//! prints. Everything printed to stdout goes through [`out!`]/[`outln!`].

/// `print!` that survives a closed stdout: `mapgauge table … | head -1`
/// stops the printing, not the run (files are still written), and any
/// other write error is said once on stderr instead of a panic.
macro_rules! out {
    ($($arg:tt)*) => { $crate::cmd::write_stdout(format_args!($($arg)*)) };
}

/// `println!` through [`out!`].
macro_rules! outln {
    () => { out!("\n") };
    ($($arg:tt)*) => {{ out!($($arg)*); out!("\n") }};
}

/// `eprintln!` that survives a closed stderr (`mapgauge eval … 2>&1 | head
/// -1` panicked with exit 101): the message is dropped, the run goes on
/// and writes its files.
macro_rules! errln {
    ($($arg:tt)*) => { $crate::cmd::write_stderr(format_args!("{}\n", format_args!($($arg)*))) };
}

pub mod batch;
pub mod compare;
pub mod convert;
pub mod crop;
pub mod demo;
pub mod detect;
pub mod errors;
pub mod eval;
pub mod locate;
pub mod synth;
pub mod table;

use indicatif::{ProgressBar, ProgressStyle};
use mapgauge::Result;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// Set once stdout failed: nothing more is written to it.
static STDOUT_GONE: AtomicBool = AtomicBool::new(false);

/// What [`out!`] does: one formatted write to the locked stdout.
pub fn write_stdout(args: std::fmt::Arguments) {
    use std::io::Write;
    if STDOUT_GONE.load(Ordering::Relaxed) {
        return;
    }
    if let Err(e) = std::io::stdout().lock().write_fmt(args) {
        STDOUT_GONE.store(true, Ordering::Relaxed);
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            errln!("warning: cannot write to stdout ({e}); the rest of the output is not printed");
        }
    }
}

/// What [`errln!`] does: one formatted write to the locked stderr, its
/// failure ignored (there is nowhere left to say it).
pub fn write_stderr(args: std::fmt::Arguments) {
    use std::io::Write;
    let _ = std::io::stderr().lock().write_fmt(args);
}

/// A byte progress bar on stderr, or `None` when stderr is not a terminal.
pub fn progress_bar(total: u64, what: &str) -> Option<ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let pb = ProgressBar::new(total);
    pb.set_style(
        ProgressStyle::with_template(
            "{msg} [{bar:40}] {bytes}/{total_bytes} {bytes_per_sec} eta {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    Some(pb)
}

/// A progress bar over a batch's runs, on a terminal only.
pub fn runs_bar(total: u64) -> Option<ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let pb = ProgressBar::new(total);
    pb.set_style(
        ProgressStyle::with_template("runs [{bar:40}] {pos}/{len} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    Some(pb)
}

/// Parses `n_min..=n_max` comma-separated finite numbers: the one parser of
/// every list flag (`--init`, `--origin`, `--plate-size`, `--survey-sigma`).
/// Flags using it set `allow_hyphen_values`, so `--init -26.7,96,30` works
/// without `=`; a wrong count is a usage error (exit 2), never a default.
pub fn numbers(s: &str, n_min: usize, n_max: usize) -> std::result::Result<Vec<f64>, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| format!("`{s}` is not a list of numbers"))?;
    if v.len() < n_min || v.len() > n_max {
        return Err(if n_min == n_max {
            format!("expected {n_min} comma-separated numbers, got {}", v.len())
        } else {
            format!(
                "expected {n_min} to {n_max} comma-separated numbers, got {}",
                v.len()
            )
        });
    }
    Ok(v)
}

/// `x,y,yaw_deg` (exactly three numbers).
pub fn triple(s: &str) -> std::result::Result<[f64; 3], String> {
    let v = numbers(s, 3, 3)?;
    Ok([v[0], v[1], v[2]])
}

/// `a[,b]`: one or two numbers, `b` absent when not given.
pub fn one_or_two(s: &str) -> std::result::Result<(f64, Option<f64>), String> {
    let v = numbers(s, 1, 2)?;
    Ok((v[0], v.get(1).copied()))
}

/// `--plate-size W[,H]` checked, with H defaulting to W (eval's and crop's).
pub fn plate_size((w, h): (f64, Option<f64>)) -> mapgauge::Result<(f64, f64)> {
    let h = h.unwrap_or(w);
    if w <= 0.0 || h <= 0.0 {
        return Err(mapgauge::Error::Param(format!(
            "--plate-size `{w},{h}`: sizes must be positive"
        )));
    }
    Ok((w, h))
}

/// `--origin lat,lon[,alt]` in WGS84 degrees and metres.
pub fn origin(s: &str) -> std::result::Result<mapgauge::survey::Geodetic, String> {
    let v = numbers(s, 2, 3)?;
    let (lat, lon, alt) = (v[0], v[1], v.get(2).copied().unwrap_or(0.0));
    if !(-90.0..=90.0).contains(&lat) || !(-180.0..=360.0).contains(&lon) {
        return Err("latitude must be within ±90° and longitude within ±180°".into());
    }
    Ok(mapgauge::survey::Geodetic { lat, lon, alt })
}

/// Refuses an output directory that names an existing file, before any work
/// is done (a refused output should cost nothing).
pub fn check_out_dir(out: &std::path::Path) -> mapgauge::Result<()> {
    check_dir_flag(out, "--out")
}

/// [`check_out_dir`] for any flag that names a directory to write into.
pub fn check_dir_flag(dir: &std::path::Path, flag: &str) -> mapgauge::Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(mapgauge::Error::Input(format!(
            "{}: exists and is not a directory ({flag} names the directory to write into)",
            dir.display()
        )));
    }
    Ok(())
}

/// `--origin` only means something for a lat/lon survey: refuse it with a
/// local one rather than ignore it.
pub fn check_origin_used(
    survey: &mapgauge::survey::Survey,
    origin: Option<mapgauge::survey::Geodetic>,
    path: &std::path::Path,
) -> mapgauge::Result<()> {
    if origin.is_some() && survey.frame == mapgauge::survey::SurveyFrame::Local {
        return Err(mapgauge::Error::Param(format!(
            "--origin applies to WGS84 (lat,lon) surveys, but {} is in local x,y coordinates",
            path.display()
        )));
    }
    Ok(())
}

/// For a tiled map (or a COPC file), how many tiles (nodes) and bytes a read
/// opened, on stderr.
pub fn print_tile_stats(reader: &dyn mapgauge::cloud::PointReader) {
    if let Some(t) = reader.tile_stats() {
        errln!(
            "{}: {} of {} opened ({:.1} of {:.1} MB)",
            if t.copc { "COPC nodes" } else { "tiles" },
            t.opened,
            t.tiles,
            t.bytes_opened as f64 / 1e6,
            t.bytes as f64 / 1e6
        );
    }
}

/// Says on stderr when a WGS84 survey was placed by the map's projection.
pub fn say_projected(survey: &mapgauge::survey::Survey, projector: Option<&std::path::Path>) {
    if let (mapgauge::survey::SurveyFrame::Wgs84Map, Some(p)) = (survey.frame, projector) {
        errln!(
            "the WGS84 survey is placed in the map frame by {}",
            p.display()
        );
    }
}

/// The surveyors' and benchmarks' flags of `eval` and `errors`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct SurveyorArgs {
    /// ISO 19157's threshold in metres: the result counts the checkpoints
    /// whose horizontal (and vertical) error exceeds it [default: none; eval:
    /// the config's `[metrics] threshold_m`].
    #[arg(long, value_name = "M")]
    pub threshold: Option<f64>,
    /// Benchmark scores to add, repeatable or comma-separated: hilti2022
    /// (10/6/3/1 points per target below 1/3/6/10 cm), hilti2023
    /// (20/10/6/5/3/1 below 0.5/1/3/6/10/40 cm), hilti2026 (100·e^(−0.4605·cm));
    /// each 0-100 over every surveyed target, a target not located earning 0.
    /// In result.json's `scores` and the summary [default: none; eval: the
    /// config's `[metrics] scores`].
    #[arg(long = "score", value_name = "RULE", value_delimiter = ',')]
    pub score: Vec<mapgauge::scores::ScoreKind>,
}

/// The checkpoint-file flags of `eval` and `errors`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct CheckpointArgs {
    /// Also write every target as a checkpoint to FILE, by its extension:
    /// .gpkg (a GeoPackage point layer), .geojson (WGS84 surveys only: RFC
    /// 7946) or .csv. Surveyed and measured positions in the survey's CRS
    /// (a WGS84 survey's as lon, lat, ellipsoidal height), dx/dy/dz, error,
    /// σ per axis (m), status and role [default: none].
    #[arg(long, value_name = "FILE")]
    pub checkpoints: Option<PathBuf>,
    /// The EPSG code of a survey given in projected x, y, written with its
    /// checkpoints, e.g. EPSG:32633 (UTM 33N) [default: undefined; a WGS84
    /// survey's is EPSG:4979].
    #[arg(long, value_name = "EPSG:CODE", value_parser = epsg, requires = "checkpoints")]
    pub checkpoints_crs: Option<u32>,
}

fn epsg(s: &str) -> std::result::Result<u32, String> {
    mapgauge::checkpoints::parse_epsg(s).map_err(|e| e.to_string())
}

impl CheckpointArgs {
    /// Refuses, before any work, a file of no known format or one that
    /// names an input.
    pub fn check(&self, inputs: &[&Path]) -> Result<()> {
        let Some(f) = &self.checkpoints else {
            return Ok(());
        };
        mapgauge::checkpoints::check_path(f)?;
        mapgauge::record::refuse_overwrite(f, inputs)
    }
    /// Refuses a checkpoints file that another output of the run would be
    /// written over or would overwrite: a file of `--out` or the JUnit report.
    pub fn check_outputs(&self, out: Option<&Path>, junit: Option<&Path>) -> Result<()> {
        let Some(f) = &self.checkpoints else {
            return Ok(());
        };
        let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
        let mine = abs(f);
        let mut taken: Vec<PathBuf> = junit.map(abs).into_iter().collect();
        if let Some(dir) = out {
            let names = mapgauge::render::OUTPUT_FILES
                .iter()
                .chain(&["report.html", "failed.csv"]);
            taken.extend(names.map(|n| abs(&dir.join(n))));
        }
        if taken.contains(&mine) {
            return Err(mapgauge::Error::Param(format!(
                "--checkpoints {}: another output of this run is written there",
                f.display()
            )));
        }
        Ok(())
    }
    /// Refuses, once the survey is read, a format its CRS cannot take.
    pub fn check_survey(&self, frame: mapgauge::survey::SurveyFrame) -> Result<()> {
        match &self.checkpoints {
            Some(f) => mapgauge::checkpoints::check(f, frame, self.checkpoints_crs),
            None => Ok(()),
        }
    }
    /// Writes the checkpoints when asked for.
    pub fn write(&self, result: &mapgauge::record::ResultFile) -> Result<()> {
        if let Some(f) = &self.checkpoints {
            if let Some(dir) = f.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| mapgauge::Error::io(dir, e))?;
            }
            let crs = mapgauge::checkpoints::write(f, result, self.checkpoints_crs)?;
            errln!("checkpoints written to {} ({})", f.display(), crs.label());
        }
        Ok(())
    }
}

/// The quality-gate flags of `eval` and `errors`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct GateArgs {
    /// A quality gate `STATISTIC OP NUMBER[UNIT]`, repeatable: `E_abs<=0.05`,
    /// `max_abs<10cm`, `RMSE_H<=25mm`, `found>=0.9`, `scale_ppm<=200`.
    /// Statistics: E_abs E_rel max_abs median_abs max_rel E_loo RMSE_H RMSE_V
    /// RMSE_3D NSSDA_H NSSDA_V (metres, or cm/mm), scale_ppm, found (0-1 or %).
    /// Each is judged with its 95 % interval: pass when the whole interval
    /// meets the threshold, fail when none of it does, undecided otherwise.
    /// Replaces the config's `[gates] checks` (eval) [default: none].
    #[arg(long = "gate", value_name = "GATE")]
    pub gate: Vec<mapgauge::gate::Gate>,
    /// What the gates do to the exit code: strict (a failed gate exits 1, an
    /// undecided one 3), point (each gate on its value alone, interval
    /// ignored: exit 1 when one misses), report-only (verdicts written,
    /// exit 0) [default: strict].
    #[arg(long, value_enum, value_name = "POLICY")]
    pub gate_policy: Option<mapgauge::gate::Policy>,
    /// Also write a JUnit XML report to FILE, for CI test reports (GitLab,
    /// GitHub, Jenkins): one test case per gate and per target (a target
    /// not found fails with its reason).
    #[arg(long, value_name = "FILE")]
    pub junit: Option<PathBuf>,
}

impl GateArgs {
    /// Refuses a JUnit path that names an input, before any work.
    pub fn check(&self, inputs: &[&Path]) -> Result<()> {
        match &self.junit {
            Some(j) => mapgauge::record::refuse_overwrite(j, inputs),
            None => Ok(()),
        }
    }
    /// Writes a JUnit report of the error when asked for: the run could not
    /// produce a result (a failure to write it is said, not returned: the
    /// run's own error is the one to report).
    pub fn write_junit_error(&self, e: &mapgauge::Error, suite: &str) {
        if let Some(j) = &self.junit {
            if let Some(dir) = j.parent().filter(|d| !d.as_os_str().is_empty()) {
                let _ = std::fs::create_dir_all(dir);
            }
            let xml = mapgauge::render::junit_error(suite, &e.to_string());
            if let Err(w) = mapgauge::record::write_atomic(j, xml.as_bytes()) {
                errln!("warning: the JUnit report could not be written: {w}");
            }
        }
    }
    /// Writes the JUnit report when asked for.
    pub fn write_junit(&self, result: &mapgauge::record::ResultFile, suite: &str) -> Result<()> {
        if let Some(j) = &self.junit {
            if let Some(dir) = j.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| mapgauge::Error::io(dir, e))?;
            }
            let xml = mapgauge::render::junit_xml(result, suite);
            mapgauge::record::write_atomic(j, xml.as_bytes())?;
            errln!("JUnit report written to {}", j.display());
        }
        Ok(())
    }
}
