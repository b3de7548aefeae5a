//! The loose crop's grid of targets: a dense grid over the targets' bounding
//! box (cell = crop radius) maps each cell to the targets whose crop region
//! touches it, so a point costs one bounding-box test and a handful of
//! distance tests whatever the number of targets.

use crate::Point;

/// Upper bound on grid cells; the cell size grows when targets span a huge area.
const MAX_CELLS: usize = 1 << 22;

/// The targets whose crop region touches each cell of the grid, so that a
/// point is tested only against the few targets near it.
pub(super) struct CentreIndex {
    min: [f64; 2],
    /// 1 / cell size: a multiplication per axis instead of a division.
    inv: f64,
    nx: usize,
    ny: usize,
    /// `nx`, `ny` as f64 (the bounds test is done before the conversion).
    nxf: f64,
    nyf: f64,
    /// CSR: cell → range in `ids`.
    starts: Vec<u32>,
    ids: Vec<u32>,
}

impl CentreIndex {
    pub(super) fn new(centres: &[Point], radius: f64) -> CentreIndex {
        let mut min = [f64::INFINITY; 2];
        let mut max = [f64::NEG_INFINITY; 2];
        for c in centres {
            for k in 0..2 {
                min[k] = min[k].min(c[k] - radius);
                max[k] = max[k].max(c[k] + radius);
            }
        }
        let mut cell = radius.max(1e-3);
        let (mut nx, mut ny);
        loop {
            nx = (((max[0] - min[0]) / cell).ceil() as usize).max(1);
            ny = (((max[1] - min[1]) / cell).ceil() as usize).max(1);
            if nx.saturating_mul(ny) <= MAX_CELLS {
                break;
            }
            cell *= 2.0;
        }
        let inv = 1.0 / cell;
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); nx * ny];
        // A point's cell is computed as `(p - min) * inv`, which is monotone in
        // p; a region's cells are computed the same way from its extent widened
        // by far more than the rounding error, so every point that passes the
        // distance test lies in a cell that lists its target.
        let idx =
            |v: f64, lo: f64, n: usize| (((v - lo) * inv).floor().max(0.0) as usize).min(n - 1);
        for (i, c) in centres.iter().enumerate() {
            let ex = 1e-9 * (c.x.abs() + radius + 1.0);
            let ey = 1e-9 * (c.y.abs() + radius + 1.0);
            let x0 = idx(c.x - radius - ex, min[0], nx);
            let x1 = idx(c.x + radius + ex, min[0], nx);
            let y0 = idx(c.y - radius - ey, min[1], ny);
            let y1 = idx(c.y + radius + ey, min[1], ny);
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    lists[iy * nx + ix].push(i as u32);
                }
            }
        }
        let mut starts = Vec::with_capacity(nx * ny + 1);
        let mut ids = Vec::new();
        starts.push(0);
        for l in &lists {
            ids.extend_from_slice(l);
            starts.push(ids.len() as u32);
        }
        CentreIndex {
            min,
            inv,
            nx,
            ny,
            nxf: nx as f64,
            nyf: ny as f64,
            starts,
            ids,
        }
    }

    #[inline]
    pub(super) fn candidates(&self, p: &Point) -> &[u32] {
        let fx = (p.x - self.min[0]) * self.inv;
        let fy = (p.y - self.min[1]) * self.inv;
        // One combined test; NaN fails it too.
        if !(fx >= 0.0 && fy >= 0.0 && fx < self.nxf && fy < self.nyf) {
            return &[];
        }
        // Both lie in [0, 2^22) here (at most `MAX_CELLS` cells), so a u32
        // conversion truncates exactly as a usize one would, and costs one
        // instruction instead of a 64-bit unsigned conversion's dozen.
        let c =
            (fy as u32 as usize).min(self.ny - 1) * self.nx + (fx as u32 as usize).min(self.nx - 1);
        match (self.starts.get(c), self.starts.get(c + 1)) {
            (Some(&a), Some(&b)) if a < b => self.ids.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
    }
}
