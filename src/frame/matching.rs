//! Matching without correspondences: the 2D rigid transform (any yaw) and z
//! offset that put the most detections on surveyed targets.
//!
//! Distances between targets do not depend on the frame. Every pair of
//! surveyed targets is compared with every pair of detections of about the
//! same length; each agreeing pair proposes a transform, which is scored by
//! how many surveyed targets then have a detection within the tolerance, and
//! the best proposals are refined by least squares on their matches. A layout
//! that two different transforms explain about equally well (a square, a
//! symmetric grid, decoys that mimic the layout) is refused: a wrong frame
//! would be reported as a very poor map, which is worse than no report.

use crate::Point;
use crate::model::ModelKind;
use std::collections::HashMap;

/// A detection to match: position in the (levelled) map frame, and what
/// was detected there (it matches only a surveyed target of that model).
#[derive(Debug, Clone, Copy)]
pub struct Candidate {
    /// Reference point (an L's corner, a sphere's centre), map frame.
    pub at: Point,
    /// What it is.
    pub model: ModelKind,
}

impl Candidate {
    /// An L's corner at `at`.
    pub fn l(at: Point) -> Self {
        Candidate {
            at,
            model: ModelKind::L,
        }
    }
}

/// The map → survey transform found: survey = R(yaw)·map + t; z + dz.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameMatch {
    /// Map → survey, horizontally.
    pub init: super::MapToSurvey,
    /// Survey z minus map z (median over matches; 0 without surveyed heights).
    pub dz: f64,
    /// (survey index, detection index, horizontal residual m) per match.
    pub matches: Vec<(usize, usize, f64)>,
    /// RMS of the horizontal residuals (m).
    pub rms: f64,
    /// Matches of the best transform that differs from this one (0 if none).
    pub runner_up: usize,
}

/// Why no frame could be chosen.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MatchError {
    /// Not enough detections agree with the survey's layout.
    #[error(
        "no frame puts {need} or more detected targets on surveyed ones (best: {best} of {detections} detections on {surveyed} surveyed targets within {tol} m)"
    )]
    TooFew {
        /// Most matches any transform found.
        best: usize,
        /// Matches needed.
        need: usize,
        /// Detections offered.
        detections: usize,
        /// Surveyed targets.
        surveyed: usize,
        /// Tolerance (m).
        tol: f64,
    },
    /// Two different transforms explain the detections about equally well.
    #[error(
        "the layout is ambiguous: two frames {apart:.1} m / {yaw:.0}° apart put {a} and {b} detections on surveyed targets"
    )]
    Ambiguous {
        /// Matches of the best.
        a: usize,
        /// Matches of the other.
        b: usize,
        /// Distance between where the two put the survey's centre (m).
        apart: f64,
        /// Yaw difference (degrees).
        yaw: f64,
    },
}

/// Matching settings.
#[derive(Debug, Clone, Copy)]
pub struct MatchParams {
    /// A detection matches a surveyed target within this (m); it must also
    /// cover the map's own error, since a map is being measured.
    pub tol: f64,
    /// Matches needed.
    pub min_matches: usize,
}

impl Default for MatchParams {
    fn default() -> Self {
        MatchParams {
            tol: 0.5,
            min_matches: 3,
        }
    }
}

#[derive(Debug, Clone)]
struct Hyp {
    yaw: f64,
    t: [f64; 2],
    matches: Vec<(usize, usize, f64)>,
    rms: f64,
}

/// Finds the transform from detections `dets` (map frame) to `survey`
/// positions (survey frame) of the models `models` (one per position; empty:
/// every one an L). A detection matches only a target of its own model.
pub fn match_frame(
    dets: &[Candidate],
    survey: &[Point],
    models: &[ModelKind],
    survey_has_z: bool,
    params: &MatchParams,
) -> Result<FrameMatch, MatchError> {
    assert!(
        models.is_empty() || models.len() == survey.len(),
        "match_frame: one model per surveyed position"
    );
    let all_l = vec![ModelKind::L; survey.len()];
    let sm = if models.is_empty() {
        &all_l[..]
    } else {
        models
    };
    let dm: Vec<ModelKind> = dets.iter().map(|d| d.model).collect();
    let kinds = Kinds { s: sm, d: &dm };
    let tol = params.tol;
    let need = params.min_matches.max(2);
    let too_few = |best| MatchError::TooFew {
        best,
        need,
        detections: dets.len(),
        surveyed: survey.len(),
        tol,
    };
    if dets.len() < 2 || survey.len() < 2 {
        return Err(too_few(0));
    }
    // Local coordinates: large survey coordinates never get squared.
    let sc = centroid(survey);
    let dc = centroid(&dets.iter().map(|d| d.at).collect::<Vec<_>>());
    let s: Vec<[f64; 2]> = survey.iter().map(|p| [p.x - sc[0], p.y - sc[1]]).collect();
    let d: Vec<[f64; 2]> = dets
        .iter()
        .map(|p| [p.at.x - dc[0], p.at.y - dc[1]])
        .collect();
    let dpairs = pairs_by_length(&d);
    let mut hyps = proposals(&s, &d, &kinds, &dpairs, tol, need);
    if hyps.is_empty() {
        // The most any pair could give is 2 (the pair itself).
        return Err(too_few(if dpairs.is_empty() {
            0
        } else {
            2.min(need - 1)
        }));
    }
    hyps.sort_by(|a, b| {
        b.matches
            .len()
            .cmp(&a.matches.len())
            .then(a.rms.total_cmp(&b.rms))
            .then(a.yaw.total_cmp(&b.yaw))
    });
    let best = hyps[0].clone();
    let runner_up = runner_up(&hyps, &s, tol)?;
    let dz = if survey_has_z {
        median_dz(&best.matches, survey, dets, sm)
    } else {
        0.0
    };
    Ok(FrameMatch {
        init: full_frame(&best, sc, dc),
        dz,
        rms: best.rms,
        matches: best.matches,
        runner_up,
    })
}

/// Every pair of detections with its length, shortest first: the survey's
/// pairs look up the detections' of about their length by bisection.
fn pairs_by_length(d: &[[f64; 2]]) -> Vec<(f64, u32, u32)> {
    let mut dpairs: Vec<(f64, u32, u32)> = Vec::new();
    for a in 0..d.len() {
        for b in a + 1..d.len() {
            dpairs.push((dist(&d[a], &d[b]), a as u32, b as u32));
        }
    }
    dpairs.sort_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    dpairs
}

/// The models of the surveyed targets and of the detections, by index.
struct Kinds<'a> {
    s: &'a [ModelKind],
    d: &'a [ModelKind],
}

/// The transforms that a surveyed pair and a detected pair of about its
/// length (and of the same models) propose (both ways round), each refined,
/// that match `need` or more.
fn proposals(
    s: &[[f64; 2]],
    d: &[[f64; 2]],
    kinds: &Kinds,
    dpairs: &[(f64, u32, u32)],
    tol: f64,
    need: usize,
) -> Vec<Hyp> {
    let index = Buckets::new(d, tol);
    let mut hyps: Vec<Hyp> = Vec::new();
    for i in 0..s.len() {
        for j in i + 1..s.len() {
            let l = dist(&s[i], &s[j]);
            if l < 2.0 * tol {
                continue;
            }
            let lo = dpairs.partition_point(|p| p.0 < l - tol);
            for &(_, a, b) in dpairs[lo..].iter().take_while(|p| p.0 <= l + tol) {
                for (a, b) in [(a, b), (b, a)] {
                    let (a, b) = (a as usize, b as usize);
                    if kinds.s[i] != kinds.d[a] || kinds.s[j] != kinds.d[b] {
                        continue;
                    }
                    let yaw = angle(&s[i], &s[j]) - angle(&d[a], &d[b]);
                    let (sn, cs) = yaw.sin_cos();
                    let t = [
                        s[i][0] - (cs * d[a][0] - sn * d[a][1]),
                        s[i][1] - (sn * d[a][0] + cs * d[a][1]),
                    ];
                    let m = score(s, &index, d, kinds, yaw, t, tol);
                    if m.len() >= need {
                        hyps.push(refine(s, d, kinds, &index, m, tol));
                    }
                }
            }
        }
    }
    hyps
}

/// Matches of the best ranked proposal (`hyps[0]` the best) that puts the
/// survey somewhere else; an error when it explains about as many
/// detections: a wrong frame must not be reported as a very poor map.
fn runner_up(hyps: &[Hyp], s: &[[f64; 2]], tol: f64) -> Result<usize, MatchError> {
    let best = &hyps[0];
    let extent = s.iter().map(|p| p[0].hypot(p[1])).fold(1.0, f64::max);
    let differs = |h: &Hyp| {
        let dyaw = wrap(h.yaw - best.yaw).abs();
        let dt = (h.t[0] - best.t[0]).hypot(h.t[1] - best.t[1]);
        dt > tol || dyaw * extent > tol
    };
    let other = hyps.iter().find(|h| differs(h));
    let runner_up = other.map_or(0, |h| h.matches.len());
    if let Some(o) = other
        && runner_up >= 3
        && runner_up + 1 >= best.matches.len()
    {
        // Where each puts the survey's centre, in the map.
        let (sa, ca) = best.yaw.sin_cos();
        let (so, co) = o.yaw.sin_cos();
        let inv = |s: f64, c: f64, t: [f64; 2]| [c * -t[0] + s * -t[1], -s * -t[0] + c * -t[1]];
        let (pa, po) = (inv(sa, ca, best.t), inv(so, co, o.t));
        return Err(MatchError::Ambiguous {
            a: best.matches.len(),
            b: runner_up,
            apart: dist(&pa, &po),
            yaw: wrap(o.yaw - best.yaw).to_degrees().abs(),
        });
    }
    Ok(runner_up)
}

/// The best proposal, found in local coordinates, back in the full ones:
/// survey = R·(map − dc) + t + sc.
fn full_frame(best: &Hyp, sc: [f64; 2], dc: [f64; 2]) -> super::MapToSurvey {
    let (sn, cs) = best.yaw.sin_cos();
    let tx = best.t[0] + sc[0] - (cs * dc[0] - sn * dc[1]);
    let ty = best.t[1] + sc[1] - (sn * dc[0] + cs * dc[1]);
    super::MapToSurvey {
        x: tx,
        y: ty,
        yaw_deg: best.yaw.to_degrees().rem_euclid(360.0),
    }
}

/// Survey z minus map z over the matches: the median, so that a target
/// whose corner height is off does not move the others; over the model
/// matched most (ties: the first in `ModelKind`'s order), since models
/// differ in where their detected point sits against the surveyed one.
fn median_dz(
    matches: &[(usize, usize, f64)],
    survey: &[Point],
    dets: &[Candidate],
    models: &[ModelKind],
) -> f64 {
    let mut count: Vec<(ModelKind, usize)> = Vec::new();
    for &(i, _, _) in matches {
        match count.iter_mut().find(|c| c.0 == models[i]) {
            Some(c) => c.1 += 1,
            None => count.push((models[i], 1)),
        }
    }
    count.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let most = count[0].0;
    let mut dzs: Vec<f64> = matches
        .iter()
        .filter(|&&(i, _, _)| models[i] == most)
        .map(|&(i, a, _)| survey[i].z - dets[a].at.z)
        .collect();
    dzs.sort_by(f64::total_cmp);
    dzs[dzs.len() / 2]
}

/// Detections hashed by cell of side `tol`.
struct Buckets {
    cell: f64,
    map: HashMap<(i64, i64), Vec<u32>>,
}

impl Buckets {
    fn new(d: &[[f64; 2]], tol: f64) -> Self {
        let mut map: HashMap<(i64, i64), Vec<u32>> = HashMap::new();
        for (i, p) in d.iter().enumerate() {
            map.entry(((p[0] / tol).floor() as i64, (p[1] / tol).floor() as i64))
                .or_default()
                .push(i as u32);
        }
        Buckets { cell: tol, map }
    }

    /// Nearest detection to `p` within `tol` that `fits`.
    fn nearest(
        &self,
        d: &[[f64; 2]],
        p: [f64; 2],
        tol: f64,
        fits: impl Fn(usize) -> bool,
    ) -> Option<(usize, f64)> {
        let (kx, ky) = (
            (p[0] / self.cell).floor() as i64,
            (p[1] / self.cell).floor() as i64,
        );
        let mut best: Option<(usize, f64)> = None;
        for dy in -1..=1 {
            for dx in -1..=1 {
                for &i in self.map.get(&(kx + dx, ky + dy)).map_or(&[][..], |v| v) {
                    let r = dist(&d[i as usize], &p);
                    if r <= tol
                        && fits(i as usize)
                        && best.is_none_or(|b| r < b.1 || (r == b.1 && (i as usize) < b.0))
                    {
                        best = Some((i as usize, r));
                    }
                }
            }
        }
        best
    }
}

/// Survey targets with a detection of their model within `tol` under
/// (yaw, t), one detection each.
fn score(
    s: &[[f64; 2]],
    index: &Buckets,
    d: &[[f64; 2]],
    kinds: &Kinds,
    yaw: f64,
    t: [f64; 2],
    tol: f64,
) -> Vec<(usize, usize, f64)> {
    let (sn, cs) = yaw.sin_cos();
    let mut used: Vec<usize> = Vec::new();
    let mut out = Vec::new();
    for (i, p) in s.iter().enumerate() {
        // map = Rᵀ(survey − t)
        let (x, y) = (p[0] - t[0], p[1] - t[1]);
        let q = [cs * x + sn * y, -sn * x + cs * y];
        if let Some((a, r)) = index.nearest(d, q, tol, |a| kinds.d[a] == kinds.s[i])
            && !used.contains(&a)
        {
            used.push(a);
            out.push((i, a, r));
        }
    }
    out
}

/// Least-squares rigid fit on the matches, then the matches again (twice).
fn refine(
    s: &[[f64; 2]],
    d: &[[f64; 2]],
    kinds: &Kinds,
    index: &Buckets,
    mut m: Vec<(usize, usize, f64)>,
    tol: f64,
) -> Hyp {
    let mut yaw = 0.0;
    let mut t = [0.0; 2];
    for _ in 0..2 {
        let pairs: Vec<([f64; 2], [f64; 2])> = m.iter().map(|&(i, j, _)| (d[j], s[i])).collect();
        (yaw, t) = super::rigid2d(&pairs);
        let again = score(s, index, d, kinds, yaw, t, tol);
        if again.len() < m.len() {
            break;
        }
        m = again;
    }
    let rms = (m.iter().map(|x| x.2 * x.2).sum::<f64>() / m.len().max(1) as f64).sqrt();
    Hyp {
        yaw,
        t,
        matches: m,
        rms,
    }
}

fn centroid(p: &[Point]) -> [f64; 2] {
    // The first point, rounded, then the mean offset from it: no large sums.
    let o = [p[0].x.round(), p[0].y.round()];
    let n = p.len() as f64;
    let m = p.iter().fold([0.0; 2], |a, q| {
        [a[0] + (q.x - o[0]) / n, a[1] + (q.y - o[1]) / n]
    });
    [o[0] + m[0].round(), o[1] + m[1].round()]
}

fn dist(a: &[f64; 2], b: &[f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn angle(a: &[f64; 2], b: &[f64; 2]) -> f64 {
    (b[1] - a[1]).atan2(b[0] - a[0])
}

fn wrap(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    (a + std::f64::consts::PI).rem_euclid(t) - std::f64::consts::PI
}

#[cfg(test)]
mod tests {
    use super::*;

    fn to_map(init: [f64; 3], p: &Point) -> Point {
        crate::frame::MapToSurvey::from(init).to_map(p)
    }

    fn survey() -> Vec<Point> {
        [
            (0.0, 0.0),
            (31.0, 4.0),
            (55.0, -12.0),
            (80.0, 9.0),
            (97.0, -3.0),
            (120.0, 14.0),
        ]
        .iter()
        .map(|&(x, y)| Point::new(352_000.0 + x, 4_026_000.0 + y, 70.0))
        .collect()
    }

    #[test]
    fn finds_any_yaw_and_a_far_offset_among_decoys() {
        let s = survey();
        for yaw in [0.0, 37.0, 181.0, 299.5] {
            let init = [352_500.0, 4_025_100.0, yaw];
            let mut dets: Vec<Candidate> = s[1..]
                .iter()
                .map(|p| Candidate::l(to_map(init, p) + nalgebra::Vector3::new(0.03, -0.02, -69.0)))
                .collect();
            for k in 0..15 {
                let f = k as f64;
                dets.push(Candidate::l(Point::new(
                    -400.0 + 7.3 * f,
                    900.0 + (f * 1.7).sin() * 20.0,
                    1.0,
                )));
            }
            let m = match_frame(&dets, &s, &[], true, &MatchParams::default()).unwrap();
            assert_eq!(m.matches.len(), 5, "yaw {yaw}");
            assert!(
                (wrap((m.init.yaw_deg - yaw).to_radians()))
                    .abs()
                    .to_degrees()
                    < 0.05
            );
            assert!((m.init.x - init[0]).abs() < 0.2 && (m.init.y - init[1]).abs() < 0.2);
            assert!((m.dz - 69.0).abs() < 1e-6);
        }
    }

    /// A square with Ls on one side and spheres on the other is no longer
    /// symmetric (alternating, it still is under a half turn): the models
    /// tell its corners apart, and a detection matches only its own model.
    #[test]
    fn models_tell_a_symmetric_layout_apart() {
        let s: Vec<Point> = [(0.0, 0.0), (40.0, 0.0), (40.0, 40.0), (0.0, 40.0)]
            .iter()
            .map(|&(x, y)| Point::new(x, y, 0.0))
            .collect();
        use ModelKind::{L, Sphere};
        let models = [L, L, Sphere, Sphere];
        let init = [5.0, 3.0, 20.0];
        let dets: Vec<Candidate> = s
            .iter()
            .zip(models)
            .map(|(p, model)| Candidate {
                at: to_map(init, p),
                model,
            })
            .collect();
        let m = match_frame(&dets, &s, &models, false, &MatchParams::default()).unwrap();
        assert_eq!(m.matches.len(), 4);
        assert!(m.matches.iter().all(|&(i, a, _)| i == a), "{:?}", m.matches);
        assert!((m.init.yaw_deg - 20.0).abs() < 0.01, "{:?}", m.init);
        // Every detection an L: the spheres' places have none of theirs.
        let ls: Vec<Candidate> = dets.iter().map(|d| Candidate::l(d.at)).collect();
        let e = match_frame(&ls, &s, &models, false, &MatchParams::default()).unwrap_err();
        assert!(matches!(e, MatchError::TooFew { best: 2, .. }), "{e}");
    }

    #[test]
    fn refuses_a_symmetric_square() {
        let s: Vec<Point> = [(0.0, 0.0), (40.0, 0.0), (40.0, 40.0), (0.0, 40.0)]
            .iter()
            .map(|&(x, y)| Point::new(x, y, 0.0))
            .collect();
        let dets: Vec<Candidate> = s
            .iter()
            .map(|p| Candidate::l(to_map([5.0, 3.0, 20.0], p)))
            .collect();
        let e = match_frame(&dets, &s, &[], false, &MatchParams::default()).unwrap_err();
        assert!(matches!(e, MatchError::Ambiguous { a: 4, b: 4, .. }), "{e}");
    }

    #[test]
    fn too_few_detections_is_an_error() {
        let s = survey();
        let dets: Vec<Candidate> = s[..2].iter().map(|p| Candidate::l(*p)).collect();
        assert!(matches!(
            match_frame(&dets, &s, &[], false, &MatchParams::default()),
            Err(MatchError::TooFew { .. })
        ));
    }
}
