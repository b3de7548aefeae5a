use super::*;
use crate::gate::{GateOutcome, Outcome};

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

const TWO: &str = r#"
baseline = "a"
config = "base.toml"

[[run]]
method = "a"
sequence = "s1"
map = "maps/a.pcd"
survey = "s1.csv"

[[run]]
method = "b"
sequence = "s1"
map = "maps/b.pcd"
survey = "s1.csv"
overrides = { metrics = { dim = "3d" }, crop = { radius = 3.0 } }
"#;

#[test]
fn a_manifest_resolves_paths_and_merges_settings() {
    let d = tempfile::tempdir().expect("tempdir");
    write(
        d.path(),
        "base.toml",
        "[metrics]\nalign = \"rigid3d\"\n[crop]\nradius = 4.0\n",
    );
    let m = Manifest::read(&write(d.path(), "m.toml", TWO)).expect("manifest");
    assert_eq!(m.runs.len(), 2);
    assert_eq!(m.runs[0].map, d.path().join("maps/a.pcd"));
    assert_eq!(m.runs[1].dir(), Path::new("s1").join("b"));
    // The file's settings, then the run's overrides key by key.
    let (a, b) = (&m.runs[0].config, &m.runs[1].config);
    assert_eq!((a.metrics.align.name(), a.crop.radius), ("rigid3d", 4.0));
    assert_eq!((b.metrics.align.name(), b.crop.radius), ("rigid3d", 3.0));
    assert_eq!(b.metrics.dim.label(), "3D");
    assert_eq!(m.sequences(), ["s1"]);
    assert_eq!(m.methods(), ["a", "b"]);
}

#[test]
fn a_bad_manifest_says_which_run_and_line() {
    let d = tempfile::tempdir().expect("tempdir");
    write(d.path(), "base.toml", "");
    let cases = [
        (
            TWO.replace("method = \"b\"", "method = \"a\""),
            "m.toml:11: run 2: method `a` on sequence `s1` is run 1 too",
        ),
        (
            TWO.replace(
                "sequence = \"s1\"\nmap = \"maps/b",
                "sequence = \"../x\"\nmap = \"maps/b",
            ),
            "m.toml:11: run 2: sequence `../x` cannot name a folder",
        ),
        (
            TWO.replace("baseline = \"a\"", "baseline = \"c\""),
            "m.toml: baseline `c` is not the method of any run",
        ),
        (
            TWO.replace("radius = 3.0", "radius = -3.0"),
            "m.toml:11: run 2: invalid parameter: crop.radius",
        ),
        (
            TWO.replace("dim = \"3d\"", "dims = \"3d\""),
            "m.toml:11: run 2: invalid parameter: overrides: unknown field `dims`",
        ),
        (
            TWO.replace("map = \"maps/a.pcd\"", "mapp = \"maps/a.pcd\""),
            "m.toml:8: unknown field `mapp`",
        ),
        ("jobs = 2\n".to_string(), "m.toml: no runs"),
        // Folders that differ only in case are one folder on macOS and Windows.
        (
            TWO.replace("method = \"b\"", "method = \"A\""),
            "m.toml:11: run 2: method `A` on sequence `s1` is run 1 too",
        ),
        (
            TWO.replace("method = \"b\"", "method = \"index.html\""),
            "m.toml:11: run 2: method `index.html` is the name of a file the batch writes",
        ),
    ];
    for (text, want) in cases {
        let e = Manifest::read(&write(d.path(), "m.toml", &text))
            .expect_err(want)
            .to_string();
        let e = e.replace(&format!("{}/", d.path().display()), "");
        assert!(e.starts_with(want), "want `{want}`, got `{e}`");
    }
}

fn record(seq: &str, method: &str, e_abs: Option<f64>, gates: Option<Outcome>) -> RunRecord {
    let result = e_abs.map(|e| {
        let mut r = crate::gate::tests::result();
        r.absolute.mean = e;
        r.gate_outcome = gates.map(|outcome| GateOutcome {
            policy: crate::gate::Policy::Strict,
            outcome,
            exit_code: outcome.exit_code(),
            counts: [0, 0, 0],
        });
        r
    });
    RunRecord {
        sequence: seq.into(),
        method: method.into(),
        status: if result.is_some() {
            Status::Evaluated
        } else {
            Status::Failed
        },
        error: result.is_none().then(|| "map.pcd: no such file".into()),
        result,
        seconds: 0.0,
    }
}

#[test]
fn the_summary_ranks_methods_and_decides_the_exit_code() {
    let d = tempfile::tempdir().expect("tempdir");
    write(d.path(), "base.toml", "");
    let mut text = TWO.to_string();
    text += "\n[[run]]\nmethod = \"a\"\nsequence = \"s2\"\nmap = \"x.pcd\"\nsurvey = \"s2.csv\"\n";
    text += "\n[[run]]\nmethod = \"b\"\nsequence = \"s2\"\nmap = \"y.pcd\"\nsurvey = \"s2.csv\"\n";
    let m = Manifest::read(&write(d.path(), "m.toml", &text)).expect("manifest");
    let recs = vec![
        record("s1", "a", Some(0.03), Some(Outcome::Pass)),
        record("s1", "b", Some(0.01), Some(Outcome::Undecided)),
        record("s2", "a", Some(0.05), Some(Outcome::Fail)),
        record("s2", "b", Some(0.02), None),
    ];
    let s = summarise(&m, &recs);
    let order: Vec<&str> = s.leaderboard.iter().map(|l| l.method.as_str()).collect();
    assert_eq!(order, ["b", "a"]);
    let b = &s.leaderboard[0];
    assert!((b.e_abs.expect("two sequences").mean - 0.015).abs() < 1e-12);
    assert_eq!(s.leaderboard[1].gates, [1, 1, 0]);
    assert_eq!(s.exit_code, 1);
    // b against a on both sequences: same survey, so compared.
    assert_eq!(s.comparisons.len(), 2);
    assert!(
        s.comparisons[0].e_abs.is_some(),
        "{}",
        s.comparisons[0].verdict
    );
    // A failed run outranks every gate: exit 4, and it is listed.
    let recs = vec![
        recs[0].clone(),
        recs[1].clone(),
        record("s2", "a", None, None),
        recs[3].clone(),
    ];
    let s = summarise(&m, &recs);
    assert_eq!(s.exit_code, 4);
    assert_eq!(
        s.leaderboard
            .iter()
            .find(|l| l.method == "a")
            .map(|l| l.failed),
        Some(1)
    );
    assert!(s.comparisons[1].verdict.contains("failed"));
    // The files.
    let out = d.path().join("out");
    write_summary(&out, &s, &recs).expect("write");
    for f in [
        "batch.json",
        "leaderboard.csv",
        "leaderboard.md",
        "index.html",
        "s1/tables.md",
        "s1/compare.md",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    // A sequence that no longer has a result loses its old pages.
    let all_failed = vec![
        recs[0].clone(),
        recs[1].clone(),
        record("s2", "a", None, None),
        record("s2", "b", None, None),
    ];
    std::fs::write(out.join("s2/tables.md"), "old").expect("write");
    write_summary(&out, &summarise(&m, &all_failed), &all_failed).expect("write");
    assert!(!out.join("s2/tables.md").exists());
    write_summary(&out, &s, &recs).expect("write");
    let index = std::fs::read_to_string(out.join("index.html")).expect("index");
    assert!(
        index.contains("s1/b/report.html") && index.contains("s2/a/error.txt"),
        "{index}"
    );
}
