//! Autoware tiled maps end to end: the same map whole and as 20 m tiles gives
//! the same results from `eval` and the same crops from `crop`, and the crop
//! opens only the tiles near the targets.

use crate::util::{bin, stderr, stdout_ok, tempdir};
use mapgauge::cloud::{self, OutFormat, TiledMap};
use std::path::Path;

/// A synthetic scene's map written whole (in tile order) and as tiles;
/// returns (whole map, tile folder, survey).
fn scene(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf, std::path::PathBuf) {
    let s = dir.join("scene");
    stdout_ok(
        bin()
            .args([
                "synth", "--points", "400000", "--format", "pcd", "--seed", "1", "--out",
            ])
            .arg(&s),
    );
    let pts = cloud::read_all(&s.join("map.pcd")).unwrap();
    let tiles = dir.join("pointcloud_map");
    let m = cloud::write_tiles(&pts, &tiles, 20.0, OutFormat::Pcd).unwrap();
    assert!(m.tiles.len() > 20, "{} tiles", m.tiles.len());
    let whole = dir.join("whole.pcd");
    cloud::write(
        &whole,
        OutFormat::Pcd,
        &TiledMap::order_points(&pts, 20.0).unwrap(),
    )
    .unwrap();
    (whole, tiles, s.join("survey.csv"))
}

/// result.json without its `eval.map` and `eval.map_bytes` lines (the path
/// given, and the bytes of one file against the tiles with their headers).
fn result_without_map(out: &Path) -> String {
    std::fs::read_to_string(out.join("result.json"))
        .unwrap()
        .lines()
        .filter(|l| !l.trim_start().starts_with("\"map\": \"") && !l.contains("\"map_bytes\""))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn whole_and_tiled_maps_give_identical_results() {
    let dir = tempdir();
    let (whole, tiles, survey) = scene(dir.path());
    let meta = tiles.join("pointcloud_map_metadata.yaml");
    let mut outs = Vec::new();
    for (k, map) in [&whole, &tiles, &meta].into_iter().enumerate() {
        let out = dir.path().join(format!("out{k}"));
        let o = bin()
            .arg("eval")
            .arg("--map")
            .arg(map)
            .arg("--survey")
            .arg(&survey)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "eval {}: {}", map.display(), stderr(&o));
        outs.push(out);
    }
    let targets = std::fs::read_to_string(outs[0].join("targets.csv")).unwrap();
    assert_eq!(
        targets.lines().filter(|l| l.contains(",ok,")).count(),
        5,
        "{targets}"
    );
    let want = result_without_map(&outs[0]);
    let full = std::fs::read_to_string(outs[0].join("result.json")).unwrap();
    assert_eq!(
        full.lines().count(),
        want.lines().count() + 2,
        "two lines dropped"
    );
    for out in &outs[1..] {
        assert_eq!(result_without_map(out), want, "{}", out.display());
        for f in ["targets.csv", "pairs.csv"] {
            assert_eq!(
                std::fs::read(out.join(f)).unwrap(),
                std::fs::read(outs[0].join(f)).unwrap(),
                "{f}"
            );
        }
        // The report hashes the metadata and every tile.
        let html = std::fs::read_to_string(out.join("report.html")).unwrap();
        assert!(html.contains("pointcloud_map"), "report names the map");
    }
}

#[test]
fn a_crop_of_a_tiled_map_opens_only_the_near_tiles() {
    let dir = tempdir();
    let (whole, tiles, survey) = scene(dir.path());
    let n_tiles = TiledMap::discover(&tiles).unwrap().tiles.len();
    let mut files = Vec::new();
    for (k, map) in [&whole, &tiles].into_iter().enumerate() {
        let out = dir.path().join(format!("crop{k}"));
        let o = bin()
            .arg("crop")
            .arg("--map")
            .arg(map)
            .arg("--survey")
            .arg(&survey)
            .arg("--out")
            .arg(&out)
            .args(["--radius", "3", "--format", "pcd"])
            .output()
            .unwrap();
        assert!(o.status.success(), "crop: {}", stderr(&o));
        let err = stderr(&o);
        let line = err.lines().find(|l| l.starts_with("tiles: "));
        if k == 0 {
            assert!(line.is_none(), "{err}");
        } else {
            // Five targets 3 m wide: each reaches at most four 20 m tiles.
            let line = line.unwrap_or_else(|| panic!("no tile line: {err}"));
            let f: Vec<&str> = line.split_whitespace().collect();
            let (opened, total): (usize, usize) = (f[1].parse().unwrap(), f[3].parse().unwrap());
            assert_eq!(total, n_tiles, "{line}");
            assert!((5..=20).contains(&opened) && opened * 2 < total, "{line}");
        }
        let mut names: Vec<_> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        names.sort();
        files.push(
            names
                .iter()
                .map(|p| (p.file_name().unwrap().to_owned(), std::fs::read(p).unwrap()))
                .collect::<Vec<_>>(),
        );
    }
    assert_eq!(files[0].len(), 5);
    assert!(files[0] == files[1], "crops differ");
}
