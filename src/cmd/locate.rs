//! `mapgauge locate`: step 5 on tight crops, one row per file.

use mapgauge::locate::{self, Init, LocateParams, Located, Space};
use nalgebra::Vector3;
use std::path::PathBuf;

/// Output layout.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum OutFormat {
    /// Aligned columns for people.
    Table,
    /// One JSON array of objects, all details.
    Json,
    /// Header row `id,x,y,z,...`, one row per file.
    Csv,
}

/// Locate the corner of the L-target in each tight crop (k-means → RANSAC → SVD → corner).
#[derive(clap::Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Tight crops (PCD, PLY, LAS/LAZ, E57, XYZ), one target per file; id = file stem.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value = "table")]
    format: OutFormat,
    /// Seed of the random draws (same seed → same output).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Accepted samples to average.
    #[arg(long, default_value_t = LocateParams::default().samples)]
    samples: usize,
    /// Attempt limit per file.
    #[arg(long, default_value_t = LocateParams::default().max_attempts)]
    max_attempts: usize,
    /// RANSAC hypotheses per plate.
    #[arg(long, default_value_t = LocateParams::default().ransac_iterations)]
    ransac_iterations: usize,
    /// RANSAC inlier distance, metres.
    #[arg(long, default_value_t = LocateParams::default().inlier_threshold)]
    inlier_threshold: f64,
    /// Perpendicularity gates (plates to each other, each to the ground), degrees.
    #[arg(long, default_value_t = LocateParams::default().angle_tolerance_deg)]
    angle_tolerance: f64,
    /// SVD refits after RANSAC (0 = the paper).
    #[arg(long, default_value_t = LocateParams::default().refit_iterations)]
    refit_iterations: usize,
    /// Refit inlier band in noise standard deviations (0 = the RANSAC inlier distance).
    #[arg(long, default_value_t = LocateParams::default().refit_sigmas)]
    refit_sigmas: f64,
    /// Local vertical as X,Y,Z (e.g. a ground normal).
    #[arg(long, value_parser = parse_up, default_value = "0,0,1")]
    up: Vector3<f64>,
    /// Run the reference algorithm exactly (3D k-means, random start, no
    /// refit, 10,000 attempts, the corner at the plate inliers' mean height;
    /// without it, as `eval` does, at the middle of the plates' seen span,
    /// the JSON `covariance` covering what that span leaves open).
    #[arg(long)]
    paper: bool,
    /// Plate width and height `W[,H]` in metres [default: 0.6,0.6]: a crop
    /// much wider than the plates is refused as a loose crop, and the corner
    /// is placed at the middle of the plates' height (H defaults to W).
    #[arg(long, value_name = "W[,H]", value_parser = super::one_or_two, allow_hyphen_values = true)]
    plate_size: Option<(f64, Option<f64>)>,
}

fn parse_up(s: &str) -> Result<Vector3<f64>, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>().map_err(|e| format!("'{t}': {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] => Ok(Vector3::new(x, y, z)),
        _ => Err(format!("expected X,Y,Z, got {} values", v.len())),
    }
}

impl Args {
    fn params(&self) -> LocateParams {
        let base = if self.paper {
            LocateParams::paper()
        } else {
            LocateParams::default()
        };
        LocateParams {
            seed: self.seed,
            samples: self.samples,
            min_samples: base.min_samples.min(self.samples.max(1)),
            max_attempts: if self.paper && self.max_attempts == LocateParams::default().max_attempts
            {
                base.max_attempts
            } else {
                self.max_attempts
            },
            ransac_iterations: self.ransac_iterations,
            inlier_threshold: self.inlier_threshold,
            angle_tolerance_deg: self.angle_tolerance,
            refit_iterations: if self.paper { 0 } else { self.refit_iterations },
            refit_sigmas: self.refit_sigmas,
            kmeans_space: if self.paper {
                Space::Full
            } else {
                base.kmeans_space
            },
            kmeans_init: if self.paper {
                Init::Random
            } else {
                base.kmeans_init
            },
            ..base
        }
    }
}

#[derive(serde::Serialize)]
struct Row {
    id: String,
    file: String,
    status: &'static str,
    reason: Option<String>,
    #[serde(flatten)]
    located: Option<Located>,
}

/// Runs the command.
pub fn run(args: Args) -> mapgauge::Result<()> {
    let params = args.params();
    let plate = match args.plate_size {
        Some(p) => super::plate_size(p)?,
        None => {
            let t = mapgauge::crop::TightParams::default();
            (t.plate_width, t.plate_height)
        }
    };
    let width = plate.0;
    let up = args.up.try_normalize(0.0).unwrap_or(args.up);
    let mut rows = Vec::with_capacity(args.files.len());
    for path in &args.files {
        let id = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let result = mapgauge::cloud::read_all(path)
            .map_err(|e| e.to_string())
            .and_then(|pts| match mapgauge::crop::looks_loose(&pts, width) {
                Some(span) => Err(format!(
                    "{}: {}",
                    path.display(),
                    mapgauge::crop::loose_crop_message(span)
                )),
                None => locate::locate_either(&pts, Some(args.up), &params)
                    .map(|mut l| {
                        // As `eval` places it (the paper: the mean height).
                        if !args.paper {
                            locate::place_height(&pts, &mut l, &up, plate);
                        }
                        l
                    })
                    .map_err(|e| format!("{}: {e}", path.display())),
            });
        let row = match result {
            Ok(l) => Row {
                id,
                file: path.display().to_string(),
                status: "ok",
                reason: None,
                located: Some(l),
            },
            Err(reason) => {
                errln!("warning: {reason}");
                Row {
                    id,
                    file: path.display().to_string(),
                    status: "not_found",
                    reason: Some(reason),
                    located: None,
                }
            }
        };
        rows.push(row);
    }
    print(&rows, args.format)?;
    if rows.iter().all(|r| r.located.is_none()) {
        return Err(mapgauge::Error::Input("no target could be located".into()));
    }
    Ok(())
}

fn print(rows: &[Row], format: OutFormat) -> mapgauge::Result<()> {
    match format {
        OutFormat::Json => {
            let s = serde_json::to_string_pretty(rows)
                .map_err(|e| mapgauge::Error::Input(e.to_string()))?;
            outln!("{s}");
        }
        OutFormat::Csv => {
            // Into memory, then out! (a closed pipe is not an error).
            let mut w = csv::Writer::from_writer(Vec::new());
            let csv_err = |e: csv::Error| mapgauge::Error::Input(format!("<stdout>: {e}"));
            w.write_record([
                "id", "x", "y", "z", "std_x", "std_y", "std_z", "accepted", "attempts", "status",
                "reason",
            ])
            .map_err(csv_err)?;
            for r in rows {
                let mut rec: Vec<String> = vec![r.id.clone()];
                match &r.located {
                    Some(l) => {
                        rec.extend([l.corner.x, l.corner.y, l.corner.z].map(|v| format!("{v:.4}")));
                        rec.extend(l.std.map(|v| format!("{v:.5}")));
                        rec.extend([l.accepted.to_string(), l.attempts.to_string()]);
                    }
                    None => rec.extend(std::iter::repeat_n(String::new(), 8)),
                }
                rec.push(r.status.to_string());
                rec.push(r.reason.clone().unwrap_or_default());
                w.write_record(&rec).map_err(csv_err)?;
            }
            let bytes = w
                .into_inner()
                .map_err(|e| mapgauge::Error::Input(format!("<stdout>: {e}")))?;
            out!("{}", String::from_utf8_lossy(&bytes));
        }
        OutFormat::Table => {
            let idw = rows.iter().map(|r| r.id.len()).max().unwrap_or(2).max(2);
            outln!(
                "{:<idw$}  {:>14}  {:>14}  {:>10}  {:>10}  {:>13}  status",
                "id",
                "x",
                "y",
                "z",
                "spread_mm",
                "accepted"
            );
            for r in rows {
                match &r.located {
                    Some(l) => outln!(
                        "{:<idw$}  {:>14.4}  {:>14.4}  {:>10.4}  {:>10.2}  {:>13}  ok",
                        r.id,
                        l.corner.x,
                        l.corner.y,
                        l.corner.z,
                        l.spread() * 1000.0,
                        format!("{}/{}", l.accepted, l.attempts)
                    ),
                    None => outln!(
                        "{:<idw$}  {:>14}  {:>14}  {:>10}  {:>10}  {:>13}  {}",
                        r.id,
                        "-",
                        "-",
                        "-",
                        "-",
                        "-",
                        r.reason.as_deref().unwrap_or("failed")
                    ),
                }
            }
        }
    }
    Ok(())
}
