//! Acceptance of the whole pipeline on synthetic scenes with known truth:
//! `mapgauge synth` writes a LiDAR-like map, `mapgauge eval` measures it, and
//! the result is compared with the scene's true target positions.

use crate::util::{bin, tempdir};
use serde_json::Value;
use std::path::Path;

struct Outcome {
    found: usize,
    total: usize,
    errors_mm: Vec<f64>,
    e_abs: (f64, f64),
    e_rel: (f64, f64),
}

/// Runs `mapgauge synth --out SCENE ARGS...`, which must succeed.
fn synth_into(scene: &Path, args: &[&str]) {
    let out = bin()
        .arg("synth")
        .arg("--out")
        .arg(scene)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "synth: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs `mapgauge eval` on a scene's map and survey into `res` with `threads`
/// rayon threads (None: the default); must succeed.
fn eval_into(map: &Path, survey: &Path, res: &Path, threads: Option<&str>) {
    let mut cmd = bin();
    if let Some(t) = threads {
        cmd.env("RAYON_NUM_THREADS", t);
    }
    let out = cmd
        .arg("eval")
        .arg("--map")
        .arg(map)
        .arg("--survey")
        .arg(survey)
        .arg("--out")
        .arg(res)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "eval: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn run(dir: &Path, synth: &[&str]) -> Outcome {
    let scene = dir.join("scene");
    let mut args = vec!["--format", "pcd"];
    args.extend_from_slice(synth);
    synth_into(&scene, &args);
    let res = dir.join("eval");
    eval_into(
        &scene.join("map.pcd"),
        &scene.join("survey.csv"),
        &res,
        None,
    );
    let truth: Value =
        serde_json::from_slice(&std::fs::read(scene.join("truth.json")).unwrap()).unwrap();
    let result: Value =
        serde_json::from_slice(&std::fs::read(res.join("result.json")).unwrap()).unwrap();
    assert_eq!(result["schema"], "mapgauge.result/1");
    let mut errors_mm = Vec::new();
    let targets = result["targets"].as_array().unwrap();
    for t in targets {
        if t["status"] != "ok" {
            eprintln!("target {} not found: {}", t["id"], t["reason"]);
            continue;
        }
        let tt = truth["targets"]
            .as_array()
            .unwrap()
            .iter()
            .find(|x| x["id"] == t["id"])
            .unwrap();
        let dx = t["map"]["x"].as_f64().unwrap() - tt["map"][0].as_f64().unwrap();
        let dy = t["map"]["y"].as_f64().unwrap() - tt["map"][1].as_f64().unwrap();
        errors_mm.push(dx.hypot(dy) * 1000.0);
    }
    errors_mm.sort_by(f64::total_cmp);
    let ex = &truth["expected"];
    let o = Outcome {
        found: errors_mm.len(),
        total: targets.len(),
        e_abs: (
            result["absolute"]["mean"].as_f64().unwrap(),
            ex["absolute"]["mean"].as_f64().unwrap(),
        ),
        e_rel: (
            result["relative"]["mean"].as_f64().unwrap(),
            ex["relative"]["mean"].as_f64().unwrap(),
        ),
        errors_mm,
    };
    eprintln!(
        "{:?}: found {}/{}, localisation error median {:.1} mm max {:.1} mm, E_abs {:.4} (truth {:.4}), E_rel {:.4} (truth {:.4})",
        synth,
        o.found,
        o.total,
        o.errors_mm
            .get(o.errors_mm.len() / 2)
            .copied()
            .unwrap_or(f64::NAN),
        o.errors_mm.last().copied().unwrap_or(f64::NAN),
        o.e_abs.0,
        o.e_abs.1,
        o.e_rel.0,
        o.e_rel.1
    );
    o
}

/// The acceptance: every target found, median localisation error
/// ≤ 1 cm, E_abs and E_rel within `tol_mm` of the truth.
fn accept(synth: &[&str], tol_abs_mm: f64, tol_rel_mm: f64) {
    let dir = tempdir();
    let o = run(dir.path(), synth);
    assert_eq!(o.found, o.total, "{synth:?}: not every target found");
    let median = o.errors_mm[o.errors_mm.len() / 2];
    assert!(
        median <= 10.0,
        "{synth:?}: median localisation error {median:.1} mm"
    );
    assert!(
        (o.e_abs.0 - o.e_abs.1).abs() * 1000.0 <= tol_abs_mm,
        "{synth:?}: E_abs {:.4} vs truth {:.4}",
        o.e_abs.0,
        o.e_abs.1
    );
    assert!(
        (o.e_rel.0 - o.e_rel.1).abs() * 1000.0 <= tol_rel_mm,
        "{synth:?}: E_rel {:.4} vs truth {:.4}",
        o.e_rel.0,
        o.e_rel.1
    );
}

#[test]
fn default_scenes_several_seeds() {
    for seed in ["2", "9"] {
        accept(&["--seed", seed], 5.0, 5.0);
    }
}

#[test]
fn clutter_one_and_a_half_metres_from_a_target() {
    accept(&["--seed", "3", "--near-clutter-m", "1.5"], 5.0, 5.0);
}

#[test]
fn bush_touching_a_target() {
    accept(&["--seed", "4", "--bush-touching"], 5.0, 5.0);
}

#[test]
fn ground_sloped_four_degrees() {
    // Measured: E_rel 0.0247 against 0.0290 on this seed (per-target errors up to
    // 7 mm, not a bias: seeds 10–13 at 4° are within 0.7 mm).
    accept(&["--seed", "5", "--slope-deg", "4"], 5.0, 5.0);
}

#[test]
fn map_tilted_half_a_degree() {
    accept(&["--seed", "6", "--tilt-deg", "0.5"], 5.0, 5.0);
}

#[test]
fn targets_seen_only_from_thirty_metres() {
    accept(
        &[
            "--seed",
            "7",
            "--target-distance-m",
            "28,32",
            "--points",
            "5000000",
        ],
        5.0,
        5.0,
    );
}

#[test]
fn twelve_targets() {
    accept(
        &[
            "--seed",
            "8",
            "--targets",
            "12",
            "--spread-m",
            "200",
            "--points",
            "4000000",
        ],
        5.0,
        5.0,
    );
}

fn eval(args: &[&std::ffi::OsStr]) -> std::process::Output {
    bin().arg("eval").args(args).output().unwrap()
}

#[test]
fn init_transform_hand_crops_and_failures() {
    let dir = tempdir();
    let d = dir.path();
    let scene = d.join("scene");
    // A map 30° and ~50 m away from the survey frame.
    synth_into(
        &scene,
        &[
            "--seed",
            "11",
            "--points",
            "1000000",
            "--yaw-deg",
            "30",
            "--offset-m",
            "40,-25,1",
        ],
    );
    let (map, survey) = (scene.join("map.ply"), scene.join("survey.csv"));
    let os = |s: &'static str| std::ffi::OsStr::new(s);

    // Without --init nothing is where the survey says: a clear error, exit 1.
    let out = eval(&[
        os("--map"),
        map.as_os_str(),
        os("--survey"),
        survey.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--init") && err.contains("targets found"),
        "{err}"
    );

    // An approximate transform (off by 2° and ~1.5 m) finds them all; the
    // second pass picks up the ones the first missed.
    let res = d.join("res");
    let out = eval(&[
        os("--map"),
        map.as_os_str(),
        os("--survey"),
        survey.as_os_str(),
        os("--init=-14,65,-28"),
        os("--save-crops"),
        os("--out"),
        res.as_os_str(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: Value =
        serde_json::from_slice(&std::fs::read(res.join("result.json")).unwrap()).unwrap();
    assert!(
        r["targets"]
            .as_array()
            .unwrap()
            .iter()
            .all(|t| t["status"] == "ok")
    );
    assert!((r["alignment"]["rotation_deg"].as_f64().unwrap() + 30.0).abs() < 0.05);
    assert!(r["absolute"]["mean"].as_f64().unwrap() < 0.05);

    // The paper's manual workflow: the tight crops as hand-made crops give the
    // same targets; a missing crop is reported, not fatal.
    let crops = res.join("crops").join("tight");
    std::fs::remove_file(crops.join("5.ply")).unwrap();
    let out = eval(&[
        os("--map"),
        map.as_os_str(),
        os("--survey"),
        survey.as_os_str(),
        os("--init=-14,65,-28"),
        os("--crops"),
        crops.as_os_str(),
        os("--format"),
        os("json"),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let m: Value = serde_json::from_slice(&out.stdout).unwrap();
    let status: Vec<&str> = m["targets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["status"].as_str().unwrap())
        .collect();
    assert_eq!(status, ["ok", "ok", "ok", "ok", "not_found"]);
    for (a, b) in m["targets"]
        .as_array()
        .unwrap()
        .iter()
        .zip(r["targets"].as_array().unwrap())
        .take(4)
    {
        let dx = a["map"]["x"].as_f64().unwrap() - b["map"]["x"].as_f64().unwrap();
        assert!(dx.abs() < 0.01, "{} manual vs automatic: {dx}", a["id"]);
    }
    assert!(String::from_utf8_lossy(&out.stderr).contains("5.ply"));

    // A map that does not exist, a survey with a bad row: exit 1, one line.
    let out = eval(&[
        os("--map"),
        d.join("nope.pcd").as_os_str(),
        os("--survey"),
        survey.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).starts_with("error: "));
    let bad = d.join("bad.csv");
    std::fs::write(&bad, "id,x,y\n1,2,3\n2,abc,4\n").unwrap();
    let out = eval(&[
        os("--map"),
        map.as_os_str(),
        os("--survey"),
        bad.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.csv:3"), "{err}");

    // Paper-style table across two runs.
    let out = bin()
        .args(["table", "--format", "latex", "--names", "a,b"])
        .arg(res.join("result.json"))
        .arg(res.join("result.json"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let t = String::from_utf8_lossy(&out.stdout);
    assert!(t.contains("toprule") && t.contains("t1 \\& t2"), "{t}");
}

#[test]
fn same_input_same_bytes() {
    let dir = tempdir();
    let d = dir.path();
    let scene = d.join("scene");
    synth_into(&scene, &["--seed", "12", "--points", "600000"]);
    let run = |name: &str, threads: &str| {
        let res = d.join(name);
        eval_into(
            &scene.join("map.ply"),
            &scene.join("survey.csv"),
            &res,
            Some(threads),
        );
        std::fs::read(res.join("result.json")).unwrap()
    };
    let a = run("a", "1");
    let b = run("b", "2");
    let c = run("c", "2");
    assert!(
        a == b && b == c,
        "result.json differs between runs or thread counts"
    );
}
