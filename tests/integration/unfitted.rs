//! The absolute error without a fit (issue 35, item 1): a map in the
//! survey's frame carries its offset as it is; the fit takes it away, and
//! the result says how much.

use crate::util::{bin, stderr, tempdir};
use serde_json::Value;
use std::path::Path;

fn run(args: &[&str]) -> std::process::Output {
    bin().args(args).output().expect("mapgauge")
}

fn json(p: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).expect("read")).expect("json")
}

#[test]
fn a_map_in_the_survey_frame_shows_its_error_as_it_is() {
    let dir = tempdir();
    let s = dir.path().join("scene");
    let s_ = s.to_str().expect("utf-8");
    // Offset 0.3 m east, 0.4 m north (0.5 m), not turned.
    let o = run(&[
        "synth",
        "--points",
        "800000",
        "--seed",
        "5",
        "--yaw-deg",
        "0",
        "--offset-m",
        "0.3,0.4,0",
        "--out",
        s_,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (map, survey) = (format!("{s_}/map.ply"), format!("{s_}/survey.csv"));
    let out = dir.path().join("eval");
    let o = run(&[
        "eval",
        "--map",
        &map,
        "--survey",
        &survey,
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        text.lines()
            .nth(2)
            .is_some_and(|l| l.contains("without a fit")),
        "{text}"
    );
    let r = json(&out.join("result.json"));
    let u = &r["unfitted"];
    // Recomputed from the result's own positions, by the definition.
    let errs: Vec<f64> = r["targets"]
        .as_array()
        .expect("targets")
        .iter()
        .filter(|t| t["status"] == "ok")
        .map(|t| {
            let d = |k: &str| {
                t["map"][k].as_f64().expect("map") - t["survey"][k].as_f64().expect("survey")
            };
            d("x").hypot(d("y"))
        })
        .collect();
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    assert!(
        (u["mean"].as_f64().expect("mean") - mean).abs() < 1e-9,
        "{u} vs {mean}"
    );
    assert_eq!(u["n"].as_u64(), Some(errs.len() as u64));
    // The map sits 0.5 m off, give or take its drift (a few cm).
    assert!((mean - 0.5).abs() < 0.05, "{mean}");
    let e_abs = r["absolute"]["mean"].as_f64().expect("E_abs");
    let absorbed = r["fit_absorbed"].as_f64().expect("fit_absorbed");
    assert!(
        (absorbed - (mean - e_abs) / mean).abs() < 1e-9,
        "{absorbed}"
    );
    assert!(absorbed > 0.8, "{absorbed}");
    let html = std::fs::read_to_string(out.join("report.html")).expect("report");
    assert!(html.contains("E_abs without a fit"));
    // Placed by --init, the map is not in the survey's frame: no such number.
    let out2 = dir.path().join("init");
    let o = run(&[
        "eval",
        "--map",
        &map,
        "--survey",
        &survey,
        "--init",
        "0.3,0.4,0",
        "--no-report",
        "--out",
        out2.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = json(&out2.join("result.json"));
    assert!(
        r.get("unfitted").is_none() && r.get("fit_absorbed").is_none(),
        "{}",
        r["unfitted"]
    );
}
