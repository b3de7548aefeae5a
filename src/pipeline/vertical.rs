//! Which way is up, from the targets: their plumb lines (they are built
//! vertical) and their surveyed heights refine the ground's vertical.

use super::target::{self, Failure, TargetRun};
use super::{Config, Warning};
use crate::Point;
use crate::cloud::{MapSource, RigidMotion};
use crate::survey::Survey;
use nalgebra::{Matrix2, Matrix3, Rotation3, Vector2, Vector3};
use rayon::prelude::*;

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
    let PlumbLines { mean, tilt, se, n } = plumb_lines(found)?;
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
    let bar = turn_bar(turned, with_heights, se_c);
    // Up to 20°: beyond, a few targets agreeing is more likely a mistake.
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

/// The targets' plumb lines averaged: their mean axis, its tilt from +z and
/// standard error (degrees), and how many targets gave one.
struct PlumbLines {
    mean: Vector3<f64>,
    tilt: f64,
    se: f64,
    n: usize,
}

/// The located targets' plumb lines weighed and averaged; `None` with
/// fewer than three.
fn plumb_lines(found: &[TargetRun]) -> Option<PlumbLines> {
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
    Some(PlumbLines { mean, tilt, se, n })
}

/// The lean beyond which a map is turned (degrees). A map read as it is
/// turns only beyond three standard errors, and beyond half a degree on
/// plumb lines alone (their noise must not turn a level map: a 0.2° turn
/// moves targets 2 m apart in height by 7 mm), a tenth of one with the
/// surveyed heights. The heights only refine a lean the map itself shows
/// (its plumb lines beyond two standard errors): heights alone cannot tell a
/// lean from odometry's vertical drift, which bends a map's heights and
/// leaves it level where the targets stand, and turning such a map would
/// move its targets by their heights times the drift's slope.
fn turn_bar(turned: bool, with_heights: bool, se_c: f64) -> f64 {
    if turned {
        0.005
    } else if with_heights {
        (3.0 * se_c).max(0.1)
    } else {
        (3.0 * se_c).max(0.5)
    }
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

/// The frame the map is first read in: levelled by its ground when that
/// leans, except when nothing may turn it (`no_turn`: `--align none`) or its
/// header declares a coordinate reference system (then z is vertical by
/// construction and the lean is the terrain's: said in a warning).
pub(super) fn first_levelling(
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
pub(super) fn refine_vertical(
    found: &mut [TargetRun],
    expected: &mut [Point],
    motion: &mut RigidMotion,
    survey: &Survey,
    no_turn: bool,
    cfg: &Config,
    warnings: &mut Vec<Warning>,
) -> Option<Plumb> {
    // The targets' plumb lines, and their surveyed heights when five or
    // more have them, refine the vertical, once: each line is a plain plane
    // fit of the target's own points and each height the located corner's,
    // which turn with the frame, so a second look would see the same.
    let turned = !motion.is_identity();
    let plumb = plumb(found, survey, turned)
        .filter(|_| !no_turn)
        .map(|(p, rot)| {
            if let Some(rot) = rot {
                turn_targets(found, &rot, motion.origin, cfg);
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
        let se_deg = vertical_se_deg(plumb.as_ref());
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

/// The "ups" tried after the crop's own: the map's own +z and the ground's
/// map-wide vertical, in the frame `motion` reads the map into.
pub(super) fn more_ups(
    motion: &RigidMotion,
    ground_up: Option<nalgebra::Vector3<f64>>,
) -> Vec<nalgebra::Vector3<f64>> {
    let mut v = vec![motion.rotation * nalgebra::Vector3::z()];
    if let Some(g) = ground_up {
        v.push(motion.rotation * g);
    }
    v
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
