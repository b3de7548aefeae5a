//! Autoware tiled maps end to end: the same map whole and as 20 m tiles gives
//! the same results from `eval` and the same crops from `crop`, and the crop
//! opens only the tiles near the targets.

use crate::util::{bin, stderr, stdout_ok, tempdir};
use mapgauge::Point;
use mapgauge::cloud::{self, OutFormat, TiledMap};
use mapgauge::survey::{Geodetic, Projector, SurveyOptions, read_survey};
use std::path::Path;

/// A synthetic scene's map (`synth` with `more` arguments) written whole (in
/// tile order) and as tiles; returns (whole map, tile folder, survey).
fn scene_with(
    dir: &Path,
    more: &[&str],
) -> (std::path::PathBuf, std::path::PathBuf, std::path::PathBuf) {
    let s = dir.join("scene");
    stdout_ok(
        bin()
            .args([
                "synth", "--points", "400000", "--format", "pcd", "--seed", "1", "--out",
            ])
            .arg(&s)
            .args(more),
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

fn scene(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf, std::path::PathBuf) {
    scene_with(dir, &[])
}

/// result.json without its `eval.map`, `eval.map_bytes` and `eval.reads`
/// (the path given, the bytes of one file against the tiles with their
/// headers, and what each pass read: a tiled map's crops open fewer tiles).
fn result_without_map(out: &Path) -> String {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    let eval = v["eval"].as_object_mut().unwrap();
    for k in ["map", "map_bytes", "reads"] {
        assert!(eval.remove(k).is_some(), "eval.{k} missing");
    }
    serde_json::to_string_pretty(&v).unwrap()
}

/// `eval.reads` of a run: (pass, points, bytes).
fn reads(out: &Path) -> Vec<(String, u64, u64)> {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    v["eval"]["reads"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r["pass"].as_str().unwrap().to_string(),
                r["points"].as_u64().unwrap(),
                r["bytes"].as_u64().unwrap(),
            )
        })
        .collect()
}

#[test]
fn whole_and_tiled_maps_give_identical_results() {
    let dir = tempdir();
    let (whole, tiles, survey) = scene(dir.path());
    let meta = tiles.join("pointcloud_map_metadata.yaml");
    let outs = same_results(dir.path(), &[&whole, &tiles, &meta], &survey);
    // Issue 29: result.json says what each pass read. The whole file is read
    // whole by both passes; the tiled map's ground pass reads every tile and
    // its crops only the tiles near the targets.
    let whole_reads = reads(&outs[0]);
    let tiled_reads = reads(&outs[1]);
    let passes = |r: &[(String, u64, u64)]| r.iter().map(|p| p.0.clone()).collect::<Vec<_>>();
    assert_eq!(passes(&whole_reads), ["ground", "crops"], "{whole_reads:?}");
    assert_eq!(passes(&tiled_reads), ["ground", "crops"], "{tiled_reads:?}");
    let map_bytes = std::fs::metadata(&whole).unwrap().len();
    assert!(
        whole_reads.iter().all(|r| r.2 == map_bytes),
        "{whole_reads:?}"
    );
    assert_eq!(whole_reads[0].1, whole_reads[1].1);
    assert_eq!(
        tiled_reads[0].1, whole_reads[0].1,
        "the ground pass reads every point"
    );
    // (This scene's targets reach 57 % of its points' tiles.)
    assert!(
        tiled_reads[1].2 < tiled_reads[0].2 * 3 / 4 && tiled_reads[1].1 < tiled_reads[0].1 * 3 / 4,
        "the crops read the tiles near the targets only: {tiled_reads:?}"
    );
}

/// Issue 29: with a ground sample of a fifth of the map (`frame.ground_sample`),
/// eval's ground pass reads every k-th tile of a tiled map and every k-th
/// block of a whole file's records, and the results are the whole map's (the
/// scene does not lean: the ground's vertical turns nothing).
#[test]
fn a_sampled_ground_pass_reads_part_of_the_map_and_changes_nothing() {
    let dir = tempdir();
    let (whole, tiles, survey) = scene(dir.path());
    let cfg = dir.path().join("sample.toml");
    std::fs::write(&cfg, "[frame]\nground_sample = 80000\n").unwrap();
    let run = |map: &Path, config: Option<&Path>, name: &str| {
        let out = dir.path().join(name);
        let mut c = bin();
        c.arg("eval")
            .arg("--map")
            .arg(map)
            .arg("--survey")
            .arg(&survey);
        c.arg("--out").arg(&out).arg("--no-report");
        if let Some(cfg) = config {
            c.arg("--config").arg(cfg);
        }
        let o = c.output().unwrap();
        assert!(o.status.success(), "eval {}: {}", map.display(), stderr(&o));
        out
    };
    let base = run(&whole, None, "base");
    // Less the map's point count (no pass reads every tile) and the ground's
    // own estimate (a sample's vertical and centre; this map is read as it is
    // whatever they are), checked on their own below.
    let without = |out: &Path| {
        let mut v: serde_json::Value = serde_json::from_str(&result_without_map(out)).unwrap();
        v["eval"].as_object_mut().unwrap().remove("map_points");
        // The echoed configuration differs by the setting under test.
        let cfg = v["eval"].as_object_mut().unwrap().remove("config").unwrap();
        assert!(cfg["frame"]["ground_sample"].as_u64().is_some());
        let lev = v["eval"]["frame"]["levelling"].as_object_mut().unwrap();
        let ground = [
            "ground_tilt_deg",
            "ground_azimuth_deg",
            "ground_support",
            "origin",
        ]
        .map(|k| lev.remove(k).unwrap());
        (v, ground)
    };
    let (want, whole_ground) = without(&base);
    let all_points = reads(&base)[0].1;
    let tiles_bytes: u64 = std::fs::read_dir(&tiles)
        .unwrap()
        .map(|e| e.unwrap().metadata().unwrap().len())
        .sum();
    for (map, total) in [
        (&whole, std::fs::metadata(&whole).unwrap().len()),
        (&tiles, tiles_bytes),
    ] {
        let out = run(
            map,
            Some(&cfg),
            if map == &whole { "whole" } else { "tiles" },
        );
        let (got, ground) = without(&out);
        assert_eq!(got, want, "{}", map.display());
        let tilt = |g: &[serde_json::Value; 4]| g[0].as_f64().unwrap();
        assert!(
            (tilt(&ground) - tilt(&whole_ground)).abs() < 0.2,
            "{}: the sample's ground tilt {ground:?} against the whole map's {whole_ground:?}",
            map.display()
        );
        let r = reads(&out);
        assert_eq!(r[0].0, "ground");
        assert!(
            r[0].1 * 3 < all_points && r[0].2 * 3 < total,
            "{}: the ground pass reads a sample: {r:?} of {all_points} points, {total} bytes",
            map.display()
        );
    }
}

/// A map leaning 6°: eval levels it, and its crops of the tiled map open the
/// tiles the discs turned back into the map's frame reach, which must hold
/// every point the whole map gives.
#[test]
fn a_tilted_tiled_map_gives_the_whole_maps_results() {
    let dir = tempdir();
    let (whole, tiles, survey) = scene_with(dir.path(), &["--tilt-deg", "6"]);
    let out = same_results(dir.path(), &[&whole, &tiles], &survey);
    let result = std::fs::read_to_string(out[0].join("result.json")).unwrap();
    assert!(result.contains("\"levelling\""), "levelled: {result}");
}

/// Runs eval on each map and checks they give the same results; returns
/// the output folders.
fn same_results(dir: &Path, maps: &[&Path], survey: &Path) -> Vec<std::path::PathBuf> {
    let mut outs = Vec::new();
    for (k, map) in maps.iter().enumerate() {
        let out = dir.join(format!("out{k}"));
        let o = bin()
            .arg("eval")
            .arg("--map")
            .arg(map)
            .arg("--survey")
            .arg(survey)
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
    outs
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

/// The WGS84 position that `p` projects to `target` (Newton's method on the
/// projection, to 1e-8 m).
fn invert(p: &Projector, target: &Point, start: Geodetic) -> Geodetic {
    let mut g = start;
    for _ in 0..50 {
        let f = p.forward(&g);
        let r = [target.x - f.x, target.y - f.y];
        g.alt += target.z - f.z;
        if r[0].abs() < 1e-8 && r[1].abs() < 1e-8 {
            return g;
        }
        let h = 1e-7;
        let fx = p.forward(&Geodetic {
            lat: g.lat + h,
            ..g
        });
        let fy = p.forward(&Geodetic {
            lon: g.lon + h,
            ..g
        });
        let j = [
            [(fx.x - f.x) / h, (fy.x - f.x) / h],
            [(fx.y - f.y) / h, (fy.y - f.y) / h],
        ];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        g.lat += (j[1][1] * r[0] - j[0][1] * r[1]) / det;
        g.lon += (-j[1][0] * r[0] + j[0][0] * r[1]) / det;
    }
    panic!("no convergence for {target}");
}

#[test]
fn a_wgs84_survey_is_placed_by_the_maps_projector_info() {
    let dir = tempdir();
    let s = dir.path().join("scene");
    // The map in the survey frame: the projection is all it takes.
    stdout_ok(
        bin()
            .args([
                "synth", "--points", "300000", "--format", "pcd", "--seed", "2",
            ])
            .args(["--yaw-deg", "0", "--offset-m", "0,0,0", "--out"])
            .arg(&s),
    );
    let pts = cloud::read_all(&s.join("map.pcd")).unwrap();
    let map = dir.path().join("map");
    cloud::write_tiles(&pts, &map, 20.0, OutFormat::Pcd).unwrap();
    let local = read_survey(&s.join("survey.csv"), &SurveyOptions::default()).unwrap();
    let origin = "map_origin:\n  latitude: 35.68\n  longitude: 139.76\n  altitude: 30.0\n";
    let start = Geodetic {
        lat: 35.68,
        lon: 139.76,
        alt: 30.0,
    };
    let eval = |survey: &Path, map: &Path, out: &Path| {
        let o = bin()
            .arg("eval")
            .arg("--map")
            .arg(map)
            .arg("--survey")
            .arg(survey)
            .arg("--out")
            .arg(out)
            .arg("--no-report")
            .output()
            .unwrap();
        assert!(o.status.success(), "eval: {}", stderr(&o));
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap())
                .unwrap();
        (v, stderr(&o))
    };
    let (want, _) = eval(&s.join("survey.csv"), &map, &dir.path().join("local"));
    assert_eq!(want["eval"]["frame"]["how"], "survey");
    for (k, yaml) in [
        format!("projector_type: LocalCartesianUTM\nvertical_datum: WGS84\n{origin}"),
        format!("projector_type: LocalCartesian\n{origin}"),
        format!("projector_type: TransverseMercator\n{origin}"),
        "projector_type: MGRS\nvertical_datum: WGS84\nmgrs_grid: 54SUE\n".to_string(),
    ]
    .iter()
    .enumerate()
    {
        let pf = map.join("map_projector_info.yaml");
        std::fs::write(&pf, yaml).unwrap();
        let proj = Projector::read(&pf, true).unwrap();
        // MGRS coordinates count from the square's corner: the survey sits
        // 50 km into it.
        let shift = if k == 3 { 50_000.0 } else { 0.0 };
        let mut csv = String::from("id,lat,lon,alt,antenna_height\n");
        for t in &local.targets {
            let q = Point::new(t.position.x + shift, t.position.y + shift, t.position.z);
            let g = invert(&proj, &q, start);
            csv += &format!(
                "{},{:.12},{:.12},{:.6},{}\n",
                t.id, g.lat, g.lon, g.alt, t.antenna_height
            );
        }
        let survey = dir.path().join(format!("wgs84-{k}.csv"));
        std::fs::write(&survey, csv).unwrap();
        let (map_k, pts_k);
        if k == 3 {
            // The MGRS map: the same points 50 km into the square.
            pts_k = pts
                .iter()
                .map(|p| Point::new(p.x + shift, p.y + shift, p.z))
                .collect::<Vec<_>>();
            map_k = dir.path().join("mgrs");
            cloud::write_tiles(&pts_k, &map_k, 20.0, OutFormat::Pcd).unwrap();
            std::fs::copy(&pf, map_k.join("map_projector_info.yaml")).unwrap();
        } else {
            map_k = map.clone();
        }
        let (got, err) = eval(&survey, &map_k, &dir.path().join(format!("out{k}")));
        assert!(err.contains("placed in the map frame by"), "{err}");
        assert_eq!(got["survey_frame"], "wgs84_map", "{yaml}");
        assert_eq!(got["eval"]["frame"]["how"], "survey", "{yaml}");
        let errors = |v: &serde_json::Value| -> Vec<f64> {
            v["targets"]
                .as_array()
                .unwrap()
                .iter()
                .map(|t| t["abs_error"].as_f64().unwrap_or(f64::NAN))
                .collect()
        };
        let (a, b) = (errors(&want), errors(&got));
        assert_eq!(a.len(), b.len());
        assert!(a.iter().filter(|e| e.is_finite()).count() >= 3, "{a:?}");
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x - y).abs() < 1e-6 || (x.is_nan() && y.is_nan()),
                "{yaml}: {a:?} vs {b:?}"
            );
        }
    }
}

/// A survey of latitude, longitude with the two columns exchanged, placed by
/// the map's projection, lands thousands of kilometres off the map: in
/// Europe or the Americas both values pass as latitudes, so nothing refuses
/// the rows. Read the other way round it falls on the map's targets, and
/// the run says so instead of "another frame or another site".
#[test]
fn a_wgs84_survey_with_latitude_and_longitude_swapped_is_named() {
    let dir = tempdir();
    let s = dir.path().join("scene");
    stdout_ok(
        bin()
            .args([
                "synth", "--points", "300000", "--format", "pcd", "--seed", "2",
            ])
            .args(["--yaw-deg", "0", "--offset-m", "0,0,0", "--out"])
            .arg(&s),
    );
    let map = dir.path().join("map");
    std::fs::create_dir(&map).unwrap();
    std::fs::copy(s.join("map.pcd"), map.join("map.pcd")).unwrap();
    let pf = map.join("map_projector_info.yaml");
    std::fs::write(
        &pf,
        "projector_type: LocalCartesian\nmap_origin:\n  latitude: 48.1\n  longitude: 11.5\n  altitude: 500.0\n",
    )
    .unwrap();
    let proj = Projector::read(&pf, true).unwrap();
    let local = read_survey(&s.join("survey.csv"), &SurveyOptions::default()).unwrap();
    let start = Geodetic {
        lat: 48.1,
        lon: 11.5,
        alt: 500.0,
    };
    let (mut right, mut swapped) = (
        String::from("id,lat,lon,alt,antenna_height\n"),
        String::from("id,lat,lon,alt,antenna_height\n"),
    );
    for t in &local.targets {
        let g = invert(&proj, &t.position, start);
        let h = t.antenna_height;
        right += &format!("{},{:.12},{:.12},{:.6},{h}\n", t.id, g.lat, g.lon, g.alt);
        swapped += &format!("{},{:.12},{:.12},{:.6},{h}\n", t.id, g.lon, g.lat, g.alt);
    }
    let run = |name: &str, csv: &str| {
        let survey = dir.path().join(format!("{name}.csv"));
        std::fs::write(&survey, csv).unwrap();
        bin()
            .arg("eval")
            .arg("--map")
            .arg(&map)
            .arg("--survey")
            .arg(&survey)
            .arg("--out")
            .arg(dir.path().join(name))
            .arg("--no-report")
            .output()
            .unwrap()
    };
    let o = run("right", &right);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run("swapped", &swapped);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("latitude and longitude look swapped")
            && err.contains("id,lat,lon: latitude first"),
        "{err}"
    );
}
