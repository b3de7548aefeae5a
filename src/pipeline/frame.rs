//! Where to look and which way is up: the frame steps of the pipeline.
//!
//! - **Levelling.** A ground pass over the whole map gives its vertical; a map
//!   leaning more than `frame.level_above_deg` is read rotated upright. After
//!   the first pass the targets' own plumb lines (they are built vertical)
//!   refine it, when they disagree with +z by more than their own scatter.
//! - **The transform.** `--init` or `--hints` when given; else the survey
//!   frame if the targets are found there; else map-wide detection matched to
//!   the survey without correspondences ([`crate::frame::matching`]).
//! - **Wrong objects.** A located object far from where all the others put it
//!   is searched for again at the predicted position, and otherwise not found.

use super::target::{self, Failure, FarBy, TargetRun};
use super::{Config, FrameMode};
use crate::cloud::{MapSource, RigidMotion};
use crate::detect::{DetectParams, Detection, detect_map};
use crate::frame::MapToSurvey;
use crate::frame::hints::read_hints;
use crate::frame::matching::{Candidate, MatchError, MatchParams, match_frame};
use crate::frame::{GroundLevel, MapGround};
use crate::survey::Survey;
use crate::{Error, Point, Result};
use nalgebra::{Matrix2, Matrix3, Rotation3, Vector2, Vector3};
use rayon::prelude::*;

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

/// The targets' plumb lines as evidence of the map's vertical.
#[derive(Debug, Clone, PartialEq)]
pub struct Plumb {
    /// Angle of their mean from +z of the frame they were located in (the
    /// ground-levelled one, or the map's own) (degrees).
    pub tilt_deg: f64,
    /// Its standard error, from their scatter (degrees).
    pub se_deg: f64,
    /// Targets that gave one.
    pub targets: usize,
    /// Whether the frame was turned (see the plumb step in this module): to
    /// the plumb lines, or to them and the surveyed heights together.
    pub applied: bool,
    /// The surveyed heights' evidence, when five or more located targets
    /// have them.
    pub heights: Option<HeightsLean>,
    /// Standard error of the vertical the frame was turned to (degrees):
    /// the plumb lines', or every estimate's together.
    pub turned_se_deg: f64,
}

/// The map's lean as the surveyed heights show it: the located corners'
/// heights less the survey's, fitted as a plane over the site. A map leaning
/// θ raises a corner d metres off by d·tan θ, so over a site of hundreds of
/// metres centimetre heights give the lean to a few hundredths of a degree,
/// far better than a plumb line's plates do; a constant datum offset (an
/// ellipsoidal survey, a map starting at 0) falls into the plane's height.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightsLean {
    /// Angle of the lean (degrees).
    pub tilt_deg: f64,
    /// Its standard error (degrees; of the angle, both directions together).
    pub se_deg: f64,
    /// Targets fitted (after setting aside heights off the plane).
    pub targets: usize,
    /// RMS of the heights about the plane (m).
    pub rms_m: f64,
    /// Whether it agreed with the plumb lines within their uncertainties
    /// (else it was not used, and a warning says so).
    pub agrees: bool,
    /// How far apart the two verticals are (degrees): leans of one size in
    /// two directions may differ by more than either.
    pub apart_deg: f64,
    /// Whether it entered the vertical: it agreed, and the frame was turned
    /// by the ground or its plumb lines lean beyond 2 standard errors.
    pub used: bool,
}

/// One estimate of the true vertical as seen in the frame the targets were
/// located in: its horizontal components (small angles, radians) with their
/// covariance.
#[derive(Debug, Clone, Copy)]
struct Lean {
    t: Vector2<f64>,
    cov: Matrix2<f64>,
}

impl Lean {
    /// The inverse-covariance mean of several estimates.
    fn combine(all: &[Lean]) -> Lean {
        let mut info = Matrix2::zeros();
        let mut sum = Vector2::zeros();
        for l in all {
            let w = l.cov.try_inverse().unwrap_or_else(Matrix2::zeros);
            info += w;
            sum += w * l.t;
        }
        let cov = info
            .try_inverse()
            .unwrap_or_else(|| Matrix2::identity() * 1.0);
        Lean { t: cov * sum, cov }
    }

    /// Whether two estimates differ by more than their uncertainties allow
    /// (χ² of 2 degrees of freedom beyond its 99.9 % point).
    fn disagrees(&self, o: &Lean) -> bool {
        let d = self.t - o.t;
        (self.cov + o.cov)
            .try_inverse()
            .is_some_and(|w| (d.transpose() * w * d)[0] > 13.8)
    }

    /// Standard error of the lean's angle, both directions together (the
    /// RMS of the angle between the estimate and the truth: √ of the
    /// covariance's trace), in degrees, as the plumb lines' scatter gives it.
    fn se_deg(&self) -> f64 {
        self.cov.trace().max(0.0).sqrt().to_degrees()
    }

    /// The vertical as a unit vector.
    fn up(&self) -> Vector3<f64> {
        // Held within 30° (a lean beyond 20° is refused anyway).
        let t = self.t * (0.5 / self.t.norm()).min(1.0);
        Vector3::new(t.x, t.y, (1.0 - t.norm_squared()).sqrt())
    }
}

/// Corner heights are known to a few centimetres at best, whatever their
/// scatter about the plane says with few targets (m): the plates' mean
/// height against the surveyed point on them moves with how the scan lines
/// fall on the plate (located minus true corner heights scattered 12–24 mm
/// over four 8-target scenes), and the survey's own height error adds to it.
const HEIGHT_SIGMA_FLOOR_M: f64 = 0.03;

/// The surveyed heights' lean (see [`HeightsLean`]): a least-squares plane
/// through (corner z − survey z) over the corners' horizontal positions,
/// setting aside, while more than five remain, up to two heights more than
/// 3 robust σ (and 5 cm) off it (a target whose lower plates were hidden, a
/// wrong object). Five targets or more, spread over both horizontal
/// directions enough to give a finite covariance.
fn heights_lean(found: &[TargetRun], survey: &Survey) -> Option<(Lean, HeightsLean)> {
    let pts: Vec<(Vector2<f64>, f64)> = found
        .iter()
        .zip(&survey.targets)
        .filter(|(_, t)| t.has_z)
        .filter_map(|(r, t)| {
            r.corner()
                .map(|c| (Vector2::new(c.x, c.y), c.z - t.reference().z))
        })
        .collect();
    lean_of_heights(pts)
}

/// [`heights_lean`] of (horizontal position, located less surveyed height).
fn lean_of_heights(mut pts: Vec<(Vector2<f64>, f64)>) -> Option<(Lean, HeightsLean)> {
    let mut dropped = 0;
    loop {
        let n = pts.len();
        if n < 5 {
            return None;
        }
        let mean = pts.iter().fold(Vector2::zeros(), |s, p| s + p.0) / n as f64;
        let mut ata = Matrix3::zeros();
        let mut atb = Vector3::zeros();
        for (xy, dz) in &pts {
            let a = Vector3::new(1.0, xy.x - mean.x, xy.y - mean.y);
            ata += a * a.transpose();
            atb += a * *dz;
        }
        let inv = ata.try_inverse()?;
        let x = inv * atb;
        let res: Vec<f64> = pts
            .iter()
            .map(|(xy, dz)| dz - (x[0] + x[1] * (xy.x - mean.x) + x[2] * (xy.y - mean.y)))
            .collect();
        let mut abs: Vec<f64> = res.iter().map(|r| r.abs()).collect();
        abs.sort_unstable_by(f64::total_cmp);
        let robust = 1.4826 * abs[n / 2];
        let (worst, &far) = res
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
        if dropped < 2 && n > 5 && far.abs() > (3.0 * robust).max(0.05) {
            pts.remove(worst);
            dropped += 1;
            continue;
        }
        let sse: f64 = res.iter().map(|r| r * r).sum();
        // σ from n − 3 degrees of freedom is itself uncertain: an estimated
        // σ is widened so its normal 95 % bounds are Student's (the floor,
        // a known bound, is not).
        let fitted = (sse / (n - 3) as f64).sqrt();
        let var = if fitted > HEIGHT_SIGMA_FLOOR_M {
            fitted * fitted * (crate::accuracy::t975(n - 3) / 1.959_964).powi(2)
        } else {
            HEIGHT_SIGMA_FLOOR_M * HEIGHT_SIGMA_FLOOR_M
        };
        let cov_g = inv.fixed_view::<2, 2>(1, 1).into_owned() * var;
        // Heights rise along the slope g in the located frame: the true
        // vertical u, seen from it, leans the other way, g = -u_xy / u_z, so
        // u_xy = -g / √(1 + |g|²) (the plumb lines' terms), its covariance
        // carried through that function's Jacobian.
        let g = Vector2::new(x[1], x[2]);
        let k = 1.0 + g.norm_squared();
        let jac = (Matrix2::identity() - g * g.transpose() / k) / k.sqrt();
        let lean = Lean {
            t: -g / k.sqrt(),
            cov: jac * cov_g * jac.transpose(),
        };
        let tilt_deg = g.norm().atan().to_degrees();
        let info = HeightsLean {
            tilt_deg,
            se_deg: lean.se_deg(),
            targets: n,
            rms_m: (sse / n as f64).sqrt(),
            agrees: true,
            apart_deg: 0.0,
            used: false,
        };
        return Some((lean, info));
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
    let found = detect_map(
        source,
        all.as_ref().unwrap_or(ground),
        motion,
        &DetectParams::default(),
        &cfg.tight,
        |b| progress(b, total),
    )?;
    reads.extend(found.reads.iter().cloned());
    let cands: Vec<Candidate> = found
        .detections
        .iter()
        .map(|d| Candidate { at: d.corner })
        .collect();
    let sur: Vec<Point> = survey.targets.iter().map(|t| t.reference()).collect();
    let params = MatchParams {
        tol: cfg.frame.match_tolerance,
        min_matches: 3,
    };
    let m = match_frame(&cands, &sur, survey.has_z(), &params);
    // A survey with x and y exchanged is the map's mirror image: no rigid
    // motion fits it, though a few targets may happen to fit one (an
    // isosceles three of them does). Its mirror fitting more is the mistake.
    let mirrored: Vec<Point> = sur.iter().map(|p| Point::new(p.y, p.x, p.z)).collect();
    if let Ok(mm) = match_frame(&cands, &mirrored, survey.has_z(), &params) {
        // As given: its matches, or the most any transform found when none
        // was chosen (too few, or two about equal).
        let given = match &m {
            Ok(m) => m.matches.len(),
            Err(MatchError::TooFew { best, .. }) => *best,
            Err(MatchError::Ambiguous { a, .. }) => *a,
        };
        if mm.matches.len() > given {
            return Err(NoFrame::Failed(Error::Input(format!(
                "the survey's x and y look swapped: with them exchanged, {} of its {} targets fall on targets detected in the map (rms {:.0} mm), against {given} as given. Check the order of the survey's columns (id,x,y: x east, y north) and run again",
                mm.matches.len(),
                sur.len(),
                mm.rms * 1e3
            ))));
        }
    }
    // A survey in another unit than the map (feet, millimetres) is the map's
    // layout scaled: no rigid motion fits it. Scaled back, it fitting is
    // the mistake (about the survey's centroid: UTM-sized coordinates stay
    // small).
    if m.is_err() && sur.len() >= 3 {
        let n = sur.len() as f64;
        let c = sur
            .iter()
            .fold(nalgebra::Vector3::zeros(), |a, p| a + p.coords)
            / n;
        let given = match &m {
            Err(MatchError::TooFew { best, .. }) => *best,
            Err(MatchError::Ambiguous { a, .. }) => *a,
            Ok(_) => 0,
        };
        for (factor, what) in UNITS {
            let scaled: Vec<Point> = sur
                .iter()
                .map(|p| Point::from(c + (p.coords - c) * factor))
                .collect();
            if let Ok(sm) = match_frame(&cands, &scaled, survey.has_z(), &params)
                && sm.matches.len() > given
            {
                return Err(NoFrame::Failed(Error::Input(format!(
                    "the survey looks {what}: scaled by {factor}, {} of its {} targets fall on targets detected in the map (rms {:.0} mm), against {given} as given. mapgauge reads both files in metres: convert the survey, or the map (`mapgauge convert --scale`), and run again",
                    sm.matches.len(),
                    sur.len(),
                    sm.rms * 1e3
                ))));
            }
        }
    }
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

/// The targets' common plumb line, and the rotation that makes it +z when it
/// leans. In a frame already turned (`turned`: the ground's vertical, which
/// carries the site's slope, or an earlier plumb turn) the plumb lines are the
/// better vertical whatever their scatter (unbiased, where the ground is not),
/// so any lean is turned away. A map read as it is is turned only beyond three
/// standard errors and half a degree: a level map must not be turned by the
/// plumb lines' noise (a 0.2° turn moves targets 2 m apart in height by 7 mm).
pub(super) fn plumb(
    found: &[TargetRun],
    survey: &Survey,
    turned: bool,
) -> Option<(Plumb, Option<Rotation3<f64>>)> {
    // Each line weighs as its weaker plate's points: a plate's normal is
    // known to about 1/√(points), so a target seen with 50 returns counts
    // far less than one seen with 500.
    let axes: Vec<(Vector3<f64>, f64)> = found
        .iter()
        .filter_map(|r| {
            r.outcome
                .as_ref()
                .ok()
                .and_then(|f| plain_axis(&r.tight, f))
        })
        .collect();
    let n = axes.len();
    if n < 3 {
        return None;
    }
    let sw: f64 = axes.iter().map(|a| a.1).sum();
    let sw2: f64 = axes.iter().map(|a| a.1 * a.1).sum();
    let mean = axes
        .iter()
        .fold(Vector3::zeros(), |s, (a, w)| s + a * *w)
        .normalize();
    let tilt = mean.angle(&Vector3::z()).to_degrees();
    let var = axes
        .iter()
        .map(|(a, w)| w * a.angle(&mean).powi(2))
        .sum::<f64>()
        / sw
        * n as f64
        / (n - 1) as f64;
    let se = (var * sw2 / (sw * sw)).sqrt().to_degrees();
    // The estimates of the vertical, each with its covariance, combined by
    // inverse variance: the plumb lines (their standard error, both ways);
    // in a turned frame, the ground that turned it (the vertical is where
    // it put it, to within the site's slope: taken as 2°, ramps and roads
    // run steeper than 1°); and the surveyed heights, when they agree with
    // the plumb lines. Those disagreeing means the map's heights drift
    // (odometry's vertical drift bends a map without leaning it) or the
    // survey's heights are not the corners': they are set aside and a
    // warning says so.
    // `se` (like the ground's 2°) is of the angle, both directions
    // together: half its square in each.
    let sp = se.max(1e-6).to_radians();
    let plumb_lean = Lean {
        t: Vector2::new(mean.x, mean.y),
        cov: Matrix2::identity() * sp * sp / 2.0,
    };
    let mut leans = vec![plumb_lean];
    if turned {
        let g = GROUND_SIGMA_DEG.to_radians();
        leans.push(Lean {
            t: Vector2::zeros(),
            cov: Matrix2::identity() * g * g / 2.0,
        });
    }
    let heights = heights_lean(found, survey).map(|(lean, mut info)| {
        info.agrees = !lean.disagrees(&plumb_lean);
        info.apart_deg = lean.up().angle(&plumb_lean.up()).to_degrees();
        // In a map read as it is, the heights only refine a lean its plumb
        // lines show (see the bar below).
        info.used = info.agrees && (turned || tilt > 2.0 * se);
        if info.used {
            leans.push(lean);
        }
        info
    });
    let with_heights = heights.as_ref().is_some_and(|h| h.used);
    let lean = Lean::combine(&leans);
    let up = lean.up();
    let angle = up.angle(&Vector3::z()).to_degrees();
    let se_c = lean.se_deg();
    // A map read as it is turns only beyond three standard errors, and
    // beyond half a degree on plumb lines alone (their noise must not turn
    // a level map: a 0.2° turn moves targets 2 m apart in height by 7 mm),
    // a tenth of one with the surveyed heights. The heights only refine a
    // lean the map itself shows (its plumb lines beyond two standard
    // errors): heights alone cannot tell a lean from odometry's vertical
    // drift, which bends a map's heights and leaves it level where the
    // targets stand, and turning such a map would move its targets by
    // their heights times the drift's slope. Up to 20°: beyond, a few
    // targets agreeing is more likely a mistake.
    let bar = if turned {
        0.005
    } else if with_heights {
        (3.0 * se_c).max(0.1)
    } else {
        (3.0 * se_c).max(0.5)
    };
    let applied = angle > bar && tilt <= 20.0;
    let rot = applied
        .then(|| Rotation3::rotation_between(&up, &Vector3::z()))
        .flatten();
    Some((
        Plumb {
            tilt_deg: tilt,
            se_deg: se,
            targets: n,
            applied: rot.is_some(),
            heights,
            turned_se_deg: se_c,
        },
        rot,
    ))
}

/// Standard error (degrees) of the vertical a levelled frame was turned to:
/// every estimate's together when the targets turned it (the plumb step),
/// else the ground's alone (its error is the site's slope).
pub(crate) fn vertical_se_deg(plumb: Option<&Plumb>) -> f64 {
    match plumb {
        Some(p) if p.applied => p.turned_se_deg,
        _ => GROUND_SIGMA_DEG,
    }
}

/// A target's plumb line from plain least-squares planes through the points
/// near each located plate: the locator's own axis comes from a sample that
/// passed its verticality gate, which leans it towards the "up" it was given.
fn plain_axis(tight: &[Point], f: &target::Found) -> Option<(Vector3<f64>, f64)> {
    let c = f.located.corner;
    let q: Vec<Vector3<f64>> = tight.iter().map(|p| p - c).collect();
    let mut n = [
        Vector3::from(f.located.plates[0].normal),
        Vector3::from(f.located.plates[1].normal),
    ];
    let mut off = [0.0, 0.0];
    let mut weak = usize::MAX;
    for _ in 0..PLUMB_REFITS {
        weak = usize::MAX;
        for k in 0..2 {
            let idx: Vec<u32> = (0..q.len() as u32)
                .filter(|&i| (n[k].dot(&q[i as usize]) - off[k]).abs() < PLUMB_SLAB)
                .collect();
            if idx.len() < 20 {
                return None;
            }
            weak = weak.min(idx.len());
            let p = crate::geom::plane::fit(&q, &idx)?;
            n[k] = p.normal;
            off[k] = p.offset;
        }
    }
    let a = n[0].cross(&n[1]);
    let a = if a.z < 0.0 { -a } else { a };
    (a.norm() > 0.5).then(|| (a.normalize(), weak as f64))
}

/// Half-width of the slab a plumb line's plane is refitted to (m): two σ of
/// a survey-grade map's range noise. A slab as thin as the noise clips the
/// tails of the plate's points where the plane is off, and the refit stays
/// near the plane it started from: at 2 cm (before issue 30) four 400 m
/// scenes tilted 2.0° gave plumb lines of 1.48–1.60°; at 4 cm, 1.70–2.03°.
const PLUMB_SLAB: f64 = 0.04;

/// Refits of a plumb line's two planes.
const PLUMB_REFITS: usize = 4;

/// How far the ground's vertical may be from the true one: a site's general
/// slope (degrees).
pub(super) const GROUND_SIGMA_DEG: f64 = 2.0;

/// Turns every target's crops by `rot` about `origin` and locates the found
/// ones again with +z as their vertical.
pub(super) fn turn_targets(
    found: &mut [TargetRun],
    rot: &Rotation3<f64>,
    origin: Point,
    cfg: &Config,
) {
    let m = RigidMotion {
        origin,
        rotation: *rot,
    };
    found.par_iter_mut().for_each(|r| {
        let z = r.expected.z;
        r.expected = m.apply(&r.expected);
        for p in r.loose.iter_mut().chain(r.tight.iter_mut()) {
            *p = m.apply(p);
        }
        r.ground_normal = r.ground_normal.map(|n| rot * n);
        // What the crop saw stays drawn where its points are.
        if let Err(Failure::Tight(crate::crop::TightError::NoTargetShape {
            seen: Some(s), ..
        })) = &mut r.outcome
        {
            let turn = |xy: &mut [f64; 2]| {
                let p = m.apply(&Point::new(xy[0], xy[1], z));
                *xy = [p.x, p.y];
            };
            turn(&mut s.at);
            if let Some(f) = s.faces.as_mut() {
                f.iter_mut().for_each(turn);
            }
        }
        if let Ok(f) = &r.outcome {
            let ups = [Vector3::z(), rot * f.up];
            r.outcome = target::locate_with(&r.tight, &ups, cfg).map_err(Failure::Locate);
        }
    });
}

/// A map's distance between two targets may disagree with the survey's by
/// at most this much (m) plus [`LAYOUT_REL`] of the distance: LiDAR odometry
/// without loop closure drifts 0.5–2 % (KITTI's worst), a projection's grid
/// scale is within 0.5 %, a target's corner is known to centimetres; 5 %
/// leaves room for a map bent by a failed loop closure (a 3.5° heading error
/// at a turn is 3.5 % over the diagonal), which must be measured, not set
/// aside. Metres over tens of metres (a rock 4 m from a surveyed spot 30 m
/// from the next, a survey in feet) are a wrong object, position, id or unit.
const LAYOUT_ABS_M: f64 = 0.3;
/// See [`LAYOUT_ABS_M`].
const LAYOUT_REL: f64 = 0.05;

/// Each pair of located targets: (index a, index b, |map − survey distance|,
/// survey distance, map distance), horizontal unless a 3D score with both
/// heights surveyed.
fn layout_pairs(
    at: &[(usize, Point)],
    survey: &Survey,
    d3: bool,
) -> Vec<(usize, usize, f64, f64, f64)> {
    let mut out = Vec::new();
    for (k, &(i, a)) in at.iter().enumerate() {
        for &(j, b) in &at[k + 1..] {
            let (si, sj) = (&survey.targets[i], &survey.targets[j]);
            // Differences first: survey coordinates may be UTM-sized.
            let (ds, dm) = (si.reference() - sj.reference(), a - b);
            let both_z = d3 && si.has_z && sj.has_z;
            let len = |v: nalgebra::Vector3<f64>| {
                if both_z { v.norm() } else { v.xy().norm() }
            };
            let (s, m) = (len(ds), len(dm));
            out.push((i, j, (m - s).abs(), s, m));
        }
    }
    out
}

/// Where each target was located: (index, corner), with the objects
/// [`off_layout`] set aside.
pub(super) fn placed(found: &[TargetRun]) -> Vec<(usize, Point)> {
    found
        .iter()
        .enumerate()
        .filter_map(|(i, r)| match &r.outcome {
            Err(Failure::OffLayout { at, .. }) => Some((i, *at)),
            _ => r.corner().map(|c| (i, c)),
        })
        .collect()
}

/// The median ratio of map distances to the survey's between the objects
/// `at` (1 for a map in the survey's unit and scale), over pairs 1 m or more
/// apart.
pub(super) fn distance_ratio(at: &[(usize, Point)], survey: &Survey) -> Option<f64> {
    let mut r: Vec<f64> = layout_pairs(at, survey, false)
        .into_iter()
        .filter(|p| p.3 >= 1.0)
        .map(|p| p.4 / p.3)
        .collect();
    if r.is_empty() {
        return None;
    }
    r.sort_by(f64::total_cmp);
    Some(r[r.len() / 2])
}

/// Located targets whose distances to the others disagree with the survey's
/// by more than a map's error ([`LAYOUT_ABS_M`], [`LAYOUT_REL`]) become
/// [`Failure::OffLayout`], whatever the frame mode and however few were
/// located (`far_from_others` compares with the targets' median misfit,
/// which needs four, and sees nothing when every one is off). Greedy: the
/// target in the most implausible pairs goes first (ties: the larger summed
/// misfit beyond the limit; a tie on that too, e.g. the two ends of the one
/// bad pair, sends both), until no implausible pair is left. The targets
/// left are kept only when they are more than were set aside (`alone`);
/// else every located target is set aside. Returns how many were.
pub(super) fn off_layout(
    found: &mut [TargetRun],
    survey: &Survey,
    opts: &crate::accuracy::ScoreOptions,
) -> usize {
    let d3 = opts.dim == crate::accuracy::Dim::D3;
    let at: Vec<(usize, Point)> = found
        .iter()
        .enumerate()
        .filter_map(|(i, r)| r.corner().map(|c| (i, c)))
        .collect();
    let bad: Vec<(usize, usize, f64, f64)> = layout_pairs(&at, survey, d3)
        .into_iter()
        .filter(|&(_, _, miss, s, _)| miss > LAYOUT_ABS_M + LAYOUT_REL * s)
        .map(|(i, j, miss, s, _)| (i, j, miss, s))
        .collect();
    let mut out: Vec<usize> = Vec::new();
    loop {
        // Per target still in: (bad pairs, summed misfit beyond the limit).
        let mut score: Vec<(usize, usize, f64)> = Vec::new();
        for p in bad
            .iter()
            .filter(|p| !out.contains(&p.0) && !out.contains(&p.1))
        {
            let beyond = p.2 - (LAYOUT_ABS_M + LAYOUT_REL * p.3);
            for i in [p.0, p.1] {
                match score.iter_mut().find(|c| c.0 == i) {
                    Some(c) => {
                        c.1 += 1;
                        c.2 += beyond;
                    }
                    None => score.push((i, 1, beyond)),
                }
            }
        }
        let Some(top) = score
            .iter()
            .map(|c| (c.1, c.2))
            .max_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)))
        else {
            break;
        };
        // Every target with the top score (one, unless the tie is exact).
        out.extend(
            score
                .iter()
                .filter(|c| c.1 == top.0 && c.2 == top.1)
                .map(|c| c.0),
        );
    }
    // The targets left are trusted only as a majority of those located: two
    // that agree where five were set aside (a survey moved 20 m lands some
    // places on other targets) are as likely a coincidence, and then none is
    // scored.
    let agree = at.len() - out.len();
    let alone = agree >= 2 && agree > out.len();
    if !out.is_empty() && !alone {
        out = at.iter().map(|a| a.0).collect();
    }
    for &i in &out {
        let Some(at) = found[i].corner() else {
            continue;
        };
        let (misfit, distance) = bad
            .iter()
            .filter(|p| p.0 == i || p.1 == i)
            .map(|p| (p.2, p.3))
            .fold((0.0, 0.0), |a, b| if b.0 > a.0 { b } else { a });
        found[i].outcome = Err(Failure::OffLayout {
            at,
            misfit,
            distance,
            alone,
        });
    }
    out.len()
}

/// Found targets far from where the others place them: (index, error, the
/// targets' median of it, which error). Two measures, each > 5 × the median
/// and > 0.3 m: the error under a fit without the target, and (with 4 or
/// more found) the median misfit of its distances to the others against the
/// survey's. The second needs no alignment, so a wrong object that pulls
/// every fit it enters (4 targets, each 1-2 m off) is still singled out.
pub(super) fn far_from_others(
    found: &[TargetRun],
    survey: &Survey,
    opts: &crate::accuracy::ScoreOptions,
) -> Vec<(usize, f64, f64, FarBy)> {
    let mut far = Vec::new();
    let corners: Vec<(usize, Point)> = found
        .iter()
        .enumerate()
        .filter_map(|(i, r)| r.corner().map(|c| (i, c)))
        .collect();
    // Heights enter only a 3D score: a 2D run leaves vertical drift unscored.
    let d3 = opts.dim == crate::accuracy::Dim::D3;
    let surveyed: Vec<(Point, bool)> = corners
        .iter()
        .map(|&(i, _)| {
            let t = &survey.targets[i];
            (t.reference(), d3 && t.has_z)
        })
        .collect();
    let map: Vec<Point> = corners.iter().map(|c| c.1).collect();
    for (k, e, median) in misfit_by_distances(&map, &surveyed) {
        far.push((corners[k].0, e, median, FarBy::Distances));
    }
    if let Ok(acc) = crate::accuracy::score(survey, &super::estimates(found), opts) {
        let errs: Vec<(usize, f64)> = acc
            .targets
            .iter()
            .enumerate()
            .filter_map(|(i, t)| t.loo_error.map(|e| (i, e)))
            .collect();
        if errs.len() >= 4 {
            let mut v: Vec<f64> = errs.iter().map(|e| e.1).collect();
            v.sort_by(f64::total_cmp);
            let median = v[v.len() / 2];
            for (i, e) in errs {
                if e > 5.0 * median && e > 0.3 && !far.iter().any(|f| f.0 == i) {
                    far.push((i, e, median, FarBy::LeaveOneOut));
                }
            }
        }
    }
    far.sort_by_key(|f| f.0);
    far
}

/// The position (in the map) whose distances to the others disagree with
/// the survey's: (index, its median misfit, the others' median misfit), when
/// its misfit is > 5 × the others' and > 0.3 m. Each position is tried as the
/// suspect: the common scale (a projection's grid scale, a map's scale drift,
/// within ±0.5 %) is the median ratio over the pairs without it, and the
/// suspect is the one whose removal leaves the others agreeing best (least
/// sum of squared pair misfits). A scale taken over every pair may be the
/// wrong object's own: with four targets, half the pairs are its. Once one
/// is singled out it is set aside and the rest are tried again, while 4
/// remain: the others' misfits are a lower median, so with two wrong among
/// six the first pass still sees the good pairs. Distances are 3D where both
/// flags say so, else horizontal. Needs 4 positions: with 3, a wrong one and
/// a right one share as many bad pairs.
fn misfit_by_distances(map: &[Point], survey: &[(Point, bool)]) -> Vec<(usize, f64, f64)> {
    let mut left: Vec<usize> = (0..map.len()).collect();
    let mut out = Vec::new();
    while left.len() >= 4 {
        let m: Vec<Point> = left.iter().map(|&i| map[i]).collect();
        let s: Vec<(Point, bool)> = left.iter().map(|&i| survey[i]).collect();
        let Some((k, own, others)) = one_by_distances(&m, &s) else {
            break;
        };
        out.push((left.remove(k), own, others));
    }
    out.sort_by_key(|f| f.0);
    out
}

/// One round of [`misfit_by_distances`]: the worst position, if it stands out.
fn one_by_distances(map: &[Point], survey: &[(Point, bool)]) -> Option<(usize, f64, f64)> {
    let n = map.len();
    if n < 4 {
        return None;
    }
    // Differences first, so UTM-sized coordinates are never squared.
    let dist = |a: &Point, b: &Point, z: bool| {
        let d = a - b;
        if z { d.norm() } else { d.xy().norm() }
    };
    let mut pairs = vec![vec![(0.0, 0.0); n]; n];
    for i in 0..n {
        for j in i + 1..n {
            let z = survey[i].1 && survey[j].1;
            let p = (
                dist(&map[i], &map[j], z),
                dist(&survey[i].0, &survey[j].0, z),
            );
            pairs[i][j] = p;
            pairs[j][i] = p;
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[(v.len() - 1) / 2]
    };
    // Suspect k: the scale and the misfits of the pairs without it; the
    // suspect whose pairs' squared misfits sum least leaves the others
    // agreeing best.
    let without = |k: usize| {
        let rest: Vec<(f64, f64)> = (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .filter(|&(i, j)| i != k && j != k)
            .map(|(i, j)| pairs[i][j])
            .collect();
        let ratios: Vec<f64> = rest
            .iter()
            .filter(|p| p.1 > 1.0)
            .map(|p| p.0 / p.1)
            .collect();
        let scale = if ratios.is_empty() {
            1.0
        } else {
            median(ratios).clamp(0.995, 1.005)
        };
        let res: Vec<f64> = rest.iter().map(|p| (p.0 - scale * p.1).abs()).collect();
        let score: f64 = res.iter().map(|r| r * r).sum();
        let own = median(
            (0..n)
                .filter(|&j| j != k)
                .map(|j| (pairs[k][j].0 - scale * pairs[k][j].1).abs())
                .collect(),
        );
        (score, median(res), own)
    };
    let (k, (_, others, own)) = (0..n)
        .map(|k| (k, without(k)))
        .min_by(|a, b| a.1.0.total_cmp(&b.1.0).then(a.0.cmp(&b.0)))
        .expect("n >= 4");
    (own > 5.0 * others && own > 0.3).then_some((k, own, others))
}

#[cfg(test)]
mod distance_tests {
    use super::misfit_by_distances;
    use crate::Point;

    /// Five targets over ~300 m; the map is the survey turned, moved and
    /// scaled by `scale`, with target `wrong` (if any) moved 1.5 m.
    fn scene(scale: f64, wrong: Option<usize>) -> (Vec<Point>, Vec<(Point, bool)>) {
        scene_of(&SURVEY[..5], scale, wrong)
    }

    const SURVEY: [(f64, f64, f64); 6] = [
        (352_000.0, 4_026_000.0, 50.0),
        (352_120.0, 4_026_030.0, 51.0),
        (352_200.0, 4_026_210.0, 49.5),
        (351_950.0, 4_026_280.0, 50.5),
        (352_060.0, 4_026_120.0, 50.2),
        (352_150.0, 4_026_330.0, 50.0),
    ];

    fn scene_of(
        s: &[(f64, f64, f64)],
        scale: f64,
        wrong: Option<usize>,
    ) -> (Vec<Point>, Vec<(Point, bool)>) {
        let (c, sn) = (1.1f64.cos(), 1.1f64.sin());
        let map = s
            .iter()
            .enumerate()
            .map(|(i, &(x, y, z))| {
                let (x, y) = (x - 352_000.0, y - 4_026_000.0);
                let mut p = Point::new(
                    scale * (c * x - sn * y) + 10.0,
                    scale * (sn * x + c * y) - 5.0,
                    z - 48.0,
                );
                if wrong == Some(i) {
                    p.x += 1.2;
                    p.y -= 0.9;
                }
                p
            })
            .collect();
        let survey = s
            .iter()
            .map(|&(x, y, z)| (Point::new(x, y, z), true))
            .collect();
        (map, survey)
    }

    #[test]
    fn a_wrong_object_is_singled_out_by_its_distances() {
        let (map, survey) = scene(1.0, Some(2));
        let far = misfit_by_distances(&map, &survey);
        assert_eq!(far.len(), 1, "{far:?}");
        assert_eq!(far[0].0, 2);
        assert!(far[0].1 > 0.5 && far[0].2 < 0.05, "{far:?}");
        // Four targets are enough; three are not.
        assert_eq!(misfit_by_distances(&map[1..], &survey[1..])[0].0, 1);
        assert!(misfit_by_distances(&map[2..], &survey[2..]).is_empty());
    }

    /// Layouts where a scale taken over every pair is the wrong object's own
    /// (found in review): the wrong one must be the one singled out.
    #[test]
    fn a_wrong_object_does_not_set_the_scale() {
        let check = |survey: &[(f64, f64)], wrong: usize, shift: (f64, f64)| {
            let s: Vec<(Point, bool)> = survey
                .iter()
                .map(|&(x, y)| (Point::new(x, y, 0.0), false))
                .collect();
            let mut m: Vec<Point> = s.iter().map(|p| p.0).collect();
            m[wrong].x += shift.0;
            m[wrong].y += shift.1;
            let far = misfit_by_distances(&m, &s);
            assert_eq!(far.len(), 1, "{far:?}");
            assert_eq!(far[0].0, wrong, "{far:?}");
        };
        check(
            &[(314.8, 76.6), (320.9, 76.5), (32.6, 342.1), (344.5, 350.6)],
            2,
            (-1.87, -0.47),
        );
        check(
            &[(0.0, 0.0), (250.0, 0.0), (250.0, 250.0), (0.0, 250.0)],
            2,
            (1.0, 1.0),
        );
    }

    /// Two wrong objects among six (the hole left by one suspect per run).
    #[test]
    fn two_wrong_objects_among_six_are_both_singled_out() {
        let (mut map, survey) = scene_of(&SURVEY, 1.0, Some(1));
        map[4].x -= 1.8;
        let far = misfit_by_distances(&map, &survey);
        let which: Vec<usize> = far.iter().map(|f| f.0).collect();
        assert_eq!(which, vec![1, 4], "{far:?}");
        // One wrong among six: only that one.
        let (map, survey) = scene_of(&SURVEY, 1.0, Some(3));
        let far = misfit_by_distances(&map, &survey);
        assert_eq!(
            far.iter().map(|f| f.0).collect::<Vec<_>>(),
            vec![3],
            "{far:?}"
        );
    }

    #[test]
    fn a_right_map_or_a_scaled_one_condemns_nothing() {
        for scale in [1.0, 0.9996, 1.003] {
            let (map, survey) = scene(scale, None);
            assert!(misfit_by_distances(&map, &survey).is_empty(), "{scale}");
        }
    }
}

#[cfg(test)]
mod lean_tests {
    use super::{Lean, lean_of_heights};
    use nalgebra::{Matrix2, Vector2};
    use rand::{Rng, SeedableRng};

    /// Heights of corners on a map leaning 2° towards 30°, with a datum
    /// offset, 2 cm noise and one target 0.3 m off (its lower plates hidden):
    /// the lean comes back within its stated uncertainty, the bad height set
    /// aside; plumb lines leaning otherwise by far are told apart.
    #[test]
    fn surveyed_heights_give_the_lean_and_disagreeing_plumb_lines_are_told() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let g = Vector2::new(30f64.to_radians().cos(), 30f64.to_radians().sin())
            * 2f64.to_radians().tan();
        let mut pts: Vec<(Vector2<f64>, f64)> = (0..8)
            .map(|i| {
                let xy = Vector2::new(55.0 * i as f64, if i % 2 == 0 { 12.0 } else { -12.0 });
                let noise: f64 = rng.sample(rand_distr::StandardNormal);
                (xy, 47.3 + g.dot(&xy) + 0.02 * noise)
            })
            .collect();
        pts[3].1 += 0.3;
        let (lean, info) = lean_of_heights(pts).expect("a lean");
        assert_eq!(info.targets, 7, "{info:?}");
        let err = (lean.t + g).norm().to_degrees();
        assert!((info.tilt_deg - 2.0).abs() < 0.1, "{info:?}");
        assert!(err < 2.5 * info.se_deg, "{err} vs {info:?}");
        let plumb = |deg: f64| Lean {
            t: -g.normalize() * deg.to_radians(),
            cov: Matrix2::identity() * 0.2f64.to_radians().powi(2),
        };
        assert!(!lean.disagrees(&plumb(1.9)));
        assert!(lean.disagrees(&plumb(0.5)));
        // Combined, the precise heights dominate.
        let both = Lean::combine(&[lean, plumb(1.9)]);
        assert!((both.t - lean.t).norm().to_degrees() < 0.01);
        assert!(both.se_deg() <= info.se_deg + 1e-12);
    }
}
