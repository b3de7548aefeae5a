//! `mapgauge errors`: steps 6–7 on positions already located (paper Tables I/II).

use mapgauge::align::AlignMethod;
use mapgauge::metrics::{Dim, EvalOptions, evaluate};
use mapgauge::result::{parse_output_format, render_report, write_outputs};
use mapgauge::survey::{SurveyOptions, read_estimates, read_survey};
use mapgauge::{Error, Result};
use std::path::PathBuf;

/// Flags of `mapgauge errors`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Survey CSV: id and x,y[,z] (local metres) or lat,lon[,alt] (WGS84); optional role, antenna_height.
    #[arg(long)]
    pub survey: PathBuf,
    /// Estimates CSV in the map frame: id,x,y[,z] (extra columns ignored).
    #[arg(long)]
    pub estimates: PathBuf,
    /// Alignment map → survey: none, rigid2d, rigid2d+z, rigid3d, similarity2d, similarity3d, robust2d.
    #[arg(long, default_value = "rigid2d")]
    pub align: String,
    /// Error dimension: 2d (x, y as the paper) or 3d (needs heights on both sides).
    #[arg(long, default_value = "2d")]
    pub dim: String,
    /// Output on stdout: table, json, csv, markdown, latex.
    #[arg(long, default_value = "table")]
    pub format: String,
    /// Survey's own 1-σ error in metres, horizontal[,vertical], folded into the ASPRS RMSEs.
    #[arg(long, value_name = "H[,V]")]
    pub survey_sigma: Option<String>,
    /// ENU origin lat,lon,alt for lat/lon surveys [default: the first target].
    #[arg(long, value_name = "LAT,LON,ALT")]
    pub origin: Option<String>,
    /// Also write result.json, targets.csv and pairs.csv into this directory.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `mapgauge errors`.
pub fn run(a: Args) -> Result<()> {
    let method: AlignMethod = a.align.parse()?;
    let dim: Dim = a.dim.parse()?;
    let survey_sigma = match &a.survey_sigma {
        None => None,
        Some(s) => {
            let v = super::numbers("survey-sigma", s, 1, 2)?;
            if v.iter().any(|x| *x < 0.0) {
                return Err(Error::Param("--survey-sigma must be ≥ 0".into()));
            }
            Some((v[0], v.get(1).copied()))
        }
    };
    let origin = a.origin.as_deref().map(super::parse_origin).transpose()?;
    let fmt = parse_output_format(&a.format)?;
    let survey = read_survey(&a.survey, &SurveyOptions { origin })?;
    let estimates = read_estimates(&a.estimates)?;
    let result = evaluate(
        &survey,
        &estimates,
        &EvalOptions {
            method,
            dim,
            survey_sigma,
        },
    )?;
    if let Some(dir) = &a.out {
        for name in ["result.json", "targets.csv", "pairs.csv"] {
            super::refuse_overwrite(&dir.join(name), &[&a.survey, &a.estimates])?;
        }
        write_outputs(&result, dir)?;
        eprintln!("wrote {}", dir.join("result.json").display());
    }
    match fmt {
        None => print!("{}", result.to_json()),
        Some(f) => print!("{}", render_report(&result, f)),
    }
    Ok(())
}
