//! `mapgauge demo`: synthesise the default scene, evaluate it, print the tables
//! and how the measurement compares with the known truth.

use mapgauge::cloud::{MapSource, OutFormat};
use mapgauge::pipeline::{self, Config};
use mapgauge::record::ResultFile;
use mapgauge::render::{TableFormat, render_report};
use mapgauge::report;
use mapgauge::survey::{SurveyOptions, read_survey};
use mapgauge::synth::{SceneFiles, SynthParams, Truth, write_scene};
use mapgauge::{Point, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Synthesise a scene with known truth, evaluate it, print the results.
#[derive(clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Directory for the scene and the results.
    #[arg(long, default_value = "mapgauge-demo")]
    out: PathBuf,
    /// Seed of the scene and of the localisation.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Approximate number of map points [default: 2000000; 4000000 with
    /// spheres].
    #[arg(long)]
    points: Option<u64>,
    /// Number of targets.
    #[arg(long, default_value_t = 5)]
    targets: usize,
    /// The targets' models in turn, comma-separated (l, sphere, board).
    /// With spheres the scene's sensor has 1 cm range noise, not 2 cm: a
    /// 145 mm sphere needs noise well below its radius. With boards the map
    /// is a float32 PCD with intensity (a board is told by its print)
    /// [default: l].
    #[arg(long, value_delimiter = ',', default_value = "l")]
    models: Vec<mapgauge::model::ModelKind>,
}

/// Runs `demo`.
pub fn run(a: Args) -> Result<()> {
    let spheres = a.models.contains(&mapgauge::model::ModelKind::Sphere);
    let mut params = SynthParams {
        seed: a.seed,
        points: a
            .points
            .unwrap_or(if spheres { 4_000_000 } else { 2_000_000 }),
        targets: a.targets,
        models: a.models.clone(),
        ..SynthParams::default()
    };
    if spheres {
        params.lidar.range_noise_m = 0.01;
    }
    params.validate()?;
    super::check_out_dir(&a.out)?;
    let t0 = std::time::Instant::now();
    errln!(
        "demo: synthesising a {}-target scene of about {} points...",
        a.targets,
        params.points
    );
    // A board is told by its print: the map must carry intensity.
    let format = if a.models.contains(&mapgauge::model::ModelKind::Board) {
        OutFormat::PcdXyzi
    } else {
        OutFormat::Pcd
    };
    let (files, truth, expected) = write_scene(&a.out.join("scene"), &params, format)?;
    let t1 = std::time::Instant::now();
    errln!(
        "demo: {} points in {:.1} s; evaluating...",
        truth.points,
        (t1 - t0).as_secs_f64()
    );
    let out = a.out.join("eval");
    let ev = evaluate(&files, a.seed, &out)?;
    let result = &ev.result;

    out!("{}", render_report(result, TableFormat::Text));
    outln!();
    against_truth(result, &truth, &expected);
    outln!();
    outln!(
        "scene:    {} (map, survey.csv, survey_llh.csv, truth.json, trajectory.txt)",
        files.map.parent().unwrap_or(&a.out).display()
    );
    outln!(
        "results:  {} (result.json, targets.csv, pairs.csv, report.html, crops/)",
        out.display()
    );
    outln!(
        "time:     synthesis {:.1} s, evaluation {:.1} s, report {:.2} s",
        (t1 - t0).as_secs_f64(),
        (ev.evaluated - t1).as_secs_f64(),
        ev.report_s
    );
    Ok(())
}

/// The scene evaluated as `eval` would, its outputs and report in `out`.
struct Evaluated {
    result: ResultFile,
    /// When the evaluation was done (before its files were written).
    evaluated: std::time::Instant,
    /// Seconds the report took.
    report_s: f64,
}

/// Evaluates the scene (`seed` also seeds the localisation) and writes what
/// `eval` writes, the report with the scene's trajectory on it.
fn evaluate(files: &SceneFiles, seed: u64, out: &Path) -> Result<Evaluated> {
    let survey = read_survey(&files.survey, &SurveyOptions::default())?;
    let mut cfg = Config::default();
    cfg.locate.seed = seed;
    let ev = pipeline::run(MapSource::File(&files.map), &survey, &cfg, |_, _| {})?;
    let result = super::eval::result_file(&ev, &survey, &files.survey);
    let evaluated = std::time::Instant::now();
    let in_paths: [&Path; 2] = [&files.map, &files.survey];
    super::eval::write_outputs(&ev, &result, out, true, &in_paths)?;
    let t3 = std::time::Instant::now();
    let route = mapgauge::trajectory::Trajectory::read(&files.trajectory)?;
    let inputs: [(&str, &Path); 3] = [
        ("map", &files.map),
        ("survey", &files.survey),
        ("trajectory", &files.trajectory),
    ];
    let hashed = report::hash_inputs(&inputs, &AtomicBool::new(false))?;
    super::eval::write_report(
        &ev,
        &result,
        &cfg,
        hashed,
        &in_paths,
        Some(&out.join("report.html")),
        None,
        Some(&route),
    )?;
    Ok(Evaluated {
        result,
        evaluated,
        report_s: t3.elapsed().as_secs_f64(),
    })
}

/// The measurement beside the scene's truth: the headline numbers, then
/// each target's localisation error (what the demo is there to show).
fn against_truth(result: &ResultFile, truth: &Truth, expected: &ResultFile) {
    outln!("Against the known truth (the scene's true target positions in the map):");
    outln!("  {:<6} {:>12} {:>12}", "mm", "measured", "truth");
    outln!(
        "  {:<6} {:>12.1} {:>12.1}",
        "E_abs",
        result.absolute.mean * 1e3,
        expected.absolute.mean * 1e3
    );
    outln!(
        "  {:<6} {:>12.1} {:>12.1}",
        "σ_abs",
        result.absolute.std * 1e3,
        expected.absolute.std * 1e3
    );
    outln!(
        "  {:<6} {:>12.1} {:>12.1}",
        "E_rel",
        result.relative.mean * 1e3,
        expected.relative.mean * 1e3
    );
    outln!(
        "  {:<6} {:>12.1} {:>12.1}",
        "σ_rel",
        result.relative.std * 1e3,
        expected.relative.std * 1e3
    );
    outln!("  localisation error per target (horizontal, mm):");
    for (t, tt) in result.targets.iter().zip(&truth.targets) {
        match &t.map {
            Some(m) => {
                let e = (Point::new(m.x, m.y, 0.0) - Point::new(tt.map[0], tt.map[1], 0.0)).norm();
                outln!("    target {:<4} {:>7.1}", t.id, e * 1000.0);
            }
            None => outln!(
                "    target {:<4} {}: {}",
                t.id,
                t.status.replace('_', " "),
                t.reason.as_deref().unwrap_or("")
            ),
        }
    }
}
