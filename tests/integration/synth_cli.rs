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
