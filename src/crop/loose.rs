//! Loose crop: one pass over the map for all targets.
//!
//! A dense grid over the targets' bounding box (cell = crop radius) maps each
//! cell to the targets whose crop region touches it, so a point costs one
//! bounding-box test and a handful of distance tests whatever the number of
//! targets. Blocks from the reader are split across threads and the per-target
//! hits are appended in block order, so the output is identical for any thread
//! count.

use crate::cloud::{PointReader, Region, Scratch};
use crate::{Error, Point, Result};
use rayon::prelude::*;
use std::sync::Mutex;

/// The region kept around each expected target position.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Shape {
    /// Vertical cylinder: horizontal distance < radius, any height (the reference code).
    #[default]
    Cylinder,
    /// Sphere: 3D distance < radius (the paper's text).
    Sphere,
}

/// Loose-crop parameters.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LooseParams {
    /// Crop radius in metres (5 m in the paper).
    pub radius: f64,
    /// Crop shape.
    pub shape: Shape,
    /// Most points [`loose_crop`] keeps per target (0 = all). Beyond it the crop
    /// is thinned uniformly at random (deterministically, see [`Thinned`]), so a
    /// dense accumulated map needs memory bounded by the number of targets, not
    /// by the map's density: 500,000 points of a 5 m crop still put tens of
    /// thousands on a 0.6 m target.
    pub max_points: usize,
}

impl Default for LooseParams {
    fn default() -> Self {
        LooseParams {
            radius: 5.0,
            shape: Shape::Cylinder,
            max_points: 500_000,
        }
    }
}

/// A point list thinned to at most `cap` points by halving: a point is kept
/// while a hash of its coordinates lies below a threshold, and the threshold
/// halves whenever the list outgrows `cap`. The kept set depends only on the
/// points (not on their order or on thread count); each point survives with the
/// same probability, 2^-`level`, so the thinning is uniform over the crop.
#[derive(Debug, Clone, Default)]
pub struct Thinned {
    /// The kept points, in the order they were pushed.
    pub points: Vec<Point>,
    /// Halvings so far: 0 = every point kept.
    pub level: u32,
    /// Points offered, kept or not.
    pub offered: u64,
    cap: usize,
}

impl Thinned {
    /// An empty list that keeps at most `cap` points (0 = no limit).
    pub fn new(cap: usize) -> Self {
        Thinned {
            cap,
            ..Default::default()
        }
    }

    fn hash(p: &Point) -> u64 {
        // splitmix64 over the coordinates' bit patterns.
        let mut z = p.x.to_bits() ^ p.y.to_bits().rotate_left(21) ^ p.z.to_bits().rotate_left(42);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn keeps(level: u32, p: &Point) -> bool {
        level == 0 || Self::hash(p) >> (64 - level.min(63)) == 0
    }

    /// Offers points; keeps those that pass the current threshold.
    pub fn extend(&mut self, pts: &[Point]) {
        self.offered += pts.len() as u64;
        let level = self.level;
        self.points
            .extend(pts.iter().filter(|p| Self::keeps(level, p)));
        while self.cap > 0 && self.points.len() > self.cap && self.level < 63 {
            self.level += 1;
            let level = self.level;
            self.points.retain(|p| Self::keeps(level, p));
        }
    }
}

/// The points of a map near each target, in the order the map stores them.
#[derive(Debug, Clone, Default)]
pub struct LooseCrop {
    /// One point list per requested centre, in the same order.
    pub points: Vec<Vec<Point>>,
    /// Points inside each crop before thinning (see [`LooseParams::max_points`]).
    pub offered: Vec<u64>,
    /// Points read from the map (finite ones).
    pub map_points: u64,
    /// Points the reader skipped as NaN/infinite.
    pub skipped_nonfinite: u64,
}

/// Upper bound on grid cells; the cell size grows when targets span a huge area.
const MAX_CELLS: usize = 1 << 22;

struct Grid {
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

impl Grid {
    fn new(centres: &[Point], radius: f64) -> Grid {
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
        Grid {
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
    fn candidates(&self, p: &Point) -> &[u32] {
        let fx = (p.x - self.min[0]) * self.inv;
        let fy = (p.y - self.min[1]) * self.inv;
        // One combined test; NaN fails it too.
        if !(fx >= 0.0 && fy >= 0.0 && fx < self.nxf && fy < self.nyf) {
            return &[];
        }
        let c = (fy as usize).min(self.ny - 1) * self.nx + (fx as usize).min(self.nx - 1);
        match (self.starts.get(c), self.starts.get(c + 1)) {
            (Some(&a), Some(&b)) if a < b => self.ids.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
    }
}

/// Streams `reader` once and returns, for every centre (map frame), the points
/// inside its crop region. `progress` is called with the bytes consumed so far.
pub fn loose_crop(
    reader: &mut dyn PointReader,
    centres: &[Point],
    params: &LooseParams,
    progress: impl FnMut(u64),
) -> Result<LooseCrop> {
    let mut kept = vec![Thinned::new(params.max_points); centres.len()];
    let (map_points, skipped_nonfinite) =
        loose_crop_each(reader, centres, params, progress, |i, p| {
            kept[i].extend(p);
            Ok(())
        })?;
    Ok(LooseCrop {
        offered: kept.iter().map(|k| k.offered).collect(),
        points: kept.into_iter().map(|k| k.points).collect(),
        map_points,
        skipped_nonfinite,
    })
}

/// [`loose_crop`] that hands the points of each crop to `sink(target, points)`
/// as they are found (in map order per target) instead of keeping them, so a
/// caller that writes crops to files needs memory independent of the crops'
/// size. Returns the map's finite and skipped non-finite point counts.
pub fn loose_crop_each(
    reader: &mut dyn PointReader,
    centres: &[Point],
    params: &LooseParams,
    mut progress: impl FnMut(u64),
    mut sink: impl FnMut(usize, &[Point]) -> Result<()>,
) -> Result<(u64, u64)> {
    if !(params.radius.is_finite() && params.radius > 0.0) {
        return Err(Error::Param(format!(
            "crop radius must be positive, got {}",
            params.radius
        )));
    }
    if centres.is_empty() {
        return Ok((0, 0));
    }
    let grid = Grid::new(centres, params.radius);
    // Handed to the reader so that it drops most of the map before building
    // points; the exact test below still decides.
    let region = Region::discs(
        &centres.iter().map(|c| [c.x, c.y]).collect::<Vec<_>>(),
        params.radius,
    );
    let r2 = params.radius * params.radius;
    let sphere = params.shape == Shape::Sphere;
    let inside = |p: &Point, c: &Point| {
        let dx = p.x - c.x;
        let dy = p.y - c.y;
        let mut d2 = dx * dx + dy * dy;
        if sphere {
            let dz = p.z - c.z;
            d2 += dz * dz;
        }
        d2 < r2
    };
    // Pieces are read, decoded and tested by the same thread, so each piece's
    // points are used while they are in its cache; hits are appended in piece
    // order, so the result does not depend on the thread count.
    let pool: Mutex<Vec<Scratch>> = Mutex::new(Vec::new());
    let mut buf = Vec::new();
    // One hit list per piece, for two batches: the hits of one batch are
    // handed to `sink` on this thread while the pool works on the next, so
    // neither core waits for the writer. The lists are kept across batches,
    // so their memory is allocated and faulted in once.
    // (Target ids and points are kept apart: a pushed (u32, Point) pair is
    // built on the stack and read back with a wider load, which stalls.)
    let mut cur: Vec<(Vec<u32>, Vec<Point>)> = Vec::new();
    let mut prev: Vec<(Vec<u32>, Vec<Point>)> = Vec::new();
    let mut prev_n = 0;
    // A piece's hits usually belong to one target and go to `sink` as they
    // lie, without a copy; a piece that mixes targets (crops overlapping, or
    // two targets near one piece) is sorted out per target first, in order,
    // so that `sink` is never called point by point.
    let mut per: Vec<Vec<Point>> = vec![Vec::new(); centres.len()];
    let mut drain = |hits: &[(Vec<u32>, Vec<Point>)]| -> Result<()> {
        for (ids, pts) in hits {
            let Some(&first) = ids.first() else {
                continue;
            };
            if ids.iter().all(|&i| i == first) {
                sink(first as usize, pts)?;
                continue;
            }
            for (&i, &p) in ids.iter().zip(pts) {
                per[i as usize].push(p);
            }
            for (i, v) in per.iter_mut().enumerate() {
                if !v.is_empty() {
                    sink(i, v)?;
                    v.clear();
                }
            }
        }
        Ok(())
    };
    loop {
        let Some(batch) = reader.next_batch(&mut buf)? else {
            break;
        };
        let n = batch.pieces();
        if cur.len() < n {
            cur.resize_with(n, Default::default);
        }
        let mut done: Vec<Result<()>> = Vec::new();
        let drained = rayon::in_place_scope(|s| {
            let (cur, done, batch) = (&mut cur, &mut done, &batch);
            let (pool, region, grid, inside) = (&pool, &region, &grid, &inside);
            s.spawn(move |_| {
                *done = cur[..n]
                    .par_iter_mut()
                    .enumerate()
                    .map(|(i, (ids, pts))| {
                        ids.clear();
                        pts.clear();
                        let mut scratch = pool
                            .lock()
                            .ok()
                            .and_then(|mut p| p.pop())
                            .unwrap_or_default();
                        let block = match region {
                            Some(r) => batch.piece_within(i, &mut scratch, r),
                            None => batch.piece(i, &mut scratch),
                        };
                        let res = block.map(|block| {
                            for p in block {
                                for &i in grid.candidates(p) {
                                    if inside(p, &centres[i as usize]) {
                                        ids.push(i);
                                        pts.push(*p);
                                    }
                                }
                            }
                        });
                        if let Ok(mut p) = pool.lock() {
                            p.push(scratch);
                        }
                        res
                    })
                    .collect();
            });
            drain(&prev[..prev_n])
        });
        drop(batch);
        drained?;
        done.into_iter().collect::<Result<()>>()?;
        std::mem::swap(&mut cur, &mut prev);
        prev_n = n;
        progress(reader.bytes_read());
    }
    drain(&prev[..prev_n])?;
    let st = reader.stats();
    Ok((st.points, st.skipped_nonfinite))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloud::{CloudInfo, Format, ReadStats};
    use rand::{Rng, SeedableRng};

    /// An in-memory reader handing out fixed-size blocks.
    pub(crate) struct VecReader {
        pts: Vec<Point>,
        pos: usize,
        block: usize,
        info: CloudInfo,
    }

    impl VecReader {
        pub(crate) fn new(pts: Vec<Point>, block: usize) -> Self {
            let info = CloudInfo {
                format: Format::Xyz,
                declared_points: Some(pts.len() as u64),
                file_bytes: 0,
            };
            VecReader {
                pts,
                pos: 0,
                block,
                info,
            }
        }
    }

    impl PointReader for VecReader {
        fn info(&self) -> &CloudInfo {
            &self.info
        }
        fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
            buf.clear();
            if self.pos >= self.pts.len() {
                return Ok(false);
            }
            let end = (self.pos + self.block).min(self.pts.len());
            buf.extend_from_slice(&self.pts[self.pos..end]);
            self.pos = end;
            Ok(true)
        }
        fn stats(&self) -> ReadStats {
            ReadStats {
                points: self.pos as u64,
                skipped_nonfinite: 0,
            }
        }
        fn bytes_read(&self) -> u64 {
            self.pos as u64 * 24
        }
    }

    fn scene(origin: [f64; 3], seed: u64) -> (Vec<Point>, Vec<Point>) {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
        let pts: Vec<Point> = (0..200_000)
            .map(|_| {
                Point::new(
                    origin[0] + rng.random_range(-100.0..100.0),
                    origin[1] + rng.random_range(-100.0..100.0),
                    origin[2] + rng.random_range(-5.0..5.0),
                )
            })
            .collect();
        let centres: Vec<Point> = (0..25)
            .map(|i| {
                let a = i as f64 * 0.7;
                Point::new(
                    origin[0] + 60.0 * a.cos(),
                    origin[1] + 60.0 * a.sin(),
                    origin[2],
                )
            })
            .chain([
                Point::new(origin[0] + 1.0, origin[1] + 2.0, origin[2]),
                Point::new(origin[0] + 3.0, origin[1] + 2.0, origin[2]),
            ])
            .collect();
        (pts, centres)
    }

    fn brute(pts: &[Point], centres: &[Point], p: &LooseParams) -> Vec<usize> {
        centres
            .iter()
            .map(|c| {
                pts.iter()
                    .filter(|q| {
                        let h = (q.x - c.x).powi(2) + (q.y - c.y).powi(2);
                        let d = if p.shape == Shape::Sphere {
                            h + (q.z - c.z).powi(2)
                        } else {
                            h
                        };
                        d < p.radius * p.radius
                    })
                    .count()
            })
            .collect()
    }

    #[test]
    fn counts_equal_brute_force_for_both_shapes() {
        let (pts, centres) = scene([0.0; 3], 1);
        for shape in [Shape::Cylinder, Shape::Sphere] {
            let params = LooseParams {
                radius: 5.0,
                shape,
                ..LooseParams::default()
            };
            let mut r = VecReader::new(pts.clone(), 70_001);
            let crop = loose_crop(&mut r, &centres, &params, |_| {}).unwrap();
            let got: Vec<usize> = crop.points.iter().map(Vec::len).collect();
            assert_eq!(got, brute(&pts, &centres, &params));
            assert_eq!(crop.map_points, pts.len() as u64);
            assert!(got.iter().all(|&n| n > 0));
        }
    }

    #[test]
    fn utm_sized_coordinates_give_the_same_crops_as_the_origin() {
        let offset = [350_000.0, 4_150_000.0, 50.0];
        let (pts0, c0) = scene([0.0; 3], 7);
        let shift = |v: &[Point]| {
            v.iter()
                .map(|p| Point::new(p.x + offset[0], p.y + offset[1], p.z + offset[2]))
                .collect::<Vec<_>>()
        };
        let (pts1, c1) = (shift(&pts0), shift(&c0));
        let params = LooseParams::default();
        let a = loose_crop(&mut VecReader::new(pts0, 50_000), &c0, &params, |_| {}).unwrap();
        let b = loose_crop(&mut VecReader::new(pts1, 50_000), &c1, &params, |_| {}).unwrap();
        for (pa, pb) in a.points.iter().zip(&b.points) {
            assert_eq!(pa.len(), pb.len());
            for (p, q) in pa.iter().zip(pb) {
                assert!(
                    (q.x - offset[0] - p.x).abs() < 1e-9 && (q.y - offset[1] - p.y).abs() < 1e-9
                );
            }
        }
    }

    /// Through a file reader that drops points outside the crop region before
    /// building them: the same crops as brute force, also for points a hair
    /// inside and outside the rim and at UTM-sized coordinates, and the same
    /// map and NaN counts as a plain read.
    #[test]
    fn region_filtered_file_reads_equal_brute_force() {
        let dir = tempfile::tempdir().unwrap();
        for (k, origin) in [[0.0; 3], [512_345.5, 5_412_345.25, 120.0], [0.0; 3]]
            .iter()
            .enumerate()
        {
            let (mut pts, mut centres) = scene(*origin, 11 + k as u64);
            if k == 2 {
                // A survey typo far away coarsens the region's grid, which
                // must still hold every point of the other targets.
                centres.push(Point::new(1e300, -1e15, 0.0));
            }
            let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
            for c in &centres {
                for j in 0..400 {
                    let a: f64 = rng.random_range(0.0..std::f64::consts::TAU);
                    let d = 5.0 * (1.0 + (j as f64 - 200.0) * 1e-15);
                    pts.push(Point::new(c.x + d * a.cos(), c.y + d * a.sin(), c.z));
                }
            }
            pts.push(Point::new(f64::NAN, centres[0].y, 0.0));
            pts.push(Point::new(centres[0].x, centres[0].y, f64::INFINITY));
            let path = dir.path().join(format!("m{k}.pcd"));
            let mut w =
                crate::cloud::CloudWriter::create(&path, crate::cloud::OutFormat::Pcd).unwrap();
            w.write(&pts).unwrap();
            w.finish().unwrap();
            let finite: Vec<Point> = pts
                .iter()
                .copied()
                .filter(|p| p.x.is_finite() && p.y.is_finite() && p.z.is_finite())
                .collect();
            for shape in [Shape::Cylinder, Shape::Sphere] {
                let params = LooseParams {
                    shape,
                    max_points: 0,
                    ..LooseParams::default()
                };
                let mut r = crate::cloud::open(&path).unwrap();
                let crop = loose_crop(&mut *r, &centres, &params, |_| {}).unwrap();
                let got: Vec<usize> = crop.points.iter().map(Vec::len).collect();
                assert_eq!(got, brute(&finite, &centres, &params), "case {k}");
                assert!(got.iter().filter(|&&n| n > 0).count() >= 25, "case {k}");
                assert_eq!(crop.map_points, finite.len() as u64);
                assert_eq!(crop.skipped_nonfinite, 2);
                let all = loose_crop(
                    &mut VecReader::new(finite.clone(), 4096),
                    &centres,
                    &params,
                    |_| {},
                )
                .unwrap();
                assert_eq!(crop.points, all.points);
            }
        }
    }

    #[test]
    fn order_is_independent_of_block_size() {
        let (pts, centres) = scene([0.0; 3], 3);
        let p = LooseParams::default();
        let a = loose_crop(
            &mut VecReader::new(pts.clone(), 1_000),
            &centres,
            &p,
            |_| {},
        )
        .unwrap();
        let b = loose_crop(&mut VecReader::new(pts, 1 << 20), &centres, &p, |_| {}).unwrap();
        assert_eq!(a.points, b.points);
    }

    #[test]
    fn bad_radius_is_an_error() {
        let p = LooseParams {
            radius: -1.0,
            ..LooseParams::default()
        };
        let e = loose_crop(
            &mut VecReader::new(vec![], 10),
            &[Point::origin()],
            &p,
            |_| {},
        )
        .unwrap_err();
        assert!(e.to_string().contains("radius"));
    }

    #[test]
    fn thinning_is_bounded_uniform_and_order_free() {
        let pts: Vec<Point> = (0..100_000)
            .map(|i| {
                let t = i as f64;
                Point::new(
                    (t * 0.618).fract() * 10.0,
                    (t * 0.377).fract() * 10.0,
                    t * 1e-5,
                )
            })
            .collect();
        let mut a = Thinned::new(30_000);
        for c in pts.chunks(777) {
            a.extend(c);
        }
        assert!(
            a.points.len() <= 30_000 && a.points.len() > 10_000,
            "{}",
            a.points.len()
        );
        assert_eq!((a.level, a.offered), (2, 100_000));
        // Same set whatever the order the points arrive in.
        let mut b = Thinned::new(30_000);
        let rev: Vec<Point> = pts.iter().rev().copied().collect();
        b.extend(&rev);
        let key = |v: &[Point]| {
            let mut k: Vec<[u64; 3]> = v
                .iter()
                .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                .collect();
            k.sort();
            k
        };
        assert_eq!(key(&a.points), key(&b.points));
        // Uniform: each half of the x range keeps about half of the points.
        let left = a.points.iter().filter(|p| p.x < 5.0).count() as f64;
        assert!((left / a.points.len() as f64 - 0.5).abs() < 0.02);
        // No cap: nothing is dropped.
        let mut c = Thinned::new(0);
        c.extend(&pts);
        assert_eq!((c.points.len(), c.level), (pts.len(), 0));
    }
}
