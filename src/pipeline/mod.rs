//! The whole evaluation, map to accuracy: loose crop → tight crop → locate →
//! align → accuracy. Each stage is a plain function of the previous stage's
//! output; this module only composes them, searches again where the first
//! pass missed, and records what happened — it writes no file and prints
//! nothing.
//!
//! ```no_run
//! use mapgauge::cloud::MapSource;
//! use mapgauge::pipeline::{self, Config};
//! use mapgauge::survey::{SurveyOptions, read_survey};
//! # fn main() -> mapgauge::Result<()> {
//! let survey = read_survey("survey.csv".as_ref(), &SurveyOptions::default())?;
//! let map = MapSource::File("map.pcd".as_ref());
//! let ev = pipeline::run(map, &survey, &Config::default(), |_, _| {})?;
//! println!("E_abs = {:.4} m", ev.accuracy.absolute.mean);
//! # Ok(()) }
//! ```

mod config;
mod diagnosis;
mod frame;
mod passes;
mod steps;
mod target;

pub use config::{Config, FrameConfig, FrameMode, MetricsConfig};
pub(crate) use frame::vertical_se_deg;
pub use frame::{FrameFound, FrameHow, HeightsLean, Plumb};
pub use target::{Failure, FarBy, Found, Pass, TargetRun, locate_with};

use crate::accuracy::{self, Accuracy, ScoreOptions};
use crate::cloud::{MapSource, RigidMotion};
use crate::crop::{self, LooseParams};
use crate::survey::{Estimate, EstimateStatus, Survey};
use crate::{Error, Point, Result};
use diagnosis::{against_survey, not_there, other_plate_size, too_few_found};
use std::path::Path;
use steps::evaluate;

/// What the map gave.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MapStats {
    /// The map as named in results (path as given, or `<memory>`).
    pub name: String,
    /// Size in bytes (0 in memory).
    pub bytes: u64,
    /// Finite points in the map when a pass read all of it; else the most
    /// any pass read (`Evaluation::reads` says what each read).
    pub points: u64,
    /// Points skipped as NaN or infinite (by the ground pass, or the crops'
    /// when it read the whole map).
    pub skipped_nonfinite: u64,
}

/// Something the caller should tell the user.
#[derive(Debug, Clone, PartialEq)]
pub enum Warning {
    /// A sphere crop was asked for but the survey has no heights: a vertical
    /// cylinder was used.
    SphereWithoutHeights,
    /// These targets were flagged as gross errors and left out of the fit
    /// and the statistics (`metrics.exclude_outliers`).
    OutliersExcluded(Vec<String>),
    /// Objects located for these targets were far from where the others put
    /// them and were rejected (the targets are not found).
    WrongObjects(Vec<String>),
    /// These targets are mapped twice (their plates show two layers): they
    /// are reported as ambiguous and left out of the fit.
    Doubled(Vec<String>),
    /// Few targets were found where expected, and detection could not find
    /// another frame; the first guess was kept.
    DetectionFailed(String),
    /// The frame the user gave (`--init` or `--hints`) found too few targets
    /// where it put them; detection found another frame, which was used.
    GivenFrameReplaced {
        /// `init` or `hints`.
        given: &'static str,
        /// Targets found with the given frame.
        found: usize,
        /// Targets in the survey.
        targets: usize,
    },
    /// The map stores float32 coordinates far from its origin: every
    /// position in it is rounded to a coarse step.
    Float32Steps {
        /// The step (m).
        step_m: f64,
        /// The farthest coordinate from the origin (m).
        reach_m: f64,
    },
    /// The ground leans, but the map's header declares a coordinate
    /// reference system: not levelled.
    Georeferenced {
        /// The CRS as named (`EPSG:32633`).
        crs: String,
        /// The ground's lean (degrees).
        tilt_deg: f64,
    },
    /// The surveyed heights lean otherwise than the targets' plumb lines,
    /// by more than both their uncertainties allow: not used to level.
    HeightsDisagree {
        /// The heights' lean and its standard error (degrees).
        heights_deg: f64,
        /// See `heights_deg`.
        heights_se_deg: f64,
        /// The plumb lines' lean and its standard error (degrees).
        plumb_deg: f64,
        /// See `plumb_deg`.
        plumb_se_deg: f64,
        /// Angle between the two verticals (degrees).
        apart_deg: f64,
    },
    /// These targets' plates were seen over part of their height only, or
    /// their points crowd toward part of it: their heights' σ was raised to
    /// cover what that leaves open.
    HeightsUncertain {
        /// The targets.
        ids: Vec<String>,
        /// The least and most plate height seen among them (m).
        seen_m: (f64, f64),
        /// The plates' configured height (m).
        plate_height_m: f64,
        /// The largest vertical σ after widening (m).
        sigma_m: f64,
        /// Every located target (three or more) is among them: the plates
        /// may be smaller than configured.
        every: bool,
    },
    /// The ground leans, but too few of its flat blocks agree on the lean to
    /// level the map by: not levelled.
    GroundWeak {
        /// The ground's lean (degrees).
        tilt_deg: f64,
        /// Share of the flat 2 m ground blocks within 1° of that vertical.
        support: f64,
        /// Flat ground blocks.
        blocks: usize,
        /// The share levelling asks for (`frame.level_min_support`).
        min_support: f64,
    },
    /// The map leans; it was read levelled and positions are in that frame.
    Levelled {
        /// Total tilt corrected (degrees).
        tilt_deg: f64,
        /// Standard error of the vertical it was turned to (degrees).
        se_deg: f64,
        /// What that angle does to the targets' levelled positions: the
        /// largest height change (m: distance from the levelling origin × the
        /// angle) and horizontal change (mm: height above it × the angle).
        height_m: f64,
        /// See `height_m`.
        across_mm: f64,
    },
}

impl Warning {
    /// What it does to the numbers, for ordering what a reader sees first:
    /// 0 a number may be wrong or targets were set aside, 1 the frame was
    /// chosen or turned, 2 how a step was done.
    pub fn weight(&self) -> u8 {
        match self {
            Warning::Float32Steps { .. }
            | Warning::Doubled(_)
            | Warning::HeightsUncertain { .. }
            | Warning::WrongObjects(_)
            | Warning::OutliersExcluded(_) => 0,
            Warning::Levelled { .. }
            | Warning::HeightsDisagree { .. }
            | Warning::Georeferenced { .. }
            | Warning::GroundWeak { .. }
            | Warning::GivenFrameReplaced { .. }
            | Warning::DetectionFailed(_) => 1,
            Warning::SphereWithoutHeights => 2,
        }
    }
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Warning::SphereWithoutHeights => f.write_str(
                "the survey has no heights; cropping with a vertical cylinder instead of a sphere",
            ),
            Warning::OutliersExcluded(ids) => write!(
                f,
                "gross errors excluded and the alignment refitted without them: {}",
                ids.join(", ")
            ),
            Warning::Doubled(ids) => write!(
                f,
                "{} {} mapped twice, the copies centimetres apart (the map has a seam there: a loop closed badly?): reported as ambiguous and left out of the fit",
                if ids.len() == 1 { "target" } else { "targets" },
                ids.join(", ")
            ),
            Warning::HeightsUncertain {
                ids,
                seen_m,
                plate_height_m,
                sigma_m,
                every,
            } => {
                let one = ids.len() == 1;
                let span = if seen_m.1 - seen_m.0 < 0.005 {
                    format!("{:.2} m", seen_m.0)
                } else {
                    format!("{:.2}-{:.2} m", seen_m.0, seen_m.1)
                };
                write!(
                    f,
                    "the {} {} {} uncertain by up to {:.0} mm (1σ): {} plates' points cover {span} of the {plate_height_m:.2} m plate height, or crowd toward part of it (a barrier, grass or a vehicle hiding the plates from below, or sparse scan lines), and the reference point at mid plate height is placed only to within that. The vertical σ includes it; horizontal positions are unaffected while the plates stand upright",
                    if one {
                        "height of target"
                    } else {
                        "heights of targets"
                    },
                    ids.join(", "),
                    if one { "is" } else { "are" },
                    sigma_m * 1e3,
                    if one { "its" } else { "their" },
                )?;
                if *every {
                    write!(
                        f,
                        ". Every located target shows it: are the plates {plate_height_m:.2} m tall (--plate-size W,H)?"
                    )?;
                }
                Ok(())
            }
            Warning::WrongObjects(ids) => write!(
                f,
                "objects located for {} are not those targets (far from where the other targets place them, or another target's object): reported as not found, each with its reason",
                ids.join(", ")
            ),
            Warning::DetectionFailed(e) => write!(
                f,
                "few targets were found where expected and detection found no other frame ({e}); the expected frame was kept"
            ),
            Warning::GivenFrameReplaced {
                given,
                found,
                targets,
            } => write!(
                f,
                "the frame from --{given} found {found} of {targets} targets where it put them; the targets were detected in the map and that frame was used instead (result.json eval.frame)"
            ),
            Warning::Float32Steps { step_m, reach_m } => write!(
                f,
                "the map stores its coordinates as float32, and they reach {reach_m:.0} m from the origin, where float32 keeps steps of {}: every point (and every located target) is rounded to that step, whatever the map's own accuracy. Have the map written in double precision, or about a local origin",
                if *step_m >= 0.1 {
                    format!("{step_m:.2} m")
                } else {
                    format!("{:.1} mm", step_m * 1e3)
                }
            ),
            Warning::Georeferenced { crs, tilt_deg } => write!(
                f,
                "the map's header declares a coordinate reference system ({crs}), so its z is vertical by construction: the ground's lean of {tilt_deg:.1}° is taken as the terrain's, not the map's, and the ground does not level it (the targets' plumb lines still may, when they all lean beyond their scatter)"
            ),
            Warning::GroundWeak {
                tilt_deg,
                support,
                blocks,
                min_support,
            } => write!(
                f,
                "the ground leans {tilt_deg:.1}°, but only {:.0} % of its {blocks} flat 2 m blocks agree on that vertical (levelling by the ground asks for {:.0} %, frame.level_min_support): taken as the terrain's slopes, not the map's tilt, and the map was not levelled by it (the targets' plumb lines still may, when they all lean beyond their scatter)",
                100.0 * support,
                100.0 * min_support
            ),
            Warning::HeightsDisagree {
                heights_deg,
                heights_se_deg,
                plumb_deg,
                plumb_se_deg,
                apart_deg,
            } => write!(
                f,
                "the surveyed heights say the map leans {heights_deg:.2}° ± {heights_se_deg:.2}° and its targets' plumb lines {plumb_deg:.2}° ± {plumb_se_deg:.2}° (1σ), verticals {apart_deg:.2}° apart: further apart than their uncertainties together allow, so the heights were not used for the vertical. The map's heights may drift (odometry's vertical drift bends a map without leaning it: evaluate heights with care), or the survey's heights are not the targets' corners' (check the antenna heights and the height datum)"
            ),
            Warning::Levelled {
                tilt_deg,
                se_deg,
                height_m,
                across_mm,
            } => write!(
                f,
                "the map leans {tilt_deg:.2}° from the vertical; it was levelled, and located positions are given in the levelled frame (result.json eval.frame.levelling maps them back). The vertical is known to ±{se_deg:.2}° (1σ): the targets' levelled heights are uncertain by up to {height_m:.2} m (distance from the levelling origin × that angle) and their horizontal positions by up to {across_mm:.1} mm (height above it × that angle): included in each target's σ and in the intervals (as one tilt shared by all)"
            ),
        }
    }
}

/// Fewer finite points than this is not a map (see `run`).
const MIN_MAP_POINTS: u64 = 100;

/// Everything an evaluation produces.
#[derive(Debug)]
pub struct Evaluation {
    /// The errors.
    pub accuracy: Accuracy,
    /// Per survey target, in survey order: crops, located corner or failure.
    pub targets: Vec<TargetRun>,
    /// What the map gave.
    pub map: MapStats,
    /// Caveats for the user.
    pub warnings: Vec<Warning>,
    /// How the map's frame was found, and its levelling.
    pub frame: FrameFound,
    /// What each pass over the map read, in order.
    pub reads: Vec<crate::cloud::PassRead>,
    /// The map from above, as the ground pass saw it (the report draws the
    /// target positions on it).
    pub footprint: crate::frame::Footprint,
    /// How close two copies of a target (a seam) may be and still be seen
    /// in this map; `None` with fewer than three targets located.
    pub doubling: Option<crate::locate::DoublingLimit>,
}

/// Points the levelling's ground pass reads of a bigger map by default
/// (`frame.ground_sample`): an even sample of its tiles, COPC nodes, LAZ
/// chunks or record blocks ([`crate::frame::ground_level`]). Millions of points give thousands of
/// 2 m ground blocks, more than the vertical's mode needs, at a tenth of a
/// pass over a 20 M-point map and a hundredth of a 200 M-point one (4 M
/// cost 0.08 s more of a 0.6 s eval of the former, with the same levelling
/// on the tilted scenes).
pub const GROUND_SAMPLE_POINTS: u64 = 2_000_000;

/// A float32 map whose coordinates are rounded to this step (m) or more is
/// refused: a uniform rounding of 0.1 m is 29 mm of noise on every point,
/// beyond a LiDAR map's own.
const FLOAT32_REFUSED_STEP: f64 = 0.1;

/// Where a running evaluation is: the pass over the map and its bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// The pass: `ground` (the map's vertical and ground, from an even
    /// sample of a big map),
    /// `detection` (map-wide detection of the targets, when the frame is
    /// not known), `crops` (around the expected positions), `second-pass`
    /// (around the positions the found targets predict).
    pub pass: &'static str,
    /// Bytes of this pass read so far.
    pub done: u64,
    /// Bytes this pass reads in all (a tiled map's or COPC file's crops
    /// may stop short of it: only the tiles or nodes near the targets).
    pub total: u64,
}

/// Evaluates a map against a survey. `progress` gets (bytes read, total
/// bytes) while a map file streams; each pass starts again from 0
/// ([`run_reporting`] says which pass).
pub fn run(
    source: MapSource,
    survey: &Survey,
    cfg: &Config,
    mut progress: impl FnMut(u64, u64),
) -> Result<Evaluation> {
    evaluate(source, survey, None, cfg, |p: Progress| {
        progress(p.done, p.total)
    })
    .map_err(|f| f.error)
}

/// [`run`] with hand-made tight crops `crops_dir/<id>.ply|pcd|…` (the paper's
/// manual workflow) instead of the automatic tight crop. The map is still read
/// for the loose crops the report shows.
pub fn run_with_crops(
    source: MapSource,
    survey: &Survey,
    crops_dir: &Path,
    cfg: &Config,
    mut progress: impl FnMut(u64, u64),
) -> Result<Evaluation> {
    evaluate(source, survey, Some(crops_dir), cfg, |p: Progress| {
        progress(p.done, p.total)
    })
    .map_err(|f| f.error)
}

/// [`run`] (or [`run_with_crops`] with `crops_dir`) telling `progress` which
/// pass over the map it is in, for a progress display that names it.
pub fn run_reporting(
    source: MapSource,
    survey: &Survey,
    crops_dir: Option<&Path>,
    cfg: &Config,
    progress: impl FnMut(Progress),
) -> Result<Evaluation> {
    evaluate(source, survey, crops_dir, cfg, progress).map_err(|f| f.error)
}

/// An evaluation that could not score, with what it found at each surveyed
/// place (crops, located corner or why not) when it got that far: what a
/// user needs to see why.
#[derive(Debug)]
pub struct Failed {
    /// Why the evaluation could not score.
    pub error: Error,
    /// Per survey target, in survey order, when the crops were read (empty
    /// when the run failed before them).
    pub targets: Vec<TargetRun>,
    /// Map → the frame the targets' positions are in (the levelling; the
    /// identity for a map read as it is).
    pub levelling: RigidMotion,
}

impl From<Error> for Failed {
    fn from(error: Error) -> Self {
        Failed {
            error,
            targets: Vec::new(),
            levelling: RigidMotion::identity_at(Point::origin()),
        }
    }
}

/// [`run_reporting`] that, when the evaluation cannot score, keeps what it
/// saw at each surveyed place ([`Failed`]) for the user to inspect.
// A large error is returned once a run: not worth a box.
#[allow(clippy::result_large_err)]
pub fn run_keeping_failures(
    source: MapSource,
    survey: &Survey,
    crops_dir: Option<&Path>,
    cfg: &Config,
    progress: impl FnMut(Progress),
) -> std::result::Result<Evaluation, Failed> {
    evaluate(source, survey, crops_dir, cfg, progress)
}

/// Every located object checked against the physical target and against
/// the other targets: one still far from where the others place it, an
/// object claimed by two targets, a target mapped twice, a layout no map
/// bends to: each is set aside with its reason (and named in a warning), and
/// a height from plates seen in part gets the σ it deserves. Returns how
/// close two copies of a target may be and still be seen.
fn check_found(
    found: &mut [TargetRun],
    survey: &Survey,
    opts: &ScoreOptions,
    far: &[(usize, f64, f64, target::FarBy)],
    cfg: &Config,
    warnings: &mut Vec<Warning>,
) -> Option<crate::locate::DoublingLimit> {
    // What is still far after the search is not the target.
    let mut wrong = Vec::new();
    // (A target found again close to the prediction is the object there:
    // its error is the map's or the survey's, and stays in the result.)
    for (i, error, median, by) in frame::far_from_others(found, survey, opts) {
        let searched = far.iter().any(|f| f.0 == i);
        if searched && found[i].pass == Pass::Second {
            continue;
        }
        if let Some(at) = found[i].corner() {
            found[i].outcome = Err(Failure::FarFromOthers {
                at,
                error,
                median,
                by,
                searched,
            });
        }
    }
    target::one_object_each(found, cfg.tight.plate_width);
    // A target mapped twice is neither copy: it leaves the fit, named.
    let (doubled, doubling) = target::check_doubled(found, cfg);
    if !doubled.is_empty() {
        warnings.push(Warning::Doubled(doubled));
    }
    // A height from plates seen in part is known only as well as the part.
    let widened = target::widen_heights(found, cfg.tight.plate_height);
    // Metres of disagreement with the survey's layout are no map's error,
    // however few targets were located.
    frame::off_layout(found, survey, opts);
    for (i, r) in found.iter().enumerate() {
        if matches!(
            r.outcome,
            Err(Failure::FarFromOthers { .. }
                | Failure::SameObject { .. }
                | Failure::OffLayout { .. })
        ) {
            wrong.push(survey.targets[i].id.clone());
        }
    }
    if !wrong.is_empty() {
        warnings.push(Warning::WrongObjects(wrong));
    }
    // Named only when still located (not set aside above).
    let widened: Vec<_> = widened
        .into_iter()
        .filter(|w| found.iter().any(|r| r.id == w.0 && r.outcome.is_ok()))
        .collect();
    if !widened.is_empty() {
        let located = found.iter().filter(|r| r.outcome.is_ok()).count();
        warnings.push(Warning::HeightsUncertain {
            ids: widened.iter().map(|w| w.0.clone()).collect(),
            seen_m: widened
                .iter()
                .map(|w| w.1.seen_m.min(w.1.plate_height_m))
                .fold((f64::INFINITY, 0.0), |(a, b), s| (a.min(s), b.max(s))),
            plate_height_m: cfg.tight.plate_height,
            sigma_m: widened.iter().map(|w| w.2).fold(0.0, f64::max),
            every: located >= 3 && widened.len() == located,
        });
    }
    doubling
}

/// The errors of the located targets, each weighed by its covariance; with
/// `metrics.exclude_outliers`, again without the gross errors, which stay in
/// the result as excluded, with the numbers that condemned them.
fn score(
    found: &[TargetRun],
    survey: &Survey,
    opts: &ScoreOptions,
    cfg: &Config,
    warnings: &mut Vec<Warning>,
) -> Result<Accuracy> {
    let covariances = found
        .iter()
        .filter_map(|r| {
            r.outcome
                .as_ref()
                .ok()
                .map(|f| (r.id.clone(), f.located.covariance))
        })
        .collect();
    let mut est = estimates(found);
    let mut accuracy = accuracy::score_with_covariances(survey, &est, &covariances, opts)?;
    if cfg.metrics.exclude_outliers {
        // Refit without the gross errors, each kept in the result as excluded
        // with the numbers that condemned it: never dropped silently.
        let gross: Vec<(String, String)> = accuracy
            .warnings
            .iter()
            .filter_map(|w| match w {
                accuracy::Warning::GrossError {
                    id,
                    error,
                    robust_z,
                    ..
                } => Some((
                    id.clone(),
                    format!(
                        "excluded as a gross error (--exclude-outliers): error {:.0} mm, robust z {robust_z:.1}",
                        error * 1e3
                    ),
                )),
                _ => None,
            })
            .collect();
        if !gross.is_empty() {
            for e in &mut est {
                if let Some((_, why)) = gross.iter().find(|g| g.0 == e.id) {
                    e.status = EstimateStatus::Excluded {
                        reason: why.clone(),
                    };
                }
            }
            accuracy = accuracy::score_with_covariances(survey, &est, &covariances, opts)?;
            warnings.push(Warning::OutliersExcluded(
                gross.into_iter().map(|g| g.0).collect(),
            ));
        }
    }
    Ok(accuracy)
}

/// What the ground pass says of the map before anything is located: too few
/// points to be a map (`needs_points`: not when hand crops are given), or
/// float32 coordinates too far from their origin to measure anything.
fn check_map(
    map: &MapStats,
    ground: &crate::frame::MapGround,
    needs_points: bool,
    warnings: &mut Vec<Warning>,
) -> Result<()> {
    // A located target alone takes hundreds of points: a "map" of fewer than
    // a hundred is another file (the survey, a list of positions) given as
    // the map, and every later message (no frame found, no target) would
    // hide that.
    if needs_points && map.points < MIN_MAP_POINTS {
        return Err(Error::Input(format!(
            "{}: only {} finite points{}; a map holds thousands around each target: is this the map?",
            map.name,
            map.points,
            if map.skipped_nonfinite > 0 {
                format!(" ({} non-finite skipped)", map.skipped_nonfinite)
            } else {
                String::new()
            }
        )));
    }
    if let Some((step_m, reach_m)) = ground.float32_step {
        let w = Warning::Float32Steps { step_m, reach_m };
        // Rounding of a tenth of a metre (coordinates beyond 1 048 576 m: UTM
        // northings) is noise no plate fit averages away; below, a warning.
        if step_m >= FLOAT32_REFUSED_STEP {
            return Err(Error::Input(format!(
                "{}: {w}. At that step no target can be measured: refused",
                map.name
            )));
        }
        warnings.push(w);
    }
    Ok(())
}

/// The frame the map is first read in: levelled by its ground when that
/// leans, except when nothing may turn it (`no_turn`: `--align none`) or its
/// header declares a coordinate reference system (then z is vertical by
/// construction and the lean is the terrain's: said in a warning).
fn first_levelling(
    source: MapSource,
    ground: &crate::frame::MapGround,
    no_turn: bool,
    cfg: &Config,
    warnings: &mut Vec<Warning>,
) -> RigidMotion {
    // A georeferenced map (its header declares a CRS) has z vertical by
    // construction: a lean of its ground is the terrain's (an airborne
    // scan of a hillside), not the map's.
    let declared_crs = match source {
        MapSource::File(p) => crate::cloud::declared_crs(p),
        MapSource::Points(_) => None,
    };
    let leaning = ground
        .level
        .as_ref()
        .filter(|l| l.tilt_deg > cfg.frame.level_above_deg);
    match (no_turn, &declared_crs, leaning) {
        (true, _, _) => RigidMotion::identity_at(ground.centre),
        (false, Some(crs), Some(l)) => {
            warnings.push(Warning::Georeferenced {
                crs: crs.clone(),
                tilt_deg: l.tilt_deg,
            });
            RigidMotion::identity_at(ground.centre)
        }
        _ => {
            let (above, support) = (cfg.frame.level_above_deg, cfg.frame.level_min_support);
            if let Some(l) = ground.leans_weakly(above, support) {
                warnings.push(Warning::GroundWeak {
                    tilt_deg: l.tilt_deg,
                    support: l.support,
                    blocks: l.blocks,
                    min_support: support,
                });
            }
            ground.levelling(above, support)
        }
    }
}

/// The targets' plumb lines (and surveyed heights) refine the vertical, once;
/// when they turn the frame, the targets and their expected positions turn
/// with it. Says what the levelling did and how well the vertical is known.
fn refine_vertical(
    found: &mut [TargetRun],
    expected: &mut [Point],
    motion: &mut RigidMotion,
    survey: &Survey,
    no_turn: bool,
    cfg: &Config,
    warnings: &mut Vec<Warning>,
) -> Option<frame::Plumb> {
    // The targets' plumb lines, and their surveyed heights when five or
    // more have them, refine the vertical, once: each line is a plain plane
    // fit of the target's own points and each height the located corner's,
    // which turn with the frame, so a second look would see the same.
    let turned = !motion.is_identity();
    let plumb = frame::plumb(found, survey, turned)
        .filter(|_| !no_turn)
        .map(|(p, rot)| {
            if let Some(rot) = rot {
                frame::turn_targets(found, &rot, motion.origin, cfg);
                let m = RigidMotion {
                    origin: motion.origin,
                    rotation: rot,
                };
                for e in expected.iter_mut() {
                    *e = m.apply(e);
                }
                *motion = motion.then(&rot);
            }
            if let Some(h) = p.heights.as_ref().filter(|h| !h.agrees) {
                warnings.push(Warning::HeightsDisagree {
                    heights_deg: h.tilt_deg,
                    heights_se_deg: h.se_deg,
                    plumb_deg: p.tilt_deg,
                    plumb_se_deg: p.se_deg,
                    apart_deg: h.apart_deg,
                });
            }
            p
        });
    let tilt = motion.tilt_deg();
    if tilt > 0.0 {
        let se_deg = frame::vertical_se_deg(plumb.as_ref());
        let a = se_deg.to_radians();
        let o = motion.origin;
        let (mut height_m, mut across_mm) = (0.0_f64, 0.0_f64);
        // The angle's error in the one direction that raises a target.
        for e in expected.iter() {
            height_m = height_m.max(a / std::f64::consts::SQRT_2 * (e.x - o.x).hypot(e.y - o.y));
        }
        // Heights from the located corners: the expected positions carry the
        // survey's heights, whose datum need not be the map's.
        for c in found.iter().filter_map(|r| r.corner()) {
            across_mm = across_mm.max(1e3 * a * (c.z - o.z).abs());
        }
        warnings.push(Warning::Levelled {
            tilt_deg: tilt,
            se_deg,
            height_m,
            across_mm,
        });
    }
    plumb
}

/// The located corners as estimates for [`accuracy::score`].
fn estimates(found: &[TargetRun]) -> Vec<Estimate> {
    found
        .iter()
        .map(|r| Estimate {
            id: r.id.clone(),
            status: match &r.outcome {
                Ok(f) => EstimateStatus::Found(f.located.corner),
                Err(e @ Failure::Doubled(_)) => EstimateStatus::Ambiguous {
                    reason: e.to_string(),
                },
                Err(e) => EstimateStatus::NotFound {
                    reason: e.to_string(),
                },
            },
            has_z: true,
        })
        .collect()
}

/// Every position but the `i`-th.
fn others_than(positions: &[Point], i: usize) -> Vec<Point> {
    let mut v = positions.to_vec();
    v.remove(i);
    v
}

/// The "ups" tried after the crop's own: the map's own +z and the ground's
/// map-wide vertical, in the frame `motion` reads the map into.
fn more_ups(
    motion: &RigidMotion,
    ground_up: Option<nalgebra::Vector3<f64>>,
) -> Vec<nalgebra::Vector3<f64>> {
    let mut v = vec![motion.rotation * nalgebra::Vector3::z()];
    if let Some(g) = ground_up {
        v.push(motion.rotation * g);
    }
    v
}

/// Where every surveyed target is expected in the (levelled) map.
/// With `level` (a transform in the map's own frame), the positions are moved
/// by the levelling at the centre of rotation's height: the survey's heights
/// may sit metres above or below the map's, and the crop is a cylinder.
fn expected_positions(
    survey: &Survey,
    init: &crate::frame::MapToSurvey,
    dz: f64,
    level: Option<&RigidMotion>,
) -> Vec<Point> {
    survey
        .targets
        .iter()
        .map(|t| {
            let mut e = init.to_map(&t.reference());
            e.z -= dz;
            if let Some(m) = level.filter(|m| !m.is_identity()) {
                let q = m.apply(&Point::new(e.x, e.y, m.origin.z));
                e.x = q.x;
                e.y = q.y;
                e.z += q.z - m.origin.z;
            }
            e
        })
        .collect()
}

/// Per centre, the crop's points and how many were offered before thinning.
type Crops = Vec<(Vec<Point>, u64)>;

/// The loose crops around `centres` in one pass over the map, each with the
/// number of points the map had there before thinning, and what the pass read.
fn read_crops(
    source: MapSource,
    centres: &[Point],
    params: &LooseParams,
    motion: &RigidMotion,
    z_range: Option<[f64; 2]>,
    map: &mut MapStats,
    progress: &mut impl FnMut(u64, u64),
) -> Result<(
    Crops,
    crate::cloud::PassRead,
    Option<crate::cloud::PassRead>,
)> {
    // With the map's z range, a tilted map's region hint reaches its reader
    // (tiles and COPC nodes far from the targets stay unread).
    let mut reader = source.open_moved_within(Some(motion), z_range)?;
    let total = reader.info().file_bytes;
    if reader.tile_stats().is_none() {
        map.bytes = total;
    }
    let mut crop = if params.by_level {
        crop::loose_crop_by_level(reader.as_mut(), centres, params, |b| progress(b, total))?
    } else {
        crop::loose_crop(reader.as_mut(), centres, params, |b| progress(b, total))?
    };
    // A tiled map's crop opened only the tiles near the targets: its counts
    // are not the map's (the ground pass's are kept).
    if reader.tile_stats().is_none_or(|t| t.selected == t.tiles) {
        map.points = crop.map_points;
        map.skipped_nonfinite = crop.skipped_nonfinite;
    }
    let read = crate::cloud::PassRead::of("crops", reader.as_ref());
    // A COPC octree read to the levels that hold enough points near a
    // target: a crop that came out with no more than it keeps was short of
    // the estimate, and is read again at every level (its own entry in
    // `eval.reads`: the two reads share the coarse nodes).
    let short: Vec<usize> = (0..centres.len())
        .filter(|&i| {
            crop.levels_cut.get(i).copied().unwrap_or(false)
                && crop.offered[i] <= params.max_points as u64
        })
        .collect();
    let mut again_read = None;
    if !short.is_empty() {
        let mut again = source.open_moved_within(Some(motion), z_range)?;
        let total = again.info().file_bytes;
        let at: Vec<Point> = short.iter().map(|&i| centres[i]).collect();
        let full = crop::loose_crop(again.as_mut(), &at, params, |b| progress(b, total))?;
        again_read = Some(crate::cloud::PassRead::of("crops-again", again.as_ref()));
        for (k, (pts, offered)) in full.points.into_iter().zip(full.offered).enumerate() {
            crop.points[short[k]] = pts;
            crop.offered[short[k]] = offered;
        }
    }
    Ok((
        crop.points.into_iter().zip(crop.offered).collect(),
        read,
        again_read,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A COPC crop read to the coarse levels that came out no larger than
    /// it keeps (a sphere hanging over the cloud's slab: the nodes' squares
    /// promise a cylinder's points) is read again at every level, and comes
    /// out as a crop of every level does; the others stay coarse.
    #[test]
    fn a_copc_crop_short_of_its_levels_estimate_is_read_again_whole() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/random-20k.copc.laz");
        let source = MapSource::File(&path);
        let centres = [
            Point::new(350_100.5, 4_150_100.5, 10.0),
            Point::new(350_312.2, 4_150_250.7, 70.0),
        ];
        let params = crop::LooseParams {
            radius: 60.0,
            shape: crop::Shape::Sphere,
            max_points: 60,
            by_level: true,
        };
        let flat = RigidMotion::identity_at(Point::origin());
        let mut map = MapStats::default();
        let (crops, read, again) = read_crops(
            source,
            &centres,
            &params,
            &flat,
            None,
            &mut map,
            &mut |_, _| {},
        )
        .unwrap();
        let again = again.expect("the short crop read again");
        let mut r = crate::cloud::open(&path).unwrap();
        let every = crop::loose_crop(r.as_mut(), &centres, &params, |_| {}).unwrap();
        let whole = crate::cloud::PassRead::of("crops", r.as_ref());
        // The sphere's cap: every level read for it, as a whole crop.
        assert!(every.offered[1] > 60 && crops[1].1 == every.offered[1]);
        assert_eq!(crops[1].0, every.points[1]);
        // The other crop: the coarse levels, more than it keeps.
        assert!(
            crops[0].1 > 60 && 3 * crops[0].1 < every.offered[0],
            "{crops:?}"
        );
        // Both reads counted, less than reading every level near both.
        let mut r = crate::cloud::open(&path).unwrap();
        let coarse = crop::loose_crop_by_level(r.as_mut(), &centres, &params, |_| {}).unwrap();
        // Both discs share the root: one group, both cut.
        assert_eq!(coarse.levels_cut, [true, true]);
        assert!(coarse.offered[1] <= 60, "{:?}", coarse.offered);
        let first = crate::cloud::PassRead::of("crops", r.as_ref());
        assert_eq!(first, read);
        assert!(read.bytes < whole.bytes, "{read:?} against {whole:?}");
        // Only the sphere's crop was read again.
        assert!(
            again.pass == "crops-again" && again.bytes < whole.bytes,
            "{again:?}"
        );
    }

    fn survey(at: &[(f64, f64)]) -> Survey {
        let at: Vec<(f64, f64, f64)> = at.iter().map(|&(x, y)| (x, y, 0.0)).collect();
        Survey::local(&at, false)
    }

    /// The failures a caller acts on come typed, with their numbers (issue
    /// 32): a patch of bare ground locates no target, and the same ground
    /// read in millimetres is not a map in metres.
    #[test]
    fn failures_to_act_on_are_typed() {
        let ground: Vec<Point> = (0..4_000)
            .map(|i| Point::new((i % 60) as f64 * 0.5, (i / 60) as f64 * 0.5, 0.0))
            .collect();
        let s = survey(&[(5.0, 5.0), (20.0, 20.0)]);
        let cfg = Config::default();
        match run(MapSource::Points(&ground), &s, &cfg, |_, _| ()) {
            Err(Error::TooFewFound {
                found: 0,
                need: 2,
                msg,
            }) => {
                assert!(msg.contains("only 0 of 2 targets found"), "{msg}")
            }
            other => panic!("{:?}", other.map(|_| ())),
        }
        // Three places (auto mode then looks map-wide): no frame.
        let s3 = survey(&[(5.0, 5.0), (20.0, 20.0), (25.0, 5.0)]);
        match run(MapSource::Points(&ground), &s3, &cfg, |_, _| ()) {
            Err(Error::FrameNotFound { detections: 0, msg }) => {
                assert!(msg.contains("none anywhere else"), "{msg}")
            }
            other => panic!("{:?}", other.map(|_| ())),
        }
        // A site of tens of metres in millimetres: tens of kilometres.
        let mm: Vec<Point> = (0..400_000)
            .map(|i| Point::new((i % 600) as f64 * 50.0, (i / 600) as f64 * 50.0, 0.0))
            .collect();
        match run(MapSource::Points(&mm), &s, &cfg, |_, _| ()) {
            Err(Error::NotMetres { extent, msg }) => {
                assert!(extent[0] > 1e3 && msg.contains("millimetres"), "{msg}")
            }
            other => panic!("{:?}", other.map(|_| ())),
        }
    }
}
