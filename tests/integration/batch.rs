//! `mapgauge batch` end to end (issue 34): 3 methods × 4 sequences of
//! synthetic scenes whose drift grows with the method, run in parallel,
//! resumed, ranked, compared with a baseline; a failed run stops nothing;
//! the same bytes whatever the number of runs at once.

use crate::util::{bin, stderr, tempdir};
use serde_json::Value;
use std::path::Path;

/// 700 k points a scene: at 300 k a seed can leave too few targets to score.
/// Method k's map drifts k/2, 1, 2 times synth's default drift; the four
/// sequences are four seeds (one survey each, shared by the methods).
fn scenes(dir: &Path) -> String {
    let mut manifest = String::from(
        "baseline = \"m1\"\n\n[overrides]\ngates = { checks = [\"E_abs<=0.2\"] }\nmetrics = { scores = [\"hilti2026\"] }\n\n",
    );
    for (m, k) in [(1, 0.5), (2, 1.0), (3, 2.0)] {
        let cfg = dir.join(format!("drift{m}.toml"));
        std::fs::write(
            &cfg,
            format!(
                "[distortion]\ndrift_m = [{}, {}, {}]\n",
                0.04 * k,
                -0.03 * k,
                0.02 * k
            ),
        )
        .expect("write synth config");
        for s in 1..=4 {
            let out = dir.join(format!("s{s}/m{m}"));
            let o = bin()
                .args([
                    "synth",
                    "--points",
                    "700000",
                    "--seed",
                    &s.to_string(),
                    "--config",
                ])
                .arg(&cfg)
                .arg("--out")
                .arg(&out)
                .output()
                .expect("synth");
            assert!(o.status.success(), "{}", stderr(&o));
        }
    }
    for s in 1..=4 {
        for m in 1..=3 {
            manifest += &format!(
                "[[run]]\nmethod = \"m{m}\"\nsequence = \"s{s}\"\nmap = \"s{s}/m{m}/map.ply\"\nsurvey = \"s{s}/m1/survey.csv\"\n\n"
            );
        }
    }
    manifest
}

fn batch(manifest: &Path, out: &Path, jobs: &str) -> (i32, Value) {
    let o = bin()
        .arg("batch")
        .arg(manifest)
        .arg("--out")
        .arg(out)
        .args(["--jobs", jobs])
        .output()
        .expect("batch");
    let summary = std::fs::read(out.join("batch.json"))
        .map(|b| serde_json::from_slice(&b).expect("batch.json"))
        .unwrap_or(Value::Null);
    (o.status.code().unwrap_or(-1), summary)
}

fn statuses(s: &Value) -> Vec<String> {
    s["runs"]
        .as_array()
        .expect("runs")
        .iter()
        .map(|r| r["status"].as_str().expect("status").to_string())
        .collect()
}

#[test]
fn twelve_runs_in_parallel_resume_rank_and_compare() {
    let dir = tempdir();
    let manifest = dir.path().join("runs.toml");
    std::fs::write(&manifest, scenes(dir.path())).expect("write manifest");
    let out = dir.path().join("out");
    let (code, s) = batch(&manifest, &out, "2");
    assert_eq!(code, 0, "{s}");
    assert_eq!(statuses(&s), vec!["evaluated"; 12]);
    // Every run's files where eval --out would put them, and the summary's.
    for f in [
        "s1/m1/result.json",
        "s4/m3/report.html",
        "s2/tables.md",
        "s3/compare.md",
        "index.html",
        "leaderboard.csv",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    // More drift, more error: the most drifting method ranks last, and each
    // of its sequences is measurably worse than the baseline's.
    let board: Vec<&str> = s["leaderboard"]
        .as_array()
        .expect("leaderboard")
        .iter()
        .map(|l| l["method"].as_str().expect("method"))
        .collect();
    assert_eq!(board.last(), Some(&"m3"), "{board:?}");
    let worse = s["comparisons"]
        .as_array()
        .expect("comparisons")
        .iter()
        .filter(|c| c["method"] == "m3")
        .filter(|c| c["e_abs"]["ci95"][0].as_f64().is_some_and(|lo| lo > 0.0))
        .count();
    assert!(worse >= 3, "{}", s["comparisons"]);
    // The gates of the [overrides] table judged every run.
    let r: Value =
        serde_json::from_slice(&std::fs::read(out.join("s2/m2/result.json")).expect("result"))
            .expect("json");
    assert_eq!(r["gates"][0]["gate"], "E_abs<=0.2");
    // ... and scored it; the leaderboard's score is the mean of its runs'
    // totals, lowest for the most drifting method.
    assert!(
        r["scores"]["hilti2026"]["total"].is_f64(),
        "{}",
        r["scores"]
    );
    let mean_score = |m: &str| {
        let l = s["leaderboard"]
            .as_array()
            .expect("leaderboard")
            .iter()
            .find(|l| l["method"] == m)
            .expect("method");
        l["scores"]["hilti2026"]["mean"]
            .as_f64()
            .expect("mean score")
    };
    let totals: Vec<f64> = s["runs"]
        .as_array()
        .expect("runs")
        .iter()
        .filter(|r| r["method"] == "m2")
        .map(|r| r["scores"]["hilti2026"].as_f64().expect("total"))
        .collect();
    assert_eq!(totals.len(), 4);
    assert!((mean_score("m2") - totals.iter().sum::<f64>() / 4.0).abs() < 1e-9);
    assert!(mean_score("m3") < mean_score("m1"), "{}", s["leaderboard"]);
    let board_csv = std::fs::read_to_string(out.join("leaderboard.csv")).expect("csv");
    assert!(board_csv.contains("Hilti 2026 score"), "{board_csv}");
    // Again: nothing changed, so nothing is evaluated, and the same summary.
    let (code, again) = batch(&manifest, &out, "2");
    assert_eq!(code, 0);
    assert_eq!(statuses(&again), vec!["reused"; 12]);
    assert_eq!(again["leaderboard"], s["leaderboard"]);
    // One run per worker: the same bytes as two at once.
    let one = dir.path().join("one");
    let (code, _) = batch(&manifest, &one, "1");
    assert_eq!(code, 0);
    for f in [
        "s1/m1/result.json",
        "s3/m2/targets.csv",
        "s4/m3/pairs.csv",
        "leaderboard.csv",
    ] {
        assert_eq!(
            std::fs::read(out.join(f)).expect("two at once"),
            std::fs::read(one.join(f)).expect("one at once"),
            "{f}"
        );
    }
    // A run that cannot be evaluated leaves its error and stops nothing:
    // exit 4, the others reused, the leaderboard counts the failure.
    let mut text = std::fs::read_to_string(&manifest).expect("manifest");
    text += "[[run]]\nmethod = \"m4\"\nsequence = \"s1\"\nmap = \"missing.pcd\"\nsurvey = \"s1/m1/survey.csv\"\n";
    std::fs::write(&manifest, text).expect("write manifest");
    let (code, s) = batch(&manifest, &out, "2");
    assert_eq!(code, 4, "{s}");
    let st = statuses(&s);
    assert_eq!(
        (
            st[12].as_str(),
            st.iter().filter(|x| *x == "reused").count()
        ),
        ("failed", 12)
    );
    let err = std::fs::read_to_string(out.join("s1/m4/error.txt")).expect("error.txt");
    assert!(err.contains("missing.pcd"), "{err}");
}

#[test]
fn a_bad_manifest_is_one_line_with_its_place() {
    let dir = tempdir();
    let m = dir.path().join("m.toml");
    std::fs::write(
        &m,
        "[[run]]\nmethod = \"a\"\nsequence = \"s/1\"\nmap = \"x.pcd\"\nsurvey = \"s.csv\"\n",
    )
    .expect("write");
    let o = bin()
        .arg("batch")
        .arg(&m)
        .arg("--out")
        .arg(dir.path().join("o"))
        .output()
        .expect("batch");
    assert_eq!(o.status.code(), Some(4));
    let e = stderr(&o);
    assert!(
        e.starts_with(&format!("error: {}:1: run 1: sequence `s/1`", m.display())),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1, "{e}");
}
