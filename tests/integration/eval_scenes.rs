//! Acceptance of the whole pipeline on synthetic scenes with known truth:
//! `mapgauge synth` writes a LiDAR-like map, `mapgauge eval` measures it, and
//! the result is compared with the scene's true target positions.

use crate::truth::{Limits, Run};
use crate::util::{bin, synth_into, tempdir};
use serde_json::Value;
use std::panic::AssertUnwindSafe;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};

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

/// Synthesises a PCD scene with `synth` flags into `dir`, evaluates it, and
/// returns the run with its truth.
fn run(dir: &Path, synth: &[&str]) -> Run {
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
    let run = Run::read(&res.join("result.json"), &scene.join("truth.json"));
    assert_eq!(run.result["schema"], "mapgauge.result/1");
    run
}

/// The acceptance scenes: name, `synth` flags, limit on |z − truth z| (mm).
///
/// Measured per-target horizontal errors (mm, this code, these seeds): at most
/// 7.0 (4° slope), 6.7 (30 m), 6.4 (12 targets), others ≤ 5.9; scene medians
/// 2.0–4.6 (worst: clutter at 1.5 m). z (the middle of the plates' seen span
/// against the plates' centre height): within 27 mm at 5–15 m, where two or
/// three beam rows cross a 0.6 m plate (57 mm as the paper's mean height), and
/// 94 mm at 30 m, where one row does (138 mm; beams are 1.25° apart: 65 cm at
/// 30 m, so the row may cross anywhere), so there the bound is the plate's half
/// height.
const SCENES: [(&str, &[&str], f64); 8] = [
    ("default, seed 2", &["--seed", "2"], 80.0),
    ("default, seed 9", &["--seed", "9"], 80.0),
    (
        "clutter 1.5 m from each target",
        &["--seed", "3", "--near-clutter-m", "1.5"],
        80.0,
    ),
    (
        "bush touching a target",
        &["--seed", "4", "--bush-touching"],
        80.0,
    ),
    // E_rel 0.0247 against 0.0290 on this seed (per-target errors up to 7 mm, not
    // a bias: seeds 10–13 at 4° are within 0.7 mm).
    (
        "ground sloped 4°",
        &["--seed", "5", "--slope-deg", "4"],
        80.0,
    ),
    (
        "map tilted 0.5°",
        &["--seed", "6", "--tilt-deg", "0.5"],
        80.0,
    ),
    (
        "targets seen only from 30 m",
        &[
            "--seed",
            "7",
            "--target-distance-m",
            "28,32",
            "--points",
            "5000000",
        ],
        300.0,
    ),
    (
        "12 targets",
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
        80.0,
    ),
];

/// Limits for every scene (mm): each target, scene median, the scene's mean
/// error vector, the metrics against the truth's. See [`SCENES`] for what the
/// code achieves; README.md quotes these.
fn limits(z_mm: f64) -> Limits {
    Limits {
        each_mm: 9.0,
        median_mm: 5.5,
        bias_mm: 5.0,
        z_mm,
        metrics_mm: 5.0,
    }
}

/// Over all scenes' targets together, the mean error vector must be shorter than
/// this (mm). Measured: 0.8 mm over 52 targets. One scene's mean vector can reach
/// 3.7 mm (clutter at 1.5 m, 5 targets) without a bug, so a constant offset of a
/// few millimetres shows only in the pooled mean.
const POOLED_BIAS_MM: f64 = 2.0;

/// Every acceptance scene, synthesised and evaluated once for all the tests
/// here, two at a time (each eval uses every core; synth mostly one). A scene
/// whose synth or eval failed holds the failure.
fn scenes() -> &'static Vec<(&'static str, f64, Result<Run, String>)> {
    static CELL: OnceLock<Vec<(&'static str, f64, Result<Run, String>)>> = OnceLock::new();
    CELL.get_or_init(|| {
        let list: Vec<_> = SCENES.iter().collect();
        let next = AtomicUsize::new(0);
        let out = Mutex::new(Vec::new());
        std::thread::scope(|sc| {
            for _ in 0..2 {
                sc.spawn(|| {
                    loop {
                        let i = next.fetch_add(1, Ordering::SeqCst);
                        let Some(&&(name, flags, z)) = list.get(i) else {
                            break;
                        };
                        let dir = tempdir();
                        let r =
                            std::panic::catch_unwind(AssertUnwindSafe(|| run(dir.path(), flags)))
                                .map_err(|e| {
                                    e.downcast_ref::<String>()
                                        .cloned()
                                        .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                                        .unwrap_or_default()
                                });
                        if let Ok(r) = &r {
                            eprintln!("{name} {flags:?}:\n{}", r.describe());
                        }
                        out.lock().unwrap().push((i, name, z, r));
                    }
                });
            }
        });
        let mut v = out.into_inner().unwrap();
        v.sort_by_key(|x| x.0);
        v.into_iter().map(|(_, n, z, r)| (n, z, r)).collect()
    })
}

/// The scene `name` found every target within [`limits`].
fn accept(name: &str) {
    let (_, z, r) = scenes()
        .iter()
        .find(|s| s.0 == name)
        .unwrap_or_else(|| panic!("no scene {name}"));
    let run = r.as_ref().unwrap_or_else(|e| panic!("{name}: {e}"));
    if let Err(e) = run.check(&limits(*z)) {
        panic!("{name}: {e}\n{}", run.describe());
    }
}

/// The mean error vector over every target of every scene, and the count (mm).
fn pooled_bias(runs: &[&Run]) -> ((f64, f64), usize) {
    let errs: Vec<_> = runs
        .iter()
        .flat_map(|r| r.corner_errors().unwrap_or_default())
        .collect();
    let n = errs.len();
    let mean =
        |f: fn(&crate::truth::CornerError) -> f64| errs.iter().map(f).sum::<f64>() / n as f64;
    ((mean(|e| e.dx), mean(|e| e.dy)), n)
}

/// What the scenes must pass together: every scene accepted (the tests below say
/// which failed) and no common offset.
fn accept_all(runs: &[&Run]) -> Result<(), String> {
    for (run, (name, z, _)) in runs.iter().zip(scenes()) {
        run.check(&limits(*z)).map_err(|e| format!("{name}: {e}"))?;
    }
    let ((bx, by), n) = pooled_bias(runs);
    if bx.hypot(by) > POOLED_BIAS_MM {
        return Err(format!(
            "mean error vector over {n} targets ({bx:+.2}, {by:+.2}) mm, longer than {POOLED_BIAS_MM} mm: the corners are off by a constant"
        ));
    }
    Ok(())
}

fn all_runs() -> Vec<&'static Run> {
    scenes()
        .iter()
        .map(|(name, _, r)| r.as_ref().unwrap_or_else(|e| panic!("{name}: {e}")))
        .collect()
}

#[test]
fn default_scenes_several_seeds() {
    accept("default, seed 2");
    accept("default, seed 9");
}

#[test]
fn clutter_one_and_a_half_metres_from_a_target() {
    accept("clutter 1.5 m from each target");
}

#[test]
fn bush_touching_a_target() {
    accept("bush touching a target");
}

#[test]
fn ground_sloped_four_degrees() {
    accept("ground sloped 4°");
}

#[test]
fn map_tilted_half_a_degree() {
    accept("map tilted 0.5°");
}

#[test]
fn targets_seen_only_from_thirty_metres() {
    accept("targets seen only from 30 m");
}

#[test]
fn twelve_targets() {
    accept("12 targets");
}

#[test]
fn no_common_offset_over_all_scenes() {
    let runs = all_runs();
    let ((bx, by), n) = pooled_bias(&runs);
    eprintln!("pooled mean error vector over {n} targets: ({bx:+.2}, {by:+.2}) mm");
    accept_all(&runs).unwrap();
}

/// Every corner of every scene moved by the same 4.5 mm, in each of 8 directions:
/// the alignment absorbs it, so E_abs and E_rel do not move, but the check must fail.
/// So must one target moved by 30 mm.
#[test]
fn a_constant_corner_shift_is_caught() {
    let runs = all_runs();
    for k in 0..8 {
        let a = k as f64 * std::f64::consts::FRAC_PI_4;
        let (dx, dy) = (0.0045 * a.cos(), 0.0045 * a.sin());
        let shifted: Vec<Run> = runs.iter().map(|r| r.shifted(dx, dy)).collect();
        let refs: Vec<&Run> = shifted.iter().collect();
        let ((bx, by), _) = pooled_bias(&refs);
        assert!(
            bx.hypot(by) > POOLED_BIAS_MM,
            "a 4.5 mm shift at {}° leaves the pooled mean vector at {:.2} mm",
            k * 45,
            bx.hypot(by)
        );
        let e = accept_all(&refs).expect_err(&format!(
            "every corner moved by 4.5 mm at {}° passed",
            k * 45
        ));
        eprintln!("shift at {}°: {e}", k * 45);
    }
    let mut one = runs[0].shifted(0.0, 0.0);
    let t = &mut one.result["targets"][0]["map"]["x"];
    *t = Value::from(t.as_f64().unwrap() + 0.030);
    let e = one
        .check(&limits(80.0))
        .expect_err("one corner moved by 30 mm passed");
    eprintln!("one corner moved by 30 mm: {e}");
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

    // Told the map is in the survey frame, nothing is where the survey says:
    // a clear error, exit 1.
    let out = eval(&[
        os("--map"),
        map.as_os_str(),
        os("--survey"),
        survey.as_os_str(),
        os("--frame"),
        os("survey"),
    ]);
    assert_eq!(out.status.code(), Some(4));
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
    assert!(!String::from_utf8_lossy(&out.stderr).contains("the frame from --init"));

    // A wrong transform finds nothing where it points; detection takes over,
    // and the terminal says the --init given was not used.
    let out = eval(&[
        os("--map"),
        map.as_os_str(),
        os("--survey"),
        survey.as_os_str(),
        os("--init=100,100,120"),
        os("--format"),
        os("json"),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("warning: the frame from --init found 0 of 5 targets where it put them; the targets were detected in the map"),
        "{err}"
    );
    let m: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!((m["alignment"]["rotation_deg"].as_f64().unwrap() + 30.0).abs() < 0.05);

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
    assert_eq!(out.status.code(), Some(4));
    assert!(String::from_utf8_lossy(&out.stderr).starts_with("error: "));
    let bad = d.join("bad.csv");
    std::fs::write(&bad, "id,x,y\n1,2,3\n2,abc,4\n").unwrap();
    let out = eval(&[
        os("--map"),
        map.as_os_str(),
        os("--survey"),
        bad.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(4));
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
