//! Quality gates end to end (issue 34): the exit codes of pass, fail and
//! undecided on a synthetic run whose truth is known, the three policies,
//! `result.json`'s verdicts, the summary's first lines, JUnit, the
//! `[gates]` table, and `errors --gate` on the paper's numbers.

use crate::util::{bin, stderr, tempdir};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Output;

fn read_json(p: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).expect("read json")).expect("parse json")
}

/// One scene for every eval below: 5 targets, 800 k points.
fn scene(dir: &Path) -> PathBuf {
    let s = dir.join("scene");
    let o = bin()
        .args(["synth", "--points", "800000", "--seed", "4", "--out"])
        .arg(&s)
        .output()
        .expect("synth");
    assert!(o.status.success(), "{}", stderr(&o));
    s
}

fn eval(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    bin()
        .args(["eval", "--map"])
        .arg(scene.join("map.ply"))
        .arg("--survey")
        .arg(scene.join("survey.csv"))
        .arg("--out")
        .arg(out)
        .arg("--no-report")
        .args(extra)
        .output()
        .expect("eval")
}

fn code(o: &Output) -> i32 {
    o.status.code().unwrap_or(-1)
}

#[test]
fn exit_codes_follow_the_interval_around_the_truth() {
    let dir = tempdir();
    let scene = scene(dir.path());
    let truth = read_json(&scene.join("truth.json"))["expected"]["absolute"]["mean"]
        .as_f64()
        .expect("true E_abs");
    // A first run, gated loosely, gives E_abs's interval.
    let first = eval(&scene, &dir.path().join("first"), &["--gate", "E_abs<=1"]);
    assert_eq!(code(&first), 0, "{}", stderr(&first));
    let r = read_json(&dir.path().join("first/result.json"));
    let g = &r["gates"][0];
    assert_eq!(g["verdict"], "pass");
    assert_eq!(g["basis"], "ci95");
    let ci: Vec<f64> = g["ci95"]
        .as_array()
        .expect("an interval")
        .iter()
        .map(|v| v.as_f64().expect("a number"))
        .collect();
    let value = g["value"].as_f64().expect("a value");
    assert_eq!(value, r["absolute"]["mean"].as_f64().expect("E_abs"));
    // The interval is honest here: it holds the true E_abs, so a threshold
    // at the truth is one the run cannot decide.
    assert!(
        ci[0] < truth && truth < ci[1],
        "truth {truth} outside {ci:?}"
    );
    let mm = 0.001;
    let run = |name: &str, gate: String, policy: &str| {
        let o = eval(
            &scene,
            &dir.path().join(name),
            &["--gate", &gate, "--gate-policy", policy],
        );
        let r = read_json(&dir.path().join(name).join("result.json"));
        (code(&o), r, String::from_utf8_lossy(&o.stdout).into_owned())
    };
    // Just outside the interval, above: the map meets the gate for sure.
    let (c, r, out) = run("pass", format!("E_abs<={}", ci[1] + mm), "strict");
    assert_eq!((c, r["gates"][0]["verdict"].as_str()), (0, Some("pass")));
    assert!(out.starts_with("gates (strict): PASS, exit 0"), "{out}");
    // Just below it: the map misses the gate for sure.
    let (c, r, out) = run("fail", format!("E_abs<={}", ci[0] - mm), "strict");
    assert_eq!((c, r["gates"][0]["verdict"].as_str()), (1, Some("fail")));
    assert!(out.starts_with("gates (strict): FAIL, exit 1"), "{out}");
    assert_eq!(r["gate_outcome"]["exit_code"], 1);
    // At the truth, inside the interval: undecided, exit 3 under strict.
    let at_truth = format!("E_abs<={truth}");
    let (c, r, out) = run("undecided", at_truth.clone(), "strict");
    assert_eq!(
        (c, r["gates"][0]["verdict"].as_str()),
        (3, Some("undecided"))
    );
    assert!(
        out.starts_with("gates (strict): UNDECIDED, exit 3"),
        "{out}"
    );
    assert!(
        out.lines().nth(1).is_some_and(|l| l.contains("95 %")),
        "{out}"
    );
    // `point` judges the value alone; `report-only` never fails the run.
    let on_value = if value <= truth { 0 } else { 1 };
    let (c, r, _) = run("point", at_truth.clone(), "point");
    assert_eq!(c, on_value);
    assert_eq!(r["gates"][0]["verdict"], "undecided");
    let (c, r, out) = run("report", format!("E_abs<={}", ci[0] - mm), "report-only");
    assert_eq!((c, r["gates"][0]["verdict"].as_str()), (0, Some("fail")));
    assert!(
        out.starts_with("gates (report-only): REPORTED, exit 0"),
        "{out}"
    );
}

#[test]
fn junit_config_table_and_usage_errors() {
    let dir = tempdir();
    let scene = scene(dir.path());
    // The [gates] table of a config file; a statistic the run does not
    // compute (RMSE_V under rigid2d) is undecided with its reason.
    let cfg = dir.path().join("gates.toml");
    std::fs::write(
        &cfg,
        "[gates]\npolicy = \"strict\"\nchecks = [\"E_abs<=50cm\", \"found>=80%\", \"RMSE_V<=1cm\"]\n",
    )
    .expect("write config");
    let junit = dir.path().join("junit.xml");
    let o = eval(
        &scene,
        &dir.path().join("cfg"),
        &[
            "--config",
            cfg.to_str().expect("utf-8"),
            "--junit",
            junit.to_str().expect("utf-8"),
        ],
    );
    assert_eq!(code(&o), 3, "{}", stderr(&o));
    let r = read_json(&dir.path().join("cfg/result.json"));
    let words: Vec<&str> = r["gates"]
        .as_array()
        .expect("gates")
        .iter()
        .map(|g| g["verdict"].as_str().expect("verdict"))
        .collect();
    assert_eq!(words, ["pass", "pass", "undecided"]);
    assert!(
        r["gates"][2]["note"]
            .as_str()
            .is_some_and(|n| n.contains("heights"))
    );
    let xml = std::fs::read_to_string(&junit).expect("junit");
    assert!(xml.starts_with("<?xml"), "{xml}");
    assert!(xml.contains("tests=\"3\" failures=\"1\""), "{xml}");
    assert_eq!(xml.matches("<testcase ").count(), 3 + 5, "{xml}");
    assert_eq!(
        xml.matches("<testcase ").count(),
        xml.matches("</testcase>").count()
    );
    // --gate replaces the table's checks; the policy stays.
    let o = eval(
        &scene,
        &dir.path().join("flag"),
        &[
            "--config",
            cfg.to_str().expect("utf-8"),
            "--gate",
            "found>=0.8",
        ],
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    // Every run says how its numbers were made, gates included.
    let prov = stderr(&o);
    let line = prov
        .lines()
        .find(|l| l.starts_with("provenance: mapgauge "))
        .expect("provenance");
    assert!(line.contains("--gate 'found>=0.8'"), "{line}");
    assert!(line.contains("gates found>=0.8 (strict)"), "{line}");
    assert!(
        line.contains("settings: align rigid2d, dim 2d, seed 0, frame auto"),
        "{line}"
    );
    assert!(line.contains(", config blake3:"), "{line}");
    // A gate that cannot be read is a usage error (2), before any work;
    // a run that cannot produce a result is 4, apart from a failed gate's 1.
    let o = eval(&scene, &dir.path().join("bad"), &["--gate", "E_abs=0.05"]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("E_abs=0.05"), "{}", stderr(&o));
    assert!(!dir.path().join("bad").exists());
    // Its JUnit file says why, so a CI test report is not silent.
    let o = bin()
        .args(["eval", "--map", "/nonexistent.pcd", "--survey"])
        .arg(scene.join("survey.csv"))
        .args(["--gate", "E_abs<=1", "--junit"])
        .arg(&junit)
        .output()
        .expect("eval");
    assert_eq!(code(&o), 4, "{}", stderr(&o));
    let xml = std::fs::read_to_string(&junit).expect("junit");
    assert!(
        xml.contains("errors=\"1\"") && xml.contains("/nonexistent.pcd"),
        "{xml}"
    );
    // The report opens with the gates.
    let o = bin()
        .args(["eval", "--map"])
        .arg(scene.join("map.ply"))
        .arg("--survey")
        .arg(scene.join("survey.csv"))
        .arg("--out")
        .arg(dir.path().join("report"))
        .args(["--gate", "E_abs<=1mm"])
        .output()
        .expect("eval");
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    let html = std::fs::read_to_string(dir.path().join("report/report.html")).expect("report");
    let (gates, summary) = (
        html.find("<section id=\"gates\">"),
        html.find("<section id=\"summary\">"),
    );
    assert!(
        gates.is_some() && gates < summary,
        "gates before the summary"
    );
    assert!(html.contains("gates (strict): FAIL, exit 1"));
}

#[test]
fn errors_takes_the_same_gates() {
    let dir = tempdir();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let junit = dir.path().join("j.xml");
    let o = bin()
        .args(["errors", "--survey"])
        .arg(data.join("paper_seq5_survey.csv"))
        .arg("--estimates")
        .arg(data.join("paper_seq5_estimates.csv"))
        .args([
            "--gate",
            "E_abs<=1m",
            "--gate",
            "max_abs<=1mm",
            "--format",
            "json",
            "--junit",
        ])
        .arg(&junit)
        .output()
        .expect("errors");
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    let r: Value = serde_json::from_slice(&o.stdout).expect("json on stdout");
    assert_eq!(r["gates"][1]["verdict"], "fail");
    assert_eq!(r["gate_outcome"]["outcome"], "fail");
    // With --format json the gate lines go to stderr.
    assert!(
        stderr(&o).contains("gates (strict): FAIL, exit 1"),
        "{}",
        stderr(&o)
    );
    assert!(
        std::fs::read_to_string(&junit)
            .expect("junit")
            .contains("max_abs&lt;=0.001")
    );
}
