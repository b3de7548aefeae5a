use super::*;

/// Six located targets of the gates' fixture, the first four given the
/// errors below (the last two not located).
fn result(errors: [f64; 4]) -> ResultFile {
    let mut r = crate::gate::tests::result();
    for (t, e) in r.targets.iter_mut().zip(errors) {
        t.abs_error = Some(e);
        t.map_covariance = None;
    }
    for t in &mut r.targets[4..] {
        t.status = "not_found".into();
        t.abs_error = None;
    }
    r
}

#[test]
fn bands_by_hand() {
    // Strictly below each band's edge: 1 cm earns the next band down.
    let k = ScoreKind::Hilti2022;
    assert_eq!(
        [
            0.0, 0.0099, 0.01, 0.0299, 0.03, 0.0599, 0.06, 0.0999, 0.1, 3.0
        ]
        .map(|e| k.points(e)),
        [10.0, 10.0, 6.0, 6.0, 3.0, 3.0, 1.0, 1.0, 0.0, 0.0]
    );
    let k = ScoreKind::Hilti2023;
    assert_eq!(
        [0.0049, 0.005, 0.0099, 0.01, 0.03, 0.06, 0.1, 0.3999, 0.4].map(|e| k.points(e)),
        [20.0, 10.0, 10.0, 6.0, 5.0, 3.0, 1.0, 1.0, 0.0]
    );
    let k = ScoreKind::Hilti2026;
    assert_eq!(k.points(0.0), 100.0);
    assert!((k.points(0.01) - 63.09).abs() < 0.01, "{}", k.points(0.01));
    assert!((k.points(0.10) - 1.0).abs() < 0.01, "{}", k.points(0.10));
}

#[test]
fn totals_by_hand_count_targets_not_located_as_zero() {
    // Errors 4, 12 and 50 mm, a fourth at 20 cm, two not located: 6 targets.
    let r = result([0.004, 0.012, 0.05, 0.2]);
    let s = score(ScoreKind::Hilti2022, &r);
    // 10 + 6 + 3 + 0 + 0 + 0 of 60.
    assert_eq!((s.targets, s.located), (6, 4));
    assert!((s.total - 100.0 * 19.0 / 60.0).abs() < 1e-9, "{}", s.total);
    let s = score(ScoreKind::Hilti2023, &r);
    // 20 + 6 + 5 + 1 of 120.
    assert!((s.total - 100.0 * 32.0 / 120.0).abs() < 1e-9, "{}", s.total);
    let s = score(ScoreKind::Hilti2026, &r);
    // (83.177 + 57.545 + 10.001 + 0.010) / 6, worked out apart.
    let hand = (83.17694333035132 + 57.54516892748761 + 10.000850966145569 + 0.01000) / 6.0;
    assert!((s.total - hand).abs() < 1e-3, "{} vs {hand}", s.total);
    assert_eq!(s.per_target[4].error_m, None);
    assert_eq!(s.per_target[4].points, 0.0);
    // Without covariances the range is the score itself.
    assert_eq!(s.range95, [s.total, s.total]);
}

#[test]
fn the_range_spans_a_band_edge_within_the_noise() {
    let mut r = result([0.009, 0.02, 0.02, 0.02]);
    // σ 1 mm along x, 0.5 mm along y, 2 mm along z; each error along x (the
    // fixture's alignment turns by well under a milliradian).
    let c = [[1e-6, 0.0, 0.0], [0.0, 0.25e-6, 0.0], [0.0, 0.0, 4e-6]];
    for t in &mut r.targets[..4] {
        t.map_covariance = Some(c);
        let e = t.abs_error.unwrap();
        t.aligned = Some(crate::record::Xyz {
            x: t.survey.x + e,
            y: t.survey.y,
            z: Some(0.0),
        });
        t.survey.z = Some(0.0);
    }
    // 9 ± 1.96 mm crosses 1 cm; 20 ± 1.96 mm crosses nothing.
    let s = score(ScoreKind::Hilti2022, &r);
    assert_eq!(s.per_target[0].points, 10.0);
    assert_eq!(s.per_target[0].range95, [6.0, 10.0]);
    assert_eq!(s.per_target[1].range95, [6.0, 6.0]);
    assert!((s.range95[0] - 100.0 * 24.0 / 60.0).abs() < 1e-9);
    assert!((s.range95[1] - 100.0 * 28.0 / 60.0).abs() < 1e-9);
    // Along y the σ is 0.5 mm: 9 ± 0.98 mm stays below 1 cm.
    let t = &mut r.targets[0];
    t.aligned = Some(crate::record::Xyz {
        x: t.survey.x,
        y: t.survey.y + 0.009,
        z: Some(0.0),
    });
    assert_eq!(
        score(ScoreKind::Hilti2022, &r).per_target[0].range95,
        [10.0, 10.0]
    );
    // In 3D a horizontal error does not take the vertical σ (2 mm), which
    // the largest axis would: still 10 points only.
    r.dim = crate::accuracy::Dim::D3;
    assert_eq!(
        score(ScoreKind::Hilti2022, &r).per_target[0].range95,
        [10.0, 10.0]
    );
}

#[test]
fn apply_records_each_rule_and_json_keys_are_their_names() {
    let mut r = result([0.004, 0.012, 0.05, 0.2]);
    apply(&[ScoreKind::Hilti2026, ScoreKind::Hilti2022], &mut r);
    let j = serde_json::to_value(&r).unwrap();
    let keys: Vec<&String> = j["scores"].as_object().unwrap().keys().collect();
    assert_eq!(keys, ["hilti2022", "hilti2026"]);
    assert!(j["scores"]["hilti2022"]["per_target"].is_array());
    let back: ResultFile = serde_json::from_value(j).unwrap();
    assert_eq!(back.scores, r.scores);
    apply(&[], &mut r);
    assert!(serde_json::to_value(&r).unwrap().get("scores").is_none());
}

#[test]
fn names_parse_and_unknown_ones_are_refused() {
    assert_eq!(
        "HILTI2023".parse::<ScoreKind>().unwrap(),
        ScoreKind::Hilti2023
    );
    let e = "hilti2024".parse::<ScoreKind>().unwrap_err().to_string();
    assert!(e.contains("hilti2022, hilti2023 or hilti2026"), "{e}");
}
