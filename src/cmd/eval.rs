//! `mapgauge eval`: the whole pipeline, map to accuracy.

use super::{file_stem_for, parse_triple, progress_bar, refuse_overwrite};
use mapgauge::align::AlignMethod;
use mapgauge::cloud::{self, OutFormat};
use mapgauge::crop::Shape;
use mapgauge::eval::{EvalConfig, EvalInputs, EvalRun, evaluate_map};
use mapgauge::metrics::Dim;
use mapgauge::report::{InputFile, Provenance, Report};
use mapgauge::result;
use mapgauge::survey::{SurveyOptions, read_survey};
use mapgauge::{Error, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// Measure a map's accuracy: crop, locate every target, align, report.
#[derive(clap::Args, Clone)]
pub struct Args {
    /// Map file (PCD, PLY, LAS/LAZ, E57, XYZ; recognised from its content).
    #[arg(long, required_unless_present = "print_config")]
    pub map: Option<PathBuf>,
    /// Survey CSV (id,x,y[,z][,antenna_height][,role] or id,lat,lon[,alt]...).
    #[arg(long, required_unless_present = "print_config")]
    pub survey: Option<PathBuf>,
    /// Directory for result.json, targets.csv, pairs.csv (and crops with --save-crops).
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
    /// Also write the loose and tight crops (PLY) under OUT/crops/.
    #[arg(long, requires = "out")]
    pub save_crops: bool,
    /// Alignment map → survey: none, rigid2d, rigid2d+z, rigid3d, similarity2d, similarity3d, robust2d [default: rigid2d].
    #[arg(long)]
    pub align: Option<AlignMethod>,
    /// Error dimension: 2d (the paper) or 3d [default: 2d].
    #[arg(long)]
    pub dim: Option<Dim>,
    /// Survey's own 1-σ error `H[,V]` in metres, folded into the ASPRS statistics.
    #[arg(long)]
    pub survey_sigma: Option<String>,
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
    #[arg(long)]
    pub plate_size: Option<String>,
    /// Approximate map → survey transform `x,y,yaw_deg` when the map is not in the survey frame.
    #[arg(long)]
    pub init: Option<String>,
    /// ENU origin `lat,lon,alt` for WGS84 surveys [default: the first target].
    #[arg(long)]
    pub origin: Option<String>,
    /// What to print on stdout: table, json, markdown, latex, csv, html.
    #[arg(long, default_value = "table")]
    pub format: String,
    /// Do not write OUT/report.html (written by default with --out; it reads the
    /// map once more for its SHA-256, about 1 s per GB).
    #[arg(long)]
    pub no_report: bool,
    /// Also write the report's figures as DIR/<name>.svg and DIR/<name>.png.
    #[arg(long)]
    pub plots: Option<PathBuf>,
}

/// Builds the configuration: defaults, then the TOML file, then flags.
pub fn config(a: &Args) -> Result<EvalConfig> {
    let mut cfg = match &a.config {
        Some(p) => EvalConfig::from_toml_file(p)?,
        None => EvalConfig::default(),
    };
    if let Some(m) = a.align {
        cfg.metrics.align = m;
    }
    if let Some(d) = a.dim {
        cfg.metrics.dim = d;
    }
    if let Some(s) = &a.survey_sigma {
        let v = super::numbers("survey-sigma", s, 1, 2)?;
        cfg.metrics.survey_sigma_h = v.first().copied();
        cfg.metrics.survey_sigma_v = v.get(1).copied();
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
    if let Some(s) = &a.plate_size {
        let v = super::numbers("plate-size", s, 1, 2)?;
        if v.iter().any(|&x| x <= 0.0) {
            return Err(Error::Param(format!(
                "--plate-size `{s}`: sizes must be positive"
            )));
        }
        cfg.tight.plate_width = v[0];
        cfg.tight.plate_height = v.get(1).copied().unwrap_or(v[0]);
    }
    if let Some(s) = &a.init {
        cfg.frame.init = Some(parse_triple(s, "init")?);
    }
    Ok(cfg)
}

/// Runs `eval`.
pub fn run(a: Args) -> Result<()> {
    let cfg = config(&a)?;
    if a.print_config {
        print!("{}", cfg.to_toml());
        return Ok(());
    }
    let (Some(map), Some(survey_path)) = (a.map.as_deref(), a.survey.as_deref()) else {
        return Err(Error::Param("--map and --survey are required".into()));
    };
    let fmt = result::parse_output_format(&a.format)?;
    if let Some(out) = &a.out {
        // Before the work, not after it: a refused output should cost nothing.
        for name in ["result.json", "targets.csv", "pairs.csv"] {
            refuse_overwrite(&out.join(name), &[map, survey_path])?;
        }
    }
    let mut inputs: Vec<(&str, &Path)> = vec![("map", map), ("survey", survey_path)];
    if let Some(c) = &a.config {
        inputs.push(("config", c));
    }
    let html = match &a.out {
        Some(out) if !a.no_report => Some(out.join("report.html")),
        _ => None,
    };
    // The report's SHA-256 reads the map once more (1.3 GB/s: 3.7 s of a 5.8 s
    // eval of a 200 M-point map when done after the run), so it runs on a
    // thread of its own alongside the pipeline, and stops if the run fails.
    let stop = AtomicBool::new(false);
    let (run, hashed) = std::thread::scope(|s| {
        let hasher = html.is_some().then(|| {
            let (inputs, stop) = (&inputs, &stop);
            s.spawn(move || hash_inputs(inputs, stop))
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
    let run = run?;
    // A failed hash costs the report, not the results: they are printed and
    // written first, and the error comes last.
    let (hashed, hash_error) = match hashed.transpose() {
        Ok(h) => (h.flatten(), None),
        Err(e) => (None, Some(e)),
    };
    match fmt {
        Some(result::TableFormat::Html) => print!(
            "{}",
            mapgauge::report::html::page(
                "mapgauge result",
                &result::render_report(&run.result, result::TableFormat::Html),
                &[]
            )
        ),
        Some(f) => print!("{}", result::render_report(&run.result, f)),
        None => print!("{}", run.result.to_json()),
    }
    if let Some(out) = &a.out {
        write_outputs(&run, out, a.save_crops, &[map, survey_path])?;
        eprintln!("results written to {}", out.display());
    }
    let in_paths: Vec<&Path> = inputs.iter().map(|i| i.1).collect();
    if let Some(e) = hash_error {
        return Err(e);
    }
    write_report(
        &run,
        &cfg,
        hashed,
        &in_paths,
        html.as_deref(),
        a.plots.as_deref(),
    )?;
    Ok(())
}

/// Sets its flag when dropped.
struct StopOnDrop<'a>(&'a AtomicBool);

impl Drop for StopOnDrop<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// The inputs' sizes and SHA-256 with the seconds it took, or `None` once
/// `stop` is set.
pub fn hash_inputs(
    inputs: &[(&str, &Path)],
    stop: &AtomicBool,
) -> Result<Option<(Vec<InputFile>, f64)>> {
    let t0 = std::time::Instant::now();
    let mut files = Vec::new();
    for (role, p) in inputs {
        match InputFile::hash_unless(role, p, stop)? {
            Some(f) => files.push(f),
            None => return Ok(None),
        }
    }
    Ok(Some((files, t0.elapsed().as_secs_f64())))
}

/// Writes report.html (when `html` is given; `hashed` holds the inputs' sizes
/// and SHA-256 for it, from [`hash_inputs`]) and the figures as SVG and PNG
/// under `plots`; logs what it cost on stderr.
pub fn write_report(
    run: &EvalRun,
    cfg: &EvalConfig,
    hashed: Option<(Vec<InputFile>, f64)>,
    in_paths: &[&Path],
    html: Option<&Path>,
    plots: Option<&Path>,
) -> Result<()> {
    if html.is_none() && plots.is_none() {
        return Ok(());
    }
    let t0 = std::time::Instant::now();
    let mut prov = Provenance::new(Some(cfg.locate.seed), Some(cfg.to_toml()));
    let t_hash = hashed.as_ref().map_or(0.0, |h| h.1);
    if html.is_some() {
        prov.inputs = hashed.map(|h| h.0).unwrap_or_default();
    }
    let report = Report::from_run(run, prov);
    if let Some(h) = html {
        refuse_overwrite(h, in_paths)?;
        report.write_html(h)?;
        eprintln!(
            "report written to {} in {:.2} s (SHA-256 of the inputs took {:.2} s)",
            h.display(),
            t0.elapsed().as_secs_f64(),
            t_hash
        );
    }
    if let Some(dir) = plots {
        let t1 = std::time::Instant::now();
        let files = report.write_plots(dir)?;
        eprintln!(
            "{} figure files written to {} in {:.2} s",
            files.len(),
            dir.display(),
            t1.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

/// Reads the survey and runs the pipeline with a progress bar.
pub fn evaluate(map: &Path, survey_path: &Path, a: &Args, cfg: &EvalConfig) -> Result<EvalRun> {
    let origin = a.origin.as_deref().map(super::parse_origin).transpose()?;
    let survey = read_survey(survey_path, &SurveyOptions { origin })?;
    let pb = progress_bar(
        std::fs::metadata(map).map(|m| m.len()).unwrap_or(0),
        "reading map",
    );
    let inputs = EvalInputs {
        map,
        survey: &survey,
        survey_path,
        crops_dir: a.crops.clone(),
    };
    let run = evaluate_map(&inputs, cfg, |b, _| {
        if let Some(pb) = &pb {
            pb.set_position(b)
        }
    })?;
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    for t in &run.result.targets {
        if let Some(r) = &t.reason {
            eprintln!("warning: target {} {}: {r}", t.id, t.status);
        }
    }
    Ok(run)
}

/// Writes result files (and crops) into `out`.
pub fn write_outputs(run: &EvalRun, out: &Path, save_crops: bool, inputs: &[&Path]) -> Result<()> {
    for name in ["result.json", "targets.csv", "pairs.csv"] {
        refuse_overwrite(&out.join(name), inputs)?;
    }
    result::write_outputs(&run.result, out)?;
    if save_crops {
        for (kind, crops) in [("loose", &run.loose), ("tight", &run.tight)] {
            let dir = out.join("crops").join(kind);
            std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
            for (t, pts) in run.result.targets.iter().zip(crops.iter()) {
                if pts.is_empty() {
                    continue;
                }
                let p = dir.join(format!("{}.ply", file_stem_for(&t.id)));
                refuse_overwrite(&p, inputs)?;
                cloud::write(&p, OutFormat::Ply, pts)?;
            }
        }
    }
    Ok(())
}
