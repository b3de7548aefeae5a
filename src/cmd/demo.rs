//! `mapgauge demo`: synthesise the default scene, evaluate it, print the tables
//! and how the measurement compares with the known truth.

use mapgauge::cloud::OutFormat;
use mapgauge::eval::{EvalConfig, EvalInputs, evaluate_map};
use mapgauge::result::{TableFormat, render_report};
use mapgauge::survey::{SurveyOptions, read_survey};
use mapgauge::synth::{SynthParams, write_scene};
use mapgauge::{Point, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Synthesise a scene with known truth, evaluate it, print the results.
#[derive(clap::Args)]
pub struct Args {
    /// Directory for the scene and the results.
    #[arg(long, default_value = "mapgauge-demo")]
    out: PathBuf,
    /// Seed of the scene and of the localisation.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Approximate number of map points.
    #[arg(long, default_value_t = 2_000_000)]
    points: u64,
    /// Number of targets.
    #[arg(long, default_value_t = 5)]
    targets: usize,
}

/// Runs `demo`.
pub fn run(a: Args) -> Result<()> {
    let params = SynthParams {
        seed: a.seed,
        points: a.points,
        targets: a.targets,
        ..SynthParams::default()
    };
    params.validate()?;
    let t0 = std::time::Instant::now();
    eprintln!(
        "demo: synthesising a {}-target scene of about {} points...",
        a.targets, a.points
    );
    let (files, truth, expected) = write_scene(&a.out.join("scene"), &params, OutFormat::Pcd)?;
    let t1 = std::time::Instant::now();
    eprintln!(
        "demo: {} points in {:.1} s; evaluating...",
        truth.points,
        (t1 - t0).as_secs_f64()
    );

    let survey = read_survey(&files.survey, &SurveyOptions::default())?;
    let mut cfg = EvalConfig::default();
    cfg.locate.seed = a.seed;
    let inputs = EvalInputs {
        map: &files.map,
        survey: &survey,
        survey_path: &files.survey,
        crops_dir: None,
    };
    let run = evaluate_map(&inputs, &cfg, |_, _| {})?;
    let t2 = std::time::Instant::now();
    let out = a.out.join("eval");
    super::eval::write_outputs(&run, &out, true, &[&files.map, &files.survey])?;
    let t3 = std::time::Instant::now();
    let inputs: [(&str, &Path); 2] = [("map", &files.map), ("survey", &files.survey)];
    let hashed = super::eval::hash_inputs(&inputs, &AtomicBool::new(false))?;
    super::eval::write_report(
        &run,
        &cfg,
        hashed,
        &[&files.map, &files.survey],
        Some(&out.join("report.html")),
        None,
    )?;
    let t_report = t3.elapsed().as_secs_f64();

    print!("{}", render_report(&run.result, TableFormat::Text));
    println!();
    println!("Against the known truth (the scene's true target positions in the map):");
    println!("  {:<6} {:>12} {:>12}", "", "measured", "truth");
    println!(
        "  {:<6} {:>12.4} {:>12.4}",
        "E_abs", run.result.absolute.mean, expected.absolute.mean
    );
    println!(
        "  {:<6} {:>12.4} {:>12.4}",
        "σ_abs", run.result.absolute.std, expected.absolute.std
    );
    println!(
        "  {:<6} {:>12.4} {:>12.4}",
        "E_rel", run.result.relative.mean, expected.relative.mean
    );
    println!(
        "  {:<6} {:>12.4} {:>12.4}",
        "σ_rel", run.result.relative.std, expected.relative.std
    );
    println!("  localisation error per target (horizontal, mm):");
    for (t, tt) in run.result.targets.iter().zip(&truth.targets) {
        match &t.map {
            Some(m) => {
                let e = (Point::new(m.x, m.y, 0.0) - Point::new(tt.map[0], tt.map[1], 0.0)).norm();
                println!("    target {:<4} {:>7.1}", t.id, e * 1000.0);
            }
            None => println!(
                "    target {:<4} not found: {}",
                t.id,
                t.reason.as_deref().unwrap_or("")
            ),
        }
    }
    println!();
    println!(
        "scene:    {} (map, survey.csv, survey_llh.csv, truth.json)",
        files.map.parent().unwrap_or(&a.out).display()
    );
    println!(
        "results:  {} (result.json, targets.csv, pairs.csv, report.html, crops/)",
        out.display()
    );
    println!(
        "time:     synthesis {:.1} s, evaluation {:.1} s, report {:.2} s",
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        t_report
    );
    Ok(())
}
