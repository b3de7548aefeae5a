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
