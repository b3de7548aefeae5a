//! Map formats through the whole command line: the same synthetic scene written as
//! PCD, PLY and LAS (`mapgauge synth --format`) and evaluated (`mapgauge eval`)
//! finds the same targets at the same places.

use crate::util::{bin, tempdir};
use std::collections::BTreeMap;
use std::path::Path;

/// One row of targets.csv: status and the located map position.
type Found = BTreeMap<String, (String, Option<[f64; 3]>)>;

/// synth (1 M points, seed 7) in `format`, eval it; returns targets.csv by id.
fn synth_and_eval(dir: &Path, format: &str) -> Found {
    let scene = dir.join(format!("scene-{format}"));
    let o = bin()
        .args([
            "synth", "--points", "1000000", "--seed", "7", "--format", format,
        ])
        .arg("--out")
        .arg(&scene)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "synth {format}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let ext = match format {
        "pcd-xyzi" | "pcd-fastlio" => "pcd",
        "ply-f32" => "ply",
        f => f,
    };
    let map = scene.join(format!("map.{ext}"));
    let head = std::fs::read(&map).unwrap();
    let magic: &[u8] = match ext {
        "pcd" => b"# .PCD",
        "ply" => b"ply",
        _ => b"LASF",
    };
    assert!(head.starts_with(magic), "{format}: not a {format} file");
    let out = dir.join(format!("eval-{format}"));
    let o = bin()
        .arg("eval")
        .arg("--map")
        .arg(&map)
        .arg("--survey")
        .arg(scene.join("survey.csv"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "eval {format}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let mut rd = csv::Reader::from_path(out.join("targets.csv")).unwrap();
    let head = rd.headers().unwrap().clone();
    let col = |n: &str| head.iter().position(|h| h == n).expect(n);
    let (id, status, mx) = (col("id"), col("status"), col("map_x"));
    rd.records()
        .map(|r| {
            let r = r.unwrap();
            let p = (0..3)
                .map(|k| r[mx + k].parse::<f64>().ok())
                .collect::<Option<Vec<f64>>>()
                .map(|v| [v[0], v[1], v[2]]);
            (r[id].to_string(), (r[status].to_string(), p))
        })
        .collect()
}

#[test]
fn pcd_ply_and_las_maps_find_the_same_targets() {
    let dir = tempdir();
    let pcd = synth_and_eval(dir.path(), "pcd");
    let ply = synth_and_eval(dir.path(), "ply");
    let las = synth_and_eval(dir.path(), "las");
    let ok = pcd.values().filter(|(s, _)| s == "ok").count();
    assert!(ok >= 4, "only {ok} of {} targets found: {pcd:?}", pcd.len());
    // PCD and PLY hold the same numbers: the same result to the printed digit.
    assert_eq!(pcd, ply);
    // LAS rounds to the millimetre: the same targets, positions within a few mm.
    assert_eq!(
        pcd.iter().map(|(k, v)| (k, &v.0)).collect::<Vec<_>>(),
        las.iter().map(|(k, v)| (k, &v.0)).collect::<Vec<_>>()
    );
    for (id, (_, p)) in &pcd {
        if let (Some(a), Some(b)) = (p, &las[id].1) {
            let dh = (a[0] - b[0]).hypot(a[1] - b[1]);
            assert!(dh < 0.005, "target {id}: pcd {a:?}, las {b:?}");
            assert!(
                (a[2] - b[2]).abs() < 0.01,
                "target {id}: pcd {a:?}, las {b:?}"
            );
        }
    }
}

#[test]
fn float32_slam_layouts_find_the_same_targets() {
    // LIO-SAM's, FAST-LIO2's and GLIM's float32 layouts of the same scene:
    // the map's own coordinates rounded to f32 (micrometres here), so the
    // same targets within a fraction of a millimetre of the double map's.
    let dir = tempdir();
    let pcd = synth_and_eval(dir.path(), "pcd");
    for format in ["pcd-xyzi", "pcd-fastlio", "ply-f32"] {
        let got = synth_and_eval(dir.path(), format);
        assert_eq!(
            pcd.iter().map(|(k, v)| (k, &v.0)).collect::<Vec<_>>(),
            got.iter().map(|(k, v)| (k, &v.0)).collect::<Vec<_>>(),
            "{format}"
        );
        for (id, (_, p)) in &pcd {
            if let (Some(a), Some(b)) = (p, &got[id].1) {
                let d = (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max);
                assert!(d < 3e-4, "{format} target {id}: pcd {a:?}, {b:?}");
            }
        }
    }
}

/// Point count of every crop file `mapgauge crop` wrote (its stdout table).
fn crop_counts(map: &Path, survey: &Path, out: &Path) -> Vec<u64> {
    let o = bin()
        .args(["crop", "--map"])
        .arg(map)
        .arg("--survey")
        .arg(survey)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "crop {}: {}",
        map.display(),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .skip(1)
        .map(|l| l.split_whitespace().nth(1).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn convert_to_every_format_keeps_the_crops() {
    let dir = tempdir();
    let scene = dir.path().join("scene");
    let o = bin()
        .args([
            "synth", "--points", "300000", "--seed", "3", "--format", "pcd", "--out",
        ])
        .arg(&scene)
        .output()
        .unwrap();
    assert!(o.status.success());
    let map = scene.join("map.pcd");
    let survey = scene.join("survey.csv");
    let want = crop_counts(&map, &survey, &dir.path().join("c-pcd"));
    assert!(want.iter().all(|&n| n > 0), "{want:?}");
    for (fmt, ext, exact) in [
        ("ply", "ply", true),
        ("pcd-compressed", "pcd", true),
        ("pcd-ascii", "pcd", false),
        ("pcd-f32", "pcd", false),
        ("pcd-xyzi", "pcd", false),
        ("pcd-fastlio", "pcd", false),
        ("ply-f32", "ply", false),
        ("las", "las", false),
        ("laz", "laz", false),
    ] {
        let out = dir.path().join(format!("map-{fmt}.{ext}"));
        let o = bin()
            .args(["convert", "--map"])
            .arg(&map)
            .arg("--out")
            .arg(&out)
            .args(["--format", fmt])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "convert {fmt}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let got = crop_counts(&out, &survey, &dir.path().join(format!("c-{fmt}")));
        for (g, w) in got.iter().zip(&want) {
            // Rounding to micrometres (ascii), to f32 (a few micrometres in
            // this local scene) or millimetres (LAS) moves a few points across
            // the 5 m boundary at most.
            let tol = if exact { 0 } else { 1 + w / 1000 };
            assert!(g.abs_diff(*w) <= tol, "{fmt}: {got:?} vs {want:?}");
        }
    }
    // The input is never overwritten.
    let o = bin()
        .args(["convert", "--map"])
        .arg(&map)
        .arg("--out")
        .arg(&map)
        .output()
        .unwrap();
    assert!(!o.status.success());
}

#[test]
fn convert_keeps_intensity_where_the_output_holds_it() {
    let dir = tempdir();
    let scene = dir.path().join("scene");
    let o = bin()
        .args([
            "synth", "--points", "100000", "--seed", "5", "--format", "pcd-xyzi", "--out",
        ])
        .arg(&scene)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let map = scene.join("map.pcd");
    let bytes = std::fs::read(&map).unwrap();
    let head = bytes
        .windows(12)
        .position(|w| w == b"DATA binary\n")
        .unwrap()
        + 12;
    let f = |k: usize, c: usize| {
        let o = head + 16 * k + 4 * c;
        f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap())
    };
    let n = (bytes.len() - head) / 16;
    let convert = |out: &Path, extra: &[&str]| {
        let o = bin()
            .args(["convert", "--map"])
            .arg(&map)
            .arg("--out")
            .arg(out)
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    // XYZ text, by extension and by `--to`: x y z intensity, every point,
    // under a header naming the columns, so that the intensity reads back.
    for (name, extra) in [("a.xyz", &[][..]), ("b.txt", &["--to", "xyz"][..])] {
        let out = dir.path().join(name);
        let said = convert(&out, extra);
        assert!(
            said.contains(&format!("{n} points")) && said.contains("with intensity"),
            "{said}"
        );
        let text = std::fs::read_to_string(&out).unwrap();
        let lines: Vec<&str> = text.lines().skip(1).collect();
        assert_eq!(text.lines().next(), Some("x y z intensity"));
        assert_eq!(lines.len(), n);
        let mut r = mapgauge::cloud::open(&out).unwrap();
        assert!(r.has_intensity(), "{name}: its intensity not read back");
        let (mut pts, mut inten) = (Vec::new(), Vec::new());
        let mut back = Vec::new();
        while r.next_chunk_intensity(&mut pts, &mut inten).unwrap() {
            back.extend(inten.iter().copied());
        }
        assert_eq!(back.len(), n);
        assert!((0..n).all(|k| back[k] == f(k, 3)), "{name}: intensities");
        for k in [0, 1, n / 2, n - 1] {
            let v: Vec<f64> = lines[k].split(' ').map(|t| t.parse().unwrap()).collect();
            assert_eq!(v.len(), 4, "{}", lines[k]);
            for c in 0..3 {
                assert!((v[c] - f64::from(f(k, c))).abs() <= 5e-7, "{}", lines[k]);
            }
            assert_eq!(v[3] as f32, f(k, 3), "{}", lines[k]);
        }
    }
    // Float PLY: an intensity property with the same values.
    let out = dir.path().join("c.ply");
    convert(&out, &["--format", "ply-f32"]);
    let ply = std::fs::read(&out).unwrap();
    let text = String::from_utf8_lossy(&ply[..400]);
    assert!(
        text.contains("property float intensity\nend_header\n"),
        "{text}"
    );
    let body = &ply[text.find("end_header\n").unwrap() + 11..];
    assert_eq!(body, &bytes[head..]);
    // Double PLY: the same property after double x, y, z.
    let out = dir.path().join("d.ply");
    convert(&out, &[]);
    let ply = std::fs::read(&out).unwrap();
    let text = String::from_utf8_lossy(&ply[..400]);
    assert!(
        text.contains("property double z\nproperty float intensity\nend_header\n"),
        "{text}"
    );
    let body = &ply[text.find("end_header\n").unwrap() + 11..];
    assert_eq!(body.len(), 28 * n);
    for k in [0, 1, n / 2, n - 1] {
        let r = &body[28 * k..28 * k + 28];
        let i = f32::from_le_bytes(r[24..].try_into().unwrap());
        assert_eq!(i, f(k, 3), "intensity of point {k}");
    }
    // A format without an intensity field drops it, said by omission.
    let said = convert(&dir.path().join("d.pcd"), &["--format", "pcd"]);
    assert!(!said.contains("intensity"), "{said}");
}
