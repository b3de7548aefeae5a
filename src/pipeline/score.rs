//! The found objects checked against the target and each other, then
//! scored.

use super::*;

/// Every located object checked against the physical target and against
/// the other targets: one still far from where the others place it, an
/// object claimed by two targets, a target mapped twice, a layout no map
/// bends to: each is set aside with its reason (and named in a warning), and
/// a height from plates seen in part gets the σ it deserves. Returns how
/// close two copies of a target may be and still be seen.
pub(super) fn check_found(
    found: &mut [TargetRun],
    survey: &Survey,
    opts: &ScoreOptions,
    far: &[super::layout::Far],
    warnings: &mut Vec<Warning>,
) -> Option<crate::locate::DoublingLimit> {
    // What is still far after the search is not the target.
    let mut wrong = Vec::new();
    // (A target found again close to the prediction is the object there:
    // its error is the map's or the survey's, and stays in the result.)
    for (i, error, median, by) in layout::far_from_others(found, survey, opts) {
        let searched = far.iter().any(|f| f.0 == i);
        if searched && found[i].pass == Pass::Second {
            continue;
        }
        if let Some(at) = found[i].corner() {
            found[i].outcome = Err(Failure::FarFromOthers {
                at,
                error,
                median,
                by,
                searched,
                row: None,
            });
        }
    }
    target::one_object_each(found);
    // A target mapped twice is neither copy: it leaves the fit, named.
    let (doubled, doubling) = target::check_doubled(found);
    if !doubled.is_empty() {
        warnings.push(Warning::Doubled(doubled));
    }
    // A height from plates seen in part is known only as well as the part.
    let widened = target::widen_heights(found);
    // ... and one on ground mapped twice only to within the copies.
    let lifted = target::widen_for_ground_copies(found);
    // Metres of disagreement with the survey's layout are no map's error,
    // however few targets were located.
    layout::off_layout(found, survey, opts);
    for (i, r) in found.iter().enumerate() {
        if matches!(
            r.outcome,
            Err(Failure::FarFromOthers { .. }
                | Failure::SameObject { .. }
                | Failure::OffLayout { .. })
        ) {
            wrong.push(survey.targets[i].id.clone());
        }
    }
    if !wrong.is_empty() {
        warnings.push(Warning::WrongObjects(wrong));
    }
    // Named only when still located (not set aside above).
    let still = |id: &str| found.iter().any(|r| r.id == id && r.outcome.is_ok());
    let widened: Vec<_> = widened.into_iter().filter(|w| still(&w.0)).collect();
    let lifted: Vec<_> = lifted.into_iter().filter(|w| still(&w.0)).collect();
    if !lifted.is_empty() {
        warnings.push(Warning::GroundDoubled {
            ids: lifted.iter().map(|w| w.0.clone()).collect(),
            separation_m: lifted
                .iter()
                .map(|w| w.1)
                .fold((f64::INFINITY, 0.0), |(a, b), s| (a.min(s), b.max(s))),
            sigma_m: lifted.iter().map(|w| w.2).fold(0.0, f64::max),
        });
    }
    // A span taller than a plate on ground mapped twice is the seam's (its
    // σ holds both): not asked about as the plates' size.
    let widened: Vec<_> = widened
        .into_iter()
        .filter(|w| w.1.fits() || !lifted.iter().any(|l| l.0 == w.0))
        .collect();
    // Spans short of a plate and spans taller than one have different
    // causes, named apart.
    let located = found.iter().filter(|r| r.outcome.is_ok()).count();
    for taller in [false, true] {
        let group: Vec<_> = widened.iter().filter(|w| w.1.fits() != taller).collect();
        if group.is_empty() {
            continue;
        }
        warnings.push(Warning::HeightsUncertain {
            ids: group.iter().map(|w| w.0.clone()).collect(),
            seen_m: group
                .iter()
                .map(|w| match taller {
                    true => w.1.seen_m,
                    false => w.1.seen_m.min(w.1.plate_height_m),
                })
                .fold((f64::INFINITY, 0.0), |(a, b), s| (a.min(s), b.max(s))),
            plate_height_m: group.iter().map(|w| w.1.plate_height_m).fold(0.0, f64::max),
            sigma_m: group.iter().map(|w| w.2).fold(0.0, f64::max),
            taller,
            every: group.len() >= 3
                && if taller {
                    2 * group.len() >= located
                } else {
                    group.len() == located
                },
        });
    }
    doubling
}

/// The errors of the located targets, each weighed by its covariance; with
/// `metrics.exclude_outliers`, again without the gross errors, which stay in
/// the result as excluded, with the numbers that condemned them.
pub(super) fn score(
    found: &[TargetRun],
    survey: &Survey,
    opts: &ScoreOptions,
    cfg: &Config,
    warnings: &mut Vec<Warning>,
) -> Result<Accuracy> {
    let covariances = found
        .iter()
        .filter_map(|r| {
            r.outcome
                .as_ref()
                .ok()
                .map(|f| (r.id.clone(), f.located.covariance))
        })
        .collect();
    let mut est = estimates(found);
    let mut accuracy = accuracy::score_with_covariances(survey, &est, &covariances, opts)?;
    if cfg.metrics.exclude_outliers {
        // Refit without the gross errors, each kept in the result as excluded
        // with the numbers that condemned it: never dropped silently.
        let gross: Vec<(String, String)> = accuracy
            .warnings
            .iter()
            .filter_map(|w| match w {
                accuracy::Warning::GrossError {
                    id,
                    error,
                    robust_z,
                    ..
                } => Some((
                    id.clone(),
                    format!(
                        "excluded as a gross error (--exclude-outliers): error {:.0} mm, robust z {robust_z:.1}",
                        error * 1e3
                    ),
                )),

                _ => None,
            })
            .collect();
        if !gross.is_empty() {
            for e in &mut est {
                if let Some((_, why)) = gross.iter().find(|g| g.0 == e.id) {
                    e.status = EstimateStatus::Excluded {
                        reason: why.clone(),
                    };
                }
            }
            accuracy = accuracy::score_with_covariances(survey, &est, &covariances, opts)?;
            // One round only: what the refit condemns stays, and says so.
            for w in &mut accuracy.warnings {
                if let accuracy::Warning::GrossError {
                    after_exclusion, ..
                } = w
                {
                    *after_exclusion = true;
                }
            }
            warnings.push(Warning::OutliersExcluded(
                gross.into_iter().map(|g| g.0).collect(),
            ));
        }
    }
    Ok(accuracy)
}

/// The located corners as estimates for [`accuracy::score`].
pub(super) fn estimates(found: &[TargetRun]) -> Vec<Estimate> {
    found
        .iter()
        .map(|r| Estimate {
            id: r.id.clone(),
            status: match &r.outcome {
                Ok(f) => EstimateStatus::Found(f.located.corner),
                Err(e @ Failure::Doubled(_)) => EstimateStatus::Ambiguous {
                    reason: e.to_string(),
                },
                Err(e) => EstimateStatus::NotFound {
                    reason: e.to_string(),
                },
            },
            has_z: true,
        })
        .collect()
}
