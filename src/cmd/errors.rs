//! `mapgauge errors`: steps 6–7 on positions already located (paper Tables I/II).

use mapgauge::align::AlignMethod;
use mapgauge::metrics::{Dim, EvalOptions, evaluate};
use mapgauge::result::{parse_output_format, render_report, write_outputs};
use mapgauge::survey::{Geodetic, SurveyOptions, read_estimates, read_survey};
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

fn numbers(flag: &str, s: &str, min: usize, max: usize) -> Result<Vec<f64>> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| Error::Param(format!("--{flag} `{s}`: not a list of numbers")))?;
    if v.len() < min || v.len() > max {
        return Err(Error::Param(format!(
            "--{flag} `{s}`: expected {min} to {max} comma-separated numbers"
        )));
    }
    Ok(v)
}

/// Runs `mapgauge errors`.
pub fn run(a: Args) -> Result<()> {
    let method: AlignMethod = a.align.parse()?;
    let dim: Dim = a.dim.parse()?;
    let survey_sigma = match &a.survey_sigma {
        None => None,
        Some(s) => {
            let v = numbers("survey-sigma", s, 1, 2)?;
            if v.iter().any(|x| *x < 0.0) {
                return Err(Error::Param("--survey-sigma must be ≥ 0".into()));
            }
            Some((v[0], v.get(1).copied()))
        }
    };
    let origin = match &a.origin {
        None => None,
        Some(s) => {
            let v = numbers("origin", s, 2, 3)?;
            if !(-90.0..=90.0).contains(&v[0]) {
                return Err(Error::Param(format!(
                    "--origin latitude {} is outside -90..90",
                    v[0]
                )));
            }
            Some(Geodetic {
                lat: v[0],
                lon: v[1],
                alt: v.get(2).copied().unwrap_or(0.0),
            })
        }
    };
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
        write_outputs(&result, dir)?;
        eprintln!("wrote {}", dir.join("result.json").display());
    }
    match fmt {
        None => print!("{}", result.to_json()),
        Some(f) => print!("{}", render_report(&result, f)),
    }
    Ok(())
}
