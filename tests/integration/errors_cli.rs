//! `mapgauge errors` end to end, and the paper's golden numbers (sequence 5).

use crate::util::{bin, tempdir};
use mapgauge::Point;
use mapgauge::accuracy::{ScoreOptions as EvalOptions, score};
use mapgauge::align::AlignMethod;
use mapgauge::record::ResultFile as RunResult;
use mapgauge::survey::{Estimate, Survey};

/// Scores estimates and builds the result file, as `mapgauge errors` does.
fn evaluate(s: &Survey, e: &[Estimate], o: &EvalOptions) -> mapgauge::Result<RunResult> {
    Ok(RunResult::from_accuracy(&score(s, e, o)?, s))
}
use mapgauge::survey::{Geodetic, SurveyOptions, read_estimates, read_survey};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn paper() -> RunResult {
    let s = read_survey(&data("paper_seq5_survey.csv"), &SurveyOptions::default()).unwrap();
    let e = read_estimates(&data("paper_seq5_estimates.csv")).unwrap();
    evaluate(&s, &e, &EvalOptions::default()).unwrap()
}

fn close4(got: f64, want: f64, what: &str) {
    assert!(
        (got - want).abs() < 0.5e-4,
        "{what}: got {got:.6}, paper {want:.4}"
    );
}

#[test]
fn paper_sequence5_golden_numbers() {
    let r = paper();
    let abs = [0.0571, 0.0643, 0.0313, 0.0513, 0.0538];
    for (t, want) in r.targets.iter().zip(abs) {
        close4(t.abs_error.unwrap(), want, &format!("abs error t{}", t.id));
    }
    close4(r.absolute.mean, 0.0516, "E_abs");
    close4(r.absolute.std, 0.0110, "σ_abs");
    let rel = [
        0.0095, 0.0796, 0.0988, 0.0990, 0.0900, 0.1089, 0.1096, 0.0187, 0.0179, 0.0008,
    ];
    let order = [
        ("1", "2"),
        ("1", "3"),
        ("1", "4"),
        ("1", "5"),
        ("2", "3"),
        ("2", "4"),
        ("2", "5"),
        ("3", "4"),
        ("3", "5"),
        ("4", "5"),
    ];
    assert_eq!(r.relative.pairs.len(), 10);
    for ((p, want), (a, b)) in r.relative.pairs.iter().zip(rel).zip(order) {
        assert_eq!((p.a.as_str(), p.b.as_str()), (a, b));
        close4(p.error, want, &format!("rel error t{a} & t{b}"));
    }
    close4(r.relative.mean, 0.0633, "E_rel");
    close4(r.relative.std, 0.0431, "σ_rel");
    // Our alignment maps the map onto GNSS; the paper quotes GNSS onto the map:
    // the inverse must be a rotation of about −1.27° and a shift of about (−0.41, −0.18).
    assert_eq!(r.alignment.method, "rigid2d");
    assert!(
        (r.alignment.rotation_deg - 1.27).abs() < 0.005,
        "{}",
        r.alignment.rotation_deg
    );
    let th = r.alignment.rotation_deg.to_radians();
    let (s, c) = th.sin_cos();
    let [tx, ty, _] = r.alignment.translation;
    let inv = (-(c * tx + s * ty), -(-s * tx + c * ty));
    assert!(
        (inv.0 + 0.41).abs() < 0.005 && (inv.1 + 0.18).abs() < 0.005,
        "{inv:?}"
    );
    // Honest errors exist and are worse than the in-sample ones.
    let loo = r.leave_one_out.as_ref().unwrap();
    assert!(loo.summary.mean > r.absolute.mean);
    let sh = r.sigma_hat.unwrap();
    assert_eq!(sh.dof, 7);
}

#[test]
fn paper_relative_errors_survive_a_rigid_motion_of_the_map() {
    let s = read_survey(&data("paper_seq5_survey.csv"), &SurveyOptions::default()).unwrap();
    let mut e = read_estimates(&data("paper_seq5_estimates.csv")).unwrap();
    let rot = nalgebra::Rotation3::from_euler_angles(0.0, 0.0, 1.234);
    for est in &mut e {
        if let mapgauge::survey::EstimateStatus::Found(p) = &mut est.status {
            *p = rot * *p + nalgebra::Vector3::new(350_000.0, 4_150_000.0, 0.0);
        }
    }
    let moved = evaluate(&s, &e, &EvalOptions::default()).unwrap();
    let r = paper();
    for (a, b) in r.relative.pairs.iter().zip(&moved.relative.pairs) {
        assert!((a.error - b.error).abs() < 1e-9);
    }
    // And the alignment absorbs the motion: absolute errors unchanged too.
    for (a, b) in r.targets.iter().zip(&moved.targets) {
        assert!((a.abs_error.unwrap() - b.abs_error.unwrap()).abs() < 1e-8);
    }
}

#[test]
fn every_method_runs_on_the_paper_data() {
    let s = read_survey(&data("paper_seq5_survey.csv"), &SurveyOptions::default()).unwrap();
    let e = read_estimates(&data("paper_seq5_estimates.csv")).unwrap();
    for m in [
        AlignMethod::None,
        AlignMethod::Rigid2d,
        AlignMethod::Similarity2d,
        AlignMethod::Robust2d,
    ] {
        let r = evaluate(
            &s,
            &e,
            &EvalOptions {
                method: m,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(r.alignment.method, m.name());
        // Least squares minimises the RMSE; Eq. 1 minimises the mean.
        let ls = paper();
        if m == AlignMethod::Robust2d {
            assert!(r.absolute.mean <= ls.absolute.mean + 1e-12);
        }
        if m == AlignMethod::Rigid2d {
            assert_eq!(r, ls);
        }
    }
    // 3D methods need heights: a clear error.
    let err = evaluate(
        &s,
        &e,
        &EvalOptions {
            method: AlignMethod::Rigid3d,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(
        err.to_string().contains("at least 3") || err.to_string().contains("z"),
        "{err}"
    );
}

#[test]
fn cli_table_json_and_out_dir() {
    let dir = tempdir();
    let out = bin()
        .args(["errors", "--survey"])
        .arg(data("paper_seq5_survey.csv"))
        .arg("--estimates")
        .arg(data("paper_seq5_estimates.csv"))
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("E_rel") && text.contains("63.3") && text.contains("43.1"),
        "{text}"
    );
    assert!(
        text.contains("t1 & t2") && text.contains("51.6") && text.contains("11.0"),
        "{text}"
    );
    // Millimetres on the terminal, the NSSDA statement too.
    assert!(text.contains("Relative error (mm, 2D)"), "{text}");
    assert!(text.contains("NSSDA (legacy: ASPRS Ed. 2 no longer uses it): tested 91.3 mm horizontal accuracy at 95 % confidence level"));
    let r = RunResult::from_json_file(&dir.path().join("result.json")).unwrap();
    assert_eq!(r, paper_roundtrip());
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("result.json")).unwrap())
            .unwrap();
    assert_eq!(v["schema"], "mapgauge.result/1");
    for k in [
        "mapgauge_version",
        "alignment",
        "targets",
        "absolute",
        "relative",
    ] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    for k in ["method", "rotation_deg", "translation", "scale"] {
        assert!(v["alignment"].get(k).is_some(), "missing alignment.{k}");
    }
    let t0 = &v["targets"][0];
    assert_eq!(t0["id"], "1");
    assert_eq!(t0["status"], "ok");
    assert!(t0["reason"].is_null());
    for k in ["survey", "map", "aligned"] {
        assert!(t0[k]["x"].is_f64() && t0[k]["y"].is_f64(), "{k}");
    }
    for k in ["n", "mean", "std", "rmse", "median", "max"] {
        assert!(v["absolute"].get(k).is_some(), "absolute.{k}");
    }
    let p0 = &v["relative"]["pairs"][0];
    for k in ["a", "b", "survey_distance", "map_distance", "error"] {
        assert!(p0.get(k).is_some(), "pair.{k}");
    }
    let targets = std::fs::read_to_string(dir.path().join("targets.csv")).unwrap();
    assert_eq!(targets.lines().count(), 6);
    assert!(targets.starts_with("id,status,reason,survey_x"));
    let pairs = std::fs::read_to_string(dir.path().join("pairs.csv")).unwrap();
    assert_eq!(pairs.lines().count(), 11);
    // No temp files left behind.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 3);

    let out = bin()
        .args(["errors", "--format", "json", "--survey"])
        .arg(data("paper_seq5_survey.csv"))
        .arg("--estimates")
        .arg(data("paper_seq5_estimates.csv"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let r2: RunResult = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(r2, r);
}

fn paper_roundtrip() -> RunResult {
    // NaN-free results survive JSON exactly (serde_json round-trips f64).
    let r = paper();
    serde_json::from_str(&r.to_json()).unwrap()
}

#[test]
fn cli_other_formats() {
    for (fmt, needle) in [
        ("markdown", "| Run | E_rel | σ_rel |"),
        ("latex", "\\toprule"),
        ("csv", "table,item,value"),
    ] {
        let out = bin()
            .args(["errors", "--format", fmt, "--align", "robust2d", "--survey"])
            .arg(data("paper_seq5_survey.csv"))
            .arg("--estimates")
            .arg(data("paper_seq5_estimates.csv"))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{fmt}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = String::from_utf8(out.stdout).unwrap();
        assert!(text.contains(needle), "{fmt}: {text}");
        // Relative errors need no alignment: same with robust2d.
        assert!(text.contains("0.063"), "{fmt}: {text}");
    }
}

#[test]
fn cli_errors_are_one_line_and_name_the_file() {
    let dir = tempdir();
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "id,x,y\n1,0,0\n2,zero,0\n").unwrap();
    let out = bin()
        .args(["errors", "--survey"])
        .arg(&bad)
        .arg("--estimates")
        .arg(data("paper_seq5_estimates.csv"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("bad.csv:3:") && err.contains("zero"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");

    let one = dir.path().join("one.csv");
    std::fs::write(&one, "id,x,y\n1,-14.08,-3.52\n9,0,0\n").unwrap();
    let out = bin()
        .args(["errors", "--survey"])
        .arg(data("paper_seq5_survey.csv"))
        .arg("--estimates")
        .arg(&one)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("only 1 target") && err.contains("at least 2"),
        "{err}"
    );

    let out = bin()
        .args(["errors", "--align", "warp", "--survey"])
        .arg(data("paper_seq5_survey.csv"))
        .arg("--estimates")
        .arg(data("paper_seq5_estimates.csv"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown alignment `warp`"));
}

#[test]
fn cli_geodetic_survey_matches_local_survey() {
    // Write the paper survey as lat/lon/alt about an origin, read it back through the
    // CLI with that origin: identical numbers to the local survey.
    let origin = Geodetic {
        lat: 36.3729,
        lon: 127.3604,
        alt: 68.2,
    };
    let dir = tempdir();
    let s = read_survey(&data("paper_seq5_survey.csv"), &SurveyOptions::default()).unwrap();
    let mut csv = String::from("id,lat,lon,alt,role\n");
    for (i, t) in s.targets.iter().enumerate() {
        let g = origin.geodetic_of(&Point::new(t.position.x, t.position.y, 0.0));
        csv += &format!(
            "{},{:.12},{:.12},{:.6},{}\n",
            t.id,
            g.lat,
            g.lon,
            g.alt,
            if i == 2 { "check" } else { "control" }
        );
    }
    let llh = dir.path().join("survey_llh.csv");
    std::fs::write(&llh, csv).unwrap();
    let out = bin()
        .args([
            "errors",
            "--format",
            "json",
            "--origin",
            "36.3729,127.3604,68.2",
            "--survey-sigma",
            "0.02,0.03",
            "--survey",
        ])
        .arg(&llh)
        .arg("--estimates")
        .arg(data("paper_seq5_estimates.csv"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: RunResult = serde_json::from_slice(&out.stdout).unwrap();
    let p = paper();
    for (a, b) in r.targets.iter().zip(&p.targets) {
        assert!((a.abs_error.unwrap() - b.abs_error.unwrap()).abs() < 1e-6);
    }
    close4(r.relative.mean, 0.0633, "E_rel via lat/lon");
    let cc = r
        .control_check
        .as_ref()
        .expect("roles give a control/check split");
    assert_eq!(cc.check.targets.len(), 1);
    assert_eq!(cc.check.targets[0].id, "3");
    assert!(r.asprs.independent && r.asprs.n_checkpoints == 1);
    assert_eq!(r.asprs.survey_sigma_h, Some(0.02));
}

/// A lat/lon/alt survey read with an origin lands where PROJ puts it (values from
/// PROJ 9.5.1 topocentric, tests/data/geodesy_proj.py): east is east, south is
/// negative north, through the survey reader and not just the geodesy functions.
#[test]
fn geodetic_survey_reads_to_projs_east_north_up() {
    let dir = tempdir();
    let llh = dir.path().join("survey_llh.csv");
    std::fs::write(
        &llh,
        "id,lat,lon,alt\nne,36.3735,127.365,75.5\nsw,36.371,127.3612,64.0\n",
    )
    .unwrap();
    let opts = SurveyOptions {
        origin: Some(Geodetic {
            lat: 36.3725,
            lon: 127.3631,
            alt: 70.0,
        }),
    };
    let s = read_survey(&llh, &opts).unwrap();
    let want = [
        (
            "ne",
            [170.50158107887387, 110.96892422451668, 5.496755368499592],
        ),
        (
            "sw",
            [-170.50672960566288, -166.44885900860953, -6.004455160600983],
        ),
    ];
    for (t, (id, [e, n, u])) in s.targets.iter().zip(want) {
        assert_eq!(t.id, id);
        let d = t.position - Point::new(e, n, u);
        assert!(
            d.norm() < 1e-4,
            "{id}: {} vs PROJ ({e}, {n}, {u})",
            t.position
        );
    }
}

/// Issue 32: stdout closed before anything is printed (`mapgauge … | head
/// -1` after `head` exits) ends the printing, not the run: no panic, exit
/// 0, and the files are still written.
#[test]
fn a_closed_stdout_is_not_a_panic() {
    // A pipe whose reader is gone before the command starts: every write
    // to its stdout fails, whatever the timing.
    let closed = || {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        writer
    };
    let dir = tempdir();
    let out = bin()
        .args(["errors", "--survey"])
        .arg(data("paper_seq5_survey.csv"))
        .arg("--estimates")
        .arg(data("paper_seq5_estimates.csv"))
        .arg("--out")
        .arg(dir.path())
        .stdout(closed())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}: {err}", out.status);
    assert!(!err.contains("panicked"), "{err}");
    assert!(dir.path().join("result.json").is_file());
    let out = bin()
        .arg("table")
        .arg(dir.path().join("result.json"))
        .stdout(closed())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !err.contains("panicked"),
        "{:?}: {err}",
        out.status
    );
}
