//! `mapgauge crop` end to end: counts and files against a brute-force count over
//! the map read back with the library, shapes, output formats, input formats,
//! and the exit codes and messages for bad maps.

use crate::util::{add_to, bin, edit_survey, stderr, tempdir};
use mapgauge::Point;
use mapgauge::survey::{SurveyOptions, read_survey};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Output;

fn run(args: &[&str], paths: &[(&str, &Path)]) -> Output {
    let mut c = bin();
    c.args(args);
    for (flag, p) in paths {
        c.arg(flag).arg(p);
    }
    c.output().expect("spawn mapgauge")
}

/// A 300 000-point synthetic scene in `format`; returns (map, survey).
fn synth(dir: &Path, format: &str, seed: u64) -> (PathBuf, PathBuf) {
    let out = dir.join(format!("scene-{format}"));
    let o = run(
        &[
            "synth",
            "--points",
            "300000",
            "--format",
            format,
            "--seed",
            &seed.to_string(),
        ],
        &[("--out", &out)],
    );
    assert!(o.status.success(), "synth: {}", stderr(&o));
    (out.join(format!("map.{format}")), out.join("survey.csv"))
}

/// Runs crop and parses its table: id → (points, file).
fn crop(
    map: &Path,
    survey: &Path,
    out: &Path,
    extra: &[&str],
) -> BTreeMap<String, (usize, PathBuf)> {
    let mut args = vec!["crop"];
    args.extend_from_slice(extra);
    let o = run(
        &args,
        &[("--map", map), ("--survey", survey), ("--out", out)],
    );
    assert!(o.status.success(), "crop: {}", stderr(&o));
    assert_ne!(o.status.code(), Some(101));
    let stdout = String::from_utf8(o.stdout).unwrap();
    let mut lines = stdout.lines();
    let head: Vec<&str> = lines.next().unwrap().split_whitespace().collect();
    assert_eq!(head, ["id", "points", "file"], "{stdout}");
    lines
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            assert_eq!(f.len(), 3, "row {l:?}");
            (
                f[0].to_string(),
                (f[1].parse().unwrap(), PathBuf::from(f[2])),
            )
        })
        .collect()
}

/// Survey reference points (antenna lowered by its height), what crop centres on.
fn centres(survey: &Path) -> Vec<(String, Point)> {
    read_survey(survey, &SurveyOptions::default())
        .unwrap()
        .targets
        .iter()
        .map(|t| (t.id.clone(), t.reference()))
        .collect()
}

/// The map points within `radius` of `c`, in map order, computed the slow way.
fn brute(map: &[Point], c: &Point, radius: f64, sphere: bool) -> Vec<Point> {
    map.iter()
        .filter(|p| {
            let (dx, dy, dz) = (p.x - c.x, p.y - c.y, p.z - c.z);
            let d2 = dx * dx + dy * dy + if sphere { dz * dz } else { 0.0 };
            d2 < radius * radius
        })
        .copied()
        .collect()
}

fn check_against_brute_force(
    map: &Path,
    survey: &Path,
    table: &BTreeMap<String, (usize, PathBuf)>,
    out: &Path,
    ext: &str,
    radius: f64,
    sphere: bool,
) {
    let pts = mapgauge::cloud::read_all(map).unwrap();
    let cs = centres(survey);
    assert_eq!(table.len(), cs.len());
    for (id, c) in &cs {
        let (n, file) = &table[id];
        assert_eq!(*file, out.join(format!("{id}.{ext}")));
        let want = brute(&pts, c, radius, sphere);
        assert_eq!(*n, want.len(), "target {id}: printed count");
        assert!(
            *n > 100,
            "target {id}: only {n} points, the scene is too thin"
        );
        let got = mapgauge::cloud::read_all(file).unwrap();
        assert_eq!(
            got.len(),
            want.len(),
            "target {id}: points in {}",
            file.display()
        );
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).norm() < 1e-6, "target {id}: {g} != {w}");
        }
    }
}

#[test]
fn cylinder_counts_and_files_equal_brute_force() {
    let dir = tempdir();
    let (map, survey) = synth(dir.path(), "pcd", 1);
    let out = dir.path().join("crops");
    let table = crop(&map, &survey, &out, &[]);
    check_against_brute_force(&map, &survey, &table, &out, "ply", 5.0, false);
}

#[test]
fn sphere_counts_equal_brute_force_and_are_inside_the_cylinder() {
    let dir = tempdir();
    let (map, survey) = synth(dir.path(), "pcd", 2);
    let out = dir.path().join("sphere");
    let table = crop(&map, &survey, &out, &["--shape", "sphere", "--radius", "3"]);
    check_against_brute_force(&map, &survey, &table, &out, "ply", 3.0, true);
    let cyl = crop(&map, &survey, &dir.path().join("cyl"), &["--radius", "3"]);
    let pts = mapgauge::cloud::read_all(&map).unwrap();
    let mut strictly_fewer = 0;
    for (id, c) in centres(&survey) {
        assert!(table[&id].0 <= cyl[&id].0, "target {id}");
        assert_eq!(cyl[&id].0, brute(&pts, &c, 3.0, false).len(), "target {id}");
        strictly_fewer += usize::from(table[&id].0 < cyl[&id].0);
    }
    // Poles, walls and cars rise above 3 m: the sphere must cut something somewhere.
    assert!(
        strictly_fewer > 0,
        "sphere and cylinder crops are identical"
    );
}

#[test]
fn pcd_output_holds_the_same_points_as_ply_output() {
    let dir = tempdir();
    let (map, survey) = synth(dir.path(), "pcd", 3);
    let (ply_dir, pcd_dir) = (dir.path().join("ply"), dir.path().join("pcd"));
    let ply = crop(&map, &survey, &ply_dir, &["--format", "ply"]);
    let pcd = crop(&map, &survey, &pcd_dir, &["--format", "pcd"]);
    check_against_brute_force(&map, &survey, &pcd, &pcd_dir, "pcd", 5.0, false);
    assert_eq!(
        ply.keys().collect::<Vec<_>>(),
        pcd.keys().collect::<Vec<_>>()
    );
    for (id, (n, f)) in &pcd {
        assert_eq!(*n, ply[id].0, "target {id}");
        let head = std::fs::read(f).unwrap();
        assert!(
            head.starts_with(b"# .PCD") || head.starts_with(b"VERSION"),
            "{}",
            f.display()
        );
        let a = mapgauge::cloud::read_all(f).unwrap();
        let b = mapgauge::cloud::read_all(&ply[id].1).unwrap();
        assert_eq!(a, b, "target {id}");
    }
}

/// Also for positions so far off (a typo in the survey) that the crop's
/// grids must coarsen: a target at 1e300 once wrapped a cell count and
/// panicked.
#[test]
fn target_outside_the_map_warns_and_still_succeeds() {
    let dir = tempdir();
    let (map, survey) = synth(dir.path(), "pcd", 1);
    let reference = crop(&map, &survey, &dir.path().join("ref"), &[]);
    for (k, far) in ["5000.0,-3000.0", "1e300,1e300", "1e15,-1e15"]
        .iter()
        .enumerate()
    {
        let mut text = std::fs::read_to_string(&survey).unwrap();
        text.push_str(&format!("far away,{far},1.0,0.42\n"));
        let survey2 = dir.path().join(format!("survey{k}.csv"));
        std::fs::write(&survey2, text).unwrap();
        let out = dir.path().join(format!("crops{k}"));
        let o = run(
            &["crop"],
            &[("--map", &map), ("--survey", &survey2), ("--out", &out)],
        );
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let err = stderr(&o);
        let warn: Vec<&str> = err.lines().filter(|l| l.starts_with("warning:")).collect();
        assert_eq!(warn.len(), 1, "{err}");
        assert!(
            warn[0].contains("far away") && warn[0].contains("no map points"),
            "{err}"
        );
        let stdout = String::from_utf8(o.stdout).unwrap();
        let row = stdout
            .lines()
            .find(|l| l.starts_with("far away"))
            .expect(&stdout);
        assert_eq!(row.split_whitespace().nth(2), Some("0"), "{row}");
        // The id is made file-safe; the file exists and holds no points.
        let f = out.join("far_away.ply");
        assert!(row.ends_with(&f.display().to_string()), "{row}");
        assert_eq!(mapgauge::cloud::read_all(&f).unwrap().len(), 0);
        // The other targets are unaffected.
        for (id, (n, _)) in &reference {
            let r = stdout
                .lines()
                .find(|l| l.split_whitespace().next() == Some(id))
                .unwrap();
            assert_eq!(
                r.split_whitespace().nth(1),
                Some(n.to_string().as_str()),
                "{far}: {r}"
            );
        }
    }
}

/// Issue 31: a crop that finds nothing is a failed run: `crop` with every
/// target far from the map, and `crop --tight` with none of them where the
/// survey says, exit 1 saying so (and the frame advice), not 0 with empty
/// files and "0 of N".
#[test]
fn a_crop_that_finds_nothing_fails_with_the_reason() {
    let dir = tempdir();
    let (map, survey) = synth(dir.path(), "pcd", 1);
    // 20 m north of every target: bare ground in the loose crops.
    let moved_path = dir.path().join("moved.csv");
    edit_survey(&survey, &moved_path, |f| add_to(&mut f[2], 20.0));
    let o = run(
        &["crop", "--tight"],
        &[
            ("--map", &map),
            ("--survey", &moved_path),
            ("--out", &dir.path().join("t")),
        ],
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(4), "{err}");
    assert!(err.contains("no tight crop made: none of the"), "{err}");
    assert!(err.contains("--init X,Y,YAW_DEG"), "{err}");
    let far_path = dir.path().join("far.csv");
    edit_survey(&survey, &far_path, |f| add_to(&mut f[1], 9000.0));
    let o = run(
        &["crop"],
        &[
            ("--map", &map),
            ("--survey", &far_path),
            ("--out", &dir.path().join("f")),
        ],
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(4), "{err}");
    assert!(err.contains("no map points within"), "{err}");
}

/// Exit code 1 (never the panic code 101) and one line `error: <path>...`.
fn assert_clean_failure(o: &Output, path: &Path) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(4), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    let want = format!("error: {}", path.display());
    assert!(err.starts_with(&want), "expected `{want}...`, got {err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn missing_map_is_a_one_line_error() {
    let dir = tempdir();
    let survey = dir.path().join("survey.csv");
    std::fs::write(&survey, "id,x,y,z\n1,0,0,0\n").unwrap();
    let map = dir.path().join("no such map.pcd");
    let out = dir.path().join("out");
    let o = run(
        &["crop"],
        &[("--map", &map), ("--survey", &survey), ("--out", &out)],
    );
    assert_clean_failure(&o, &map);
}

#[test]
fn truncated_maps_are_one_line_errors() {
    let dir = tempdir();
    for format in ["pcd", "ply", "las"] {
        let (map, survey) = synth(dir.path(), format, 1);
        let bytes = std::fs::read(&map).unwrap();
        // Cut in the middle of the data, in the header, and one byte short.
        for (what, len) in [
            ("half", bytes.len() / 2),
            ("header", 60),
            ("one byte short", bytes.len() - 1),
        ] {
            let cut = dir.path().join(format!("cut-{}.{format}", len));
            std::fs::write(&cut, &bytes[..len]).unwrap();
            let out = dir.path().join(format!("out-{format}-{len}"));
            let o = run(
                &["crop"],
                &[("--map", &cut), ("--survey", &survey), ("--out", &out)],
            );
            assert_ne!(
                o.status.code(),
                Some(101),
                "{format} {what}: {}",
                stderr(&o)
            );
            assert_clean_failure(&o, &cut);
        }
    }
}

#[test]
fn pcd_ply_and_las_maps_give_the_same_crops() {
    let dir = tempdir();
    let mut tables = Vec::new();
    let mut maps = Vec::new();
    for format in ["pcd", "ply", "las"] {
        let (map, survey) = synth(dir.path(), format, 4);
        let out = dir.path().join(format!("crops-{format}"));
        tables.push(crop(&map, &survey, &out, &[]));
        maps.push(mapgauge::cloud::read_all(&map).unwrap());
    }
    // The same scene, point for point: LAS stores millimetres.
    assert_eq!(maps[0].len(), maps[1].len());
    assert_eq!(maps[0].len(), maps[2].len());
    for i in 0..maps[0].len() {
        assert!(
            (maps[0][i] - maps[1][i]).norm() < 1e-5,
            "point {i}: pcd vs ply"
        );
        let d = maps[0][i] - maps[2][i];
        assert!(d.amax() <= 0.0005 + 1e-5, "point {i}: pcd vs las {d}");
    }
    for (id, (n, _)) in &tables[0] {
        assert_eq!(tables[1][id].0, *n, "target {id}: ply");
        // Quantisation may move a point across the 5 m boundary: allow a few.
        let las = tables[2][id].0;
        assert!(
            las.abs_diff(*n) <= 3 + n / 1000,
            "target {id}: pcd {n}, las {las}"
        );
    }
}

#[test]
fn radius_out_of_range_is_a_one_line_error() {
    let dir = tempdir();
    let (map, survey) = synth(dir.path(), "pcd", 2);
    for r in ["0", "5e-324", "-1", "1e9", "NaN"] {
        let out = dir.path().join(format!("crops-{r}"));
        let arg = format!("--radius={r}");
        let o = run(
            &["crop", &arg],
            &[("--map", &map), ("--survey", &survey), ("--out", &out)],
        );
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(4), "{r}: {err}");
        assert_eq!(err.lines().count(), 1, "{r}: {err}");
        assert!(
            err.starts_with("error: ") && err.contains("--radius"),
            "{r}: {err}"
        );
        assert!(!out.exists(), "{r}: output directory created");
    }
}

/// A map in another frame: crop looks where the survey puts the targets,
/// finds nothing, fails, and says how to get the frame; `--plate-size` shapes
/// tight crops only.
#[test]
fn a_map_in_another_frame_gets_the_way_to_its_frame() {
    let dir = tempdir();
    let (map, survey) = synth(dir.path(), "ply", 3);
    let moved = dir.path().join("moved.ply");
    let pts: Vec<Point> = mapgauge::cloud::read_all(&map)
        .unwrap()
        .into_iter()
        .map(|p| Point::new(p.x + 500.0, p.y - 300.0, p.z))
        .collect();
    mapgauge::cloud::write(&moved, mapgauge::cloud::OutFormat::Ply, &pts).unwrap();
    for tight in [false, true] {
        let mut args = vec!["crop"];
        if tight {
            args.push("--tight");
        }
        let out = dir.path().join(format!("out-{tight}"));
        let o = run(
            &args,
            &[("--map", &moved), ("--survey", &survey), ("--out", &out)],
        );
        // Nothing found is a failed run (issue 31), with the way to the frame.
        assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("needs --init X,Y,YAW_DEG: `mapgauge eval` finds the frame by itself and writes it to result.json as eval.frame.init"),
            "{}",
            stderr(&o)
        );
    }
    // The way back: --init puts the targets where they are.
    let got = crop(
        &moved,
        &survey,
        &dir.path().join("init"),
        &["--init=-500,300,0"],
    );
    assert!(got.values().all(|(n, _)| *n > 100), "{got:?}");
    let o = run(
        &["crop", "--plate-size", "0.5"],
        &[
            ("--map", &map),
            ("--survey", &survey),
            ("--out", &dir.path().join("p")),
        ],
    );
    assert_eq!(o.status.code(), Some(4));
    assert!(stderr(&o).contains("add --tight"), "{}", stderr(&o));
    let o = run(
        &["crop", "--tight", "--plate-size", "0.6,0.6"],
        &[
            ("--map", &map),
            ("--survey", &survey),
            ("--out", &dir.path().join("q")),
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
}
