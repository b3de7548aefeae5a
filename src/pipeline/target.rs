//! One target through steps 4–5: its tight crop (automatic or hand-made) and
//! the paper's localisation, with the fallbacks that make it robust.

use super::Config;
use crate::crop::{self, TightError};
use crate::locate::{self, LocateError, Located};
use crate::model::ModelKind;
use crate::{Error, Point, Result};
use nalgebra::Vector3;
use std::path::Path;

/// Which search found a target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pass {
    /// Around the expected position.
    First = 1,
    /// Around the position the alignment of the other targets predicts.
    Second = 2,
}

/// A located target.
#[derive(Debug, Clone)]
pub struct Found {
    /// The paper's estimate: corner, spread, plates, samples.
    pub located: Located,
    /// The direction the gates used as vertical.
    pub up: Vector3<f64>,
    /// The plates' intersection line, pointing up: the target's plumb line
    /// in the map (`up` for a sphere, which has none).
    pub axis: Vector3<f64>,
    /// The sphere fitted, for a sphere target (`None`: an L).
    pub sphere: Option<crate::model::SphereFit>,
    /// The board fitted, for a checkerboard target.
    pub board: Option<crate::model::BoardFit>,
}

impl Found {
    /// What was located.
    pub fn model(&self) -> crate::model::ModelKind {
        match (&self.sphere, &self.board) {
            (Some(_), _) => crate::model::ModelKind::Sphere,
            (_, Some(_)) => crate::model::ModelKind::Board,
            _ => crate::model::ModelKind::L,
        }
    }
    /// Whether it is an L: only an L has plates, a plumb line, layers.
    pub fn is_l(&self) -> bool {
        self.sphere.is_none() && self.board.is_none()
    }
}

/// Why a target was not located, by stage.
#[derive(Debug)]
pub enum Failure {
    /// The loose crop was empty.
    NoLoosePoints,
    /// The hand-made tight crop is missing or unreadable.
    HandCrop(Error),
    /// The automatic tight crop found no target.
    Tight(TightError),
    /// The localisation failed on the tight crop (the last variant's error).
    Locate(LocateError),
    /// Something target-shaped was located, but far from where every other
    /// target places it, and nothing was found where they do: not the target.
    FarFromOthers {
        /// Where the object was (evaluation frame).
        at: Point,
        /// Its error under a fit without it (m).
        error: f64,
        /// The median of the same error over the targets (m).
        median: f64,
        /// Which error condemned it.
        by: FarBy,
        /// Whether the target was searched for again where the others place
        /// it (not with hand crops, nor for a target flagged only at the end).
        searched: bool,
        /// Once the others are aligned: where their fit puts the object in
        /// the survey's frame against this target's row, so a row mistyped
        /// by metres can be found and mended.
        row: Option<RowHint>,
    },
    /// No sphere of the surveyed size stood near the expected position.
    Sphere(crate::model::SphereError),
    /// No checkerboard board stood near the expected position (or the map
    /// has no intensity to tell one).
    Board(crate::model::BoardError),
    /// The target is mapped twice (a loop closed badly): a plate shows two
    /// layers, and the located corner is a blend of the copies.
    Doubled(crate::locate::Doubled),
    /// Its distance to another located target disagrees with the survey's
    /// by more than any map's error over that distance (`alone`: the others
    /// agree with the survey; else no target agrees with the others).
    OffLayout {
        /// Where the object was (evaluation frame).
        at: Point,
        /// The largest disagreement of its distances with the survey's (m).
        misfit: f64,
        /// That pair's surveyed distance (m).
        distance: f64,
        /// Whether it alone was singled out.
        alone: bool,
    },
    /// The object located is the one another target was located at, and
    /// that target was expected nearer to it: no object serves two targets.
    SameObject {
        /// The other target's id.
        other: String,
        /// Where the object was (evaluation frame).
        at: Point,
    },
}

impl Failure {
    /// The stage that failed, as result.json names it.
    pub fn stage(&self) -> &'static str {
        match self {
            Failure::NoLoosePoints => "loose",
            Failure::HandCrop(_) | Failure::Tight(_) | Failure::Sphere(_) | Failure::Board(_) => {
                "tight"
            }
            Failure::Locate(_) => "locate",
            Failure::FarFromOthers { .. }
            | Failure::OffLayout { .. }
            | Failure::SameObject { .. }
            | Failure::Doubled(_) => "check",
        }
    }
}

/// An object far from where the other targets place it, seen from the
/// survey's side: where the fit on the others puts it, against the row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowHint {
    /// The object's position under the fit on the other targets (survey
    /// frame, x and y; m).
    pub object: [f64; 2],
    /// The row's position (survey frame, x and y; m).
    pub row: [f64; 2],
    /// The row's line in the survey file.
    pub line: u64,
    /// The row gives latitude and longitude (the frame is east and north
    /// metres about the survey's origin, or the map's projection).
    pub geodetic: bool,
}

impl std::fmt::Display for RowHint {
    /// One coordinate alone off (the other within 5 % of it and 5 cm) is
    /// how a mistyped digit or a pasted column shows: said so.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let d = [self.row[0] - self.object[0], self.row[1] - self.object[1]];
        let (frame, axes) = if self.geodetic {
            (
                "m east and north in the survey's local frame",
                ["longitude (east)", "latitude (north)"],
            )
        } else {
            ("in the survey's frame", ["x", "y"])
        };
        write!(
            f,
            "if it is this target, the fit on the others puts it at ({:.3}, {:.3}) {frame}, and line {} of the survey is ({:+.3}, {:+.3}) m from that",
            self.object[0], self.object[1], self.line, d[0], d[1]
        )?;
        for (k, axis) in [(0, axes[0]), (1, axes[1])] {
            let (big, small) = (d[k].abs(), d[1 - k].abs());
            if small <= 0.05 * big && small <= 0.05 {
                write!(f, ": its {axis} alone, as a mistyped digit would be")?;
            }
        }
        Ok(())
    }
}

/// What showed an object to be far from where the other targets place it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FarBy {
    /// Its error under an alignment of the other targets.
    LeaveOneOut,
    /// Where a fit on the others alone places it (the one whose leaving out
    /// lets them fit best): a blunder cannot pull that fit.
    OthersFit,
    /// Its distances to the other targets against the survey's, which no
    /// alignment enters: one wrong object among four pulls every
    /// leave-one-out fit that includes it, but not the others' distances.
    Distances,
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::NoLoosePoints => {
                f.write_str("no map points within the crop radius of the expected position")
            }
            Failure::HandCrop(e) => write!(f, "{e}"),
            Failure::Tight(e) => write!(f, "{e}"),
            Failure::Sphere(e) => write!(f, "{e}"),
            Failure::Board(e) => write!(f, "{e}"),
            Failure::Locate(e) => write!(f, "localisation failed: {e}"),
            Failure::FarFromOthers {
                at,
                error,
                median,
                by,
                searched,
                row,
            } => {
                write!(
                    f,
                    "the object located at ({:.2}, {:.2}) is {error:.2} m ",
                    at.x, at.y
                )?;
                match by {
                    FarBy::LeaveOneOut => write!(
                        f,
                        "from where the other targets place it (their median {:.0} mm)",
                        median * 1e3
                    )?,
                    FarBy::OthersFit => write!(
                        f,
                        "from where a fit on the other targets places it (they agree with their survey to {:.0} mm rms)",
                        median * 1e3
                    )?,
                    FarBy::Distances => write!(
                        f,
                        "off in its distances to the other targets (median over them, against the survey's; the targets' median {:.0} mm)",
                        median * 1e3
                    )?,
                }
                if *searched {
                    f.write_str(
                        ", and nothing target-shaped stands where they place it: not this target, or its survey row is that far off (check the row's position and id)",
                    )?;
                    match row {
                        Some(row) => write!(f, "; {row}"),
                        None => Ok(()),
                    }
                } else {
                    f.write_str(": not this target, or a map or survey error (it was not searched for where they place it; with hand crops, check this target's crop)")
                }
            }
            Failure::OffLayout {
                at,
                misfit,
                distance,
                alone,
            } => {
                if *misfit > 0.0 {
                    write!(
                        f,
                        "the object located at ({:.2}, {:.2}) is {misfit:.2} m off in its distance to another located target ({distance:.1} m apart in the survey): more than a map's error over that distance",
                        at.x, at.y
                    )?;
                } else {
                    write!(
                        f,
                        "the object located at ({:.2}, {:.2}) agrees with too few of the others: most located targets stand metres from where the survey places them relative to each other",
                        at.x, at.y
                    )?;
                }
                if *alone {
                    f.write_str(", where the other targets agree with the survey: not this target, or a wrong survey position or id")
                } else {
                    f.write_str(", and too few located targets agree with each other to tell which: check the survey (positions, ids, unit), that these objects are the targets, and the map (a failed loop closure bends a map by metres)")
                }
            }
            Failure::Doubled(d) => doubled(f, d),
            Failure::SameObject { other, at } => write!(
                f,
                "the object located at ({:.2}, {:.2}) is target {other}'s, which was expected nearer to it",
                at.x, at.y
            ),
        }
    }
}

/// [`Failure::Doubled`]'s sentence: each doubled plate's two layers, and
/// where the copies' corners are.
fn doubled(f: &mut std::fmt::Formatter<'_>, d: &locate::Doubled) -> std::fmt::Result {
    let [a, b] = d.copies;
    let plates: Vec<String> = d
        .plates
        .iter()
        .enumerate()
        .filter(|(_, p)| p.doubled)
        .map(|(k, p)| {
            format!(
                "plate {} two layers {:.0} mm apart ({} and {} points, each {:.0} mm thick)",
                k + 1,
                (p.offsets[1] - p.offsets[0]) * 1e3,
                p.counts[0],
                p.counts[1],
                p.sigma * 1e3
            )
        })
        .collect();
    write!(
        f,
        "mapped twice (a seam where a loop closed badly?): {}; the copies' corners are near ({:.3}, {:.3}) and ({:.3}, {:.3}), {:.0} mm apart, and one fit through both would lie between them: not used in the fit",
        plates.join(", "),
        a.x,
        a.y,
        b.x,
        b.y,
        d.separation * 1e3
    )
}

/// Everything the pipeline did for one target.
#[derive(Debug)]
pub struct TargetRun {
    /// Target id.
    pub id: String,
    /// Where it was looked for (map frame).
    pub expected: Point,
    /// Which search this is.
    pub pass: Pass,
    /// How far from `expected` the target was searched (m, horizontal): the
    /// configured `tight.search_radius` (a sphere's or board's own), or less
    /// where the other targets placed it (a dense crop in the first pass,
    /// one far from them after); 0 for a hand-made crop (used as it is).
    pub search_radius: f64,
    /// Searched after the others, only where they place it (its crop was
    /// far denser than theirs: `waves.rs`), and found there.
    pub waited: bool,
    /// Found in the coarse levels of a COPC octree and located in every
    /// level within this radius (m, horizontal) of where it was found there
    /// (`detail.rs`); 0 otherwise.
    pub detail_radius: f64,
    /// The loose crop (thinned beyond `crop.max_points`; of a target located
    /// in detail, the coarse levels with every level within `detail_radius`).
    pub loose: Vec<Point>,
    /// Points the map had in the loose crop, when it was thinned (of a COPC
    /// map read with `crop.by_level`: those of the octree levels read).
    pub loose_thinned_from: Option<u64>,
    /// The tight crop (empty when none was made).
    pub tight: Vec<Point>,
    /// Local ground normal from the automatic tight crop.
    pub ground_normal: Option<Vector3<f64>>,
    /// The located target, or why not.
    pub outcome: std::result::Result<Found, Failure>,
    /// What the survey says the target is.
    pub model: ModelKind,
    /// An L's plate width and height (m): the survey's `size` as the width
    /// and the configured build's proportions, else the configured plates.
    pub plates: (f64, f64),
}

impl TargetRun {
    /// The located corner (map frame).
    pub fn corner(&self) -> Option<Point> {
        self.outcome.as_ref().ok().map(|f| f.located.corner)
    }

    /// Where the run will score the corner: an L's moved to the middle of
    /// its plates' seen span (`locate::place_height`, done by the checks
    /// after the frame is settled), for what reads heights before that.
    pub(super) fn placed_corner(&self) -> Option<Point> {
        let f = self.outcome.as_ref().ok()?;
        if !f.is_l() {
            return Some(f.located.corner);
        }
        let mut l = f.located.clone();
        crate::locate::place_height(&self.tight, &mut l, &f.up, self.plates);
        Some(l.corner)
    }
}

/// Where one target is looked for: its id, where it is expected, the
/// other targets' expected positions (objects nearer them are theirs), and
/// the last "ups" to try.
pub(crate) struct Place<'a> {
    pub(crate) id: &'a str,
    pub(crate) expected: Point,
    pub(crate) others: &'a [Point],
    pub(crate) more_ups: &'a [Vector3<f64>],
    /// What the target is, and its surveyed size (m) when given.
    pub(crate) model: (crate::model::ModelKind, Option<f64>),
    /// A board's crop with intensities (`crops::board_crops_of`), read apart
    /// from the loose crops, which carry coordinates only.
    pub(crate) board: Option<super::crops::BoardCrop>,
}

/// Steps 4–5 for one target: tight crop (hand-made from `crops_dir`, else
/// automatic from `loose`, leaving objects nearer the other targets' expected
/// positions `others` to them), then localisation. `more_ups` are the last "ups"
/// tried, in the frame the points are in: the map's own +z (in case levelling
/// by the ground turned a level map on a slope) and the ground's map-wide
/// vertical (for a map leaning a few degrees that was not levelled).
pub(crate) fn locate_target(
    place: Place,
    loose: Vec<Point>,
    crops_dir: Option<&Path>,
    tight: &crate::crop::TightParams,
    cfg: &Config,
    pass: Pass,
) -> TargetRun {
    let Place {
        id,
        expected,
        others,
        more_ups,
        model,
        board,
    } = place;
    let mut run = TargetRun {
        id: id.to_string(),
        expected,
        pass,
        search_radius: if crops_dir.is_some() {
            0.0
        } else {
            tight.search_radius
        },
        waited: false,
        detail_radius: 0.0,
        loose,
        loose_thinned_from: None,
        tight: Vec::new(),
        ground_normal: None,
        outcome: Err(Failure::NoLoosePoints),
        model: model.0,
        plates: l_plates(model.1, tight),
    };
    let sized;
    let tight = match model {
        (ModelKind::L, None) => tight,
        (ModelKind::L, Some(_)) => {
            sized = crate::crop::TightParams {
                plate_width: run.plates.0,
                plate_height: run.plates.1,
                ..tight.clone()
            };
            &sized
        }
        (ModelKind::Sphere, size) => {
            let mut centre = run.expected;
            if let Some(dir) = crops_dir {
                // A hand-made crop is searched whole, about its own middle:
                // the expected position may be a guess in another frame.
                match hand_crop(dir, id, None) {
                    Ok(p) if !p.is_empty() => {
                        let n = p.len() as f64;
                        let mid = p.iter().map(|q| q.coords).sum::<Vector3<f64>>() / n;
                        centre = Point::new(mid.x, mid.y, centre.z);
                        run.loose = p;
                    }
                    Ok(_) => return run,
                    Err(e) => {
                        run.outcome = Err(Failure::HandCrop(e));
                        return run;
                    }
                }
            }
            sphere_target(&mut run, centre, others, size, tight, cfg);
            return run;
        }
        (ModelKind::Board, size) => {
            let board = match crops_dir {
                // A hand-made crop is searched whole, about its own middle,
                // with the intensity its file carries.
                Some(dir) => match hand_board_crop(dir, id) {
                    Ok(c) => {
                        if let Ok((p, _)) = &c
                            && !p.is_empty()
                        {
                            let n = p.len() as f64;
                            let mid = p.iter().map(|q| q.coords).sum::<Vector3<f64>>() / n;
                            run.expected = Point::new(mid.x, mid.y, run.expected.z);
                        }
                        Some(c)
                    }
                    Err(e) => {
                        run.outcome = Err(Failure::HandCrop(e));
                        return run;
                    }
                },
                None => board,
            };
            board_target(&mut run, board, others, size, tight, cfg);
            return run;
        }
    };
    // Hand-made tight crops (the paper's workflow) or the automatic one.
    let ups: Vec<Vector3<f64>> = match crops_dir {
        Some(dir) => match hand_crop(dir, id, Some(tight.plate_width)) {
            Ok(p) => {
                run.tight = p;
                vec![Vector3::z()]
            }
            Err(e) => {
                run.outcome = Err(Failure::HandCrop(e));
                return run;
            }
        },
        None => {
            if run.loose.is_empty() {
                return run;
            }
            match crop::tight_crop_among(&run.loose, &expected, others, tight) {
                Ok(t) => {
                    run.ground_normal = Some(Vector3::from(t.ground_normal));
                    let up = Vector3::from(t.up);
                    run.tight = t.points;
                    // A fallback "up" in case the ground normal misleads the gates.
                    let mut ups = vec![up];
                    for &u in std::iter::once(&Vector3::z()).chain(more_ups) {
                        if !ups.contains(&u) {
                            ups.push(u);
                        }
                    }
                    ups
                }
                Err(e) => {
                    run.outcome = Err(Failure::Tight(e));
                    return run;
                }
            }
        }
    };
    run.outcome = locate_with(&run.tight, &ups, cfg).map_err(Failure::Locate);
    run
}

/// An L's plates (width, height) for a surveyed size: a build like the
/// configured one scaled to that width (square plates stay square), or the
/// configured plates without one.
pub(crate) fn l_plates(size: Option<f64>, tight: &crate::crop::TightParams) -> (f64, f64) {
    match size {
        Some(w) => (w, tight.plate_height * w / tight.plate_width),
        None => (tight.plate_width, tight.plate_height),
    }
}

/// A sphere's or board's search radius (its model's own, `own`), no wider
/// than the L's when that was narrowed for this search (`tight` against the
/// configured), recorded in `run` unless it is a hand-made crop (0).
fn own_radius(
    run: &mut TargetRun,
    own: f64,
    tight: &crate::crop::TightParams,
    cfg: &Config,
) -> f64 {
    let r = if tight.search_radius < cfg.tight.search_radius {
        own.min(tight.search_radius)
    } else {
        own
    };
    if run.search_radius > 0.0 {
        run.search_radius = r;
    }
    r
}

/// A sphere target: found in the loose crop and fitted
/// (`model::sphere`); its points near it are the tight crop. A search
/// narrowed below the configured L's (the second pass's, near a
/// prediction) narrows the sphere's too.
fn sphere_target(
    run: &mut TargetRun,
    centre: Point,
    others: &[Point],
    size: Option<f64>,
    tight: &crate::crop::TightParams,
    cfg: &Config,
) {
    let mut p = cfg.sphere.clone();
    p.search_radius_m = own_radius(run, p.search_radius_m, tight, cfg);
    if run.loose.is_empty() {
        return;
    }
    let search = crate::model::sphere::Search {
        points: &run.loose,
        expected: centre,
        others,
        radius: size.unwrap_or(p.diameter_m) / 2.0,
        up: Vector3::z(),
        surveyed: true,
    };
    match crate::model::sphere::locate(&search, &p) {
        Ok((fit, near)) => {
            run.tight = near;
            let located = point_estimate(fit.centre, fit.covariance, &fit.samples);
            run.outcome = Ok(Found {
                sphere: Some(fit),
                ..located
            });
        }
        Err(e) => run.outcome = Err(Failure::Sphere(e)),
    }
}

/// A model located as a point (a sphere's centre, a board's crossing), its
/// fit to be added: no plates, "up" and the axis the map's +z.
fn point_estimate(centre: Point, covariance: [[f64; 3]; 3], samples: &[Point]) -> Found {
    Found {
        located: locate::Located::without_plates(centre, covariance, samples.to_vec()),
        up: Vector3::z(),
        axis: Vector3::z(),
        sphere: None,
        board: None,
    }
}

/// A checkerboard target: found and located in its crop with intensities
/// (`model::board`); its points on the board are the tight crop.
fn board_target(
    run: &mut TargetRun,
    crop: Option<super::crops::BoardCrop>,
    others: &[Point],
    size: Option<f64>,
    tight: &crate::crop::TightParams,
    cfg: &Config,
) {
    let mut p = cfg.board.clone();
    p.search_radius_m = own_radius(run, p.search_radius_m, tight, cfg);
    let (pts, inten) = match crop {
        Some(Ok(c)) => c,
        Some(Err(why)) => {
            run.outcome = Err(Failure::Board(crate::model::BoardError::NoIntensity {
                why,
            }));
            return;
        }
        None => {
            run.outcome = Err(Failure::Board(crate::model::BoardError::NoIntensity {
                why: "this search read none".into(),
            }));
            return;
        }
    };
    run.loose = pts;
    if run.loose.is_empty() {
        run.outcome = Err(Failure::NoLoosePoints);
        return;
    }
    let search = crate::model::board::Search {
        points: &run.loose,
        intensity: &inten,
        expected: run.expected,
        others,
        side: size.unwrap_or(p.side_m),
        up: Vector3::z(),
        on_surfaces: true,
    };
    match crate::model::board::locate(&search, &p) {
        Ok((fit, near)) => {
            run.tight = near;
            let located = point_estimate(fit.centre, fit.covariance, &fit.samples);
            run.outcome = Ok(Found {
                board: Some(fit),
                ..located
            });
        }
        Err(e) => run.outcome = Err(Failure::Board(e)),
    }
}

/// Step 5 on a tight crop, trying each "up" in turn (and each of the
/// refit and plain draws), as `eval` does.
pub fn locate_with(
    points: &[Point],
    ups: &[Vector3<f64>],
    cfg: &Config,
) -> std::result::Result<Found, LocateError> {
    // Each up with both kinds of draws, in `locate_either`'s order.
    let mut last_err = LocateError::BadUp;
    for up in ups {
        match locate::locate_either(points, Some(*up), &cfg.locate) {
            Ok(l) => return Ok(found(l, *up)),
            Err(e) => last_err = e,
        }
    }
    Err(last_err)
}

fn found(l: locate::Located, up: Vector3<f64>) -> Found {
    let axis = Vector3::from(l.plates[0].normal).cross(&Vector3::from(l.plates[1].normal));
    let axis = if axis.z < 0.0 { -axis } else { axis };
    Found {
        located: l,
        up,
        axis: axis.normalize(),
        sphere: None,
        board: None,
    }
}

/// A board's hand-made crop (`DIR/<stem>.<ext>`, as [`hand_crop`] finds it)
/// with its intensities, or why its file has none.
fn hand_board_crop(dir: &Path, id: &str) -> Result<super::crops::BoardCrop> {
    let stem = crate::survey::file_stem(id);
    for ext in [
        "ply", "pcd", "las", "laz", "xyz", "txt", "csv", "e57", "pts",
    ] {
        let p = dir.join(format!("{stem}.{ext}"));
        if !p.is_file() {
            continue;
        }
        let mut r = crate::cloud::open(&p)?;
        if !r.has_intensity() {
            return Ok(Err(format!(
                "{} has no intensity mapgauge reads: the file holds no intensity field \
                 (mapgauge reads one from PCD `intensity` or `i`, PLY `intensity` or \
                 `scalar_intensity`, LAS, LAZ, COPC, E57, PTS, XYZ/CSV with a header naming one)",
                p.display()
            )));
        }
        let (mut pts, mut inten) = (Vec::new(), Vec::new());
        let (mut b, mut i) = (Vec::new(), Vec::new());
        while r.next_chunk_intensity(&mut b, &mut i)? {
            for (p, v) in b.iter().zip(&i) {
                if v.is_finite() {
                    pts.push(*p);
                    inten.push(*v);
                }
            }
        }
        return Ok(Ok((pts, inten)));
    }
    Err(Error::Input(format!(
        "no tight crop {}/{stem}.ply|pcd|las|laz|xyz|e57",
        dir.display()
    )))
}

/// Finds `DIR/<stem>.<ext>` for any readable cloud extension and reads it,
/// where the stem is the id made safe as a file name.
/// `plate_width`: an L's, to refuse a loose crop given as a tight one
/// (`None` for a sphere, searched in whatever crop it is given).
fn hand_crop(dir: &Path, id: &str, plate_width: Option<f64>) -> Result<Vec<Point>> {
    let stem = crate::survey::file_stem(id);
    for ext in [
        "ply", "pcd", "las", "laz", "xyz", "txt", "csv", "e57", "pts",
    ] {
        let p = dir.join(format!("{stem}.{ext}"));
        if p.is_file() {
            let pts = crate::cloud::read_all(&p)?;
            if let Some(span) = plate_width.and_then(|w| crop::looks_loose(&pts, w)) {
                return Err(Error::format(&p, crop::loose_crop_message(span)));
            }
            return Ok(pts);
        }
    }
    Err(Error::Input(format!(
        "no tight crop {}/{stem}.ply|pcd|las|laz|xyz|e57",
        dir.display()
    )))
}

/// Located targets whose plates show two layers in the map around them,
/// each as thin as this map's plates (`locate::layering`), are blends of two
/// copies: they become `Doubled`. Returns their ids, and how close two
/// copies may be and still be seen (unknown with fewer than three targets).
pub(super) fn check_doubled(
    found: &mut [TargetRun],
) -> (Vec<String>, Option<crate::locate::DoublingLimit>) {
    use rayon::prelude::*;
    let layering: Vec<Option<crate::locate::Layering>> = found
        .par_iter()
        .map(|r| {
            let f = r.outcome.as_ref().ok().filter(|f| f.is_l())?;
            let (w, h) = r.plates;
            crate::locate::layering(&r.loose, &f.located, &f.up, w, h)
        })
        .collect();
    // What a plate of this map looks like: the median target's thinner
    // plate (unknown with fewer than three targets located).
    let mut thick: Vec<f64> = layering
        .iter()
        .flatten()
        .filter_map(|l| l.thickness())
        .collect();
    thick.sort_unstable_by(f64::total_cmp);
    let plate = (thick.len() >= 3).then(|| thick[thick.len() / 2]);
    let mut ids = Vec::new();
    // The limit stated with the results: from the targets left single (a
    // doubled one measured as one layer is thicker, and would raise it the
    // more of the map is doubled).
    let mut single: Vec<f64> = Vec::new();
    for (r, l) in found.iter_mut().zip(layering) {
        let Some(l) = l else { continue };
        if let Some(d) = l.doubled(plate) {
            r.outcome = Err(Failure::Doubled(d));
            ids.push(r.id.clone());
        } else if let Some(t) = l.thickness() {
            single.push(t);
        }
    }
    // With most of the map doubled, the few single targets say it (or, with
    // none, the median of all: an upper bound). Stated once three targets'
    // plates are measured.
    single.sort_unstable_by(f64::total_cmp);
    let limit = plate.map(|all| {
        crate::locate::DoublingLimit::of(single.get(single.len() / 2).copied().unwrap_or(all))
    });
    (ids, limit)
}

/// A located L's height is placed in the middle of the plates' span seen
/// (the paper's mean height leans toward the densest scan line, and toward
/// the post and antenna above the corner), and a target whose plates were
/// not seen whole (a barrier or grass hides the lower plates from the road)
/// has its height less well known than its points' scatter says: what the
/// span leaves open is added to its covariance (`locate::HeightSeen`).
/// Returns those whose height is uncertain by a twentieth of the plate
/// height or more (1σ), with what was seen and their vertical σ after.
pub(super) fn widen_heights(
    found: &mut [TargetRun],
) -> Vec<(String, crate::locate::HeightSeen, f64)> {
    let mut widened = Vec::new();
    for r in found.iter_mut() {
        let plates = r.plates;
        let Some(f) = r.outcome.as_mut().ok().filter(|f| f.is_l()) else {
            continue;
        };
        let Some(seen) = crate::locate::place_height(&r.tight, &mut f.located, &f.up, plates)
        else {
            continue;
        };
        if seen.worth_naming() {
            widened.push((r.id.clone(), seen, f.located.sigma()[2]));
        }
    }
    widened
}

/// A located target whose ground shows two layers at heights centimetres
/// apart (`locate::ground_layers`: a loop's seam, which upright plates
/// cannot show when it is in height) has its height known only to within
/// the copies: the located height may be either copy's or between them,
/// and the truth is either copy's, so σz gains separation²/3 (a uniform
/// over ± the separation) along the vertical. Returns those targets, each
/// with the separation and its vertical σ after.
pub(super) fn widen_for_ground_copies(found: &mut [TargetRun]) -> Vec<(String, f64, f64)> {
    use rayon::prelude::*;
    let layers: Vec<Option<crate::locate::GroundLayers>> = found
        .par_iter()
        .map(|r| {
            let f = r.outcome.as_ref().ok()?;
            crate::locate::ground_layers(&r.loose, &f.located.corner, &f.up)
        })
        .collect();
    let mut widened = Vec::new();
    for (r, g) in found.iter_mut().zip(layers) {
        let (Some(g), Ok(f)) = (g, r.outcome.as_mut()) else {
            continue;
        };
        let up = f.up.normalize();
        let add = up * up.transpose() * (g.separation_m.powi(2) / 3.0);
        for (i, row) in f.located.covariance.iter_mut().enumerate() {
            for (j, c) in row.iter_mut().enumerate() {
                *c += add[(i, j)];
            }
        }
        widened.push((r.id.clone(), g.separation_m, f.located.sigma()[2]));
    }
    widened
}

/// No object serves two targets: when two located corners are closer than a
/// plate's width (the narrower of the two targets'), the target expected
/// farther from the object loses it.
pub(super) fn one_object_each(found: &mut [TargetRun]) {
    let n = found.len();
    for i in 0..n {
        for j in 0..n {
            let (Some(a), Some(b)) = (found[i].corner(), found[j].corner()) else {
                continue;
            };
            let plate_width = found[i].plates.0.min(found[j].plates.0);
            if i == j || (a - b).xy().norm() >= plate_width {
                continue;
            }
            let di = (a - found[i].expected).xy().norm();
            let dj = (b - found[j].expected).xy().norm();
            if di > dj || (di == dj && i > j) {
                found[i].outcome = Err(Failure::SameObject {
                    other: found[j].id.clone(),
                    at: a,
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A target condemned without a search (hand crops) must not claim that
    /// nothing stands where the others place it.
    #[test]
    fn a_far_object_names_whether_it_was_searched_for() {
        let far = |searched| Failure::FarFromOthers {
            at: Point::new(1.0, 2.0, 0.0),
            error: 1.5,
            median: 0.01,
            by: FarBy::Distances,
            searched,
            row: None,
        };
        let yes = far(true).to_string();
        let no = far(false).to_string();
        assert!(
            yes.contains("nothing target-shaped stands where they place it"),
            "{yes}"
        );
        assert!(!no.contains("nothing target-shaped"), "{no}");
        assert!(
            no.contains("not searched for") && no.contains("hand crops"),
            "{no}"
        );
        assert!(
            no.starts_with("the object located at (1.00, 2.00) is 1.50 m off in its distances"),
            "{no}"
        );
    }

    /// A board's hand-made crop is read with the intensity its file carries
    /// and located about its own middle; a crop file without intensity says
    /// so.
    #[test]
    fn a_boards_hand_crop_is_located_with_its_intensity() {
        let dir = tempfile::tempdir().unwrap();
        // A 0.6 m board facing +y, its crossing at (10, 20, 1.2), 1 cm apart,
        // and a patch of ground.
        let (mut pts, mut inten) = (Vec::new(), Vec::new());
        for i in 0..60 {
            for j in 0..60 {
                let (u, v) = (-0.295 + 0.01 * i as f64, -0.295 + 0.01 * j as f64);
                pts.push(Point::new(
                    10.0 + u,
                    20.0 + 0.002 * ((i * 7 + j * 3) % 5) as f64,
                    1.2 + v,
                ));
                inten.push(if (u > 0.0) == (v > 0.0) {
                    200.0f32
                } else {
                    20.0
                });
            }
        }
        for i in 0..40 {
            for j in 0..40 {
                pts.push(Point::new(
                    9.0 + 0.05 * i as f64,
                    19.0 + 0.05 * j as f64,
                    0.0,
                ));
                inten.push(60.0);
            }
        }
        let path = dir.path().join("b7.pcd");
        let mut w =
            crate::cloud::CloudWriter::create_with(&path, crate::cloud::OutFormat::PcdXyzi, true)
                .unwrap();
        w.write_intensity(&pts, &inten).unwrap();
        w.finish().unwrap();
        let place = |id: &'static str| Place {
            id,
            // The survey's place, in another frame: the crop is searched
            // about its own middle.
            expected: Point::new(500.0, -3.0, 1.0),
            others: &[],
            more_ups: &[],
            model: (ModelKind::Board, Some(0.6)),
            board: None,
        };
        let cfg = Config::default();
        let r = locate_target(
            place("b7"),
            Vec::new(),
            Some(dir.path()),
            &cfg.tight,
            &cfg,
            Pass::First,
        );
        let f = r.outcome.as_ref().expect("a board");
        assert!(f.board.is_some() && f.model() == ModelKind::Board);
        let c = f.located.corner;
        assert!((c - Point::new(10.0, 20.0, 1.2)).norm() < 0.004, "{c:?}");
        // The same points as a PLY of doubles: no intensity.
        let ply = dir.path().join("b8.ply");
        let mut w =
            crate::cloud::CloudWriter::create_with(&ply, crate::cloud::OutFormat::Ply, false)
                .unwrap();
        w.write(&pts).unwrap();
        w.finish().unwrap();
        let r = locate_target(
            place("b8"),
            Vec::new(),
            Some(dir.path()),
            &cfg.tight,
            &cfg,
            Pass::First,
        );
        let e = r.outcome.err().expect("no intensity").to_string();
        assert!(e.contains("has no intensity"), "{e}");
    }
}
