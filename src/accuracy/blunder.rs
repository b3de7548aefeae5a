//! A survey blunder: the target a fit on the other targets does not place.
//! A blunder of a few decimetres among five targets pulls a fit on all of
//! them so far that its own error no longer stands out, and the others'
//! errors grow with it; left out, the others fit each other to their noise
//! and the blunder shows at its whole size. Distances between targets need
//! no fit either ([`super::distances`]), but they see only the part of a
//! blunder along the lines to the others: a Monte Carlo found a 20 cm
//! blunder by its distances 56-70 % of the time at 2 cm of noise per axis
//! and 59-78 % at 5 mm, by this test 98-99 % and 100 %, with as few false
//! alarms (`bench/blunder_mc.py`).

use crate::Point;
use crate::align::{AlignMethod, fit};
use nalgebra::Vector3;

/// Fewest targets the test runs on: three left to fit (three parameters,
/// six coordinates) when one is left out. With four, the three left
/// extrapolate to the fourth, and their rms is itself a rough guess: the
/// distance is then weighed by how far the fourth lies from their middle
/// (`bench/blunder_mc.py`: at 2 cm of noise per axis, 1.5 % false alarms
/// unweighed, none weighed; a 20 cm blunder found 93 % of the time).
pub(crate) const MIN_TARGETS: usize = 4;

/// Below this many targets left, a left-out distance is weighed by its
/// leverage (see [`MIN_TARGETS`]); from five on, the test as measured.
const WEIGH_BELOW: usize = 5;

/// One target the others' fit does not place.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Misfit {
    /// Its index.
    pub k: usize,
    /// Its distance from where the others' fit places it (m).
    pub off: f64,
    /// The others' rms residual in that fit (m).
    pub others_rms: f64,
    /// The height part of that distance (m, map less survey), in 3D.
    pub dz: Option<f64>,
}

/// How the left-out test fits and measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Test {
    /// Horizontal: a rigid 2D fit, horizontal distances.
    Horizontal,
    /// A run that scores heights (an antenna height's typo is a blunder
    /// too): yaw and a 3D shift, 3D distances.
    Heights,
    /// Heights, in a run whose alignment tilts (rigid3d, similarity3d):
    /// a blunder's pull on that tilt is the others' to undo, so their fit
    /// tilts too; its rms is then per coordinate left over, and the
    /// left-out distance weighed by its leverage, however many targets.
    HeightsTilted,
}

/// The targets (index, distance from where a rigid fit on the others places
/// it, those others' rms residual; m) that stand out: over `floor` and over
/// `ratio` × the others' rms, measured as `test` says. `aligned` are the map's
/// positions already in the survey's frame, so the fit only takes up what
/// the blunder pulled. The suspect is the target whose leaving out lets the
/// others fit each other best; once one is named it is set aside and the
/// rest tried again while [`MIN_TARGETS`] remain.
pub(crate) fn left_out_misfits(
    aligned: &[Point],
    survey: &[Point],
    test: Test,
    floor: f64,
    ratio: f64,
) -> Vec<Misfit> {
    let mut left: Vec<usize> = (0..aligned.len().min(survey.len())).collect();
    let mut out = Vec::new();
    while left.len() >= MIN_TARGETS {
        let Some((k, off, rms, dz)) = suspect(aligned, survey, &left, test) else {
            break;
        };
        let weighed = if left.len() < WEIGH_BELOW || test == Test::HeightsTilted {
            off / (1.0 + leverage(survey, &left, k)).sqrt()
        } else {
            off
        };
        if !(weighed > floor && off > ratio * rms) {
            break;
        }
        out.push(Misfit {
            k: left.remove(k),
            off,
            others_rms: rms,
            dz: (test != Test::Horizontal).then_some(dz),
        });
    }
    out.sort_by_key(|f| f.k);
    out
}

/// How much a rigid 2D fit on `left` less its `k`th moves where it places
/// that one, per unit of their scatter: 1/m for the shift, and for the turn
/// its squared distance from their middle over their spread, halved (the
/// turn moves it across that line only).
fn leverage(survey: &[Point], left: &[usize], k: usize) -> f64 {
    let rest: Vec<&Point> = left
        .iter()
        .enumerate()
        .filter(|&(j, _)| j != k)
        .map(|(_, &i)| &survey[i])
        .collect();
    let m = rest.len() as f64;
    let (cx, cy) = (
        rest.iter().map(|p| p.x).sum::<f64>() / m,
        rest.iter().map(|p| p.y).sum::<f64>() / m,
    );
    let spread: f64 = rest
        .iter()
        .map(|p| (p.x - cx).powi(2) + (p.y - cy).powi(2))
        .sum();
    let me = &survey[left[k]];
    let d2 = (me.x - cx).powi(2) + (me.y - cy).powi(2);
    1.0 / m
        + if spread > 0.0 {
            d2 / (2.0 * spread)
        } else {
            0.0
        }
}

/// Of `left`, the one (its place in `left`) whose leaving out lets the
/// others fit best: with its distance from the others' fit, their rms and
/// its height part.
fn suspect(
    aligned: &[Point],
    survey: &[Point],
    left: &[usize],
    test: Test,
) -> Option<(usize, f64, f64, f64)> {
    let (method, norm): (AlignMethod, fn(Vector3<f64>) -> f64) = match test {
        Test::Horizontal => (AlignMethod::Rigid2d, |d| d.xy().norm()),
        Test::Heights => (AlignMethod::Rigid2dZ, |d| d.norm()),
        Test::HeightsTilted => (AlignMethod::Rigid3d, |d| d.norm()),
    };
    let mut best: Option<(usize, f64, f64, f64)> = None;
    for (k, &i) in left.iter().enumerate() {
        let rest: Vec<usize> = left.iter().copied().filter(|&j| j != i).collect();
        let src: Vec<Point> = rest.iter().map(|&j| aligned[j]).collect();
        let dst: Vec<Point> = rest.iter().map(|&j| survey[j]).collect();
        let Ok(a) = fit(method, &src, &dst) else {
            continue;
        };
        let sse: f64 = src
            .iter()
            .zip(&dst)
            .map(|(p, q)| norm(a.apply(p) - q).powi(2))
            .sum();
        // A tilting fit takes two more parameters from few targets, most
        // near one line along a road: their rms is of the coordinates
        // left over (3m − 6), or it is too small and a far end's
        // extrapolated height stands out (a clean scene's 114 mm against
        // 22 mm, seed 16, found by review).
        let rms = match test {
            Test::HeightsTilted => (sse / (rest.len() as f64 - 2.0).max(1.0)).sqrt(),
            _ => (sse / rest.len() as f64).sqrt(),
        };
        let d = a.apply(&aligned[i]) - survey[i];
        if best.is_none_or(|b| rms < b.2) {
            best = Some((k, norm(d), rms, d.z));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Five to eight targets over 100 m, each off by a few centimetres: one
    /// moved 20 cm across the lines to its neighbours (where its distances
    /// barely change) is named with its size; none, or 3 cm, is not.
    #[test]
    fn a_blunder_across_the_layout_is_named() {
        let survey: Vec<Point> = [
            (0.0, 0.0),
            (50.0, 10.0),
            (100.0, 0.0),
            (20.0, 60.0),
            (80.0, 70.0),
            (50.0, 100.0),
        ]
        .iter()
        .map(|&(x, y)| Point::new(x + 352_000.0, y + 4_150_000.0, 40.0))
        .collect();
        let noise = [
            (0.012, -0.008),
            (-0.015, 0.01),
            (0.004, 0.017),
            (-0.009, -0.014),
            (0.016, 0.003),
            (-0.006, -0.011),
        ];
        let moved = |b: f64| -> Vec<Point> {
            survey
                .iter()
                .zip(&noise)
                .enumerate()
                .map(|(i, (p, n))| {
                    // Target 1 (50, 10): moved along y, across its lines to 0 and 2.
                    let extra = if i == 1 { b } else { 0.0 };
                    Point::new(p.x + n.0, p.y + n.1 + extra, p.z)
                })
                .collect()
        };
        let found = left_out_misfits(&moved(0.2), &survey, Test::Horizontal, 0.10, 5.0);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].k, 1);
        assert!((found[0].off - 0.2).abs() < 0.05, "{found:?}");
        assert!(found[0].others_rms < 0.03, "{found:?}");
        for b in [0.0, 0.03] {
            assert!(left_out_misfits(&moved(b), &survey, Test::Horizontal, 0.10, 5.0).is_empty());
        }
        // Four targets: the three left extrapolate, and still name it;
        // three: nothing to tell a blunder by.
        let found = left_out_misfits(&moved(0.25)[..4], &survey[..4], Test::Horizontal, 0.10, 5.0);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].k, 1);
        assert!(
            left_out_misfits(&moved(0.03)[..4], &survey[..4], Test::Horizontal, 0.10, 5.0)
                .is_empty()
        );
        assert!(
            left_out_misfits(&moved(0.25)[..3], &survey[..3], Test::Horizontal, 0.10, 5.0)
                .is_empty()
        );
        // An antenna height typed 25 cm off: seen only in 3D.
        let mut high = moved(0.0);
        high[4].z += 0.25;
        assert!(left_out_misfits(&high, &survey, Test::Horizontal, 0.10, 5.0).is_empty());
        let found = left_out_misfits(&high, &survey, Test::Heights, 0.10, 5.0);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].k, 4);
        assert!((found[0].dz.unwrap() - 0.25).abs() < 0.03, "{found:?}");
        // Under a rigid3d alignment the blunder tilts the fit on all six;
        // the others' fit tilts back and still names it.
        let al = fit(AlignMethod::Rigid3d, &high, &survey).unwrap();
        let tilted: Vec<Point> = high.iter().map(|p| al.apply(p)).collect();
        let found = left_out_misfits(&tilted, &survey, Test::HeightsTilted, 0.10, 5.0);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].k, 4);
        assert!((found[0].off - 0.25).abs() < 0.03, "{found:?}");
    }
}
