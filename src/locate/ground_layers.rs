//! Is the ground around a target mapped twice, at heights centimetres
//! apart? (issue 30)
//!
//! Where a loop closed badly the map holds two copies of what the seam
//! crosses. Drift the closure left across the ground shows in the plates'
//! layers (`layers.rs`); drift in height alone, the direction LiDAR odometry
//! holds worst, does not: two copies of an upright plate 4 cm apart in
//! height lie in one plane, and only the few scan lines between the copies'
//! edges tell them apart. The locator then places the corner at either
//! copy's height or between them, with a single target's σz (synth, every
//! target mapped twice 4 cm apart: 8 of 20 heights beyond 1.96 σ, one
//! 6.9 σ). The ground around the target was mapped by the same passes, and
//! flat ground shows the two heights plainly: two thin layers at every
//! place, the same distance apart.
//!
//! So: the points from a ring about the target (past its own plates and
//! legs), in cells of half a metre across; in each cell the lowest quarter
//! metre (ground, not what stands on it) less a plane fitted to it (slope
//! and bumps), pooled; split into two layers by the plates' mixture. The
//! ground is doubled when it holds 1000 points or more, each layer a fifth
//! of them, they stand apart by three of their σ and 2 cm, each is a third
//! of that thin and at most 2.5 cm (tall grass is a thick layer), and three quarters of the ring or more show the
//! same two layers, with every quarter that has the points to say but one
//! (a curb or a step crosses part of a ring, never all of it), and the two
//! are alike thick, as two copies of one surface are, with a gap between
//! them (short grass over soil fills it), and lie at the same places:
//! 10 cm squares hold both about as often as random mixing gives (raised
//! beds and corrugations a cell wide put them side by side).
//! Rough ground (grass, gravel, a noisy map) hides a few centimetres' seam:
//! then nothing is reported.

use super::layers::two_layers;
use crate::Point;
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// The ring about the target whose ground is read (m, horizontal from the
/// located point): beyond the plates (0.6 m) and a stand's legs, within a
/// loose crop (5 m).
const INNER_M: f64 = 1.0;
/// See [`INNER_M`].
const OUTER_M: f64 = 3.0;
/// Cell side (m): small enough that a plane follows the ground's bumps.
const CELL_M: f64 = 0.5;
/// Height above a cell's lowest point still taken as its ground (m).
const BAND_M: f64 = 0.25;
/// Fewest points of a cell whose plane is fitted.
const MIN_CELL_POINTS: usize = 8;
/// A cell's plane steeper than this (rise per metre, 8.5°) is not fitted:
/// its points then lie about the ring's mean slope. Two scan lines of two
/// copies crossing a cell could otherwise be fitted by one tilted plane.
const MAX_CELL_SLOPE: f64 = 0.15;
/// Fewest ground points for the ring to be read: a map's, not one scan's
/// few rings (a single Velodyne frame's curb at 8 m, 421 points, split
/// into layers 16 cm apart).
const MIN_POINTS: usize = 1000;
/// Each layer is at most this thick (its σ, m): a SLAM map's ground is as
/// thin as its ranging at grazing incidence, a few millimetres to a
/// centimetre or two; thicker ground cannot show a seam of centimetres,
/// and two thick layers are terrain (a curb and the road, a car's sill).
const MAX_LAYER_SIGMA_M: f64 = 0.025;
/// Most ground points the mixture is fitted to (an even sample of the
/// sorted rest beyond it: its cost is up to a hundred passes over them).
const MAX_POINTS: usize = 3000;
/// The layers stand apart by this many of their shared σ ...
const SEPARATION_SIGMAS: f64 = 3.0;
/// ... and by at least this (m): closer copies change heights by less than
/// a located height's own σ.
const MIN_SEPARATION_M: f64 = 0.02;
/// The smaller layer holds at least this share.
const MIN_SHARE: f64 = 0.2;
/// Each layer's own σ is at most this share of their separation.
const MAX_SPREAD_SHARE: f64 = 1.0 / 3.0;
/// The thicker layer's σ is at most this many times the thinner's: two
/// copies of one ground are one surface seen twice, as thick as each other.
/// (A review's short grass, soil at 3 mm under 70 % of returns raised up to
/// 5 cm, was taken for a seam 28–30 mm apart at 10 of 15 synth targets; the
/// mixture split it into halves alike thick, and [`MAX_GAP_SHARE`] refuses
/// it.)
const MAX_SPREAD_RATIO: f64 = 1.5;
/// Points about the layers' middle, at most this share of those about the
/// lesser layer's mean.
const MAX_GAP_SHARE: f64 = 0.5;
/// Side of the sub-cells in which both layers are looked for (m).
const SUBCELL_M: f64 = 0.1;
/// Sub-cells holding both layers, at least this share of what random
/// mixing of the layers' points gives. Measured on synth: 1.00–1.30 where
/// every target was mapped twice (4 cm; 3 cm over half the road), 0.22–0.37
/// on raised beds 7 cm high, 0.25 m wide and 0.5 m apart about every target
/// (taken as a seam before this test, 14 of 15 targets).
const MIN_INTERLEAVED: f64 = 0.7;
/// Fewer sub-cells than this expected to hold both layers say nothing.
const MIN_EXPECTED_MIXED: f64 = 20.0;
/// Fewest points of a quarter of the ring that has a say.
const MIN_QUARTER_POINTS: usize = 100;
/// A quarter's separation agrees with the ring's within this share.
const QUARTER_AGREES: f64 = 0.25;

/// The ground about a target as two layers.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct GroundLayers {
    /// Ground points read.
    pub points: usize,
    /// Height between the two layers (m).
    pub separation_m: f64,
    /// The layers' shared σ (m).
    pub sigma_m: f64,
    /// Share of the points in the lower and the upper layer.
    pub shares: [f64; 2],
}

/// The ground in `points` (the map near the target) about `at` (the located
/// point), `up` the vertical, when it shows two layers. `None` when it
/// shows one, or too little of it is seen to say.
pub fn ground_layers(points: &[Point], at: &Point, up: &Vector3<f64>) -> Option<GroundLayers> {
    let up = up.try_normalize(1e-12)?;
    let e1 = up
        .cross(&Vector3::x())
        .try_normalize(0.1)
        .or_else(|| up.cross(&Vector3::y()).try_normalize(0.1))?;
    let e2 = up.cross(&e1);
    // Each point of the ring as (across, along, height), by cell.
    let mut cells: BTreeMap<(i64, i64), Vec<[f64; 3]>> = BTreeMap::new();
    for p in points {
        let q = p - at;
        let (x, y) = (e1.dot(&q), e2.dot(&q));
        let r2 = x * x + y * y;
        if !(r2 >= INNER_M * INNER_M && r2 < OUTER_M * OUTER_M) {
            continue;
        }
        let key = ((x / CELL_M).floor() as i64, (y / CELL_M).floor() as i64);
        cells.entry(key).or_default().push([x, y, up.dot(&q)]);
    }
    // Each cell's ground band, for the ring's mean slope first.
    let bands: Vec<Vec<[f64; 3]>> = cells
        .into_values()
        .filter_map(|c| {
            let low = c.iter().map(|v| v[2]).fold(f64::INFINITY, f64::min);
            let band: Vec<[f64; 3]> = c.into_iter().filter(|v| v[2] < low + BAND_M).collect();
            (band.len() >= MIN_CELL_POINTS).then_some(band)
        })
        .collect();
    let all: Vec<[f64; 3]> = bands.iter().flatten().copied().collect();
    if all.len() < MIN_POINTS {
        return None;
    }
    let ring = plane(&all)?;
    // Residuals from each cell's own plane (or the ring's slope through the
    // cell's mean), with the quarter of the ring each lies in.
    // (residual, quarter, sub-cell) of each ground point.
    let mut res: Vec<(f64, usize, (i64, i64))> = Vec::with_capacity(all.len());
    for band in &bands {
        let own = plane(band).filter(|p| p[1].hypot(p[2]) <= MAX_CELL_SLOPE);
        let p = own.unwrap_or_else(|| {
            let m = band
                .iter()
                .map(|v| v[2] - ring[1] * v[0] - ring[2] * v[1])
                .sum::<f64>()
                / band.len() as f64;
            [m, ring[1], ring[2]]
        });
        for v in band {
            let quarter = usize::from(v[0] >= 0.0) + 2 * usize::from(v[1] >= 0.0);
            let sub = (
                (v[0] / SUBCELL_M).floor() as i64,
                (v[1] / SUBCELL_M).floor() as i64,
            );
            res.push((v[2] - p[0] - p[1] * v[0] - p[2] * v[1], quarter, sub));
        }
    }
    let (layers, middle) = split(res.iter().map(|r| r.0).collect())?;
    if !interleaved(&res, middle) {
        return None;
    }
    // Three quarters or more show the same two layers, and every quarter
    // with the points to say but one: a seam goes all round a target.
    let (mut said, mut agree) = (0, 0);
    for k in 0..4 {
        let d: Vec<f64> = res.iter().filter(|r| r.1 == k).map(|r| r.0).collect();
        if d.len() < MIN_QUARTER_POINTS {
            continue;
        }
        said += 1;
        if split(d).is_some_and(|(q, _)| {
            (q.separation_m - layers.separation_m).abs() <= QUARTER_AGREES * layers.separation_m
        }) {
            agree += 1;
        }
    }
    (agree >= 3 && agree + 1 >= said).then_some(layers)
}

/// Whether the two layers lie at the same places, as two copies of one
/// ground do, rather than side by side (raised beds, a corrugated surface
/// half a cell across, which a cell's plane cannot follow): of the
/// sub-cells holding two points or more, as many hold both layers (split
/// at `middle`) as random mixing gives, within [`MIN_INTERLEAVED`]. Too few
/// sub-cells to say is no evidence against.
fn interleaved(res: &[(f64, usize, (i64, i64))], middle: f64) -> bool {
    let mut subs: BTreeMap<(i64, i64), (usize, usize)> = BTreeMap::new();
    for r in res {
        let e = subs.entry(r.2).or_default();
        e.0 += 1;
        e.1 += usize::from(r.0 > middle);
    }
    let upper = res.iter().filter(|r| r.0 > middle).count() as f64 / res.len().max(1) as f64;
    let (mut expected, mut seen) = (0.0, 0usize);
    for &(n, up) in subs.values().filter(|c| c.0 >= 2) {
        expected += 1.0 - upper.powi(n as i32) - (1.0 - upper).powi(n as i32);
        seen += usize::from(up > 0 && up < n);
    }
    expected < MIN_EXPECTED_MIXED || seen as f64 >= MIN_INTERLEAVED * expected
}

/// `d` (heights about the ground's planes) as two thin layers standing
/// apart, with the height between their means, or `None`.
fn split(mut d: Vec<f64>) -> Option<(GroundLayers, f64)> {
    d.retain(|x| x.is_finite());
    d.sort_unstable_by(f64::total_cmp);
    let n = d.len();
    if n < MIN_QUARTER_POINTS {
        return None;
    }
    // Two layers Δ apart holding p and 1 − p of the points spread at least
    // √(p(1 − p)) Δ as one: ground thinner than that for the closest,
    // least even layers asked for is one layer, without the mixture (most
    // grounds of a clean map: 2–5 mm).
    let mean = d.iter().sum::<f64>() / n as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
    if var < MIN_SHARE * (1.0 - MIN_SHARE) * MIN_SEPARATION_M.powi(2) {
        return None;
    }
    if n > MAX_POINTS {
        d = (0..MAX_POINTS).map(|i| d[i * n / MAX_POINTS]).collect();
    }
    let mix = two_layers(&d)?;
    let apart = mix.means[1] - mix.means[0];
    let m = d.len() as f64;
    let shares = [mix.counts[0] as f64 / m, mix.counts[1] as f64 / m];
    // Two layers have a gap between them: fewer points about their middle
    // than about either mean (two normal layers 3.5 σ apart: 0.5 of the
    // lesser; grass over soil fills the gap, a mixture splits it anyway).
    let near = |at: f64| {
        let w = 0.25 * mix.sigma;
        d.partition_point(|x| *x <= at + w) - d.partition_point(|x| *x < at - w)
    };
    let middle = near(0.5 * (mix.means[0] + mix.means[1]));
    let gap = (middle as f64) <= MAX_GAP_SHARE * near(mix.means[0]).min(near(mix.means[1])) as f64;
    let thin = gap
        && mix
            .spreads
            .iter()
            .all(|s| *s <= MAX_SPREAD_SHARE * apart && *s <= MAX_LAYER_SIGMA_M)
        && mix.spreads[0].max(mix.spreads[1])
            <= MAX_SPREAD_RATIO * mix.spreads[0].min(mix.spreads[1]);
    (apart >= MIN_SEPARATION_M
        && apart >= SEPARATION_SIGMAS * mix.sigma
        && shares[0].min(shares[1]) >= MIN_SHARE
        && thin)
        .then_some((
            GroundLayers {
                points: n,
                separation_m: apart,
                sigma_m: mix.sigma,
                shares,
            },
            0.5 * (mix.means[0] + mix.means[1]),
        ))
}

/// Least-squares plane `h = a + b x + c y` through `v` ([x, y, h]), about
/// their mean (cells lie metres from the target). `None` when the points
/// do not span a plane.
fn plane(v: &[[f64; 3]]) -> Option<[f64; 3]> {
    let n = v.len() as f64;
    let mean = [0, 1, 2].map(|k| v.iter().map(|p| p[k]).sum::<f64>() / n);
    let (mut sxx, mut sxy, mut syy, mut sxh, mut syh) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in v {
        let (x, y, h) = (p[0] - mean[0], p[1] - mean[1], p[2] - mean[2]);
        sxx += x * x;
        sxy += x * y;
        syy += y * y;
        sxh += x * h;
        syh += y * h;
    }
    let det = sxx * syy - sxy * sxy;
    // A line of points (one scan line through the cell) fixes no plane.
    if !(det > 1e-6 * (sxx + syy).powi(2)) {
        return None;
    }
    let b = (sxh * syy - syh * sxy) / det;
    let c = (syh * sxx - sxh * sxy) / det;
    Some([mean[2] - b * mean[0] - c * mean[1], b, c])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ground about a target 1.1 m above it: a 2° slope, gentle bumps,
    /// `noise` (m) of height scatter from a hash, every 4 cm; with
    /// `second`, a copy `second` higher on every other point.
    fn ground(noise: f64, second: Option<f64>, step: Option<f64>) -> Vec<Point> {
        let mut pts = Vec::new();
        let mut k: u64 = 1;
        let mut next = || {
            // Two uniforms summed: triangular, enough for a noise test.
            k = k
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let a = (k >> 11) as f64 / (1u64 << 53) as f64;
            k = k
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let b = (k >> 11) as f64 / (1u64 << 53) as f64;
            (a + b - 1.0) * 2.45
        };
        for i in -90..=90 {
            for j in -90..=90 {
                let (x, y) = (i as f64 * 0.04, j as f64 * 0.04);
                let mut z = -1.1 + 0.035 * x + 0.03 * (0.7 * y).sin() + noise * next();
                if let Some(s) = step.filter(|_| x > 0.8) {
                    z += s;
                }
                if let Some(dz) = second.filter(|_| (i + j) % 2 == 0) {
                    z += dz;
                }
                pts.push(Point::new(100.0 + x, 200.0 + y, 30.0 + z));
            }
        }
        pts
    }

    /// Two layers at the same places (a seam) against side by side (raised
    /// beds 0.25 m wide): 10 cm squares of 4 points each, half of the
    /// points 4 cm up.
    #[test]
    fn a_seams_layers_lie_at_the_same_places_raised_beds_do_not() {
        let squares = |beds: bool| {
            let mut res = Vec::new();
            for i in 0..40i64 {
                for j in 0..10i64 {
                    for k in 0..4 {
                        let up = if beds { (i / 5) % 2 == 0 } else { k % 2 == 0 };
                        res.push((if up { 0.04 } else { 0.0 }, 0, (i, j)));
                    }
                }
            }
            res
        };
        assert!(interleaved(&squares(false), 0.02));
        assert!(!interleaved(&squares(true), 0.02));
        // Too few squares of two points to say: no evidence against.
        assert!(interleaved(&squares(true)[..60], 0.02));
    }

    #[test]
    fn ground_mapped_twice_4_cm_apart_is_seen() {
        let at = Point::new(100.0, 200.0, 30.0);
        let g = ground_layers(&ground(0.004, Some(0.04), None), &at, &Vector3::z()).unwrap();
        assert!((g.separation_m - 0.04).abs() < 0.004, "{g:?}");
        assert!((g.shares[0] - 0.5).abs() < 0.05, "{g:?}");
    }

    #[test]
    fn one_ground_is_one_layer_noisy_or_not_and_with_a_curb() {
        let at = Point::new(100.0, 200.0, 30.0);
        for noise in [0.002, 0.005, 0.02] {
            assert_eq!(
                ground_layers(&ground(noise, None, None), &at, &Vector3::z()),
                None
            );
            // A 12 cm curb across part of the ring.
            assert_eq!(
                ground_layers(&ground(noise, None, Some(0.12)), &at, &Vector3::z()),
                None
            );
        }
        // Short grass: 70 % of the returns raised by up to 5 cm over soil
        // seen at 3 mm (a review's case): no gap between soil and blades.
        let mut k: u64 = 7;
        let mut uniform = || {
            k = k
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (k >> 11) as f64 / (1u64 << 53) as f64
        };
        let grass: Vec<Point> = ground(0.003, None, None)
            .into_iter()
            .map(|mut p| {
                if uniform() < 0.7 {
                    p.z += 0.05 * uniform();
                }
                p
            })
            .collect();
        assert_eq!(ground_layers(&grass, &at, &Vector3::z()), None);
        // Rough ground hides a 3 cm seam: nothing is claimed.
        assert_eq!(
            ground_layers(&ground(0.02, Some(0.03), None), &at, &Vector3::z()),
            None
        );
        // Too little ground: nothing to say.
        assert_eq!(
            ground_layers(&ground(0.004, Some(0.04), None)[..300], &at, &Vector3::z()),
            None
        );
    }
}
