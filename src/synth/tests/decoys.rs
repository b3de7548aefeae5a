//! Decoys: deterministic, scanned, and moving nothing else in the scene.

use super::*;

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
    same_on_one_thread(&p);
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
