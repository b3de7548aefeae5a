//! Which way is up, from the surveyed heights: a map leaning θ raises a
//! corner d metres off by d·tan θ, so the located corners' heights less the
//! survey's, fitted as a plane, give the lean; and how independent estimates
//! of the vertical (plumb lines, ground, heights) combine.

use super::target::TargetRun;
use crate::survey::Survey;
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

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
pub(super) struct Lean {
    pub(super) t: Vector2<f64>,
    pub(super) cov: Matrix2<f64>,
}

impl Lean {
    /// The inverse-covariance mean of several estimates.
    pub(super) fn combine(all: &[Lean]) -> Lean {
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
    pub(super) fn disagrees(&self, o: &Lean) -> bool {
        let d = self.t - o.t;
        (self.cov + o.cov)
            .try_inverse()
            .is_some_and(|w| (d.transpose() * w * d)[0] > 13.8)
    }

    /// Standard error of the lean's angle, both directions together (the
    /// RMS of the angle between the estimate and the truth: √ of the
    /// covariance's trace), in degrees, as the plumb lines' scatter gives it.
    pub(super) fn se_deg(&self) -> f64 {
        self.cov.trace().max(0.0).sqrt().to_degrees()
    }

    /// The vertical as a unit vector.
    pub(super) fn up(&self) -> Vector3<f64> {
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
pub(super) fn heights_lean(found: &[TargetRun], survey: &Survey) -> Option<(Lean, HeightsLean)> {
    let pts: Vec<(Vector2<f64>, f64)> = found
        .iter()
        .zip(&survey.targets)
        .filter(|(_, t)| t.has_z)
        .filter_map(|(r, t)| {
            // The heights scored, not the locator's mean heights.
            r.placed_corner()
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
