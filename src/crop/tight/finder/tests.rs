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
