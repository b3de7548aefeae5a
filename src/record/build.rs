//! [`ResultFile`] from the typed [`Accuracy`]: where numbers get their JSON
//! names and caveats become the sentences a reader sees.

use super::{
    AlignmentOut, Asprs, AxisStats, ControlCheck, HeldOut, HeldOutTarget, Pair, RelativeStats,
    ResultFile, SCHEMA, SigmaHat, Stats, TargetOut, Unmatched, Xyz,
};
use crate::Point;
use crate::accuracy::{self, Accuracy, AsprsCaveat, Fit, Status, Summary, Warning};
use crate::align::AlignMethod;
use crate::survey::Survey;

impl ResultFile {
    /// The result file of `acc`, scored against `survey` (its frame and origin
    /// are recorded). The `eval` section is left empty: a map evaluation adds it.
    pub fn from_accuracy(acc: &Accuracy, survey: &Survey) -> ResultFile {
        ResultFile {
            schema: SCHEMA.into(),
            mapgauge_version: env!("CARGO_PKG_VERSION").into(),
            dim: acc.dim,
            survey_frame: survey.frame,
            origin: survey.origin,
            alignment: alignment_out(&acc.fit),
            targets: acc.targets.iter().map(target_out).collect(),
            absolute: Stats {
                ci95_measurement: Some(acc.intervals.e_abs.measurement),
                ci95_targets: Some(acc.intervals.e_abs.targets),
                ..stats(&acc.absolute)
            },
            unfitted: None,
            fit_absorbed: None,
            relative: relative(acc),
            leave_one_out: acc.leave_one_out.as_ref().map(held_out),
            control_check: acc.control_check.as_ref().map(|c| ControlCheck {
                control: c.control.clone(),
                alignment: alignment_out(&c.fit),
                check: held_out(&c.check),
            }),
            sigma_hat: acc.sigma_hat.map(|s| SigmaHat {
                value: s.value,
                sse: s.sse,
                dof: s.dof,
            }),
            asprs: asprs(&acc.asprs, &acc.intervals.rmse_h, acc.fit.alignment.method),
            iso19157: Some(acc.iso19157.clone()),
            unmatched: Unmatched {
                survey_only: acc.survey_only.clone(),
                estimates_only: acc.estimates_only.clone(),
            },
            scale: acc.scale,
            warnings: ranked(acc.warnings.iter().map(|w| (w.weight(), warning_text(w)))),
            eval: None,
            gates: Vec::new(),
            gate_outcome: None,
            scores: Default::default(),
        }
    }

    /// The result file of a map evaluation, as `eval` writes it and Python's
    /// `Result.to_dict()` returns it: the scores, the caveats of both the
    /// scoring and the pipeline (levelling, wrong objects rejected, targets
    /// mapped twice) ranked by what they do to the numbers, then how the run
    /// went. `survey_name` names the survey as the user gave it.
    pub fn from_evaluation(
        ev: &crate::pipeline::Evaluation,
        survey: &Survey,
        survey_name: &str,
    ) -> ResultFile {
        let mut result = ResultFile::from_accuracy(&ev.accuracy, survey);
        result.warnings = ranked(
            ev.accuracy
                .warnings
                .iter()
                .map(|w| (w.weight(), warning_text(w)))
                .chain(ev.warnings.iter().map(|w| (w.weight(), w.to_string()))),
        );
        result.eval = Some(super::EvalInfo::from_evaluation(ev, survey_name));
        // The map's positions are the survey's frame's only when the
        // targets were found where the survey places them and the map was
        // not turned: then the error without a fit means something.
        let as_is = matches!(ev.frame.how, crate::pipeline::FrameHow::Survey)
            && ev.frame.levelling.is_identity();
        if as_is && let Some(u) = crate::accuracy::unfitted(&ev.accuracy) {
            result.unfitted = Some(stats(&u.summary));
            result.fit_absorbed = Some(u.absorbed);
        }
        result
    }
}

/// Warnings in the order a reader should meet them: what may make a number
/// wrong first, the stock caveats last; in their own order within a weight.
fn ranked(w: impl Iterator<Item = (u8, String)>) -> Vec<String> {
    let mut w: Vec<(u8, String)> = w.collect();
    w.sort_by_key(|x| x.0);
    w.into_iter().map(|x| x.1).collect()
}

/// What to do about a gross error: score without it, or, when it was found
/// with the first round already set aside, that it is in these numbers.
fn gross_hint(after_exclusion: bool) -> &'static str {
    if after_exclusion {
        "it stays in these numbers, as --exclude-outliers sets aside one round of gross errors only; remove its row to score without it"
    } else {
        "--exclude-outliers scores the map without it, refitted"
    }
}

/// The sentence a reader sees for a warning.
pub(crate) fn warning_text(w: &Warning) -> String {
    match w {
        Warning::SurveyOnly(ids) => {
            format!("survey targets without an estimate: {}", ids.join(", "))
        }
        Warning::EstimatesOnly(ids) => {
            format!("estimates not in the survey (ignored): {}", ids.join(", "))
        }
        Warning::HeightDatumNotCorrected(m) => format!(
            "3D errors with {m} alignment: the map's height datum is not corrected (consider rigid2d+z)"
        ),
        Warning::HeightOffset { dz, spread } => format!(
            "every target's height is {:+.2} m off the survey's (spread {:.2} m): one offset for all is a height datum's, not the map's error — ellipsoidal against orthometric heights (the geoid lies 20-50 m from the ellipsoid in most places), or the map's own zero. The vertical numbers carry it; an alignment that fits heights (rigid2d+z) takes it out",
            dz, spread
        ),
        Warning::LeaveOneOutTooFew { method, n } => {
            format!("leave-one-out needs at least 3 targets for {method} (have {n})")
        }
        Warning::NoCheckTargets => "survey has roles but no located check targets".into(),
        Warning::TooFewControls { n: 0, method } => format!(
            "no located control targets (every target is role=check, or no control was located): {method} was fitted on all the targets, so the checkpoints are not independent; mark the targets that fit the map role=control"
        ),
        Warning::TooFewControls { n, method } => format!(
            "only {n} located control target(s): cannot fit {method} on control targets alone; it was fitted on all the targets, so the checkpoints are not independent"
        ),
        Warning::GrossError {
            id,
            error,
            sigma,
            robust_z,
            height,
            after_exclusion,
        } => match height {
            Some((dz, sigma_z, horizontal)) if dz.abs() > *horizontal => format!(
                "target {id}: error {:.0} mm is inconsistent with its uncertainty (σ {:.1} mm horizontal, {:.1} mm in height) and with the other targets (robust z {robust_z:.1}), and it is mostly in height: {:.0} mm {} the others' against the survey, {:.0} mm horizontally. A gross error? ({}, a wrong corner or a survey blunder; check it: {})",
                error * 1000.0,
                sigma * 1000.0,
                sigma_z * 1000.0,
                dz.abs() * 1000.0,
                if *dz > 0.0 { "above" } else { "below" },
                horizontal * 1000.0,
                antenna_hint(*dz),
                gross_hint(*after_exclusion)
            ),
            _ => format!(
                "target {id}: error {:.0} mm is inconsistent with its uncertainty (σ {:.1} mm{}) and with the other targets (robust z {robust_z:.1}): a gross error? (wrong corner or survey blunder; check it: {})",
                error * 1000.0,
                sigma * 1000.0,
                height.map_or(String::new(), |(_, sz, _)| format!(
                    " horizontal, {:.1} mm in height",
                    sz * 1000.0
                )),
                gross_hint(*after_exclusion)
            ),
        },
        Warning::LayoutMisfit {
            id,
            off,
            others_rms,
            dz,
        } => {
            let what = match dz {
                Some(dz) if mostly_height(*off, *dz) => format!(
                    ", {:.0} mm of it in height: {}, a survey blunder or a wrong corner?",
                    dz.abs() * 1000.0,
                    antenna_hint(*dz)
                ),
                _ => ": a survey blunder or a wrong corner?".into(),
            };
            format!(
                "target {id}: a fit on the other targets, which agree with their survey to {:.0} mm (rms), places it {:.0} mm from its own{what} (or the map distorted there; check its survey row and its panel). It stays in the numbers, --exclude-outliers too: this test cannot tell a survey typo from the map bent there; remove its row to score without it",
                others_rms * 1000.0,
                off * 1000.0
            )
        }
        Warning::TooFewForIntervals { n } => format!(
            "only {n} target(s) scored: no confidence intervals, and a survey blunder cannot be told from an error of the map (each needs at least {}; 5 or more are better)",
            accuracy::intervals::MIN_TARGETS.max(accuracy::blunder::MIN_TARGETS)
        ),
        Warning::VerticalNotReported => {
            "vertical accuracy not reported: choose an alignment that fits z (rigid2d+z, rigid3d)"
                .into()
        }
    }
}

/// Whether most of an error of `total` (m) is its height part `dz`.
fn mostly_height(total: f64, dz: f64) -> bool {
    dz.abs() > total / std::f64::consts::SQRT_2
}

/// A height error (map less survey) read as the antenna height it would
/// take: the survey's height is its point's less `antenna_height`, so one
/// too large puts the survey below the map.
fn antenna_hint(dz: f64) -> String {
    format!(
        "its antenna_height {:.2} m too {}, or its surveyed height typed wrong",
        dz.abs(),
        if dz > 0.0 { "large" } else { "small" }
    )
}

fn caveat_text(c: &AsprsCaveat) -> String {
    match c {
        AsprsCaveat::NotIndependent => "checkpoints were also used to fit the alignment: accuracy is optimistic (add role=check targets)".into(),
        AsprsCaveat::FewerThanNssda(n) => format!("only {n} checkpoints: NSSDA requires at least 20"),
        AsprsCaveat::FewerThanAsprs(n) => {
            format!("only {n} checkpoints: ASPRS (2023) requires at least 30")
        }
    }
}

fn xyz(p: &Point, has_z: bool) -> Xyz {
    Xyz {
        x: p.x,
        y: p.y,
        z: if has_z { Some(p.z) } else { None },
    }
}

fn stats(s: &Summary) -> Stats {
    Stats {
        n: s.n,
        mean: s.mean,
        std: s.std,
        rmse: s.rmse,
        median: s.median,
        max: s.max,
        ci95_measurement: None,
        ci95_targets: None,
    }
}

fn alignment_out(f: &Fit) -> AlignmentOut {
    let a = &f.alignment;
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
        n_used: f.n_used,
        iterations: a.iterations,
    }
}

fn target_out(t: &accuracy::TargetScore) -> TargetOut {
    let (status, reason) = match &t.status {
        Status::Ok => ("ok", None),
        Status::NoEstimate => ("not_found", Some("no estimate with this id".to_string())),
        Status::NotFound(r) => ("not_found", Some(r.clone())),
        Status::Excluded(r) => ("excluded", Some(r.clone())),
        Status::Ambiguous(r) => ("ambiguous", Some(r.clone())),
    };
    TargetOut {
        id: t.id.clone(),
        status: status.into(),
        reason,
        survey: xyz(&t.survey, t.survey_has_z),
        map: t.map.map(|p| xyz(&p, t.map_has_z)),
        aligned: t.aligned.map(|p| xyz(&p, t.aligned_has_z)),
        abs_error: t.abs_error,
        loo_error: t.loo_error,
        role: t.role,
        map_covariance: t.map_covariance,
    }
}

fn relative(acc: &Accuracy) -> RelativeStats {
    let s = &acc.relative.summary;
    RelativeStats {
        n: s.n,
        mean: s.mean,
        std: s.std,
        rmse: s.rmse,
        median: s.median,
        max: s.max,
        ci95_measurement: acc.intervals.e_rel.measurement,
        ci95_targets: acc.intervals.e_rel.targets,
        pairs: acc
            .relative
            .pairs
            .iter()
            .map(|p| Pair {
                a: p.a.clone(),
                b: p.b.clone(),
                survey_distance: p.survey_distance,
                map_distance: p.map_distance,
                error: p.error,
                error_per_100m: p.error_per_100m,
            })
            .collect(),
    }
}

fn held_out(h: &accuracy::HeldOut) -> HeldOut {
    HeldOut {
        summary: stats(&h.summary),
        targets: h
            .targets
            .iter()
            .map(|(id, e)| HeldOutTarget {
                id: id.clone(),
                error: *e,
            })
            .collect(),
    }
}

fn axis(a: &accuracy::AxisStats) -> AxisStats {
    AxisStats {
        bias: a.bias,
        std: a.std,
        rmse: a.rmse,
    }
}

/// The NSSDA statements in FGDC's words, with what the test rested on: how
/// many checkpoints and whether they also fitted the alignment (the report
/// adds the test's date, which result.json leaves out to stay reproducible).
fn asprs(a: &accuracy::Asprs, ci: &accuracy::Ci95, method: AlignMethod) -> Asprs {
    let basis = format!(
        "using {} checkpoint{}, {} the {} alignment",
        a.n_checkpoints,
        if a.n_checkpoints == 1 { "" } else { "s" },
        if a.independent {
            "held out of"
        } else {
            "also used to fit"
        },
        method
    );
    let mut lines = vec![format!(
        "Tested {:.3} m horizontal accuracy at 95% confidence level {basis}",
        a.nssda_horizontal_95
    )];
    if let Some(v) = a.nssda_vertical_95 {
        lines.push(format!(
            "Tested {v:.3} m vertical accuracy at 95% confidence level {basis}"
        ));
    }
    Asprs {
        n_checkpoints: a.n_checkpoints,
        independent: a.independent,
        x: axis(&a.x),
        y: axis(&a.y),
        z: a.z.as_ref().map(axis),
        rmse_x: a.x.rmse,
        rmse_y: a.y.rmse,
        rmse_h: a.rmse_h,
        rmse_v: a.rmse_v,
        rmse_3d: a.rmse_3d,
        rmse_h_measured: a.rmse_h_measured,
        rmse_v_measured: a.rmse_v_measured,
        survey_sigma_h: a.survey_sigma_h,
        survey_sigma_v: a.survey_sigma_v,
        nssda_horizontal_95: a.nssda_horizontal_95,
        nssda_vertical_95: a.nssda_vertical_95,
        nssda_lines: lines,
        warnings: a.caveats.iter().map(caveat_text).collect(),
        ci95_measurement: ci.measurement,
        ci95_targets: ci.targets,
    }
}
