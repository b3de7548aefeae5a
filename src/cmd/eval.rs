//! `mapgauge eval`: the whole pipeline, map to accuracy.

mod outputs;

use super::progress_bar;
use mapgauge::accuracy::Dim;
use mapgauge::align::AlignMethod;
use mapgauge::cloud::{self, MapSource, OutFormat};
use mapgauge::crop::Shape;
use mapgauge::pipeline::{self, Config, Evaluation};
use mapgauge::record::{ResultFile, refuse_overwrite};
use mapgauge::render::{self, OutputFormat, TableFormat};
use mapgauge::report::{self, HashedInputs};
use mapgauge::survey::{Geodetic, SurveyOptions, file_stem, read_survey_for_map};
use mapgauge::{Error, Result};
use outputs::save_failure;
pub use outputs::write_outputs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// Measure a map's accuracy: crop, locate every target, align, report.
#[derive(clap::Args, Clone)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Map file (PCD, PLY, LAS/LAZ, E57, PTS, XYZ; recognised from its content), or an
    /// Autoware tiled map: a folder of PCD tiles or its `*metadata*.yaml`.
    #[arg(long, required_unless_present = "print_config")]
    pub map: Option<PathBuf>,
    /// Survey CSV (id,x,y[,z][,antenna_height][,role] or id,lat,lon[,alt]...).
    #[arg(long, required_unless_present = "print_config")]
    pub survey: Option<PathBuf>,
    /// Directory for result.json, targets.csv, pairs.csv and report.html (and
    /// crops with --save-crops). A run that cannot score writes failed.csv
    /// and report.html there instead: what each surveyed place showed.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// TOML file with any parameter (see --print-config); flags override it.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Print the full configuration (defaults merged with --config and flags) and exit.
    #[arg(long)]
    pub print_config: bool,
    /// Use hand-made tight crops DIR/<id>.ply|pcd|... instead of the automatic crop.
    #[arg(long)]
    pub crops: Option<PathBuf>,
    /// Also write the loose and tight crops (PLY) under OUT/crops/, also when
    /// too few targets are found to score.
    #[arg(long, requires = "out")]
    pub save_crops: bool,
    /// Alignment map → survey: none, rigid2d, rigid2d+z, rigid3d, similarity2d, similarity3d, robust2d [default: rigid2d].
    #[arg(long)]
    pub align: Option<AlignMethod>,
    /// Error dimension: 2d (the paper) or 3d [default: 2d].
    #[arg(long)]
    pub dim: Option<Dim>,
    /// Survey's own 1-σ error `H[,V]` in metres, folded into the ASPRS statistics.
    #[arg(long, value_name = "H[,V]", value_parser = super::one_or_two, allow_hyphen_values = true)]
    pub survey_sigma: Option<(f64, Option<f64>)>,
    /// Seed of the localisation's random draws [default: 0].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Loose crop radius in metres [default: 5].
    #[arg(long)]
    pub radius: Option<f64>,
    /// Loose crop shape [default: cylinder].
    #[arg(long, value_enum)]
    pub shape: Option<Shape>,
    /// Plate width and height `W[,H]` in metres [default: 0.6,0.6].
    #[arg(long, value_name = "W[,H]", value_parser = super::one_or_two, allow_hyphen_values = true)]
    pub plate_size: Option<(f64, Option<f64>)>,
    /// Approximate map → survey transform `x,y,yaw_deg`: a map point p is at
    /// R(yaw)·p + (x, y) in the survey, yaw counter-clockwise in degrees
    /// (so a survey point s is looked for at R(-yaw)·(s - (x, y)) in the map).
    /// Not needed when the frame can be found automatically (--frame auto).
    #[arg(long, value_name = "X,Y,YAW_DEG", value_parser = super::triple, allow_hyphen_values = true)]
    pub init: Option<[f64; 3]>,
    /// How to find the map's frame: auto = --init or --hints when given, else
    /// the survey frame when the targets are there, else detect target-shaped
    /// objects map-wide and match them to the survey [default: auto].
    #[arg(long, value_enum)]
    pub frame: Option<mapgauge::pipeline::FrameMode>,
    /// CSV `id,x,y[,z]`: approximate map positions (±0.5 m, as clicked in a
    /// viewer) of 2 or more surveyed targets; they give the transform.
    #[arg(long, value_name = "FILE")]
    pub hints: Option<std::path::PathBuf>,
    /// ENU origin `lat,lon[,alt]` for WGS84 surveys [default: the first target].
    #[arg(long, value_name = "LAT,LON[,ALT]", value_parser = super::origin, allow_hyphen_values = true)]
    pub origin: Option<Geodetic>,
    /// What to print on stdout: table (a summary, one row per target), json,
    /// markdown, latex, csv, html (the paper's tables).
    #[arg(long, default_value = "table")]
    pub format: OutputFormat,
    /// Refit without targets flagged as gross errors; they stay in the result
    /// as `excluded`, with the reason [default: off: flagged in the warnings only].
    #[arg(long)]
    pub exclude_outliers: bool,
    /// With `--format table`, also print every pair's relative error.
    #[arg(long, short)]
    pub verbose: bool,
    /// Do not write OUT/report.html (written by default with --out; it reads the
    /// map once more for its BLAKE3 hash, about 0.3 s per GB).
    #[arg(long)]
    pub no_report: bool,
    /// Also write the report's figures as DIR/<name>.svg and DIR/<name>.png.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// The sensor's trajectory in the map's frame, as the SLAM software wrote
    /// it: TUM (`t x y z qx qy qz qw`) or KITTI (3 × 4 pose matrix) lines. The
    /// report draws it on the map and plots each target's error against the
    /// distance driven to it [default: none].
    #[arg(long, value_name = "FILE")]
    pub trajectory: Option<PathBuf>,
    #[command(flatten)]
    pub surveyor: super::SurveyorArgs,
    #[command(flatten)]
    pub checkpoints: super::CheckpointArgs,
    #[command(flatten)]
    pub gates: super::GateArgs,
}

/// Builds the configuration: defaults, then the TOML file, then flags.
pub fn config(a: &Args) -> Result<Config> {
    let mut cfg = match &a.config {
        Some(p) => Config::from_toml_file(p)?,
        None => Config::default(),
    };
    if let Some(m) = a.align {
        cfg.metrics.align = m;
    }
    if let Some(d) = a.dim {
        cfg.metrics.dim = d;
    }
    if let Some((h, v)) = a.survey_sigma {
        cfg.metrics.survey_sigma_h = Some(h);
        cfg.metrics.survey_sigma_v = v;
    }
    if let Some(s) = a.seed {
        cfg.locate.seed = s;
        cfg.tight.seed = s;
    }
    if let Some(r) = a.radius {
        cfg.crop.radius = r;
    }
    if let Some(s) = a.shape {
        cfg.crop.shape = s;
    }
    if let Some(p) = a.plate_size {
        let (w, h) = super::plate_size(p)?;
        cfg.tight.plate_width = w;
        cfg.tight.plate_height = h;
    }
    if let Some(i) = a.init {
        cfg.frame.init = Some(i.into());
    }
    if let Some(m) = a.frame {
        cfg.frame.mode = m;
    }
    if let Some(h) = &a.hints {
        cfg.frame.hints = Some(h.clone());
    }
    if a.exclude_outliers {
        cfg.metrics.exclude_outliers = true;
    }
    if let Some(o) = a.origin {
        cfg.frame.origin = Some([o.lat, o.lon, o.alt]);
    }
    if a.surveyor.threshold.is_some() {
        cfg.metrics.threshold_m = a.surveyor.threshold;
    }
    if !a.surveyor.score.is_empty() {
        cfg.metrics.scores = a.surveyor.score.clone();
    }
    if !a.gates.gate.is_empty() {
        cfg.gates.checks = a.gates.gate.clone();
    }
    if let Some(p) = a.gates.gate_policy {
        cfg.gates.policy = p;
    }
    cfg.validate()?;
    Ok(cfg)
}

/// Runs `eval`; `Ok` holds the exit code its gates decided (0 without gates).
/// With `--junit`, a run that cannot produce a result still leaves a JUnit
/// file that says why (unless the file would overwrite an input).
pub fn run(a: Args) -> Result<u8> {
    let r = run_eval(&a);
    if let Err(e) = &r
        && a.gates.check(&given_inputs(&a)).is_ok()
    {
        a.gates.write_junit_error(e, "mapgauge eval");
    }
    r
}

/// Every input file named on the command line (what no output may overwrite).
fn given_inputs(a: &Args) -> Vec<&Path> {
    [&a.map, &a.survey, &a.config, &a.trajectory, &a.hints]
        .into_iter()
        .filter_map(|p| p.as_deref())
        .collect()
}

fn run_eval(a: &Args) -> Result<u8> {
    let cfg = config(&a)?;
    if a.print_config {
        out!("{}", cfg.to_toml());
        return Ok(0);
    }
    let (Some(map), Some(survey_path)) = (a.map.as_deref(), a.survey.as_deref()) else {
        return Err(Error::Param("--map and --survey are required".into()));
    };
    if let Some(out) = &a.out {
        // Before the work, not after it: a refused output should cost nothing.
        super::check_out_dir(out)?;
        render::refuse_overwriting_inputs(out, &[map, survey_path])?;
    }
    if let Some(dir) = &a.plots {
        super::check_dir_flag(dir, "--plots")?;
    }
    a.gates.check(&given_inputs(&a))?;
    a.checkpoints.check(&given_inputs(&a))?;
    a.checkpoints
        .check_outputs(a.out.as_deref(), a.gates.junit.as_deref())?;
    // Read before the run: a bad trajectory should cost nothing.
    let route = a
        .trajectory
        .as_deref()
        .map(mapgauge::trajectory::Trajectory::read)
        .transpose()?;
    let mut inputs: Vec<(&str, &Path)> = vec![("map", map), ("survey", survey_path)];
    if let Some(c) = &a.config {
        inputs.push(("config", c));
    }
    if let Some(t) = &a.trajectory {
        inputs.push(("trajectory", t));
    }
    let html = match &a.out {
        Some(out) if !a.no_report => Some(out.join("report.html")),
        _ => None,
    };
    if route.is_some() && html.is_none() && a.plots.is_none() {
        errln!(
            "warning: --trajectory is drawn in the report: it needs --out (without --no-report) or --plots"
        );
    }
    // The report's hash reads the map once more (SHA-256 took 3.7 s of a 5.8 s
    // eval of a 200 M-point map when done after the run; BLAKE3 is 3-4x
    // cheaper), so it runs on a thread of its own alongside the pipeline, and
    // stops if the run fails.
    let stop = AtomicBool::new(false);
    let (run, hashed) = std::thread::scope(|s| {
        let hasher = html.is_some().then(|| {
            let (inputs, stop) = (&inputs, &stop);
            s.spawn(move || report::hash_inputs(inputs, stop))
        });
        // Set on every way out, a panic's unwinding included, so the scope
        // never waits for a whole map to be hashed for nothing.
        let _stop_if_failed = StopOnDrop(&stop);
        let run = evaluate(map, survey_path, &a, &cfg);
        if run.is_err() {
            stop.store(true, Ordering::Relaxed);
        }
        let hashed = hasher.map(|h| {
            h.join()
                .unwrap_or_else(|_| Err(Error::Input("the hashing thread panicked".into())))
        });
        (run, hashed)
    });
    let (ev, result) = run?;
    // A failed hash costs the report, not the results: they are printed and
    // written first, and the error comes last.
    let (hashed, hash_error) = match hashed.transpose() {
        Ok(h) => (h.flatten(), None),
        Err(e) => (None, Some(e)),
    };
    print_result(&result, a.format, a.verbose);
    if let Some(route) = &route {
        warn_off_route(route, &ev, &result);
    }
    if let Some(out) = &a.out {
        write_outputs(&ev, &result, out, a.save_crops, &[map, survey_path])?;
        errln!("results written to {}", out.display());
    }
    a.checkpoints.write(&result)?;
    let in_paths: Vec<&Path> = inputs.iter().map(|i| i.1).collect();
    if let Some(e) = hash_error {
        return Err(e);
    }
    errln!("{}", provenance(&cfg, hashed.as_ref()));
    write_report(
        &ev,
        &result,
        &cfg,
        hashed,
        &in_paths,
        html.as_deref(),
        a.plots.as_deref(),
        route.as_ref(),
    )?;
    // Last: a JUnit file holds the verdicts only when everything else was
    // written (else the error's JUnit, from `run`, says what went wrong).
    a.gates.write_junit(&result, "mapgauge eval")?;
    Ok(result.gate_outcome.map_or(0, |o| o.exit_code))
}

/// One line that says how the numbers were made, to paste beside them:
/// the version, the command as typed (shell-quoted), the effective settings
/// that move the numbers (and the hash of the whole effective
/// configuration, defaults included), the inputs' hashes.
fn provenance(cfg: &Config, hashed: Option<&HashedInputs>) -> String {
    let argv: Vec<String> = std::env::args_os()
        .skip(1)
        .map(|a| shell_quote(&a.to_string_lossy()))
        .collect();
    let tight = if cfg.tight.seed != cfg.locate.seed {
        format!(" (tight crop {})", cfg.tight.seed)
    } else {
        String::new()
    };
    let mut line = format!(
        "provenance: mapgauge {} {}; settings: align {}, dim {}, seed {}{tight}, frame {}",
        env!("CARGO_PKG_VERSION"),
        argv.join(" "),
        cfg.metrics.align,
        cfg.metrics.dim.label().to_lowercase(),
        cfg.locate.seed,
        format!("{:?}", cfg.frame.mode).to_lowercase()
    );
    if !cfg.metrics.scores.is_empty() {
        let names: Vec<&str> = cfg.metrics.scores.iter().map(|k| k.name()).collect();
        line += &format!(", scores {}", names.join(" "));
    }
    if !cfg.gates.checks.is_empty() {
        let gates: Vec<String> = cfg.gates.checks.iter().map(|g| g.to_string()).collect();
        line += &format!(", gates {} ({})", gates.join(" "), cfg.gates.policy.name());
    }
    let whole = cfg.settings_hash();
    line += &format!(", config blake3:{}", &whole[..16]);
    match hashed {
        Some(h) => {
            let files: Vec<String> = h
                .files
                .iter()
                .map(|f| format!("{} blake3:{}", f.role, &f.blake3[..16.min(f.blake3.len())]))
                .collect();
            line += &format!("; inputs {}", files.join(", "));
        }
        None => line += "; inputs not hashed (no report written)",
    }
    line
}

/// `s` as one POSIX shell word: as it is when it holds only safe
/// characters, else single-quoted (a `'` inside as `'\''`).
fn shell_quote(s: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "_./=:,+@%-".contains(c);
    if !s.is_empty() && s.chars().all(safe) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// Says when located targets lie far from every point of the trajectory: a
/// route in another frame than the map's (or of another run) would plot
/// nonsense against the distance driven.
fn warn_off_route(route: &mapgauge::trajectory::Trajectory, ev: &Evaluation, result: &ResultFile) {
    let moved = route.moved(&ev.frame.levelling);
    let far = report::located_stations(result, &moved)
        .iter()
        .map(|(_, s)| s.off)
        .fold(0.0, f64::max);
    if far > report::ROUTE_FAR_M {
        errln!(
            "warning: a located target is {far:.0} m from the trajectory ({} poses, {:.0} m): is it in the map's frame, and of this run? (the report's error-against-distance figure assumes so)",
            route.positions.len(),
            route.length()
        );
    }
}

/// Prints a result on stdout in `format`.
pub fn print_result(result: &ResultFile, format: OutputFormat, verbose: bool) {
    match format {
        OutputFormat::Table(TableFormat::Text) => {
            out!("{}", render::render_text(result, verbose))
        }
        OutputFormat::Table(TableFormat::Html) => out!(
            "{}",
            report::html::page(
                "mapgauge result",
                &render::render_report(result, TableFormat::Html),
                &[]
            )
        ),
        OutputFormat::Table(f) => out!("{}", render::render_report(result, f)),
        OutputFormat::Json => out!("{}", result.to_json()),
    }
}

/// Sets its flag when dropped.
struct StopOnDrop<'a>(&'a AtomicBool);

impl Drop for StopOnDrop<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// Writes report.html and the figure files, and says what it cost on stderr.
#[allow(clippy::too_many_arguments)]
pub fn write_report(
    ev: &Evaluation,
    result: &ResultFile,
    cfg: &Config,
    hashed: Option<HashedInputs>,
    in_paths: &[&Path],
    html: Option<&Path>,
    plots: Option<&Path>,
    route: Option<&mapgauge::trajectory::Trajectory>,
) -> Result<()> {
    let t_hash = hashed.as_ref().map_or(0.0, |h| h.seconds);
    let w = report::write_report(ev, result, cfg, hashed, in_paths, html, plots, route)?;
    if let (Some(h), Some(secs)) = (html, w.html_seconds) {
        errln!(
            "report written to {} in {secs:.2} s (hashing the inputs took {t_hash:.2} s)",
            h.display(),
        );
    }
    if let (Some(dir), Some((files, secs))) = (plots, w.plots) {
        errln!(
            "{} figure files written to {} in {secs:.2} s",
            files.len(),
            dir.display(),
        );
    }
    Ok(())
}

/// Reads the survey and runs the pipeline with a progress bar. The caller
/// says the warnings (`run`: on stderr for formats other than the text
/// summary, which holds them).
pub fn evaluate(
    map: &Path,
    survey_path: &Path,
    a: &Args,
    cfg: &Config,
) -> Result<(Evaluation, ResultFile)> {
    let origin = cfg
        .frame
        .origin
        .map(|[lat, lon, alt]| Geodetic { lat, lon, alt });
    let projector = cloud::map_projector(map)?;
    let survey = read_survey_for_map(survey_path, &SurveyOptions { origin }, projector.as_deref())?;
    super::say_projected(&survey, projector.as_deref());
    super::check_origin_used(&survey, origin, survey_path)?;
    a.checkpoints.check_survey(survey.frame)?;
    let pb = progress_bar(
        cloud::map_bytes(map),
        &format!("pass 1: {}", pass_label("ground")),
    );
    // One bar for the whole run: each pass over the map is named and
    // numbered as it starts, and fills the bar from 0 again.
    let mut passes: Vec<&'static str> = Vec::new();
    let progress = |p: pipeline::Progress| {
        let Some(pb) = &pb else { return };
        if passes.last() != Some(&p.pass) {
            passes.push(p.pass);
            pb.set_message(format!("pass {}: {}", passes.len(), pass_label(p.pass)));
            pb.set_length(p.total);
        }
        pb.set_position(p.done)
    };
    let source = MapSource::File(map);
    let run = pipeline::run_keeping_failures(source, &survey, a.crops.as_deref(), cfg, progress);
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    let ev = match run {
        Ok(ev) => ev,
        Err(f) => {
            // A run that cannot score still leaves what it saw at each
            // surveyed place: the reasons and a page of the crops always
            // (small), the crops themselves when asked for.
            if let (Some(out), false) = (&a.out, f.targets.is_empty()) {
                let page = (!a.no_report).then(|| out.join("report.html"));
                match save_failure(
                    &f,
                    out,
                    a.save_crops,
                    page.as_deref(),
                    cfg,
                    &[map, survey_path],
                ) {
                    Ok(()) => errln!(
                        "what each surveyed place showed, and why no target was taken there: {}{}{}",
                        out.join("failed.csv").display(),
                        page.map(|p| format!(", {} (its crops drawn)", p.display()))
                            .unwrap_or_default(),
                        if a.save_crops {
                            format!("; the crops in {}", out.join("crops").display())
                        } else {
                            "; `--save-crops` also writes the crops to open in a viewer".into()
                        }
                    ),
                    Err(e) => errln!("warning: what each place showed could not be saved: {e}"),
                }
            }
            return Err(f.error);
        }
    };
    let mut result = result_file(&ev, &survey, survey_path);
    cfg.finish(&mut result);
    // The text summary gives the warnings, ranked, and each target's reason
    // in its table: saying them on stderr too would only double the noise.
    // Other formats say on stderr the caveats result.json holds, in the text
    // summary's order.
    if a.format != OutputFormat::Table(TableFormat::Text) {
        for line in render::gate_lines(&result) {
            errln!("{line}");
        }
        for w in result.caveats() {
            errln!("warning: {w}");
        }
        for t in &result.targets {
            if let Some(r) = &t.reason {
                errln!("warning: target {} {}: {r}", t.id, t.status);
            }
        }
    }
    // How the frame was found, where the user reads: a detected frame costs a
    // map-wide pass that --init saves next time.
    if let pipeline::FrameHow::Detected { matched, rms, .. } = &ev.frame.how {
        let mapgauge::frame::MapToSurvey { x, y, yaw_deg: yaw } = ev.frame.init;
        let level = if ev.frame.levelling.is_identity() {
            ""
        } else {
            " (a frame of the levelled map: the map as stored differs from it by the tilt, height × angle, which the crops' few metres absorb on most sites)"
        };
        errln!(
            "frame: the map is not in the survey frame; it was found by detecting the targets map-wide ({} matched, rms {:.0} mm). Next time `--init {x:.3},{y:.3},{yaw:.4}` skips the detection{level}",
            matched.len(),
            rms * 1e3
        );
    }
    Ok((ev, result))
}

/// What a pass over the map is doing, for the progress bar.
fn pass_label(pass: &str) -> &str {
    match pass {
        "ground" => "ground (the map's vertical)",
        "detection" => "detecting the targets (map-wide)",
        "crops" => "crops near the targets",
        "second-pass" => "second pass (predicted positions)",
        other => other,
    }
}

/// The result file of an evaluation, with its `eval` section.
pub fn result_file(
    ev: &Evaluation,
    survey: &mapgauge::survey::Survey,
    survey_path: &Path,
) -> ResultFile {
    // The pipeline's caveats (levelling, wrong objects rejected) belong in
    // the file and the report as much as on stderr.
    ResultFile::from_evaluation(ev, survey, &survey_path.display().to_string())
}
