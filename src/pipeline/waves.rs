//! Dense targets wait for the frame the others give (issue 29).
//!
//! A target's first search covers the whole error of the frame guess
//! (`tight.search_radius`, 4.5 m): in a dense crop that is a hundred L-finder
//! windows over whatever stands near it (a car, a wall, a stack), most of the
//! first pass's time. Once three or more lighter targets are located and agree
//! with the survey, the guess's error at a dense target is that fit's error,
//! so the dense one is searched only where the fit puts it: its corner
//! within what a map's distortion allows between neighbouring targets
//! (`layout`'s 0.3 m + 5 % of the distance to the nearest located one, at
//! least 0.5 m), its points a plate further. An object beyond that would be
//! set aside later as far from the others, so nothing the run could keep is
//! lost; a target not found there is searched as before, over the whole
//! radius. Only Ls wait: the cost is the L finder's windows.

use super::layout::{LAYOUT_ABS_M, LAYOUT_REL};
use crate::Point;
use crate::align::{self, AlignMethod, Alignment};
use crate::survey::Survey;

/// A crop holding more than this many times the survey's median crop's points
/// waits: its finder's windows hold as many times more points.
const DENSE_OVER_MEDIAN: usize = 2;
/// A crop of fewer points never waits: it costs little wherever it is.
const DENSE_MIN_POINTS: usize = 100_000;
/// Located targets a prediction needs: a rigid fit passes through two
/// whatever they are, so only a third can show that they agree.
const MIN_LOCATED: usize = 3;
/// The corner's allowed distance from the fit's place is at least this (m).
const MIN_ALLOWED_M: f64 = 0.5;

/// Which targets wait, by their loose crops' point counts: those over
/// [`DENSE_OVER_MEDIAN`] × the median and [`DENSE_MIN_POINTS`], when at
/// least [`MIN_LOCATED`] others do not (else none waits).
pub(super) fn dense(sizes: &[usize]) -> Vec<bool> {
    let mut sorted = sizes.to_vec();
    sorted.sort_unstable();
    let Some(&median) = sorted.get(sorted.len() / 2) else {
        return Vec::new();
    };
    let late: Vec<bool> = sizes
        .iter()
        .map(|&n| n > DENSE_MIN_POINTS && n > DENSE_OVER_MEDIAN * median)
        .collect();
    if late.iter().filter(|&&l| !l).count() < MIN_LOCATED {
        return vec![false; sizes.len()];
    }
    late
}

/// The map → survey fit of the targets located first, trusted only when
/// every one of them lies within [`LAYOUT_ABS_M`] of it.
pub(super) struct FirstFit {
    /// Survey → map.
    to_map: Alignment,
    /// The located targets: (index, corner in the map).
    located: Vec<(usize, Point)>,
}

impl FirstFit {
    /// The fit of `located` (index, corner) to the survey, when there are
    /// [`MIN_LOCATED`] or more and they agree with it.
    pub(super) fn of(located: Vec<(usize, Point)>, survey: &Survey) -> Option<Self> {
        if located.len() < MIN_LOCATED {
            return None;
        }
        let map: Vec<Point> = located.iter().map(|l| l.1).collect();
        let surveyed: Vec<Point> = located
            .iter()
            .map(|l| survey.targets[l.0].reference())
            .collect();
        let fit = align::fit(AlignMethod::Rigid2d, &map, &surveyed).ok()?;
        let agree = map
            .iter()
            .zip(&surveyed)
            .all(|(m, s)| (fit.apply(m) - s).xy().norm() <= LAYOUT_ABS_M);
        agree.then(|| FirstFit {
            to_map: fit.inverse(),
            located,
        })
    }

    /// Where the fit puts target `i` in the map (horizontally; the height is
    /// `expected`'s, as the first search's).
    pub(super) fn predict(&self, survey: &Survey, i: usize, expected: &Point) -> Point {
        let p = self.to_map.apply(&survey.targets[i].reference());
        Point::new(p.x, p.y, expected.z)
    }

    /// Where and how far to search for target `i`: its prediction, and the
    /// distortion allowed over the distance to the nearest located target (at
    /// least [`MIN_ALLOWED_M`]) plus `reach` (the target's plates reach that
    /// far from its corner), below `full`. `None` when that disc does not
    /// lie inside the loose crop about `expected` (radius `loose`): then it
    /// is searched as the others were.
    pub(super) fn narrowed(
        &self,
        survey: &Survey,
        i: usize,
        expected: &Point,
        reach: f64,
        (full, loose): (f64, f64),
    ) -> Option<(Point, f64)> {
        let at = self.predict(survey, i, expected);
        let me = survey.targets[i].reference();
        let nearest = self
            .located
            .iter()
            .map(|l| (survey.targets[l.0].reference() - me).xy().norm())
            .fold(f64::INFINITY, f64::min);
        let radius = (LAYOUT_ABS_M + LAYOUT_REL * nearest).max(MIN_ALLOWED_M) + reach;
        let inside = (at - expected).xy().norm() + radius <= loose;
        (radius < full && inside).then_some((at, radius))
    }

    /// Where every other target is for target `i`'s search: located, or
    /// predicted.
    pub(super) fn others(&self, survey: &Survey, i: usize, expected: &[Point]) -> Vec<Point> {
        (0..expected.len())
            .filter(|&j| j != i)
            .map(|j| match self.located.iter().find(|l| l.0 == j) {
                Some(l) => l.1,
                None => self.predict(survey, j, &expected[j]),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_crops_far_denser_than_most_wait() {
        let k = 1000;
        assert_eq!(
            dense(&[489 * k, 125 * k, 87 * k, 205 * k, 63 * k]),
            [true, false, false, false, false]
        );
        // Small crops never wait, however they compare.
        assert_eq!(dense(&[90 * k, 10 * k, 10 * k, 10 * k]), [false; 4]);
        // Too few others to fix the frame first.
        assert_eq!(dense(&[500 * k, 10 * k, 10 * k]), [false; 3]);
        assert_eq!(dense(&[]), Vec::<bool>::new());
    }

    /// A map turned 1° and moved 2 m from a survey's frame: four targets
    /// located first place the fifth to the millimetre and search it within
    /// 0.3 m + 5 % of the 27 m to its nearest, plus a plate; one of the four
    /// half a metre off, and no place is trusted.
    #[test]
    fn the_first_targets_place_the_rest_when_they_agree() {
        let at = [
            (0.0, 0.0),
            (25.0, 10.0),
            (50.0, -10.0),
            (75.0, 5.0),
            (100.0, -15.0),
        ];
        let survey = Survey::local(
            &at.iter().map(|&(x, y)| (x, y, 1.0)).collect::<Vec<_>>(),
            true,
        );
        let (s, c) = 1f64.to_radians().sin_cos();
        let to_map = |p: Point| Point::new(c * p.x - s * p.y + 1.5, s * p.x + c * p.y - 1.3, p.z);
        let map: Vec<Point> = survey
            .targets
            .iter()
            .map(|t| to_map(t.reference()))
            .collect();
        let located: Vec<(usize, Point)> = (1..5).map(|i| (i, map[i])).collect();
        let fit = FirstFit::of(located.clone(), &survey).expect("they agree");
        let expected = survey.targets[0].reference();
        let (place, radius) = fit
            .narrowed(&survey, 0, &expected, 0.6, (4.5, 5.0))
            .unwrap();
        assert!((place - map[0]).xy().norm() < 1e-9);
        assert_eq!(place.z, expected.z);
        let nearest = (25f64).hypot(10.0);
        assert!((radius - (0.3 + 0.05 * nearest + 0.6)).abs() < 1e-9);
        // The disc must lie in the loose crop about the first guess (2 m off).
        assert!(
            fit.narrowed(&survey, 0, &expected, 0.6, (4.5, 3.5))
                .is_none()
        );
        // Nor be as wide as the whole search.
        assert!(
            fit.narrowed(&survey, 0, &expected, 0.6, (2.0, 5.0))
                .is_none()
        );
        let others = fit.others(&survey, 0, &[expected; 5]);
        assert_eq!(others, map[1..]);

        let mut off = located.clone();
        off[2].1.x += 0.5;
        assert!(FirstFit::of(off, &survey).is_none());
        assert!(FirstFit::of(located[..2].to_vec(), &survey).is_none());
    }
}
