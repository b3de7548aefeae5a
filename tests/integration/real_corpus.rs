//! Real files (`tests/data/real`, provenance and licences in its README.md),
//! none holding a survey target: each is read exactly as an independent
//! reader reads it (`manifest.json`, written by `measure.py` with numpy's own
//! PCD/PTS/CSV parsing, laspy, plyfile and pye57), `detect` finds no target
//! in it, and the ground spots of a fake survey are never located (issue 30).
//! `MAPGAUGE_CORPUS=DIR` runs the same checks on another folder with its own
//! manifest.json (`fetch_more.sh --download DIR`, then
//! `measure.py DIR/* > DIR/manifest.json`).

use crate::util::{bin, stderr, tempdir};
use serde_json::Value;
use std::path::PathBuf;

/// Files `detect` still takes a target from, with why: each a known failure
/// of issue 30 item 3, asserted so that its fix shows here. (Empty since
/// map-wide detection asks for 70 % of a plate's height: the Velodyne
/// frame's 0.35 m tall L and lone-star's three 0.23-0.41 m ones are gone.)
const KNOWN_FALSE: &[(&str, usize, &str)] = &[];

fn corpus() -> (PathBuf, Vec<Value>) {
    let dir = std::env::var_os("MAPGAUGE_CORPUS").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/real"),
        PathBuf::from,
    );
    let m: Vec<Value> =
        serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).expect("manifest.json"))
            .expect("manifest.json is a list");
    assert!(!m.is_empty());
    (dir, m)
}

fn triple(v: &Value) -> [f64; 3] {
    [0, 1, 2].map(|i| v[i].as_f64().expect("a number"))
}

#[test]
fn every_real_file_reads_as_an_independent_reader_reads_it() {
    let (dir, manifest) = corpus();
    let mut bad = Vec::new();
    for e in &manifest {
        let name = e["file"].as_str().unwrap();
        let pts = match mapgauge::cloud::read_all(&dir.join(name)) {
            Ok(p) => p,
            Err(err) => {
                bad.push(format!("{name}: {err}"));
                continue;
            }
        };
        let want = e["points"].as_u64().unwrap() - e["nan_points"].as_u64().unwrap();
        if pts.len() as u64 != want {
            bad.push(format!("{name}: {} points, {want} expected", pts.len()));
            continue;
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in &pts {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let first = [pts[0].x, pts[0].y, pts[0].z];
        // Float32, integer and text sources convert exactly; scaled
        // integers (LAS, E57) may differ in the last bits of a double.
        let close = |a: f64, b: f64| (a - b).abs() <= 4.0 * f64::EPSILON * a.abs().max(1.0);
        for (what, got, want) in [
            ("min", lo, triple(&e["min"])),
            ("max", hi, triple(&e["max"])),
            ("first point", first, triple(&e["first"])),
        ] {
            if !(0..3).all(|k| close(got[k], want[k])) {
                bad.push(format!("{name}: {what} {got:?}, {want:?} expected"));
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// Checkerboard boards are told by intensity (issue 33): where the
/// independent reader reads it (laspy for LAS/LAZ, plyfile for PLY, pye57
/// for E57 in the local run's larger files), every
/// file's intensities read as it reads them: their sum, least, greatest and
/// first, over the finite intensities of the points with finite coordinates.
#[test]
fn intensities_read_as_an_independent_reader_reads_them() {
    let (dir, manifest) = corpus();
    let mut bad = Vec::new();
    let mut checked = 0;
    for e in &manifest {
        let Some(want) = e.get("intensity") else {
            continue;
        };
        let name = e["file"].as_str().unwrap();
        let mut r = mapgauge::cloud::open(&dir.join(name)).unwrap();
        if !r.has_intensity() {
            bad.push(format!("{name}: no intensity read"));
            continue;
        }
        let (mut all, mut buf, mut inten) = (Vec::new(), Vec::new(), Vec::new());
        while r.next_chunk_intensity(&mut buf, &mut inten).unwrap() {
            // A point without one (NaN) says nothing of a print, as in measure.py.
            all.extend(
                inten
                    .iter()
                    .filter(|v| v.is_finite())
                    .map(|&v| f64::from(v)),
            );
        }
        let got = [
            all.iter().sum::<f64>(),
            all.iter().copied().fold(f64::INFINITY, f64::min),
            all.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            all.first().copied().unwrap_or(f64::NAN),
        ];
        let want = ["sum", "min", "max", "first"].map(|k| want[k].as_f64().unwrap());
        // Whole-number intensities (LAS, most PLY) agree exactly; float ones
        // (an E57 scan's) to f32's precision and the summation's order.
        let near = |a: f64, b: f64| (a - b).abs() <= 1e-7 * b.abs().max(1.0);
        if !(0..4).all(|k| near(got[k], want[k])) {
            bad.push(format!(
                "{name}: intensity (sum, min, max, first) {got:?}, {want:?} expected"
            ));
        }
        checked += 1;
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
    // The committed corpus holds six such files; a local one may hold fewer.
    let committed = std::env::var_os("MAPGAUGE_CORPUS").is_none();
    assert!(
        checked >= if committed { 6 } else { 1 },
        "{checked} files with intensity"
    );
}

#[test]
fn detect_finds_no_target_in_real_maps_without_any() {
    let (dir, manifest) = corpus();
    let tmp = tempdir();
    let mut bad = Vec::new();
    let mut in_feet = Vec::new();
    for e in &manifest {
        let name = e["file"].as_str().unwrap();
        let out = tmp.path().join(name);
        let o = bin()
            .arg("detect")
            .arg("--map")
            .arg(dir.join(name))
            .arg("--out")
            .arg(&out)
            // Spheres too (issue 33): a 145 mm round patch of a tank, a
            // machine or a boulder is not a sphere target standing alone.
            .args(["--sphere-diameter", "0.145"])
            // Standing boards too: a sign, a window or a patch of a wall
            // with contrast is not a board's print.
            .args(["--board-side", "0.6"])
            .output()
            .unwrap();
        // A map whose header declares feet is refused, naming the unit
        // (read as metres, a 0.6 m plate would be looked for at 0.6 ft).
        // The remedy it names is run: the map in metres, then detected in.
        let said = stderr(&o);
        if !o.status.success() && said.contains("whose unit is the") {
            in_feet.push(name.to_string());
            let scale = said
                .split("--scale ")
                .nth(1)
                .and_then(|t| t.split('`').next())
                .unwrap_or_else(|| panic!("{name}: no scale named: {said}"));
            let metres = tmp.path().join(format!("{name}.m.las"));
            crate::util::stdout_ok(
                bin()
                    .args(["convert", "--scale", scale, "--map"])
                    .arg(dir.join(name))
                    .arg("--out")
                    .arg(&metres),
            );
            let said = crate::util::stdout_ok(bin().arg("detect").arg("--map").arg(&metres));
            if !said.contains("0 target-shaped object(s)") {
                bad.push(format!("{name} in metres: {said}"));
            }
            continue;
        }
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let csv = std::fs::read_to_string(out.join("detections.csv")).unwrap();
        let found = csv.lines().skip(1).filter(|l| !l.trim().is_empty()).count();
        let known = KNOWN_FALSE.iter().find(|k| k.0 == name).map_or(0, |k| k.1);
        if found != known {
            bad.push(format!(
                "{name}: {found} detections, {known} expected\n{csv}"
            ));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
    // laspy's Autzen tile declares Oregon's Lambert projection in feet
    // (GeoTIFF unit key 9002, and a WKT `UNIT["foot",0.3048]`).
    if std::env::var_os("MAPGAUGE_CORPUS").is_none() {
        assert_eq!(in_feet, ["laspy_autzen_trim.laz"]);
    }
}

/// Five spots on the ground of each real scan 10 m across or more and dense
/// enough for a target to show (10 points a square metre over its extent:
/// the Velodyne frames, not the airborne tiles), each the lowest point
/// within 1 m of points spread through the file, surveyed as targets and
/// evaluated in the survey's frame: every spot is `not_found`; as L targets
/// (the corner at the spot), as spheres (the centre 1.3 m above it) and as
/// checkerboard boards (the crossing at the spot: lying on the ground is
/// searched too, since 6 Dec 2026). And spots on the scans' walls (points
/// 0.8 m or more above the ground whose 0.3 m about them is a standing
/// plane), surveyed as boards: a board hung on a wall is searched for on
/// the wall's plane, and none of these is one.
#[test]
fn ground_spots_of_a_fake_survey_are_never_located() {
    for model in ["l", "sphere", "board"] {
        ground_spots_as(model, false);
    }
    ground_spots_as("board", true);
}

/// Up to five points 3 m apart or more, at least 0.8 m above the scan's
/// 5th-percentile height, each with 60 or more points within 0.3 m that lie
/// on a standing plane (normal within 11.5° of level, the least spread under
/// a fiftieth of the middle one).
fn wall_spots(pts: &[mapgauge::Point]) -> Vec<mapgauge::Point> {
    let mut z: Vec<f64> = pts.iter().map(|p| p.z).collect();
    z.sort_by(f64::total_cmp);
    let floor = z[z.len() / 20];
    let mut spots: Vec<mapgauge::Point> = Vec::new();
    for p in pts.iter().step_by((pts.len() / 3000).max(1)) {
        if p.z < floor + 0.8 || spots.iter().any(|q| (q - p).norm() < 3.0) {
            continue;
        }
        let near: Vec<_> = pts.iter().filter(|q| (*q - p).norm() < 0.3).collect();
        if near.len() < 60 {
            continue;
        }
        let m = near
            .iter()
            .fold(nalgebra::Vector3::zeros(), |a, q| a + q.coords)
            / near.len() as f64;
        let cov = near.iter().fold(nalgebra::Matrix3::zeros(), |a, q| {
            let d = q.coords - m;
            a + d * d.transpose()
        });
        let eig = cov.symmetric_eigen();
        let mut order = [0, 1, 2];
        order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        let n = eig.eigenvectors.column(order[0]);
        if n.z.abs() < 0.2 && eig.eigenvalues[order[0]] < 0.02 * eig.eigenvalues[order[1]] {
            spots.push(*p);
            if spots.len() == 5 {
                break;
            }
        }
    }
    spots
}

fn ground_spots_as(model: &str, walls: bool) {
    let (dir, manifest) = corpus();
    let tmp = tempdir();
    let mut tried = 0;
    let mut spots_tried = 0;
    for e in &manifest {
        let (lo, hi) = (triple(&e["min"]), triple(&e["max"]));
        let (w, d) = (hi[0] - lo[0], hi[1] - lo[1]);
        let n = e["points"].as_u64().unwrap() as f64;
        if w < 10.0 || d < 10.0 || n / (w * d) < 10.0 {
            continue;
        }
        let name = e["file"].as_str().unwrap();
        let pts = mapgauge::cloud::read_all(&dir.join(name)).unwrap();
        let mut survey = String::from("id,x,y,z,antenna_height,model\n");
        let above = if model == "sphere" { 1.3 } else { 0.0 };
        let on_walls = if walls { wall_spots(&pts) } else { Vec::new() };
        for (i, c) in on_walls.iter().enumerate() {
            survey += &format!("w{i},{:.3},{:.3},{:.3},0,{model}\n", c.x, c.y, c.z);
        }
        for i in 0..5 {
            if walls {
                break;
            }
            let c = pts[(2 * i + 1) * pts.len() / 10];
            let low = pts
                .iter()
                .filter(|p| (p.x - c.x).hypot(p.y - c.y) < 1.0)
                .min_by(|a, b| a.z.total_cmp(&b.z))
                .unwrap();
            survey += &format!(
                "s{i},{:.3},{:.3},{:.3},0,{model}\n",
                low.x,
                low.y,
                low.z + above
            );
        }
        let spots = if walls { on_walls.len() } else { 5 };
        if spots == 0 {
            continue;
        }
        let s = tmp.path().join(format!("{name}.{model}.csv"));
        std::fs::write(&s, survey).unwrap();
        let out = tmp.path().join(format!("{name}.{model}.out"));
        let o = bin()
            .arg("eval")
            .arg("--map")
            .arg(dir.join(name))
            .arg("--survey")
            .arg(&s)
            .arg("--out")
            .arg(&out)
            .args(["--frame", "survey", "--no-report"])
            .output()
            .unwrap();
        assert!(
            !o.status.success(),
            "{name}: scored ground spots as {model}"
        );
        // A run that cannot score lists every place with its status.
        let failed = std::fs::read_to_string(out.join("failed.csv"))
            .unwrap_or_else(|e| panic!("{name}: no failed.csv ({e}): {}", stderr(&o)));
        let rows: Vec<&str> = failed.lines().skip(1).collect();
        assert_eq!(rows.len(), spots, "{name}:\n{failed}");
        spots_tried += spots;
        for r in rows {
            assert!(
                r.split(',').nth(1) == Some("not_found"),
                "{name}: a ground spot ({model}) was not refused:\n{r}"
            );
        }
        tried += 1;
    }
    assert!(tried >= 2, "only {tried} real scans wide and dense enough");
    assert!(
        spots_tried >= 8,
        "only {spots_tried} spots (walls: {walls})"
    );
}

/// A seam in height is read from the ground about a target
/// (`locate::ground_layers`): real single-pass scans and airborne tiles must
/// show one layer everywhere. Spots on a grid of 30 across each file (2 m
/// apart at least), each read where 400 points or more lie within 3 m.
/// Measured on the committed files (444 spots) and, with the same grid, on
/// 14 files of the local run (1 101 spots, the committed ones' larger twins
/// among them): one spot was two layers, 16 cm apart, each 4.6 cm thick (a
/// curb in a single Velodyne frame, 421 points) before the ring asked for
/// 1000 points, layers 2.5 cm thin at most and three quarters agreeing;
/// none after.
#[test]
fn the_ground_of_real_scans_is_one_layer() {
    use mapgauge::Point;
    use nalgebra::Vector3;
    let (dir, manifest) = corpus();
    let (mut spots, mut bad) = (0, Vec::new());
    for e in &manifest {
        let name = e["file"].as_str().unwrap();
        let Ok(pts) = mapgauge::cloud::read_all(&dir.join(name)) else {
            continue;
        };
        let (mut lo, mut hi) = (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        );
        for p in pts.iter().filter(|p| p.iter().all(|v| v.is_finite())) {
            lo = lo.inf(&p.coords);
            hi = hi.sup(&p.coords);
        }
        let step = ((hi.x - lo.x).max(hi.y - lo.y) / 30.0).max(2.0);
        let n = |a: f64, b: f64| (((b - a) / step).floor() as usize).min(40);
        for i in 0..n(lo.x, hi.x) {
            for j in 0..n(lo.y, hi.y) {
                let (x, y) = (
                    lo.x + (i as f64 + 0.5) * step,
                    lo.y + (j as f64 + 0.5) * step,
                );
                let near: Vec<Point> = pts
                    .iter()
                    .filter(|p| (p.x - x).abs() < 3.1 && (p.y - y).abs() < 3.1)
                    .copied()
                    .collect();
                if near.len() < 400 {
                    continue;
                }
                spots += 1;
                let z = near.iter().map(|p| p.z).sum::<f64>() / near.len() as f64;
                let at = Point::new(x, y, z);
                if let Some(g) = mapgauge::locate::ground_layers(&near, &at, &Vector3::z()) {
                    bad.push(format!("{name} at ({x:.1}, {y:.1}): {g:?}"));
                }
            }
        }
    }
    println!("{spots} spots");
    assert!(spots > 300, "{spots} spots");
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}
