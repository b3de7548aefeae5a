//! The points near a candidate plate, indexed by height: the plate's
//! height band, and whether it is clear beside (a face that stops).

use super::*;

/// One histogram peak's plane in a window: the points within the shells'
/// reach of it, gathered once for every pairing that uses it.
#[derive(Clone)]
pub(super) struct PlanePoints {
    /// Points within `SHELL.1` of the plane, ordered by height; `t` holds
    /// the position along the plane from the window's origin (the other
    /// plate's normal · point), which a pairing turns into the distance from
    /// its corner by a subtraction, keeping the order.
    pub(super) pts: Vec<Near>,
    /// The slab's points (`|d| < SLAB`) as (position, height), ordered by
    /// position: a pairing's distances along the plate come out sorted.
    pub(super) slab: Vec<(f64, f64)>,
}

impl PlanePoints {
    /// The plane `n · x = off`, positions along `dir`, from the window's
    /// points in height order (height, point).
    pub(super) fn gather(
        by_height: &[(f64, [f64; 2])],
        n: [f64; 2],
        off: f64,
        dir: [f64; 2],
    ) -> Self {
        // Room for a quarter of the window up front: grown from nothing, a
        // wall's plane reallocated a dozen times (callgrind: reallocations
        // were 5 % of a dense crop's finder).
        let mut pts: Vec<Near> = Vec::with_capacity(by_height.len() / 4);
        pts.extend(by_height.iter().filter_map(|&(z, [x, y])| {
            let d = (n[0] * x + n[1] * y) - off;
            (d.abs() < SHELL.1).then(|| Near {
                d,
                t: dir[0] * x + dir[1] * y,
                z,
            })
        }));
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
    pub(super) fn slab_distances(&self, c: f64, sign: f64, z0: f64, z1: f64) -> Vec<f64> {
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
pub(super) fn on_plate_heights(near: &[Vec<Near>; 2], w: f64) -> Vec<f64> {
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
pub(super) struct Near {
    /// Signed distance from the plane (m).
    pub(super) d: f64,
    /// Distance along the plate from the corner (m; positive on the plate).
    pub(super) t: f64,
    /// Height along "up" (m).
    pub(super) z: f64,
}

/// Half-width of the slab that holds a plate's points (2 σ of the range
/// noise a survey-grade map has, and the plate's own 1–2 cm).
pub(super) const SLAB: f64 = 0.04;

/// The shells beside a slab (distance from the plane): as wide as half the
/// slab, so twice the emptier shell is what a volume of points puts in it.
pub(super) const SHELL: (f64, f64) = (0.05, 0.09);

/// Points of one plate's slab in `t0..t1` along it and `z0..z1` up, and how
/// many of them stand out as a surface: the slab's count less what the
/// emptier of the two shells beside it says a volume would put there. A wall
/// behind the grill fills one shell only; foliage fills both.
pub(super) fn planar_count(near: &[Near], t0: f64, t1: f64, z0: f64, z1: f64) -> (usize, usize) {
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
pub(super) fn plate_band(near: &[Vec<Near>; 2], z: &[f64], p: &TightParams) -> Option<(f64, f64)> {
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
pub(super) struct Indexed {
    pub(super) v: Vec<f64>,
    pub(super) z0: f64,
    /// `start[k]`: how many heights lie below `z0 + k BUCKET`; the last
    /// entry is above every height.
    pub(super) start: Vec<u32>,
}

/// `Indexed`'s bucket (m).
pub(super) const BUCKET: f64 = 0.005;

impl Indexed {
    pub(super) fn new(mut v: Vec<f64>) -> Self {
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
    pub(super) fn below(&self, z: f64) -> usize {
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
pub(super) struct ByHeight {
    /// Heights of the points in the slab or in either shell, `0.15 w < t < w`.
    pub(super) all: Indexed,
    /// `cum[i]`: how many of `all`'s first `i` heights lie in the slab, the
    /// shell in front (`d > 0`) and the shell behind. One list with running
    /// counts, so that a row edge is one search, not one per list (the
    /// searches were most of `plate_band`'s time on a wall's windows).
    pub(super) cum: Vec<[u32; 3]>,
    /// (height, distance along the plate) in the slab with `t > 0`, unsorted:
    /// `plate_wide` takes a percentile of a band's, which needs no order, and
    /// few bands get that far.
    pub(super) ext: Vec<(f64, f64)>,
}

impl ByHeight {
    pub(super) fn new(near: &[Near], w: f64) -> Self {
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
    pub(super) fn edge(&self, z: f64) -> [(usize, usize); 3] {
        let below = self.all.below(z);
        let at = below + self.all.v[below..].iter().take_while(|&&x| x == z).count();
        let (b, a) = (self.cum[below], self.cum[at]);
        [0, 1, 2].map(|k| (b[k] as usize, a[k] as usize))
    }

    /// `planar_count(near, 0.15 w, w, a, b).1` of the row between two edges
    /// (`a < b`): the slab's points strictly between them less twice the
    /// emptier shell's.
    pub(super) fn planar(a: &[(usize, usize); 3], b: &[(usize, usize); 3]) -> usize {
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
    pub(super) fn rows(
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
pub(super) fn plate_wide(pl: &ByHeight, lo: f64, hi: f64, w: f64) -> bool {
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
pub(super) fn clear_beside(pl: &ByHeight, lo: f64, hi: f64) -> bool {
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

/// Rows in which `clear_beside` walks out from a plate's band (m).
pub(super) const ROW: f64 = 0.02;

/// How far out from a plate's band `clear_beside` looks (m).
pub(super) const REACH: f64 = 0.36;

/// The least gap (m) that parts a plate from an object beyond it; wider when
/// the plate's own scan lines lie farther apart.
pub(super) const MIN_GAP: f64 = 0.08;

/// A face reaching this far past a plate's band (m) goes on.
pub(super) const GOING_ON: f64 = 0.12;
