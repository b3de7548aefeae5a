//! Issue 33: target models beside the L. A survey mixing Ls and spheres
//! (synth's spheres on poles) is evaluated end to end: every sphere found
//! near its true centre with a covariance that covers the error, the Ls as
//! before; a survey naming a model mapgauge cannot locate says so per
//! target; a bad model or size is refused with its line.

use crate::util::{bin, stderr, tempdir};
use nalgebra::{Matrix3, Vector3};
use serde_json::Value;
use std::path::Path;

fn synth(scene: &Path, seed: &str) -> Value {
    synth_with(scene, seed, &[])
}

fn synth_with(scene: &Path, seed: &str, extra: &[&str]) -> Value {
    let out = bin()
        .arg("synth")
        .arg("--out")
        .arg(scene)
        .args(["--points", "4000000", "--seed", seed])
        .args(extra)
        .args(["--range-noise-m", "0.01", "--models", "l,sphere"])
        .output()
        .unwrap();
    assert!(out.status.success(), "synth: {}", stderr(&out));
    serde_json::from_slice(&std::fs::read(scene.join("truth.json")).unwrap()).unwrap()
}

fn eval(scene: &Path, survey: &Path, out: &Path) -> std::process::Output {
    bin()
        .arg("eval")
        .arg("--map")
        .arg(scene.join("map.ply"))
        .arg("--survey")
        .arg(survey)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

fn json(p: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

fn v3(v: &Value) -> Vector3<f64> {
    Vector3::new(
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    )
}

/// Seeds 1 and 3 level; seed 3 again on a map leaning 1°, which the Ls'
/// plumb lines level: the spheres' estimates turn with the frame (they were
/// once located again as Ls there).
#[test]
fn spheres_and_ls_in_one_survey() {
    for (seed, extra) in [
        ("1", &[][..]),
        ("3", &[][..]),
        ("3", &["--tilt-deg", "1.0"][..]),
    ] {
        let dir = tempdir();
        let (scene, out) = (dir.path().join("scene"), dir.path().join("out"));
        let truth = synth_with(&scene, seed, extra);
        let survey = std::fs::read_to_string(scene.join("survey.csv")).unwrap();
        assert!(
            survey.starts_with("id,x,y,z,antenna_height,model,size\n"),
            "{survey}"
        );
        assert!(survey.contains(",sphere,0.145\n"), "{survey}");
        let o = eval(&scene, &scene.join("survey.csv"), &out);
        assert!(o.status.success(), "eval: {}", stderr(&o));
        let r = json(&out.join("result.json"));
        if !extra.is_empty() {
            let tilt = r["eval"]["frame"]["levelling"]["tilt_deg"]
                .as_f64()
                .unwrap();
            assert!(tilt > 0.5, "the leaning map was not levelled: {tilt}");
        }
        let mut spheres = 0;
        for (t, d) in r["targets"]
            .as_array()
            .unwrap()
            .iter()
            .zip(r["eval"]["targets"].as_array().unwrap())
        {
            assert_eq!(
                t["status"], "ok",
                "seed {seed} target {}: {}",
                t["id"], t["reason"]
            );
            let tt = truth["targets"]
                .as_array()
                .unwrap()
                .iter()
                .find(|x| x["id"] == t["id"])
                .unwrap();
            if tt["model"] != "sphere" {
                assert!(d.get("model").is_none() && d.get("sphere").is_none(), "{d}");
                continue;
            }
            spheres += 1;
            assert_eq!(d["model"], "sphere");
            let s = &d["sphere"];
            assert!(s["inliers"].as_u64().unwrap() >= 30, "{s}");
            assert!(
                (s["free_radius"].as_f64().unwrap() - 0.0725).abs() < 0.006,
                "{s}"
            );
            // The centre against the truth (both in the map's frame), and
            // against its own covariance: within the 99.9 % ellipsoid.
            let e = v3(&d["corner_in_map"]) - v3(&tt["map"]);
            assert!(
                e.norm() < 0.01,
                "seed {seed} sphere {}: {:.1} mm off",
                t["id"],
                e.norm() * 1e3
            );
            let c = &t["map_covariance"];
            let cov = Matrix3::from_fn(|i, j| c[i][j].as_f64().unwrap());
            let m2 = e.dot(&(cov.try_inverse().unwrap() * e));
            assert!(
                m2 < 16.27,
                "seed {seed} sphere {}: error {e:?} outside its ellipsoid (m² {m2:.1}, cov {cov:?})",
                t["id"]
            );
        }
        assert_eq!(spheres, 2);
        let csv = std::fs::read_to_string(out.join("targets.csv")).unwrap();
        assert_eq!(
            csv.lines().filter(|l| l.contains(",ok,")).count(),
            5,
            "{csv}"
        );
    }
}

#[test]
fn boards_are_reported_not_located_and_bad_models_refused() {
    let dir = tempdir();
    let (scene, out) = (dir.path().join("scene"), dir.path().join("out"));
    synth(&scene, "2");
    let text = std::fs::read_to_string(scene.join("survey.csv")).unwrap();
    // Target 2, a sphere, surveyed as a board instead.
    let board = dir.path().join("board.csv");
    std::fs::write(&board, text.replacen(",sphere,0.145\n", ",board,0.6\n", 1)).unwrap();
    let o = eval(&scene, &board, &out);
    assert!(o.status.success(), "eval: {}", stderr(&o));
    let r = json(&out.join("result.json"));
    let t2 = &r["targets"][1];
    assert_eq!(t2["status"], "not_found");
    assert!(
        t2["reason"]
            .as_str()
            .unwrap()
            .contains("does not locate board targets yet"),
        "{t2}"
    );
    assert_eq!(r["eval"]["targets"][1]["model"], "board");

    for (bad, says) in [
        (",sphere,0.145\n", ",cone,\n"),
        (",sphere,0.145\n", ",sphere,145\n"),
    ] {
        let f = dir.path().join("bad.csv");
        std::fs::write(&f, text.replacen(bad, says, 1)).unwrap();
        let o = eval(&scene, &f, &dir.path().join("bad"));
        assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("bad.csv:3:"), "{e}");
        assert!(
            e.contains("`cone`") || e.contains("size 145 m is outside 0.05..1 m"),
            "{e}"
        );
    }
}
