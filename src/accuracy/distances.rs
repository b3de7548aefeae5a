//! Which position disagrees with the others' layout: the distances between
//! positions need no alignment, so one bad position cannot hide by pulling
//! the fit (a wrong object in `pipeline::layout`; a survey blunder is
//! [`super::blunder`]'s, which also sees one across the lines to the others).

use crate::Point;

/// The position (in the map) whose distances to the others disagree with
/// the survey's: (index, its median misfit, the others' median misfit), when
/// its misfit is > 5 × the others' and > `floor` (m). Each position is tried as the
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
pub(crate) fn misfit_by_distances(
    map: &[Point],
    survey: &[(Point, bool)],
    floor: f64,
) -> Vec<(usize, f64, f64)> {
    let mut left: Vec<usize> = (0..map.len()).collect();
    let mut out = Vec::new();
    while left.len() >= 4 {
        let m: Vec<Point> = left.iter().map(|&i| map[i]).collect();
        let s: Vec<(Point, bool)> = left.iter().map(|&i| survey[i]).collect();
        let Some((k, own, others)) = one_by_distances(&m, &s, floor) else {
            break;
        };
        out.push((left.remove(k), own, others));
    }
    out.sort_by_key(|f| f.0);
    out
}

/// One round of [`misfit_by_distances`]: the worst position, if it stands out.
fn one_by_distances(
    map: &[Point],
    survey: &[(Point, bool)],
    floor: f64,
) -> Option<(usize, f64, f64)> {
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
    (own > 5.0 * others && own > floor).then_some((k, own, others))
}

#[cfg(test)]
mod tests {
    use super::misfit_by_distances;
    /// The wrong-object floor of `pipeline::layout`.
    const WRONG: f64 = 0.3;
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
        let far = misfit_by_distances(&map, &survey, WRONG);
        assert_eq!(far.len(), 1, "{far:?}");
        assert_eq!(far[0].0, 2);
        assert!(far[0].1 > 0.5 && far[0].2 < 0.05, "{far:?}");
        // Four targets are enough; three are not.
        assert_eq!(misfit_by_distances(&map[1..], &survey[1..], WRONG)[0].0, 1);
        assert!(misfit_by_distances(&map[2..], &survey[2..], WRONG).is_empty());
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
            let far = misfit_by_distances(&m, &s, WRONG);
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
        let far = misfit_by_distances(&map, &survey, WRONG);
        let which: Vec<usize> = far.iter().map(|f| f.0).collect();
        assert_eq!(which, vec![1, 4], "{far:?}");
        // One wrong among six: only that one.
        let (map, survey) = scene_of(&SURVEY, 1.0, Some(3));
        let far = misfit_by_distances(&map, &survey, WRONG);
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
            assert!(
                misfit_by_distances(&map, &survey, WRONG).is_empty(),
                "{scale}"
            );
        }
    }
}
