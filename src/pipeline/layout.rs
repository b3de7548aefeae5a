//! The targets against each other: a located object far from where all
//! the others put it, by the survey's distances, is a wrong object.

use super::target::{Failure, FarBy, TargetRun};
use crate::Point;
use crate::survey::Survey;

/// A target found far from where the others place it: (index, distance,
/// allowed, by how much).
pub(super) type Far = (usize, f64, f64, FarBy);

/// A map's distance between two targets may disagree with the survey's by
/// at most this much (m) plus [`LAYOUT_REL`] of the distance: LiDAR odometry
/// without loop closure drifts 0.5–2 % (KITTI's worst), a projection's grid
/// scale is within 0.5 %, a target's corner is known to centimetres; 5 %
/// leaves room for a map bent by a failed loop closure (a 3.5° heading error
/// at a turn is 3.5 % over the diagonal), which must be measured, not set
/// aside. Metres over tens of metres (a rock 4 m from a surveyed spot 30 m
/// from the next, a survey in feet) are a wrong object, position, id or unit.
pub(super) const LAYOUT_ABS_M: f64 = 0.3;
/// See [`LAYOUT_ABS_M`].
pub(super) const LAYOUT_REL: f64 = 0.05;

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
/// targets' median of it, which error). Three measures, each > 5 × the
/// median (the others' rms for the second) and > 0.3 m: the error under a
/// fit without the target, the distance from where a fit on the others
/// alone places it (the one whose leaving out lets them fit best), and
/// (with 4 or more found) the median misfit of its distances to the others
/// against the survey's. The second needs no alignment, so a wrong object that pulls
/// every fit it enters (4 targets, each 1-2 m off) is still singled out.
pub(super) fn far_from_others(
    found: &[TargetRun],
    survey: &Survey,
    opts: &crate::accuracy::ScoreOptions,
) -> Vec<Far> {
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
    // More than 0.3 m off is no map's error: a wrong object.
    for (k, e, median) in crate::accuracy::misfit_by_distances(&map, &surveyed, 0.3) {
        far.push((corners[k].0, e, median, FarBy::Distances));
    }
    // The target a fit on the others places far from its survey position
    // (the survey-blunder test with a wrong object's floor): a 0.5-1 m
    // survey typo among six pulls every fit it enters, so its own
    // leave-one-out error (984 mm) stayed under 5 × the others' (which it
    // inflates), and it stayed in the numbers as `ok`.
    // Not under a fitted scale: a stretched map's far end is the scale's.
    // Heights only where the run fits a height offset and no tilt (a map
    // left tilted, short of the levelling threshold, is rigid3d's to take).
    use crate::align::AlignMethod;
    if !matches!(
        opts.method,
        AlignMethod::Similarity2d | AlignMethod::Similarity3d
    ) {
        use crate::accuracy::blunder::{Test, left_out_misfits};
        let test = if d3 && opts.method == AlignMethod::Rigid2dZ && surveyed.iter().all(|s| s.1) {
            Test::Heights
        } else {
            Test::Horizontal
        };
        let refs: Vec<Point> = surveyed.iter().map(|s| s.0).collect();
        for m in left_out_misfits(&map, &refs, test, 0.3, 5.0) {
            let i = corners[m.k].0;
            if !far.iter().any(|f| f.0 == i) {
                far.push((i, m.off, m.others_rms, FarBy::OthersFit));
            }
        }
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
