//! Steps 3–4 of the tight crop: find the L. In windows about a target's size,
//! a Hough vote over headings finds the best perpendicular pair of vertical
//! planes; shape checks (an L, plate-sized, faces that stop) reject clutter; the
//! strong candidate nearest the expected position wins.

use super::TightParams;
use crate::frame::grid::TileMap;
use crate::geom::densest_run;
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
pub(super) fn detect_l(
    ap: &[Vector3<f64>],
    up: &Vector3<f64>,
    params: &TightParams,
    others: &[Vector3<f64>],
) -> (Option<LShape>, usize, usize, Option<Rejected>) {
    let w = params.plate_width;
    let step = 0.25_f64.min(w / 2.0);
    let rw = 0.47 * w / 0.6 * 1.0 + step * 0.75;
    // Keys are sorted before use: the fast hasher changes nothing but time.
    let mut cells: TileMap<(i64, i64), Vec<u32>> = TileMap::default();
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
    let mut seen: Option<Rejected> = None;
    // Windows are independent: fitted in parallel (a dense crop's finder
    // then uses the cores its neighbours' targets left idle), consumed in
    // key order, so the choice is the same for any thread count.
    let flat = Flat::new(ap, up);
    let fits: Vec<Option<Result<LShape, Rejected>>> = keys
        .par_iter()
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
            let bounded = |l: &LShape| is_bounded(l, &cells, ap, step, up, params);
            Some(fit_l(&flat, window, up, params, bounded))
        })
        .collect();
    for fit in fits.into_iter().flatten() {
        match fit {
            Ok(l) => {
                best_score = best_score.max(l.score);
                if l.score >= params.min_plate_points {
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

/// The crop's points as the L finder reads them, computed once per crop
/// (each point lies in some twenty overlapping windows): in the horizontal
/// basis `e1, e2` orthogonal to "up" (a heading's normals are
/// `na = e1 cos θ + e2 sin θ` and `nb = up × na = e2 cos θ − e1 sin θ`, so a
/// projection is two products), and in height order.
struct Flat {
    e: [Vector3<f64>; 2],
    /// `[e1 · v, e2 · v]` of each point.
    xy: Vec<[f64; 2]>,
    /// (height, `xy`) of every point, by height.
    sorted: Vec<(f64, [f64; 2])>,
    /// Each point's place in `sorted`.
    rank: Vec<u32>,
}

impl Flat {
    fn new(ap: &[Vector3<f64>], up: &Vector3<f64>) -> Self {
        let e1 = (Vector3::x() - up * up.x).normalize();
        let e2 = up.cross(&e1);
        let xy: Vec<[f64; 2]> = ap.iter().map(|v| [e1.dot(v), e2.dot(v)]).collect();
        let mut order: Vec<(f64, u32)> = ap
            .iter()
            .enumerate()
            .map(|(i, v)| (up.dot(v), i as u32))
            .collect();
        order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut rank = vec![0u32; ap.len()];
        for (r, &(_, i)) in order.iter().enumerate() {
            rank[i as usize] = r as u32;
        }
        let sorted = order.iter().map(|&(z, i)| (z, xy[i as usize])).collect();
        Flat {
            e: [e1, e2],
            xy,
            sorted,
            rank,
        }
    }

    /// A window's points (by index) in height order: its ranks sorted, which
    /// is cheaper than sorting its heights.
    fn by_height(&self, win: &[u32]) -> Vec<(f64, [f64; 2])> {
        let mut r: Vec<u32> = win.iter().map(|&i| self.rank[i as usize]).collect();
        r.sort_unstable();
        r.into_iter().map(|k| self.sorted[k as usize]).collect()
    }
}

/// Best perpendicular pair of vertical planes in one window, or `None` when the
/// support does not look like an L of the configured size.
fn fit_l(
    flat: &Flat,
    win: &[u32],
    up: &Vector3<f64>,
    p: &TightParams,
    bounded: impl Fn(&LShape) -> bool,
) -> Result<LShape, Rejected> {
    let [e1, e2] = flat.e;
    let bin = 0.02;
    let [f1, f2] = flat.xy[*win.first().ok_or(Rejected::unnamed(0))? as usize];
    // Histograms over a fixed range around the first point (every window point
    // is within two window radii of it, plus what a slightly tilted "up" adds):
    // arrays, not hash maps, since this loop is most of a dense map's crop time.
    let half = ((4.0 * p.plate_width + 0.3) / bin).ceil() as i64 + 2;
    let mut hist_a = vec![0u32; (2 * half + 1) as usize];
    let mut hist_b = vec![0u32; (2 * half + 1) as usize];
    let xy: Vec<[f64; 2]> = win.iter().map(|&i| flat.xy[i as usize]).collect();
    // The heading (1.5° steps) where the weaker plate's peak is sharpest;
    // ties keep the lower angle.
    let mut score = |deg: f64, pts: &[[f64; 2]]| {
        // In bins: a product, not a division, per point (a point within an
        // ulp of a bin's edge may fall in the other bin than `peaks` puts
        // it; this only ranks headings).
        let (sn, cs) = f64::to_radians(deg).sin_cos();
        let (sn, cs) = (sn / bin, cs / bin);
        let base_a = (cs * f1 + sn * f2).floor() as i64 - half;
        let base_b = (cs * f2 - sn * f1).floor() as i64 - half;
        bin_headings(pts, [cs, sn], [base_a, base_b], [&mut hist_a, &mut hist_b]);
        sharp_peak(&hist_a).min(sharp_peak(&hist_b))
    };
    let mut headings = Vec::with_capacity(60);
    let mut deg = 0.0;
    while deg < 90.0 {
        headings.push(deg);
        deg += 1.5;
    }
    // A dense window (a wall, a TLS scan) is searched on a fixed-stride
    // sample of `HEADING_POINTS`, and its best few headings are scored
    // again on every point: the choice is the whole window's unless the
    // sample ranks the best heading below `HEADING_RESCORE` others.
    let stride = win.len().div_ceil(HEADING_POINTS).max(1);
    if stride > 1 {
        let sample: Vec<[f64; 2]> = xy.iter().step_by(stride).copied().collect();
        let mut ranked: Vec<(usize, usize)> = headings
            .iter()
            .enumerate()
            .map(|(k, &d)| (score(d, &sample), k))
            .collect();
        ranked.sort_unstable_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut keep: Vec<usize> = ranked.iter().take(HEADING_RESCORE).map(|r| r.1).collect();
        keep.sort_unstable();
        headings = keep.into_iter().map(|k| headings[k]).collect();
    }
    let mut best = (0, 0.0);
    for deg in headings {
        let support = score(deg, &xy);
        if support > best.0 {
            best = (support, deg);
        }
    }
    let deg = best.1;
    let mut why = Rejected::unnamed(0);
    let (sn, cs) = deg.to_radians().sin_cos();
    let na = e1 * cs + e2 * sn;
    let nb = up.cross(&na);
    // At the winning heading, every strong peak of each histogram: a wall or a
    // container parallel behind a plate makes a peak of its own, often the
    // highest. Each pairing is checked in turn, strongest first; the plate
    // is the one that stops where a plate stops.
    let peaks = |proj: &dyn Fn(f64, f64) -> f64| {
        let base = (proj(f1, f2) / bin).floor() as i64 - half;
        let mut h = vec![0u32; (2 * half + 1) as usize];
        for &[x, y] in &xy {
            h[((proj(x, y) / bin).floor() as i64 - base).clamp(0, 2 * half) as usize] += 1;
        }
        strong_peaks(&h, base, bin, p.min_plate_points)
    };
    let (pa, pb) = (
        peaks(&|x, y| cs * x + sn * y),
        peaks(&|x, y| cs * y - sn * x),
    );
    let mut pairs: Vec<(usize, usize, usize)> = (0..pa.len())
        .flat_map(|i| (0..pb.len()).map(move |j| (i, j)))
        .map(|(i, j)| (pa[i].0.min(pb[j].0), i, j))
        .collect();
    pairs.sort_by_key(|x| std::cmp::Reverse(x.0));
    // Each peak's plane is gathered from the window once, when a pairing
    // first needs it: up to nine pairings share six planes (each pairing
    // used to rescan the window for both of its planes and sort what it
    // found, most of a dense window's time).
    // The window in height order, once, so that every plane's points come
    // out in height order without sorting each.
    let mut by_height: Vec<(f64, [f64; 2])> = Vec::new();
    let mut planes_a: Vec<Option<PlanePoints>> = vec![None; pa.len()];
    let mut planes_b: Vec<Option<PlanePoints>> = vec![None; pb.len()];
    let (ca, cb) = ([cs, sn], [-sn, cs]);
    for (score, i, j) in pairs {
        let (oa, ob) = (pa[i].1, pb[j].1);
        if by_height.is_empty() {
            by_height = flat.by_height(win);
        }
        let a = &*planes_a[i].get_or_insert_with(|| PlanePoints::gather(&by_height, ca, oa, cb));
        let b = &*planes_b[j].get_or_insert_with(|| PlanePoints::gather(&by_height, cb, ob, ca));
        let checked = check_l(p, [na, nb], [oa, ob], [a, b], score).and_then(|l| {
            if bounded(&l) {
                Ok(l)
            } else {
                Err(Rejected {
                    score,
                    why: "faces going on past a plate's edge (a car, a cabinet, a wall)".into(),
                    corner: l.corner,
                    along: l.along,
                    size: None,
                })
            }
        });
        match checked {
            Ok(l) => return Ok(l),
            Err(e) if why.why.is_empty() => why = e,
            Err(_) => {}
        }
    }
    Err(why)
}

/// Counts `pts` afresh into two histograms of their projections (in bins) on the
/// heading `(cs, sn)` and across it, less the bases, clamped to the ends.
/// Its own function over plain slices: in the closure that calls it, every
/// increment reloaded the vectors' pointers and lengths (a write through one
/// might move them, as the compiler saw it), ~55 instructions a point where
/// this takes ~30; the bins are the same (`fit_l`'s heading search runs this
/// ~90 000 times a window).
fn bin_headings(
    pts: &[[f64; 2]],
    [cs, sn]: [f64; 2],
    [base_a, base_b]: [i64; 2],
    [ha, hb]: [&mut [u32]; 2],
) {
    ha.fill(0);
    hb.fill(0);
    let top = ha.len().min(hb.len()) as i64 - 1;
    for &[x, y] in pts {
        let ia = ((cs * x + sn * y).floor() as i64 - base_a).max(0).min(top);
        let ib = ((cs * y - sn * x).floor() as i64 - base_b).max(0).min(top);
        ha[ia as usize] += 1;
        hb[ib as usize] += 1;
    }
}

/// Whether the planes `n·x = off` (at one heading) are an L of the configured
/// size in this window; else the score and what the points looked like.
///
/// The plates' height band is chosen first: the densest band of a plate's
/// height, among those with clear space above and below in the plates'
/// planes (a grill plate is a band; a stack under it, a cabinet or a car side
/// goes on). Every other check looks inside that band only, so an object at
/// the target's feet or foliage below the plates cannot make it "too tall".
fn check_l(
    p: &TightParams,
    [na, nb]: [Vector3<f64>; 2],
    [oa, ob]: [f64; 2],
    planes: [&PlanePoints; 2],
    score: usize,
) -> Result<LShape, Rejected> {
    let w = p.plate_width;
    let corner = na * oa + nb * ob;
    let mut along = [Vector3::zeros(); 2];
    // Refused, with what was seen and where (the faces as far as decided),
    // and its size when that alone refused it.
    let mut size = None;
    macro_rules! no {
        ($why:expr) => {
            return Err(Rejected {
                score,
                why: $why,
                corner,
                along,
                size,
            })
        };
    }
    let mut width = [0.0; 2];
    // Each plate's near points: (distance from the plane, along the plate
    // from the corner, height). The side of the corner the plate lies on is
    // the side most of its slab points near the corner are.
    // Ordered by height, as their planes' points are.
    let mut near: [Vec<Near>; 2] = [Vec::new(), Vec::new()];
    // Per plate, the corner's position along it and the side it lies on.
    let mut placed = [(0.0, 1.0); 2];
    for (k, dir) in [nb, na].into_iter().enumerate() {
        let plane = planes[k];
        // Distance along the plane from the corner: `s` less the corner's.
        let c = dir.dot(&corner);
        // Points spread along the plane, less its densest 0.12 m: a surface
        // standing across the plane (a wall behind the other plate) puts
        // many points at one distance from the corner, a plate spreads them.
        // (The count itself is checked whole: a sparse plate's frame edge
        // may hold a third of its points.) `x - c` grows with `x`, so the
        // slab's sorted `s` give the sorted distances of a span by two
        // binary searches.
        let side = |lo: f64, hi: f64| {
            let s = &plane.slab;
            let span = s.partition_point(|a| a.0 - c <= lo)..s.partition_point(|a| a.0 - c < hi);
            let t: Vec<f64> = s[span].iter().map(|a| a.0 - c).collect();
            (t.len() - densest_run(&t, 0.12), t.len())
        };
        let (pos, neg) = (side(0.05, w + 0.15), side(-w - 0.15, -0.05));
        let (sign, count) = if pos.0 >= neg.0 {
            (1.0, pos.1)
        } else {
            (-1.0, neg.1)
        };
        if count < p.min_plate_points {
            no!(String::new());
        }
        along[k] = dir * sign;
        placed[k] = (c, sign);
        near[k] = plane
            .pts
            .iter()
            .map(|q| Near {
                t: (q.t - c) * sign,
                ..*q
            })
            .collect();
    }
    // The plates' heights, once: the band is chosen from them, and when
    // none is clear they say how tall the faces are.
    let z = on_plate_heights(&near, w);
    let Some((lo, hi)) = plate_band(&near, &z, p) else {
        if z.len() < 2 * p.min_plate_points {
            no!(String::new());
        }
        let tall = z[z.len() - 1 - z.len() / 50] - z[z.len() / 50];
        // Its faces stop within a few plate heights: an L of taller plates.
        if tall < 2.5 * p.plate_height {
            size = Some(Box::new([f64::NAN, f64::NAN, tall]));
        }
        no!(format!(
            "an L {tall:.1} m tall (its faces go on above or below a plate's height)"
        ));
    };
    let mut planar = [0usize; 2];
    let mut counts = [0usize; 2];
    for k in 0..2 {
        // The slab's distances along the plate in the band, ascending.
        let (c, sign) = placed[k];
        let ts = planes[k].slab_distances(c, sign, lo - 0.05, hi + 0.05);
        let major = ts.iter().filter(|&&t| t > 0.05).count();
        if major < p.min_plate_points {
            no!(String::new());
        }
        // An L: the plate lies on one side of the corner. Behind the corner,
        // this plate's plane crosses whatever stands parallel behind the
        // other plate (a wall seen through its grill): those points sit at
        // one distance, while a plate going on spreads along its plane.
        let behind = &ts[..ts.partition_point(|&t| t < -0.05)];
        let minor = behind.len() - densest_run(behind, 0.12);
        if minor * 3 > major {
            no!("a plane running through the corner (a T or a cross)".into());
        }
        let ext = &ts[ts.partition_point(|&t| t <= 0.0)..];
        let far = ext[(ext.len() * 9) / 10];
        if far > w + 0.15 {
            // A plane that stops within a few plate widths: a wider plate.
            let edge = ext[(ext.len() * 19) / 20];
            if edge < 2.5 * w {
                size = Some(Box::new([edge, f64::NAN, f64::NAN]));
            }
            no!(format!("a plane continuing {far:.1} m past the corner"));
        }
        // A plate is as wide as a plate: occlusion from below or foliage
        // thins it but leaves its top edge whole.
        width[k] = ext[(ext.len() * 19) / 20];
        counts[k] = ext.len();
        // ... and its points reach from the corner to that edge: a plane
        // crossing a wall obliquely holds a strip of wall at one distance.
        let first = ext[ext.len() / 10];
        if first > 0.35 * w {
            no!(format!(
                "plate {}'s points start {first:.2} m from the corner, not at it",
                k + 1
            ));
        }
        // A plate is thin: points spread through a volume (foliage, a bush)
        // fill the shells beside the plane as much as the slab.
        let (slab, excess) = planar_count(&near[k], 0.1 * w, w, lo, hi);
        if 2 * excess < slab {
            no!(format!(
                "points spread through a volume, not a plate (foliage?): {} of {slab} in plate {}'s plane stand out from their surroundings",
                excess,
                k + 1
            ));
        }
        planar[k] = excess;
        // ... and a rectangle: its points span its width at each height or
        // its band at each place along it. A slanted object crossing the
        // plane (a pipe, a machine's sloping face) does neither (issue 30:
        // a pump room's machine base).
        let (c, sign) = placed[k];
        if let [Some(rows), Some(columns)] = spanning(&planes[k].slab, c, sign, lo, hi, w)
            && rows.max(columns) < MIN_SPANNING_SHARE
        {
            no!(format!(
                "plate {}'s points do not fill a rectangle ({:.0} % of them in rows spanning its width, {:.0} % in columns spanning its height): a slanted object, not a plate",
                k + 1,
                100.0 * rows,
                100.0 * columns
            ));
        }
    }
    // The 95th percentile of n points spread over a plate scatters by about
    // 0.22 w / √n: a plate is allowed one of those (3 cm with 20 points).
    let slack = |k: usize| 0.22 * w / (counts[k].max(1) as f64).sqrt();
    let short = (0..2).any(|k| width[k] < MIN_WIDTH_SHARE * w - slack(k));
    let long = (0..2).any(|k| width[k] > MAX_WIDTH_SHARE * w + slack(k));
    let narrow = width[0].min(width[1]);
    let tall = hi - lo;
    let low = tall < MIN_HEIGHT_SHARE * p.plate_height - 0.02;
    if short || long || low {
        size = Some(Box::new([width[0], width[1], tall]));
    }
    if short || long {
        no!(format!(
            "a {:.2} × {:.2} m L (plates {:.2} and {:.2} m wide, {} m expected)",
            narrow,
            hi - lo,
            width[0],
            width[1],
            w
        ));
    }
    // ... and as tall as a plate, less what may hide its lower part (grass,
    // a barrier): the rim of a mound, a log, a kerb or a bumper make an L of
    // the right width a hand's height tall (issue 30: 0.12 m "plates").
    if low {
        no!(format!(
            "an L {tall:.2} m tall ({} m plates expected, at most {:.0} % of them hidden)",
            p.plate_height,
            100.0 * (1.0 - MIN_HEIGHT_SHARE)
        ));
    }
    Ok(LShape {
        n: [na, nb],
        off: [oa, ob],
        along,
        corner,
        band: (lo, hi),
        score: planar[0].min(planar[1]),
        widths: width,
    })
}

/// How far a plate's slab points (`slab`: raw position along the plate,
/// height; `c`, `sign`: the corner and the side, as `check_l` placed them)
/// in the band `lo..hi` fill a rectangle: the share of them in `SPAN_ROW`
/// rows that stretch `MIN_SPAN` of the width, and the share in `SPAN_COLUMNS`
/// columns that stretch `MIN_SPAN` of the band's height (each stretch from
/// the 5th to the 95th percentile, over cells of `MIN_CELL_POINTS` or more).
/// A plate's points fill it: a scan line crossing it level makes rows that
/// span it, one crossing it aslant (a sensor above the plate, the plate
/// turned) rows that do not, but then every column meets every line; hidden
/// parts (grass, a barrier below, returns thinned) leave cells sparse, not
/// short. A slanted object crossing the plane (a machine's sloping face)
/// holds a short stretch at each height and a short one at each place
/// along: both shares low. Each is `None` without `MIN_SPAN_EVIDENCE` (a far
/// or sparse plate, a rosette's few petals).
fn spanning(slab: &[(f64, f64)], c: f64, sign: f64, lo: f64, hi: f64, w: f64) -> [Option<f64>; 2] {
    let n_rows = ((hi - lo) / SPAN_ROW).ceil().max(1.0) as usize;
    let mut rows: Vec<Vec<f64>> = vec![Vec::new(); n_rows];
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); SPAN_COLUMNS];
    for &(x, z) in slab {
        let t = (x - c) * sign;
        if z > lo && z < hi && t > 0.0 && t < w {
            rows[(((z - lo) / SPAN_ROW) as usize).min(n_rows - 1)].push(t);
            columns[((t / w * SPAN_COLUMNS as f64) as usize).min(SPAN_COLUMNS - 1)].push(z);
        }
    }
    [
        spanning_share(rows, MIN_SPAN * w),
        spanning_share(columns, MIN_SPAN * (hi - lo)),
    ]
}

/// The share of the points of `cells` (those with `MIN_CELL_POINTS` or
/// more) in cells whose 5th–95th percentile stretch is at least `need`;
/// `None` without `MIN_SPAN_EVIDENCE`.
fn spanning_share(cells: Vec<Vec<f64>>, need: f64) -> Option<f64> {
    let (mut counted, mut spanning, mut judged) = (0usize, 0usize, 0usize);
    for mut v in cells {
        if v.len() < MIN_CELL_POINTS {
            continue;
        }
        judged += 1;
        v.sort_unstable_by(f64::total_cmp);
        let n = v.len();
        counted += n;
        if v[n - 1 - n / 20] - v[n / 20] >= need {
            spanning += n;
        }
    }
    (counted >= MIN_SPAN_EVIDENCE.0 && judged >= MIN_SPAN_EVIDENCE.1)
        .then(|| spanning as f64 / counted as f64)
}

/// Points and cells `spanning_share` needs to judge: a sparse plate's few
/// rows are arcs of whichever scan lines crossed it (a rosette's petals
/// cross a plate in part), and a row of 20 points may be one short arc.
const MIN_SPAN_EVIDENCE: (usize, usize) = (200, 3);
/// Rows of `spanning` (m): a level scan line's returns on a plate lie
/// within a few centimetres of one height.
const SPAN_ROW: f64 = 0.05;
/// Columns of `spanning` across a plate's width.
const SPAN_COLUMNS: usize = 6;
/// Fewest points in a row or column whose stretch counts.
const MIN_CELL_POINTS: usize = 20;
/// A row or column spans the plate when its points stretch this share of
/// the plate's width or band (a whole one stretches ~0.9 between its 5th
/// and 95th percentiles).
const MIN_SPAN: f64 = 0.6;
/// A plate has at least this share of its counted points in spanning rows,
/// or in spanning columns.
const MIN_SPANNING_SHARE: f64 = 0.5;

/// One histogram peak's plane in a window: the points within the shells'
/// reach of it, gathered once for every pairing that uses it.
#[derive(Clone)]
struct PlanePoints {
    /// Points within `SHELL.1` of the plane, ordered by height; `t` holds
    /// the position along the plane from the window's origin (the other
    /// plate's normal · point), which a pairing turns into the distance from
    /// its corner by a subtraction, keeping the order.
    pts: Vec<Near>,
    /// The slab's points (`|d| < SLAB`) as (position, height), ordered by
    /// position: a pairing's distances along the plate come out sorted.
    slab: Vec<(f64, f64)>,
}

impl PlanePoints {
    /// The plane `n · x = off`, positions along `dir`, from the window's
    /// points in height order (height, point).
    fn gather(by_height: &[(f64, [f64; 2])], n: [f64; 2], off: f64, dir: [f64; 2]) -> Self {
        let pts: Vec<Near> = by_height
            .iter()
            .filter_map(|&(z, [x, y])| {
                let d = (n[0] * x + n[1] * y) - off;
                (d.abs() < SHELL.1).then(|| Near {
                    d,
                    t: dir[0] * x + dir[1] * y,
                    z,
                })
            })
            .collect();
        let mut slab: Vec<(f64, f64)> = pts
            .iter()
            .filter(|q| q.d.abs() < SLAB)
            .map(|q| (q.t, q.z))
            .collect();
        slab.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        PlanePoints { pts, slab }
    }

    /// Distances from the corner (`x - c`, times `sign`) of the slab's
    /// points with heights in `(z0, z1)`, ascending.
    fn slab_distances(&self, c: f64, sign: f64, z0: f64, z1: f64) -> Vec<f64> {
        let t = |&(x, z): &(f64, f64)| (z > z0 && z < z1).then_some((x - c) * sign);
        if sign > 0.0 {
            self.slab.iter().filter_map(t).collect()
        } else {
            self.slab.iter().rev().filter_map(t).collect()
        }
    }
}

/// Heights of both plates' slab points over the plate away from the post
/// (`0.1 w < t < w`), sorted: a merge, since each plate's are in height
/// order already.
fn on_plate_heights(near: &[Vec<Near>; 2], w: f64) -> Vec<f64> {
    let on_plate = |q: &&Near| q.d.abs() < SLAB && q.t > 0.1 * w && q.t < w;
    let mut a = near[0].iter().filter(on_plate).map(|q| q.z).peekable();
    let mut b = near[1].iter().filter(on_plate).map(|q| q.z).peekable();
    let mut z = Vec::new();
    loop {
        let next = match (a.peek(), b.peek()) {
            (Some(x), Some(y)) if x.total_cmp(y).is_le() => a.next(),
            (Some(_), Some(_)) => b.next(),
            (Some(_), None) => a.next(),
            (None, _) => b.next(),
        };
        match next {
            Some(v) => z.push(v),
            None => break,
        }
    }
    debug_assert!(z.is_sorted_by(|a, b| a.total_cmp(b).is_le()));
    z
}

/// A point near one plate's plane, in that plate's terms.
#[derive(Clone, Copy)]
struct Near {
    /// Signed distance from the plane (m).
    d: f64,
    /// Distance along the plate from the corner (m; positive on the plate).
    t: f64,
    /// Height along "up" (m).
    z: f64,
}

/// Half-width of the slab that holds a plate's points (2 σ of the range
/// noise a survey-grade map has, and the plate's own 1–2 cm).
const SLAB: f64 = 0.04;

/// The shells beside a slab (distance from the plane): as wide as half the
/// slab, so twice the emptier shell is what a volume of points puts in it.
const SHELL: (f64, f64) = (0.05, 0.09);

/// Points of one plate's slab in `t0..t1` along it and `z0..z1` up, and how
/// many of them stand out as a surface: the slab's count less what the
/// emptier of the two shells beside it says a volume would put there. A wall
/// behind the grill fills one shell only; foliage fills both.
fn planar_count(near: &[Near], t0: f64, t1: f64, z0: f64, z1: f64) -> (usize, usize) {
    let (mut slab, mut front, mut back) = (0usize, 0usize, 0usize);
    for q in near {
        if q.t <= t0 || q.t >= t1 || q.z <= z0 || q.z >= z1 {
            continue;
        }
        let a = q.d.abs();
        if a < SLAB {
            slab += 1;
        } else if a > SHELL.0 && a < SHELL.1 {
            if q.d > 0.0 {
                front += 1;
            } else {
                back += 1;
            }
        }
    }
    (slab, slab.saturating_sub(2 * front.min(back)))
}

/// The plates' height band: of the bands a plate's height tall (2 cm steps,
/// plus the noise), the best supported whose planes are clear just above and
/// below it on both plates; its 2nd–98th percentile heights (a plate hidden
/// from below shows only its upper part). `None` when every band's faces go on.
/// `z`: the plates' on-plate heights in order (`on_plate_heights`).
fn plate_band(near: &[Vec<Near>; 2], z: &[f64], p: &TightParams) -> Option<(f64, f64)> {
    let w = p.plate_width;
    if z.len() < 2 * p.min_plate_points {
        return None;
    }
    let h = p.plate_height + 0.04;
    let count = |a: f64, b: f64| z.partition_point(|&x| x < b) - z.partition_point(|&x| x < a);
    let mut bands: Vec<(usize, f64)> = Vec::new();
    let mut s = z[0] - 0.02;
    while s + h < z[z.len() - 1] + 0.04 {
        bands.push((count(s, s + h), s));
        s += 0.02;
    }
    if bands.is_empty() {
        bands.push((z.len(), z[0]));
    }
    bands.sort_unstable_by(|a, b| b.0.cmp(&a.0).then(a.1.total_cmp(&b.1)));
    // The first clear band as wide as a plate on both plates; else the first
    // clear band (then refused by its widths). A solid object at the feet
    // whose faces lie in the plates' planes (a pallet stack inside the L) is
    // a clear band too, denser than the grill above it, but it stops short
    // of a plate's far edge (clutter stack seed 8).
    // Each plate's points indexed by height once: a band's checks then cost
    // a few binary searches, not a pass over the plate (a cluttered crop
    // tries many bands, and each looked at every near point ~70 times).
    let plates = [ByHeight::new(&near[0], w), ByHeight::new(&near[1], w)];
    let mut first_clear = None;
    for (n, s) in bands {
        if n < 2 * p.min_plate_points {
            break;
        }
        // `z` is sorted: the band's heights are one run of it.
        let inside = &z[z.partition_point(|&x| x < s)..z.partition_point(|&x| x < s + h)];
        let (lo, hi) = (
            inside[inside.len() / 50],
            inside[inside.len() - 1 - inside.len() / 50],
        );
        if plates.iter().all(|pl| clear_beside(pl, lo, hi)) {
            if plates.iter().all(|pl| plate_wide(pl, lo, hi, w)) {
                return Some((lo, hi));
            }
            first_clear.get_or_insert((lo, hi));
        }
    }
    first_clear
}

/// Heights in order, with an index of 5 mm buckets: how many lie below a
/// height is one lookup and a search of three buckets, where a binary search
/// of the whole list took a dozen unpredictable branches. `clear_beside` asks
/// it some seventy times a band, and a wall's window tries every band (half
/// of a dense crop's L finder went there).
struct Indexed {
    v: Vec<f64>,
    z0: f64,
    /// `start[k]`: how many heights lie below `z0 + k BUCKET`; the last
    /// entry is above every height.
    start: Vec<u32>,
}

/// `Indexed`'s bucket (m).
const BUCKET: f64 = 0.005;

impl Indexed {
    fn new(mut v: Vec<f64>) -> Self {
        // `ByHeight` hands over a sorted list (`near` is in height order,
        // `PlanePoints`): the check is one pass, kept so that the index
        // holds for any input.
        if !v.is_sorted_by(|a, b| a.total_cmp(b).is_le()) {
            v.sort_unstable_by(f64::total_cmp);
        }
        let z0 = v.first().copied().unwrap_or(0.0);
        let n = v.last().map_or(0, |&l| ((l - z0) / BUCKET) as usize + 2);
        let mut start = Vec::with_capacity(n + 1);
        let mut i = 0;
        for k in 0..=n {
            let e = z0 + k as f64 * BUCKET;
            while i < v.len() && v[i] < e {
                i += 1;
            }
            start.push(i as u32);
        }
        Indexed { v, z0, start }
    }

    /// `v.partition_point(|&x| x < z)`, exactly: the buckets either side of
    /// `z`'s are searched too, so a rounded bucket edge cannot misplace it.
    fn below(&self, z: f64) -> usize {
        let f = (z - self.z0) / BUCKET;
        // Below the second bucket, within two of the top, or no index.
        if !(f >= 1.0) || f + 3.0 >= self.start.len() as f64 {
            return self.v.partition_point(|&x| x < z);
        }
        let k = f as usize;
        let (lo, hi) = (self.start[k - 1] as usize, self.start[k + 2] as usize);
        lo + self.v[lo..hi].partition_point(|&x| x < z)
    }
}

/// One plate's near points sorted by height, for `plate_band`'s per-band
/// checks: the slab and the two shells beside it over the plate's width
/// away from the post (`clear_beside`'s rows), and the slab's points on the
/// plate's side of the corner with their distance along it (`plate_wide`).
struct ByHeight {
    /// Heights of the points in the slab or in either shell, `0.15 w < t < w`.
    all: Indexed,
    /// `cum[i]`: how many of `all`'s first `i` heights lie in the slab, the
    /// shell in front (`d > 0`) and the shell behind. One list with running
    /// counts, so that a row edge is one search, not one per list (the
    /// searches were most of `plate_band`'s time on a wall's windows).
    cum: Vec<[u32; 3]>,
    /// (height, distance along the plate) in the slab with `t > 0`, unsorted:
    /// `plate_wide` takes a percentile of a band's, which needs no order, and
    /// few bands get that far.
    ext: Vec<(f64, f64)>,
}

impl ByHeight {
    fn new(near: &[Near], w: f64) -> Self {
        let (t0, t1) = (0.15 * w, w);
        let mut kinds: Vec<(f64, u8)> = Vec::with_capacity(near.len());
        let mut ext = Vec::with_capacity(near.len());
        for q in near {
            let a = q.d.abs();
            if a < SLAB && q.t > 0.0 {
                ext.push((q.z, q.t));
            }
            if q.t <= t0 || q.t >= t1 {
                continue;
            }
            if a < SLAB {
                kinds.push((q.z, 0));
            } else if a > SHELL.0 && a < SHELL.1 {
                kinds.push((q.z, if q.d > 0.0 { 1 } else { 2 }));
            }
        }
        // `near` is in height order (`PlanePoints`); sorted here only for
        // other input (the unit tests' shuffled plates).
        if !kinds.is_sorted_by(|a, b| a.0.total_cmp(&b.0).is_le()) {
            kinds.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        let mut cum = Vec::with_capacity(kinds.len() + 1);
        let mut c = [0u32; 3];
        cum.push(c);
        for &(_, k) in &kinds {
            c[k as usize] += 1;
            cum.push(c);
        }
        ByHeight {
            all: Indexed::new(kinds.into_iter().map(|k| k.0).collect()),
            cum,
            ext,
        }
    }

    /// Where the row edge `z` falls in the slab, front and back heights:
    /// (points below it, points at or below it) in each.
    fn edge(&self, z: f64) -> [(usize, usize); 3] {
        let below = self.all.below(z);
        let at = below + self.all.v[below..].iter().take_while(|&&x| x == z).count();
        let (b, a) = (self.cum[below], self.cum[at]);
        [0, 1, 2].map(|k| (b[k] as usize, a[k] as usize))
    }

    /// `planar_count(near, 0.15 w, w, a, b).1` of the row between two edges
    /// (`a < b`): the slab's points strictly between them less twice the
    /// emptier shell's.
    fn planar(a: &[(usize, usize); 3], b: &[(usize, usize); 3]) -> usize {
        let between = |k: usize| b[k].0 - a[k].1;
        between(0).saturating_sub(2 * between(1).min(between(2)))
    }

    /// The planar counts of the 2 cm rows between the edges `z0 + i ROW` and
    /// `z0 + (i + 1) ROW`, for `i` in `rows`, in that order (up or down).
    /// Each edge is searched for once, closing one row and opening the next:
    /// half the binary searches of looking each row up by its two edges,
    /// which were most of `plate_band`'s time in a cluttered crop. (The old
    /// per-row upper edge `a + ROW` could differ from the next row's lower
    /// edge in the last bit; now rows tile the height exactly. A point on an
    /// edge, which only a map quantised to a grid holds, may fall in the
    /// other row than before; on the synthetic scenes every decision was the
    /// same.) Lazy: a walk that stops early searches no further.
    fn rows(
        &self,
        z0: f64,
        mut rows: std::ops::Range<usize>,
        down: bool,
    ) -> impl Iterator<Item = usize> + '_ {
        let at = move |i: usize| self.edge(z0 + i as f64 * ROW);
        // The edge shared with the row before, in walking order.
        let mut held: Option<(usize, [(usize, usize); 3])> = None;
        std::iter::from_fn(move || {
            let i = if down { rows.next_back() } else { rows.next() }?;
            let (shared, other) = if down { (i + 1, i) } else { (i, i + 1) };
            let first = match held.take() {
                Some((j, e)) if j == shared => e,
                _ => at(shared),
            };
            let second = at(other);
            held = Some((other, second));
            Some(if down {
                Self::planar(&second, &first)
            } else {
                Self::planar(&first, &second)
            })
        })
    }
}

/// Whether a plate's points in the band reach a plate's width, as
/// `check_l`'s width test measures it (the 95th percentile along the plate
/// from the corner, less the scatter of n points).
fn plate_wide(pl: &ByHeight, lo: f64, hi: f64, w: f64) -> bool {
    let (a, b) = (lo - 0.05, hi + 0.05);
    let mut ext: Vec<f64> = pl
        .ext
        .iter()
        .filter(|e| e.0 > a && e.0 < b)
        .map(|e| e.1)
        .collect();
    if ext.is_empty() {
        return false;
    }
    let k = (ext.len() * 19) / 20;
    let width = *ext.select_nth_unstable_by(k, f64::total_cmp).1;
    width >= MIN_WIDTH_SHARE * w - 0.22 * w / (ext.len() as f64).sqrt()
}

/// Whether a plate's plane is clear just below and above its band (away from
/// the post). Walking out from the band's edge in 2 cm rows, a face going on
/// (a cabinet, a car, a wall) keeps finding surface rows with no gap wider
/// than the plate's own gaps between scan lines; a gap wider than that, then
/// an object (a stack at the target's feet), is allowed, and so is foliage
/// (points that do not stand out from the shells beside the plane).
///
/// Fixed thin strips were measured to fail here: a LiDAR's rings leave
/// 8 cm strips of a cabinet's face nearly empty when the band ends in a lull.
fn clear_beside(pl: &ByHeight, lo: f64, hi: f64) -> bool {
    let n_in = ((hi - lo) / ROW).ceil().max(1.0) as usize;
    let inside: Vec<usize> = pl.rows(lo, 0..n_in, false).collect();
    let total: usize = inside.iter().sum();
    if total == 0 {
        return true;
    }
    // The widest run of empty rows inside the band: the scan lines' spacing.
    let mut gap_in = 0usize;
    let mut run = 0usize;
    for &r in &inside {
        run = if r == 0 { run + 1 } else { 0 };
        gap_in = gap_in.max(run);
    }
    let allowed = ((gap_in as f64 * 1.5).ceil() as usize).max((MIN_GAP / ROW).round() as usize);
    let per_row = total as f64 / inside.len() as f64;
    let n_out = (REACH / ROW).round() as usize;
    // Rows walking out from each edge, nearest first; below only when the
    // plate is clear above.
    let walk = |out: &mut dyn Iterator<Item = usize>| {
        let (mut last, mut empty, mut count) = (None, 0usize, 0usize);
        for (i, r) in out.enumerate() {
            if r > 0 {
                last = Some(i);
                count += r;
                empty = 0;
            } else {
                empty += 1;
                if empty > allowed {
                    break;
                }
            }
        }
        let Some(last) = last else { return true };
        let extent = (last + 1) as f64 * ROW;
        // Beyond the band's 2nd/98th percentile edge a plate leaves a few
        // noisy rows; a face going on fills what it reaches at 30 % or more
        // of the plate's own density.
        !(extent >= GOING_ON && count as f64 >= 0.3 * per_row * (last + 1) as f64)
    };
    walk(&mut pl.rows(hi, 0..n_out, false)) && walk(&mut pl.rows(lo - REACH, 0..n_out, true))
}

/// Most window points the heading search histograms at every heading (see
/// `fit_l`); denser windows are searched on a sample and rescored. The
/// clutter cases' target windows came out the same with it (only the
/// `DETECT_POINTS` sample moved corners there).
const HEADING_POINTS: usize = 1500;

/// Headings a dense window's sample passes on to be scored on every point.
const HEADING_RESCORE: usize = 6;

/// Rows in which `clear_beside` walks out from a plate's band (m).
const ROW: f64 = 0.02;

/// How far out from a plate's band `clear_beside` looks (m).
const REACH: f64 = 0.36;

/// The least gap (m) that parts a plate from an object beyond it; wider when
/// the plate's own scan lines lie farther apart.
const MIN_GAP: f64 = 0.08;

/// A face reaching this far past a plate's band (m) goes on.
const GOING_ON: f64 = 0.12;

/// A plate narrower than this share of the configured width (from the 95th
/// percentile of its points' distance from the corner) is not the target's:
/// the grill's frame returns at the far edge, so a whole plate reaches ~0.97.
const MIN_WIDTH_SHARE: f64 = 0.85;
/// A located or detected L's plates are at least this share of the plate
/// height tall: up to 60 % of a plate may be hidden from below (the clutter
/// cases hide 40 %), and nothing a hand's height tall is a target.
const MIN_HEIGHT_SHARE: f64 = 0.4;

/// A plate wider than this share of the configured width is not the
/// target's either (a 0.8 m cabinet side); the range noise along a plate
/// seen at a grazing angle moves its far edge by a few centimetres.
const MAX_WIDTH_SHARE: f64 = 1.12;

/// Peaks tried per histogram: a wall or a container behind a plate makes a
/// peak of its own, often the highest, so the plate may be the second or the
/// third. Foliage makes peaks too; `check_l`'s thinness test refuses them.
const MAX_PEAKS: usize = 3;

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
    all.sort_unstable_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
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

/// How sharply a histogram peaks: the best count of three bins less the mean
/// of the three-bin counts 6 cm to either side. A plate seen edge-on at the
/// right heading is a spike; a wall seen at the wrong heading is a plateau as
/// high as a plate's spike but with no spike on it, so it scores only at its
/// edges, and half (clutter seeds 7 and 8, wall 0.1 m behind: the wall won the
/// heading search by raw count at 20° off the plates).
fn sharp_peak(h: &[u32]) -> usize {
    // Three-bin sums at the occupied bins only (called 60 times a window,
    // on histograms mostly empty), indexed directly: the iterator chain
    // this replaces cost ten times the instructions.
    let n = h.len();
    let three = |k: usize| -> usize {
        if k >= n {
            return 0;
        }
        let below = if k > 0 { h[k - 1] as usize } else { 0 };
        let above = if k + 1 < n { h[k + 1] as usize } else { 0 };
        below + h[k] as usize + above
    };
    let mut best = 0;
    for (k, &c) in h.iter().enumerate() {
        if c == 0 {
            continue;
        }
        let sides = if k >= 3 { three(k - 3) } else { 0 } + three(k + 3);
        best = best.max(three(k).saturating_sub(sides / 2));
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A plate's points fill a rectangle: rows span it (also with its
    /// lower part hidden or most returns thinned away), or, where scan
    /// lines cross it aslant, columns do; a slanted object's stretches step
    /// along the plane and do neither (the pump room's machine base); a
    /// plate of a few rays says nothing.
    #[test]
    fn a_plate_fills_a_rectangle_a_slanted_object_does_not() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let w = 0.6;
        // Raw positions run the other way from a corner at 2.0 (sign -1).
        let (c, sign) = (2.0, -1.0);
        let at = |t: f64, z: f64| (c - t, z);
        let plate = |n: usize, z0: f64, rng: &mut rand_pcg::Pcg64Mcg| -> Vec<(f64, f64)> {
            (0..n)
                .map(|_| at(rng.random_range(0.0..w), rng.random_range(z0..0.6)))
                .collect()
        };
        let fills = |slab: &[(f64, f64)]| match spanning(slab, c, sign, 0.0, 0.6, w) {
            [Some(r), Some(k)] => Some(r.max(k) >= MIN_SPANNING_SHARE),
            _ => None,
        };
        assert_eq!(
            spanning(&plate(3000, 0.0, &mut rng), c, sign, 0.0, 0.6, w),
            [Some(1.0); 2]
        );
        assert_eq!(fills(&plate(1500, 0.35, &mut rng)), Some(true));
        // A spinning LiDAR above a turned plate: each ring climbs 10 cm
        // across it, the rings 14 cm apart; rows fail, columns hold.
        let rings: Vec<(f64, f64)> = (0..3000)
            .map(|i| {
                let t: f64 = rng.random_range(0.0..w);
                at(t, 0.02 + 0.14 * (i % 4) as f64 + t / w * 0.1)
            })
            .collect();
        let [rows, columns] = spanning(&rings, c, sign, 0.0, 0.6, w);
        assert!(rows.is_some_and(|r| r < MIN_SPANNING_SHARE), "{rows:?}");
        assert!(
            columns.is_some_and(|k| k >= MIN_SPANNING_SHARE),
            "{columns:?}"
        );
        // A 0.2 m stretch stepping 0.36 m along the plate over its height.
        let slanted: Vec<(f64, f64)> = (0..3000)
            .map(|_| {
                let z: f64 = rng.random_range(0.0..0.6);
                at(0.05 + 0.6 * z + rng.random_range(0.0..0.2), z)
            })
            .collect();
        assert_eq!(fills(&slanted), Some(false));
        assert_eq!(
            spanning(&plate(60, 0.0, &mut rng), c, sign, 0.0, 0.6, w),
            [None; 2]
        );
    }

    /// The row walk, up and down, counts what `planar_count` counts row by
    /// row, edge ties included.
    #[test]
    fn rows_walk_counts_as_planar_count() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
        let w = 0.6;
        let mut near: Vec<Near> = (0..3000)
            .map(|_| Near {
                d: rng.random_range(-0.09..0.09),
                t: rng.random_range(-0.1..0.7),
                z: rng.random_range(-0.5..1.0),
            })
            .collect();
        // Points exactly on row edges, and several at one height.
        let z0 = 0.013;
        for i in [0usize, 3, 4, 17] {
            for d in [0.0, 0.06, -0.07] {
                near.push(Near {
                    d,
                    t: 0.3,
                    z: z0 + i as f64 * ROW,
                });
            }
        }
        let pl = ByHeight::new(&near, w);
        let direct = |i: usize| {
            let edge = |k: usize| z0 + k as f64 * ROW;
            planar_count(&near, 0.15 * w, w, edge(i), edge(i + 1)).1
        };
        let up: Vec<usize> = pl.rows(z0, 0..20, false).collect();
        assert_eq!(up, (0..20).map(direct).collect::<Vec<_>>());
        let down: Vec<usize> = pl.rows(z0, 0..20, true).collect();
        assert_eq!(down, (0..20).rev().map(direct).collect::<Vec<_>>());
        assert!(up.iter().any(|&r| r > 0));
    }
}
