//! A COPC map end to end (issue 29): eval finds each target in the coarse
//! levels of the octree near it, then locates it in every level within a
//! plate of what it found (`crops-detail`), with the corners of a read of
//! every level; a target the coarse levels do not show is searched in every
//! level of its whole crop (`crops-whole`).

use crate::util::{bin, stdout_ok, tempdir};
use std::path::{Path, PathBuf};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/copc-synth4")
}

/// `eval` of the committed COPC scene with `[crop]` set to `crop`: its
/// result.json.
fn eval_with(dir: &Path, name: &str, crop: &str) -> serde_json::Value {
    let cfg = dir.join(format!("{name}.toml"));
    std::fs::write(&cfg, format!("[crop]\n{crop}\n")).unwrap();
    let out = dir.join(name);
    stdout_ok(
        bin()
            .arg("eval")
            .arg("--map")
            .arg(data().join("map.copc.laz"))
            .arg("--survey")
            .arg(data().join("survey.csv"))
            .arg("--config")
            .arg(&cfg)
            .arg("--no-report")
            .arg("--out")
            .arg(&out),
    );
    serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap()
}

/// Bytes read per pass.
fn reads(r: &serde_json::Value) -> Vec<(String, u64)> {
    r["eval"]["reads"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            (
                p["pass"].as_str().unwrap().to_string(),
                p["bytes"].as_u64().unwrap(),
            )
        })
        .collect()
}

fn corners(r: &serde_json::Value) -> Vec<[f64; 3]> {
    r["eval"]["targets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            let c = t["corner_in_map"].as_array().expect("every target located");
            [0, 1, 2].map(|k| c[k].as_f64().unwrap())
        })
        .collect()
}

#[test]
fn eval_of_a_copc_map_finds_in_coarse_levels_and_locates_in_every_one() {
    let dir = tempdir();
    let every = eval_with(dir.path(), "every", "by_level = false");
    let whole: u64 = reads(&every)
        .iter()
        .filter(|r| r.0 == "crops")
        .map(|r| r.1)
        .sum();
    assert_eq!(corners(&every).len(), 4);
    // Coarse levels of 1 500 points or more near each target (the levels
    // read hold ~8 k of the ~60 k of each crop): all four found there,
    // located in every level near them, the same corners, fewer bytes read.
    let coarse = eval_with(dir.path(), "coarse", "coarse_points = 1000");
    let r = reads(&coarse);
    let passes: Vec<&str> = r.iter().map(|p| p.0.as_str()).collect();
    assert_eq!(passes, ["ground", "crops", "crops-detail"], "{r:?}");
    assert_eq!(corners(&coarse), corners(&every));
    let read: u64 = r[1..].iter().map(|p| p.1).sum();
    assert!(read < whole && r[1].1 * 4 < whole, "{r:?} against {whole}");
    for t in coarse["eval"]["targets"].as_array().unwrap() {
        let d = t["detail_radius_m"].as_f64().expect("located in detail");
        assert!((1.0..1.2).contains(&d), "{t}");
    }
    // Coarse levels of a few points show no L: each target searched in
    // every level of its crop, as in a map without levels.
    let sparse = eval_with(dir.path(), "sparse", "coarse_points = 20");
    let r = reads(&sparse);
    assert!(r.iter().any(|p| p.0 == "crops-whole"), "{r:?}");
    assert!(!r.iter().any(|p| p.0 == "crops-detail"), "{r:?}");
    for t in sparse["eval"]["targets"].as_array().unwrap() {
        assert!(t.get("detail_radius_m").is_none(), "{t}");
    }
    assert_eq!(corners(&sparse), corners(&every));
    // The default wants more points than these crops' coarse levels hold:
    // every level is read, as `by_level = false` does.
    let default = eval_with(dir.path(), "default", "");
    assert_eq!(reads(&default), reads(&every));
    assert_eq!(corners(&default), corners(&every));
}
