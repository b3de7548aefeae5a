//! `mapgauge synth` through the command line (map writing itself is tested in cloud).

use crate::util::{bin, tempdir};

#[test]
fn print_config_is_valid_toml_with_flags_applied() {
    let out = bin()
        .args([
            "synth",
            "--print-config",
            "--targets",
            "12",
            "--slope-deg",
            "4",
            "--near-clutter-m",
            "1.5",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let p: mapgauge::synth::SynthParams =
        toml::from_str(&String::from_utf8(out.stdout).unwrap()).unwrap();
    assert_eq!(p.targets, 12);
    assert_eq!(p.slope_deg, 4.0);
    assert_eq!(p.clutter.near_target_m, Some(1.5));
}

#[test]
fn bad_values_give_one_line_errors() {
    let dir = tempdir();
    let out = bin()
        .args(["synth", "--out"])
        .arg(dir.path())
        .args(["--targets", "0"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("targets"), "{err}");

    let cfg = dir.path().join("bad.toml");
    std::fs::write(&cfg, "seed = 1\nsloap_deg = 3\n").unwrap();
    let out = bin()
        .args(["synth", "--print-config", "--config"])
        .arg(&cfg)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("bad.toml") && err.contains("sloap_deg"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
}

#[test]
fn issue_15_knobs_from_flags_and_config() {
    let dir = tempdir();
    let cfg = dir.path().join("s.toml");
    std::fs::write(
        &cfg,
        "layout = \"square\"\ntargets = 4\nspread_m = 30.0\n[clutter]\ndecoys = 5\n",
    )
    .unwrap();
    let out = bin()
        .args(["synth", "--print-config", "--config"])
        .arg(&cfg)
        .args([
            "--yaw-deg",
            "-270",
            "--tilt-deg",
            "-14",
            "--offset-m",
            "-10000,5000,3",
            "--survey-false-origin-m",
            "352000,4026000,0",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let p: mapgauge::synth::SynthParams =
        toml::from_str(&String::from_utf8(out.stdout).unwrap()).unwrap();
    assert_eq!(p.layout, mapgauge::synth::Layout::Square);
    assert_eq!(p.clutter.decoys, 5);
    assert_eq!(p.distortion.yaw_deg, -270.0);
    assert_eq!(p.distortion.tilt_deg, -14.0);
    assert_eq!(p.distortion.offset_m, [-10000.0, 5000.0, 3.0]);
    assert_eq!(p.survey_false_origin_m, [352000.0, 4026000.0, 0.0]);

    let out = bin()
        .args(["synth", "--print-config", "--layout", "square"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("targets = 4"), "{err}");
}

/// `--labels` writes one code per map point, in the map's order: each
/// target's plate and part codes add up to its returns in truth.json, and its
/// plate points stand within a plate of its true corner; without the flag
/// the map is byte for byte the same and no labels file is written.
#[test]
fn labels_file_names_every_points_target_plate() {
    let dir = tempdir();
    let run = |sub: &str, labels: bool| {
        let mut c = bin();
        c.args(["synth", "--points", "150000", "--format", "pcd", "--out"])
            .arg(dir.path().join(sub));
        if labels {
            c.arg("--labels");
        }
        let out = c.output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    run("a", true);
    run("b", false);
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    assert_eq!(
        std::fs::read(a.join("map.pcd")).unwrap(),
        std::fs::read(b.join("map.pcd")).unwrap()
    );
    assert!(!b.join("labels.u16").exists());
    let map = mapgauge::cloud::read_all(&a.join("map.pcd")).unwrap();
    let raw = std::fs::read(a.join("labels.u16")).unwrap();
    let codes: Vec<u16> = raw
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    assert_eq!(codes.len(), map.len());
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("truth.json")).unwrap()).unwrap();
    let targets = truth["targets"].as_array().unwrap();
    for (k, t) in targets.iter().enumerate() {
        let base = 16 + 4 * k as u16;
        let m: Vec<f64> = t["map"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let mut n = [0u64; 3];
        for (p, &c) in map.iter().zip(&codes) {
            if (base..base + 3).contains(&c) {
                n[(c - base) as usize] += 1;
            }
            if c == base || c == base + 1 {
                assert!((p.x - m[0]).hypot(p.y - m[1]) < 0.7, "target {k}: {p:?}");
            }
        }
        assert_eq!(
            n.iter().sum::<u64>(),
            t["points"].as_u64().unwrap(),
            "target {k}"
        );
        assert!(n[0] > 0 && n[1] > 0, "target {k}: {n:?}");
    }
    assert!(codes.contains(&0) && codes.contains(&1));
    assert!(
        codes
            .iter()
            .all(|&c| c < 2 || (16..16 + 4 * targets.len() as u16).contains(&c))
    );
    // A scene written again without labels leaves none of the earlier run's.
    run("a", false);
    assert!(!a.join("labels.u16").exists());
}
