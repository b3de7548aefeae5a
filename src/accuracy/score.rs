//! [`score`] as its steps, in the order evo's `ape()` runs them: match the
//! estimates to the survey → align → the errors (absolute, relative, held
//! out) → a control/check split when the survey names roles → the
//! survey-standard numbers and their intervals → gross errors and scale.

use super::*;
use nalgebra::{Matrix2, Matrix3, Vector3};

/// Aligns the estimates to the survey and computes every error statistic.
///
/// Targets are matched by id; estimates that are not found or excluded are
/// listed in the result with their reason but never scored.
pub fn score(survey: &Survey, estimates: &[Estimate], opts: &ScoreOptions) -> Result<Accuracy> {
    score_with_covariances(survey, estimates, &HashMap::new(), opts)
}

/// [`score`] with each located target's covariance (m², map frame), by id:
/// they are reported per target and give the measurement intervals (which
/// need one for every scored target).
pub fn score_with_covariances(
    survey: &Survey,
    estimates: &[Estimate],
    covariances: &HashMap<String, [[f64; 3]; 3]>,
    opts: &ScoreOptions,
) -> Result<Accuracy> {
    let dim = opts.dim;
    let mut warnings = Vec::new();
    let mut m = Matched::new(survey, estimates, covariances, opts)?;
    let all_z = m.enough(survey, estimates, opts, &mut warnings)?;
    let al = align::fit(opts.method, &m.map, &m.survey)?;
    let aligned: Vec<Point> = m.map.iter().map(|p| al.apply(p)).collect();
    let abs: Vec<f64> = aligned
        .iter()
        .zip(&m.survey)
        .map(|(a, s)| dist(a, s, dim))
        .collect();
    let pairs = relative_errors(&m.ids, &m.map, &m.survey, dim);
    let rel: Vec<f64> = pairs.iter().map(|p| p.error).collect();
    // Honest errors.
    let loo = leave_one_out(opts.method, &m.map, &m.survey, dim);
    if loo.is_none() {
        warnings.push(Warning::LeaveOneOutTooFew {
            method: opts.method,
            n: m.used.len(),
        });
    }
    let sigma_hat = sigma_hat(&aligned, &m.survey, opts.method);
    for (j, &k) in m.used.iter().enumerate() {
        let t = &mut m.targets[k];
        t.aligned = Some(aligned[j]);
        t.aligned_has_z = all_z || opts.method.uses_z();
        t.abs_error = Some(abs[j]);
        t.loo_error = loo.as_ref().map(|l| l[j]);
    }
    let (control_check, check_residuals) = m.control_check(survey, opts, &mut warnings)?;
    // Heights are comparable when the fit corrected them or the map is already in the survey frame.
    let vertical = all_z && (opts.method.uses_z() || opts.method == AlignMethod::None);
    let residuals: Vec<Vector3<f64>> = aligned.iter().zip(&m.survey).map(|(a, s)| a - s).collect();
    let checkpoints = check_residuals.as_deref().unwrap_or(&residuals);
    let asprs = asprs::asprs(
        checkpoints,
        vertical,
        opts.survey_sigma,
        check_residuals.is_some(),
    );
    let iso19157 = super::iso19157::iso19157(checkpoints, vertical, opts.threshold);
    if all_z && !vertical {
        warnings.push(Warning::VerticalNotReported);
    }
    if vertical && opts.method == AlignMethod::None {
        warnings.extend(height_offset(&residuals));
    }
    let intervals = m.intervals(covariances, opts, !asprs.independent, &mut warnings);
    let gross = gross_errors(
        &m.ids,
        &abs,
        &residuals,
        &m.survey_covariances(&al),
        dim == Dim::D3 && all_z,
    );
    // Of the aligned positions: a fitted scale or a 3D fit's tilt is the
    // alignment's, not a misfit. Heights only where the errors are: a 2D
    // run leaves them unscored.
    // Heights are tested wherever the run reports them (RMSE_V under a 2D
    // dim too); an alignment that tilts leaves the others' fit to tilt.
    use super::blunder::Test;
    let test = if !(vertical || (dim == Dim::D3 && all_z)) {
        Test::Horizontal
    } else if matches!(
        opts.method,
        AlignMethod::Rigid3d | AlignMethod::Similarity3d
    ) {
        Test::HeightsTilted
    } else {
        Test::Heights
    };
    let misfits =
        super::blunder::left_out_misfits(&aligned, &m.survey, test, BLUNDER_M, BLUNDER_RATIO);
    let flagged = |id: &str| {
        gross
            .iter()
            .any(|w| matches!(w, Warning::GrossError { id: g, .. } if g == id))
    };
    let layout: Vec<Warning> = misfits
        .into_iter()
        .filter(|f| !flagged(&m.ids[f.k]))
        .map(|f| Warning::LayoutMisfit {
            id: m.ids[f.k].clone(),
            off: f.off,
            others_rms: f.others_rms,
            dz: f.dz,
        })
        .collect();
    warnings.extend(gross);
    warnings.extend(layout);
    let scale = layout_scale(
        &m.survey
            .iter()
            .zip(&m.map)
            .map(|(s, p)| ([s.x, s.y], [p.x, p.y]))
            .collect::<Vec<_>>(),
    );
    let n_used = m.used.len();
    Ok(Accuracy {
        scale,
        dim,
        fit: Fit {
            alignment: al,
            n_used,
        },
        targets: m.targets,
        absolute: summarize(&abs),
        relative: Relative {
            summary: summarize(&rel),
            pairs,
        },
        leave_one_out: loo.map(|l| HeldOut {
            summary: summarize(&l),
            targets: m.ids.iter().cloned().zip(l).collect(),
        }),
        control_check,
        sigma_hat,
        asprs,
        iso19157,
        survey_only: m.survey_only,
        estimates_only: m.estimates_only,
        intervals,
        warnings,
    })
}

/// The estimates matched to the survey by id: every surveyed target with
/// its status (survey order), and the located ones side by side.
struct Matched {
    targets: Vec<TargetScore>,
    /// Survey indices of the located targets, and their ids.
    used: Vec<usize>,
    ids: Vec<String>,
    /// The located targets' map and survey positions.
    map: Vec<Point>,
    survey: Vec<Point>,
    survey_only: Vec<String>,
    estimates_only: Vec<String>,
}

impl Matched {
    fn new(
        survey: &Survey,
        estimates: &[Estimate],
        covariances: &HashMap<String, [[f64; 3]; 3]>,
        opts: &ScoreOptions,
    ) -> Result<Matched> {
        let by_id: HashMap<&str, &Estimate> =
            estimates.iter().map(|e| (e.id.as_str(), e)).collect();
        let mut m = Matched {
            targets: Vec::new(),
            used: Vec::new(),
            ids: Vec::new(),
            map: Vec::new(),
            survey: Vec::new(),
            survey_only: Vec::new(),
            estimates_only: estimates
                .iter()
                .filter(|e| survey.get(&e.id).is_none())
                .map(|e| e.id.clone())
                .collect(),
        };
        for (k, st) in survey.targets.iter().enumerate() {
            let sp = st.reference();
            let base = TargetScore {
                id: st.id.clone(),
                status: Status::Ok,
                survey: sp,
                survey_has_z: st.has_z,
                map: None,
                map_has_z: false,
                aligned: None,
                aligned_has_z: false,
                abs_error: None,
                loo_error: None,
                role: st.role,
                map_covariance: None,
            };
            let status = |s: Status| TargetScore {
                status: s,
                ..base.clone()
            };
            let t = match by_id.get(st.id.as_str()).map(|e| (e, &e.status)) {
                None => {
                    m.survey_only.push(st.id.clone());
                    status(Status::NoEstimate)
                }
                Some((e, EstimateStatus::Found(p))) => {
                    if opts.dim == Dim::D3 && !(st.has_z && e.has_z) {
                        return Err(Error::Input(format!(
                            "target `{}`: 3D errors need z in both the survey and the estimates (use --dim 2d)",
                            st.id
                        )));
                    }
                    m.used.push(k);
                    m.ids.push(st.id.clone());
                    m.map.push(*p);
                    m.survey.push(sp);
                    TargetScore {
                        map: Some(*p),
                        map_has_z: e.has_z,
                        map_covariance: covariances
                            .get(&st.id)
                            .map(|c| opts.vertical.map_or(*c, |v| v.add_to(c, p))),
                        ..base
                    }
                }
                Some((_, EstimateStatus::NotFound { reason })) => {
                    status(Status::NotFound(reason.clone()))
                }
                Some((_, EstimateStatus::Excluded { reason })) => {
                    status(Status::Excluded(reason.clone()))
                }
                Some((_, EstimateStatus::Ambiguous { reason })) => {
                    status(Status::Ambiguous(reason.clone()))
                }
            };
            m.targets.push(t);
        }
        Ok(m)
    }

    /// Enough located targets for the alignment, with the heights it needs:
    /// whether every located target has z on both sides.
    fn enough(
        &self,
        survey: &Survey,
        estimates: &[Estimate],
        opts: &ScoreOptions,
        warnings: &mut Vec<Warning>,
    ) -> Result<bool> {
        if !self.survey_only.is_empty() {
            warnings.push(Warning::SurveyOnly(self.survey_only.clone()));
        }
        if !self.estimates_only.is_empty() {
            warnings.push(Warning::EstimatesOnly(self.estimates_only.clone()));
        }
        let n = self.used.len();
        let need = opts.method.min_points().max(2);
        if n < need {
            let mut msg = format!(
                "only {n} target(s) are both surveyed and located; at least {need} are needed for {} alignment",
                opts.method
            );
            let shared = estimates.iter().any(|e| survey.get(&e.id).is_some());
            if !shared && !estimates.is_empty() {
                let list = |ids: Vec<&str>| {
                    let more = if ids.len() > 5 { ", ..." } else { "" };
                    ids[..ids.len().min(5)].join(", ") + more
                };
                msg += &format!(
                    ": the ids differ (survey: {}; estimates: {})",
                    list(survey.targets.iter().map(|t| t.id.as_str()).collect()),
                    list(estimates.iter().map(|e| e.id.as_str()).collect())
                );
            }
            return Err(Error::Input(msg));
        }
        let all_z = self
            .used
            .iter()
            .all(|&k| self.targets[k].survey_has_z && self.targets[k].map_has_z);
        if opts.method.uses_z() && !all_z {
            return Err(Error::Input(format!(
                "alignment {} needs z in both the survey and the estimates",
                opts.method
            )));
        }
        if opts.dim == Dim::D3 && !opts.method.uses_z() && opts.method != AlignMethod::None {
            warnings.push(Warning::HeightDatumNotCorrected(opts.method));
        }
        Ok(all_z)
    }

    /// With roles in the survey, the alignment fitted to the control
    /// targets alone and the check targets' errors under it (and their
    /// residuals, for the survey-standard numbers).
    fn control_check(
        &self,
        survey: &Survey,
        opts: &ScoreOptions,
        warnings: &mut Vec<Warning>,
    ) -> Result<Split> {
        if !self.used.iter().any(|&k| survey.targets[k].role.is_some()) {
            return Ok((None, None));
        }
        let is_check = |j: usize| survey.targets[self.used[j]].role == Some(Role::Check);
        let n = self.used.len();
        let ctrl: Vec<usize> = (0..n).filter(|&j| !is_check(j)).collect();
        let chk: Vec<usize> = (0..n).filter(|&j| is_check(j)).collect();
        if chk.is_empty() {
            warnings.push(Warning::NoCheckTargets);
            return Ok((None, None));
        }
        if ctrl.len() < opts.method.min_points().max(2) {
            warnings.push(Warning::TooFewControls {
                n: ctrl.len(),
                method: opts.method,
            });
            return Ok((None, None));
        }
        let src: Vec<Point> = ctrl.iter().map(|&j| self.map[j]).collect();
        let dst: Vec<Point> = ctrl.iter().map(|&j| self.survey[j]).collect();
        let a = align::fit(opts.method, &src, &dst)?;
        let per: Vec<(String, f64)> = chk
            .iter()
            .map(|&j| {
                (
                    self.ids[j].clone(),
                    dist(&a.apply(&self.map[j]), &self.survey[j], opts.dim),
                )
            })
            .collect();
        let errs: Vec<f64> = per.iter().map(|t| t.1).collect();
        let residuals = chk
            .iter()
            .map(|&j| a.apply(&self.map[j]) - self.survey[j])
            .collect();
        let cc = ControlCheck {
            control: ctrl.iter().map(|&j| self.ids[j].clone()).collect(),
            fit: Fit {
                alignment: a,
                n_used: ctrl.len(),
            },
            check: HeldOut {
                summary: summarize(&errs),
                targets: per,
            },
        };
        Ok((Some(cc), Some(residuals)))
    }

    /// The headline numbers' intervals, from the located targets'
    /// covariances as given (the measurement's) and from the targets drawn
    /// again.
    fn intervals(
        &self,
        covariances: &HashMap<String, [[f64; 3]; 3]>,
        opts: &ScoreOptions,
        rmse_h: bool,
        warnings: &mut Vec<Warning>,
    ) -> Intervals {
        let covs: Option<Vec<Matrix3<f64>>> = self
            .ids
            .iter()
            .map(|id| {
                covariances
                    .get(id)
                    .map(|c| Matrix3::from_fn(|i, j| c[i][j]))
            })
            .collect();
        let intervals = intervals::intervals(&intervals::Inputs {
            method: opts.method,
            dim: opts.dim,
            ids: &self.ids,
            map: &self.map,
            survey: &self.survey,
            covariances: covs,
            vertical: opts.vertical,
            survey_sigma_h: opts.survey_sigma.map_or(0.0, |s| s.0),
            rmse_h,
        });
        if self.used.len() < intervals::MIN_TARGETS {
            warnings.push(Warning::TooFewForIntervals { n: self.used.len() });
        }
        intervals
    }

    /// Each located target's covariance as reported (the vertical's share
    /// included: the alignment does not absorb what it does to one target
    /// alone), turned into the survey frame by the alignment.
    fn survey_covariances(&self, al: &Alignment) -> Vec<Option<Matrix3<f64>>> {
        self.used
            .iter()
            .map(|&k| {
                self.targets[k].map_covariance.map(|c| {
                    let c = Matrix3::from_fn(|i, j| c[i][j]);
                    let r = al.rotation * al.scale;
                    r * c * r.transpose()
                })
            })
            .collect()
    }
}

/// A control/check split and its check targets' residuals.
type Split = (Option<ControlCheck>, Option<Vec<Vector3<f64>>>);

/// The residuals' standard error over the alignment's degrees of freedom
/// (horizontal unless the alignment fits heights).
fn sigma_hat(aligned: &[Point], survey: &[Point], method: AlignMethod) -> Option<SigmaHat> {
    let (d, sse) = if method.uses_z() {
        (
            3,
            aligned
                .iter()
                .zip(survey)
                .map(|(a, s)| (a - s).norm_squared())
                .sum::<f64>(),
        )
    } else {
        (
            2,
            aligned
                .iter()
                .zip(survey)
                .map(|(a, s)| (a - s).xy().norm_squared())
                .sum::<f64>(),
        )
    };
    let dof = (d * aligned.len()) as i64 - method.params() as i64;
    (dof > 0).then(|| SigmaHat {
        value: (sse / dof as f64).sqrt(),
        sse,
        dof: dof as usize,
    })
}

/// Least distance (m) from where a fit on the other targets places a
/// target called a blunder; it must also be over [`BLUNDER_RATIO`] × their
/// rms residual. An RTK survey's ±2 cm and a SLAM map's ±2 cm per axis:
/// a Monte Carlo of 5-8 targets over 100 m named a target with no blunder
/// 0.0-0.3 % of the time at 2 cm per axis, 0.3-2.9 % at 3 cm, and found a
/// 20 cm blunder 98-99 % of the time at 2 cm, 65-75 % at 3 cm, 100 % at
/// 5 mm; a 12 cm one 50-57 % at 2 cm (`bench/blunder_mc.py`; the
/// distances' test this replaced found 20 cm 56-78 %). A warning only:
/// `--exclude-outliers` leaves out what the covariance test names.
pub(crate) const BLUNDER_M: f64 = 0.10;

/// How many times the others' rms residual a blunder stands off.
const BLUNDER_RATIO: f64 = 5.0;

/// Heights compared as they are, all off by one amount of a metre or more
/// (their spread under a quarter of it): a datum's offset (ellipsoidal
/// against orthometric heights, 20-50 m in most places; a map's own zero),
/// which no map's error is.
fn height_offset(residuals: &[Vector3<f64>]) -> Option<Warning> {
    if residuals.len() < 2 {
        return None;
    }
    let dz = median(residuals.iter().map(|r| r.z).collect());
    let spread = 1.4826 * median(residuals.iter().map(|r| (r.z - dz).abs()).collect());
    (dz.abs() >= 1.0 && spread < 0.25 * dz.abs()).then_some(Warning::HeightOffset { dz, spread })
}

/// The median of `v` (the mean of the middle two for an even count).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        (v[m - 1] + v[m]) / 2.0
    }
}

/// χ²₂ 99.9 % quantile: −2 ln(0.001).
const CHI2_2_999: f64 = 13.815_510_557_964_274;
/// Robust z-score above which an error is far from the others.
const ROBUST_Z: f64 = 3.5;
/// And at least this many times their median: errors held tight about
/// their median (20-22 mm, MAD 1 mm) put a stretched map's end targets
/// (29 and 33 mm) at robust z 4-7, which is the map's error, not a
/// blunder (a new user's trial, rigid3d in 3D on a clean scene).
const GROSS_RATIO: f64 = 2.0;

/// Targets whose horizontal residual lies outside their own 99.9 % ellipse and
/// whose error is a robust outlier among the targets' errors (needs ≥ 5
/// targets: a median and MAD of fewer say little).
fn gross_errors(
    ids: &[String],
    errors: &[f64],
    residuals: &[Vector3<f64>],
    covs: &[Option<Matrix3<f64>>],
    d3: bool,
) -> Vec<Warning> {
    let n = errors.len();
    if n < 5 {
        return Vec::new();
    }
    let med = median(errors.to_vec());
    let mad = 1.4826 * median(errors.iter().map(|e| (e - med).abs()).collect());
    // A floor of 1 mm: identical errors would make any difference "infinitely" far.
    let scale = mad.max(1e-3);
    // Heights against the others': a datum no fit corrected is theirs too.
    let med_z = median(residuals.iter().map(|r| r.z).collect());
    let mut out = Vec::new();
    for j in 0..n {
        let z = (errors[j] - med) / scale;
        let Some(c) = covs[j] else { continue };
        let c2 = Matrix2::new(c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)]);
        let r = residuals[j].xy();
        let Some(inv) = c2.try_inverse() else {
            continue;
        };
        let m2 = (r.transpose() * inv * r)[(0, 0)];
        if z > ROBUST_Z && m2 > CHI2_2_999 && errors[j] > GROSS_RATIO * med {
            out.push(Warning::GrossError {
                id: ids[j].clone(),
                error: errors[j],
                sigma: ((c2[(0, 0)] + c2[(1, 1)]) / 2.0).max(0.0).sqrt(),
                robust_z: z,
                height: d3.then(|| (residuals[j].z - med_z, c[(2, 2)].max(0.0).sqrt(), r.norm())),
                after_exclusion: false,
            });
        }
    }
    out
}
