//! Step 1 of the tight crop: the local ground, as a plane (RANSAC through the
//! lowest point of each cell, refined by least squares) for the normal and
//! per-cell minima for the bumps the plane cannot follow.

use super::TightParams;
use crate::frame::grid::TileMap;
use crate::geom::{Draw, Plane, Ransac, Scatter};
use nalgebra::Vector3;
use rand::SeedableRng;

/// Local ground: a plane for the normal, per-cell minima for the bumps.
pub(super) struct Ground {
    /// Upward unit normal of the ground plane.
    pub(super) normal: Vector3<f64>,
    offset: f64,
    cell: f64,
    /// Lowest plane height in each cell's 3×3 block.
    floor: TileMap<(i64, i64), f64>,
}

impl Ground {
    fn key(cell: f64, v: &Vector3<f64>) -> (i64, i64) {
        ((v.x / cell).floor() as i64, (v.y / cell).floor() as i64)
    }

    pub(super) fn fit(q: &[Vector3<f64>], params: &TightParams) -> Ground {
        let cell = params.ground_cell.max(0.05);
        // Cell-keyed maps with the grid's fast hasher (SipHash was a tenth of a
        // dense crop); nothing below depends on their order.
        let mut lowest: TileMap<(i64, i64), Vector3<f64>> = TileMap::default();
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
        let mut cell_min: TileMap<(i64, i64), f64> = TileMap::default();
        for v in q {
            let h = normal.dot(v) - offset;
            cell_min
                .entry(Self::key(cell, v))
                .and_modify(|m| *m = m.min(h))
                .or_insert(h);
        }
        let mut floor = TileMap::with_capacity_and_hasher(cell_min.len(), Default::default());
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

    /// Height of `v` above the local ground (the lowest point nearby).
    pub(super) fn height(&self, v: &Vector3<f64>) -> f64 {
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
    let all: Vec<u32> = (0..u32::try_from(c.len()).ok()?).collect();
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed ^ 0x6a09_e667_f3bc_c908);
    let ransac = Ransac {
        iterations: 200,
        threshold: 0.12,
        score_points: 0,
        confidence: 0.0,
        draw: Draw::Independent,
    };
    // Hypotheses face up; steeper than 20° is not ground.
    let level = |p: Plane| {
        let p = if p.normal.z < 0.0 { p.flipped() } else { p };
        if p.normal.z < 0.94 { None } else { Some(p) }
    };
    let mut inliers = Vec::new();
    ransac.best_plane_where(c, &all, &mut rng, &mut Vec::new(), &mut inliers, level)?;
    if inliers.len() < 3 {
        return None;
    }
    let axis = Scatter::of(inliers.iter().map(|&i| &c[i as usize]))?.least_axis();
    let normal = if axis.z < 0.0 { -axis } else { axis };
    Some(normal.normalize())
}
