//! Step 3 of the L finder: a Hough vote over headings finds the best
//! perpendicular pairs of vertical planes in a window; each pairing is
//! handed to the checks.

use super::*;

/// The crop's points as the L finder reads them, computed once per crop
/// (each point lies in some twenty overlapping windows): in the horizontal
/// basis `e1, e2` orthogonal to "up" (a heading's normals are
/// `na = e1 cos θ + e2 sin θ` and `nb = up × na = e2 cos θ − e1 sin θ`, so a
/// projection is two products), and in height order.
pub(super) struct Flat {
    pub(super) e: [Vector3<f64>; 2],
    /// `[e1 · v, e2 · v]` of each point.
    pub(super) xy: Vec<[f64; 2]>,
    /// (height, `xy`) of every point, by height.
    pub(super) sorted: Vec<(f64, [f64; 2])>,
    /// Each point's place in `sorted`.
    pub(super) rank: Vec<u32>,
}

impl Flat {
    pub(super) fn new(ap: &[Vector3<f64>], up: &Vector3<f64>) -> Self {
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

    /// A window's points (by index) in height order: its ranks marked in a
    /// bitset of the crop's and read out in order, the same list as sorting
    /// them (ranks are distinct) in time linear in the window, plus a word
    /// per 64 of the crop's points (the sort was 4 % of a dense crop's
    /// finder, measured by callgrind).
    pub(super) fn by_height(&self, win: &[u32]) -> Vec<(f64, [f64; 2])> {
        let mut bits = vec![0u64; self.rank.len().div_ceil(64)];
        for &i in win {
            let r = self.rank[i as usize] as usize;
            bits[r >> 6] |= 1 << (r & 63);
        }
        let mut out = Vec::with_capacity(win.len());
        for (w, &word) in bits.iter().enumerate() {
            let mut b = word;
            while b != 0 {
                out.push(self.sorted[(w << 6) | b.trailing_zeros() as usize]);
                b &= b - 1;
            }
        }
        out
    }
}

/// Best perpendicular pair of vertical planes in one window, or `None` when the
/// support does not look like an L of the configured size.
pub(super) fn fit_l(
    flat: &Flat,
    win: &[u32],
    up: &Vector3<f64>,
    p: &TightParams,
    bounded: impl Fn(&LShape) -> bool,
) -> Result<LShape, Rejected> {
    let [e1, e2] = flat.e;
    let bin = 0.02;
    let first = flat.xy[*win.first().ok_or(Rejected::unnamed(0))? as usize];
    // Histograms over a fixed range around the first point (every window point
    // is within two window radii of it, plus what a slightly tilted "up" adds):
    // arrays, not hash maps, since this loop is most of a dense map's crop time.
    let bins = Bins {
        first,
        half: ((4.0 * p.plate_width + 0.3) / bin).ceil() as i64 + 2,
        bin,
    };
    let xy: Vec<[f64; 2]> = win.iter().map(|&i| flat.xy[i as usize]).collect();
    let deg = best_heading(&xy, &bins);
    let (sn, cs) = deg.to_radians().sin_cos();
    let na = e1 * cs + e2 * sn;
    let at = AtHeading {
        cs,
        sn,
        n: [na, up.cross(&na)],
        peaks: heading_peaks(&xy, &bins, [cs, sn], p.min_plate_points),
    };
    first_l(flat, win, p, &at, bounded)
}

/// The fixed histogram range of a window: `half` bins of `bin` either side
/// of the bin of its first point's projection.
struct Bins {
    first: [f64; 2],
    half: i64,
    bin: f64,
}

/// The heading (1.5° steps) where the weaker plate's peak is sharpest; ties
/// keep the lower angle.
fn best_heading(xy: &[[f64; 2]], bins: &Bins) -> f64 {
    let (bin, half) = (bins.bin, bins.half);
    let [f1, f2] = bins.first;
    let mut hist_a = vec![0u32; (2 * half + 1) as usize];
    let mut hist_b = vec![0u32; (2 * half + 1) as usize];
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
    let stride = xy.len().div_ceil(HEADING_POINTS).max(1);
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
        let support = score(deg, xy);
        if support > best.0 {
            best = (support, deg);
        }
    }
    best.1
}

/// The winning heading: its cosine and sine, the two plates' normals, and
/// the strong peaks across each.
struct AtHeading {
    cs: f64,
    sn: f64,
    n: [Vector3<f64>; 2],
    peaks: [Vec<(usize, f64)>; 2],
}

/// At the winning heading `[cs, sn]`, every strong peak of each histogram: a
/// wall or a container parallel behind a plate makes a peak of its own,
/// often the highest, so each is a candidate plane.
fn heading_peaks(
    xy: &[[f64; 2]],
    bins: &Bins,
    [cs, sn]: [f64; 2],
    min_plate_points: usize,
) -> [Vec<(usize, f64)>; 2] {
    let (bin, half) = (bins.bin, bins.half);
    let [f1, f2] = bins.first;
    let peaks = |proj: &dyn Fn(f64, f64) -> f64| {
        let base = (proj(f1, f2) / bin).floor() as i64 - half;
        let mut h = vec![0u32; (2 * half + 1) as usize];
        for &[x, y] in xy {
            h[((proj(x, y) / bin).floor() as i64 - base).clamp(0, 2 * half) as usize] += 1;
        }
        strong_peaks(&h, base, bin, min_plate_points)
    };
    [
        peaks(&|x, y| cs * x + sn * y),
        peaks(&|x, y| cs * y - sn * x),
    ]
}

/// The first pairing of peaks, strongest first, that the checks and
/// `bounded` accept; else the first named refusal. The plate is the one
/// that stops where a plate stops.
fn first_l(
    flat: &Flat,
    win: &[u32],
    p: &TightParams,
    at: &AtHeading,
    bounded: impl Fn(&LShape) -> bool,
) -> Result<LShape, Rejected> {
    let [pa, pb] = &at.peaks;
    let (cs, sn) = (at.cs, at.sn);
    let mut why = Rejected::unnamed(0);
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
        let checked = check_l(p, at.n, [oa, ob], [a, b], score).and_then(|l| {
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
pub(super) fn bin_headings(
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

/// Most window points the heading search histograms at every heading (see
/// `fit_l`); denser windows are searched on a sample and rescored. The
/// clutter cases' target windows came out the same with it (only the
/// `DETECT_POINTS` sample moved corners there).
pub(super) const HEADING_POINTS: usize = 1500;

/// Headings a dense window's sample passes on to be scored on every point.
pub(super) const HEADING_RESCORE: usize = 6;

/// Peaks tried per histogram: a wall or a container behind a plate makes a
/// peak of its own, often the highest, so the plate may be the second or the
/// third. Foliage makes peaks too; `check_l`'s thinness test refuses them.
pub(super) const MAX_PEAKS: usize = 3;

/// Peaks (count of three bins ≥ `min`, centre) of a histogram, strongest
/// first, at most `MAX_PEAKS`, each at least 4 bins (8 cm) from a stronger one.
pub(super) fn strong_peaks(h: &[u32], base: i64, bin: f64, min: usize) -> Vec<(usize, f64)> {
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

/// How sharply a histogram peaks: the best count of three bins less the mean
/// of the three-bin counts 6 cm to either side. A plate seen edge-on at the
/// right heading is a spike; a wall seen at the wrong heading is a plateau as
/// high as a plate's spike but with no spike on it, so it scores only at its
/// edges, and half (clutter seeds 7 and 8, wall 0.1 m behind: the wall won the
/// heading search by raw count at 20° off the plates).
pub(super) fn sharp_peak(h: &[u32]) -> usize {
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
