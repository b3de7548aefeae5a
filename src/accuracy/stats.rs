//! Summary statistics of error lists and the per-pair, held-out and per-axis
//! figures built on them: plain numbers, no alignment policy.

use super::Dim;
use crate::Point;
use crate::align::{self, AlignMethod};

/// Summary statistics of a list of errors: the numbers of the paper's tables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Count.
    pub n: usize,
    /// Mean.
    pub mean: f64,
    /// Population standard deviation (divide by n), as the paper.
    pub std: f64,
    /// Root mean square.
    pub rmse: f64,
    /// Median.
    pub median: f64,
    /// Maximum.
    pub max: f64,
}

/// Mean, population std, RMSE, median and max of `v` (all 0 for an empty list).
pub(crate) fn summarize(v: &[f64]) -> Summary {
    let n = v.len();
    if n == 0 {
        return Summary {
            n,
            mean: 0.0,
            std: 0.0,
            rmse: 0.0,
            median: 0.0,
            max: 0.0,
        };
    }
    let nf = n as f64;
    let mean = v.iter().sum::<f64>() / nf;
    let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / nf;
    let rmse = (v.iter().map(|x| x * x).sum::<f64>() / nf).sqrt();
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let median = if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    };
    Summary {
        n,
        mean,
        std: var.sqrt(),
        rmse,
        median,
        max: s[n - 1],
    }
}

/// Distance between two points in the chosen dimension.
pub(crate) fn dist(a: &Point, b: &Point, dim: Dim) -> f64 {
    match dim {
        Dim::D2 => (a - b).xy().norm(),
        Dim::D3 => (a - b).norm(),
    }
}

/// Relative error of every pair: | ‖xᵢ − xⱼ‖ − ‖x̂ᵢ − x̂ⱼ‖ |, in input order
/// (i < j). Needs no alignment, so it is unaffected by how the map is placed.
pub(crate) fn relative_errors(
    ids: &[String],
    map: &[Point],
    survey: &[Point],
    dim: Dim,
) -> Vec<PairError> {
    let mut out = Vec::new();
    for i in 0..map.len() {
        for j in i + 1..map.len() {
            let sd = dist(&survey[i], &survey[j], dim);
            let md = dist(&map[i], &map[j], dim);
            let error = (md - sd).abs();
            out.push(PairError {
                a: ids[i].clone(),
                b: ids[j].clone(),
                survey_distance: sd,
                map_distance: md,
                error,
                error_per_100m: (sd > 0.0).then(|| error / sd * 100.0),
            });
        }
    }
    out
}

/// Leave-one-out errors: each target scored with the alignment fitted on all the
/// others. `None` when too few targets remain to fit.
pub fn leave_one_out(
    method: AlignMethod,
    map: &[Point],
    survey: &[Point],
    dim: Dim,
) -> Option<Vec<f64>> {
    let n = map.len();
    if n < 3 || n - 1 < method.min_points() {
        return None;
    }
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let src: Vec<Point> = map
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, p)| *p)
            .collect();
        let dst: Vec<Point> = survey
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, p)| *p)
            .collect();
        let a = align::fit(method, &src, &dst).ok()?;
        out.push(dist(&a.apply(&map[i]), &survey[i], dim));
    }
    Some(out)
}

/// One pair's relative error (the paper's Table I).
#[derive(Debug, Clone, PartialEq)]
pub struct PairError {
    /// First target id.
    pub a: String,
    /// Second target id.
    pub b: String,
    /// Distance between the surveyed points (m).
    pub survey_distance: f64,
    /// Distance between the map estimates (m).
    pub map_distance: f64,
    /// | map_distance − survey_distance | (m).
    pub error: f64,
    /// The error per 100 m of survey distance (m); `None` for coincident survey points.
    pub error_per_100m: Option<f64>,
}

/// Bias, sample std and RMSE of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisStats {
    /// Mean residual (aligned − survey).
    pub bias: f64,
    /// Sample standard deviation (n − 1).
    pub std: f64,
    /// Root mean square residual.
    pub rmse: f64,
}

/// Bias, sample std and RMSE of one axis' residuals.
pub(crate) fn axis(v: &[f64]) -> AxisStats {
    let n = v.len();
    let nf = n as f64;
    let mean = if n > 0 {
        v.iter().sum::<f64>() / nf
    } else {
        0.0
    };
    let std = if n > 1 {
        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (nf - 1.0)).sqrt()
    } else {
        0.0
    };
    let rmse = if n > 0 {
        (v.iter().map(|x| x * x).sum::<f64>() / nf).sqrt()
    } else {
        0.0
    };
    AxisStats {
        bias: mean,
        std,
        rmse,
    }
}

/// Student's t 0.975 quantile for `dof` degrees of freedom (table to 30, then
/// the normal limit with the first correction term).
pub(crate) fn t975(dof: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match dof {
        0 => f64::NAN,
        d if d <= 30 => T[d - 1],
        d => 1.959_964 + 2.372 / d as f64,
    }
}
