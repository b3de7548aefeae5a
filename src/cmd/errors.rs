//! `mapgauge errors`: steps 6–7 on positions already located (paper Tables I/II).

use mapgauge::accuracy::{Dim, ScoreOptions, score};
use mapgauge::align::AlignMethod;
use mapgauge::record::ResultFile;
use mapgauge::render::{OutputFormat, write_outputs};
use mapgauge::survey::{Geodetic, SurveyOptions, read_estimates, read_survey};
use mapgauge::{Error, Result};
use std::path::PathBuf;

/// Flags of `mapgauge errors`.
#[derive(clap::Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Survey CSV: id and x,y[,z] (local metres) or lat,lon[,alt] (WGS84); optional role, antenna_height.
    #[arg(long)]
    pub survey: PathBuf,
    /// Estimates CSV in the map frame: id,x,y[,z] (extra columns ignored), or
    /// the targets.csv an eval wrote (its map_x, map_y, map_z and status).
    #[arg(long)]
    pub estimates: PathBuf,
    /// Alignment map → survey: none, rigid2d, rigid2d+z, rigid3d, similarity2d, similarity3d, robust2d.
    #[arg(long, default_value = "rigid2d")]
    pub align: AlignMethod,
    /// Error dimension: 2d (x, y as the paper) or 3d (needs heights on both sides).
    #[arg(long, default_value = "2d")]
    pub dim: Dim,
    /// Output on stdout: table, json, csv, markdown, latex.
    #[arg(long, default_value = "table")]
    pub format: OutputFormat,
    /// With `--format table`, also print every pair's relative error.
    #[arg(long, short)]
    pub verbose: bool,
    /// Survey's own 1-σ error in metres, horizontal[,vertical], folded into the ASPRS RMSEs.
    #[arg(long, value_name = "H[,V]", value_parser = super::one_or_two, allow_hyphen_values = true)]
    pub survey_sigma: Option<(f64, Option<f64>)>,
    /// ENU origin lat,lon,alt for lat/lon surveys [default: the first target].
    #[arg(long, value_name = "LAT,LON[,ALT]", value_parser = super::origin, allow_hyphen_values = true)]
    pub origin: Option<Geodetic>,
    /// Also write result.json, targets.csv and pairs.csv into this directory.
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub surveyor: super::SurveyorArgs,
    #[command(flatten)]
    pub checkpoints: super::CheckpointArgs,
    #[command(flatten)]
    pub gates: super::GateArgs,
}

/// Runs `mapgauge errors`; `Ok` holds the exit code its gates decided.
pub fn run(a: Args) -> Result<u8> {
    if let Some((h, v)) = a.survey_sigma {
        if h < 0.0 || v.is_some_and(|v| v < 0.0) {
            return Err(Error::Param("--survey-sigma must be ≥ 0".into()));
        }
    }
    if let Some(t) = a.surveyor.threshold
        && !(t.is_finite() && (0.0..=1e3).contains(&t))
    {
        return Err(Error::Param(format!(
            "--threshold {t}: a distance from 0 to 1000 m"
        )));
    }
    if let Some(out) = &a.out {
        super::check_out_dir(out)?;
    }
    a.gates.check(&[&a.survey, &a.estimates])?;
    a.checkpoints.check(&[&a.survey, &a.estimates])?;
    a.checkpoints
        .check_outputs(a.out.as_deref(), a.gates.junit.as_deref())?;
    let survey = read_survey(&a.survey, &SurveyOptions { origin: a.origin })?;
    a.checkpoints.check_survey(survey.frame)?;
    super::check_origin_used(&survey, a.origin, &a.survey)?;
    let estimates = read_estimates(&a.estimates)?;
    let acc = score(
        &survey,
        &estimates,
        &ScoreOptions {
            method: a.align,
            dim: a.dim,
            survey_sigma: a.survey_sigma,
            vertical: None,
            threshold: a.surveyor.threshold,
        },
    )?;
    let mut result = ResultFile::from_accuracy(&acc, &survey);
    mapgauge::scores::apply(&a.surveyor.score, &mut result);
    let policy = a.gates.gate_policy.unwrap_or_default();
    mapgauge::gate::judge(&a.gates.gate, policy, &mut result);
    if let Some(dir) = &a.out {
        mapgauge::render::refuse_overwriting_inputs(dir, &[&a.survey, &a.estimates])?;
        write_outputs(&result, dir)?;
        errln!("wrote {}", dir.join("result.json").display());
    }
    super::eval::print_result(&result, a.format, a.verbose);
    a.checkpoints.write(&result)?;
    if a.format != OutputFormat::Table(mapgauge::render::TableFormat::Text) {
        for line in mapgauge::render::gate_lines(&result) {
            errln!("{line}");
        }
    }
    a.gates.write_junit(&result, "mapgauge errors")?;
    Ok(result.gate_outcome.map_or(0, |o| o.exit_code))
}
