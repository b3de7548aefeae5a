//! Is the located target mapped twice? (issue 30)
//!
//! Where a loop closed badly, the map holds two copies of whatever the
//! seam crosses, a few centimetres apart. The locator then fits one plane
//! through both copies of a plate and reports a corner between them with
//! the confidence of a single target. A plate's points, measured along its
//! normal, show it: one layer as thick as the map's noise, or two.
//!
//! Per plate, the points of the map (the loose crop: the tight crop keeps
//! only ±8 cm about the finder's planes) over the plate's middle — away
//! from the corner, where the other plate and the post stand, and from the
//! far edge — within ±`REACH` of the located plane are split into two
//! layers by a two-component mixture along the normal (one shared
//! variance). Two layers are reported when each holds a fifth of the points
//! and they stand apart by more than `MIN_SEPARATION_SIGMAS` of their own
//! thickness (a mixture of two equal layers is bimodal beyond 2σ;
//! `SPARSE_SEPARATION_SIGMAS` on a plate of few points), and both layers
//! stop where the plate stops: a wall seen through the grill or
//! behind it goes on past the plate's far edge.
//!
//! Separations under about 2.5 σ of the map's noise (3 cm at 1.2 cm) do not
//! show as two layers: that plate is only thicker than one plate.

use super::Located;
use crate::Point;
use crate::geom::densest_run;
use nalgebra::Vector3;

/// Half-width of the slab about the located plane examined (m): doubling
/// beyond it leaves the copies far enough apart that the finder takes one.
const REACH: f64 = 0.2;
/// Two layers must stand apart by this many of their shared σ.
const MIN_SEPARATION_SIGMAS: f64 = 2.5;
/// ... and by at least this much (m): below it the layers are the plate's
/// own structure (a grill and its frame).
const MIN_SEPARATION: f64 = 0.025;
/// The smaller layer holds at least this share of the plate's points.
const MIN_SHARE: f64 = 0.2;
/// ... and at least this many points,
const MIN_LAYER_POINTS: usize = 30;
/// ... of a plate middle of at least this many: sparse plates (52–90
/// points at 10–30 m on single-pass synthetic maps) split into two layers
/// 26–32 mm apart, their points bunched by scan line and station, where
/// the truth's plane shows one layer.
const MIN_PLATE_POINTS: usize = 120;
/// Fewest points of a plate's middle whose spread counts as a thickness
/// (a plate seen by a few rays has none to speak of).
const MIN_THICKNESS_POINTS: usize = 20;
/// Two copies stand at least this many of the map's typical plate
/// thickness apart.
const MIN_APART_PLATES: f64 = 2.0;
/// Each of two copies' layers is at most this many times as thick as the
/// map's typical plate.
const MAX_THICKNESS_RATIO: f64 = 1.8;
/// A layer with more than this share of its points within a fifth of the
/// plate's middle stands across the plate, not along it.
const MAX_RUN_SHARE: f64 = 0.5;
/// A layer that holds more than this share of its density on the plate
/// past the plate's far edge is a surface going on (a wall).
const GOING_ON_SHARE: f64 = 0.25;

/// One plate's points along its normal.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PlateLayers {
    /// Points examined over the plate's middle.
    pub points: usize,
    /// The layers' offsets from the located plane along its normal (m),
    /// the lower first; one entry when the plate is one layer.
    pub offsets: [f64; 2],
    /// Points in each layer.
    pub counts: [usize; 2],
    /// The layers' shared standard deviation along the normal (m).
    pub sigma: f64,
    /// Each layer's own standard deviation (m; both the same for one).
    pub spreads: [f64; 2],
    /// The plate's standard deviation along its normal as one layer (m).
    pub single: f64,
    /// Whether this plate is two layers (`offsets` differ).
    pub doubled: bool,
}

/// A target mapped twice: both copies' corners and how far apart they are.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Doubled {
    /// Each plate's layers.
    pub plates: [PlateLayers; 2],
    /// The two copies' corners as far as the map parts them: the located
    /// corner moved by each layer's offset along the normal of each plate
    /// that shows two layers (the located height).
    pub copies: [Point; 2],
    /// Horizontal distance between the copies (m).
    pub separation: f64,
}

/// A located target's plates as the map around it shows them, before they
/// are judged against the map's other targets ([`Layering::doubled`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Layering {
    corner: Point,
    normals: [Vector3<f64>; 2],
    /// Each plate's layers.
    pub plates: [PlateLayers; 2],
}

/// Each located plate's points in `points` (the map near the target) along
/// its normal, as one layer or two. `width`/`height` are the plates' size
/// (m). `None` when the plates' normals are not usable.
pub fn layering(
    points: &[Point],
    located: &Located,
    up: &Vector3<f64>,
    width: f64,
    height: f64,
) -> Option<Layering> {
    let c = located.corner;
    let n = located.plates.map(|p| {
        let v = Vector3::from(p.normal);
        (v - up * up.dot(&v)).normalize()
    });
    if n.iter().any(|v| !v.iter().all(|x| x.is_finite())) {
        return None;
    }
    // Every test below looks within half a plate height of the corner and,
    // along the plates, within `REACH` of a plane and a plate's width plus
    // 0.8 m of the corner: the rest of a loose crop (a wall's half million
    // points beside one) is dropped first, a superset kept, so the answer
    // is the same at a fraction of the cost.
    let sin = n[0].cross(&n[1]).norm();
    let reach = (width + 0.8 + REACH) * 2.0 / sin.max(1e-9);
    let keep = |v: &Vector3<f64>| {
        let h = up.dot(v);
        sin < 0.1 || (h.abs() <= height / 2.0 && (v - up * h).norm_squared() <= reach * reach)
    };
    let q: Vec<Vector3<f64>> = points.iter().map(|p| p - c).filter(keep).collect();
    // Along plate k from the corner: ±n of the other plate, the side where
    // most of the points near plate k's plane are.
    let along = |k: usize| {
        let o = n[1 - k];
        let side: f64 = q
            .iter()
            .filter(|v| {
                n[k].dot(v).abs() < 0.05 && up.dot(v).abs() < height / 2.0 && o.dot(v).abs() < width
            })
            .map(|v| o.dot(v).signum())
            .sum();
        if side >= 0.0 { o } else { -o }
    };
    let u = [along(0), along(1)];
    Some(Layering {
        corner: c,
        normals: n,
        plates: [0, 1].map(|k| plate_layers(&q, &n[k], &u[k], up, width, height)),
    })
}

/// How a map's plates let its targets' doubling be seen: about how far
/// apart two copies of a plate must stand for [`Layering::doubled`] to tell
/// them apart, given the map's typical plate thickness. It is a scale, not a
/// sharp cut: the test is against each plate's own layers (2.5 of their σ,
/// a little under the plate's thickness as one layer), on plates of 120+
/// middle points with a fifth of them in each copy; copies at the limit are
/// seen about half the time, at 1.1 times it nearly always, at 0.6 times
/// hardly ever (on plates under `SPARSE_PLATE_POINTS` middle points the
/// layers must stand 2.8 of their σ apart, and close copies are seen less
/// often). Closer copies look like one plate a little thicker than the
/// others, and the locator fits one corner between them with a single
/// target's confidence: a limit of the map, stated with every result
/// (issue 30: 3 cm copies of 17 mm-thick synthetic plates blend, 6-9 sigma
/// from either copy).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DoublingLimit {
    /// The map's typical plate thickness: the median target's thinner
    /// plate (of those not found doubled), as the standard deviation of its
    /// points along the plate's normal (m).
    pub plate_thickness_m: f64,
    /// Copies about this far apart along a plate's normal or more are
    /// usually seen (reported `ambiguous`); closer ones hardly ever (m).
    pub resolved_from_m: f64,
}

impl DoublingLimit {
    /// The limit for plates `thickness` thick (m).
    pub fn of(thickness: f64) -> Self {
        DoublingLimit {
            plate_thickness_m: thickness,
            resolved_from_m: (MIN_SEPARATION_SIGMAS.max(MIN_APART_PLATES) * thickness)
                .max(MIN_SEPARATION),
        }
    }
}

impl Layering {
    /// The thinner plate's thickness (σ along its normal as one layer, m):
    /// what a plate of this map looks like, for [`Layering::doubled`].
    /// `None` when neither plate has the points to say.
    pub fn thickness(&self) -> Option<f64> {
        self.plates
            .iter()
            .filter(|p| p.points >= MIN_THICKNESS_POINTS)
            .map(|p| p.single)
            .min_by(f64::total_cmp)
    }

    /// The copies, when a plate is two layers each as thin as a plate of
    /// this map: `plate` is the typical plate thickness (the median of the
    /// map's targets' [`Layering::thickness`]), or `None` when too few
    /// targets were located to say (then any two layers count). A plate and
    /// a volume beside it (foliage through the grill) are two layers, but
    /// thick ones.
    pub fn doubled(&self, plate: Option<f64>) -> Option<Doubled> {
        // Each layer as thin as a plate, and the two further apart than a
        // plate is thick: one flat band (a bent plate, a turned one) splits
        // into halves a few σ of their own apart, but not of a plate's.
        let thin = |l: &PlateLayers| {
            plate.is_none_or(|t| {
                l.spreads[0].max(l.spreads[1]) <= MAX_THICKNESS_RATIO * t
                    && l.offsets[1] - l.offsets[0] >= MIN_APART_PLATES * t
            })
        };
        let two = self.plates.map(|l| l.doubled && thin(&l));
        // The copies: each layer's offset from the blend along its plate's
        // normal. With both plates two layers, the copies pair the larger
        // layers (both passes see a target from the same road, so a copy's
        // share of returns is alike on its two plates); with one, the
        // copies differ along that plate's normal only, as far as the map
        // shows (the other plate's layers lie within its noise).
        let shift = |k: usize, j: usize| self.normals[k] * self.plates[k].offsets[j];
        let larger = |k: usize| usize::from(self.plates[k].counts[1] > self.plates[k].counts[0]);
        let (a, b) = match two {
            [true, true] => {
                let (a0, a1) = (larger(0), larger(1));
                (
                    shift(0, a0) + shift(1, a1),
                    shift(0, 1 - a0) + shift(1, 1 - a1),
                )
            }
            [true, false] => (shift(0, 0), shift(0, 1)),
            [false, true] => (shift(1, 0), shift(1, 1)),
            [false, false] => return None,
        };
        let mut plates = self.plates;
        for (p, t) in plates.iter_mut().zip(two) {
            p.doubled = t;
        }
        Some(Doubled {
            plates,
            copies: [self.corner + a, self.corner + b],
            separation: (a - b).xy().norm(),
        })
    }
}

/// Plate `n`'s points over its middle (along `u` from the corner, a plate's
/// height band about the corner) within ±`REACH`, as one or two layers.
fn plate_layers(
    q: &[Vector3<f64>],
    n: &Vector3<f64>,
    u: &Vector3<f64>,
    up: &Vector3<f64>,
    width: f64,
    height: f64,
) -> PlateLayers {
    let mut plate = PlateFrame {
        n,
        u,
        up,
        width,
        height,
        tilt: (0.0, 0.0, 0.0, 0.0),
    };
    // Distances from the plate's own least-squares plane through the middle
    // points (offset kept from the located plane): a sparse plate's located
    // plane may be turned a few degrees, which spreads one layer along the
    // plate into a flat band that two layers would fit. Copies of a plate
    // are parallel and cover the same part of it, so the tilt is theirs.
    let mid: Vec<&Vector3<f64>> = q
        .iter()
        .filter(|v| plate.on(v, 0.3 * width, 0.9 * width))
        .collect();
    plate.tilt = plane_tilt(&mid, n, u, up);
    let mut d: Vec<f64> = mid.iter().map(|v| plate.dist(v)).collect();
    d.sort_unstable_by(f64::total_cmp);
    if d.len() < MIN_PLATE_POINTS {
        return one_layer(&d);
    }
    let Some(mix) = two_layers(&d) else {
        return one_layer(&d);
    };
    if !stands_apart(&mix, d.len()) {
        return one_layer(&d);
    }
    let band = 2.0 * mix.sigma;
    if mix.means.iter().any(|&at| plate.goes_on(q, at, band)) {
        return one_layer(&d);
    }
    if mix.means.iter().any(|&at| plate.across(q, at, band)) {
        return one_layer(&d);
    }
    PlateLayers {
        points: d.len(),
        offsets: mix.means,
        counts: mix.counts,
        sigma: mix.sigma,
        spreads: mix.spreads,
        single: one_layer(&d).single,
        doubled: true,
    }
}

/// The plate's sorted distances `d` as one layer.
fn one_layer(d: &[f64]) -> PlateLayers {
    let m = d.iter().sum::<f64>() / d.len().max(1) as f64;
    let s = (d.iter().map(|x| (x - m).powi(2)).sum::<f64>() / d.len().max(1) as f64).sqrt();
    PlateLayers {
        points: d.len(),
        offsets: [m, m],
        counts: [d.len(), 0],
        sigma: s,
        spreads: [s, s],
        single: s,
        doubled: false,
    }
}

/// Whether the mixture of a plate's `points` is two layers at all: each
/// holding enough of them, further apart than the plate's own structure
/// and than their σ.
fn stands_apart(mix: &Mixture, points: usize) -> bool {
    let sigmas = if points < SPARSE_PLATE_POINTS {
        SPARSE_SEPARATION_SIGMAS
    } else {
        MIN_SEPARATION_SIGMAS
    };
    stands_apart_by(mix, points, sigmas)
}

/// [`stands_apart`] with the layers `sigmas` of their σ apart.
fn stands_apart_by(mix: &Mixture, points: usize, sigmas: f64) -> bool {
    let apart = mix.means[1] - mix.means[0];
    let small = mix.counts[0].min(mix.counts[1]);
    small >= MIN_LAYER_POINTS
        && small as f64 >= MIN_SHARE * points as f64
        && apart >= MIN_SEPARATION
        && apart >= sigmas * mix.sigma
}

/// A plate's middle of fewer points than this must show its two layers
/// `SPARSE_SEPARATION_SIGMAS` apart. One layer cut in two gives halves 1.6
/// of its σ apart and 0.6 of it thick, 2.65 of their own σ: the mixture
/// usually merges them again, but on 132–150 points it left 0.8–0.9 % of
/// simulated Gaussian layers (17 mm, as a plate seen face on) split past
/// 2.5 σ and 25 mm, 0.05 % past 2.8 σ; at 200 points 0.05 % and none
/// (2000 layers each, the same fit in numpy). A single-pass rosette scan's
/// face-on plate (132 points) was split 27 mm apart and its target
/// reported mapped twice (issue 30). The cost: fewer close copies seen on
/// such plates (copies 3 σ of their own apart, 132–200 points: 91–97 % at
/// 2.5 σ, 61–65 % at a 3.0 σ cut in the same simulation; 2.8 σ lies
/// between, not measured itself).
const SPARSE_PLATE_POINTS: usize = 200;
/// Separation, in the layers' σ, of two layers on a sparse plate.
const SPARSE_SEPARATION_SIGMAS: f64 = 2.8;

/// One plate as seen from the corner (points as offsets from it): its
/// normal `n`, the direction `u` along it, and its plane's `tilt` (from
/// [`plane_tilt`]) once fitted.
struct PlateFrame<'a> {
    n: &'a Vector3<f64>,
    u: &'a Vector3<f64>,
    up: &'a Vector3<f64>,
    width: f64,
    height: f64,
    tilt: (f64, f64, f64, f64),
}

impl PlateFrame<'_> {
    /// Within the slab about the plate, between `lo` and `hi` along it.
    #[inline]
    fn on(&self, v: &Vector3<f64>, lo: f64, hi: f64) -> bool {
        let t = self.u.dot(v);
        t > lo && t < hi && self.up.dot(v).abs() < 0.4 * self.height && self.n.dot(v).abs() < REACH
    }

    /// Distance from the plate's own (tilted) plane.
    #[inline]
    fn dist(&self, v: &Vector3<f64>) -> f64 {
        let tilt = &self.tilt;
        self.n.dot(v) - tilt.0 * (self.u.dot(v) - tilt.2) - tilt.1 * (self.up.dot(v) - tilt.3)
    }

    /// The layer at `at` (±`band`) past the plate's far edge: a surface
    /// going on (a wall behind the plate, seen through the grill) has as
    /// many points per metre there as on the plate; both copies of a plate
    /// stop with it.
    fn goes_on(&self, q: &[Vector3<f64>], at: f64, band: f64) -> bool {
        let width = self.width;
        let in_layer = |v: &&Vector3<f64>| (self.dist(v) - at).abs() < band;
        let on_plate = q
            .iter()
            .filter(|v| self.on(v, 0.3 * width, 0.9 * width))
            .filter(in_layer)
            .count();
        let past = q
            .iter()
            .filter(|v| self.on(v, width + 0.2, width + 0.8))
            .filter(in_layer)
            .count();
        // Per metre along the plate: 0.6 w on the plate, 0.6 m past it.
        past as f64 / 0.6 > GOING_ON_SHARE * on_plate as f64 / (0.6 * width)
    }

    /// The layer at `at` (±`band`) bunched at one distance from the corner:
    /// a surface standing across the plate (a wall beside the other plate,
    /// a pole), where a copy of the plate spreads along it.
    fn across(&self, q: &[Vector3<f64>], at: f64, band: f64) -> bool {
        let width = self.width;
        let mut t: Vec<f64> = q
            .iter()
            .filter(|v| self.on(v, 0.3 * width, 0.9 * width) && (self.dist(v) - at).abs() < band)
            .map(|v| self.u.dot(v))
            .collect();
        t.sort_unstable_by(f64::total_cmp);
        // A fifth of the span holds a fifth of an even layer's points.
        densest_run(&t, 0.12 * width) as f64 > MAX_RUN_SHARE * t.len() as f64
    }
}

/// Least squares of the distance along `n` on the position along the plate
/// (`u`) and up: (slope along, slope up, mean along, mean up). Flat (zero
/// slopes) when the points do not span the plate.
fn plane_tilt(
    pts: &[&Vector3<f64>],
    n: &Vector3<f64>,
    u: &Vector3<f64>,
    up: &Vector3<f64>,
) -> (f64, f64, f64, f64) {
    let k = pts.len() as f64;
    if pts.len() < 3 {
        return (0.0, 0.0, 0.0, 0.0);
    }
    let tm = pts.iter().map(|v| u.dot(v)).sum::<f64>() / k;
    let zm = pts.iter().map(|v| up.dot(v)).sum::<f64>() / k;
    let dm = pts.iter().map(|v| n.dot(v)).sum::<f64>() / k;
    let (mut stt, mut szz, mut stz, mut std_, mut szd) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for v in pts {
        let (t, z, d) = (u.dot(v) - tm, up.dot(v) - zm, n.dot(v) - dm);
        stt += t * t;
        szz += z * z;
        stz += t * z;
        std_ += t * d;
        szd += z * d;
    }
    let det = stt * szz - stz * stz;
    if det <= 1e-12 * (stt * szz).max(1e-30) {
        return (0.0, 0.0, tm, zm);
    }
    // At most a few degrees: the gates kept the plane within a degree of
    // vertical, and a larger slope would be layers covering different
    // parts of the plate, not a turned plane.
    let b = ((std_ * szz - szd * stz) / det).clamp(-MAX_SLOPE, MAX_SLOPE);
    let c = ((szd * stt - std_ * stz) / det).clamp(-MAX_SLOPE, MAX_SLOPE);
    (b, c, tm, zm)
}

/// Largest tilt removed from a plate's plane (tan 3°).
const MAX_SLOPE: f64 = 0.052;

/// A two-component mixture along one axis.
pub(super) struct Mixture {
    pub(super) means: [f64; 2],
    /// Points nearer each mean (by responsibility).
    pub(super) counts: [usize; 2],
    /// The shared σ.
    pub(super) sigma: f64,
    /// Each layer's own σ (responsibility-weighted).
    pub(super) spreads: [f64; 2],
}

/// Two normal layers with one shared σ fitted to sorted `d` by EM, started
/// from the best split in two (k-means in one dimension, exact on sorted
/// values). `None` when the values do not vary.
pub(super) fn two_layers(d: &[f64]) -> Option<Mixture> {
    let n = d.len();
    let mut prefix = vec![0.0; n + 1];
    let mut prefix2 = vec![0.0; n + 1];
    let m0 = d[n / 2];
    for (i, x) in d.iter().enumerate() {
        prefix[i + 1] = prefix[i] + (x - m0);
        prefix2[i + 1] = prefix2[i] + (x - m0).powi(2);
    }
    let sse = |a: usize, b: usize| {
        let k = (b - a) as f64;
        let s = prefix[b] - prefix[a];
        prefix2[b] - prefix2[a] - s * s / k
    };
    let split =
        (1..n).min_by(|&i, &j| (sse(0, i) + sse(i, n)).total_cmp(&(sse(0, j) + sse(j, n))))?;
    let mut mu = [
        m0 + prefix[split] / split as f64,
        m0 + (prefix[n] - prefix[split]) / (n - split) as f64,
    ];
    let mut w = [split as f64 / n as f64, (n - split) as f64 / n as f64];
    let mut var = ((sse(0, split) + sse(split, n)) / n as f64).max(1e-10);
    let mut r = vec![0.0; n];
    for _ in 0..100 {
        // E: responsibility of layer 1 for each value.
        for (ri, x) in r.iter_mut().zip(d) {
            let l0 = w[0] * (-(x - mu[0]).powi(2) / (2.0 * var)).exp();
            let l1 = w[1] * (-(x - mu[1]).powi(2) / (2.0 * var)).exp();
            *ri = if l0 + l1 > 0.0 { l1 / (l0 + l1) } else { 0.5 };
        }
        // M.
        let s1: f64 = r.iter().sum();
        let s0 = n as f64 - s1;
        if s0 < 1.0 || s1 < 1.0 {
            return None;
        }
        let new_mu = [
            d.iter().zip(&r).map(|(x, ri)| x * (1.0 - ri)).sum::<f64>() / s0,
            d.iter().zip(&r).map(|(x, ri)| x * ri).sum::<f64>() / s1,
        ];
        var = (d
            .iter()
            .zip(&r)
            .map(|(x, ri)| (1.0 - ri) * (x - new_mu[0]).powi(2) + ri * (x - new_mu[1]).powi(2))
            .sum::<f64>()
            / n as f64)
            .max(1e-10);
        w = [s0 / n as f64, s1 / n as f64];
        let moved = (new_mu[0] - mu[0]).abs() + (new_mu[1] - mu[1]).abs();
        mu = new_mu;
        if moved < 1e-7 {
            break;
        }
    }
    if mu[0] > mu[1] {
        mu.swap(0, 1);
        r.iter_mut().for_each(|x| *x = 1.0 - *x);
    }
    let c1 = r.iter().filter(|&&x| x > 0.5).count();
    // Each layer's own spread about its mean, weighted by responsibility.
    let spread = |j: usize| {
        let (mut sw, mut s2) = (0.0, 0.0);
        for (x, ri) in d.iter().zip(&r) {
            let w = if j == 1 { *ri } else { 1.0 - ri };
            sw += w;
            s2 += w * (x - mu[j]).powi(2);
        }
        (s2 / sw.max(1e-12)).sqrt()
    };
    Some(Mixture {
        means: mu,
        counts: [n - c1, c1],
        sigma: var.sqrt(),
        spreads: [spread(0), spread(1)],
    })
}

#[cfg(test)]
mod tests;
