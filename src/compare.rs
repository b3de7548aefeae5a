//! "Is B better than A?": paired differences of two result files on the
//! targets both located, with 95 % intervals from a paired bootstrap over
//! targets (seeded, sequential: deterministic). Definitions in
//! `docs/uncertainty.md`.

use crate::accuracy::{ScaleEstimate, t975};
use crate::record::ResultFile;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::Serialize;
use std::collections::HashMap;

/// Bootstrap resamples.
pub(crate) const RESAMPLES: usize = 4000;
/// Seed of the bootstrap.
pub const SEED: u64 = 0x636f_6d70_6172_6521;
/// Fewest common targets for an interval.
pub const MIN_COMMON: usize = 4;

/// One target both runs located.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetDiff {
    /// Target id.
    pub id: String,
    /// A's absolute error (m).
    pub a: f64,
    /// B's absolute error (m).
    pub b: f64,
    /// b − a (m).
    pub diff: f64,
}

/// One pair of common targets.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairDiff {
    /// First id.
    pub a_id: String,
    /// Second id.
    pub b_id: String,
    /// A's relative error (m).
    pub a: f64,
    /// B's relative error (m).
    pub b: f64,
    /// b − a (m).
    pub diff: f64,
}

/// A headline number in both runs and their difference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Difference {
    /// A's value on the common targets (m).
    pub a: f64,
    /// B's value on the common targets (m).
    pub b: f64,
    /// b − a (m).
    pub diff: f64,
    /// 95 % interval of b − a (paired bootstrap over targets), `null` with
    /// fewer than [`MIN_COMMON`] common targets.
    pub ci95: Option<[f64; 2]>,
}

impl Difference {
    /// Whether the interval excludes zero.
    pub fn significant(&self) -> bool {
        self.ci95.is_some_and(|c| c[0] > 0.0 || c[1] < 0.0)
    }
}

/// Two runs compared.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// Names of A and B.
    pub names: [String; 2],
    /// Targets both located, in A's order.
    pub targets: Vec<TargetDiff>,
    /// Pairs of common targets both runs report.
    pub pairs: Vec<PairDiff>,
    /// Mean absolute error on the common targets.
    pub e_abs: Difference,
    /// Mean relative error on the common pairs.
    pub e_rel: Difference,
    /// Each map's horizontal scale and their difference, when both runs
    /// scored 3 or more targets.
    pub scale: Option<ScaleDiff>,
}

/// Two runs' scales (each from its own scored targets' layout) and B − A.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScaleDiff {
    /// A's scale.
    pub a: ScaleEstimate,
    /// B's scale.
    pub b: ScaleEstimate,
    /// B − A (ppm).
    pub diff_ppm: f64,
    /// 95 % interval of B − A (ppm): the two runs' half-widths added in
    /// quadrature, as if independent; against one survey its errors are
    /// shared and cancel in B − A, so the interval is conservative.
    pub ci95_ppm: [f64; 2],
}

/// A run's scale: result.json's, or (a file written before it was
/// recorded) from its scored targets' survey and map positions.
fn run_scale(r: &ResultFile) -> Option<ScaleEstimate> {
    r.scale.or_else(|| {
        let pairs: Vec<([f64; 2], [f64; 2])> = r
            .targets
            .iter()
            .filter(|t| t.status == "ok")
            .filter_map(|t| t.map.map(|m| ([t.survey.x, t.survey.y], [m.x, m.y])))
            .collect();
        crate::accuracy::layout_scale(&pairs)
    })
}

/// The one-line verdict on the maps' scales, when both runs have one.
pub fn scale_verdict(c: &Comparison) -> Option<String> {
    let d = c.scale?;
    let [a, b] = &c.names;
    let [lo, hi] = d.ci95_ppm;
    Some(if lo > 0.0 || hi < 0.0 {
        format!(
            "scale: {b}'s map is {} against {a}'s by {:.0} ppm, 95 % CI [{:.0}, {:.0}] ppm ({a} {:+.0}, {b} {:+.0} ppm against the survey)",
            if d.diff_ppm > 0.0 {
                "stretched"
            } else {
                "shrunk"
            },
            d.diff_ppm.abs(),
            lo.abs().min(hi.abs()),
            lo.abs().max(hi.abs()),
            d.a.ppm,
            d.b.ppm
        )
    } else {
        format!(
            "scale: no significant difference ({b} − {a} = {:+.0} ppm, 95 % CI [{:.0}, {:.0}] ppm)",
            d.diff_ppm, lo, hi
        )
    })
}

/// Compares `b` with `a` on the targets both located.
pub fn compare(a: &ResultFile, b: &ResultFile, names: [String; 2]) -> crate::Result<Comparison> {
    let targets = common_targets(a, b);
    if targets.len() < 2 {
        return Err(crate::Error::Input(format!(
            "{} and {} have {} located target(s) in common; comparing needs at least 2",
            names[0],
            names[1],
            targets.len()
        )));
    }
    let (pairs, pair_idx) = common_pairs(a, b, &targets);
    let (ci_abs, ci_rel) = if targets.len() >= MIN_COMMON {
        bootstrap(&targets, &pairs, &pair_idx)
    } else {
        (None, None)
    };
    let e_abs = difference(
        &mut targets.iter().map(|t| t.a),
        &mut targets.iter().map(|t| t.b),
        ci_abs,
    );
    let e_rel = difference(
        &mut pairs.iter().map(|p| p.a),
        &mut pairs.iter().map(|p| p.b),
        if pairs.is_empty() { None } else { ci_rel },
    );
    Ok(Comparison {
        names,
        e_abs,
        e_rel,
        scale: scale_diff(a, b),
        targets,
        pairs,
    })
}

/// The targets both runs located, in A's order, with both errors.
fn common_targets(a: &ResultFile, b: &ResultFile) -> Vec<TargetDiff> {
    let b_abs: HashMap<&str, f64> = b
        .targets
        .iter()
        .filter_map(|t| t.abs_error.map(|e| (t.id.as_str(), e)))
        .collect();
    a.targets
        .iter()
        .filter_map(|t| {
            let (ea, eb) = (t.abs_error?, *b_abs.get(t.id.as_str())?);
            Some(TargetDiff {
                id: t.id.clone(),
                a: ea,
                b: eb,
                diff: eb - ea,
            })
        })
        .collect()
}

/// The pairs of common `targets` both runs report (in A's order, either
/// way round in B), and each pair's two indices into `targets` for the
/// bootstrap.
fn common_pairs(
    a: &ResultFile,
    b: &ResultFile,
    targets: &[TargetDiff],
) -> (Vec<PairDiff>, Vec<(usize, usize)>) {
    let index: HashMap<&str, usize> = targets
        .iter()
        .enumerate()
        .map(|(i, t)| (t.id.as_str(), i))
        .collect();
    let key = |x: &str, y: &str| {
        if x <= y {
            (x.to_string(), y.to_string())
        } else {
            (y.to_string(), x.to_string())
        }
    };
    let b_pairs: HashMap<(String, String), f64> = b
        .relative
        .pairs
        .iter()
        .map(|p| (key(&p.a, &p.b), p.error))
        .collect();
    let mut pairs = Vec::new();
    let mut pair_idx = Vec::new();
    for p in &a.relative.pairs {
        let (Some(&i), Some(&j)) = (index.get(p.a.as_str()), index.get(p.b.as_str())) else {
            continue;
        };
        if let Some(&eb) = b_pairs.get(&key(&p.a, &p.b)) {
            pairs.push(PairDiff {
                a_id: p.a.clone(),
                b_id: p.b.clone(),
                a: p.error,
                b: eb,
                diff: eb - p.error,
            });
            pair_idx.push((i, j));
        }
    }
    (pairs, pair_idx)
}

/// A headline number (the mean of `a`'s and of `b`'s values; NaN without
/// any) in both runs, with the interval of their difference.
fn difference(
    a: &mut dyn Iterator<Item = f64>,
    b: &mut dyn Iterator<Item = f64>,
    ci95: Option<[f64; 2]>,
) -> Difference {
    let a = mean(a).unwrap_or(f64::NAN);
    let b = mean(b).unwrap_or(f64::NAN);
    Difference {
        a,
        b,
        diff: b - a,
        ci95,
    }
}

/// The mean, in the values' order (`None` without values).
fn mean(v: &mut dyn Iterator<Item = f64>) -> Option<f64> {
    let (s, k) = v.fold((0.0, 0usize), |(s, k), x| (s + x, k + 1));
    (k > 0).then(|| s / k as f64)
}

/// The runs' scales and B − A, when both have one; the interval adds the
/// two half-widths in quadrature.
fn scale_diff(a: &ResultFile, b: &ResultFile) -> Option<ScaleDiff> {
    run_scale(a).zip(run_scale(b)).map(|(sa, sb)| {
        let half = |s: &ScaleEstimate| (s.ci95_ppm[1] - s.ci95_ppm[0]) / 2.0;
        let h = half(&sa).hypot(half(&sb));
        let diff_ppm = sb.ppm - sa.ppm;
        ScaleDiff {
            a: sa,
            b: sb,
            diff_ppm,
            ci95_ppm: [diff_ppm - h, diff_ppm + h],
        }
    })
}

/// Paired bootstrap: resample the common targets with replacement; the mean
/// per-target difference, and the mean pair difference over the resample's
/// pairs of distinct targets (with multiplicity).
fn bootstrap(
    targets: &[TargetDiff],
    pairs: &[PairDiff],
    pair_idx: &[(usize, usize)],
) -> (Option<[f64; 2]>, Option<[f64; 2]>) {
    let n = targets.len();
    let mut rng = Pcg64Mcg::seed_from_u64(SEED);
    let mut abs = Vec::with_capacity(RESAMPLES);
    let mut rel = Vec::with_capacity(RESAMPLES);
    let mut count = vec![0usize; n];
    for _ in 0..RESAMPLES {
        count.iter_mut().for_each(|c| *c = 0);
        for _ in 0..n {
            count[rng.random_range(0..n)] += 1;
        }
        let d: f64 = targets
            .iter()
            .zip(&count)
            .map(|(t, &c)| t.diff * c as f64)
            .sum();
        abs.push(d / n as f64);
        let (mut s, mut w) = (0.0, 0usize);
        for (p, &(i, j)) in pairs.iter().zip(pair_idx) {
            let m = count[i] * count[j];
            s += p.diff * m as f64;
            w += m;
        }
        if w > 0 {
            rel.push(s / w as f64);
        }
    }
    (percentile95(abs), percentile95(rel))
}

/// The 95 % percentile interval of at least 100 resampled values.
fn percentile95(v: Vec<f64>) -> Option<[f64; 2]> {
    if v.len() < 100 {
        return None;
    }
    crate::accuracy::intervals::percentile_interval(v)
}

/// The one-line verdict on `what` (e.g. "E_abs"): "B's E_abs is lower by
/// 12 mm, 95 % CI [4, 20] mm", "no significant difference …", or why nothing
/// can be said.
pub fn verdict(c: &Comparison, d: &Difference, what: &str) -> String {
    // Rounded to whole millimetres here, so a -0.3 mm difference reads 0,
    // not "-0".
    let mm = |v: f64| {
        let r = (v * 1000.0).round();
        if r == 0.0 { 0.0 } else { r }
    };
    let [a, b] = &c.names;
    match d.ci95 {
        None => format!(
            "{what}: too few common targets ({}) to say whether {a} or {b} is better (need {MIN_COMMON})",
            c.targets.len()
        ),
        Some(ci) if d.significant() => {
            let (word, lo, hi) = if d.diff < 0.0 {
                ("lower", -ci[1], -ci[0])
            } else {
                ("higher", ci[0], ci[1])
            };
            format!(
                "{b}'s {what} is {word} than {a}'s by {:.0} mm, 95 % CI [{:.0}, {:.0}] mm",
                mm(d.diff.abs()),
                mm(lo),
                mm(hi)
            )
        }
        Some(ci) => format!(
            "{what}: no significant difference ({b} − {a} = {:+.0} mm, 95 % CI [{:.0}, {:.0}] mm)",
            mm(d.diff),
            mm(ci[0]),
            mm(ci[1])
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn result(errors: &[(&str, Option<f64>)]) -> ResultFile {
        let mut r: ResultFile = serde_json::from_str(
            r#"{"schema":"mapgauge.result/1","mapgauge_version":"0","alignment":{"method":"rigid2d","rotation_deg":0,"translation":[0,0,0],"scale":1},
            "targets":[],"absolute":{"n":0,"mean":0,"std":0,"rmse":0,"median":0,"max":0},
            "relative":{"n":0,"mean":0,"std":0,"pairs":[]},
            "asprs":{"n_checkpoints":0,"independent":false,"x":{"bias":0,"std":0,"rmse":0},"y":{"bias":0,"std":0,"rmse":0},"z":null,
            "rmse_x":0,"rmse_y":0,"rmse_h":0,"rmse_v":null,"rmse_3d":null,"rmse_h_measured":0,"rmse_v_measured":null,
            "survey_sigma_h":null,"survey_sigma_v":null,"nssda_horizontal_95":0,"nssda_vertical_95":null,"nssda_lines":[],"warnings":[]}}"#,
        )
        .unwrap();
        for (id, e) in errors {
            r.targets.push(crate::record::TargetOut {
                id: id.to_string(),
                status: if e.is_some() { "ok" } else { "not_found" }.into(),
                reason: None,
                survey: crate::record::Xyz {
                    x: 0.0,
                    y: 0.0,
                    z: None,
                },
                map: None,
                aligned: None,
                abs_error: *e,
                loo_error: None,
                role: None,
                map_covariance: None,
            });
        }
        let ok: Vec<_> = errors.iter().filter(|e| e.1.is_some()).collect();
        for (i, x) in ok.iter().enumerate() {
            for y in &ok[i + 1..] {
                r.relative.pairs.push(crate::record::Pair {
                    a: x.0.into(),
                    b: y.0.into(),
                    survey_distance: 10.0,
                    map_distance: 10.0,
                    error: (x.1.unwrap() + y.1.unwrap()) / 2.0,
                    error_per_100m: None,
                });
            }
        }
        r
    }

    #[test]
    fn a_clear_improvement_is_significant_and_noise_is_not() {
        let a = result(&[
            ("1", Some(0.03)),
            ("2", Some(0.04)),
            ("3", Some(0.035)),
            ("4", Some(0.05)),
            ("5", Some(0.045)),
            ("6", None),
        ]);
        let b = result(&[
            ("1", Some(0.02)),
            ("2", Some(0.028)),
            ("3", Some(0.024)),
            ("4", Some(0.037)),
            ("5", Some(0.036)),
            ("6", Some(0.01)),
        ]);
        let c = compare(&a, &b, ["A".into(), "B".into()]).unwrap();
        assert_eq!(c.targets.len(), 5);
        assert_eq!(c.pairs.len(), 10);
        assert!(c.e_abs.significant() && c.e_abs.diff < 0.0, "{:?}", c.e_abs);
        let v = verdict(&c, &c.e_abs, "E_abs");
        assert!(v.starts_with("B's E_abs is lower than A's by 11 mm"), "{v}");
        assert_eq!(c, compare(&a, &b, ["A".into(), "B".into()]).unwrap());
        // Mixed signs: no significant difference.
        let d = result(&[
            ("1", Some(0.04)),
            ("2", Some(0.03)),
            ("3", Some(0.045)),
            ("4", Some(0.04)),
            ("5", Some(0.045)),
        ]);
        let c2 = compare(&a, &d, ["A".into(), "B".into()]).unwrap();
        assert!(!c2.e_abs.significant());
        assert!(verdict(&c2, &c2.e_abs, "E_abs").contains("no significant difference"));
        // Too few: no interval, says so.
        let e = result(&[("1", Some(0.02)), ("2", Some(0.02)), ("3", Some(0.02))]);
        let c3 = compare(&a, &e, ["A".into(), "B".into()]).unwrap();
        assert!(c3.e_abs.ci95.is_none());
        assert!(verdict(&c3, &c3.e_abs, "E_abs").contains("too few common targets (3)"));
        assert!(compare(&a, &result(&[("9", Some(0.1))]), ["A".into(), "B".into()]).is_err());
    }
}

/// Mean of one number over several runs and its 95 % interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AcrossRuns {
    /// Runs with a value.
    pub n: usize,
    /// Mean over the runs.
    pub mean: f64,
    /// 95 % interval of the mean: mean ± t(0.975, n − 1) · s / √n, s the
    /// sample standard deviation over runs (Student's t: runs are few), its
    /// low end clamped at 0: the values are error magnitudes, and a t
    /// interval of two runs (t = 12.7) reaches far below 0.
    pub ci95: [f64; 2],
}

/// Mean and 95 % interval of `values` (one per run: error magnitudes, never
/// negative); `None` with fewer than 2 runs (no spread to estimate).
pub fn across_runs(values: &[f64]) -> Option<AcrossRuns> {
    let n = values.len();
    if n < 2 || values.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    let s = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
    let h = t975(n - 1) * s / (n as f64).sqrt();
    Some(AcrossRuns {
        n,
        mean,
        ci95: [(mean - h).max(0.0), mean + h],
    })
}

#[cfg(test)]
mod runs_tests {
    use super::*;

    #[test]
    fn across_runs_is_a_t_interval() {
        let r = across_runs(&[0.01, 0.02, 0.03]).unwrap();
        assert!((r.mean - 0.02).abs() < 1e-15);
        // s = 0.01, t(2) = 4.303: half-width 0.004303·√3/… = 4.303·0.01/√3.
        assert!((r.ci95[1] - 0.02 - 4.303 * 0.01 / 3f64.sqrt()).abs() < 1e-12);
        assert!(across_runs(&[0.01]).is_none());
        // Two runs: t(1) = 12.7 takes the low end below 0; a magnitude's is 0.
        let two = across_runs(&[0.01, 0.03]).unwrap();
        assert_eq!(two.ci95[0], 0.0);
        // s = √2 · 0.01, so the half-width is 12.706 · 0.01.
        assert!((two.ci95[1] - 0.02 - 12.706 * 0.01).abs() < 1e-9);
        assert!((t975(1000) - 1.962).abs() < 1e-3);
    }
}
