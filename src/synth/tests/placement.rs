//! Where things are placed: the survey's false origin, distortions that
//! reach far from the origin, and the square layout.

use super::*;

/// survey.csv as (id, x, y, z, antenna height).
fn read_csv(path: &std::path::Path) -> Vec<(String, [f64; 4])> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let v = |i: usize| f[i].parse::<f64>().unwrap();
            (f[0].to_string(), [v(1), v(2), v(3), v(4)])
        })
        .collect()
}

#[test]
fn false_origin_moves_the_survey_not_the_map_without_losing_precision() {
    let dir = tempfile::tempdir().unwrap();
    let f = [1e6, 1e6, 1e6];
    let mut p = small(6, 30_000);
    p.survey_noise_m = 0.01;
    p.clutter.decoys = 5;
    let q = SynthParams {
        survey_false_origin_m: f,
        ..p.clone()
    };
    let fmt = crate::cloud::OutFormat::Pcd;
    let (fa, ta, ea) = write_scene(&dir.path().join("a"), &p, fmt).unwrap();
    let (fb, tb, eb) = write_scene(&dir.path().join("b"), &q, fmt).unwrap();
    // The map and the WGS84 survey are the same bytes.
    assert_eq!(
        std::fs::read(&fa.map).unwrap(),
        std::fs::read(&fb.map).unwrap()
    );
    assert_eq!(
        std::fs::read(&fa.survey_llh).unwrap(),
        std::fs::read(&fb.survey_llh).unwrap()
    );
    // survey.csv minus the false origin is the one without it.
    let (sa, sb) = (read_csv(&fa.survey), read_csv(&fb.survey));
    assert_eq!(sa.len(), 5);
    for ((ia, a), (ib, b)) in sa.iter().zip(&sb) {
        assert_eq!(ia, ib);
        for k in 0..3 {
            assert!(
                (b[k] - f[k] - a[k]).abs() < 1e-6,
                "{ia}: {} vs {}",
                b[k],
                a[k]
            );
        }
        assert_eq!(a[3], b[3]);
    }
    // Truth: world positions carry it, map positions do not, and the
    // distortion takes world positions to map positions either way.
    for (a, b) in ta.targets.iter().zip(&tb.targets) {
        assert_eq!(a.map, b.map);
        for k in 0..3 {
            assert!((b.world[k] - f[k] - a.world[k]).abs() < 1e-9);
        }
        assert!((b.survey.x - f[0] - a.survey.x).abs() < 1e-9);
        assert!((b.survey.y - f[1] - a.survey.y).abs() < 1e-9);
        assert!((b.survey.z - f[2] - a.survey.z).abs() < 1e-9);
        assert!((b.antenna_top_z - f[2] - a.antenna_top_z).abs() < 1e-9);
        assert!((b.ground_z - f[2] - a.ground_z).abs() < 1e-9);
        let m = tb.distortion.apply(&Point::from(b.world));
        assert!((m - Point::from(b.map)).norm() < 1e-9);
    }
    for (a, b) in ta.decoys.iter().zip(&tb.decoys) {
        assert_eq!(a.map, b.map);
        assert!((b.world[0] - f[0] - a.world[0]).abs() < 1e-9);
        let m = tb.distortion.apply(&Point::from(b.world));
        assert!((m - Point::from(b.map)).norm() < 1e-9);
    }
    for (a, b) in ta.path.iter().zip(&tb.path) {
        assert!((b.x - f[0] - a.x).abs() < 1e-9 && (b.z - f[2] - a.z).abs() < 1e-9);
    }
    // The errors a perfect locator would report do not depend on it.
    assert!((ea.absolute.mean - eb.absolute.mean).abs() < 1e-6);
    assert!((ea.relative.mean - eb.relative.mean).abs() < 1e-6);
    // The file says which origin it used; without one it says nothing.
    let ja = std::fs::read_to_string(&fa.truth).unwrap();
    let jb = std::fs::read_to_string(&fb.truth).unwrap();
    assert!(!ja.contains("survey_false_origin_m") && !ja.contains("survey_origin"));
    assert!(jb.contains("survey_false_origin_m") && jb.contains("survey_origin"));
}

#[test]
fn wide_distortions_are_accepted_and_maps_keep_precision_10_km_away() {
    let ok = DistortParams {
        offset_m: [1e7, -1e7, 100.0],
        yaw_deg: -360.0,
        tilt_deg: 15.0,
        ..Default::default()
    };
    assert!(ok.validate().is_ok());
    for bad in [
        DistortParams {
            tilt_deg: 15.01,
            ..Default::default()
        },
        DistortParams {
            yaw_deg: 360.5,
            ..Default::default()
        },
        DistortParams {
            offset_m: [0.0, 1.0001e7, 0.0],
            ..Default::default()
        },
    ] {
        assert!(bad.validate().is_err(), "{bad:?}");
    }
    let mut p = small(7, 40_000);
    p.distortion.offset_m = [10_000.0, -10_000.0, 35.0];
    p.distortion.yaw_deg = 237.0;
    p.distortion.tilt_deg = 12.0;
    p.distortion.tilt_axis_deg = 70.0;
    let (pts, truth, _) = collect(&p);
    // The map sits 10 km away, tilted: the truth says where.
    let t = &truth.targets[0];
    assert!((t.map[0] - t.world[0]).abs() > 9_000.0);
    let dir = tempfile::tempdir().unwrap();
    use crate::cloud::{OutFormat, read_all, write};
    for (fmt, tol) in [
        (OutFormat::Pcd, 0.0),
        (OutFormat::Ply, 0.0),
        (OutFormat::PcdAscii, 5.1e-7),
        // Millimetre integers from an offset taken from the data.
        (OutFormat::Las, 5.0e-4 + 1e-9),
    ] {
        let path = dir.path().join(format!("m.{}", fmt.extension()));
        write(&path, fmt, &pts).unwrap();
        let back = read_all(&path).unwrap();
        assert_eq!(back.len(), pts.len());
        let worst = pts
            .iter()
            .zip(&back)
            .map(|(a, b)| (a - b).abs().max())
            .fold(0.0, f64::max);
        assert!(worst <= tol, "{fmt:?}: {worst} m");
        std::fs::remove_file(&path).unwrap();
    }
}

#[test]
fn square_layout_is_symmetric_under_a_quarter_turn() {
    for side in [20.0, 30.0, 60.0] {
        let mut p = small(8, 1);
        p.layout = Layout::Square;
        p.targets = 4;
        p.spread_m = side;
        p.slope_deg = 0.0;
        p.undulation_m = 0.0;
        let (_, t, _) = collect(&p);
        assert_eq!(t.targets.len(), 4);
        let c = t.targets.iter().fold([0.0, 0.0], |a, t| {
            [a[0] + t.world[0] / 4.0, a[1] + t.world[1] / 4.0]
        });
        assert!((c[0] - side / 2.0).abs() < 1e-9);
        for (k, a) in t.targets.iter().enumerate() {
            let b = &t.targets[(k + 1) % 4];
            let (dx, dy) = (a.world[0] - c[0], a.world[1] - c[1]);
            // Rotated by +90° about the centre, corner k lands on corner k + 1 ...
            assert!((c[0] - dy - b.world[0]).abs() < 1e-9, "side {side}");
            assert!((c[1] + dx - b.world[1]).abs() < 1e-9, "side {side}");
            // ... with its L turned the same way, the same height, and a
            // square's side apart from it.
            let dh = (b.heading_deg - a.heading_deg).rem_euclid(360.0);
            assert!((dh - 90.0).abs() < 1e-9, "{dh}");
            assert_eq!(a.world[2], b.world[2]);
            assert!(((a.world[0] - b.world[0]).hypot(a.world[1] - b.world[1]) - side).abs() < 1e-9);
            // The L opens towards the centre.
            let inward = (-dy).atan2(-dx).to_degrees();
            let d = (a.heading_deg + 45.0 - inward).rem_euclid(360.0);
            assert!(d.min(360.0 - d) < 1e-9, "target {}: {d}", a.id);
            assert!(a.road_distance_m >= 4.0);
        }
    }
    // Wrong uses are refused, naming the knob.
    let sq = SynthParams {
        layout: Layout::Square,
        targets: 4,
        spread_m: 30.0,
        ..Default::default()
    };
    for (bad, word) in [
        (
            SynthParams {
                targets: 5,
                ..sq.clone()
            },
            "targets = 4",
        ),
        (
            SynthParams {
                spread_m: 61.0,
                ..sq.clone()
            },
            "spread_m",
        ),
        (
            SynthParams {
                spread_m: 10.0,
                road_curve_m: 20.0,
                ..sq.clone()
            },
            "from the road",
        ),
    ] {
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains(word), "{e}");
    }
    let toml_text = "layout = \"square\"\ntargets = 4\nspread_m = 30.0\n";
    let q: SynthParams = toml::from_str(toml_text).unwrap();
    assert_eq!(q.layout, Layout::Square);
    assert!(toml::from_str::<SynthParams>("layout = \"circle\"").is_err());
    // Off by default and then not printed.
    assert!(
        !toml::to_string(&SynthParams::default())
            .unwrap()
            .contains("layout")
    );
    assert!(
        toml::to_string(&sq)
            .unwrap()
            .contains("layout = \"square\"")
    );
}

#[test]
fn square_layout_targets_are_all_seen_from_the_road() {
    // Corners are side/2 (± the road's curve) off the road: at 1 M points a
    // 30 m square gives 160–260 returns per target, a 60 m one 55–75.
    for (side, least) in [(30.0, 120), (60.0, 40)] {
        let mut p = small(9, 1_000_000);
        p.layout = Layout::Square;
        p.targets = 4;
        p.spread_m = side;
        let (_, t, _) = collect(&p);
        for tg in &t.targets {
            assert!(
                tg.points >= least,
                "side {side}: target {} ({:.1} m off the road): {} returns",
                tg.id,
                tg.road_distance_m,
                tg.points
            );
        }
    }
}
