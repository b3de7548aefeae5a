//! Steps 3–4 of the tight crop: find the L. In windows about a target's size,
//! a Hough vote over headings finds the best perpendicular pair of vertical
//! planes; shape checks (an L, plate-sized, faces that stop) reject clutter; the
//! strong candidate nearest the expected position wins.

use super::TightParams;
use nalgebra::Vector3;
use std::collections::HashMap;

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

/// Hough over headings in windows centred on occupied cells. Returns the chosen
/// L, the number of windows that passed, the best score seen, and (when none
/// passed) what the best-supported rejected window looked like.
pub(super) fn detect_l(
    ap: &[Vector3<f64>],
    up: &Vector3<f64>,
    params: &TightParams,
    others: &[Vector3<f64>],
) -> (Option<LShape>, usize, usize, Option<String>) {
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
    let mut seen: Option<(usize, String)> = None;
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
        let bounded = |l: &LShape| is_bounded(l, &cells, ap, step, up, params);
        match fit_l(&window, up, params, bounded) {
            Ok(l) => {
                best_score = best_score.max(l.score);
                if l.score >= params.min_plate_points {
                    found.push(l);
                }
            }
            Err((s, why)) => {
                if !why.is_empty() && seen.as_ref().is_none_or(|b: &(usize, String)| s > b.0) {
                    seen = Some((s, why));
                }
            }
        }
    }
    // An L nearer another target's expected position is that target's.
    let theirs = |l: &LShape| {
        others
            .iter()
            .any(|o| (l.corner - o).xy().norm() < l.corner.xy().norm())
    };
    let before = found.len();
    found.retain(|l| !theirs(l));
    if found.is_empty() && before > 0 {
        let seen =
            "only target-shaped objects nearer another surveyed target's position than this one's";
        return (None, 0, best_score, Some(seen.into()));
    }
    let n = found.len();
    let Some(top) = found.iter().map(|l| l.score).max() else {
        return (None, 0, best_score, seen.map(|s| s.1));
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

/// Best perpendicular pair of vertical planes in one window, or `None` when the
/// support does not look like an L of the configured size.
fn fit_l(
    win: &[Vector3<f64>],
    up: &Vector3<f64>,
    p: &TightParams,
    bounded: impl Fn(&LShape) -> bool,
) -> Result<LShape, (usize, String)> {
    // Horizontal basis orthogonal to up.
    let e1 = (Vector3::x() - up * up.x).normalize();
    let e2 = up.cross(&e1);
    let bin = 0.02;
    let first = *win.first().ok_or((0, String::new()))?;
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
    let (_, deg, _, _) = best.ok_or((0, String::new()))?;
    let th = deg.to_radians();
    let na = e1 * th.cos() + e2 * th.sin();
    let nb = up.cross(&na);
    // At the winning heading, every strong peak of each histogram: a wall or a
    // container parallel behind a plate makes a peak of its own, often the
    // highest. Each pairing is checked in turn, strongest first; the plate is
    // the one that stops where a plate stops.
    let peaks = |n: &Vector3<f64>| {
        let base = (n.dot(&first) / bin).floor() as i64 - half;
        let mut h = vec![0u32; (2 * half + 1) as usize];
        for v in win {
            h[((n.dot(v) / bin).floor() as i64 - base).clamp(0, 2 * half) as usize] += 1;
        }
        strong_peaks(&h, base, bin, p.min_plate_points)
    };
    let (pa, pb) = (peaks(&na), peaks(&nb));
    let mut pairs: Vec<(usize, f64, f64)> = pa
        .iter()
        .flat_map(|a| pb.iter().map(move |b| (a.0.min(b.0), a.1, b.1)))
        .collect();
    pairs.sort_by_key(|x| std::cmp::Reverse(x.0));
    let mut why = Err((0, String::new()));
    for (score, oa, ob) in pairs {
        let checked = check_l(win, up, p, [na, nb], [oa, ob], score).and_then(|l| {
            if bounded(&l) {
                Ok(l)
            } else {
                Err((
                    score,
                    "faces going on past a plate's edge (a car, a cabinet, a wall)".into(),
                ))
            }
        });
        match checked {
            Ok(l) => return Ok(l),
            Err(e)
                if why
                    .as_ref()
                    .is_err_and(|w: &(usize, String)| w.1.is_empty()) =>
            {
                why = Err(e)
            }
            Err(_) => {}
        }
    }
    why
}

/// Whether the planes `n·x = off` (at one heading) are an L of the configured
/// size in this window; else the score and what the points looked like.
fn check_l(
    win: &[Vector3<f64>],
    up: &Vector3<f64>,
    p: &TightParams,
    [na, nb]: [Vector3<f64>; 2],
    [oa, ob]: [f64; 2],
    score: usize,
) -> Result<LShape, (usize, String)> {
    let no = |s: String| Err((score, s));
    let corner = na * oa + nb * ob;
    let tol = 0.04;
    let mut along = [Vector3::zeros(); 2];
    let mut width = [0.0; 2];
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
        if major < p.min_plate_points {
            return no(String::new());
        }
        if minor * 3 > major {
            return no("a plane running through the corner (a T or a cross)".into());
        }
        along[k] = dir * sign;
        let mut ext: Vec<f64> = ts.iter().map(|t| t * sign).filter(|&t| t > 0.0).collect();
        ext.sort_by(f64::total_cmp);
        let far = ext[(ext.len() * 9) / 10];
        if far > p.plate_width + 0.15 {
            return no(format!("a plane continuing {far:.1} m past the corner"));
        }
        // A plate is as wide as a plate: occlusion from below or foliage
        // thins it but leaves its top edge whole.
        width[k] = ext[(ext.len() * 19) / 20];
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
        return no(String::new());
    }
    inl_h.sort_by(f64::total_cmp);
    let lo = inl_h[inl_h.len() / 50];
    let hi = inl_h[inl_h.len() - 1 - inl_h.len() / 50];
    let narrow = width[0].min(width[1]);
    if narrow < MIN_WIDTH_SHARE * p.plate_width {
        return no(format!(
            "a {:.2} × {:.2} m L (plates {:.2} and {:.2} m wide, {} m expected)",
            narrow,
            hi - lo,
            width[0],
            width[1],
            p.plate_width
        ));
    }
    if hi - lo > p.plate_height + 0.25 {
        // taller than a plate: a wall, a cabinet, a tree
        return no(format!("an L {:.1} m tall", hi - lo));
    }
    Ok(LShape {
        n: [na, nb],
        off: [oa, ob],
        along,
        corner,
        band: (lo, hi),
        score,
        widths: width,
    })
}

/// A plate narrower than this share of the configured width (from the 95th
/// percentile of its points' distance from the corner) is not the target's:
/// the grill's frame returns at the far edge, so a whole plate reaches ~0.97.
const MIN_WIDTH_SHARE: f64 = 0.8;

/// Peaks tried per histogram. One (the strongest, as before issue 16): with
/// more, a wall behind a plate paired the other way, but foliage through the
/// plates made false Ls (see docs/algorithm.md).
const MAX_PEAKS: usize = 1;

/// Peaks (count of three bins ≥ `min`, centre) of a histogram, strongest
/// first, at most `MAX_PEAKS`, each at least 4 bins (8 cm) from a stronger one.
fn strong_peaks(h: &[u32], base: i64, bin: f64, min: usize) -> Vec<(usize, f64)> {
    let mut all: Vec<(usize, usize)> = (0..h.len())
        .filter(|&k| h[k] > 0)
        .map(|k| {
            let c = h[k] as usize
                + k.checked_sub(1).map_or(0, |j| h[j] as usize)
                + h.get(k + 1).map_or(0, |&x| x as usize);
            (c, k)
        })
        .filter(|&(c, _)| c >= min)
        .collect();
    all.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut kept: Vec<(usize, usize)> = Vec::new();
    for (c, k) in all {
        if kept.iter().all(|&(_, j)| j.abs_diff(k) >= 4) {
            kept.push((c, k));
            if kept.len() == MAX_PEAKS {
                break;
            }
        }
    }
    kept.into_iter()
        .map(|(c, k)| (c, (k as i64 + base) as f64 * bin + 0.5 * bin))
        .collect()
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
                    // A surface parallel behind the plate (0.1 m or more) is
                    // background seen through the grill, not the plate going on.
                    let wedge = (tol + 0.27 * (t - w)).min(0.08);
                    if in_band && t > w + 0.15 && t < reach && d < wedge {
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
