//! `--hints`: where a user saw a few targets in the map (clicked in a viewer,
//! ±0.5 m), as a CSV like the survey's (`id,x,y[,z]`, map frame). Two shared
//! ids fix the 2D transform; more are fitted by least squares, and a hint that
//! disagrees with the others by more than a metre is an error, not an average.

use crate::cloud::RigidMotion;
use crate::survey::{Survey, SurveyOptions, read_survey};
use crate::{Error, Point, Result};
use std::path::Path;

/// The transform the hints give (survey = R·map + t) and the
/// survey-minus-map height offset (0 when either lacks heights).
#[derive(Debug, Clone, PartialEq)]
pub struct HintFrame {
    /// Map → survey, horizontally.
    pub init: super::MapToSurvey,
    /// Survey z minus map z.
    pub dz: f64,
    /// Hints used.
    pub used: usize,
    /// Largest disagreement of a hint with the fit (m).
    pub worst: f64,
}

/// Reads `path` and fits the map → survey transform from the ids it shares
/// with `survey`. Hints are in the map's own frame; `motion` (the levelling)
/// moves them into the frame the transform is for (a hint without a height
/// is taken at the centre of rotation's).
pub fn read_hints(path: &Path, survey: &Survey, motion: &RigidMotion) -> Result<HintFrame> {
    let hints = read_survey(path, &SurveyOptions::default())?;
    let ids: Vec<&str> = hints
        .targets
        .iter()
        .filter(|h| survey.get(&h.id).is_some())
        .map(|h| h.id.as_str())
        .collect();
    let pairs: Vec<(Point, Point, bool)> = hints
        .targets
        .iter()
        .filter_map(|h| {
            let mut p = h.position;
            if !h.has_z {
                p.z = motion.origin.z;
            }
            survey
                .get(&h.id)
                .map(|s| (motion.apply(&p), s.reference(), h.has_z && s.has_z))
        })
        .collect();
    if pairs.len() < 2 {
        return Err(Error::Input(format!(
            "{}: hints must give the map positions of at least 2 surveyed targets; {} of its ids are in the survey",
            path.display(),
            pairs.len()
        )));
    }
    let map: Vec<Point> = pairs.iter().map(|p| p.0).collect();
    let sur: Vec<Point> = pairs.iter().map(|p| p.1).collect();
    let (init, worst) = fit2d(&map, &sur);
    if worst > 1.0 {
        return Err(Error::Input(format!(
            "{}: the hints do not agree with the survey's layout: one is {worst:.1} m off the best fit of the others (hints should be within ±0.5 m){}",
            path.display(),
            which_hint(&map, &sur, &ids)
        )));
    }
    let mut dzs: Vec<f64> = pairs
        .iter()
        .filter(|p| p.2)
        .map(|p| p.1.z - p.0.z)
        .collect();
    dzs.sort_by(f64::total_cmp);
    Ok(HintFrame {
        init,
        dz: dzs.get(dzs.len() / 2).copied().unwrap_or(0.0),
        used: pairs.len(),
        worst,
    })
}

/// Of hints that disagree, the mistake that explains it, when one does:
/// two ids exchanged (the rest then fit), or one hint off (the others fit
/// without it). Needs three hints: two fit any layout of their distance.
fn which_hint(map: &[Point], sur: &[Point], ids: &[&str]) -> String {
    let n = map.len();
    if n < 3 {
        return String::new();
    }
    for i in 0..n {
        for j in i + 1..n {
            let mut swapped = sur.to_vec();
            swapped.swap(i, j);
            if fit2d(map, &swapped).1 <= 1.0 {
                return format!(
                    ": the hints for {} and {} look exchanged (with their ids swapped, all fit)",
                    ids[i], ids[j]
                );
            }
        }
    }
    if n >= 4 {
        for k in 0..n {
            let m: Vec<Point> = (0..n).filter(|&j| j != k).map(|j| map[j]).collect();
            let s: Vec<Point> = (0..n).filter(|&j| j != k).map(|j| sur[j]).collect();
            if fit2d(&m, &s).1 <= 1.0 {
                return format!(
                    ": the hint for {} is the one off (the others fit without it)",
                    ids[k]
                );
            }
        }
    }
    String::new()
}

/// 2D rigid least squares, map → survey: (the transform, worst residual).
pub(crate) fn fit2d(map: &[Point], sur: &[Point]) -> (super::MapToSurvey, f64) {
    // Local coordinates about each side's first point.
    let (o_m, o_s) = (map[0], sur[0]);
    let pairs: Vec<([f64; 2], [f64; 2])> = map
        .iter()
        .zip(sur)
        .map(|(a, b)| ([a.x - o_m.x, a.y - o_m.y], [b.x - o_s.x, b.y - o_s.y]))
        .collect();
    let (yaw, t) = super::rigid2d(&pairs);
    let (sn, cs) = yaw.sin_cos();
    let worst = pairs
        .iter()
        .map(|(f, g)| {
            let px = cs * f[0] - sn * f[1] + t[0];
            let py = sn * f[0] + cs * f[1] + t[1];
            (px - g[0]).hypot(py - g[1])
        })
        .fold(0.0, f64::max);
    // survey = R·(map − o_m) + t + o_s = R·map + (t + o_s − R·o_m).
    let tx = t[0] + o_s.x - (cs * o_m.x - sn * o_m.y);
    let ty = t[1] + o_s.y - (sn * o_m.x + cs * o_m.y);
    let f = super::MapToSurvey {
        x: tx,
        y: ty,
        yaw_deg: yaw.to_degrees().rem_euclid(360.0),
    };
    (f, worst)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two hints' ids exchanged, or one hint metres off: named.
    #[test]
    fn exchanged_or_odd_hints_are_named() {
        let init = crate::frame::MapToSurvey {
            x: 352_123.0,
            y: 4_026_456.0,
            yaw_deg: 33.0,
        };
        let sur = [
            Point::new(352_100.0, 4_026_400.0, 70.0),
            Point::new(352_160.0, 4_026_430.0, 71.0),
            Point::new(352_130.0, 4_026_480.0, 71.0),
            Point::new(352_090.0, 4_026_450.0, 71.0),
        ];
        let ids = ["a", "b", "c", "d"];
        let mut map: Vec<Point> = sur.iter().map(|p| init.to_map(p)).collect();
        map.swap(1, 2);
        assert!(fit2d(&map, &sur).1 > 1.0);
        let said = which_hint(&map, &sur, &ids);
        assert!(said.contains("for b and c look exchanged"), "{said}");
        map.swap(1, 2);
        map[3].x += 6.0;
        let said = which_hint(&map, &sur, &ids);
        assert!(said.contains("the hint for d is the one off"), "{said}");
    }

    #[test]
    fn two_hints_fix_yaw_and_offset_in_utm_coordinates() {
        let init = crate::frame::MapToSurvey {
            x: 352_123.0,
            y: 4_026_456.0,
            yaw_deg: 233.0,
        };
        let sur = [
            Point::new(352_100.0, 4_026_400.0, 70.0),
            Point::new(352_160.0, 4_026_430.0, 71.0),
        ];
        let map: Vec<Point> = sur.iter().map(|p| init.to_map(p)).collect();
        let (got, worst) = fit2d(&map, &sur);
        assert!(worst < 1e-6);
        assert!((got.x - init.x).abs() < 1e-5 && (got.y - init.y).abs() < 1e-5);
        assert!((got.yaw_deg - init.yaw_deg).abs() < 1e-9);
    }
}
