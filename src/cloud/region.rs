//! A region of the horizontal plane that a consumer wants points from, handed
//! to a reader so it can drop the rest before building them.
//!
//! Why: the loose crop keeps a few percent of a map. Testing raw coordinates
//! against a bitmap while a record is still in the cache, and never building
//! (or handing over) the other points, costs a fraction of decoding every point
//! and testing it afterwards. The region is a hint: it is a superset of what the
//! consumer keeps, so a reader may ignore it, and the consumer still applies its
//! exact test.

/// Most cells a region's bitmap may have (2 MiB of bits); the cell size grows
/// when the discs span a larger area.
const MAX_CELLS: usize = 1 << 24;

/// Cells per disc radius (the finer, the fewer points outside the discs pass).
const CELLS_PER_RADIUS: f64 = 8.0;

/// A set of cells of a regular grid in the horizontal (x, y) plane.
#[derive(Debug, Clone)]
pub struct Region {
    /// Centre of cell (0, 0); the grid has one empty cell of border all
    /// round.
    min: [f64; 2],
    /// 1 / cell size.
    inv: f64,
    nx: u32,
    ny: u32,
    bits: Vec<u64>,
}

impl Region {
    /// The cells that touch any disc of `radius` around a centre `[x, y]`.
    /// Every point within `radius` of a centre (horizontally) is contained.
    /// `None` when the radius is not a positive finite number or the discs
    /// span more than a grid can cover (centres near ±1e300, say): the caller
    /// then reads every point. No centres give an empty region.
    pub fn discs(centers: &[[f64; 2]], radius: f64) -> Option<Region> {
        if !(radius.is_finite() && radius > 0.0) {
            return None;
        }
        if centers.is_empty() {
            return Some(Region::empty());
        }
        // Cell k (per axis) holds the values whose `(v - min) * inv` rounds
        // to k: computed in floating point, so with an error of a few ulps of
        // the largest coordinate involved. `slack` bounds that error by far,
        // in metres; the box and every cell are widened by it, so no point
        // inside a disc lands in an unset cell.
        let big = centers
            .iter()
            .map(|c| c[0].abs() + c[1].abs())
            .fold(0.0, f64::max)
            + radius
            + 1.0;
        // The rounding errors are a few ulps of `big` (~1e-15 of it); a
        // thousand times that.
        let slack0 = 1e-12 * big;
        let mut min = [f64::INFINITY; 2];
        let mut max = [f64::NEG_INFINITY; 2];
        for c in centers {
            for k in 0..2 {
                min[k] = min[k].min(c[k] - radius - 2.0 * slack0);
                max[k] = max[k].max(c[k] + radius + 2.0 * slack0);
            }
        }
        let mut cell = radius / CELLS_PER_RADIUS;
        let (nx, ny) = loop {
            // (A subnormal radius gives a cell of 0, which doubling never
            // leaves.)
            if !(cell.is_finite() && cell > 0.0) {
                return None;
            }
            // Counted in f64 (a huge span must not saturate or wrap). Three
            // more than the box needs: a border cell below it, one above it,
            // and the half cell each side that rounding to the nearest cell
            // centre takes.
            let fx = ((max[0] - min[0]) / cell).ceil() + 3.0;
            let fy = ((max[1] - min[1]) / cell).ceil() + 3.0;
            if fx * fy <= MAX_CELLS as f64 {
                break (fx as usize, fy as usize);
            }
            cell *= 2.0;
        };
        // Cell 0's centre one cell below the box: box values map to [1, n - 2].
        let min = [min[0] - cell, min[1] - cell];
        if !min.iter().chain(&max).all(|v| v.is_finite()) {
            return None;
        }
        let inv = 1.0 / cell;
        let slack = slack0 + 1e-6 * cell;
        let reach = radius + slack;
        let mut bits = vec![0u64; (nx * ny).div_ceil(64)];
        for c in centers {
            // Never a border cell: the box lies between them with half a
            // cell to spare, and cell 0 also takes NaN.
            let range = |v: f64, lo: f64, n: usize| {
                let a = (((v - reach - lo) * inv).round().max(1.0) as usize).min(n - 2);
                let b = (((v + reach - lo) * inv).round().max(1.0) as usize).min(n - 2);
                a..=b
            };
            // Distance from `v` to cell k's extent, widened by the slack.
            let gap = |v: f64, lo: f64, k: usize| {
                let a = lo + (k as f64 - 0.5) * cell - slack;
                let b = lo + (k as f64 + 0.5) * cell + slack;
                (a - v).max(v - b).max(0.0)
            };
            for iy in range(c[1], min[1], ny) {
                let dy = gap(c[1], min[1], iy);
                for ix in range(c[0], min[0], nx) {
                    let dx = gap(c[0], min[0], ix);
                    if dx * dx + dy * dy <= reach * reach {
                        let i = iy * nx + ix;
                        bits[i / 64] |= 1 << (i % 64);
                    }
                }
            }
        }
        Some(Region {
            min,
            inv,
            nx: nx as u32,
            ny: ny as u32,
            bits,
        })
    }

    /// A region containing nothing.
    fn empty() -> Region {
        Region {
            min: [0.0; 2],
            inv: 1.0,
            nx: 0,
            ny: 0,
            bits: Vec::new(),
        }
    }

    /// Whether the cell of `(x, y)` is in the region. False for NaN and
    /// infinities too, except that a NaN's payload may name a cell: a reader
    /// tests finiteness itself.
    #[inline(always)]
    pub fn contains(&self, x: f64, y: f64) -> bool {
        // Adding 1.5 * 2^52 rounds to the nearest integer, which lands in the
        // low bits (exact for |v| < 2^51): a cheaper float-to-int than `as`,
        // which must saturate. Negatives wrap to huge values and fail the
        // compare, the canonical NaN gives 0 (a border cell), and values about
        // 2^32 cells away may alias a cell: a superset is all a region
        // promises.
        const ROUND: f64 = 6_755_399_441_055_744.0;
        let ix = ((x - self.min[0]) * self.inv + ROUND).to_bits() as u32;
        let iy = ((y - self.min[1]) * self.inv + ROUND).to_bits() as u32;
        if ix >= self.nx || iy >= self.ny {
            return false;
        }
        let i = iy as usize * self.nx as usize + ix as usize;
        self.bits
            .get(i / 64)
            .is_some_and(|w| (w >> (i % 64)) & 1 == 1)
    }

    /// Share of the bounding box's cells that are set.
    #[cfg(test)]
    fn fill(&self) -> f64 {
        let set: u64 = self.bits.iter().map(|w| u64::from(w.count_ones())).sum();
        let cells = f64::from(self.nx) * f64::from(self.ny);
        if cells > 0.0 { set as f64 / cells } else { 0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(s: &mut u64) -> f64 {
        *s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*s >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn every_point_in_a_disc_is_contained_and_far_points_are_not() {
        for (cx, cy) in [(0.0, 0.0), (512_345.678, 5_412_345.123), (-17.5, 3.25)] {
            let centers = [[cx, cy], [cx + 13.0, cy - 4.0], [cx + 400.0, cy + 250.0]];
            let r = 5.0;
            let reg = Region::discs(&centers, r).unwrap();
            let mut s = 7u64;
            for _ in 0..200_000 {
                let c = centers[(lcg(&mut s) * 3.0) as usize % 3];
                let a = lcg(&mut s) * std::f64::consts::TAU;
                // Up to just inside the rim, where rounding matters most.
                let d = r * (1.0 - 1e-12) * lcg(&mut s).sqrt().max(lcg(&mut s));
                let (x, y) = (c[0] + d * a.cos(), c[1] + d * a.sin());
                assert!(reg.contains(x, y), "({x}, {y}) near {c:?} dropped");
                // Well outside every disc: one cell of slack beyond the rim.
                let far = r + 2.0 * r / CELLS_PER_RADIUS * std::f64::consts::SQRT_2;
                let (fx, fy) = (c[0] + far * a.cos(), c[1] + far * a.sin());
                let near_other = centers.iter().any(|o| (fx - o[0]).hypot(fy - o[1]) < far);
                if !near_other {
                    assert!(!reg.contains(fx, fy), "({fx}, {fy}) kept");
                }
            }
            assert!(!reg.contains(f64::NAN, cy));
            assert!(!reg.contains(cx, f64::INFINITY));
            assert!(reg.fill() > 0.0 && reg.fill() < 0.01, "{}", reg.fill());
        }
    }

    #[test]
    fn exact_rim_points_on_cell_borders_are_contained() {
        // Centres and radius on the cell grid, so rim points fall exactly on
        // cell borders.
        let reg = Region::discs(&[[0.0, 0.0]], 8.0).unwrap();
        for (x, y) in [(8.0, 0.0), (-8.0, 0.0), (0.0, 8.0), (0.0, -8.0)] {
            assert!(reg.contains(x, y), "({x}, {y})");
        }
        for k in 0..3600 {
            let a = k as f64 / 3600.0 * std::f64::consts::TAU;
            let (x, y) = (8.0 * (1.0 - 1e-15) * a.cos(), 8.0 * (1.0 - 1e-15) * a.sin());
            assert!(reg.contains(x, y), "({x}, {y})");
        }
    }

    #[test]
    fn huge_spans_stay_within_the_cell_cap() {
        let reg = Region::discs(&[[0.0, 0.0], [1e6, 1e6]], 5.0).unwrap();
        assert!(reg.bits.len() * 64 <= MAX_CELLS + 64);
        assert!(reg.contains(1e6 + 4.9, 1e6));
        assert!(reg.contains(0.0, -4.9));
        assert!(!reg.contains(5e5, 5e5));
        let none = Region::discs(&[], 5.0).unwrap();
        assert!(!none.contains(0.0, 0.0));
        // Spans no grid can cover give no region (the caller reads
        // everything) instead of a wrapped cell count.
        if let Some(r) = Region::discs(&[[0.0, 0.0], [1e300, 1e300]], 5.0) {
            assert!(r.contains(0.0, 4.9) && r.contains(0.0, 0.0) && r.contains(1e300, 1e300));
        }
        assert!(Region::discs(&[[-1.7e308, 0.0], [1.7e308, 0.0]], 5.0).is_none());
        assert!(Region::discs(&[[0.0, 0.0]], f64::NAN).is_none());
        for k in 1..=8 {
            // Subnormal radii round the cell to 0; this once looped forever.
            let r = f64::from_bits(k);
            assert!(Region::discs(&[[0.0, 0.0]], r).is_none_or(|g| g.contains(0.0, 0.0)));
        }
        let far = Region::discs(&[[0.0, 0.0], [1e15, -1e15]], 5.0).unwrap();
        assert!(far.contains(0.0, 4.9) && far.contains(1e15, -1e15 + 4.9));
    }
}
