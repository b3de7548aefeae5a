//! Scene-level tests: determinism, point budget, truth, coverage of the targets.

use super::*;

fn small(seed: u64, points: u64) -> SynthParams {
    SynthParams {
        seed,
        points,
        ..Default::default()
    }
}

fn collect(p: &SynthParams) -> (Vec<Point>, Truth, usize) {
    let mut all = Vec::new();
    let mut calls = 0;
    let truth = generate(p, &mut |b: &[Point]| {
        all.extend_from_slice(b);
        calls += 1;
        Ok(())
    })
    .expect("generate");
    (all, truth, calls)
}

#[test]
fn same_seed_same_points_any_thread_count() {
    let p = small(7, 120_000);
    let (a, ta, _) = collect(&p);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let (b, tb, _) = pool.install(|| collect(&p));
    assert_eq!(a.len(), b.len());
    assert!(
        a.iter()
            .zip(&b)
            .all(|(x, y)| x.coords.map(f64::to_bits) == y.coords.map(f64::to_bits))
    );
    assert_eq!(ta, tb);
    let (c, _, _) = collect(&small(8, 120_000));
    assert!(a != c, "another seed must give another map");
}

/// Labels come with the very points `generate` gives; each target's plate
/// and other labels add up to its returns in the truth, and its plates'
/// points lie in the plates' height band, near its corner.
#[test]
fn labels_name_each_points_target_plate() {
    let p = small(4, 200_000);
    let (plain, truth, _) = collect(&p);
    let mut pts = Vec::new();
    let mut labels = Vec::new();
    let t2 = generate_labelled(&p, &mut |b, l| {
        assert_eq!(b.len(), l.len());
        pts.extend_from_slice(b);
        labels.extend_from_slice(l);
        Ok(())
    })
    .unwrap();
    assert_eq!(truth, t2);
    assert_eq!(pts, plain);
    for (k, t) in truth.targets.iter().enumerate() {
        let k = k as u32;
        let mut plates = [0u64; 2];
        let mut other = 0u64;
        for (q, l) in pts.iter().zip(&labels) {
            match *l {
                PointLabel::Plate { target, plate } if target == k => {
                    plates[plate as usize] += 1;
                    let m = Point::from(t.map);
                    assert!((q.x - m.x).hypot(q.y - m.y) < 0.7, "target {k}: {q:?}");
                    assert!((q.z - m.z).abs() < 0.35, "target {k}: {q:?}");
                }
                PointLabel::TargetOther { target } if target == k => other += 1,
                _ => {}
            }
        }
        assert_eq!(plates[0] + plates[1] + other, t.points, "target {k}");
        assert!(
            t.points == 0 || plates.iter().all(|&n| n > 0),
            "target {k}: {plates:?}"
        );
    }
    assert!(labels.contains(&PointLabel::Ground) && labels.contains(&PointLabel::Other));
}

#[test]
fn point_count_is_about_requested_and_streamed_per_scan() {
    let p = small(3, 300_000);
    let (pts, truth, calls) = collect(&p);
    assert_eq!(pts.len() as u64, truth.points);
    assert_eq!(calls as u64, truth.scans);
    assert_eq!(truth.path.len() as u64, truth.scans);
    let r = pts.len() as f64 / p.points as f64;
    assert!(
        (0.75..1.35).contains(&r),
        "{} points for {} requested",
        pts.len(),
        p.points
    );
    assert!(pts.iter().all(|q| q.coords.iter().all(|v| v.is_finite())));
}

#[test]
fn truth_is_the_distortion_of_the_world_corner() {
    let mut p = small(5, 50_000);
    p.distortion.tilt_deg = 0.5;
    p.survey_noise_m = 0.01;
    let (_, truth, _) = collect(&p);
    assert_eq!(truth.targets.len(), 5);
    for (i, t) in truth.targets.iter().enumerate() {
        assert_eq!(t.id, (i + 1).to_string());
        let m = truth.distortion.apply(&Point::from(t.world));
        assert!((m - Point::from(t.map)).norm() < 1e-12);
        // Reference height is the plates' centre; the antenna is above it.
        assert!((t.world[2] - (t.plate_bottom_z + t.plate_top_z) / 2.0).abs() < 1e-12);
        assert!(((t.antenna_top_z - t.world[2]) - t.survey.antenna_height).abs() < 1e-12);
        // Survey noise is small but present.
        let e = (t.survey.x - t.world[0]).hypot(t.survey.y - t.world[1]);
        assert!(e < 0.06);
        // Map within a few metres of the survey frame.
        let d = (t.map[0] - t.world[0]).hypot(t.map[1] - t.world[1]);
        assert!(d > 0.5 && d < 5.0, "map offset {d}");
    }
    assert!(truth.targets.iter().any(|t| t.survey.x != t.world[0]));
}

#[test]
fn default_scene_targets_receive_hundreds_of_points() {
    let p = SynthParams::default();
    let mut near = vec![0u64; p.targets];
    let mut total = 0u64;
    let mut truth_map: Option<Vec<[f64; 3]>> = None;
    // Truth comes at the end; gather points near the targets with a first cheap pass
    // at the same seed: scene layout does not depend on the point budget.
    let (_, pre, _) = collect(&SynthParams {
        points: 1,
        ..p.clone()
    });
    let maps: Vec<[f64; 3]> = pre.targets.iter().map(|t| t.map).collect();
    let truth = generate(&p, &mut |b: &[Point]| {
        total += b.len() as u64;
        for q in b {
            for (n, m) in near.iter_mut().zip(&maps) {
                if (q.x - m[0]).hypot(q.y - m[1]) < 0.7 && (q.z - m[2]).abs() < 0.3 {
                    *n += 1;
                }
            }
        }
        Ok(())
    })
    .unwrap();
    truth_map.replace(truth.targets.iter().map(|t| t.map).collect());
    assert_eq!(truth_map.unwrap(), maps);
    let r = total as f64 / p.points as f64;
    assert!((0.75..1.35).contains(&r), "{total} points");
    for (t, n) in truth.targets.iter().zip(&near) {
        assert!(t.points >= 200, "target {} has {} returns", t.id, t.points);
        assert!(
            *n >= 150,
            "target {}: {n} points at plate height near the corner",
            t.id
        );
    }
}

#[test]
fn hard_cases_add_clutter_next_to_targets() {
    let mut p = small(9, 1);
    p.clutter.near_target_m = Some(1.5);
    p.clutter.bush_touching = true;
    let (_, truth, _) = collect(&p);
    let t1 = &truth.targets[0];
    let near: Vec<_> = truth
        .clutter
        .iter()
        .filter(|c| c.role.starts_with("near"))
        .collect();
    assert_eq!(near.len(), 2);
    for c in near {
        let d = (c.x - t1.world[0]).hypot(c.y - t1.world[1]);
        assert!((1.5..2.0).contains(&d), "{} at {d}", c.kind);
    }
    assert!(truth.clutter.iter().any(|c| c.role == "touching target 2"));
    // Random clutter keeps its distance from every target.
    for c in truth
        .clutter
        .iter()
        .filter(|c| c.role == "random" && c.kind != "car")
    {
        for t in &truth.targets {
            assert!((c.x - t.world[0]).hypot(c.y - t.world[1]) > 4.0);
        }
    }
}

#[test]
fn bad_parameters_are_rejected() {
    for p in [
        SynthParams {
            targets: 0,
            ..Default::default()
        },
        SynthParams {
            points: 0,
            ..Default::default()
        },
        SynthParams {
            target_distance_m: [10.0, 5.0],
            ..Default::default()
        },
        SynthParams {
            lidar: LidarParams {
                az_step_deg: 0.0,
                ..Default::default()
            },
            ..Default::default()
        },
    ] {
        assert!(matches!(
            generate(&p, &mut |_| Ok(())),
            Err(Error::Param(_))
        ));
    }
}

#[test]
fn params_round_trip_through_toml() {
    let p = SynthParams {
        clutter: ClutterParams {
            near_target_m: Some(1.5),
            ..Default::default()
        },
        ..Default::default()
    };
    let s = toml::to_string(&p).unwrap();
    let q: SynthParams = toml::from_str(&s).unwrap();
    assert_eq!(p, q);
    assert!(toml::from_str::<SynthParams>("sead = 3").is_err());
}

#[test]
fn noise_free_target_returns_lie_on_plates_or_post() {
    let mut p = small(11, 100_000);
    p.lidar.range_noise_m = 0.0;
    p.distortion = DistortParams {
        offset_m: [0.0; 3],
        yaw_deg: 0.0,
        tilt_deg: 0.0,
        tilt_axis_deg: 0.0,
        drift_m: [0.0; 3],
        drift_wave_m: 0.0,
    };
    let (pts, truth, _) = collect(&p);
    let mut on_plate = [0usize; 2];
    for t in &truth.targets {
        let a = t.heading_deg.to_radians();
        let (u1, u2) = ((a.cos(), a.sin()), (-a.sin(), a.cos()));
        for q in &pts {
            let (dx, dy) = (q.x - t.world[0], q.y - t.world[1]);
            if dx.hypot(dy) > 0.9 || q.z < t.plate_bottom_z + 0.01 || q.z > t.plate_top_z - 0.01 {
                continue;
            }
            let s1 = dx * u1.0 + dy * u1.1;
            let s2 = dx * u2.0 + dy * u2.1;
            let post = s1.abs() <= 0.0151 && s2.abs() <= 0.0151;
            let a_ = s2.abs() < 1e-6 && (-1e-6..=0.6 + 1e-6).contains(&s1);
            let b_ = s1.abs() < 1e-6 && (-1e-6..=0.6 + 1e-6).contains(&s2);
            assert!(
                post || a_ || b_,
                "target {}: stray point s1={s1} s2={s2}",
                t.id
            );
            on_plate[0] += a_ as usize;
            on_plate[1] += b_ as usize;
        }
    }
    assert!(on_plate[0] > 20 && on_plate[1] > 20, "{on_plate:?}");
}

#[test]
fn hard_scene_still_scans_every_target() {
    let mut p = small(12, 600_000);
    p.targets = 12;
    p.slope_deg = 4.0;
    p.distortion.tilt_deg = 0.5;
    p.clutter.near_target_m = Some(1.5);
    p.clutter.bush_touching = true;
    let mut n = 0u64;
    let truth = generate(&p, &mut |b: &[Point]| {
        n += b.len() as u64;
        Ok(())
    })
    .unwrap();
    assert_eq!(truth.targets.len(), 12);
    for t in &truth.targets {
        assert!(t.points >= 30, "target {}: {} returns", t.id, t.points);
    }
    // Ground rises 4° along the slope direction: the road's end is metres higher.
    let dz = truth.path.last().unwrap().z - truth.path[0].z;
    assert!(dz.abs() > 3.0, "dz {dz}");
}

/// A scene's truth with the per-object return counts cleared: what must not
/// move when something is added elsewhere.
fn layout_of(t: &Truth) -> (Vec<TargetTruth>, Vec<ClutterInfo>) {
    let targets = t
        .targets
        .iter()
        .map(|t| TargetTruth {
            points: 0,
            ..t.clone()
        })
        .collect();
    (targets, t.clutter.clone())
}

/// Points every centimetre along a decoy's footprint outline (the L's outer
/// faces, the box's sides), from its truth alone.
fn footprint(d: &DecoyTruth) -> Vec<(f64, f64)> {
    let a = d.heading_deg.to_radians();
    let (u, v) = ((a.cos(), a.sin()), (-a.sin(), a.cos()));
    let (x, y) = (d.world[0], d.world[1]);
    let at = |s: f64, t: f64| (x + s * u.0 + t * v.0, y + s * u.1 + t * v.1);
    let [l, w, _] = d.size_m;
    let corners = if matches!(d.kind.as_str(), "building_corner" | "l_board" | "small_l") {
        vec![at(l, 0.0), at(0.0, 0.0), at(0.0, w)]
    } else {
        let (h, k) = (l / 2.0, w / 2.0);
        vec![at(h, k), at(-h, k), at(-h, -k), at(h, -k), at(h, k)]
    };
    let mut out = Vec::new();
    for s in corners.windows(2) {
        let n = ((s[1].0 - s[0].0).hypot(s[1].1 - s[0].1) / 0.01).ceil() as usize;
        for i in 0..=n {
            let f = i as f64 / n as f64;
            out.push((
                s[0].0 + f * (s[1].0 - s[0].0),
                s[0].1 + f * (s[1].1 - s[0].1),
            ));
        }
    }
    out
}

fn with_decoys(seed: u64, points: u64, n: usize) -> SynthParams {
    let mut p = small(seed, points);
    p.clutter.decoys = n;
    p
}

#[test]
fn decoys_are_deterministic_and_move_nothing_else() {
    for seed in [1, 2, 3] {
        let (_, plain, _) = collect(&small(seed, 1));
        let (_, t, _) = collect(&with_decoys(seed, 1, 10));
        assert!(plain.decoys.is_empty());
        assert_eq!(layout_of(&plain), layout_of(&t), "seed {seed}");
        assert_eq!(t.decoys.len(), 10, "seed {seed}: all placed");
        let kinds = ["building_corner", "l_board", "cabinet", "small_l", "pallet"];
        for (i, d) in t.decoys.iter().enumerate() {
            assert_eq!(d.kind, kinds[i % 5]);
            let [a, b, h] = d.size_m;
            let in_range = match i % 5 {
                0 => (3.0..8.0).contains(&a) && (3.0..8.0).contains(&b) && (3.0..6.0).contains(&h),
                1 => (0.9..1.2).contains(&a) && (0.9..1.2).contains(&b) && h == 0.6,
                2 => d.size_m == [0.6, 0.4, 1.2],
                3 => (0.35..0.45).contains(&a) && (0.35..0.45).contains(&b) && h == 0.6,
                _ => d.size_m == [1.2, 0.8, 1.0],
            };
            assert!(in_range, "{} {:?}", d.kind, d.size_m);
            assert_eq!(d.grill.is_some(), matches!(i % 5, 1 | 3));
            if matches!(i % 5, 1 | 3) {
                assert!((d.bottom_z - d.ground_z - 0.8).abs() < 1e-12);
                assert!((d.world[2] - (d.bottom_z + d.top_z) / 2.0).abs() < 1e-12);
            }
            // Off the road at the targets' distances; every part of it (the
            // reference point here; the outline is checked when placing) clear
            // of every target.
            assert!(
                (4.5..15.5).contains(&d.road_distance_m),
                "{} {}",
                d.kind,
                d.road_distance_m
            );
            for q in footprint(d) {
                for tg in &t.targets {
                    let r = (q.0 - tg.world[0]).hypot(q.1 - tg.world[1]);
                    assert!(r >= 4.0, "{} {r} m from target {}", d.kind, tg.id);
                }
                assert!((q.1 - t.road.y(q.0)).abs() >= 3.0, "{} on the road", d.kind);
            }
            let m = t.distortion.apply(&Point::from(d.world));
            assert!((m - Point::from(d.map)).norm() < 1e-9);
        }
    }
    // The most allowed is placed in reasonable time (as many as fit), more
    // is refused.
    let start = std::time::Instant::now();
    let (_, many, _) = collect(&with_decoys(1, 1, 200));
    assert!(many.decoys.len() >= 30, "{}", many.decoys.len());
    assert!(start.elapsed().as_secs_f64() < 20.0);
    assert!(with_decoys(1, 1, 201).validate().is_err());
    // Same seed, same bytes (points and truth), whatever the thread count.
    let p = with_decoys(4, 120_000, 10);
    let (a, ta, _) = collect(&p);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let (b, tb, _) = pool.install(|| collect(&p));
    assert_eq!(a.len(), b.len());
    assert!(
        a.iter()
            .zip(&b)
            .all(|(x, y)| x.coords.map(f64::to_bits) == y.coords.map(f64::to_bits))
    );
    assert_eq!(ta, tb);
    assert_eq!(
        serde_json::to_string(&ta).unwrap(),
        serde_json::to_string(&tb).unwrap()
    );
}

#[test]
fn decoys_are_scanned_and_hide_no_target() {
    let p = with_decoys(5, 600_000, 15);
    let (pts, t, _) = collect(&p);
    let (_, plain, _) = collect(&small(5, 600_000));
    assert_eq!(t.decoys.len(), 15);
    for d in &t.decoys {
        assert!(d.points >= 20, "{} has {} returns", d.kind, d.points);
    }
    // Targets keep most of their returns (the scan spacing differs slightly
    // because the decoys add returns per scan).
    for (a, b) in t.targets.iter().zip(&plain.targets) {
        assert!(
            a.points as f64 >= 0.7 * b.points as f64,
            "target {}: {} returns with decoys, {} without",
            a.id,
            a.points,
            b.points
        );
    }
    // A building corner's walls really stand there: map points on them.
    let bc = &t.decoys[0];
    let near = pts
        .iter()
        .filter(|q| (q.x - bc.map[0]).hypot(q.y - bc.map[1]) < 8.5 && q.z > bc.map[2])
        .count();
    assert!(near > 100, "{near} points by the building corner");
    // Off: the truth file has no `decoys` key, on: it has.
    let s = serde_json::to_string(&plain).unwrap();
    assert!(!s.contains("\"decoys\""));
    assert!(serde_json::to_string(&t).unwrap().contains("\"decoys\""));
}

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

/// A forward-looking rosette sensor driven along +x never sees behind where
/// it started; a spinning one sees the ground there. Its returns crowd at the
/// centre of its field of view (the rose curve passes through it every turn).
#[test]
fn a_rosette_sensor_looks_forward_only() {
    let mut p = small(3, 150_000);
    let spinning = collect(&p);
    p.lidar.pattern = lidar::ScanPattern::Rosette;
    p.lidar.fov_deg = 70.0;
    let rosette = collect(&p);
    let x0 = spinning.1.path[0].x;
    let behind = |pts: &[Point]| pts.iter().filter(|q| q.x < x0 - 5.0).count();
    assert!(behind(&spinning.0) > 1000, "{}", behind(&spinning.0));
    assert_eq!(behind(&rosette.0), 0);
    assert!(rosette.0.len() > 100_000, "{}", rosette.0.len());
    // Beyond 120° of field the sensor is refused.
    p.lidar.fov_deg = 150.0;
    assert!(matches!(
        generate(&p, &mut |_| Ok(())),
        Err(Error::Param(_))
    ));
}
