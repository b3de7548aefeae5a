//! Where to look: the map → survey transform of the pipeline.
//!
//! - **The transform.** `--init` or `--hints` when given; else the survey
//!   frame if the targets are found there; else map-wide detection matched to
//!   the survey without correspondences ([`crate::frame::matching`]).
//! - Which way is up (the ground's vertical, refined by the targets' plumb
//!   lines) is [`super::vertical`]; wrong objects, found far from where the
//!   others put them, [`super::layout`].

use super::target::TargetRun;
use super::vertical::Plumb;
use super::{Config, FrameMode};
use crate::cloud::{MapSource, RigidMotion};
use crate::detect::{DetectParams, Detection, detect_map};
use crate::frame::MapToSurvey;
use crate::frame::hints::read_hints;
use crate::frame::matching::{Candidate, FrameMatch, MatchError, MatchParams, match_frame};
use crate::frame::{GroundLevel, MapGround};
use crate::model::ModelKind;
use crate::survey::Survey;
use crate::{Error, Point, Result};

/// How the map → survey transform was found.
#[derive(Debug, Clone, PartialEq)]
pub enum FrameHow {
    /// The targets were where the survey says (the map is in its frame).
    Survey,
    /// `--init` gave it.
    Init,
    /// Fitted to `--hints`.
    Hints {
        /// Hints shared with the survey.
        used: usize,
        /// Largest disagreement of a hint with the fit (m).
        worst: f64,
    },
    /// Target-shaped objects detected map-wide and matched to the survey.
    Detected {
        /// Objects detected.
        detections: usize,
        /// (survey id, detection index) per match.
        matched: Vec<(String, usize)>,
        /// RMS horizontal residual of the matches (m).
        rms: f64,
        /// Matches of the best different transform (0: none).
        runner_up: usize,
    },
}

impl FrameHow {
    /// Short name, as result.json gives it.
    pub fn name(&self) -> &'static str {
        match self {
            FrameHow::Survey => "survey",
            FrameHow::Init => "init",
            FrameHow::Hints { .. } => "hints",
            FrameHow::Detected { .. } => "detect",
        }
    }
}

/// What the pipeline learned about the map's frame.
#[derive(Debug, Clone)]
pub struct FrameFound {
    /// How the transform was found.
    pub how: FrameHow,
    /// Map → survey, horizontally: of the map as stored for `--init` and the
    /// survey frame, of the levelled map for hints and detection.
    pub init: MapToSurvey,
    /// Survey z minus map z used to place the crops.
    pub dz: f64,
    /// The ground's vertical, when enough ground was seen.
    pub ground: Option<GroundLevel>,
    /// Map → the frame every position of the evaluation is in (identity for a
    /// level map): p_levelled = origin + R·(p_map − origin).
    pub levelling: RigidMotion,
    /// The targets' plumb lines, when three or more were located.
    pub plumb: Option<Plumb>,
    /// Detected objects that matched no surveyed target (map frame corners).
    pub unmatched: Vec<Detection>,
}

/// The first guess at the transform before any target is located: what the
/// user gave, or the survey frame (auto mode tries it first).
pub(super) fn given(
    survey: &Survey,
    cfg: &Config,
    motion: &RigidMotion,
) -> Result<(FrameHow, MapToSurvey, f64)> {
    if let Some(init) = cfg.frame.init {
        return Ok((FrameHow::Init, init, 0.0));
    }
    if let Some(path) = &cfg.frame.hints
        && matches!(cfg.frame.mode, FrameMode::Auto | FrameMode::Hints)
    {
        let h = read_hints(path, survey, motion)?;
        return Ok((
            FrameHow::Hints {
                used: h.used,
                worst: h.worst,
            },
            h.init,
            h.dz,
        ));
    }
    Ok((FrameHow::Survey, MapToSurvey::IDENTITY, 0.0))
}

/// Whether the first pass in the survey frame found the targets there.
pub(super) fn targets_there(found: &[TargetRun]) -> bool {
    let n = found.iter().filter(|r| r.outcome.is_ok()).count();
    n >= 3.min(found.len()).max(2)
}

/// Unit mix-ups between the survey and the map: the factor that brings the
/// survey to the map's unit, and what it means.
const UNITS: [(f64, &str); 4] = [
    (
        0.3048,
        "to be in feet (international or US survey) while the map is in metres",
    ),
    (1.0 / 0.3048, "to be in metres while the map is in feet"),
    (0.001, "to be in millimetres while the map is in metres"),
    (1000.0, "to be in metres while the map is in millimetres"),
];

/// Why map-wide detection gave no frame.
#[derive(Debug)]
pub(super) enum NoFrame {
    /// The map could not be read, or a diagnosis that stands by itself (the
    /// survey's x and y swapped).
    Failed(Error),
    /// Detection ran, and no frame put enough of its objects on surveyed
    /// targets.
    NotMatched {
        /// Target-shaped objects detected map-wide.
        detections: usize,
        /// How the matching failed.
        why: MatchError,
    },
}

impl From<Error> for NoFrame {
    fn from(e: Error) -> Self {
        NoFrame::Failed(e)
    }
}

impl NoFrame {
    /// The remedy a failed match calls for.
    pub(super) fn remedy(why: &MatchError) -> &'static str {
        match why {
            MatchError::Ambiguous { .. } => {
                "give --hints FILE (id,x,y of 2 or more targets as seen in the map, ±0.5 m) to choose"
            }
            MatchError::TooFew { .. } => {
                "give --hints FILE (id,x,y of 2 or more targets as seen in the map, ±0.5 m) or --init x,y,yaw_deg"
            }
        }
    }

    /// The error when detection was all there was to go by (`--frame
    /// detect`, or a warning beside a frame that found enough).
    pub(super) fn into_error(self) -> Error {
        match self {
            NoFrame::Failed(e) => e,
            NoFrame::NotMatched { detections: 0, .. } => Error::FrameNotFound {
                detections: 0,
                msg: "detection found no target-shaped object anywhere in the map: no frame can be matched to the survey (a map without these targets, or plates of another size than --plate-size?)".into(),
            },
            NoFrame::NotMatched { why, detections } => Error::FrameNotFound {
                detections,
                msg: format!(
                    "the map's frame could not be found by detection: {why}; {}",
                    NoFrame::remedy(&why)
                ),
            },
        }
    }
}

/// The spheres detection looks for: none unless the survey has spheres;
/// the diameter most of its sphere rows give (ties: the smaller; spheres of
/// other sizes are located once the frame is found from the others).
fn spheres_to_detect<'a>(
    survey: &Survey,
    cfg: &'a Config,
) -> Option<(&'a crate::model::SphereParams, f64)> {
    most_common_size(survey, ModelKind::Sphere, cfg.sphere.diameter_m).map(|d| (&cfg.sphere, d))
}

/// The size most of the survey's rows of `model` give (`default` for rows
/// without one; ties: the smaller); `None` without such rows.
fn most_common_size(survey: &Survey, model: ModelKind, default: f64) -> Option<f64> {
    let mut sizes: Vec<f64> = survey
        .targets
        .iter()
        .filter(|t| t.model == model)
        .map(|t| t.size.unwrap_or(default))
        .collect();
    sizes.sort_by(f64::total_cmp);
    let mut best: Option<(f64, usize)> = None;
    for run in sizes.chunk_by(|a, b| a == b) {
        if best.is_none_or(|b| run.len() > b.1) {
            best = Some((run[0], run.len()));
        }
    }
    best.map(|(d, _)| d)
}

/// The boards detection looks for: none unless the survey has boards; the
/// side most of its board rows give (ties: the smaller), as for spheres.
fn boards_to_detect<'a>(
    survey: &Survey,
    cfg: &'a Config,
) -> Option<(&'a crate::model::BoardParams, f64)> {
    most_common_size(survey, ModelKind::Board, cfg.board.side_m).map(|s| (&cfg.board, s))
}

/// Detects targets map-wide and matches them to the survey.
#[allow(clippy::too_many_arguments)]
pub(super) fn detect_and_match(
    source: MapSource,
    survey: &Survey,
    ground: &MapGround,
    motion: &RigidMotion,
    cfg: &Config,
    total: u64,
    progress: &mut impl FnMut(u64, u64),
    reads: &mut Vec<crate::cloud::PassRead>,
) -> std::result::Result<(FrameHow, MapToSurvey, f64, Vec<Detection>), NoFrame> {
    // The levelling's ground was a sample; detection needs the ground under
    // every cell of the map.
    let all = if ground.sampled {
        let g = ground.completed(source, |b| progress(b, total))?;
        reads.push(crate::cloud::PassRead {
            pass: "detect-ground".into(),
            ..g.pass_read.clone()
        });
        Some(g)
    } else {
        None
    };
    let models = crate::detect::Models {
        tight: &cfg.tight,
        sphere: spheres_to_detect(survey, cfg),
        board: boards_to_detect(survey, cfg),
    };
    let found = detect_map(
        source,
        all.as_ref().unwrap_or(ground),
        motion,
        &DetectParams::default(),
        models,
        |b| progress(b, total),
    )?;
    reads.extend(found.reads.iter().cloned());
    let cands: Vec<Candidate> = found
        .detections
        .iter()
        .map(|d| Candidate {
            at: d.corner,
            model: d.model,
        })
        .collect();
    let sur: Vec<Point> = survey.targets.iter().map(|t| t.reference()).collect();
    let kinds: Vec<ModelKind> = survey.targets.iter().map(|t| t.model).collect();
    let params = MatchParams {
        tol: cfg.frame.match_tolerance,
        min_matches: 3,
    };
    let m = match_frame(&cands, &sur, &kinds, survey.has_z(), &params);
    let survey_xy = SurveyXy {
        cands: &cands,
        sur: &sur,
        kinds: &kinds,
        has_z: survey.has_z(),
        params: &params,
        wgs84_origin: (survey.frame == crate::survey::SurveyFrame::Wgs84Enu)
            .then_some(survey.origin)
            .flatten(),
        // As the layout is read: each target's reference point, its
        // position moved alike.
        exchanged: survey
            .exchanged
            .as_ref()
            .filter(|x| x.len() == survey.targets.len())
            .map(|x| {
                x.iter()
                    .zip(&survey.targets)
                    .map(|(p, t)| p + (t.reference() - t.position))
                    .collect()
            }),
    };
    survey_xy.not_latlon_swapped(&m)?;
    survey_xy.not_swapped(&m)?;
    survey_xy.in_metres(&m)?;
    let m = m.map_err(|why| NoFrame::NotMatched {
        detections: found.detections.len(),
        why,
    })?;
    let used: Vec<usize> = m.matches.iter().map(|x| x.1).collect();
    let unmatched = found
        .detections
        .iter()
        .enumerate()
        .filter(|(i, _)| !used.contains(i))
        .map(|(_, d)| d.clone())
        .collect();
    let how = FrameHow::Detected {
        detections: found.detections.len(),
        matched: m
            .matches
            .iter()
            .map(|&(i, a, _)| (survey.targets[i].id.clone(), a))
            .collect(),
        rms: m.rms,
        runner_up: m.runner_up,
    };
    Ok((how, m.init, m.dz, unmatched))
}

/// The survey's layout tried against the map's detections in the forms a
/// mistaken survey takes, to say what the mistake is instead of "not
/// matched".
struct SurveyXy<'a> {
    cands: &'a [Candidate],
    sur: &'a [Point],
    kinds: &'a [ModelKind],
    has_z: bool,
    params: &'a MatchParams,
    /// The ENU origin of a survey read as latitude, longitude.
    wgs84_origin: Option<crate::survey::Geodetic>,
    /// A survey of latitude, longitude placed by the map's projection, read
    /// the other way round (reference points, as `sur`).
    exchanged: Option<Vec<Point>>,
}

impl SurveyXy<'_> {
    /// A survey of latitude and longitude in each other's columns is not
    /// the map's mirror image alone: a degree of longitude is cos(latitude)
    /// of one of latitude, so the mirror is stretched one way (1.5× at 48°)
    /// and the plain exchange of x and y misses it. Its positions are read
    /// back to degrees, exchanged and projected again.
    fn not_latlon_swapped(
        &self,
        m: &std::result::Result<FrameMatch, MatchError>,
    ) -> std::result::Result<(), NoFrame> {
        const HOW: &str =
            "the survey's latitude and longitude look swapped: read the other way round";
        const FIX: &str =
            "Check the order of the survey's columns (id,lat,lon: latitude first) and run again";
        // Placed by the map's projection, a swapped survey lands far off the
        // map; read the other way round, it is on it.
        if let Some(x) = &self.exchanged {
            return self.fits_better(m, x, HOW, FIX);
        }
        let Some(o) = self.wgs84_origin else {
            return Ok(());
        };
        let swap = |g: crate::survey::Geodetic| crate::survey::Geodetic {
            lat: g.lon,
            lon: g.lat,
            alt: g.alt,
        };
        // About the first target read the other way round: an `--origin`
        // given right must not be exchanged with the rows.
        let Some(first) = self.sur.first() else {
            return Ok(());
        };
        let o2 = swap(o.geodetic_of(first));
        if !(o2.lat.abs() < 90.0) {
            return Ok(());
        }
        let exchanged: Vec<Point> = self
            .sur
            .iter()
            .map(|p| o2.enu_of(&swap(o.geodetic_of(p))))
            .collect();
        self.fits_better(m, &exchanged, HOW, FIX)
    }

    /// A survey with x and y exchanged is the map's mirror image (as is one
    /// with an axis reversed: every mirror is any other turned, so the two
    /// cannot be told apart): no rigid motion fits it, though a few targets may happen to fit one (an
    /// isosceles three of them does). Its mirror fitting more is the mistake.
    fn not_swapped(
        &self,
        m: &std::result::Result<FrameMatch, MatchError>,
    ) -> std::result::Result<(), NoFrame> {
        let mirrored: Vec<Point> = self.sur.iter().map(|p| Point::new(p.y, p.x, p.z)).collect();
        self.fits_better(
            m,
            &mirrored,
            "the survey is the map's mirror image: with its x and y exchanged",
            "Any mirror fits once turned, so this cannot tell which: the survey's x and y swapped (check the order of its columns: id,x,y, x east, y north), or one axis reversed in the survey or the map (north-east-down against east-north-up, a left-handed frame). Fix the one that is wrong and run again",
        )
    }

    /// A survey in another unit than the map (feet, millimetres) is the
    /// map's layout scaled: no rigid motion fits it. Scaled back, it
    /// fitting is the mistake (about the survey's centroid: UTM-sized
    /// coordinates stay small).
    fn in_metres(
        &self,
        m: &std::result::Result<FrameMatch, MatchError>,
    ) -> std::result::Result<(), NoFrame> {
        let sur = self.sur;
        if m.is_ok() || sur.len() < 3 {
            return Ok(());
        }
        let n = sur.len() as f64;
        let c = sur
            .iter()
            .fold(nalgebra::Vector3::zeros(), |a, p| a + p.coords)
            / n;
        for (factor, what) in UNITS {
            let scaled: Vec<Point> = sur
                .iter()
                .map(|p| Point::from(c + (p.coords - c) * factor))
                .collect();
            self.fits_better(
                m,
                &scaled,
                &format!("the survey looks {what}: scaled by {factor}"),
                "mapgauge reads both files in metres: convert the survey, or the map (`mapgauge convert --scale`), and run again",
            )?;
        }
        Ok(())
    }

    /// The survey read another way (`read`) puts more of its targets on
    /// detections than as written (`m`): the mistake, refused as `how` it
    /// was read, and `fix`.
    fn fits_better(
        &self,
        m: &std::result::Result<FrameMatch, MatchError>,
        read: &[Point],
        how: &str,
        fix: &str,
    ) -> std::result::Result<(), NoFrame> {
        let Ok(mm) = match_frame(self.cands, read, self.kinds, self.has_z, self.params) else {
            return Ok(());
        };
        let given = matched_as_given(m);
        if mm.matches.len() <= given {
            return Ok(());
        }
        Err(NoFrame::Failed(Error::Input(format!(
            "{how}, {} of its {} targets fall on targets detected in the map (rms {:.0} mm); as written, {}. {fix}",
            mm.matches.len(),
            self.sur.len(),
            mm.rms * 1e3,
            as_written(given)
        ))))
    }
}

/// How many targets the survey as written put on detections, in words.
fn as_written(n: usize) -> String {
    match n {
        0 => "none does".into(),
        1 => "only 1 does (no frame is fitted on fewer than 3)".into(),
        2 => "only 2 do (no frame is fitted on fewer than 3)".into(),
        n => format!("only {n} do"),
    }
}

/// Targets the survey as given matched: its matches, or the most any
/// transform found when none was chosen (too few, or two about equal).
fn matched_as_given(m: &std::result::Result<FrameMatch, MatchError>) -> usize {
    match m {
        Ok(m) => m.matches.len(),
        Err(MatchError::TooFew { best, .. }) => *best,
        Err(MatchError::Ambiguous { a, .. }) => *a,
    }
}
