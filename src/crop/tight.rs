//! Automatic tight crop: from a loose crop, find the L-shaped target and keep
//! only its plates.
//!
//! 1. **Ground.** The lowest point of every 0.5 m cell is a ground candidate; a
//!    RANSAC plane through those gives the local ground normal, and the lowest
//!    height in each 3×3 cell block follows bumps the plane cannot.
//! 2. **Above ground.** Points between `min_height` and `max_height` over the
//!    local ground, within `search_radius` of the expected position.
//! 3. **L detection.** Windows about the size of a target are centred on every
//!    occupied cell. In each, a Hough vote over headings finds the pair of
//!    perpendicular vertical planes with the most support (the weaker plate's
//!    count is the score). A window passes when both plates lie on one side of
//!    their intersection (an L, not a T or a cross), are no longer than a plate,
//!    the supporting points span no more than a plate's height (plus 0.25 m),
//!    and the faces stop where a plate stops (a car's or a cabinet's go on).
//! 4. **Choice.** Among windows scoring at least a quarter of the best (solid
//!    clutter returns more points than a mesh plate), the one whose corner is
//!    nearest the expected position wins.
//! 5. **Crop.** Points near either plate plane, on the plate's side of the
//!    corner, inside the plates' height band (the post below and the antenna
//!    above are dropped, so the corner height is the plates' mean height).

use crate::Point;
use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use std::collections::HashMap;

/// Tight-crop parameters; the target size is the physical build.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TightParams {
    /// Plate width in metres (each arm of the L).
    pub plate_width: f64,
    /// Plate height in metres.
    pub plate_height: f64,
    /// Ground cell size in metres.
    pub ground_cell: f64,
    /// Points lower than this above the local ground are ground (metres).
    pub min_height: f64,
    /// Points higher than this above the local ground are ignored (metres).
    pub max_height: f64,
    /// Horizontal search radius around the expected position (metres).
    pub search_radius: f64,
    /// Half-width of the slab kept around each plate plane (metres).
    pub keep_distance: f64,
    /// Minimum points on each plate for a candidate.
    pub min_plate_points: usize,
    /// The ground normal is used as "up" only when it is within this angle of
    /// the map's +z (degrees); steeper ground is a slope, not a tilted map.
    pub max_up_tilt_deg: f64,
    /// Seed for the ground RANSAC.
    pub seed: u64,
}

impl Default for TightParams {
    fn default() -> Self {
        TightParams {
            plate_width: 0.6,
            plate_height: 0.6,
            ground_cell: 0.5,
            min_height: 0.2,
            max_height: 4.0,
            search_radius: 4.5,
            keep_distance: 0.08,
            min_plate_points: 12,
            max_up_tilt_deg: 0.75,
            seed: 0,
        }
    }
}

/// A tight crop and what was learned on the way.
#[derive(Debug, Clone, serde::Serialize)]
pub struct TightCrop {
    /// The target's points (map frame).
    pub points: Vec<Point>,
    /// The direction used as vertical by the localisation gates.
    pub up: [f64; 3],
    /// Estimated local ground normal.
    pub ground_normal: [f64; 3],
    /// Tilt of the ground normal from +z (degrees).
    pub ground_tilt_deg: f64,
    /// Points classified as ground.
    pub ground_points: usize,
    /// Points above ground inside the search radius.
    pub above_ground: usize,
    /// Corner found by the L detector (map frame; a first guess).
    pub corner_guess: Point,
    /// Support of the weaker plate in the winning window.
    pub score: usize,
    /// Windows that looked like a target.
    pub candidates: usize,
}

/// Why no tight crop could be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum TightError {
    /// The loose crop is empty: the target is outside the map.
    #[error("no map points near the expected position")]
    NoPoints,
    /// Everything near the target is ground.
    #[error(
        "nothing stands above the ground near the expected position ({points} points, all ground)"
    )]
    NothingAboveGround {
        /// Points in the loose crop.
        points: usize,
    },
    /// Objects stand there, but none is shaped like the target.
    #[error(
        "no target-shaped object within {radius} m ({above} points above ground; best plate support {best})"
    )]
    NoTargetShape {
        /// Search radius used.
        radius: f64,
        /// Points above ground.
        above: usize,
        /// Best weaker-plate support seen in any window.
        best: usize,
    },
}

/// Finds the target in `points` (a loose crop) near `expected` (map frame).
pub fn tight_crop(
    points: &[Point],
    expected: &Point,
    params: &TightParams,
) -> Result<TightCrop, TightError> {
    if points.is_empty() {
        return Err(TightError::NoPoints);
    }
    // Local coordinates about the expected position keep squares small.
    let q: Vec<Vector3<f64>> = points.iter().map(|p| p - expected).collect();
    let ground = Ground::fit(&q, params);
    let heights: Vec<f64> = q.iter().map(|v| ground.height(v)).collect();
    let r2 = params.search_radius * params.search_radius;
    let above: Vec<usize> = (0..q.len())
        .filter(|&i| {
            heights[i] > params.min_height
                && heights[i] < params.max_height
                && q[i].x * q[i].x + q[i].y * q[i].y < r2
        })
        .collect();
    let ground_points = heights.iter().filter(|&&h| h <= params.min_height).count();
    if above.is_empty() {
        return Err(TightError::NothingAboveGround {
            points: points.len(),
        });
    }
    let up = if ground.normal.angle(&Vector3::z()).to_degrees() <= params.max_up_tilt_deg {
        ground.normal
    } else {
        Vector3::z()
    };
    let ap: Vec<Vector3<f64>> = above.iter().map(|&i| q[i]).collect();
    let (best, candidates, best_score) = detect_l(&ap, &up, params);
    let Some(l) = best else {
        return Err(TightError::NoTargetShape {
            radius: params.search_radius,
            above: above.len(),
            best: best_score,
        });
    };
    let kept: Vec<Point> = ap
        .iter()
        .filter(|v| l.keeps(v, &up, params))
        .map(|v| expected + v)
        .collect();
    Ok(TightCrop {
        points: kept,
        up: up.into(),
        ground_normal: ground.normal.into(),
        ground_tilt_deg: ground.normal.angle(&Vector3::z()).to_degrees(),
        ground_points,
        above_ground: above.len(),
        corner_guess: Point::new(
            expected.x + l.corner.x,
            expected.y + l.corner.y,
            expected.z + (l.band.0 + l.band.1) / 2.0,
        ),
        score: l.score,
        candidates,
    })
}

/// Local ground: a plane for the normal, per-cell minima for the bumps.
struct Ground {
    normal: Vector3<f64>,
    offset: f64,
    cell: f64,
    /// Lowest plane height in each cell's 3×3 block.
    floor: HashMap<(i64, i64), f64>,
}

impl Ground {
    fn key(cell: f64, v: &Vector3<f64>) -> (i64, i64) {
        ((v.x / cell).floor() as i64, (v.y / cell).floor() as i64)
    }

    fn fit(q: &[Vector3<f64>], params: &TightParams) -> Ground {
        let cell = params.ground_cell.max(0.05);
        let mut lowest: HashMap<(i64, i64), Vector3<f64>> = HashMap::new();
        for v in q {
            lowest
                .entry(Self::key(cell, v))
                .and_modify(|m| {
                    if v.z < m.z {
                        *m = *v
                    }
                })
                .or_insert(*v);
        }
        let mut keys: Vec<(i64, i64)> = lowest.keys().copied().collect();
        keys.sort_unstable();
        let cand: Vec<Vector3<f64>> = keys.iter().map(|k| lowest[k]).collect();
        let normal = ransac_ground(&cand, params.seed).unwrap_or_else(Vector3::z);
        let offset = 0.0;
        let mut cell_min: HashMap<(i64, i64), f64> = HashMap::new();
        for v in q {
            let h = normal.dot(v) - offset;
            cell_min
                .entry(Self::key(cell, v))
                .and_modify(|m| *m = m.min(h))
                .or_insert(h);
        }
        let mut floor = HashMap::with_capacity(cell_min.len());
        for &(kx, ky) in cell_min.keys() {
            let mut m = f64::INFINITY;
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(&h) = cell_min.get(&(kx + dx, ky + dy)) {
                        m = m.min(h);
                    }
                }
            }
            floor.insert((kx, ky), m);
        }
        Ground {
            normal,
            offset,
            cell,
            floor,
        }
    }

    fn height(&self, v: &Vector3<f64>) -> f64 {
        let h = self.normal.dot(v) - self.offset;
        h - self
            .floor
            .get(&Self::key(self.cell, v))
            .copied()
            .unwrap_or(h)
    }
}

/// Plane through cell minima: RANSAC for support, least squares to refine.
/// Returns the upward unit normal, or `None` with too few cells.
fn ransac_ground(c: &[Vector3<f64>], seed: u64) -> Option<Vector3<f64>> {
    if c.len() < 6 {
        return None;
    }
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed ^ 0x6a09_e667_f3bc_c908);
    let thr = 0.12;
    let mut best: (usize, Vector3<f64>, f64) = (0, Vector3::z(), 0.0);
    for _ in 0..200 {
        let a = c[rng.random_range(0..c.len())];
        let b = c[rng.random_range(0..c.len())];
        let d = c[rng.random_range(0..c.len())];
        let n = (b - a).cross(&(d - a));
        let len = n.norm();
        if len < 1e-9 {
            continue;
        }
        let mut n = n / len;
        if n.z < 0.0 {
            n = -n;
        }
        if n.z < 0.94 {
            continue; // steeper than 20°: not ground
        }
        let off = n.dot(&a);
        let support = c.iter().filter(|v| (n.dot(v) - off).abs() < thr).count();
        if support > best.0 {
            best = (support, n, off);
        }
    }
    if best.0 < 3 {
        return None;
    }
    let (_, n, off) = best;
    let inl: Vec<&Vector3<f64>> = c.iter().filter(|v| (n.dot(v) - off).abs() < thr).collect();
    let mean = inl.iter().fold(Vector3::zeros(), |s, v| s + **v) / inl.len() as f64;
    let mut cov = Matrix3::zeros();
    for v in &inl {
        let d = **v - mean;
        cov += d * d.transpose();
    }
    let eig = cov.symmetric_eigen();
    let (imin, _) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .fold(
            (0, f64::INFINITY),
            |m, (i, &e)| if e < m.1 { (i, e) } else { m },
        );
    let mut normal: Vector3<f64> = eig.eigenvectors.column(imin).into();
    if normal.z < 0.0 {
        normal = -normal;
    }
    Some(normal.normalize())
}

/// A detected L: two perpendicular vertical planes in window-local terms.
#[derive(Debug, Clone)]
struct LShape {
    /// Unit normals (horizontal) of plate A and B.
    n: [Vector3<f64>; 2],
    /// Plane offsets along the normals.
    off: [f64; 2],
    /// Direction from the corner along each plate (in its plane, horizontal).
    along: [Vector3<f64>; 2],
    /// Corner (x, y), local coordinates.
    corner: Vector3<f64>,
    /// Height band (along up) of the plates.
    band: (f64, f64),
    score: usize,
}

impl LShape {
    fn keeps(&self, v: &Vector3<f64>, up: &Vector3<f64>, p: &TightParams) -> bool {
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

/// Hough over headings in windows centred on occupied cells. Returns the chosen
/// L, the number of windows that passed, and the best score seen.
fn detect_l(
    ap: &[Vector3<f64>],
    up: &Vector3<f64>,
    params: &TightParams,
) -> (Option<LShape>, usize, usize) {
    let w = params.plate_width;
    let step = 0.25_f64.min(w / 2.0);
    let rw = 0.47 * w / 0.6 * 1.0 + step * 0.75;
    let mut cells: HashMap<(i64, i64), Vec<u32>> = HashMap::new();
    for (i, v) in ap.iter().enumerate() {
        cells
            .entry(((v.x / step).floor() as i64, (v.y / step).floor() as i64))
            .or_default()
            .push(i as u32);
    }
    let mut keys: Vec<(i64, i64)> = cells.keys().copied().collect();
    keys.sort_unstable();
    let reach = (rw / step).ceil() as i64;
    let mut found: Vec<LShape> = Vec::new();
    let mut best_score = 0;
    let mut window: Vec<Vector3<f64>> = Vec::new();
    for &(kx, ky) in &keys {
        let centre = Vector3::new((kx as f64 + 0.5) * step, (ky as f64 + 0.5) * step, 0.0);
        window.clear();
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                if let Some(ids) = cells.get(&(kx + dx, ky + dy)) {
                    for &i in ids {
                        let v = ap[i as usize];
                        if (v.x - centre.x).powi(2) + (v.y - centre.y).powi(2) < rw * rw {
                            window.push(v);
                        }
                    }
                }
            }
        }
        if window.len() < 2 * params.min_plate_points {
            continue;
        }
        if let Some(l) =
            fit_l(&window, up, params).filter(|l| is_bounded(l, &cells, ap, step, up, params))
        {
            best_score = best_score.max(l.score);
            if l.score >= params.min_plate_points {
                found.push(l);
            }
        }
    }
    let n = found.len();
    let Some(top) = found.iter().map(|l| l.score).max() else {
        return (None, 0, best_score);
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
    (chosen, n, best_score)
}

/// Best perpendicular pair of vertical planes in one window, or `None` when the
/// support does not look like an L of the configured size.
fn fit_l(win: &[Vector3<f64>], up: &Vector3<f64>, p: &TightParams) -> Option<LShape> {
    // Horizontal basis orthogonal to up.
    let e1 = (Vector3::x() - up * up.x).normalize();
    let e2 = up.cross(&e1);
    let bin = 0.02;
    let first = *win.first()?;
    // Histograms over a fixed range around the first point (every window point
    // is within two window radii of it, plus what a slightly tilted "up" adds):
    // arrays, not hash maps, since this loop is most of a dense map's crop time.
    let half = ((4.0 * p.plate_width + 0.3) / bin).ceil() as i64 + 2;
    let mut hist_a = vec![0u32; (2 * half + 1) as usize];
    let mut hist_b = vec![0u32; (2 * half + 1) as usize];
    let mut best: Option<(usize, f64, f64, f64)> = None; // score, theta, offA, offB
    let mut deg = 0.0;
    while deg < 90.0 {
        let th = f64::to_radians(deg);
        let na = e1 * th.cos() + e2 * th.sin();
        let nb = up.cross(&na);
        let base_a = (na.dot(&first) / bin).floor() as i64 - half;
        let base_b = (nb.dot(&first) / bin).floor() as i64 - half;
        hist_a.fill(0);
        hist_b.fill(0);
        for v in win {
            let ia = ((na.dot(v) / bin).floor() as i64 - base_a).clamp(0, 2 * half);
            let ib = ((nb.dot(v) / bin).floor() as i64 - base_b).clamp(0, 2 * half);
            hist_a[ia as usize] += 1;
            hist_b[ib as usize] += 1;
        }
        let (ca, oa) = peak(&hist_a, base_a, bin);
        let (cb, ob) = peak(&hist_b, base_b, bin);
        let s = ca.min(cb);
        if best.is_none_or(|b| s > b.0) {
            best = Some((s, deg, oa, ob));
        }
        deg += 1.5;
    }
    let (score, deg, oa, ob) = best?;
    let th = deg.to_radians();
    let na = e1 * th.cos() + e2 * th.sin();
    let nb = up.cross(&na);
    let corner = na * oa + nb * ob;
    let tol = 0.04;
    let mut along = [Vector3::zeros(); 2];
    let mut inl_h: Vec<f64> = Vec::new();
    for (k, (n, off, dir)) in [(na, oa, nb), (nb, ob, na)].into_iter().enumerate() {
        let ts: Vec<f64> = win
            .iter()
            .filter(|v| (n.dot(v) - off).abs() < tol)
            .map(|v| dir.dot(&(*v - corner)))
            .collect();
        let pos = ts.iter().filter(|&&t| t > 0.05).count();
        let neg = ts.iter().filter(|&&t| t < -0.05).count();
        // An L: the plate lies on one side of the corner.
        let (sign, major, minor) = if pos >= neg {
            (1.0, pos, neg)
        } else {
            (-1.0, neg, pos)
        };
        if major < p.min_plate_points || minor * 3 > major {
            return None;
        }
        along[k] = dir * sign;
        let mut ext: Vec<f64> = ts.iter().map(|t| t * sign).filter(|&t| t > 0.0).collect();
        ext.sort_by(f64::total_cmp);
        let far = ext[(ext.len() * 9) / 10];
        if far > p.plate_width + 0.15 {
            return None;
        }
        inl_h.extend(
            win.iter()
                .filter(|v| {
                    (n.dot(v) - off).abs() < tol
                        && (dir * sign).dot(&(*v - corner)) > 0.1 * p.plate_width
                })
                .map(|v| up.dot(v)),
        );
    }
    if inl_h.len() < 2 * p.min_plate_points {
        return None;
    }
    inl_h.sort_by(f64::total_cmp);
    let lo = inl_h[inl_h.len() / 50];
    let hi = inl_h[inl_h.len() - 1 - inl_h.len() / 50];
    if hi - lo > p.plate_height + 0.25 {
        return None; // taller than a plate: a wall, a cabinet, a tree
    }
    Some(LShape {
        n: [na, nb],
        off: [oa, ob],
        along,
        corner,
        band: (lo, hi),
        score,
    })
}

/// A plate ends where the target ends: along each plate's plane, beyond its far
/// edge and above or below its height band (away from the post), there must be
/// little. A car, a box or a building corner is L-shaped too, but its faces go
/// on; this is what tells them apart.
fn is_bounded(
    l: &LShape,
    cells: &HashMap<(i64, i64), Vec<u32>>,
    ap: &[Vector3<f64>],
    step: f64,
    up: &Vector3<f64>,
    p: &TightParams,
) -> bool {
    let w = p.plate_width;
    let h = l.band.1 - l.band.0;
    let reach = w + 0.9;
    let r = (reach / step).ceil() as i64 + 1;
    let (cx, cy) = (
        (l.corner.x / step).floor() as i64,
        (l.corner.y / step).floor() as i64,
    );
    let tol = 0.05;
    let mut beyond = [0usize; 2];
    let mut support = [0usize; 2];
    for dy in -r..=r {
        for dx in -r..=r {
            let Some(ids) = cells.get(&(cx + dx, cy + dy)) else {
                continue;
            };
            for &i in ids {
                let v = ap[i as usize];
                let z = up.dot(&v);
                for k in 0..2 {
                    let d = (l.n[k].dot(&v) - l.off[k]).abs();
                    let t = l.along[k].dot(&(v - l.corner));
                    let in_band = z > l.band.0 - 0.03 && z < l.band.1 + 0.03;
                    // Past the plate's end, look in a 15° wedge, not only the
                    // slab: a face the Hough vote saw a few degrees off still
                    // shows there.
                    if in_band && t > w + 0.15 && t < reach && d < tol + 0.27 * (t - w) {
                        beyond[k] += 1;
                        continue;
                    }
                    if d >= tol {
                        continue;
                    }
                    if in_band && t > 0.1 * w && t < w {
                        support[k] += 1;
                    } else if t > 0.15 * w
                        && t < w
                        && (z > l.band.1 + 0.15 && z < l.band.1 + 0.15 + h
                            || z < l.band.0 - 0.15 && z > l.band.0 - 0.15 - h)
                    {
                        beyond[k] += 1;
                    }
                }
            }
        }
    }
    (0..2).all(|k| 4 * beyond[k] <= support[k])
}

/// Largest count in three consecutive bins, and the centre of those bins.
fn peak(h: &[u32], base: i64, bin: f64) -> (usize, f64) {
    let mut best = (0, 0.0);
    for k in 0..h.len() {
        if h[k] == 0 {
            continue;
        }
        let c = h[k] as usize
            + k.checked_sub(1).map_or(0, |j| h[j] as usize)
            + h.get(k + 1).map_or(0, |&x| x as usize);
        if c > best.0 {
            best = (c, (k as i64 + base) as f64 * bin + 0.5 * bin);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_distr::{Distribution, Normal};

    struct Scene {
        pts: Vec<Point>,
        corner: Point,
    }

    /// Ground with slope and bumps, an L target (perforated plates on a post,
    /// antenna on top), and optional clutter, sampled uniformly with noise.
    fn scene(seed: u64, slope_deg: f64, heading: f64, clutter: &[&str]) -> Scene {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
        let noise = Normal::new(0.0, 0.01).unwrap();
        let origin = Vector3::new(352_000.0, 4_150_000.0, 40.0);
        let slope = slope_deg.to_radians().tan();
        let ground = |x: f64, y: f64| slope * x + 0.05 * (x * 0.8).sin() * (y * 0.6).cos();
        let mut pts = Vec::new();
        let mut push = |v: Vector3<f64>, rng: &mut rand_pcg::Pcg64Mcg| {
            let n = Vector3::new(noise.sample(rng), noise.sample(rng), noise.sample(rng));
            pts.push(Point::from(origin + v + n));
        };
        for _ in 0..20_000 {
            let (x, y) = (rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
            push(Vector3::new(x, y, ground(x, y)), &mut rng);
        }
        let (c, base) = (Vector3::new(0.7, -0.4, 0.0), ground(0.7, -0.4));
        let bottom = base + 0.8;
        let d = [
            Vector3::new(heading.cos(), heading.sin(), 0.0),
            Vector3::new(-heading.sin(), heading.cos(), 0.0),
        ];
        for k in 0..2 {
            let mut n = 0;
            while n < 400 {
                let (s, h) = (rng.random_range(0.0..0.6), rng.random_range(0.0..0.6));
                // Grill: bars every 5 cm, half open.
                if ((s / 0.025) as i64 + (h / 0.025) as i64) % 2 == 1 {
                    continue;
                }
                push(c + d[k] * s + Vector3::new(0.0, 0.0, bottom + h), &mut rng);
                n += 1;
            }
        }
        for _ in 0..80 {
            let h = rng.random_range(base..bottom);
            push(c + Vector3::new(0.0, 0.0, h), &mut rng); // post
        }
        for _ in 0..40 {
            let a: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            push(
                c + Vector3::new(0.08 * a.cos(), 0.08 * a.sin(), bottom + 0.7),
                &mut rng,
            ); // antenna
        }
        for what in clutter {
            match *what {
                "wall" => {
                    for _ in 0..4000 {
                        let (s, h) = (rng.random_range(-4.0..4.0), rng.random_range(0.0..3.0));
                        push(Vector3::new(-2.5, s, ground(-2.5, s) + h), &mut rng);
                    }
                }
                "pole" => {
                    for _ in 0..500 {
                        let a: f64 = rng.random_range(0.0..std::f64::consts::TAU);
                        let h = rng.random_range(0.0..4.0);
                        push(
                            Vector3::new(
                                2.2 + 0.1 * a.cos(),
                                0.3 + 0.1 * a.sin(),
                                ground(2.2, 0.3) + h,
                            ),
                            &mut rng,
                        );
                    }
                }
                "bush" => {
                    // A blob touching the back of the target.
                    let b = c - (d[0] + d[1]) * 0.45 + Vector3::new(0.0, 0.0, base + 0.6);
                    for _ in 0..1500 {
                        let v = Vector3::new(
                            rng.random_range(-1.0..1.0),
                            rng.random_range(-1.0..1.0),
                            rng.random_range(-1.0..1.0),
                        );
                        if v.norm() < 1.0 {
                            push(b + v * 0.5, &mut rng);
                        }
                    }
                }
                "car" => {
                    // A car body 0.8 m tall (as tall as an L of plates), its
                    // corner nearer the expected position than the target.
                    for _ in 0..8000 {
                        let (s, h) = (rng.random_range(0.0..4.5), rng.random_range(0.3..1.1));
                        let v = match rng.random_range(0..4) {
                            0 => Vector3::new(-4.0 + s, -2.0, 0.0),
                            1 => Vector3::new(-4.0 + s, -3.8, 0.0),
                            2 => Vector3::new(-4.0, -2.0 - s * 0.4, 0.0),
                            _ => Vector3::new(0.5, -2.0 - s * 0.4, 0.0),
                        };
                        push(v + Vector3::new(0.0, 0.0, ground(v.x, v.y) + h), &mut rng);
                    }
                }
                "box" => {
                    for _ in 0..6000 {
                        let (s, h) = (rng.random_range(0.0..4.5), rng.random_range(0.0..1.5));
                        let side = rng.random_range(0..2);
                        let v = if side == 0 {
                            Vector3::new(-1.0 + s, 2.6, 0.0)
                        } else {
                            Vector3::new(-1.0, 2.6 + s * 0.4, 0.0)
                        };
                        push(v + Vector3::new(0.0, 0.0, ground(v.x, v.y) + h), &mut rng);
                    }
                }
                _ => unreachable!(),
            }
        }
        let corner = Point::from(origin + c + Vector3::new(0.0, 0.0, bottom + 0.3));
        Scene { pts, corner }
    }

    fn check(sc: &Scene, expected_offset: Vector3<f64>) -> TightCrop {
        let expected = sc.corner + expected_offset;
        let t = tight_crop(&sc.pts, &expected, &TightParams::default()).unwrap();
        let e = ((t.corner_guess - sc.corner).xy()).norm();
        assert!(e < 0.06, "corner guess off by {e:.3} m");
        assert!(t.points.len() > 500, "only {} points kept", t.points.len());
        // Nothing far from the plates survives.
        for p in &t.points {
            assert!((p - sc.corner).xy().norm() < 0.75);
        }
        t
    }

    #[test]
    fn finds_target_on_level_ground() {
        let sc = scene(1, 0.0, 0.3, &[]);
        let t = check(&sc, Vector3::new(1.5, -1.0, 0.0));
        assert!(t.ground_tilt_deg < 1.0);
    }

    #[test]
    fn finds_target_on_sloped_ground_with_clutter() {
        for (seed, clutter) in [
            (2, vec!["wall"]),
            (3, vec!["pole", "box"]),
            (4, vec!["wall", "pole"]),
        ] {
            let sc = scene(seed, 4.0, 1.1 + seed as f64, &clutter);
            let t = check(&sc, Vector3::new(-1.0, 2.0, 0.0));
            // 4° of ground slope is a slope, not a tilted map.
            assert_eq!(t.up, [0.0, 0.0, 1.0]);
        }
    }

    #[test]
    fn a_car_corner_is_not_a_target() {
        let sc = scene(8, 1.0, 0.4, &["car"]);
        // Expected position 1.6 m from the car's corner, 2.2 m from the target.
        check(&sc, Vector3::new(-2.0, -0.8, 0.0));
    }

    #[test]
    fn finds_target_with_a_bush_touching_it() {
        let sc = scene(5, 1.0, 2.0, &["bush"]);
        check(&sc, Vector3::new(0.5, 0.5, 0.0));
    }

    #[test]
    fn reports_why_nothing_was_found() {
        assert_eq!(
            tight_crop(&[], &Point::origin(), &TightParams::default()).unwrap_err(),
            TightError::NoPoints
        );
        let mut sc = scene(6, 2.0, 0.0, &["wall"]);
        // Remove the target: everything within 1 m of it.
        let c = sc.corner;
        sc.pts.retain(|p| (p - c).xy().norm() > 1.0);
        let e = tight_crop(&sc.pts, &c, &TightParams::default()).unwrap_err();
        assert!(matches!(e, TightError::NoTargetShape { .. }), "{e}");
        let flat: Vec<Point> = (0..1000)
            .map(|i| Point::new((i % 40) as f64 * 0.2, (i / 40) as f64 * 0.2, 0.0))
            .collect();
        let e = tight_crop(&flat, &Point::new(4.0, 2.0, 0.0), &TightParams::default()).unwrap_err();
        assert!(matches!(e, TightError::NothingAboveGround { .. }), "{e}");
    }
}
