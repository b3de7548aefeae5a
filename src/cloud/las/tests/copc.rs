//! COPC: a whole read equals the plain LAZ one; a region hint reads the
//! nodes near the targets only (by level when a crop keeps few points);
//! a late or invalid hint is ignored; a damaged file is an error.

use super::*;

/// A COPC file written by copclib 2.6.3 (`bench/copc_write.py --random 20000
/// 21`, leaves of about 200 points): 20 000 points in 400 m x 400 m x 20 m,
/// 169 nodes on levels 0-3.
const COPC: &[u8] = include_bytes!("../../../../tests/corpus/random-20k.copc.laz");

/// [`COPC`] in a temporary directory (kept while the first is alive).
fn copc_file() -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.copc.laz");
    std::fs::write(&path, COPC).unwrap();
    (dir, path)
}

#[test]
fn copc_whole_read_equals_plain_laz() {
    let (_dir, path) = copc_file();
    let mut copc = crate::cloud::las::open(&path).unwrap();
    let mut plain = open_with(&path, false, true).unwrap();
    assert!(plain.tile_stats().is_none(), "the plain path reads chunks");
    let (a, b) = (all(copc.as_mut()), all(plain.as_mut()));
    assert_eq!(a.len(), 20_000);
    assert_eq!(a, b, "same points in the same order");
    assert_eq!(copc.stats(), plain.stats());
    // Variable-size chunks: coordinate-only decoding equals the crate's.
    let (c, sc, _) = all_of(&path, false, false).unwrap();
    assert!(c == a && sc == copc.stats());
    assert_eq!(copc.info().format, Format::Laz);
    assert_eq!(copc.info().declared_points, Some(20_000));
    let t = copc.tile_stats().unwrap();
    assert!(
        t.copc && t.tiles == 169 && t.selected == 169 && t.opened == 169,
        "{t:?}"
    );
    assert_eq!(t.bytes_opened, t.bytes);
    assert!(t.bytes > 0 && t.bytes < COPC.len() as u64);
}

#[test]
fn copc_crop_reads_near_nodes_only_and_equals_plain_laz() {
    use crate::crop::{LooseParams, Shape, loose_crop};
    let (_dir, path) = copc_file();
    let centres = [
        Point::new(350_100.5, 4_150_100.5, 10.0),
        Point::new(350_312.2, 4_150_250.7, 5.0),
        // On the octree's corner, and off the map.
        Point::new(350_000.0, 4_150_000.0, 0.0),
        Point::new(349_000.0, 4_150_000.0, 0.0),
    ];
    for (radius, shape) in [
        (10.0, Shape::Cylinder),
        (10.0, Shape::Sphere),
        (60.0, Shape::Cylinder),
    ] {
        let params = LooseParams {
            radius,
            shape,
            max_points: 0,
            by_level: false,
            ..LooseParams::default()
        };
        let mut copc = crate::cloud::las::open(&path).unwrap();
        let mut plain = open_with(&path, false, true).unwrap();
        let a = loose_crop(copc.as_mut(), &centres, &params, |_| ()).unwrap();
        let b = loose_crop(plain.as_mut(), &centres, &params, |_| ()).unwrap();
        assert_eq!(a.points, b.points, "radius {radius} {shape:?}");
        assert_eq!(a.offered, b.offered);
        assert!(a.points[0].len() > 5 && a.points[1].len() > 5 && a.points[3].is_empty());
        let t = copc.tile_stats().unwrap();
        assert!(t.selected < t.tiles && t.opened == t.selected, "{t:?}");
        assert!(t.bytes_opened < t.bytes / 2, "{t:?}");
        // Only the points of the nodes read were decoded.
        assert!(a.map_points < b.map_points && b.map_points == 20_000);
    }
}

/// A crop that needs `enough` points reads near each centre only the levels
/// that hold more than that there: fewer nodes, a subset of the full crop's
/// points, each crop still more than it needs.
#[test]
fn copc_crop_by_level_reads_the_coarse_levels_it_needs() {
    use crate::crop::{LooseParams, Shape, loose_crop, loose_crop_by_level};
    let (_dir, path) = copc_file();
    let centres = [
        Point::new(350_100.5, 4_150_100.5, 10.0),
        Point::new(350_312.2, 4_150_250.7, 5.0),
    ];
    let params = LooseParams {
        radius: 60.0,
        shape: Shape::Cylinder,
        max_points: 60,
        by_level: false,
        ..LooseParams::default()
    };
    let mut every = crate::cloud::las::open(&path).unwrap();
    let full = loose_crop(every.as_mut(), &centres, &params, |_| ()).unwrap();
    assert!(full.levels_cut.is_empty());
    let mut copc = crate::cloud::las::open(&path).unwrap();
    let by_level = loose_crop_by_level(copc.as_mut(), &centres, &params, 60, |_| ()).unwrap();
    let (a, b) = (copc.tile_stats().unwrap(), every.tile_stats().unwrap());
    assert!(
        by_level.levels_cut == [true, true] && a.opened < b.opened,
        "{a:?} against {b:?}"
    );
    assert!(a.bytes_opened < b.bytes_opened);
    for i in 0..centres.len() {
        assert!(
            full.offered[i] > 3 * by_level.offered[i],
            "{:?} {:?}",
            full.offered,
            by_level.offered
        );
        assert!(by_level.offered[i] > 60, "{:?}", by_level.offered);
    }
    // Needing more than the levels hold, every level is read.
    let mut copc = crate::cloud::las::open(&path).unwrap();
    let all = loose_crop_by_level(copc.as_mut(), &centres, &params, u64::MAX / 2, |_| ()).unwrap();
    assert!(all.levels_cut.is_empty());
    assert_eq!(all.offered, full.offered);
}

#[test]
fn copc_hint_after_reading_or_invalid_is_ignored() {
    let (_dir, path) = copc_file();
    let mut r = crate::cloud::las::open(&path).unwrap();
    r.hint_discs(&[[f64::NAN, 0.0]], 5.0);
    r.hint_discs(&[[350_100.0, 4_150_100.0]], -1.0);
    let mut buf = Vec::new();
    assert!(r.next_chunk(&mut buf).unwrap());
    r.hint_discs(&[[350_100.0, 4_150_100.0]], 1.0);
    let t = r.tile_stats().unwrap();
    assert_eq!(t.selected, t.tiles);
    let n = buf.len() + all(r.as_mut()).len();
    assert_eq!(n, 20_000);
}

#[test]
fn copc_truncated_or_corrupt_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.copc.laz");
    // Without its hierarchy (the EVLR at the end) it is read as plain LAZ,
    // whose chunk table is gone too.
    std::fs::write(&path, &COPC[..COPC.len() / 2]).unwrap();
    assert!(read(&path).is_err());
    // Node data overwritten: the decoder's error (or caught panic) names the file.
    let mut bad = COPC.to_vec();
    for b in &mut bad[2000..60_000] {
        *b = b.wrapping_mul(31).wrapping_add(7);
    }
    std::fs::write(&path, &bad).unwrap();
    let mut r = crate::cloud::las::open(&path).unwrap();
    r.hint_discs(&[[350_100.0, 4_150_100.0]], 100.0);
    let mut buf = Vec::new();
    let mut res = Ok(true);
    while let Ok(true) = res {
        res = r.next_chunk(&mut buf);
    }
    let e = res.unwrap_err().to_string();
    assert!(e.contains("m.copc.laz") && e.contains("COPC node"), "{e}");
    // The plain LAZ path checks every chunk's head when opening.
    let e = open_with(&path, false, true).err().unwrap().to_string();
    assert!(
        e.contains("layers of") && e.contains("declared in a chunk"),
        "{e}"
    );
}
