//! Loose crop: streaming, shapes, thinning, bad radii.

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
            assert!((q.x - offset[0] - p.x).abs() < 1e-9 && (q.y - offset[1] - p.y).abs() < 1e-9);
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
        let mut w = crate::cloud::CloudWriter::create(&path, crate::cloud::OutFormat::Pcd).unwrap();
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

/// A dense map read from a file whose batches hold more hits per thread
/// than a lane segment (so pieces land in several segments, and crops
/// overlap): every thread count hands the sink the same points in map order,
/// equal to brute force.
#[test]
fn dense_file_crops_are_in_map_order_at_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(9);
    // 150,000 points in a 16 m square: nearly all of them within 5 m of one
    // of the two overlapping targets, so one batch holds far more than
    // `SEGMENT` hits.
    let pts: Vec<Point> = (0..150_000)
        .map(|_| {
            Point::new(
                rng.random_range(-8.0..8.0),
                rng.random_range(-8.0..8.0),
                rng.random_range(0.0..2.0),
            )
        })
        .collect();
    let centres = [Point::new(-2.0, 0.0, 1.0), Point::new(2.5, 0.5, 1.0)];
    let path = dir.path().join("dense.pcd");
    let mut w = crate::cloud::CloudWriter::create(&path, crate::cloud::OutFormat::Pcd).unwrap();
    w.write(&pts).unwrap();
    w.finish().unwrap();
    let params = LooseParams {
        max_points: 0,
        ..LooseParams::default()
    };
    let want: Vec<Vec<Point>> = centres
        .iter()
        .map(|c| {
            pts.iter()
                .copied()
                .filter(|p| {
                    let (dx, dy) = (p.x - c.x, p.y - c.y);
                    dx * dx + dy * dy < 25.0
                })
                .collect()
        })
        .collect();
    assert!(want.iter().map(Vec::len).sum::<usize>() > 2 * super::SEGMENT);
    for threads in [1, 2, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let got = pool.install(|| {
            let mut r = crate::cloud::open(&path).unwrap();
            let mut got = vec![Vec::new(); centres.len()];
            loose_crop_each(
                &mut *r,
                &centres,
                &params,
                |_| {},
                |i, p| {
                    got[i].extend_from_slice(p);
                    Ok(())
                },
            )
            .unwrap();
            got
        });
        assert_eq!(got, want, "{threads} threads");
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

#[test]
fn a_taken_lane_is_passed_over_not_waited_for() {
    let m: Vec<std::sync::Mutex<u32>> = (0..3).map(std::sync::Mutex::new).collect();
    let (i, g) = lock_any(&m, 1);
    assert_eq!((i, *g), (1, 1));
    // The same thread asks again while holding lane 1: lane 2, not a deadlock.
    let (j, h) = lock_any(&m, 1);
    assert_eq!((j, *h), (2, 2));
    let (k, f) = lock_any(&m, 1);
    assert_eq!((k, *f), (0, 0));
    drop((g, h, f));
}
