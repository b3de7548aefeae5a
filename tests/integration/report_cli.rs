//! `eval` writes report.html and, with `--plots`, every figure as SVG and PNG;
//! `table` renders several runs as one HTML page or JSON.

use crate::util::{bin, stdout_ok, tempdir};
use std::path::Path;

/// A small scene (4 targets) plus one surveyed target where nothing stands.
fn scene(dir: &Path) {
    stdout_ok(
        bin()
            .args(["synth", "--points", "800000", "--targets", "4", "--out"])
            .arg(dir),
    );
    let survey = dir.join("survey.csv");
    let mut text = std::fs::read_to_string(&survey).unwrap();
    text.push_str("<t&9>,900.0,900.0,1.0,0.42\n");
    std::fs::write(dir.join("survey_extra.csv"), text).unwrap();
}

#[test]
fn eval_writes_report_and_plots() {
    let dir = tempdir();
    scene(dir.path());
    let out = dir.path().join("out");
    let plots = dir.path().join("plots");
    stdout_ok(
        bin()
            .args(["eval", "--map"])
            .arg(dir.path().join("map.ply"))
            .arg("--survey")
            .arg(dir.path().join("survey_extra.csv"))
            .arg("--out")
            .arg(&out)
            .arg("--plots")
            .arg(&plots),
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    // Overview, relative error, the errors' CDF, and one panel per target
    // (5, one failed).
    assert_eq!(html.matches("<svg ").count(), 8);
    assert_eq!(html.matches("<div class=\"target").count(), 5);
    // The unsurveyable target fails (a sparse synthetic target may too).
    assert!(html.matches("class=\"target failed\"").count() >= 1);
    assert!(html.contains("&lt;t&amp;9&gt;") && !html.contains("<t&9>"));
    assert!(html.contains("no map points within the crop radius"));
    // Provenance: both inputs with their BLAKE3 hashes.
    assert!(html.contains("map.ply") && html.contains("survey_extra.csv"));
    assert_eq!(
        html.matches("<td class=\"hash\">").count(),
        2,
        "two hashed inputs"
    );
    assert_eq!(
        html.matches("http").count(),
        html.matches("xmlns=\"http://www.w3.org/2000/svg\"").count()
    );
    // result.json stays free of the date: byte-identical on a rerun.
    let first = std::fs::read(out.join("result.json")).unwrap();
    let out2 = dir.path().join("out2");
    stdout_ok(
        bin()
            .args(["eval", "--no-report", "--map"])
            .arg(dir.path().join("map.ply"))
            .arg("--survey")
            .arg(dir.path().join("survey_extra.csv"))
            .arg("--out")
            .arg(&out2),
    );
    assert_eq!(first, std::fs::read(out2.join("result.json")).unwrap());
    assert!(!out2.join("report.html").exists(), "--no-report");

    let mut names: Vec<String> = std::fs::read_dir(&plots)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names.len(), 16, "{names:?}");
    for stem in [
        "overview",
        "relative",
        "error-cdf",
        "target-1",
        "target-4",
        "target-_t_9_",
    ] {
        let svg = std::fs::read_to_string(plots.join(format!("{stem}.svg"))).unwrap();
        assert!(svg.contains("<svg ") && svg.trim_end().ends_with("</svg>"));
        let png = std::fs::read(plots.join(format!("{stem}.png"))).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{stem}.png");
        assert!(png.len() > 10_000, "{stem}.png is {} bytes", png.len());
    }
}

/// What the report shows of the map itself (issue 31): its footprint under
/// the target positions, the trajectory with each target's error against
/// the distance driven, and with `--save-crops` each located target's
/// fitted plates as a PLY mesh; a trajectory file that is not one is refused
/// before any work, naming the line.
#[test]
fn the_report_shows_the_map_the_route_and_the_fitted_plates() {
    let dir = tempdir();
    scene(dir.path());
    let out = dir.path().join("out");
    stdout_ok(
        bin()
            .args(["eval", "--save-crops", "--map"])
            .arg(dir.path().join("map.ply"))
            .arg("--survey")
            .arg(dir.path().join("survey.csv"))
            .arg("--trajectory")
            .arg(dir.path().join("trajectory.txt"))
            .arg("--out")
            .arg(&out),
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    // Overview, relative, CDF, route, 4 targets.
    assert_eq!(html.matches("<svg ").count(), 8);
    for id in ["fig-error-cdf", "fig-error-route"] {
        assert_eq!(
            html.matches(&format!("<figure id=\"{id}\"")).count(),
            1,
            "{id}"
        );
    }
    let overview = html
        .split("<figure id=\"fig-overview\">")
        .nth(1)
        .and_then(|s| s.split("</figure>").next())
        .unwrap();
    // The footprint's shaded squares (runs of them merged) and the route.
    let shades = ["#eef0f3", "#dde1e7", "#cbd1d9", "#b6bec9"]
        .iter()
        .map(|c| overview.matches(&format!("fill=\"{c}\"")).count())
        .sum::<usize>();
    assert!(shades > 100, "{shades} footprint rectangles");
    assert!(overview.contains("the trajectory") && overview.contains("the map from above"));
    let route = html
        .split("<figure id=\"fig-error-route\">")
        .nth(1)
        .unwrap();
    assert!(route.contains("slope") && route.contains("poses"));
    // The fitted plates: two quads through the corner that result.json gives.
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    let mut meshes = 0;
    for t in r["targets"].as_array().unwrap() {
        let id = t["id"].as_str().unwrap();
        let ply = out.join("crops").join("fit").join(format!("{id}.ply"));
        if t["status"] != "ok" {
            continue;
        }
        let text = std::fs::read_to_string(&ply).unwrap();
        assert!(text.contains("element vertex 9") && text.contains("element face 4"));
        let v: Vec<Vec<f64>> = text
            .split("end_header\n")
            .nth(1)
            .unwrap()
            .lines()
            .take(9)
            .map(|l| l.split(' ').take(3).map(|x| x.parse().unwrap()).collect())
            .collect();
        let m = &t["map"];
        let corner = [
            m["x"].as_f64().unwrap(),
            m["y"].as_f64().unwrap(),
            m["z"].as_f64().unwrap(),
        ];
        for k in 0..3 {
            assert!(
                (v[8][k] - corner[k]).abs() < 1e-4,
                "{id}: corner {v:?} vs {corner:?}"
            );
        }
        // Each plate about the configured 0.6 m high, reaching at most that far.
        for q in [&v[0..4], &v[4..8]] {
            let h = q[3][2] - q[0][2];
            assert!((0.4..0.7).contains(&h), "{id}: plate height {h}");
            let far = ((q[1][0] - v[8][0]).hypot(q[1][1] - v[8][1])).max(1e-9);
            assert!(far < 0.75, "{id}: plate reaches {far} m");
        }
        meshes += 1;
    }
    assert!(meshes >= 3, "{meshes} meshes");
    // A file of other lines is refused before the map is read.
    let bad = dir.path().join("poses.txt");
    std::fs::write(&bad, "0 1 2 3 0 0 0 1\n1 2 3\n").unwrap();
    let o = bin()
        .args(["eval", "--no-report", "--map"])
        .arg(dir.path().join("map.ply"))
        .arg("--survey")
        .arg(dir.path().join("survey.csv"))
        .arg("--trajectory")
        .arg(&bad)
        .output()
        .unwrap();
    let e = crate::util::stderr(&o);
    assert_eq!(o.status.code(), Some(4), "{e}");
    assert!(
        e.contains("poses.txt:2: 3 numbers") && e.contains("TUM"),
        "{e}"
    );
}

#[test]
fn table_html_and_json_line_up_different_target_sets() {
    let dir = tempdir();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let mut results = Vec::new();
    for (name, drop) in [("all", None), ("four", Some("3"))] {
        let out = dir.path().join(name);
        let est = std::fs::read_to_string(data.join("paper_seq5_estimates.csv")).unwrap();
        let est: String = est
            .lines()
            .filter(|l| drop.is_none_or(|d| !l.starts_with(&format!("{d},"))))
            .map(|l| format!("{l}\n"))
            .collect();
        let est_path = dir.path().join(format!("{name}.csv"));
        std::fs::write(&est_path, est).unwrap();
        let survey = if drop.is_some() {
            // The survey without target 3 too: a run with a different target set.
            let s = std::fs::read_to_string(data.join("paper_seq5_survey.csv")).unwrap();
            let s: String = s
                .lines()
                .filter(|l| !l.starts_with("3,"))
                .map(|l| format!("{l}\n"))
                .collect();
            let p = dir.path().join("survey4.csv");
            std::fs::write(&p, s).unwrap();
            p
        } else {
            data.join("paper_seq5_survey.csv")
        };
        stdout_ok(
            bin()
                .args(["errors", "--survey"])
                .arg(&survey)
                .arg("--estimates")
                .arg(&est_path)
                .arg("--out")
                .arg(&out),
        );
        results.push(out.join("result.json"));
    }
    let html = stdout_ok(bin().arg("table").args(&results).args([
        "--format",
        "html",
        "--names",
        "Seq <5>,Four",
    ]));
    assert!(html.starts_with("<!DOCTYPE html>") && html.contains("Seq &lt;5&gt;"));
    assert!(html.contains("<td><strong>0.0516</strong></td>"), "{html}");
    assert!(!html.contains("http"));
    let json = stdout_ok(
        bin()
            .arg("table")
            .args(&results)
            .args(["--format", "json", "--names", "a,b"]),
    );
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let abs = &v["absolute"];
    // Full precision, not the 4 decimals of the text tables.
    let t3 = abs[0]["t3"].as_f64().unwrap();
    assert!((t3 - 0.0313).abs() < 5e-5 && t3 != 0.0313, "{t3}");
    // Target 3 is not in the second run: a blank (null), columns still keyed by id.
    assert!(abs[1]["t3"].is_null());
    assert!(abs[1]["t4"].as_f64().is_some());
    assert!(v["relative"][1]["t1 & t3"].is_null());
    let t12 = v["relative"][0]["t1 & t2"].as_f64().unwrap();
    assert!((t12 - 0.0095).abs() < 5e-5, "{t12}");
}
