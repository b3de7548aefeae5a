use super::*;
use nalgebra::{Rotation3, Unit};

/// A 60 × 60 m yard, a 12° ramp over a fifth of it and a wall, tilted.
fn site(tilt_deg: f64) -> Vec<Point> {
    let r = Rotation3::from_axis_angle(
        &Unit::new_normalize(Vector3::new(0.3, 1.0, 0.0)),
        tilt_deg.to_radians(),
    );
    let mut pts = Vec::new();
    let mut s = 7u64;
    let mut rnd = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 33) as f64) / (1u64 << 31) as f64 - 0.5
    };
    for i in 0..300 {
        for j in 0..300 {
            let (x, y) = (i as f64 * 0.2 + 0.1 * rnd(), j as f64 * 0.2 + 0.1 * rnd());
            let ramp = if x > 48.0 {
                (x - 48.0) * 12f64.to_radians().tan()
            } else {
                0.0
            };
            pts.push(Point::new(x, y, ramp + 0.005 * rnd()));
        }
    }
    for i in 0..400 {
        for h in 0..30 {
            pts.push(Point::new(10.0, i as f64 * 0.1, h as f64 * 0.1));
        }
    }
    pts.iter()
        .map(|p| Point::from(r * p.coords + Vector3::new(5e5, 4e6, 30.0)))
        .collect()
}

/// A sample of a quarter of the points, as every 4th tile of a tiled map
/// and as every 4th block of a single file's records, finds the tilt
/// the whole map gives, and says it read only a sample.
#[test]
fn a_sample_of_tiles_or_record_blocks_finds_the_whole_maps_tilt() {
    let dir = tempfile::tempdir().unwrap();
    let pts = site(6.6);
    let whole = ground_level(MapSource::Points(&pts), None, None, |_| {}).unwrap();
    let whole_tilt = whole.level.as_ref().unwrap().tilt_deg;
    let tiles = dir.path().join("tiles");
    let map = crate::cloud::write_tiles(&pts, &tiles, 10.0, crate::cloud::OutFormat::Pcd).unwrap();
    let file = dir.path().join("map.pcd");
    crate::cloud::write(&file, crate::cloud::OutFormat::Pcd, &pts).unwrap();
    for path in [&tiles, &file] {
        let g = ground_level(
            MapSource::File(path),
            None,
            Some(pts.len() as u64 / 4),
            |_| {},
        )
        .unwrap();
        assert!(g.sampled, "{}", path.display());
        assert!(g.z_range.is_none(), "a sample's z range is not the map's");
        let read = g.pass_read.points as f64 / pts.len() as f64;
        assert!(
            (0.2..0.45).contains(&read),
            "{}: read {read} {:?}",
            path.display(),
            g.pass_read
        );
        assert!(
            g.pass_read.bytes * 2 < crate::cloud::map_bytes(path),
            "{}: {:?}",
            path.display(),
            g.pass_read
        );
        let tilt = g.level.as_ref().unwrap().tilt_deg;
        assert!(
            (tilt - whole_tilt).abs() < 0.1,
            "{}: {tilt} against {whole_tilt}",
            path.display()
        );
        // Completed, the ground is the whole map's, with the sample's vertical.
        let all = g.completed(MapSource::File(path), |_| {}).unwrap();
        assert!(!all.sampled);
        assert_eq!(all.points, pts.len() as u64);
        assert_eq!(all.level, g.level);
        assert_eq!(all.z_range, whole.z_range);
    }
    assert!(map.tiles.len() >= 32, "{} tiles", map.tiles.len());
}

/// Issue 31: a float32 map in UTM coordinates (northings of 5.4e6 m)
/// keeps half-metre steps: the ground pass says so; the same map about
/// a local origin, or in double precision, says nothing.
#[test]
fn float32_coordinates_far_from_the_origin_report_their_step() {
    let dir = tempfile::tempdir().unwrap();
    let pts = site(0.0);
    let write_f32 = |path: &std::path::Path, shift: [f64; 3]| {
        let mut b = format!(
            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n",
            n = pts.len()
        )
        .into_bytes();
        for p in &pts {
            // site() sits at (5e5, 4e6): moved to `shift`.
            for v in [p.x - 5e5 + shift[0], p.y - 4e6 + shift[1], p.z + shift[2]] {
                b.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
        std::fs::write(path, b).unwrap();
    };
    let utm = dir.path().join("utm.pcd");
    write_f32(&utm, [4.5e5, 5.4e6, 0.0]);
    let g = ground_level(MapSource::File(&utm), None, None, |_| {}).unwrap();
    let (step, reach) = g.float32_step.expect("a float32 step reported");
    assert_eq!(step, 0.5, "{reach}");
    let local = dir.path().join("local.pcd");
    write_f32(&local, [0.0, 0.0, 0.0]);
    let g = ground_level(MapSource::File(&local), None, None, |_| {}).unwrap();
    assert_eq!(g.float32_step, None);
    let double = dir.path().join("double.pcd");
    crate::cloud::write(&double, crate::cloud::OutFormat::Pcd, &pts).unwrap();
    let g = ground_level(MapSource::File(&double), None, None, |_| {}).unwrap();
    assert_eq!(g.float32_step, None);
    assert_eq!(crate::cloud::float32_step(5.4e6), 0.5);
    assert_eq!(crate::cloud::float32_step(30_000.0), 2f64.powi(-9));
}

/// Issue 31: a map in millimetres read as metres spreads a point to
/// each 32 m square; the pass says so instead of growing a tile for each.
#[test]
fn a_map_in_millimetres_is_refused_before_its_grid_grows() {
    let pts: Vec<Point> = site(0.0)
        .iter()
        .map(|p| Point::from(p.coords * 1000.0))
        .collect();
    let e = ground_level(MapSource::Points(&pts), None, None, |_| {}).unwrap_err();
    assert!(e.to_string().contains("millimetres"), "{e}");
    // The same points in metres are a map.
    let pts = site(0.0);
    assert!(ground_level(MapSource::Points(&pts), None, None, |_| {}).is_ok());
}

/// Rolling hills on a 6° incline: their flat blocks lean every way, so
/// few agree on one vertical and the ground does not level the map; a
/// tilted yard's ground leans alike everywhere and does.
#[test]
fn a_lean_few_ground_blocks_agree_on_does_not_level_the_map() {
    let mut pts = Vec::new();
    for i in 0..400 {
        for j in 0..400 {
            let (x, y) = (i as f64 * 0.2, j as f64 * 0.2);
            let z = 1.2 * (x / 5.0).sin() * (y / 6.0).cos() + 6f64.to_radians().tan() * x;
            pts.push(Point::new(x, y, z));
        }
    }
    let hills = ground_level(MapSource::Points(&pts), None, None, |_| {}).unwrap();
    let l = hills.level.as_ref().unwrap();
    assert!(l.support < 0.5, "{} of {} blocks", l.support, l.blocks);
    assert!(hills.levelling(0.0, 0.5).is_identity());
    assert!(hills.leans_weakly(0.0, 0.5).is_some());
    // Asked for no agreement at all, it levels.
    assert!(!hills.levelling(0.0, 0.0).is_identity());
    let yard = ground_level(MapSource::Points(&site(6.6)), None, None, |_| {}).unwrap();
    let y = yard.level.as_ref().unwrap();
    assert!(y.support > 0.6, "{} of {} blocks", y.support, y.blocks);
    assert!(!yard.levelling(5.0, 0.5).is_identity());
    assert!(yard.leans_weakly(5.0, 0.5).is_none());
}

#[test]
fn finds_the_tilt_of_a_tilted_yard_with_a_ramp_and_a_wall() {
    for tilt in [0.0, 6.6, 14.0] {
        let pts = site(tilt);
        let g = ground_level(MapSource::Points(&pts), None, None, |_| {})
            .unwrap()
            .level
            .unwrap();
        assert!(
            (g.tilt_deg - tilt).abs() < 0.1,
            "tilt {tilt}: found {}",
            g.tilt_deg
        );
        let m = g.motion();
        // Levelled, the yard is flat.
        let a = m.apply(&pts[0]);
        let b = m.apply(&pts[299 * 300 / 2]);
        assert!((a.z - b.z).abs() < 0.05, "{} {}", a.z, b.z);
    }
}

/// The measures that tell a map written with y up: the yard as mapped has
/// its ground flat over most blocks (a stray point 60 m below it, which
/// stretches its z extent, does not change that); the same yard with y up
/// is little flat, 3 m across y and spreads over 60 m in z.
#[test]
fn a_yard_written_with_y_up_shows_little_flat_ground_and_a_deep_extent() {
    let mut pts = site(0.0);
    let c = pts[0];
    pts.push(Point::new(c.x + 30.0, c.y + 30.0, c.z - 60.0));
    let yard = ground_level(MapSource::Points(&pts), None, None, |_| {}).unwrap();
    assert!(yard.flat_share() > 0.6, "{}", yard.flat_share());
    let span = yard.horizontal_span().unwrap();
    assert!(span[0] >= 60.0 && span[1] >= 60.0, "{span:?}");
    let yup: Vec<Point> = site(0.0)
        .iter()
        .map(|p| Point::new(p.x, p.z, -p.y))
        .collect();
    let turned = ground_level(MapSource::Points(&yup), None, None, |_| {}).unwrap();
    assert!(turned.flat_share() < 0.5, "{}", turned.flat_share());
    assert!(turned.z_extent().unwrap() > 59.0);
    let span = turned.horizontal_span().unwrap();
    assert!(span[1] < 5.0, "{span:?}");
}
