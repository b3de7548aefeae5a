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
/// targets' median of it, which error). Two measures, each > 5 × the median
/// and > 0.3 m: the error under a fit without the target, and (with 4 or
/// more found) the median misfit of its distances to the others against the
/// survey's. The second needs no alignment, so a wrong object that pulls
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
    for (k, e, median) in misfit_by_distances(&map, &surveyed) {
        far.push((corners[k].0, e, median, FarBy::Distances));
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

/// The position (in the map) whose distances to the others disagree with
/// the survey's: (index, its median misfit, the others' median misfit), when
/// its misfit is > 5 × the others' and > 0.3 m. Each position is tried as the
/// suspect: the common scale (a projection's grid scale, a map's scale drift,
/// within ±0.5 %) is the median ratio over the pairs without it, and the
/// suspect is the one whose removal leaves the others agreeing best (least
/// sum of squared pair misfits). A scale taken over every pair may be the
/// wrong object's own: with four targets, half the pairs are its. Once one
/// is singled out it is set aside and the rest are tried again, while 4
/// remain: the others' misfits are a lower median, so with two wrong among
/// six the first pass still sees the good pairs. Distances are 3D where both
/// flags say so, else horizontal. Needs 4 positions: with 3, a wrong one and
/// a right one share as many bad pairs.
fn misfit_by_distances(map: &[Point], survey: &[(Point, bool)]) -> Vec<(usize, f64, f64)> {
    let mut left: Vec<usize> = (0..map.len()).collect();
    let mut out = Vec::new();
    while left.len() >= 4 {
        let m: Vec<Point> = left.iter().map(|&i| map[i]).collect();
        let s: Vec<(Point, bool)> = left.iter().map(|&i| survey[i]).collect();
        let Some((k, own, others)) = one_by_distances(&m, &s) else {
            break;
        };
        out.push((left.remove(k), own, others));
    }
    out.sort_by_key(|f| f.0);
    out
}

/// One round of [`misfit_by_distances`]: the worst position, if it stands out.
fn one_by_distances(map: &[Point], survey: &[(Point, bool)]) -> Option<(usize, f64, f64)> {
    let n = map.len();
    if n < 4 {
        return None;
    }
    // Differences first, so UTM-sized coordinates are never squared.
    let dist = |a: &Point, b: &Point, z: bool| {
        let d = a - b;
        if z { d.norm() } else { d.xy().norm() }
    };
    let mut pairs = vec![vec![(0.0, 0.0); n]; n];
    for i in 0..n {
        for j in i + 1..n {
            let z = survey[i].1 && survey[j].1;
            let p = (
                dist(&map[i], &map[j], z),
                dist(&survey[i].0, &survey[j].0, z),
            );
            pairs[i][j] = p;
            pairs[j][i] = p;
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[(v.len() - 1) / 2]
    };
    // Suspect k: the scale and the misfits of the pairs without it; the
    // suspect whose pairs' squared misfits sum least leaves the others
    // agreeing best.
    let without = |k: usize| {
        let rest: Vec<(f64, f64)> = (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .filter(|&(i, j)| i != k && j != k)
            .map(|(i, j)| pairs[i][j])
            .collect();
        let ratios: Vec<f64> = rest
            .iter()
            .filter(|p| p.1 > 1.0)
            .map(|p| p.0 / p.1)
            .collect();
        let scale = if ratios.is_empty() {
            1.0
        } else {
            median(ratios).clamp(0.995, 1.005)
        };
        let res: Vec<f64> = rest.iter().map(|p| (p.0 - scale * p.1).abs()).collect();
        let score: f64 = res.iter().map(|r| r * r).sum();
        let own = median(
            (0..n)
                .filter(|&j| j != k)
                .map(|j| (pairs[k][j].0 - scale * pairs[k][j].1).abs())
                .collect(),
        );
        (score, median(res), own)
    };
    let (k, (_, others, own)) = (0..n)
        .map(|k| (k, without(k)))
        .min_by(|a, b| a.1.0.total_cmp(&b.1.0).then(a.0.cmp(&b.0)))
        .expect("n >= 4");
    (own > 5.0 * others && own > 0.3).then_some((k, own, others))
}

#[cfg(test)]
mod distance_tests {
    use super::misfit_by_distances;
    use crate::Point;

    /// Five targets over ~300 m; the map is the survey turned, moved and
    /// scaled by `scale`, with target `wrong` (if any) moved 1.5 m.
    fn scene(scale: f64, wrong: Option<usize>) -> (Vec<Point>, Vec<(Point, bool)>) {
        scene_of(&SURVEY[..5], scale, wrong)
    }

    const SURVEY: [(f64, f64, f64); 6] = [
        (352_000.0, 4_026_000.0, 50.0),
        (352_120.0, 4_026_030.0, 51.0),
        (352_200.0, 4_026_210.0, 49.5),
        (351_950.0, 4_026_280.0, 50.5),
        (352_060.0, 4_026_120.0, 50.2),
        (352_150.0, 4_026_330.0, 50.0),
    ];

    fn scene_of(
        s: &[(f64, f64, f64)],
        scale: f64,
        wrong: Option<usize>,
    ) -> (Vec<Point>, Vec<(Point, bool)>) {
        let (c, sn) = (1.1f64.cos(), 1.1f64.sin());
        let map = s
            .iter()
            .enumerate()
            .map(|(i, &(x, y, z))| {
                let (x, y) = (x - 352_000.0, y - 4_026_000.0);
                let mut p = Point::new(
                    scale * (c * x - sn * y) + 10.0,
                    scale * (sn * x + c * y) - 5.0,
                    z - 48.0,
                );
                if wrong == Some(i) {
                    p.x += 1.2;
                    p.y -= 0.9;
                }
                p
            })
            .collect();
        let survey = s
            .iter()
            .map(|&(x, y, z)| (Point::new(x, y, z), true))
            .collect();
        (map, survey)
    }

    #[test]
    fn a_wrong_object_is_singled_out_by_its_distances() {
        let (map, survey) = scene(1.0, Some(2));
        let far = misfit_by_distances(&map, &survey);
        assert_eq!(far.len(), 1, "{far:?}");
        assert_eq!(far[0].0, 2);
        assert!(far[0].1 > 0.5 && far[0].2 < 0.05, "{far:?}");
        // Four targets are enough; three are not.
        assert_eq!(misfit_by_distances(&map[1..], &survey[1..])[0].0, 1);
        assert!(misfit_by_distances(&map[2..], &survey[2..]).is_empty());
    }

    /// Layouts where a scale taken over every pair is the wrong object's own
    /// (found in review): the wrong one must be the one singled out.
    #[test]
    fn a_wrong_object_does_not_set_the_scale() {
        let check = |survey: &[(f64, f64)], wrong: usize, shift: (f64, f64)| {
            let s: Vec<(Point, bool)> = survey
                .iter()
                .map(|&(x, y)| (Point::new(x, y, 0.0), false))
                .collect();
            let mut m: Vec<Point> = s.iter().map(|p| p.0).collect();
            m[wrong].x += shift.0;
            m[wrong].y += shift.1;
            let far = misfit_by_distances(&m, &s);
            assert_eq!(far.len(), 1, "{far:?}");
            assert_eq!(far[0].0, wrong, "{far:?}");
        };
        check(
            &[(314.8, 76.6), (320.9, 76.5), (32.6, 342.1), (344.5, 350.6)],
            2,
            (-1.87, -0.47),
        );
        check(
            &[(0.0, 0.0), (250.0, 0.0), (250.0, 250.0), (0.0, 250.0)],
            2,
            (1.0, 1.0),
        );
    }

    /// Two wrong objects among six (the hole left by one suspect per run).
    #[test]
    fn two_wrong_objects_among_six_are_both_singled_out() {
        let (mut map, survey) = scene_of(&SURVEY, 1.0, Some(1));
        map[4].x -= 1.8;
        let far = misfit_by_distances(&map, &survey);
        let which: Vec<usize> = far.iter().map(|f| f.0).collect();
        assert_eq!(which, vec![1, 4], "{far:?}");
        // One wrong among six: only that one.
        let (map, survey) = scene_of(&SURVEY, 1.0, Some(3));
        let far = misfit_by_distances(&map, &survey);
        assert_eq!(
            far.iter().map(|f| f.0).collect::<Vec<_>>(),
            vec![3],
            "{far:?}"
        );
    }

    #[test]
    fn a_right_map_or_a_scaled_one_condemns_nothing() {
        for scale in [1.0, 0.9996, 1.003] {
            let (map, survey) = scene(scale, None);
            assert!(misfit_by_distances(&map, &survey).is_empty(), "{scale}");
        }
    }
}
