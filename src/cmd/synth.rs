//! `mapgauge synth`: write a synthetic map with known truth.

use mapgauge::cloud::OutFormat;
use mapgauge::synth::{self, SynthParams};
use mapgauge::{Error, Result};
use std::path::PathBuf;

/// Generate a LiDAR-like map of L-targets with known truth (map, survey.csv, truth.json, trajectory.txt).
#[derive(clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Output directory (created if missing): map.<ext>, survey.csv, survey_llh.csv, truth.json,
    /// trajectory.txt (the sensor's route in the map frame, TUM).
    #[arg(long, required_unless_present = "print_config")]
    out: Option<PathBuf>,
    /// Approximate number of map points [default: 2000000].
    #[arg(long)]
    points: Option<u64>,
    /// Random seed [default: 1].
    #[arg(long)]
    seed: Option<u64>,
    /// Number of targets, ids "1".."K" [default: 5].
    #[arg(long)]
    targets: Option<usize>,
    /// Map file format.
    #[arg(long, value_enum, default_value_t = OutFormat::Ply)]
    format: OutFormat,
    /// TOML file with any SynthParams fields (see --print-config); flags override it.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Also write labels.u16: what each map point is a return from, one
    /// little-endian u16 per point in the map's order: 0 the ground, 1
    /// anything else (clutter, decoys, obstacles), 16 + 4k + j for target k
    /// (0-based, the survey's order) with j = 0 its plate along the heading,
    /// 1 its other plate, 2 its post or antenna; a second pass's copies
    /// (`[second_pass]`) are labelled as the first's [default: off; a
    /// labels.u16 of an earlier run in OUT is removed]. For testing a locator
    /// against the plates' own points (numpy: `np.fromfile(path, "<u2")`).
    #[arg(long)]
    labels: bool,
    /// Print the effective parameters as TOML and exit.
    #[arg(long)]
    print_config: bool,
    /// Distance along the road over which targets are spread, m [default: 100].
    #[arg(long)]
    spread_m: Option<f64>,
    /// Targets' distance from the road, "MIN,MAX" m [default: 5,15].
    #[arg(long, value_parser = parse_pair)]
    target_distance_m: Option<[f64; 2]>,
    /// Ground slope, degrees [default: 1.5].
    #[arg(long)]
    slope_deg: Option<f64>,
    /// Ground undulation amplitude bound, m [default: 0.08].
    #[arg(long)]
    undulation_m: Option<f64>,
    /// Hard case: a pole and a cabinet this far from target 1, m [default: off].
    #[arg(long)]
    near_clutter_m: Option<f64>,
    /// Hard case: a bush touching target 2 [default: off].
    #[arg(long)]
    bush_touching: bool,
    /// Map tilt, degrees [default: 0].
    #[arg(long, allow_negative_numbers = true)]
    tilt_deg: Option<f64>,
    /// Map yaw relative to the survey frame, degrees [default: 1].
    #[arg(long, allow_negative_numbers = true)]
    yaw_deg: Option<f64>,
    /// Map offset relative to the survey frame, "X,Y,Z" m [default: 1.5,-1,0.3].
    #[arg(long, value_parser = parse_triple, allow_hyphen_values = true)]
    offset_m: Option<[f64; 3]>,
    /// LiDAR range noise (1 sigma), m [default: 0.02].
    #[arg(long)]
    range_noise_m: Option<f64>,
    /// Noise (1 sigma) added to surveyed positions, m [default: 0].
    #[arg(long)]
    survey_noise_m: Option<f64>,
    /// Scene-wide decoys (building corners, L boards, cabinets, small Ls,
    /// pallets) along the road [default: 0].
    #[arg(long)]
    decoys: Option<usize>,
    /// Target layout: road, or square (4 targets at a square's corners, side
    /// --spread-m, symmetric under 90° rotation) [default: road].
    #[arg(long, value_parser = ["road", "square"])]
    layout: Option<String>,
    /// False origin added to the survey (and truth world) positions, "X,Y,Z" m,
    /// e.g. 352000,4026000,0 for UTM-size coordinates [default: 0,0,0].
    #[arg(long, value_parser = parse_triple, allow_hyphen_values = true)]
    survey_false_origin_m: Option<[f64; 3]>,
    /// The targets' models in turn, comma-separated: target i is the
    /// (i mod count)-th (l, sphere, board; a sphere stands on a pole, 145 mm,
    /// its centre 1.3 m up; a board is a 0.6 m checkerboard on two legs, its
    /// centre 1.2 m up, printed in the intensity of the formats that have
    /// one: ply, pcd-xyzi, pcd-fastlio, pcd-compressed, ply-f32, xyz, las, laz)
    /// [default: l].
    #[arg(long, value_delimiter = ',')]
    models: Option<Vec<mapgauge::model::ModelKind>>,
}

fn parse_list<const N: usize>(s: &str) -> std::result::Result<[f64; N], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>().map_err(|e| format!("{t:?}: {e}")))
        .collect::<std::result::Result<_, _>>()?;
    v.try_into()
        .map_err(|_| format!("expected {N} comma-separated numbers"))
}

fn parse_pair(s: &str) -> std::result::Result<[f64; 2], String> {
    parse_list::<2>(s)
}

fn parse_triple(s: &str) -> std::result::Result<[f64; 3], String> {
    parse_list::<3>(s)
}

/// Builds the effective parameters: defaults, then the TOML file, then the flags.
fn params(a: &Args) -> Result<SynthParams> {
    let mut p = match &a.config {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
            toml::from_str::<SynthParams>(&text)
                .map_err(|e| Error::format(path, e.to_string().replace('\n', " ")))?
        }
        None => SynthParams::default(),
    };
    macro_rules! set {
        ($flag:expr, $field:expr) => {
            if let Some(v) = $flag {
                $field = v;
            }
        };
    }
    set!(a.points, p.points);
    set!(a.seed, p.seed);
    set!(a.targets, p.targets);
    set!(a.spread_m, p.spread_m);
    set!(a.target_distance_m, p.target_distance_m);
    set!(a.slope_deg, p.slope_deg);
    set!(a.undulation_m, p.undulation_m);
    set!(a.tilt_deg, p.distortion.tilt_deg);
    set!(a.yaw_deg, p.distortion.yaw_deg);
    set!(a.offset_m, p.distortion.offset_m);
    set!(a.range_noise_m, p.lidar.range_noise_m);
    set!(a.survey_noise_m, p.survey_noise_m);
    set!(a.decoys, p.clutter.decoys);
    set!(a.survey_false_origin_m, p.survey_false_origin_m);
    set!(a.models.clone(), p.models);
    if let Some(l) = &a.layout {
        p.layout = if l == "square" {
            synth::Layout::Square
        } else {
            synth::Layout::Road
        };
    }
    if a.near_clutter_m.is_some() {
        p.clutter.near_target_m = a.near_clutter_m;
    }
    if a.bush_touching {
        p.clutter.bush_touching = true;
    }
    p.validate()?;
    Ok(p)
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    let p = params(&a)?;
    if a.print_config {
        let text = toml::to_string(&p).map_err(|e| Error::Input(e.to_string()))?;
        out!("{text}");
        return Ok(());
    }
    let Some(dir) = a.out else {
        return Err(Error::Param("--out DIR is required".into()));
    };
    super::check_out_dir(&dir)?;
    if let Some(cfg) = &a.config {
        let ext = a.format.extension();
        for name in [
            &*format!("map.{ext}"),
            "survey.csv",
            "survey_llh.csv",
            "truth.json",
            "trajectory.txt",
            "labels.u16",
        ] {
            mapgauge::record::refuse_overwrite(&dir.join(name), &[cfg])?;
        }
    }
    let start = std::time::Instant::now();
    errln!(
        "synth: about {} points, {} targets, seed {}",
        p.points,
        p.targets,
        p.seed
    );
    // A board is told by its print in the intensity: a format without one
    // writes boards that eval cannot locate (said, not refused: a test of
    // that very message needs such a map).
    if p.models.contains(&mapgauge::model::ModelKind::Board) && !a.format.holds_intensity() {
        errln!(
            "synth: warning: --format {} holds no intensity, where boards print their \
             squares: eval will find none of them (formats with intensity: ply, pcd-xyzi, \
             pcd-fastlio, pcd-compressed, ply-f32, xyz, las, laz)",
            clap::ValueEnum::to_possible_value(&a.format)
                .map_or("?".into(), |v| v.get_name().to_string())
        );
    }
    if a.labels && p.targets > synth::PointLabel::MAX_TARGETS {
        return Err(Error::Param(format!(
            "--labels names at most {} targets, not {}",
            synth::PointLabel::MAX_TARGETS,
            p.targets
        )));
    }
    let (files, truth, expected) = if a.labels {
        synth::write_scene_labelled(&dir, &p, a.format)?
    } else {
        synth::write_scene(&dir, &p, a.format)?
    };
    let secs = start.elapsed().as_secs_f64();
    errln!(
        "synth: {} points in {} scans, {:.1} s ({:.2} M points/s)",
        truth.points,
        truth.scans,
        secs,
        truth.points as f64 / secs.max(1e-9) / 1e6
    );
    outln!("map         {}", files.map.display());
    outln!("survey      {}", files.survey.display());
    outln!("survey_llh  {}", files.survey_llh.display());
    outln!("truth       {}", files.truth.display());
    if let Some(l) = &files.labels {
        outln!("labels      {}", l.display());
    }
    outln!(
        "expected    E_abs {:.4} m, E_rel {:.4} m (true map positions, rigid2d)",
        expected.absolute.mean,
        expected.relative.mean
    );
    let level = mapgauge::pipeline::Config::default().frame.level_above_deg;
    if p.distortion.tilt_deg > level {
        outln!(
            "            (of the map as written, leaning {}°: eval levels a map leaning more than {level}°, so it measures without the tilt's share)",
            p.distortion.tilt_deg
        );
    }
    if p.clutter.decoys > 0 {
        outln!(
            "decoys      {} placed of {} asked",
            truth.decoys.len(),
            p.clutter.decoys
        );
    }
    for t in &truth.targets {
        outln!(
            "target {:>3}  world ({:9.3}, {:9.3}, {:7.3})  map ({:9.3}, {:9.3}, {:7.3})  {:>6} returns",
            t.id,
            t.world[0],
            t.world[1],
            t.world[2],
            t.map[0],
            t.map[1],
            t.map[2],
            t.points
        );
    }
    Ok(())
}
