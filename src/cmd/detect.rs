//! `mapgauge detect`: every target-shaped object in a map, without a survey.

use mapgauge::cloud::MapSource;
use mapgauge::crop::TightParams;
use mapgauge::detect::{DetectParams, Detection, detect_map};
use mapgauge::frame::ground_level;
use mapgauge::record::write_atomic;
use mapgauge::{Error, Result};
use std::fmt::Write as _;
use std::path::PathBuf;

/// List every object shaped like a target (two perpendicular plates of the
/// configured size meeting at a vertical edge) anywhere in the map.
#[derive(clap::Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// The map (PCD, PLY, LAS/LAZ, E57, XYZ, PTS), or an Autoware tiled map
    /// (a folder of PCD tiles or its `*metadata*.yaml`).
    #[arg(long)]
    map: PathBuf,
    /// Directory for detections.csv and detections.ply (corners and the L's
    /// arms, to view with the map); without it, only the table is printed.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Plate width[,height] in metres (default 0.6,0.6: the paper's target).
    #[arg(long, value_parser = super::one_or_two, allow_hyphen_values = true)]
    plate_size: Option<(f64, Option<f64>)>,
    /// The map is levelled when its ground leans more than this (degrees).
    #[arg(long, default_value_t = mapgauge::pipeline::FrameConfig::default().level_above_deg)]
    level_above: f64,
    /// Also look for spheres of this diameter (m; 0.145 and 0.2 are the
    /// common scanning spheres): listed with model `sphere`, their centre
    /// as the position. Default: Ls only.
    #[arg(long, value_name = "M")]
    sphere_diameter: Option<f64>,
    /// Also look for checkerboard boards of this side (m; 0.6 is a common
    /// ground-control board) standing in the map: listed with model
    /// `board`, the point where its four squares meet as the position.
    /// Needs the map's intensity; boards lying flat are not detected
    /// map-wide. Default: Ls only.
    #[arg(long, value_name = "M")]
    board_side: Option<f64>,
}

pub fn run(a: Args) -> Result<()> {
    if let Some(out) = &a.out {
        super::check_out_dir(out)?;
    }
    let mut tight = TightParams::default();
    if let Some((w, h)) = a.plate_size {
        if !(w > 0.05 && w <= 5.0 && h.is_none_or(|h| h > 0.05 && h <= 5.0)) {
            return Err(Error::Param(
                "--plate-size: width and height must be in (0.05, 5] m".into(),
            ));
        }
        tight.plate_width = w;
        tight.plate_height = h.unwrap_or(w);
    }
    let sphere = mapgauge::model::SphereParams::default();
    if let Some(d) = a.sphere_diameter {
        mapgauge::model::ModelKind::Sphere
            .check_size(d)
            .map_err(|e| Error::Param(format!("--sphere-diameter: {e}")))?;
    }
    let board = mapgauge::model::BoardParams::default();
    if let Some(d) = a.board_side {
        mapgauge::model::ModelKind::Board
            .check_size(d)
            .map_err(|e| Error::Param(format!("--board-side: {e}")))?;
    }
    mapgauge::cloud::refuse_non_metric(&a.map)?;
    let source = MapSource::File(&a.map);
    let ground = ground_level(source, None, None, |_| {})?;
    // A georeferenced map (its header declares a CRS) is vertical by
    // construction, as in `eval`: its ground's lean is the terrain's.
    let crs = mapgauge::cloud::declared_crs(&a.map);
    let min_support = mapgauge::pipeline::FrameConfig::default().level_min_support;
    let motion = match &crs {
        Some(_) => mapgauge::cloud::RigidMotion::identity_at(ground.centre),
        None => ground.levelling(a.level_above, min_support),
    };
    let found = detect_map(
        source,
        &ground,
        &motion,
        &DetectParams::default(),
        mapgauge::detect::Models {
            tight: &tight,
            sphere: a.sphere_diameter.map(|d| (&sphere, d)),
            board: a.board_side.map(|d| (&board, d)),
        },
        |_| {},
    )?;
    let models = a.sphere_diameter.is_some() || a.board_side.is_some();
    let mut s = String::new();
    let _ = writeln!(s, "map: {} ({} points)", a.map.display(), ground.points);
    match &ground.level {
        Some(l) => {
            let _ = writeln!(
                s,
                "ground: leans {:.2}° towards {:.0}° ({:.0} % of {} ground blocks agree){}",
                l.tilt_deg,
                l.azimuth_deg,
                100.0 * l.support,
                l.blocks,
                match (&crs, motion.is_identity()) {
                    (Some(c), _) if l.tilt_deg > a.level_above => format!(
                        "; not levelled: the map declares a coordinate reference system ({c}), z vertical by construction"
                    ),
                    (_, false) => "; the map was levelled for detection".into(),
                    _ if l.tilt_deg > a.level_above => format!(
                        "; not levelled: levelling by the ground asks for {:.0} % to agree (terrain's own slopes scatter, a tilted map's ground leans alike)",
                        100.0 * min_support
                    ),
                    _ => String::new(),
                }
            );
        }
        None => s.push_str(
            "ground: too little flat ground seen to estimate its lean (fewer than 20 flat 2 m blocks); the map is read as it is, not levelled\n",
        ),
    }
    let _ = writeln!(
        s,
        "{} target-shaped object(s) among {} candidate group(s)",
        found.detections.len(),
        found.candidates
    );
    for (why, n) in found.rejected.iter().take(5) {
        let _ = writeln!(s, "  rejected {n}: {why}");
    }
    if let Some(why) = &found.boards_not_looked_for {
        let _ = writeln!(
            s,
            "boards: not looked for: {why} (a board is told by its print)"
        );
    }
    if !found.detections.is_empty() {
        s.push_str(&table(&found.detections, models));
    }
    out!("{s}");
    if let Some(out) = &a.out {
        std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
        write_atomic(
            &out.join("detections.csv"),
            csv(&found.detections, models).as_bytes(),
        )?;
        write_atomic(
            &out.join("detections.ply"),
            ply(&found.detections, &tight, &motion).as_bytes(),
        )?;
        outln!(
            "wrote {} and {}",
            out.join("detections.csv").display(),
            out.join("detections.ply").display()
        );
    }
    Ok(())
}

/// The detections, one a line; with `models` (spheres were looked for),
/// a last column says which model each is.
fn table(d: &[Detection], models: bool) -> String {
    let mut s = format!(
        "{:>4} {:>14} {:>14} {:>10} {:>8} {:>13} {:>7} {:>7} {:>6}{}\n",
        "#",
        "x",
        "y",
        "z",
        "heading",
        "widths",
        "height",
        "support",
        "score",
        if models { "  model" } else { "" }
    );
    for (i, d) in d.iter().enumerate() {
        let c = d.corner_map;
        let _ = writeln!(
            s,
            "{:>4} {:>14.3} {:>14.3} {:>10.3} {:>7.1}° {:>6.2}×{:<6.2} {:>7.2} {:>7} {:>6.2}{}",
            i + 1,
            c.x,
            c.y,
            c.z,
            d.heading_deg,
            d.plate_widths[0],
            d.plate_widths[1],
            d.plate_height,
            d.support,
            d.score,
            model_column(d, models, "  ")
        );
    }
    s
}

/// `sep` and the detection's model, when models are listed.
fn model_column(d: &Detection, models: bool, sep: &str) -> String {
    if models {
        format!("{sep}{}", d.model)
    } else {
        String::new()
    }
}

fn csv(d: &[Detection], models: bool) -> String {
    let mut s = format!(
        "n,x,y,z,heading_deg,plate_width_a,plate_width_b,plate_height,support,score{}\n",
        if models { ",model" } else { "" }
    );
    for (i, d) in d.iter().enumerate() {
        let c = d.corner_map;
        let _ = writeln!(
            s,
            "{},{:.4},{:.4},{:.4},{:.2},{:.3},{:.3},{:.3},{},{:.3}{}",
            i + 1,
            c.x,
            c.y,
            c.z,
            d.heading_deg,
            d.plate_widths[0],
            d.plate_widths[1],
            d.plate_height,
            d.support,
            d.score,
            model_column(d, models, ",")
        );
    }
    s
}

/// Each detection as a red L (a sphere as its horizontal great circle): its two arms at mid-height, drawn in the
/// levelled frame and moved back into the map's own.
fn ply(d: &[Detection], t: &TightParams, motion: &mapgauge::cloud::RigidMotion) -> String {
    let mut v = Vec::new();
    for (i, d) in d.iter().enumerate() {
        if d.model == mapgauge::model::ModelKind::Sphere {
            let r = d.plate_widths[0] / 2.0;
            for k in 0..48 {
                let a = std::f64::consts::TAU * k as f64 / 48.0;
                let c = d.corner;
                let p = nalgebra::Point3::new(c.x + r * a.cos(), c.y + r * a.sin(), c.z);
                v.push((motion.invert(&p), i + 1));
            }
            continue;
        }
        if d.model == mapgauge::model::ModelKind::Board {
            // Its outline, standing across its face's normal (the boards
            // detected map-wide stand), and the lines where its squares meet.
            let (h, s) = (d.heading_deg.to_radians(), d.plate_height / 2.0);
            let e1 = nalgebra::Vector3::new(-h.sin(), h.cos(), 0.0);
            let e2 = nalgebra::Vector3::z();
            let at = |u: f64, w: f64| motion.invert(&(d.corner + e1 * u + e2 * w));
            for k in 0..=24 {
                let f = s * (2.0 * k as f64 / 24.0 - 1.0);
                for q in [
                    at(f, -s),
                    at(f, s),
                    at(-s, f),
                    at(s, f),
                    at(f, 0.0),
                    at(0.0, f),
                ] {
                    v.push((q, i + 1));
                }
            }
            continue;
        }
        let h = d.heading_deg.to_radians();
        let arms = [
            h - std::f64::consts::FRAC_PI_4,
            h + std::f64::consts::FRAC_PI_4,
        ];
        for a in arms {
            for k in 0..=24 {
                let r = t.plate_width * k as f64 / 24.0;
                let c = d.corner;
                let p = nalgebra::Point3::new(c.x + r * a.cos(), c.y + r * a.sin(), c.z);
                v.push((motion.invert(&p), i + 1));
            }
        }
    }
    let mut s = format!(
        "ply\nformat ascii 1.0\ncomment mapgauge detect: target-shaped objects\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty int detection\nend_header\n",
        v.len()
    );
    for (p, i) in v {
        let _ = writeln!(s, "{:.4} {:.4} {:.4} 255 0 0 {i}", p.x, p.y, p.z);
    }
    s
}
