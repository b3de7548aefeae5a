//! Helpers shared by every module of the integration-test binary.

use std::process::{Command, Output};

/// The mapgauge binary Cargo built for these tests.
pub const BIN: &str = env!("CARGO_BIN_EXE_mapgauge");

/// A command running the mapgauge binary.
pub fn bin() -> Command {
    Command::new(BIN)
}

/// A run's stderr as text (lossy: a test must still show bytes that are not UTF-8).
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `mapgauge synth --out SCENE ARGS...`, which must succeed.
pub fn synth_into(scene: &std::path::Path, args: &[&str]) {
    let out = bin()
        .arg("synth")
        .arg("--out")
        .arg(scene)
        .args(args)
        .output()
        .unwrap();
    assert!(out.status.success(), "synth: {}", stderr(&out));
}

/// Runs `cmd`, which must succeed (its stderr is the failure message); returns stdout.
pub fn stdout_ok(cmd: &mut Command) -> String {
    let out = cmd.output().expect("spawn mapgauge");
    assert!(out.status.success(), "{cmd:?}: {}", stderr(&out));
    String::from_utf8(out.stdout).expect("stdout is UTF-8")
}

/// Writes `to`: the survey CSV `from` with `edit` applied to each data row's
/// fields (the header kept), e.g. a survey moved or with columns swapped.
pub fn edit_survey(from: &std::path::Path, to: &std::path::Path, edit: impl Fn(&mut Vec<String>)) {
    let text = std::fs::read_to_string(from).expect("read the survey");
    let mut lines = text.lines();
    let mut out = format!("{}\n", lines.next().expect("a header"));
    for l in lines {
        let mut f: Vec<String> = l.split(',').map(String::from).collect();
        edit(&mut f);
        out += &(f.join(",") + "\n");
    }
    std::fs::write(to, out).expect("write the survey");
}

/// Adds `d` to a CSV field holding a number (4 decimals, as surveys are).
pub fn add_to(field: &mut String, d: f64) {
    *field = format!("{:.4}", field.parse::<f64>().expect("a number") + d);
}

/// A fresh temporary directory, removed when dropped.
pub fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("create a temporary directory")
}

/// The oracle's corner of target `target` (0-based): a least-squares plane
/// through each plate's own returns (the labels synth knows: no detection,
/// no outliers), the point where the two planes cross at the mean height of
/// their points, as the paper defines the corner. `None` when a plate has
/// fewer than 3 returns.
/// Computed about `near` (the true corner) to keep the squares small.
pub fn oracle_corner(
    map: &[mapgauge::Point],
    labels: &[mapgauge::synth::PointLabel],
    target: usize,
    near: nalgebra::Vector3<f64>,
) -> Option<nalgebra::Vector3<f64>> {
    use mapgauge::synth::PointLabel;
    use nalgebra::{Matrix3, Vector3};
    let plate = |k: u8| -> Vec<Vector3<f64>> {
        map.iter()
            .zip(labels)
            .filter(|(_, l)| {
                **l == PointLabel::Plate {
                    target: target as u32,
                    plate: k,
                }
            })
            .map(|(p, _)| p.coords - near)
            .collect()
    };
    let (a, b) = (plate(0), plate(1));
    if a.len() < 3 || b.len() < 3 {
        return None;
    }
    // Normal = the least-variance direction.
    let fit = |pts: &[Vector3<f64>]| {
        let c = pts.iter().sum::<Vector3<f64>>() / pts.len() as f64;
        let mut m = Matrix3::zeros();
        for p in pts {
            let d = p - c;
            m += d * d.transpose();
        }
        let e = m.symmetric_eigen();
        (c, e.eigenvectors.column(e.eigenvalues.imin()).into_owned())
    };
    let ((ca, na), (cb, nb)) = (fit(&a), fit(&b));
    let z = a.iter().chain(&b).map(|p| p.z).sum::<f64>() / (a.len() + b.len()) as f64;
    // Both planes at height z: n·(x, y, z) = n·c.
    let (ra, rb) = (na.dot(&ca) - na.z * z, nb.dot(&cb) - nb.z * z);
    let det = na.x * nb.y - na.y * nb.x;
    if det.abs() < 1e-6 {
        return None;
    }
    let x = (ra * nb.y - rb * na.y) / det;
    let y = (na.x * rb - nb.x * ra) / det;
    Some(near + Vector3::new(x, y, z))
}

/// `pts` written as LAS 1.4 (point format 0), with `wkt` as its CRS when
/// given; x and y stored to `step`, z to 0.1 mm, about the first point.
pub fn write_las(path: &std::path::Path, wkt: Option<&[u8]>, pts: &[mapgauge::Point], step: f64) {
    let mut b = las::Builder::from((1, 4));
    b.point_format = las::point::Format::new(0).unwrap();
    let t = |scale: f64, offset: f64| las::Transform {
        scale,
        offset: offset.round(),
    };
    b.transforms = las::Vector {
        x: t(step, pts[0].x),
        y: t(step, pts[0].y),
        z: t(1e-4, pts[0].z),
    };
    let mut h = b.into_header().unwrap();
    if let Some(w) = wkt {
        h.set_wkt_crs(w.to_vec()).unwrap();
    }
    let mut w = las::Writer::from_path(path, h).unwrap();
    for p in pts {
        w.write_point(las::Point {
            x: p.x,
            y: p.y,
            z: p.z,
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
}

/// `convert` of `from` with `flags` (saying `told`), then `eval` of the
/// map it wrote against `survey`: every one of the survey's `n` targets
/// found.
pub fn converted_scores(
    from: &std::path::Path,
    flags: &[&str],
    told: &str,
    survey: &std::path::Path,
    n: usize,
) {
    let dir = from.parent().unwrap();
    let stem = from.file_stem().unwrap().to_string_lossy();
    let back = dir.join(format!("{stem}-converted.pcd"));
    let said = stdout_ok(
        bin()
            .arg("convert")
            .args(flags)
            .arg("--map")
            .arg(from)
            .arg("--out")
            .arg(&back),
    );
    assert!(said.contains(told), "{said}");
    let out = dir.join(format!("{stem}-converted-out"));
    stdout_ok(
        bin()
            .args(["eval", "--no-report", "--map"])
            .arg(&back)
            .arg("--survey")
            .arg(survey)
            .arg("--out")
            .arg(&out),
    );
    let csv = std::fs::read_to_string(out.join("targets.csv")).unwrap();
    assert_eq!(
        csv.lines().filter(|l| l.contains(",ok,")).count(),
        n,
        "{csv}"
    );
}
