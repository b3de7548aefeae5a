//! Steps 3–4 of the tight crop: find the L. In windows about a target's size,
//! a Hough vote over headings finds the best perpendicular pair of vertical
//! planes; shape checks (an L, plate-sized, faces that stop) reject clutter; the
//! strong candidate nearest the expected position wins.

mod band;
mod check;
mod heading;
#[cfg(test)]
mod tests;

use super::TightParams;
use crate::frame::grid::TileMap;
use crate::geom::densest_run;
use band::*;
use check::*;
use heading::*;
use nalgebra::Vector3;
use rayon::prelude::*;

/// A detected L: two perpendicular vertical planes in window-local terms.
#[derive(Debug, Clone)]
pub(super) struct LShape {
    /// Unit normals (horizontal) of plate A and B.
    n: [Vector3<f64>; 2],
    /// Plane offsets along the normals.
    off: [f64; 2],
    /// Direction from the corner along each plate (in its plane, horizontal).
    along: [Vector3<f64>; 2],
    /// Corner (x, y), local coordinates.
    pub(super) corner: Vector3<f64>,
    /// Height band (along up) of the plates.
    pub(super) band: (f64, f64),
    /// Support of the weaker plate.
    pub(super) score: usize,
    /// Each plate's width measured from its points (95th percentile of the
    /// distance from the corner).
    pub(super) widths: [f64; 2],
}

impl LShape {
    /// Heading of the L's bisector (from the corner into the L), radians
    /// from the horizontal basis' first axis `e1`.
    pub(super) fn bisector(&self) -> Vector3<f64> {
        (self.along[0] + self.along[1]).normalize()
    }
}

impl LShape {
    /// Whether `v` belongs to the target: near a plate's plane, on the plate's
    /// side of the corner, inside the plates' height band.
    pub(super) fn keeps(&self, v: &Vector3<f64>, up: &Vector3<f64>, p: &TightParams) -> bool {
        let h = up.dot(v);
        if h < self.band.0 - 0.03 || h > self.band.1 + 0.03 {
            return false;
        }
        (0..2).any(|k| {
            let d = (self.n[k].dot(v) - self.off[k]).abs();
            let t = self.along[k].dot(&(v - self.corner));
            d < p.keep_distance && t > -0.1 && t < p.plate_width + 0.1
        })
    }
}

/// A window that held an L-like pair of planes the checks refused: why, and
/// where (window-local), so the user can be shown what stood there.
#[derive(Debug, Clone)]
pub(super) struct Rejected {
    /// Weaker plate's support.
    score: usize,
    /// What it looked like; empty when it was not worth naming.
    pub(super) why: String,
    /// Its corner (x, y), local coordinates.
    pub(super) corner: Vector3<f64>,
    /// Direction from the corner along each face (zero when not decided).
    pub(super) along: [Vector3<f64>; 2],
    /// Its plates' widths and height (m; NaN where not measured), when it
    /// was refused for its size alone: an L of another size than configured.
    pub(super) size: Option<Box<[f64; 3]>>,
}

impl Rejected {
    fn unnamed(score: usize) -> Self {
        Rejected {
            score,
            why: String::new(),
            corner: Vector3::zeros(),
            along: [Vector3::zeros(); 2],
            size: None,
        }
    }
}

/// Hough over headings in windows centred on occupied cells. Returns the chosen
/// L, the number of windows that passed, the best score seen, and (when none
/// passed) what the best-supported rejected window looked like.
pub(super) fn find_l(
    ap: &[Vector3<f64>],
    up: &Vector3<f64>,
    params: &TightParams,
    others: &[Vector3<f64>],
) -> (Option<LShape>, usize, usize, Option<Rejected>) {
    let w = params.plate_width;
    let step = 0.25_f64.min(w / 2.0);
    let cells = cells_of(ap, step);
    let fits = fit_windows(ap, up, params, &cells, step);
    let (found, best_score, seen) = tally(fits, params.min_plate_points);
    choose(found, others, w, best_score, seen)
}

/// The points' indices by cell of `step`, so that a window, and
/// `is_bounded`, look only at the cells within their reach.
fn cells_of(ap: &[Vector3<f64>], step: f64) -> TileMap<(i64, i64), Vec<u32>> {
    // Keys are sorted before use: the fast hasher changes nothing but time.
    let mut cells: TileMap<(i64, i64), Vec<u32>> = TileMap::default();
    for (i, v) in ap.iter().enumerate() {
        cells
            .entry(((v.x / step).floor() as i64, (v.y / step).floor() as i64))
            .or_default()
            .push(i as u32);
    }
    cells
}

/// The fit of a window about a target's size centred on each occupied cell,
/// in key order (`None` where too few points for two plates).
fn fit_windows(
    ap: &[Vector3<f64>],
    up: &Vector3<f64>,
    params: &TightParams,
    cells: &TileMap<(i64, i64), Vec<u32>>,
    step: f64,
) -> Vec<Option<Result<LShape, Rejected>>> {
    let w = params.plate_width;
    let rw = 0.47 * w / 0.6 * 1.0 + step * 0.75;
    let mut keys: Vec<(i64, i64)> = cells.keys().copied().collect();
    keys.sort_unstable();
    let reach = (rw / step).ceil() as i64;
    // Windows are independent: fitted in parallel (a dense crop's finder
    // then uses the cores its neighbours' targets left idle), consumed in
    // key order, so the choice is the same for any thread count.
    let flat = Flat::new(ap, up);
    keys.par_iter()
        .map_init(Vec::new, |window: &mut Vec<u32>, &(kx, ky)| {
            let centre = Vector3::new((kx as f64 + 0.5) * step, (ky as f64 + 0.5) * step, 0.0);
            window.clear();
            for dy in -reach..=reach {
                for dx in -reach..=reach {
                    if let Some(ids) = cells.get(&(kx + dx, ky + dy)) {
                        for &i in ids {
                            let v = ap[i as usize];
                            if (v.x - centre.x).powi(2) + (v.y - centre.y).powi(2) < rw * rw {
                                window.push(i);
                            }
                        }
                    }
                }
            }
            if window.len() < 2 * params.min_plate_points {
                return None;
            }
            let bounded = |l: &LShape| is_bounded(l, cells, ap, step, up, params);
            Some(fit_l(&flat, window, up, params, bounded))
        })
        .collect()
}

/// The windows' Ls strong enough to compete (at least `min` on the weaker
/// plate), the best score of any, and the best-supported named refusal, to
/// show the user when nothing passed.
fn tally(
    fits: Vec<Option<Result<LShape, Rejected>>>,
    min: usize,
) -> (Vec<LShape>, usize, Option<Rejected>) {
    let mut found: Vec<LShape> = Vec::new();
    let mut best_score = 0;
    let mut seen: Option<Rejected> = None;
    for fit in fits.into_iter().flatten() {
        match fit {
            Ok(l) => {
                best_score = best_score.max(l.score);
                if l.score >= min {
                    found.push(l);
                }
            }
            Err(r) => {
                if !r.why.is_empty() && seen.as_ref().is_none_or(|b| r.score > b.score) {
                    seen = Some(r);
                }
            }
        }
    }
    (found, best_score, seen)
}

/// Step 4, the choice: the strong candidate nearest the expected position
/// (the origin), unless every candidate is nearer another target's
/// position; returns what `find_l` does.
fn choose(
    found: Vec<LShape>,
    others: &[Vector3<f64>],
    w: f64,
    best_score: usize,
    seen: Option<Rejected>,
) -> (Option<LShape>, usize, usize, Option<Rejected>) {
    // An L nearer another target's expected position is that target's.
    let theirs = |l: &LShape| {
        others
            .iter()
            .any(|o| (l.corner - o).xy().norm() < l.corner.xy().norm())
    };
    let (theirs, found): (Vec<LShape>, Vec<LShape>) = found.into_iter().partition(theirs);
    if found.is_empty()
        && let Some(l) = theirs.iter().max_by_key(|l| l.score)
    {
        let seen = Rejected {
            score: l.score,
            why: "only target-shaped objects nearer another surveyed target's position than this one's".into(),
            corner: l.corner,
            along: l.along,
            size: None,
        };
        return (None, 0, best_score, Some(seen));
    }
    let n = found.len();
    let Some(top) = found.iter().map(|l| l.score).max() else {
        return (None, 0, best_score, seen);
    };
    // Nearest strong candidate to the expected position, then the best-supported
    // window on that same corner.
    let near = found
        .iter()
        .filter(|l| 4 * l.score >= top)
        .min_by(|a, b| a.corner.xy().norm().total_cmp(&b.corner.xy().norm()))
        .map(|l| l.corner)
        .expect("top exists");
    let chosen = found
        .into_iter()
        .filter(|l| (l.corner - near).xy().norm() < 0.25 * w / 0.6)
        .max_by(|a, b| {
            a.score
                .cmp(&b.score)
                .then(b.corner.xy().norm().total_cmp(&a.corner.xy().norm()))
        });
    (chosen, n, best_score, None)
}

/// A plate ends where the target ends: along each plate's plane, beyond its far
/// edge within its height band, there must be little (above and below the band
/// is `clear_beside`'s). A car, a box or a building corner is L-shaped too, but its faces go
/// on; this is what tells them apart.
fn is_bounded(
    l: &LShape,
    cells: &TileMap<(i64, i64), Vec<u32>>,
    ap: &[Vector3<f64>],
    step: f64,
    up: &Vector3<f64>,
    p: &TightParams,
) -> bool {
    let w = p.plate_width;
    let reach = w + 0.9;
    let r = (reach / step).ceil() as i64 + 1;
    let (cx, cy) = (
        (l.corner.x / step).floor() as i64,
        (l.corner.y / step).floor() as i64,
    );
    // Within the plates' band, points near each plate's plane: signed
    // distance from it, for those past its far edge and those on it.
    let mut past: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    let mut on: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    for dy in -r..=r {
        for dx in -r..=r {
            let Some(ids) = cells.get(&(cx + dx, cy + dy)) else {
                continue;
            };
            for &i in ids {
                let v = ap[i as usize];
                let z = up.dot(&v);
                if z <= l.band.0 - 0.03 || z >= l.band.1 + 0.03 {
                    continue;
                }
                for k in 0..2 {
                    let d = l.n[k].dot(&v) - l.off[k];
                    if d.abs() >= 0.15 {
                        continue;
                    }
                    let t = l.along[k].dot(&(v - l.corner));
                    if t > w + 0.15 && t < reach {
                        past[k].push(d);
                    } else if t > 0.1 * w && t < w {
                        on[k].push(d);
                    }
                }
            }
        }
    }
    let beyond = past.map(|d| going_on(&d));
    let support = on.map(|d| going_on(&d));
    let min = p.min_plate_points as i64;
    (0..2).all(|k| support[k] >= min && 4 * beyond[k] <= support[k])
}

/// How many of these points (signed distances from a plate's plane, within
/// 0.15 m) make a surface in that plane. When most lie near the plane (a face
/// going on, perhaps a few degrees off the plate's heading), every point
/// within 6 cm counts; when they centre on a surface standing parallel a
/// decimetre or more away, or spread evenly (a surface across the plane) (a wall seen past the plate's edge), only those
/// within 3 cm beyond the ones 3–6 cm off count, which its noise tail does not
/// give.
fn going_on(d: &[f64]) -> i64 {
    if d.is_empty() {
        return 0;
    }
    let mut s = d.to_vec();
    s.sort_unstable_by(f64::total_cmp);
    let near = |a: f64, b: f64| d.iter().filter(|x| x.abs() >= a && x.abs() < b).count() as i64;
    // A surface standing across the plane (a barrier the plane runs into)
    // spreads its points evenly over the ±0.15 m; a face keeps them close.
    let face = near(0.0, 0.06) >= 3 * near(0.06, 0.15);
    if s[s.len() / 2].abs() < 0.05 && face {
        near(0.0, 0.06)
    } else {
        near(0.0, 0.03) - near(0.03, 0.06)
    }
}
