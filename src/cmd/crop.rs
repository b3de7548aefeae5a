//! `mapgauge crop`: loose crops around every surveyed target, for hand editing.

use super::progress_bar;
use mapgauge::cloud::{self, OutFormat};
use mapgauge::crop::{LooseParams, Shape, loose_crop_each};
use mapgauge::frame::MapToSurvey;
use mapgauge::record::refuse_overwrite;
use mapgauge::survey::{Geodetic, SurveyOptions, file_stem, read_survey_for_map};
use mapgauge::{Point, Result};
use std::path::PathBuf;

/// Cut the map around every surveyed target (one pass over the map).
#[derive(clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Map file (PCD, PLY, LAS/LAZ, E57, PTS, XYZ; recognised from its content), or an
    /// Autoware tiled map: a folder of PCD tiles or its `*metadata*.yaml`.
    #[arg(long)]
    map: PathBuf,
    /// Survey CSV (id,x,y[,z] or id,lat,lon[,alt]).
    #[arg(long)]
    survey: PathBuf,
    /// Output directory; one file per target id.
    #[arg(long)]
    out: PathBuf,
    /// Crop radius in metres (0.001 to 10000, as `crop.radius` for eval).
    #[arg(long, default_value_t = 5.0)]
    radius: f64,
    /// Crop shape: vertical cylinder (horizontal distance) or sphere.
    #[arg(long, value_enum, default_value_t = Shape::Cylinder)]
    shape: Shape,
    /// Write the automatic tight crops instead (ground removed, the target's
    /// plates isolated, as `eval` makes them): what `locate` and `eval --crops`
    /// expect. Loose crops keep the ground, for inspection or hand editing.
    #[arg(long)]
    tight: bool,
    /// Plate width and height `W[,H]` in metres, for `--tight` [default: 0.6,0.6].
    #[arg(long, value_name = "W[,H]", value_parser = super::one_or_two, allow_hyphen_values = true)]
    plate_size: Option<(f64, Option<f64>)>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutFormat::Ply)]
    format: OutFormat,
    /// ENU origin `lat,lon[,alt]` for WGS84 surveys [default: the first target].
    #[arg(long, value_name = "LAT,LON[,ALT]", value_parser = super::origin, allow_hyphen_values = true)]
    origin: Option<Geodetic>,
    /// Approximate map → survey transform `x,y,yaw_deg` (survey = R(yaw)·map + (x, y))
    /// when the map is not in the survey frame.
    #[arg(long, value_name = "X,Y,YAW_DEG", value_parser = super::triple, allow_hyphen_values = true)]
    init: Option<[f64; 3]>,
}

/// Runs `crop`.
pub fn run(a: Args) -> Result<()> {
    check_args(&a)?;
    super::check_out_dir(&a.out)?;
    // Radii and plate sizes are metres, as in `eval`.
    cloud::refuse_non_metric(&a.map)?;
    let projector = cloud::map_projector(&a.map)?;
    let survey = read_survey_for_map(
        &a.survey,
        &SurveyOptions { origin: a.origin },
        projector.as_deref(),
    )?;
    super::say_projected(&survey, projector.as_deref());
    super::check_origin_used(&survey, a.origin, &a.survey)?;
    let init = a.init.map_or(MapToSurvey::IDENTITY, MapToSurvey::from);
    let centres: Vec<Point> = survey
        .targets
        .iter()
        .map(|t| init.to_map(&t.reference()))
        .collect();
    let mut shape = a.shape;
    if shape == Shape::Sphere && !survey.has_z() {
        errln!("warning: the survey has no heights; cropping with a vertical cylinder");
        shape = Shape::Cylinder;
    }
    if a.tight {
        return write_tight(&a, &survey, &centres, shape);
    }
    write_loose(&a, &survey, &centres, shape)
}

/// Refuses a radius out of range, and plate sizes without `--tight` (they
/// would be silently ignored).
fn check_args(a: &Args) -> Result<()> {
    if !(1e-3..=1e4).contains(&a.radius) {
        return Err(mapgauge::Error::Param(format!(
            "--radius {}: must be within 0.001..10000 m",
            a.radius
        )));
    }
    if let Some(p) = a.plate_size {
        if !a.tight {
            return Err(mapgauge::Error::Param(
                "--plate-size shapes the tight crops: add --tight (loose crops are cylinders whatever the plates)".into(),
            ));
        }
        super::plate_size(p)?;
    }
    Ok(())
}

/// The loose crops streamed to one file per target, then which targets got
/// points; a run where none did is an error.
fn write_loose(
    a: &Args,
    survey: &mapgauge::survey::Survey,
    centres: &[Point],
    shape: Shape,
) -> Result<()> {
    let mut reader = cloud::open(&a.map)?;
    std::fs::create_dir_all(&a.out).map_err(|e| mapgauge::Error::io(&a.out, e))?;
    let (paths, mut writers) = open_writers(a, survey)?;
    let pb = progress_bar(reader.info().file_bytes, "reading map");
    let (map_points, skipped) = loose_crop_each(
        reader.as_mut(),
        centres,
        &LooseParams {
            radius: a.radius,
            shape,
            ..LooseParams::default()
        },
        |b| {
            if let Some(pb) = &pb {
                pb.set_position(b)
            }
        },
        |i, pts| writers[i].write(pts),
    )?;
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    let empty = list_files(a, survey, writers, &paths)?;
    if empty > 0 {
        frame_hint();
    }
    errln!(
        "{} points read{}; {} of {} targets have points",
        map_points,
        if skipped > 0 {
            format!(", {skipped} non-finite skipped")
        } else {
            String::new()
        },
        survey.targets.len() - empty,
        survey.targets.len()
    );
    super::print_tile_stats(reader.as_ref());
    if empty == survey.targets.len() {
        // Empty files are kept (they say which targets were asked for), but
        // the run found nothing to crop: not a success.
        return Err(mapgauge::Error::Input(format!(
            "no map points within {} m of any of the {} surveyed targets: the map is not where the survey is (another frame, another unit, another site?)",
            a.radius,
            survey.targets.len()
        )));
    }
    // `locate` and `eval --crops` refuse these (ground included): say so here,
    // where the user decides what to do with them.
    errln!(
        "these are loose crops (ground and surroundings included), for inspection or hand editing; \
         `mapgauge locate` and `eval --crops` want tight crops: `mapgauge crop --tight`"
    );
    Ok(())
}

/// One streaming writer per target: points go to disk as they are found, so
/// memory does not grow with the crops (a 200 M-point map has millions of
/// points within 5 m of its targets).
fn open_writers(
    a: &Args,
    survey: &mapgauge::survey::Survey,
) -> Result<(Vec<PathBuf>, Vec<cloud::CloudWriter>)> {
    let mut paths = Vec::new();
    let mut writers = Vec::new();
    for t in &survey.targets {
        let path = a
            .out
            .join(format!("{}.{}", file_stem(&t.id), a.format.extension()));
        refuse_overwrite(&path, &[&a.map, &a.survey])?;
        writers.push(cloud::CloudWriter::create(&path, a.format)?);
        paths.push(path);
    }
    Ok((paths, writers))
}

/// Each target's file finished and listed with its points; the number of
/// targets without any (each warned of: outside the map, or another frame).
fn list_files(
    a: &Args,
    survey: &mapgauge::survey::Survey,
    writers: Vec<cloud::CloudWriter>,
    paths: &[PathBuf],
) -> Result<usize> {
    outln!("{:<12} {:>10}  file", "id", "points");
    let mut empty = 0;
    for ((t, w), path) in survey.targets.iter().zip(writers).zip(paths) {
        let n = w.finish()?;
        outln!("{:<12} {:>10}  {}", t.id, n, path.display());
        if n == 0 {
            empty += 1;
            errln!(
                "warning: target {} has no map points within {} m (outside the map, or wrong frame?)",
                t.id,
                a.radius
            );
        }
    }
    Ok(empty)
}

/// crop looks where the survey (or `--init`) puts the targets; it does not
/// search the map for them as eval does: say how to get the frame.
fn frame_hint() {
    errln!(
        "a map in another frame needs --init X,Y,YAW_DEG: `mapgauge eval` finds the frame by itself and writes it to result.json as eval.frame.init (for a map that leans and that eval levels, that frame is the levelled one: take the crops from `eval --save-crops` instead)"
    );
}

/// `crop --tight`: the loose crops in memory (thinned as `eval` thins them),
/// then each target's automatic tight crop written, or why there is none.
fn write_tight(
    a: &Args,
    survey: &mapgauge::survey::Survey,
    centres: &[Point],
    shape: Shape,
) -> Result<()> {
    let params = LooseParams {
        radius: a.radius,
        shape,
        ..LooseParams::default()
    };
    let mut reader = cloud::open(&a.map)?;
    let pb = progress_bar(reader.info().file_bytes, "reading map");
    let loose = mapgauge::crop::loose_crop(reader.as_mut(), centres, &params, |b| {
        if let Some(pb) = &pb {
            pb.set_position(b)
        }
    })?;
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    super::print_tile_stats(reader.as_ref());
    std::fs::create_dir_all(&a.out).map_err(|e| mapgauge::Error::io(&a.out, e))?;
    let mut tight_params = mapgauge::crop::TightParams::default();
    if let Some(p) = a.plate_size {
        (tight_params.plate_width, tight_params.plate_height) = super::plate_size(p)?;
    }
    outln!("{:<12} {:>10}  file", "id", "points");
    let mut written = 0;
    for ((t, pts), c) in survey.targets.iter().zip(&loose.points).zip(centres) {
        match mapgauge::crop::tight_crop(pts, c, &tight_params) {
            Ok(tc) => {
                let path = a
                    .out
                    .join(format!("{}.{}", file_stem(&t.id), a.format.extension()));
                refuse_overwrite(&path, &[&a.map, &a.survey])?;
                cloud::write(&path, a.format, &tc.points)?;
                outln!("{:<12} {:>10}  {}", t.id, tc.points.len(), path.display());
                written += 1;
            }
            Err(e) => {
                outln!("{:<12} {:>10}  -", t.id, 0);
                errln!("warning: target {}: no tight crop: {e}", t.id);
            }
        }
    }
    errln!(
        "{} of {} targets have a tight crop",
        written,
        survey.targets.len()
    );
    if written == 0 {
        // Nothing to hand to `locate`: a failed run, said with its likely cause.
        frame_hint();
        return Err(mapgauge::Error::Input(format!(
            "no tight crop made: none of the {} surveyed places shows a target (the reasons are above)",
            survey.targets.len()
        )));
    }
    if loose.points.iter().any(|p| p.is_empty()) {
        frame_hint();
    }
    Ok(())
}
