//! 95 % intervals on the headline numbers (E_abs, E_rel, RMSE_H), of two kinds
//! (definitions in `docs/uncertainty.md`):
//!
//! - **measurement**: how much the number moves when each located corner is
//!   redrawn within its own covariance (Monte Carlo, the alignment refitted on
//!   every draw) — the uncertainty the localisation itself leaves;
//! - **targets**: how much it moves when another set of targets like these had
//!   been surveyed (bootstrap over targets, the alignment refitted on every
//!   resample) — with 5 targets, usually the larger one.
//!
//! Both are percentile intervals (2.5 % and 97.5 % quantiles of the redrawn
//! statistic), from fixed seeds and run sequentially: the same input gives the
//! same bytes on any machine and thread count.

use super::Dim;
use super::stats::{dist, relative_errors};
use crate::Point;
use crate::align::{self, AlignMethod};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rand_pcg::Pcg64Mcg;

/// Monte Carlo draws of the measurement interval.
pub(crate) const MEASUREMENT_DRAWS: usize = 2000;
/// Bootstrap resamples of the targets interval.
pub(crate) const BOOTSTRAP_RESAMPLES: usize = 2000;
/// Seed of both (fixed: intervals are part of the deterministic output).
pub const SEED: u64 = 0x6d61_7067_6175_6765;
/// Fewest scored targets for any interval: with 3 or fewer a bootstrap has
/// only a handful of distinct resamples and says nothing.
pub const MIN_TARGETS: usize = 4;

/// A 95 % interval [lo, hi] (m).
pub(crate) type Interval = [f64; 2];

/// The two intervals of one headline number; `None` when not computed (too
/// few targets, no covariances, or the number is not defined on resamples).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ci95 {
    /// From the per-target covariances (Monte Carlo).
    pub measurement: Option<Interval>,
    /// From the choice of targets (bootstrap).
    pub targets: Option<Interval>,
}

/// Intervals of E_abs, E_rel and RMSE_H.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Intervals {
    /// Mean absolute error.
    pub e_abs: Ci95,
    /// Mean relative (pair) error.
    pub e_rel: Ci95,
    /// ASPRS RMSE_H (on all scored targets; `None` when ASPRS used check targets).
    pub rmse_h: Ci95,
}

/// What the intervals are computed from: the scored targets in order.
pub struct Inputs<'a> {
    pub(crate) method: AlignMethod,
    pub(crate) dim: Dim,
    pub(crate) ids: &'a [String],
    pub(crate) map: &'a [Point],
    pub(crate) survey: &'a [Point],
    /// Per-target covariance (map frame), all or nothing.
    pub(crate) covariances: Option<Vec<Matrix3<f64>>>,
    /// A levelled frame's vertical: one tilt shared by every target per draw.
    pub(crate) vertical: Option<super::Vertical>,
    /// Survey horizontal σ folded into RMSE_H.
    pub(crate) survey_sigma_h: f64,
    /// Whether RMSE_H intervals apply (ASPRS on all targets, not check targets).
    pub(crate) rmse_h: bool,
}

/// The three statistics of one (possibly redrawn) set of targets.
fn headline(inp: &Inputs, map: &[Point], survey: &[Point], ids: &[String]) -> Option<[f64; 3]> {
    let al = align::fit(inp.method, map, survey).ok()?;
    let n = map.len() as f64;
    let mut abs = 0.0;
    let mut h2 = 0.0;
    for (m, s) in map.iter().zip(survey) {
        let a = al.apply(m);
        abs += dist(&a, s, inp.dim);
        h2 += (a - s).xy().norm_squared();
    }
    let pairs = relative_errors(ids, map, survey, inp.dim);
    // Pairs of a resampled target with itself carry no information.
    let rel: Vec<f64> = pairs
        .iter()
        .filter(|p| p.a != p.b)
        .map(|p| p.error)
        .collect();
    if rel.is_empty() {
        return None;
    }
    let e_rel = rel.iter().sum::<f64>() / rel.len() as f64;
    let rmse_h = (h2 / n + inp.survey_sigma_h.powi(2)).sqrt();
    let v = [abs / n, e_rel, rmse_h];
    v.iter().all(|x| x.is_finite()).then_some(v)
}

/// The 2.5 % and 97.5 % quantiles (linear interpolation between order statistics).
pub(crate) fn percentile_interval(mut v: Vec<f64>) -> Option<Interval> {
    if v.len() < 20 {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| {
        let x = p * (v.len() - 1) as f64;
        let (i, f) = (x.floor() as usize, x.fract());
        let j = (i + 1).min(v.len() - 1);
        v[i] + (v[j] - v[i]) * f
    };
    Some([q(0.025), q(0.975)])
}

/// A matrix square root L (L Lᵀ = C) of a covariance, negative eigenvalues
/// (rounding) clamped to zero.
fn sqrt_psd(c: &Matrix3<f64>) -> Matrix3<f64> {
    let eig = SymmetricEigen::new((c + c.transpose()) / 2.0);
    let mut l = eig.eigenvectors;
    for j in 0..3 {
        let s = eig.eigenvalues[j].max(0.0).sqrt();
        for i in 0..3 {
            l[(i, j)] *= s;
        }
    }
    l
}

/// Intervals of the three statistics, one per column.
fn intervals_of(draws: Vec<[f64; 3]>) -> [Option<Interval>; 3] {
    [0, 1, 2].map(|k| percentile_interval(draws.iter().map(|d| d[k]).collect()))
}

/// Both kinds of intervals; all `None` with fewer than [`MIN_TARGETS`].
pub(crate) fn intervals(inp: &Inputs) -> Intervals {
    let n = inp.map.len();
    if n < MIN_TARGETS {
        return Intervals::default();
    }
    let measurement = inp.covariances.as_ref().map(|covs| {
        let roots: Vec<Matrix3<f64>> = covs.iter().map(sqrt_psd).collect();
        let mut rng = Pcg64Mcg::seed_from_u64(SEED);
        let mut draws = Vec::with_capacity(MEASUREMENT_DRAWS);
        let mut moved = inp.map.to_vec();
        for _ in 0..MEASUREMENT_DRAWS {
            for (k, p) in moved.iter_mut().enumerate() {
                let z = Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
                *p = inp.map[k] + roots[k] * z;
            }
            // Drawn after the targets', so a level map's draws are as before.
            if let Some(v) = inp.vertical {
                let mut d = || v.se_rad * rng.sample::<f64, _>(StandardNormal);
                let tilt = nalgebra::Rotation3::from_scaled_axis(Vector3::new(d(), d(), 0.0));
                for p in moved.iter_mut() {
                    *p = v.origin + tilt * (*p - v.origin);
                }
            }
            if let Some(v) = headline(inp, &moved, inp.survey, inp.ids) {
                draws.push(v);
            }
        }
        intervals_of(draws)
    });
    let targets = {
        let mut rng = Pcg64Mcg::seed_from_u64(SEED ^ 0xb007);
        let need = inp.method.min_points().max(2);
        let mut draws = Vec::with_capacity(BOOTSTRAP_RESAMPLES);
        let (mut m, mut s, mut ids) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..BOOTSTRAP_RESAMPLES {
            let pick: Vec<usize> = (0..n).map(|_| rng.random_range(0..n)).collect();
            let mut distinct = pick.clone();
            distinct.sort_unstable();
            distinct.dedup();
            if distinct.len() < need {
                continue;
            }
            m.clear();
            s.clear();
            ids.clear();
            for &k in &pick {
                m.push(inp.map[k]);
                s.push(inp.survey[k]);
                ids.push(inp.ids[k].clone());
            }
            if let Some(v) = headline(inp, &m, &s, &ids) {
                draws.push(v);
            }
        }
        intervals_of(draws)
    };
    let pick = |k: usize, on: bool| Ci95 {
        measurement: if on {
            measurement.and_then(|m| m[k])
        } else {
            None
        },
        targets: if on { targets[k] } else { None },
    };
    Intervals {
        e_abs: pick(0, true),
        e_rel: pick(1, true),
        rmse_h: pick(2, inp.rmse_h),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ids, map points, survey points and covariances of a test scene.
    type Scene = (
        Vec<String>,
        Vec<Point>,
        Vec<Point>,
        Option<Vec<Matrix3<f64>>>,
    );

    fn inputs(n: usize, noise: f64, covs: bool) -> Scene {
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        let ids: Vec<String> = (0..n).map(|i| format!("t{i}")).collect();
        let survey: Vec<Point> = (0..n)
            .map(|i| {
                Point::new(
                    30.0 * (i as f64).cos() * i as f64,
                    25.0 * (i as f64).sin() * i as f64,
                    0.0,
                )
            })
            .collect();
        let map: Vec<Point> = survey
            .iter()
            .map(|p| {
                p + Vector3::new(
                    noise * rng.sample::<f64, _>(StandardNormal),
                    noise * rng.sample::<f64, _>(StandardNormal),
                    0.0,
                )
            })
            .collect();
        let c = covs.then(|| {
            vec![Matrix3::from_diagonal(&Vector3::new(noise * noise, noise * noise, 1e-4)); n]
        });
        (ids, map, survey, c)
    }

    fn run(n: usize, noise: f64) -> Intervals {
        let scene = inputs(n, noise, true);
        rigid2d(&scene, None)
    }

    /// The intervals of a rigid 2D fit in 2D on `scene`.
    fn rigid2d(
        (ids, map, survey, covariances): &Scene,
        vertical: Option<super::super::Vertical>,
    ) -> Intervals {
        intervals(&Inputs {
            method: AlignMethod::Rigid2d,
            dim: Dim::D2,
            ids,
            map,
            survey,
            covariances: covariances.clone(),
            vertical,
            survey_sigma_h: 0.0,
            rmse_h: true,
        })
    }

    #[test]
    fn intervals_bracket_plausible_values_and_are_deterministic() {
        let a = run(12, 0.02);
        assert_eq!(a, run(12, 0.02));
        for ci in [a.e_abs, a.e_rel, a.rmse_h] {
            for iv in [ci.measurement.unwrap(), ci.targets.unwrap()] {
                assert!(iv[0] < iv[1] && iv[0] > 0.0 && iv[1] < 0.1, "{iv:?}");
            }
        }
        // RMSE_H of 2 cm per axis noise is ~2.8 cm less the fit's dof: inside the targets interval.
        let t = a.rmse_h.targets.unwrap();
        assert!(t[0] < 0.028 && t[1] > 0.015, "{t:?}");
    }

    /// The levelled vertical's error is one tilt shared by every target of
    /// a draw: targets at one height above the origin move together (a
    /// shift the alignment takes up, pair distances kept), so the intervals
    /// stay as without it; at heights 10 m apart they move apart and the
    /// intervals widen. A tilt drawn per target would widen both.
    #[test]
    fn the_vertical_is_one_tilt_shared_by_every_target() {
        let n = 8;
        let ids: Vec<String> = (0..n).map(|i| format!("t{i}")).collect();
        let at = |i: usize, z: f64| {
            let a = i as f64 * 0.8;
            Point::new(200.0 * a.cos(), 150.0 * a.sin(), z)
        };
        let covs = Some(vec![Matrix3::from_diagonal_element(0.002_f64.powi(2)); n]);
        let run = |heights: &dyn Fn(usize) -> f64, vertical: Option<super::super::Vertical>| {
            let survey: Vec<Point> = (0..n).map(|i| at(i, heights(i))).collect();
            rigid2d(
                &(ids.clone(), survey.clone(), survey, covs.clone()),
                vertical,
            )
        };
        let v = Some(super::super::Vertical {
            origin: Point::new(0.0, 0.0, 0.0),
            se_rad: 1e-3,
        });
        let w = |c: Ci95| {
            let m = c.measurement.unwrap();
            m[1] - m[0]
        };
        let level = |_: usize| 10.0;
        let (without, with) = (run(&level, None), run(&level, v));
        for (a, b) in [(without.e_abs, with.e_abs), (without.e_rel, with.e_rel)] {
            assert!((w(a) - w(b)).abs() < 3e-4, "{a:?} against {b:?}");
        }
        let apart = |i: usize| if i % 2 == 0 { 0.0 } else { 10.0 };
        let (without, with) = (run(&apart, None), run(&apart, v));
        for (a, b) in [(without.e_abs, with.e_abs), (without.e_rel, with.e_rel)] {
            assert!(w(b) > w(a) + 2e-3, "{a:?} against {b:?}");
        }
    }

    #[test]
    fn too_few_targets_give_nothing() {
        assert_eq!(run(3, 0.02), Intervals::default());
    }

    #[test]
    fn intervals_scale_with_noise() {
        let (a, b) = (run(10, 0.01), run(10, 0.04));
        let w = |iv: Interval| iv[1] - iv[0];
        assert!(w(b.e_abs.measurement.unwrap()) > 2.0 * w(a.e_abs.measurement.unwrap()));
        assert!(w(b.e_abs.targets.unwrap()) > 2.0 * w(a.e_abs.targets.unwrap()));
    }
}
