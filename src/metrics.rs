//! Absolute and relative errors, honest (held-out) errors and survey-standard
//! statistics: steps 6–7 of the pipeline in one call, [`evaluate`].

use crate::align::{self, AlignMethod, Alignment};
use crate::result::{
    AlignmentOut, Asprs, AxisStats, ControlCheck, HeldOut, HeldOutTarget, Pair, RelativeStats,
    RunResult, SigmaHat, TargetOut, Unmatched, Xyz,
};
use crate::survey::{Estimate, EstimateStatus, Role, Survey};
use crate::{Error, Point, Result};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Whether errors are measured in the horizontal plane or in space.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Dim {
    /// x, y only (the paper's tables).
    #[default]
    #[serde(rename = "2d")]
    D2,
    /// x, y, z (needs heights in the survey and the estimates).
    #[serde(rename = "3d")]
    D3,
}

impl std::str::FromStr for Dim {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "2d" | "2" => Ok(Dim::D2),
            "3d" | "3" => Ok(Dim::D3),
            _ => Err(Error::Param(format!("unknown dimension `{s}` (2d or 3d)"))),
        }
    }
}

/// Knobs of [`evaluate`].
#[derive(Debug, Clone, Default)]
pub struct EvalOptions {
    /// Alignment of the map onto the survey.
    pub method: AlignMethod,
    /// Error dimension.
    pub dim: Dim,
    /// The survey's own 1-σ error (horizontal RMSE, optional vertical), folded into
    /// the ASPRS figures as √(measured² + survey²).
    pub survey_sigma: Option<(f64, Option<f64>)>,
}

/// Summary statistics of a list of errors: the numbers of the paper's tables.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
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
pub fn summarize(v: &[f64]) -> Summary {
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
pub fn dist(a: &Point, b: &Point, dim: Dim) -> f64 {
    match dim {
        Dim::D2 => (a - b).xy().norm(),
        Dim::D3 => (a - b).norm(),
    }
}

/// Relative error of every pair: | ‖xᵢ − xⱼ‖ − ‖x̂ᵢ − x̂ⱼ‖ |, in input order
/// (i < j). Needs no alignment, so it is unaffected by how the map is placed.
pub fn relative_errors(ids: &[String], map: &[Point], survey: &[Point], dim: Dim) -> Vec<Pair> {
    let mut out = Vec::new();
    for i in 0..map.len() {
        for j in i + 1..map.len() {
            let sd = dist(&survey[i], &survey[j], dim);
            let md = dist(&map[i], &map[j], dim);
            let error = (md - sd).abs();
            out.push(Pair {
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

fn xyz(p: &Point, has_z: bool) -> Xyz {
    Xyz {
        x: p.x,
        y: p.y,
        z: if has_z { Some(p.z) } else { None },
    }
}

fn alignment_out(a: &Alignment, n_used: usize) -> AlignmentOut {
    AlignmentOut {
        method: a.method.name().to_string(),
        rotation_deg: a.rotation_deg(),
        translation: [a.translation.x, a.translation.y, a.translation.z],
        scale: a.scale,
        scale_ppm: a.scale_ppm(),
        rotation_matrix: [
            [a.rotation[(0, 0)], a.rotation[(0, 1)], a.rotation[(0, 2)]],
            [a.rotation[(1, 0)], a.rotation[(1, 1)], a.rotation[(1, 2)]],
            [a.rotation[(2, 0)], a.rotation[(2, 1)], a.rotation[(2, 2)]],
        ],
        n_used,
        iterations: a.iterations,
    }
}

fn axis(v: &[f64]) -> AxisStats {
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

/// ASPRS (2023, Ed. 2) figures from aligned − survey residuals.
fn asprs(
    res: &[nalgebra::Vector3<f64>],
    vertical: bool,
    sigma: Option<(f64, Option<f64>)>,
    independent: bool,
) -> Asprs {
    let n = res.len();
    let x = axis(&res.iter().map(|r| r.x).collect::<Vec<_>>());
    let y = axis(&res.iter().map(|r| r.y).collect::<Vec<_>>());
    let z = vertical.then(|| axis(&res.iter().map(|r| r.z).collect::<Vec<_>>()));
    let rmse_h_measured = x.rmse.hypot(y.rmse);
    let rmse_v_measured = z.map(|z| z.rmse);
    let (sh, sv) = sigma.unwrap_or((0.0, None));
    let rmse_h = rmse_h_measured.hypot(sh);
    let rmse_v = rmse_v_measured.map(|v| v.hypot(sv.unwrap_or(0.0)));
    let rmse_3d = rmse_v.map(|v| rmse_h.hypot(v));
    let mut warnings = Vec::new();
    if !independent {
        warnings.push(
            "checkpoints were also used to fit the alignment: accuracy is optimistic (add role=check targets)"
                .to_string(),
        );
    }
    if n < 20 {
        warnings.push(format!("only {n} checkpoints: NSSDA requires at least 20"));
    }
    if n < 30 {
        warnings.push(format!(
            "only {n} checkpoints: ASPRS (2023) requires at least 30"
        ));
    }
    let nssda_h = 1.7308 * rmse_h;
    let nssda_v = rmse_v.map(|v| 1.96 * v);
    let mut lines = vec![format!(
        "Tested {nssda_h:.3} m horizontal accuracy at 95% confidence level"
    )];
    if let Some(v) = nssda_v {
        lines.push(format!(
            "Tested {v:.3} m vertical accuracy at 95% confidence level"
        ));
    }
    Asprs {
        n_checkpoints: n,
        independent,
        x,
        y,
        z,
        rmse_x: x.rmse,
        rmse_y: y.rmse,
        rmse_h,
        rmse_v,
        rmse_3d,
        rmse_h_measured,
        rmse_v_measured,
        survey_sigma_h: sigma.map(|s| s.0),
        survey_sigma_v: sigma.and_then(|s| s.1),
        nssda_horizontal_95: nssda_h,
        nssda_vertical_95: nssda_v,
        nssda_lines: lines,
        warnings,
    }
}

/// Aligns the estimates to the survey and computes every error statistic.
///
/// Targets are matched by id; estimates that are not found or excluded are
/// listed in the result with their reason but never scored.
pub fn evaluate(survey: &Survey, estimates: &[Estimate], opts: &EvalOptions) -> Result<RunResult> {
    let dim = opts.dim;
    let mut warnings = Vec::new();
    let by_id: HashMap<&str, &Estimate> = estimates.iter().map(|e| (e.id.as_str(), e)).collect();
    let mut targets = Vec::new();
    let mut used = Vec::new(); // index into survey.targets of scored targets
    let mut map_pts = Vec::new();
    let mut sur_pts = Vec::new();
    let mut survey_only = Vec::new();
    for (k, st) in survey.targets.iter().enumerate() {
        let sp = st.reference();
        let base = TargetOut {
            id: st.id.clone(),
            status: "ok".into(),
            reason: None,
            survey: xyz(&sp, st.has_z),
            map: None,
            aligned: None,
            abs_error: None,
            loo_error: None,
            role: st.role,
        };
        match by_id.get(st.id.as_str()) {
            None => {
                survey_only.push(st.id.clone());
                targets.push(TargetOut {
                    status: "not_found".into(),
                    reason: Some("no estimate with this id".into()),
                    ..base
                });
            }
            Some(e) => match &e.status {
                EstimateStatus::Found(p) => {
                    if dim == Dim::D3 && !(st.has_z && e.has_z) {
                        return Err(Error::Input(format!(
                            "target `{}`: 3D errors need z in both the survey and the estimates (use --dim 2d)",
                            st.id
                        )));
                    }
                    used.push(k);
                    map_pts.push(*p);
                    sur_pts.push(sp);
                    targets.push(TargetOut {
                        map: Some(xyz(p, e.has_z)),
                        ..base
                    });
                }
                EstimateStatus::NotFound { reason } => targets.push(TargetOut {
                    status: "not_found".into(),
                    reason: Some(reason.clone()),
                    ..base
                }),
                EstimateStatus::Excluded { reason } => targets.push(TargetOut {
                    status: "excluded".into(),
                    reason: Some(reason.clone()),
                    ..base
                }),
            },
        }
    }
    let estimates_only: Vec<String> = estimates
        .iter()
        .filter(|e| survey.get(&e.id).is_none())
        .map(|e| e.id.clone())
        .collect();
    if !survey_only.is_empty() {
        warnings.push(format!(
            "survey targets without an estimate: {}",
            survey_only.join(", ")
        ));
    }
    if !estimates_only.is_empty() {
        warnings.push(format!(
            "estimates not in the survey (ignored): {}",
            estimates_only.join(", ")
        ));
    }
    let n = used.len();
    let need = opts.method.min_points().max(2);
    if n < need {
        return Err(Error::Input(format!(
            "only {n} target(s) are both surveyed and located; at least {need} are needed for {} alignment",
            opts.method
        )));
    }
    let all_z = used.iter().all(|&k| survey.targets[k].has_z)
        && used.iter().all(|&k| {
            by_id
                .get(survey.targets[k].id.as_str())
                .is_some_and(|e| e.has_z)
        });
    if opts.method.uses_z() && !all_z {
        return Err(Error::Input(format!(
            "alignment {} needs z in both the survey and the estimates",
            opts.method
        )));
    }
    if dim == Dim::D3 && !opts.method.uses_z() && opts.method != AlignMethod::None {
        warnings.push(format!(
            "3D errors with {} alignment: the map's height datum is not corrected (consider rigid2d+z)",
            opts.method
        ));
    }

    let al = align::fit(opts.method, &map_pts, &sur_pts)?;
    let aligned: Vec<Point> = map_pts.iter().map(|p| al.apply(p)).collect();
    let abs: Vec<f64> = aligned
        .iter()
        .zip(&sur_pts)
        .map(|(a, s)| dist(a, s, dim))
        .collect();
    let ids: Vec<String> = used.iter().map(|&k| survey.targets[k].id.clone()).collect();
    let pairs = relative_errors(&ids, &map_pts, &sur_pts, dim);
    let rel: Vec<f64> = pairs.iter().map(|p| p.error).collect();

    // Honest errors.
    let loo = leave_one_out(opts.method, &map_pts, &sur_pts, dim);
    if loo.is_none() {
        warnings.push(format!(
            "leave-one-out needs at least 3 targets for {} (have {n})",
            opts.method
        ));
    }
    let sigma_hat = {
        let (d, sse) = if opts.method.uses_z() {
            (
                3,
                aligned
                    .iter()
                    .zip(&sur_pts)
                    .map(|(a, s)| (a - s).norm_squared())
                    .sum::<f64>(),
            )
        } else {
            (
                2,
                aligned
                    .iter()
                    .zip(&sur_pts)
                    .map(|(a, s)| (a - s).xy().norm_squared())
                    .sum::<f64>(),
            )
        };
        let dof = (d * n) as i64 - opts.method.params() as i64;
        (dof > 0).then(|| SigmaHat {
            value: (sse / dof as f64).sqrt(),
            sse,
            dof: dof as usize,
        })
    };

    for (j, &k) in used.iter().enumerate() {
        let t = &mut targets[k];
        t.aligned = Some(xyz(&aligned[j], all_z || opts.method.uses_z()));
        t.abs_error = Some(abs[j]);
        t.loo_error = loo.as_ref().map(|l| l[j]);
    }

    // Control/check split.
    let has_roles = used.iter().any(|&k| survey.targets[k].role.is_some());
    let mut control_check = None;
    let mut check_residuals = None;
    if has_roles {
        let is_check = |k: usize| survey.targets[k].role == Some(Role::Check);
        let ctrl: Vec<usize> = (0..n).filter(|&j| !is_check(used[j])).collect();
        let chk: Vec<usize> = (0..n).filter(|&j| is_check(used[j])).collect();
        if chk.is_empty() {
            warnings.push("survey has roles but no located check targets".into());
        } else if ctrl.len() < need {
            warnings.push(format!(
                "only {} located control target(s): cannot fit {} on control targets alone",
                ctrl.len(),
                opts.method
            ));
        } else {
            let src: Vec<Point> = ctrl.iter().map(|&j| map_pts[j]).collect();
            let dst: Vec<Point> = ctrl.iter().map(|&j| sur_pts[j]).collect();
            let a = align::fit(opts.method, &src, &dst)?;
            let per: Vec<HeldOutTarget> = chk
                .iter()
                .map(|&j| HeldOutTarget {
                    id: ids[j].clone(),
                    error: dist(&a.apply(&map_pts[j]), &sur_pts[j], dim),
                })
                .collect();
            let errs: Vec<f64> = per.iter().map(|t| t.error).collect();
            check_residuals = Some(
                chk.iter()
                    .map(|&j| a.apply(&map_pts[j]) - sur_pts[j])
                    .collect::<Vec<_>>(),
            );
            control_check = Some(ControlCheck {
                control: ctrl.iter().map(|&j| ids[j].clone()).collect(),
                alignment: alignment_out(&a, ctrl.len()),
                check: HeldOut {
                    summary: summarize(&errs),
                    targets: per,
                },
            });
        }
    }
    // Heights are comparable when the fit corrected them or the map is already in the survey frame.
    let vertical = all_z && (opts.method.uses_z() || opts.method == AlignMethod::None);
    let asprs = match check_residuals {
        Some(r) => asprs(&r, vertical, opts.survey_sigma, true),
        None => {
            let r: Vec<_> = aligned.iter().zip(&sur_pts).map(|(a, s)| a - s).collect();
            asprs(&r, vertical, opts.survey_sigma, false)
        }
    };
    if all_z && !vertical {
        warnings.push(
            "vertical accuracy not reported: choose an alignment that fits z (rigid2d+z, rigid3d)"
                .into(),
        );
    }

    let absolute_summary = summarize(&abs);
    let relative_summary = summarize(&rel);
    Ok(RunResult {
        schema: crate::result::SCHEMA.into(),
        mapgauge_version: env!("CARGO_PKG_VERSION").into(),
        dim,
        survey_frame: survey.frame,
        origin: survey.origin,
        alignment: alignment_out(&al, n),
        targets,
        absolute: absolute_summary,
        relative: RelativeStats {
            n: relative_summary.n,
            mean: relative_summary.mean,
            std: relative_summary.std,
            rmse: relative_summary.rmse,
            median: relative_summary.median,
            max: relative_summary.max,
            pairs,
        },
        leave_one_out: loo.map(|l| HeldOut {
            summary: summarize(&l),
            targets: ids
                .iter()
                .zip(&l)
                .map(|(id, e)| HeldOutTarget {
                    id: id.clone(),
                    error: *e,
                })
                .collect(),
        }),
        control_check,
        sigma_hat,
        asprs,
        unmatched: Unmatched {
            survey_only,
            estimates_only,
        },
        warnings,
        eval: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::survey::{SurveyFrame, SurveyTarget};
    use nalgebra::Vector3;

    fn survey(pts: &[(f64, f64, f64)]) -> Survey {
        Survey {
            targets: pts
                .iter()
                .enumerate()
                .map(|(i, p)| SurveyTarget {
                    id: format!("t{}", i + 1),
                    position: Point::new(p.0, p.1, p.2),
                    has_z: true,
                    role: None,
                    antenna_height: 0.0,
                    line: i as u64 + 2,
                })
                .collect(),
            frame: SurveyFrame::Local,
            origin: None,
        }
    }

    #[test]
    fn summary_is_population() {
        let s = summarize(&[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(s.mean, 2.5);
        assert!((s.std - 1.25f64.sqrt()).abs() < 1e-15);
        assert_eq!(s.median, 2.5);
        assert_eq!(s.max, 4.0);
        assert!((s.rmse - 7.5f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn relative_errors_invariant_under_rigid_motion() {
        let s = survey(&[
            (0.0, 0.0, 0.0),
            (10.0, 1.0, 0.5),
            (20.0, -5.0, 1.0),
            (3.0, 30.0, -1.0),
        ]);
        let est: Vec<Point> = s
            .targets
            .iter()
            .map(|t| t.position + Vector3::new(0.01, -0.02, 0.03) * t.position.x)
            .collect();
        let ids: Vec<String> = s.targets.iter().map(|t| t.id.clone()).collect();
        let sp: Vec<Point> = s.targets.iter().map(|t| t.position).collect();
        for dim in [Dim::D2, Dim::D3] {
            let before = relative_errors(&ids, &est, &sp, dim);
            let r = nalgebra::Rotation3::from_euler_angles(
                if dim == Dim::D3 { 0.3 } else { 0.0 },
                0.1 * (dim == Dim::D3) as u8 as f64,
                2.0,
            );
            let moved: Vec<Point> = est
                .iter()
                .map(|p| r * p + Vector3::new(350_000.0, 4_150_000.0, 50.0))
                .collect();
            let after = relative_errors(&ids, &moved, &sp, dim);
            for (a, b) in before.iter().zip(&after) {
                assert!((a.error - b.error).abs() < 1e-8, "{dim:?}");
            }
        }
    }

    #[test]
    fn not_found_and_unmatched_are_reported_not_scored() {
        let s = survey(&[
            (0.0, 0.0, 0.0),
            (10.0, 0.0, 0.0),
            (0.0, 10.0, 0.0),
            (5.0, 5.0, 0.0),
        ]);
        let est = vec![
            Estimate::found("t1", Point::new(0.1, 0.0, 0.0)),
            Estimate::found("t2", Point::new(10.0, 0.0, 0.0)),
            Estimate::found("t3", Point::new(0.0, 10.0, 0.0)),
            Estimate {
                id: "t4".into(),
                status: EstimateStatus::NotFound {
                    reason: "no points".into(),
                },
                has_z: false,
            },
            Estimate::found("zz", Point::origin()),
        ];
        let r = evaluate(&s, &est, &EvalOptions::default()).unwrap();
        assert_eq!(r.absolute.n, 3);
        assert_eq!(r.relative.n, 3);
        assert_eq!(r.targets[3].status, "not_found");
        assert_eq!(r.targets[3].reason.as_deref(), Some("no points"));
        assert!(r.targets[3].abs_error.is_none());
        assert_eq!(r.unmatched.estimates_only, vec!["zz".to_string()]);
        assert!(r.leave_one_out.is_some());
        let two = &est[..2];
        let r2 = evaluate(&s, two, &EvalOptions::default()).unwrap();
        assert!(r2.leave_one_out.is_none());
        assert!(r2.unmatched.survey_only.len() == 2);
        let e = evaluate(&s, &est[..1], &EvalOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least 2"), "{e}");
    }

    #[test]
    fn control_check_and_sigma_hat() {
        let mut s = survey(&[
            (0.0, 0.0, 0.0),
            (30.0, 0.0, 0.0),
            (0.0, 30.0, 0.0),
            (30.0, 30.0, 0.0),
            (15.0, 15.0, 0.0),
        ]);
        s.targets[4].role = Some(Role::Check);
        for t in &mut s.targets[..4] {
            t.role = Some(Role::Control);
        }
        // Map = survey rotated by 10°, plus a 0.1 m error on the check target only.
        let r = nalgebra::Rotation3::from_euler_angles(0.0, 0.0, 10f64.to_radians());
        let est: Vec<Estimate> = s
            .targets
            .iter()
            .map(|t| {
                let mut p = r * t.position;
                if t.role == Some(Role::Check) {
                    p.x += 0.1;
                }
                Estimate::found(t.id.clone(), p)
            })
            .collect();
        let res = evaluate(
            &s,
            &est,
            &EvalOptions {
                survey_sigma: Some((0.02, None)),
                ..Default::default()
            },
        )
        .unwrap();
        let cc = res.control_check.as_ref().unwrap();
        assert_eq!(cc.check.targets.len(), 1);
        assert!((cc.check.targets[0].error - 0.1).abs() < 1e-9);
        assert!(res.asprs.independent);
        assert!((res.asprs.rmse_h_measured - 0.1).abs() < 1e-9);
        assert!((res.asprs.rmse_h - 0.1f64.hypot(0.02)).abs() < 1e-12);
        assert!((res.asprs.nssda_horizontal_95 - 1.7308 * res.asprs.rmse_h).abs() < 1e-12);
        assert!(res.asprs.warnings.iter().any(|w| w.contains("NSSDA")));
        // σ̂ = sqrt(SSE / (2n − 3)).
        let sh = res.sigma_hat.unwrap();
        assert_eq!(sh.dof, 7);
        let sse: f64 = res
            .targets
            .iter()
            .map(|t| t.abs_error.unwrap().powi(2))
            .sum();
        assert!((sh.value - (sse / 7.0).sqrt()).abs() < 1e-12);
        // LOO is never smaller on the perturbed target than the in-sample error.
        let t5 = &res.targets[4];
        assert!(t5.loo_error.unwrap() >= t5.abs_error.unwrap());
    }

    #[test]
    fn three_d_with_z_alignment() {
        let s = survey(&[
            (0.0, 0.0, 1.0),
            (30.0, 0.0, 2.0),
            (0.0, 30.0, 0.0),
            (30.0, 30.0, 1.5),
        ]);
        let est: Vec<Estimate> = s
            .targets
            .iter()
            .enumerate()
            .map(|(i, t)| {
                Estimate::found(
                    t.id.clone(),
                    t.position + Vector3::new(5.0, -3.0, 100.0 + 0.01 * i as f64),
                )
            })
            .collect();
        let opts = EvalOptions {
            method: AlignMethod::Rigid2dZ,
            dim: Dim::D3,
            survey_sigma: None,
        };
        let r = evaluate(&s, &est, &opts).unwrap();
        assert!((r.absolute.mean - 0.01).abs() < 1e-9, "{:?}", r.absolute);
        assert!(r.asprs.rmse_v.is_some() && r.asprs.rmse_3d.is_some());
        // The antenna height is taken off the survey z before comparing.
        let mut raised = s.clone();
        raised.targets[1].position.z += 1.8;
        raised.targets[1].antenna_height = 1.8;
        let r2 = evaluate(&raised, &est, &opts).unwrap();
        assert!((r2.absolute.mean - r.absolute.mean).abs() < 1e-12);
        // With no alignment heights are compared as they are.
        let none = EvalOptions {
            method: AlignMethod::None,
            dim: Dim::D3,
            survey_sigma: None,
        };
        let r3 = evaluate(&s, &est, &none).unwrap();
        assert!(r3.asprs.rmse_v.unwrap() > 99.0);
        let mut no_z = est.clone();
        no_z[0].has_z = false;
        assert!(evaluate(&s, &no_z, &opts).is_err());
    }
}
