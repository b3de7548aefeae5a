//! What a new user runs into first (issue 19): surveys as spreadsheets write
//! them, loose crops handed to `locate`, outputs that name files, flags that
//! take negative numbers, and messages that name the remedy.

use crate::util::{
    add_to, bin, converted_scores, edit_survey, stderr, stdout_ok, tempdir, write_las,
};
use std::path::Path;
use std::process::Command;

/// Negates a CSV field holding a number.
fn add_to_neg(field: &mut String) {
    *field = format!("{:.4}", -field.parse::<f64>().expect("a number"));
}

fn scene(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let scene = dir.join("scene");
    stdout_ok(
        bin()
            .args(["synth", "--points", "1000000", "--out"])
            .arg(&scene),
    );
    (scene.join("map.ply"), scene.join("survey.csv"))
}

/// `eval --no-report` of `map` against `survey` with `extra` flags, which
/// must be refused (exit 1): its stderr.
fn eval_refused(map: &Path, survey: &Path, extra: &[&str]) -> String {
    let o = bin()
        .args(["eval", "--no-report"])
        .args(extra)
        .arg("--map")
        .arg(map)
        .arg("--survey")
        .arg(survey)
        .output()
        .unwrap();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(4), "{e}");
    e
}

#[test]
fn crop_tight_then_locate_works_and_a_loose_crop_is_named() {
    let d = tempdir();
    let (map, survey) = scene(d.path());
    let loose = d.path().join("loose");
    stdout_ok(
        bin()
            .args(["crop", "--map"])
            .arg(&map)
            .arg("--survey")
            .arg(&survey)
            .arg("--out")
            .arg(&loose),
    );
    let o = bin()
        .arg("locate")
        .arg(loose.join("1.ply"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4));
    assert!(
        stderr(&o).contains("looks like a loose crop") && stderr(&o).contains("crop --tight"),
        "{}",
        stderr(&o)
    );
    let o = bin()
        .args(["eval", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&survey)
        .arg("--crops")
        .arg(&loose)
        .output()
        .unwrap();
    assert!(
        stderr(&o).contains("looks like a loose crop") && !stderr(&o).contains("--init"),
        "{}",
        stderr(&o)
    );
    // The loose crop says what it wrote, and what locate wants instead.
    let o = bin()
        .args(["crop", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&survey)
        .arg("--out")
        .arg(d.path().join("loose2"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("these are loose crops (ground and surroundings included)")
            && stderr(&o).contains("`mapgauge crop --tight`"),
        "{}",
        stderr(&o)
    );
    let tight = d.path().join("tight");
    stdout_ok(
        bin()
            .args(["crop", "--tight", "--map"])
            .arg(&map)
            .arg("--survey")
            .arg(&survey)
            .arg("--out")
            .arg(&tight),
    );
    let out = stdout_ok(
        bin()
            .arg("locate")
            .args((1..=5).map(|i| tight.join(format!("{i}.ply")))),
    );
    assert_eq!(
        out.lines().filter(|l| l.ends_with(" ok")).count(),
        5,
        "{out}"
    );
    let json = stdout_ok(
        bin()
            .args(["eval", "--format", "json", "--map"])
            .arg(&map)
            .arg("--survey")
            .arg(&survey)
            .arg("--crops")
            .arg(&tight),
    );
    assert!(!json.contains("not_found"), "{json}");
}

#[test]
fn surveys_with_semicolons_tabs_or_no_header() {
    let d = tempdir();
    let est = d.path().join("est.csv");
    std::fs::write(&est, "id,x,y\n1,0,0\n2,10,0\n3,0,10\n").unwrap();
    for (name, text) in [
        ("semi.csv", "id;x;y\n1;0;0\n2;10;0.01\n3;0;10\n"),
        (
            "tab.csv",
            "# a comment\nid\tx\ty\n1\t0\t0\n2\t10\t0.01\n3\t0\t10\n",
        ),
    ] {
        let p = d.path().join(name);
        std::fs::write(&p, text).unwrap();
        let json = stdout_ok(
            bin()
                .args(["errors", "--format", "json", "--survey"])
                .arg(&p)
                .arg("--estimates")
                .arg(&est),
        );
        assert!(json.contains("\"n\": 3"), "{name}: {json}");
    }
    let p = d.path().join("nohead.csv");
    std::fs::write(&p, "1,0,0\n2,10,0\n").unwrap();
    let o = bin()
        .args(["errors", "--survey"])
        .arg(&p)
        .arg("--estimates")
        .arg(&est)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4));
    let e = stderr(&o);
    assert!(
        e.starts_with(&format!("error: {}:1: no header line", p.display()))
            && e.contains("id,x,y,z"),
        "{e}"
    );
}

#[test]
fn messages_name_the_remedy() {
    let d = tempdir();
    let a = d.path().join("a.csv");
    let b = d.path().join("b.csv");
    std::fs::write(&a, "id,x,y\n1,0,0\n2,10,0\n3,0,10\n").unwrap();
    std::fs::write(&b, "id,x,y\nT1,0,0\nT2,10,0\n").unwrap();
    let o = bin()
        .args(["errors", "--survey"])
        .arg(&a)
        .arg("--estimates")
        .arg(&b)
        .output()
        .unwrap();
    assert!(
        stderr(&o).contains("the ids differ (survey: 1, 2, 3; estimates: T1, T2)"),
        "{}",
        stderr(&o)
    );
    // --out naming a file: refused before any work, the file untouched.
    let f = d.path().join("file");
    std::fs::write(&f, "keep").unwrap();
    let o = bin()
        .args(["errors", "--survey"])
        .arg(&a)
        .arg("--estimates")
        .arg(&a)
        .arg("--out")
        .arg(&f)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4));
    assert!(
        stderr(&o).contains("exists and is not a directory"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read_to_string(&f).unwrap(), "keep");
    // --origin with a local survey is refused, not ignored.
    let o = bin()
        .args(["errors", "--origin", "37.5,127.0", "--survey"])
        .arg(&a)
        .arg("--estimates")
        .arg(&a)
        .output()
        .unwrap();
    assert!(
        stderr(&o).contains("--origin applies to WGS84"),
        "{}",
        stderr(&o)
    );
    // A negative number is a value, so an out-of-range one gets the range
    // error (exit 1), not clap's "unexpected argument '-1'".
    for cmd in ["eval", "crop"] {
        let o = bin()
            .args([cmd, "--radius", "-1", "--out"])
            .arg(d.path().join("neg"))
            .arg("--map")
            .arg(d.path().join("none.ply"))
            .arg("--survey")
            .arg(d.path().join("none.csv"))
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(4), "{cmd}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("-1: must be within 0.001..10000"),
            "{cmd}: {}",
            stderr(&o)
        );
    }
    // List flags: negative numbers without `=`; a wrong count is a usage error.
    let (map, survey) = scene(d.path());
    // The survey given as the map: read as a 5-point map, and said so, rather
    // than "no frame found".
    let o = bin()
        .args(["eval", "--map"])
        .arg(&survey)
        .arg("--survey")
        .arg(&survey)
        .arg("--out")
        .arg(d.path().join("swapped"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "only 5 finite points; a map holds thousands around each target: is this the map?"
        ),
        "{}",
        stderr(&o)
    );
    let o = bin()
        .args(["eval", "--init", "-26.7,96,30", "--print-config"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("init = [\n    -26.7,")
            || String::from_utf8_lossy(&o.stdout).contains("init = [-26.7"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let o = bin()
        .args(["eval", "--init", "1,2", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&survey)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("expected 3 comma-separated numbers"),
        "{}",
        stderr(&o)
    );
    let o = bin()
        .args(["eval", "--format", "yaml", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&survey)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // One surveyed target: the message says the survey is the problem.
    let one = d.path().join("one.csv");
    let first = std::fs::read_to_string(&survey).unwrap();
    let two_lines: String = first.lines().take(2).map(|l| format!("{l}\n")).collect();
    std::fs::write(&one, two_lines).unwrap();
    let o = bin()
        .args(["eval", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&one)
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(
        e.contains("The survey has 1 target(s)") && !e.contains("; ."),
        "{e}"
    );
}

/// `--plots` naming an existing file: refused before any work, as `--out` is.
#[test]
fn plots_naming_a_file_is_refused_before_any_work() {
    let d = tempdir();
    let (map, survey) = scene(d.path());
    let f = d.path().join("plots-file");
    std::fs::write(&f, "keep").unwrap();
    let out = d.path().join("out");
    let o = bin()
        .args(["eval", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&survey)
        .arg("--out")
        .arg(&out)
        .arg("--plots")
        .arg(&f)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert_eq!(
        stderr(&o).trim_end(),
        format!(
            "error: {}: exists and is not a directory (--plots names the directory to write into)",
            f.display()
        )
    );
    assert!(o.stdout.is_empty(), "nothing evaluated, nothing printed");
    assert!(!out.join("result.json").exists(), "nothing written");
    assert_eq!(std::fs::read_to_string(&f).unwrap(), "keep");
}

/// `--verbose` pairs are in millimetres like the rest of the terminal (and the
/// report's slope in mm per 100 m); pairs.csv keeps metres.
#[test]
fn verbose_pairs_are_in_millimetres() {
    let d = tempdir();
    let survey = d.path().join("s.csv");
    let est = d.path().join("e.csv");
    std::fs::write(&survey, "id,x,y\n1,0,0\n2,100,0\n3,0,50\n").unwrap();
    std::fs::write(&est, "id,x,y\n1,0,0\n2,100.02,0\n3,0,50\n").unwrap();
    let out = stdout_ok(
        bin()
            .args(["errors", "-v", "--survey"])
            .arg(&survey)
            .arg("--estimates")
            .arg(&est)
            .arg("--out")
            .arg(d.path().join("o")),
    );
    let pairs = out
        .split("\nPairs\n")
        .nth(1)
        .unwrap_or_else(|| panic!("{out}"));
    let mut lines = pairs.lines();
    let head = lines.next().unwrap();
    assert!(
        head.contains("error mm") && head.contains("mm per 100 m"),
        "{head}"
    );
    // Pair 1 & 2: 20 mm over 100 m: 20.0 mm, 20.0 mm per 100 m.
    let row: Vec<&str> = lines
        .find(|l| l.starts_with("1 ") && l.split_whitespace().nth(1) == Some("2"))
        .unwrap()
        .split_whitespace()
        .collect();
    assert_eq!(&row[2..], ["100.000", "100.020", "20.0", "20.0"], "{pairs}");
    let csv = std::fs::read_to_string(d.path().join("o/pairs.csv")).unwrap();
    assert!(
        csv.contains("1,2,100.000000,100.020000,0.020000,0.020000"),
        "{csv}"
    );
}

/// `table` over runs scored against different surveys says so, whether a
/// target moved or the target sets differ.
#[test]
fn table_warns_about_different_surveys() {
    let d = tempdir();
    let est = d.path().join("e.csv");
    std::fs::write(&est, "id,x,y\n1,0,0\n2,10,0.01\n3,0,10\n4,10,10\n").unwrap();
    let mut results = Vec::new();
    for (name, text) in [
        ("a", "id,x,y\n1,0,0\n2,10,0\n3,0,10\n"),
        ("b", "id,x,y\n1,0,0\n2,10,0\n3,0,10\n4,10,10\n"),
        ("c", "id,x,y\n1,0,0\n2,10,0\n3,0,10.5\n"),
    ] {
        let sv = d.path().join(format!("{name}.csv"));
        std::fs::write(&sv, text).unwrap();
        let out = d.path().join(name);
        let o = bin()
            .args(["errors", "--survey"])
            .arg(&sv)
            .arg("--estimates")
            .arg(&est)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        results.push(out.join("result.json"));
    }
    let table = |r: &[&std::path::PathBuf]| {
        let o = bin().arg("table").args(r).output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    assert_eq!(
        table(&[&results[0], &results[0]]),
        "",
        "same survey: no warning"
    );
    let e = table(&[&results[0], &results[1]]);
    assert!(
        e.contains(
            "runs `a` and `b` were scored against different surveys (only in `a`: none; only in `b`: 4)"
        ),
        "{e}"
    );
    let e = table(&[&results[0], &results[2]]);
    assert!(
        e.contains("runs `a` and `c` were scored against different surveys (targets 3 differ)"),
        "{e}"
    );
    // Issue 31: `compare` of runs against different surveys gave a confident
    // difference; it refuses, and compares under --force with a warning.
    let o = bin()
        .arg("compare")
        .args([&results[0], &results[2]])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("`a` and `c` were scored against different surveys: targets 3 are surveyed at other positions")
            && stderr(&o).contains("--force"),
        "{}",
        stderr(&o)
    );
    let o = bin()
        .args(["compare", "--force"])
        .args([&results[0], &results[2]])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).starts_with("warning: `a` and `c` were scored against different surveys"),
        "{}",
        stderr(&o)
    );
    let o = bin()
        .arg("compare")
        .args([&results[0], &results[0]])
        .output()
        .unwrap();
    assert!(
        o.status.success() && stderr(&o).is_empty(),
        "{}",
        stderr(&o)
    );
}

/// `origin` in TOML as `--origin` takes it: `[lat, lon]` (alt 0) or
/// `[lat, lon, alt]`; another count names the file's line.
#[test]
fn toml_origin_takes_two_or_three_numbers() {
    let d = tempdir();
    let c = d.path().join("c.toml");
    std::fs::write(&c, "[frame]\norigin = [36.5, 127.25]\n").unwrap();
    let out = stdout_ok(bin().args(["eval", "--print-config", "--config"]).arg(&c));
    let compact: String = out.split_whitespace().collect();
    assert!(compact.contains("origin=[36.5,127.25,0.0,]"), "{out}");
    std::fs::write(&c, "[frame]\norigin = [1, 2, 3, 4]\n").unwrap();
    let o = bin()
        .args(["eval", "--print-config", "--config"])
        .arg(&c)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4));
    assert!(
        stderr(&o).starts_with(&format!("error: {}:2: ", c.display()))
            && stderr(&o).contains("origin takes [lat, lon] or [lat, lon, alt], got 4 numbers"),
        "{}",
        stderr(&o)
    );
    std::fs::write(&c, "[frame]\norigin = [95, 2]\n").unwrap();
    let o = bin()
        .args(["eval", "--print-config", "--config"])
        .arg(&c)
        .output()
        .unwrap();
    assert!(
        stderr(&o).starts_with(&format!("error: {}:2: frame.origin = 95", c.display())),
        "{}",
        stderr(&o)
    );
}

/// Issue 31: a map in millimetres (a synthetic scene ×1000) is refused with
/// the diagnosis and the remedy within a second and under a 1 GiB address
/// space (it grew to 24 GB and was killed before); `convert --scale 0.001`
/// gives back the map in metres, whose targets are all found.
#[test]
fn a_map_in_millimetres_is_refused_in_bounded_memory_and_convert_scale_fixes_it() {
    let dir = tempdir();
    let (map, survey) = scene(dir.path());
    let mm = dir.path().join("mm.pcd");
    let pts: Vec<mapgauge::Point> = mapgauge::cloud::read_all(&map)
        .unwrap()
        .iter()
        .map(|p| mapgauge::Point::from(p.coords * 1000.0))
        .collect();
    mapgauge::cloud::write(&mm, mapgauge::cloud::OutFormat::Pcd, &pts).unwrap();
    let out = dir.path().join("out-mm");
    let t0 = std::time::Instant::now();
    let o = Command::new("bash")
        .arg("-c")
        .arg("ulimit -v 1048576 && exec \"$0\" eval --map \"$1\" --survey \"$2\" --out \"$3\"")
        .arg(crate::util::BIN)
        .args([&mm, &survey, &out])
        .output()
        .unwrap();
    let secs = t0.elapsed().as_secs_f64();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(4), "{err}");
    assert!(
        err.contains("spread too thin")
            && err.contains("millimetres")
            && err.contains("--scale 0.001")
            // The map's extent set against the survey's (issue 31).
            && err.contains("the points read so far span")
            && err.contains(" km × ")
            && err.contains("The survey's targets span"),
        "{err}"
    );
    // Loose: a loaded test machine; the refusal itself takes a tenth of it.
    assert!(secs < 30.0, "{secs} s");
    converted_scores(
        &mm,
        &["--scale", "0.001"],
        "coordinates × 0.001",
        &survey,
        5,
    );
    let bad = bin()
        .args(["convert", "--scale", "0", "--map"])
        .arg(&mm)
        .arg("--out")
        .arg(dir.path().join("z.pcd"))
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(4), "{}", stderr(&bad));
    assert!(stderr(&bad).contains("--scale 0"), "{}", stderr(&bad));
}

/// A map in longitude and latitude (degrees) read as metres fits the whole
/// site in a centimetre: every surveyed place showed "no map points" and the
/// user was asked whether it was the map of the site. A LAS whose header
/// declares a geographic CRS is refused before any pass, naming the UTM zone
/// to reproject to (`eval`, `detect` and `crop`); a PCD in degrees, which cannot say
/// so, is refused after the ground pass by its extent set against the
/// survey's.
#[test]
fn a_map_in_degrees_is_refused_with_the_zone_to_reproject_to() {
    let dir = tempdir();
    let (map, survey) = scene(dir.path());
    let (lat0, lon0) = (52.5_f64, 13.4_f64);
    let deg: Vec<mapgauge::Point> = mapgauge::cloud::read_all(&map)
        .unwrap()
        .iter()
        .map(|p| {
            mapgauge::Point::new(
                lon0 + p.x / (111_320.0 * lat0.to_radians().cos()),
                lat0 + p.y / 111_320.0,
                p.z,
            )
        })
        .collect();
    let las_path = dir.path().join("geo.las");
    write_las(
        &las_path,
        Some(br#"GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],UNIT["degree",0.0174532925199433]]"#),
        &deg,
        1e-9,
    );
    let err = eval_refused(&las_path, &survey, &[]);
    assert!(
        err.contains("geographic coordinate reference system (WGS 84)")
            && err.contains("longitude and latitude in degrees")
            && err.contains("EPSG:32633"),
        "{err}"
    );
    let o = bin()
        .arg("detect")
        .arg("--map")
        .arg(&las_path)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(stderr(&o).contains("EPSG:32633"), "{}", stderr(&o));
    let o = bin()
        .arg("crop")
        .arg("--map")
        .arg(&las_path)
        .arg("--survey")
        .arg(&survey)
        .arg("--out")
        .arg(dir.path().join("crops"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(stderr(&o).contains("EPSG:32633"), "{}", stderr(&o));
    // Metres across, heights in US survey feet (a compound CRS): z alone
    // is converted, and the map converted so is scored.
    let ft = dir.path().join("ft.las");
    let heights_ft: Vec<mapgauge::Point> = mapgauge::cloud::read_all(&map)
        .unwrap()
        .iter()
        .map(|p| mapgauge::Point::new(p.x, p.y, p.z * 3937.0 / 1200.0))
        .collect();
    write_las(
        &ft,
        Some(br#"COMPD_CS["local UTM + height (ftUS)",PROJCS["WGS 84 / UTM zone 33N",GEOGCS["WGS 84",UNIT["degree",0.0174532925199433]],UNIT["metre",1]],VERT_CS["height (ftUS)",UNIT["US survey foot",0.304800609601219]]]"#),
        &heights_ft,
        1e-4,
    );
    let err = eval_refused(&ft, &survey, &[]);
    assert!(
        err.contains("whose heights are in the US survey foot")
            && err.contains("--scale-z 0.304800609601219`"),
        "{err}"
    );
    converted_scores(
        &ft,
        &["--scale-z", "0.304800609601219"],
        "z × 0.304800609601219",
        &survey,
        5,
    );
    // Without a header to say so: the extent tells.
    let pcd = dir.path().join("geo.pcd");
    mapgauge::cloud::write(&pcd, mapgauge::cloud::OutFormat::Pcd, &deg).unwrap();
    let err = eval_refused(&pcd, &survey, &[]);
    assert!(
        err.contains("m horizontally, where the survey's targets lie up to")
            && err.contains("no frame puts the survey in this map")
            && err.contains("may be longitude and latitude in degrees"),
        "{err}"
    );
}

/// A map written with y up (Open3D's, Unity's convention) was told it held
/// none of the survey's targets. The message now names the likely up axis
/// and `convert --up`, which turns the map back: all five found.
#[test]
fn a_map_with_y_up_is_named_and_convert_up_turns_it() {
    let dir = tempdir();
    let (map, survey) = scene(dir.path());
    let yup: Vec<mapgauge::Point> = mapgauge::cloud::read_all(&map)
        .unwrap()
        .iter()
        .map(|p| mapgauge::Point::new(p.x, p.z, -p.y))
        .collect();
    let path = dir.path().join("yup.pcd");
    mapgauge::cloud::write(&path, mapgauge::cloud::OutFormat::Pcd, &yup).unwrap();
    let err = eval_refused(&path, &survey, &[]);
    assert!(
        err.contains("Or was the map written with y up or down") && err.contains("--up y`"),
        "{err}"
    );
    converted_scores(&path, &["--up", "y"], "turned so its y is +z", &survey, 5);
    // The map as written, not turned: the hint is not given.
    let err = eval_refused(&map, &dir.path().join("nowhere.csv"), &[]);
    assert!(!err.contains("Or its up is not +z"), "{err}");
}

/// A survey of latitude and longitude in each other's columns, at a
/// latitude where both read as valid (48° N, 11° E): the mirror is stretched
/// 1.5× one way, so the x/y exchange did not see it and the user was told
/// the map might be in another frame. It is named; the same survey written
/// the right way round is scored.
#[test]
fn a_survey_with_latitude_and_longitude_swapped_is_named() {
    let dir = tempdir();
    let cfg = dir.path().join("munich.toml");
    std::fs::write(&cfg, "origin_llh = [48.137, 11.575, 520.0]\n").unwrap();
    let scene = dir.path().join("scene");
    stdout_ok(
        bin()
            .args(["synth", "--points", "1000000", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&scene),
    );
    let map = scene.join("map.ply");
    let sw = dir.path().join("swapped_llh.csv");
    edit_survey(&scene.join("survey_llh.csv"), &sw, |f| f.swap(1, 2));
    let e = eval_refused(&map, &sw, &[]);
    assert!(
        e.contains("the survey's latitude and longitude look swapped: read the other way round, 5 of its 5 targets")
            && e.contains("as written, only"),
        "{e}"
    );
    // With the right origin given: it is not exchanged with the rows.
    let e = eval_refused(&map, &sw, &["--origin", "48.137,11.575,520"]);
    assert!(
        e.contains("the survey's latitude and longitude look swapped"),
        "{e}"
    );
    stdout_ok(
        bin()
            .args(["eval", "--no-report", "--map"])
            .arg(&map)
            .arg("--survey")
            .arg(scene.join("survey_llh.csv")),
    );
}

/// Issue 31: a survey with x and y swapped is the map's mirror image. It was
/// scored on the three targets (an isosceles three) that a rotation happened
/// to fit, as if nothing were wrong; it is refused, naming the mistake. A
/// wrong plate size, and an empty map, each get their own diagnosis too
/// (all three were "the map is not in the survey frame").
#[test]
fn a_swapped_survey_a_wrong_plate_size_and_an_empty_map_get_their_own_diagnosis() {
    let dir = tempdir();
    let (map, survey) = scene(dir.path());
    let sw = dir.path().join("swapped.csv");
    edit_survey(&survey, &sw, |f| f.swap(1, 2));
    let o = bin()
        .args(["eval", "--no-report", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&sw)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "the survey is the map's mirror image: with its x and y exchanged, 5 of its 5 targets"
        ),
        "{}",
        stderr(&o)
    );
    // One axis reversed (north-east-down) is a mirror too, named as one.
    let neg = dir.path().join("y_reversed.csv");
    edit_survey(&survey, &neg, |f| add_to_neg(&mut f[2]));
    let e = eval_refused(&map, &neg, &[]);
    assert!(
        e.contains("the survey is the map's mirror image") && e.contains("one axis reversed"),
        "{e}"
    );
    // Plates of another size than --plate-size: said so, with the size seen,
    // instead of "the map is not in the survey frame".
    for (flag, seen) in [("0.4", "0.6"), ("0.8,0.8", "0.5")] {
        let o = bin()
            .args(["eval", "--no-report", "--plate-size", flag, "--map"])
            .arg(&map)
            .arg("--survey")
            .arg(&survey)
            .output()
            .unwrap();
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(4), "{e}");
        assert!(
            e.contains("L's of other plates than configured stand at")
                && e.contains(&format!("plates about {seen}"))
                && e.contains("Is that their size?"),
            "{flag}: {e}"
        );
    }
    let empty = dir.path().join("empty.pcd");
    std::fs::write(
        &empty,
        "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 0\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 0\nDATA binary\n",
    )
    .unwrap();
    let o = bin()
        .args(["eval", "--no-report", "--map"])
        .arg(&empty)
        .arg("--survey")
        .arg(&survey)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "only 0 finite points; a map holds thousands around each target: is this the map?"
        ),
        "{}",
        stderr(&o)
    );
}

/// Issue 31: "the map is not in the survey frame" only when the map holds
/// targets elsewhere. A survey that describes no target of the map (its x
/// stretched: no rigid frame fits) is told apart from a map without targets
/// at all, and each message first says what the surveyed places showed.
#[test]
fn a_survey_of_other_places_and_a_map_without_targets_are_told_apart() {
    let dir = tempdir();
    let (map, survey) = scene(dir.path());
    let stretched = dir.path().join("stretched.csv");
    edit_survey(&survey, &stretched, |f| {
        let x: f64 = f[1].parse().unwrap();
        f[1] = format!("{:.4}", 0.7 * x + 3.0);
    });
    let e = eval_refused(&map, &stretched, &[]);
    assert!(
        e.contains("no target where the survey places them (of its 5 places:")
            && e.contains("detection map-wide found 5 target-shaped object(s)")
            && e.contains("Either the map is in another frame than the survey")
            && e.contains("or the survey does not describe the targets in this map"),
        "{e}"
    );
    // The same map with its targets cut out.
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(map.with_file_name("truth.json")).unwrap())
            .unwrap();
    let at: Vec<[f64; 3]> = truth["targets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            let m = t["map"].as_array().unwrap();
            [0, 1, 2].map(|k| m[k].as_f64().unwrap())
        })
        .collect();
    let pts: Vec<mapgauge::Point> = mapgauge::cloud::read_all(&map)
        .unwrap()
        .into_iter()
        .filter(|p| {
            // Everything within 1.2 m of a target and above its plates'
            // lowest edge (0.8 m below the corner's height, less a margin).
            !at.iter()
                .any(|c| (p.x - c[0]).hypot(p.y - c[1]) < 1.2 && p.z > c[2] - 0.9)
        })
        .collect();
    let bare = dir.path().join("bare.ply");
    mapgauge::cloud::write(&bare, mapgauge::cloud::OutFormat::Ply, &pts).unwrap();
    let e = eval_refused(&bare, &survey, &[]);
    assert!(
        e.contains("no target where the survey places them")
            && e.contains("detection map-wide found no target-shaped object")
            && e.contains("The map holds none of the surveyed targets")
            && !e.contains("another frame")
            // A level site is not taken for a map with another up.
            && !e.contains("Or was the map written with"),
        "{e}"
    );
}

/// Issue 30: objects located where the survey places them but in a layout
/// no map bends to (metres off over tens of metres) were scored "ok" with
/// metre-level errors when too few targets were found for the leave-one-out
/// check; they are set aside, whatever the frame mode, and the run says the
/// survey is the suspect. A survey in feet is named as such.
#[test]
fn a_layout_off_by_metres_is_refused_and_a_survey_in_feet_is_named() {
    let dir = tempdir();
    let (map, survey) = scene(dir.path());
    // Two and three targets, each moved 3 m a different way.
    for (keep, name) in [(2usize, "two.csv"), (3, "three.csv")] {
        let sv = dir.path().join(name);
        let text = std::fs::read_to_string(&survey).unwrap();
        let mut out = String::new();
        for (i, l) in text.lines().enumerate() {
            if i > keep {
                break;
            }
            let mut f: Vec<String> = l.split(',').map(String::from).collect();
            match i {
                1 => add_to(&mut f[1], 3.0),
                2 => add_to(&mut f[2], -3.0),
                _ => {}
            }
            out += &(f.join(",") + "\n");
        }
        std::fs::write(&sv, out).unwrap();
        let e = eval_refused(&map, &sv, &["--frame", "survey"]);
        assert!(
            e.contains("do not stand as the survey places them")
                && e.contains("by more than a working map's error")
                && e.contains("map distances are"),
            "{name}: {e}"
        );
    }
    let feet = dir.path().join("feet.csv");
    edit_survey(&survey, &feet, |f| {
        for k in [1, 2, 3] {
            let v: f64 = f[k].parse().unwrap();
            f[k] = format!("{:.4}", v / 0.3048);
        }
    });
    let e = eval_refused(&map, &feet, &[]);
    assert!(
        e.contains("the survey looks to be in feet") && e.contains("5 of its 5 targets"),
        "{e}"
    );
}

/// Issue 31: a float32 map far from its origin. UTM northings (5.4e6 m)
/// keep half-metre steps: refused, saying so (it was "no frame found");
/// eastings alone (3e5 m, 31 mm steps) are measured, with a warning.
#[test]
fn float32_coordinates_far_from_the_origin_are_named() {
    let dir = tempdir();
    let (map, survey) = scene(dir.path());
    let pts = mapgauge::cloud::read_all(&map).unwrap();
    let shifted = |name: &str, dx: f64, dy: f64| {
        let n = pts.len();
        let mut b = format!(
            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n"
        )
        .into_bytes();
        for p in &pts {
            for v in [p.x + dx, p.y + dy, p.z] {
                b.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
        let m = dir.path().join(format!("{name}.pcd"));
        std::fs::write(&m, b).unwrap();
        let sv = dir.path().join(format!("{name}.csv"));
        edit_survey(&survey, &sv, |f| {
            add_to(&mut f[1], dx);
            add_to(&mut f[2], dy);
        });
        bin()
            .args(["eval", "--no-report", "--map"])
            .arg(&m)
            .arg("--survey")
            .arg(&sv)
            .output()
            .unwrap()
    };
    let o = shifted("utm", 4.5e5, 5.4e6);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(4), "{e}");
    assert!(
        e.contains("stores its coordinates as float32")
            && e.contains("steps of 0.50 m")
            && e.contains("refused"),
        "{e}"
    );
    let o = shifted("east", 3e5, 0.0);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    // A scored run's warnings are in its summary (stdout), once.
    let e = String::from_utf8_lossy(&o.stdout);
    assert!(
        e.contains("warning: the map stores its coordinates as float32")
            && e.contains("steps of 31.2 mm"),
        "{e}"
    );
}

/// Issue 31: a run that cannot score leaves, under `--out` and without any
/// flag, `failed.csv` and a report page drawing what each surveyed place
/// showed (its crop, the reason); the crops themselves only with
/// `--save-crops`, and no result.
#[test]
fn a_failed_eval_leaves_a_failure_page() {
    let dir = tempdir();
    let (map, survey) = scene(dir.path());
    let sv = dir.path().join("moved.csv");
    edit_survey(&survey, &sv, |f| add_to(&mut f[2], 20.0));
    let out = dir.path().join("out");
    let o = bin()
        .args(["eval", "--frame", "survey", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&sv)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(4), "{e}");
    assert!(
        e.contains("failed.csv") && e.contains("report.html") && e.contains("--save-crops"),
        "{e}"
    );
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        page.contains("no result"),
        "the page says the run did not score"
    );
    assert!(
        page.contains("only 0 of 5 targets found"),
        "the page gives the error"
    );
    // One drawing per surveyed place, each with its reason.
    assert_eq!(page.matches("<figure id=\"fig-target-").count(), 5);
    assert!(page.matches("class=\"reason\"").count() >= 5);
    let csv = std::fs::read_to_string(out.join("failed.csv")).unwrap();
    assert_eq!(csv.lines().count(), 6, "{csv}");
    assert!(!out.join("crops").exists(), "crops only with --save-crops");
    assert!(!out.join("result.json").exists());
}

/// Issue 31: `eval --save-crops` of a run that cannot score (the survey 20 m
/// off, `--frame survey`) exits 1 and still writes every loose crop and
/// `failed.csv` with each place's reason; it wrote nothing before.
#[test]
fn a_failed_eval_still_saves_its_crops_and_reasons() {
    let dir = tempdir();
    let (map, survey) = scene(dir.path());
    let sv = dir.path().join("moved.csv");
    edit_survey(&survey, &sv, |f| add_to(&mut f[2], 20.0));
    let out = dir.path().join("out");
    let o = bin()
        .args([
            "eval",
            "--frame",
            "survey",
            "--save-crops",
            "--no-report",
            "--map",
        ])
        .arg(&map)
        .arg("--survey")
        .arg(&sv)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(4), "{e}");
    assert!(e.contains("only 0 of 5 targets found"), "{e}");
    assert!(e.contains("failed.csv"), "{e}");
    let csv = std::fs::read_to_string(out.join("failed.csv")).unwrap();
    assert_eq!(csv.lines().count(), 6, "{csv}");
    assert!(
        csv.starts_with("id,status,x_map,y_map,z_map,loose_points,tight_points,stage,reason\n"),
        "{csv}"
    );
    assert!(
        csv.lines().skip(1).all(|l| l.contains(",not_found,")),
        "{csv}"
    );
    for id in 1..=5 {
        let p = out.join(format!("crops/loose/{id}.ply"));
        assert!(
            !mapgauge::cloud::read_all(&p).unwrap().is_empty(),
            "{}",
            p.display()
        );
    }
    assert!(
        !out.join("result.json").exists(),
        "no result from a run that did not score"
    );
}

/// Signal first (issue 31): what changed the numbers (here, the map was
/// levelled) is said once, before the tables; the caveats every small 2D run
/// carries fold into one note at the end; the terminal gives millimetres
/// throughout.
#[test]
fn the_summary_ranks_its_warnings_and_folds_the_stock_ones() {
    let dir = tempdir();
    let scene = dir.path().join("scene");
    stdout_ok(
        bin()
            .args(["synth", "--points", "600000", "--tilt-deg", "6", "--out"])
            .arg(&scene),
    );
    let o = bin()
        .args(["eval", "--map"])
        .arg(scene.join("map.ply"))
        .arg("--survey")
        .arg(scene.join("survey.csv"))
        .output()
        .unwrap();
    let (out, err) = (String::from_utf8_lossy(&o.stdout).into_owned(), stderr(&o));
    assert!(o.status.success(), "{err}");
    let at = |s: &str| out.find(s).unwrap_or_else(|| panic!("no {s:?} in\n{out}"));
    assert!(at("warning: the map leans") < at("\nTargets\n"), "{out}");
    assert_eq!(
        out.matches("levelled heights are uncertain").count(),
        1,
        "{out}"
    );
    assert!(!err.contains("levelled heights"), "said twice: {err}");
    let notes: Vec<&str> = out.lines().filter(|l| l.starts_with("note: ")).collect();
    assert_eq!(notes.len(), 1, "{out}");
    for part in [
        "5 checkpoints",
        "NSSDA asks for 20",
        "optimistic",
        "vertical accuracy not reported",
    ] {
        assert!(notes[0].contains(part), "{part}: {}", notes[0]);
    }
    assert!(
        !out.contains("warning: only") && !out.contains("warning: vertical"),
        "{out}"
    );
    assert!(
        !out.contains("Tested 0.")
            && out.contains("NSSDA (legacy: ASPRS Ed. 2 no longer uses it): tested "),
        "{out}"
    );
    assert!(out.contains("Relative error (mm, 2D)") && out.contains("Absolute error (mm, 2D)"));
}

/// A user's trial: an `--init` with its yaw's sign flipped placed no
/// target, and the message advised giving `--init`. It now names the one
/// given and its convention.
#[test]
fn a_wrong_init_is_named_not_asked_for() {
    let d = tempdir();
    let (map, survey) = scene(d.path());
    let e = eval_refused(&map, &survey, &["--init", "500,0,90", "--frame", "survey"]);
    assert!(e.contains("The --init given (500, 0, 90°)"), "{e}");
    assert!(!e.contains("If not, give --init"), "{e}");
}

/// A new user's trial: an antenna height typed 0.5 m too large on one
/// target went unseen under `rigid2d+z`, which reports RMSE_V (the blunder
/// test looked only across); with `--dim 3d` the gross-error warning
/// quoted the horizontal σ for a height error. Both now say it is in
/// height and what antenna height would explain it. A 25 cm blunder among
/// four targets is named too (the test asked for five).
#[test]
fn an_antenna_height_typed_wrong_and_a_blunder_among_four_are_named() {
    let dir = tempdir();
    let (map, survey) = scene(dir.path());
    let ah = dir.path().join("antenna.csv");
    edit_survey(&survey, &ah, |f| {
        if f[0] == "3" {
            add_to(&mut f[4], 0.5);
        }
    });
    let run = |s: &Path, extra: &[&str]| {
        let o = bin()
            .args(["eval", "--no-report"])
            .args(extra)
            .arg("--map")
            .arg(&map)
            .arg("--survey")
            .arg(s)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8_lossy(&o.stdout).into_owned() + &stderr(&o)
    };
    for extra in [
        &["--align", "rigid2d+z"][..],
        &["--align", "rigid2d+z", "--dim", "3d"],
        &["--align", "rigid3d"],
    ] {
        let e = run(&ah, extra);
        let w = e
            .lines()
            .find(|l| l.contains("target 3:"))
            .unwrap_or_else(|| panic!("{extra:?}: no warning for target 3 in {e}"));
        assert!(
            w.contains("in height") && w.contains("antenna_height 0.") && w.contains("too large"),
            "{extra:?}: {w}"
        );
    }
    assert!(!run(&survey, &["--align", "rigid2d+z"]).contains("target 3:"));
    // Four targets, one 25 cm off across the line.
    let text = std::fs::read_to_string(&survey).unwrap();
    let four: Vec<&str> = text.lines().take(5).collect();
    let four_csv = dir.path().join("four.csv");
    std::fs::write(&four_csv, four.join("\n") + "\n").unwrap();
    let blunder = dir.path().join("four_blunder.csv");
    edit_survey(&four_csv, &blunder, |f| {
        if f[0] == "3" {
            add_to(&mut f[2], 0.25);
        }
    });
    let e = run(&blunder, &[]);
    assert!(e.contains("target 3: a fit on the other targets"), "{e}");
    assert!(!run(&four_csv, &[]).contains("a fit on the other targets"));
}

/// Two survey typos, 0.7 m and 10 cm: the large one hides the small (the fit
/// it bends spreads the others' errors), so `--exclude-outliers` sets aside
/// the first and the refit condemns the second. Its warning used to say
/// "--exclude-outliers scores the map without it" with that flag on and the
/// target still in the numbers; it now says it stays in them.
#[test]
fn a_gross_error_found_after_exclusion_says_it_stays_in_the_numbers() {
    let dir = tempdir();
    let scene = dir.path().join("scene");
    stdout_ok(
        bin()
            .args([
                "synth",
                "--seed",
                "3",
                "--targets",
                "6",
                "--points",
                "3000000",
                "--out",
            ])
            .arg(&scene),
    );
    let two = dir.path().join("two.csv");
    edit_survey(&scene.join("survey.csv"), &two, |f| match f[0].as_str() {
        "3" => add_to(&mut f[1], 0.7),
        "5" => add_to(&mut f[2], 0.1),
        _ => {}
    });
    let run = |extra: &[&str]| {
        let o = bin()
            .args(["eval", "--no-report"])
            .args(extra)
            .arg("--map")
            .arg(scene.join("map.ply"))
            .arg("--survey")
            .arg(&two)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8_lossy(&o.stdout).into_owned() + &stderr(&o)
    };
    let plain = run(&[]);
    let w3 = plain
        .lines()
        .find(|l| l.starts_with("warning: target 3:"))
        .expect(&plain);
    assert!(
        w3.contains("check it: --exclude-outliers scores the map without it"),
        "{w3}"
    );
    assert!(!plain.contains("warning: target 5:"), "{plain}");
    let excl = run(&["--exclude-outliers"]);
    assert!(
        excl.contains("excluded and the alignment refitted without them: 3"),
        "{excl}"
    );
    let w5 = excl
        .lines()
        .find(|l| l.starts_with("warning: target 5:"))
        .expect(&excl);
    assert!(
        w5.contains("gross error?")
            && w5.contains("it stays in these numbers, as --exclude-outliers sets aside one round")
            && !w5.contains("scores the map without it"),
        "{w5}"
    );
}

/// `eval … 2>&1 | head -1` exited 101 (a panic writing to the closed
/// stderr): with both pipes closed before it writes, the run still ends
/// well and writes its files.
#[test]
fn closed_stdout_and_stderr_do_not_stop_the_run() {
    use std::process::Stdio;
    let dir = tempdir();
    let (map, survey) = scene(dir.path());
    let out = dir.path().join("out");
    let mut child = bin()
        .args(["eval", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&survey)
        .arg("--out")
        .arg(&out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    drop(child.stderr.take());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(0));
    assert!(out.join("result.json").is_file());
}

/// A new user's trial: `locate` on `crop --tight`'s crops failed one
/// target (1 of 2000 draws passed) that `eval --crops` located: eval tries
/// the refit and plain draws, `locate` tried one. It tries both now.
#[test]
fn locate_on_tight_crops_agrees_with_eval() {
    let dir = tempdir();
    let scene = dir.path().join("scene");
    stdout_ok(
        bin()
            .args([
                "synth",
                "--targets",
                "6",
                "--points",
                "2000000",
                "--seed",
                "1",
                "--out",
            ])
            .arg(&scene),
    );
    let crops = dir.path().join("crops");
    stdout_ok(
        bin()
            .args(["crop", "--tight", "--map"])
            .arg(scene.join("map.ply"))
            .arg("--survey")
            .arg(scene.join("survey.csv"))
            .arg("--out")
            .arg(&crops),
    );
    let mut files: Vec<_> = std::fs::read_dir(&crops)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ply"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 6, "{files:?}");
    let out = stdout_ok(bin().arg("locate").args(&files));
    let ok = out
        .lines()
        .filter(|l| l.trim_end().ends_with(" ok"))
        .count();
    assert_eq!(ok, 6, "{out}");
}

/// Spheres surveyed at 200 mm where 145 mm ones stand: each place names
/// the 145 mm sphere near it, and the run says the size is the suspect
/// (it said "the map holds none of the surveyed targets"). Spheres too
/// noisy to fit (2 cm against a 72 mm radius) are named as a possibility
/// beside the frame.
#[test]
fn spheres_of_another_size_or_too_noisy_are_named() {
    let dir = tempdir();
    let scene = dir.path().join("scene");
    stdout_ok(
        bin()
            .args([
                "synth",
                "--models",
                "sphere",
                "--range-noise-m",
                "0.01",
                "--points",
                "3000000",
                "--out",
            ])
            .arg(&scene),
    );
    let map = scene.join("map.ply");
    let wrong = dir.path().join("s200.csv");
    let text = std::fs::read_to_string(scene.join("survey.csv")).unwrap();
    std::fs::write(&wrong, text.replace(",sphere,0.145", ",sphere,0.2")).unwrap();
    let e = eval_refused(&map, &wrong, &[]);
    assert!(
        e.contains("a target of another size than given stands")
            && e.contains("a sphere of 145 mm stands")
            && e.contains("is the size given right"),
        "{e}"
    );
    let noisy = dir.path().join("noisy");
    stdout_ok(
        bin()
            .args([
                "synth", "--models", "sphere", "--points", "2000000", "--out",
            ])
            .arg(&noisy),
    );
    let e = eval_refused(&noisy.join("map.ply"), &noisy.join("survey.csv"), &[]);
    assert!(
        e.contains("Or the spheres stand there but show too few points"),
        "{e}"
    );
}

/// A survey row mistyped by metres (3 m in x): the object the run located
/// for it is the real target, far from where the other targets place it,
/// and nothing stands there. Its reason says where the fit on the others
/// puts that object in the survey's frame, how far the row's line is from
/// it, and that the x alone is off.
#[test]
fn a_row_mistyped_by_metres_names_its_line_and_the_coordinate() {
    let dir = tempdir();
    let scene = dir.path().join("scene");
    stdout_ok(
        bin()
            .args([
                "synth",
                "--seed",
                "3",
                "--targets",
                "6",
                "--points",
                "2000000",
                "--out",
            ])
            .arg(&scene),
    );
    let typo = dir.path().join("typo.csv");
    edit_survey(&scene.join("survey.csv"), &typo, |f| {
        if f[0] == "3" {
            add_to(&mut f[1], 3.0)
        }
    });
    let o = bin()
        .args(["eval", "--no-report", "--map"])
        .arg(scene.join("map.ply"))
        .arg("--survey")
        .arg(&typo)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let row = out.lines().find(|l| l.starts_with("3 ")).expect(&out);
    assert!(row.contains("not_found"), "{row}");
    let (_, hint) = row
        .split_once("if it is this target, the fit on the others puts it at (")
        .expect(row);
    // "... and line 4 of the survey is (+3.007, -0.015) m from that: its x
    // alone, as a mistyped digit would be"
    let (_, off) = hint
        .split_once("and line 4 of the survey is (")
        .expect(hint);
    let (off, rest) = off.split_once(") m from that").expect(off);
    let d: Vec<f64> = off.split(", ").map(|v| v.parse().unwrap()).collect();
    assert!((d[0] - 3.0).abs() < 0.05 && d[1].abs() < 0.05, "{row}");
    assert!(rest.starts_with(": its x alone"), "{row}");
    // The same typo in a latitude (2.2 m north) names it so, in metres.
    let llh = dir.path().join("llh.csv");
    edit_survey(&scene.join("survey_llh.csv"), &llh, |f| {
        if f[0] == "3" {
            add_to(&mut f[1], 0.00002)
        }
    });
    let o = bin()
        .args(["eval", "--no-report", "--map"])
        .arg(scene.join("map.ply"))
        .arg("--survey")
        .arg(&llh)
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    let row = out.lines().find(|l| l.starts_with("3 ")).expect(&out);
    assert!(
        row.contains("m east and north in the survey's local frame, and line 4 of the survey is (")
            && row.ends_with("its latitude (north) alone, as a mistyped digit would be"),
        "{row}"
    );
}
