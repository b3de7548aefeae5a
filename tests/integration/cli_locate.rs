//! `mapgauge locate` end to end on the tight crops that `mapgauge eval --save-crops`
//! writes, checked against the synthetic scene's truth; a one-plate crop is refused
//! with its reason and the exit status documented in src/cmd/locate.rs (0 when at
//! least one file was located, 1 when none was).

use crate::util::{bin, stderr, tempdir};
use mapgauge::Point;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::Output;
use std::sync::OnceLock;

/// One scene for all tests: synth (1 M points; 300 k is too sparse for the tight
/// crop) and `eval --save-crops`. Lives under Cargo's target tmp dir (`cargo clean`
/// removes what is left).
struct Scene {
    _dir: tempfile::TempDir,
    root: PathBuf,
    /// Truth map-frame corners by id.
    truth: BTreeMap<String, [f64; 3]>,
}

fn scene() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| {
        let dir = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
        let root = dir.path().to_path_buf();
        let s = root.join("scene");
        let o = bin()
            .args(["synth", "--points", "1000000", "--format", "pcd", "--out"])
            .arg(&s)
            .output()
            .unwrap();
        assert!(o.status.success(), "synth: {}", stderr(&o));
        let o = bin()
            .arg("eval")
            .arg("--map")
            .arg(s.join("map.pcd"))
            .arg("--survey")
            .arg(s.join("survey.csv"))
            .arg("--out")
            .arg(root.join("eval"))
            .arg("--save-crops")
            .output()
            .unwrap();
        assert!(o.status.success(), "eval: {}", stderr(&o));
        // A static is never dropped: keep only what the tests read (crops, truth),
        // not the 24 MB map, in target/tmp.
        std::fs::remove_file(s.join("map.pcd")).unwrap();
        let truth: serde_json::Value =
            serde_json::from_slice(&std::fs::read(s.join("truth.json")).unwrap()).unwrap();
        let truth = truth["targets"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| {
                let m: Vec<f64> = t["map"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_f64().unwrap())
                    .collect();
                (t["id"].as_str().unwrap().to_string(), [m[0], m[1], m[2]])
            })
            .collect();
        Scene {
            _dir: dir,
            root,
            truth,
        }
    })
}

fn tight_crops(s: &Scene) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(s.root.join("eval/crops/tight"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}

fn locate(args: &[&str], files: &[PathBuf]) -> Output {
    bin().arg("locate").args(args).args(files).output().unwrap()
}

#[test]
fn csv_has_a_row_per_file_within_2_cm_of_the_truth() {
    let s = scene();
    let files = tight_crops(s);
    assert_eq!(files.len(), s.truth.len(), "a tight crop per target");
    let o = locate(&["--format", "csv"], &files);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    let mut rd = csv::Reader::from_reader(text.as_bytes());
    let head: Vec<String> = rd.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(head[..4], ["id", "x", "y", "z"], "{text}");
    let col = |name: &str| head.iter().position(|h| h == name).expect(name);
    let (status, reason) = (col("status"), col("reason"));
    let rows: Vec<csv::StringRecord> = rd.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), files.len(), "{text}");
    for (r, f) in rows.iter().zip(&files) {
        let id = &r[0];
        assert_eq!(
            Some(id),
            f.file_stem().and_then(|s| s.to_str()),
            "rows in file order"
        );
        assert_eq!(&r[status], "ok", "{id}: {}", &r[reason]);
        let p: Vec<f64> = (1..4).map(|k| r[k].parse().unwrap()).collect();
        let t = s.truth[id];
        let dh = ((p[0] - t[0]).powi(2) + (p[1] - t[1]).powi(2)).sqrt();
        // The corner is a vertical line; its horizontal position is what is measured.
        // z is the mean height of the plates' points, within the plates' 0.6 m.
        assert!(dh < 0.02, "target {id}: horizontal error {dh:.4} m");
        assert!(
            (p[2] - t[2]).abs() < 0.3,
            "target {id}: z {} vs {}",
            p[2],
            t[2]
        );
    }
}

#[test]
fn table_and_json_agree_with_csv() {
    let s = scene();
    let files = tight_crops(s);
    let table = locate(&[], &files);
    assert!(table.status.success(), "{}", stderr(&table));
    let table = String::from_utf8(table.stdout).unwrap();
    assert_eq!(table.lines().count(), files.len() + 1, "{table}");
    assert!(table.lines().next().unwrap().starts_with("id"), "{table}");
    let json = locate(&["--format", "json"], &files);
    let json: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    let json = json.as_array().unwrap();
    assert_eq!(json.len(), files.len());
    let csv = String::from_utf8(locate(&["--format", "csv"], &files).stdout).unwrap();
    for (row, (j, line)) in csv
        .lines()
        .skip(1)
        .zip(json.iter().zip(table.lines().skip(1)))
    {
        let f: Vec<&str> = row.split(',').collect();
        assert_eq!(j["id"].as_str(), Some(f[0]));
        assert_eq!(j["status"].as_str(), Some("ok"));
        let x: f64 = f[1].parse().unwrap();
        let jx = j["corner"][0].as_f64().or(j["corner"]["x"].as_f64());
        assert!((jx.expect("corner x in json") - x).abs() < 1e-4, "{j}");
        assert!(
            line.starts_with(f[0]) && line.contains(f[1]),
            "{line} vs {row}"
        );
    }
}

/// Keeps the points of the crop's biggest plate: the points more than 10 cm from
/// the true corner (horizontally), whose bearing is within 25° of the most common
/// bearing.
fn one_plate(points: &[Point], corner: [f64; 3]) -> Vec<Point> {
    let bearing = |p: &Point| (p.y - corner[1]).atan2(p.x - corner[0]).to_degrees();
    let far: Vec<&Point> = points
        .iter()
        .filter(|p| (p.x - corner[0]).hypot(p.y - corner[1]) > 0.1)
        .collect();
    let mut hist = [0usize; 36];
    for p in &far {
        hist[((bearing(p) + 180.0) / 10.0).floor().clamp(0.0, 35.0) as usize] += 1;
    }
    let best = (0..36).max_by_key(|&i| hist[i]).unwrap();
    let mode = best as f64 * 10.0 + 5.0 - 180.0;
    far.into_iter()
        .filter(|p| {
            let d = (bearing(p) - mode + 540.0).rem_euclid(360.0) - 180.0;
            d.abs() < 25.0
        })
        .copied()
        .collect()
}

#[test]
fn a_single_plate_is_reported_with_its_reason() {
    let s = scene();
    let files = tight_crops(s);
    let good = &files[0];
    let id = good.file_stem().unwrap().to_str().unwrap();
    let pts = mapgauge::cloud::read_all(good).unwrap();
    let plate = one_plate(&pts, s.truth[id]);
    assert!(
        plate.len() > 30 && plate.len() < pts.len() * 3 / 4,
        "{} of {} points kept",
        plate.len(),
        pts.len()
    );
    let dir = tempdir();
    let bad = dir.path().join("plate.ply");
    mapgauge::cloud::write(&bad, mapgauge::cloud::OutFormat::Ply, &plate).unwrap();

    // Alone: nothing located → exit 1, the reason as a warning, then one error line.
    let o = locate(&["--format", "csv"], std::slice::from_ref(&bad));
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(4), "{err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 2, "{err}");
    assert!(
        lines[0].starts_with("warning: ") && lines[0].contains("plate.ply"),
        "{err}"
    );
    assert!(lines[1].starts_with("error: "), "{err}");
    let out = String::from_utf8(o.stdout).unwrap();
    let row = out.lines().nth(1).expect("a row for the failed file");
    assert!(row.starts_with("plate,,,,"), "{row}");
    assert!(row.contains(",not_found,"), "{row}");
    let reason = row.split(",not_found,").nth(1).unwrap();
    assert!(reason.contains("one plate"), "reason: {row}");
    assert!(lines[0].ends_with(reason), "{err}");

    // With a good crop: exit 0, the good row ok, the bad row with the same reason.
    let o = locate(&["--format", "csv"], &[good.clone(), bad.clone()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8(o.stdout).unwrap();
    let rows: Vec<&str> = out.lines().skip(1).collect();
    assert_eq!(rows.len(), 2, "{out}");
    assert!(
        rows[0].starts_with(&format!("{id},")) && rows[0].ends_with(",ok,"),
        "{out}"
    );
    assert!(rows[1].ends_with(reason), "{out}");
}

#[test]
fn unreadable_file_is_a_row_not_a_crash() {
    let s = scene();
    let files = tight_crops(s);
    let dir = tempdir();
    let missing = dir.path().join("missing.ply");
    let o = locate(&["--format", "csv"], &[missing.clone(), files[1].clone()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8(o.stdout).unwrap();
    assert!(out.lines().nth(1).unwrap().starts_with("missing,"), "{out}");
    assert!(out.contains("not_found"), "{out}");
    let o = locate(&[], &[missing]);
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(stderr(&o).contains("missing.ply"), "{}", stderr(&o));
}

/// A tight crop of bigger plates (the scene's scaled ×4 about its corner: at
/// least 2.4 m across whatever its heading, wider than any crop of 0.6 m
/// plates) is refused as a loose crop by default and located with
/// `--plate-size`, its corner where the scaled one is.
#[test]
fn plate_size_reaches_the_loose_crop_check() {
    let s = scene();
    let files = tight_crops(s);
    let good = &files[0];
    let id = good.file_stem().unwrap().to_str().unwrap();
    let c = s.truth[id];
    let corner = Point::new(c[0], c[1], c[2]);
    let big: Vec<Point> = mapgauge::cloud::read_all(good)
        .unwrap()
        .iter()
        .map(|p| corner + (p - corner) * 4.0)
        .collect();
    let dir = tempdir();
    let file = dir.path().join("big.ply");
    mapgauge::cloud::write(&file, mapgauge::cloud::OutFormat::Ply, &big).unwrap();
    let o = locate(&["--format", "csv"], std::slice::from_ref(&file));
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("looks like a loose crop"),
        "{}",
        stderr(&o)
    );
    let o = locate(
        &["--format", "csv", "--plate-size", "2.4"],
        std::slice::from_ref(&file),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8(o.stdout).unwrap();
    let row: Vec<&str> = out.lines().nth(1).expect("a row").split(',').collect();
    let got = [row[1], row[2]].map(|v| v.parse::<f64>().unwrap());
    let d = ((got[0] - c[0]).powi(2) + (got[1] - c[1]).powi(2)).sqrt();
    assert!(d < 0.08, "corner {d:.3} m from the scaled truth: {out}");
}
