//! Tests of the PCD reader and the PLY/PCD writers, on hand-written fixtures in
//! the layouts PCL, Open3D, LIO-SAM and FAST-LIO produce.

use super::*;
use crate::cloud::{self, CloudWriter, OutFormat};

/// (name, TYPE, SIZE, COUNT)
type F = (&'static str, char, usize, usize);

fn header(fields: &[F], width: u64, height: u64, data: &str) -> String {
    let list = |f: &dyn Fn(&F) -> String| fields.iter().map(f).collect::<Vec<_>>().join(" ");
    format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {}\nSIZE {}\nTYPE {}\nCOUNT {}\n\
         WIDTH {width}\nHEIGHT {height}\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA {data}\n",
        list(&|f| f.0.to_string()),
        list(&|f| f.2.to_string()),
        list(&|f| f.1.to_string()),
        list(&|f| f.3.to_string()),
        width * height
    )
}

fn encode(ty: char, size: usize, v: f64, out: &mut Vec<u8>) {
    match (ty, size) {
        ('F', 4) => out.extend_from_slice(&(v as f32).to_le_bytes()),
        ('F', 8) => out.extend_from_slice(&v.to_le_bytes()),
        ('I', 1) => out.extend_from_slice(&(v as i8).to_le_bytes()),
        ('I', 2) => out.extend_from_slice(&(v as i16).to_le_bytes()),
        ('I', 4) => out.extend_from_slice(&(v as i32).to_le_bytes()),
        ('I', 8) => out.extend_from_slice(&(v as i64).to_le_bytes()),
        ('U', 1) => out.extend_from_slice(&(v as u8).to_le_bytes()),
        ('U', 2) => out.extend_from_slice(&(v as u16).to_le_bytes()),
        ('U', 4) => out.extend_from_slice(&(v as u32).to_le_bytes()),
        ('U', 8) => out.extend_from_slice(&(v as u64).to_le_bytes()),
        _ => panic!("bad test type"),
    }
}

/// Value of field `name` (element `k`) for a point: x, y, z from the point,
/// anything else a recognisable junk value.
fn value(name: &str, k: usize, p: &[f64; 3]) -> f64 {
    match name {
        "x" => p[0],
        "y" => p[1],
        "z" => p[2],
        _ => 100.0 + k as f64,
    }
}

/// Row-wise binary records.
fn binary(fields: &[F], pts: &[[f64; 3]]) -> Vec<u8> {
    let mut out = Vec::new();
    for p in pts {
        for f in fields {
            for k in 0..f.3 {
                encode(f.1, f.2, value(f.0, k, p), &mut out);
            }
        }
    }
    out
}

/// PCL's binary_compressed payload: column-wise, LZF, two u32 sizes.
fn compressed(fields: &[F], pts: &[[f64; 3]]) -> Vec<u8> {
    let mut cols = Vec::new();
    for f in fields {
        for p in pts {
            for k in 0..f.3 {
                encode(f.1, f.2, value(f.0, k, p), &mut cols);
            }
        }
    }
    let packed = crate::cloud::write::lzf_block(&cols);
    let mut out = Vec::new();
    out.extend_from_slice(&(packed.len() as u32).to_le_bytes());
    out.extend_from_slice(&(cols.len() as u32).to_le_bytes());
    out.extend_from_slice(&packed);
    out
}

fn ascii(fields: &[F], pts: &[[f64; 3]]) -> Vec<u8> {
    let mut s = String::new();
    for p in pts {
        let mut toks = Vec::new();
        for f in fields {
            for k in 0..f.3 {
                let v = value(f.0, k, p);
                toks.push(if v.is_nan() {
                    "nan".to_string()
                } else {
                    format!("{v}")
                });
            }
        }
        s.push_str(&toks.join(" "));
        s.push('\n');
    }
    s.into_bytes()
}

fn file(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn make(
    dir: &tempfile::TempDir,
    name: &str,
    fields: &[F],
    w: u64,
    h: u64,
    data: &str,
    pts: &[[f64; 3]],
) -> PathBuf {
    let mut bytes = header(fields, w, h, data).into_bytes();
    bytes.extend(match data {
        "binary" => binary(fields, pts),
        "binary_compressed" => compressed(fields, pts),
        _ => ascii(fields, pts),
    });
    file(dir, name, &bytes)
}

fn read(path: &Path) -> Result<(Vec<[f64; 3]>, ReadStats)> {
    let mut r = cloud::open(path)?;
    let mut all = Vec::new();
    let mut buf = Vec::new();
    while r.next_chunk(&mut buf)? {
        assert!(!buf.is_empty());
        all.extend(buf.iter().map(|p| [p.x, p.y, p.z]));
    }
    assert!(!r.next_chunk(&mut buf)?);
    Ok((all, r.stats()))
}

fn err(path: &Path) -> String {
    match read(path) {
        Ok(_) => panic!("{} read without error", path.display()),
        Err(e) => e.to_string(),
    }
}

fn sample(n: usize) -> Vec<[f64; 3]> {
    (0..n)
        .map(|i| [i as f64 * 0.5, -(i as f64) * 0.25, (i % 7) as f64])
        .collect()
}

const PCL_RGB: &[F] = &[
    ("x", 'F', 4, 1),
    ("y", 'F', 4, 1),
    ("z", 'F', 4, 1),
    ("_", 'U', 1, 4),
    ("rgb", 'F', 4, 1),
    ("_", 'U', 1, 12),
];
const VELODYNE: &[F] = &[
    ("x", 'F', 4, 1),
    ("y", 'F', 4, 1),
    ("z", 'F', 4, 1),
    ("intensity", 'F', 4, 1),
    ("ring", 'U', 2, 1),
    ("time", 'F', 4, 1),
];
const LIO_SAM_POSE: &[F] = &[
    ("x", 'F', 4, 1),
    ("y", 'F', 4, 1),
    ("z", 'F', 4, 1),
    ("_", 'U', 1, 4),
    ("intensity", 'F', 4, 1),
    ("roll", 'F', 4, 1),
    ("pitch", 'F', 4, 1),
    ("yaw", 'F', 4, 1),
    ("time", 'F', 8, 1),
];
const FAST_LIO: &[F] = &[
    ("x", 'F', 4, 1),
    ("y", 'F', 4, 1),
    ("z", 'F', 4, 1),
    ("intensity", 'F', 4, 1),
    ("normal_x", 'F', 4, 1),
    ("normal_y", 'F', 4, 1),
    ("normal_z", 'F', 4, 1),
    ("curvature", 'F', 4, 1),
];

#[test]
fn reads_writer_layouts_in_every_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let pts = sample(1000);
    for (lname, fields) in [
        ("pcl", PCL_RGB),
        ("velodyne", VELODYNE),
        ("liosam", LIO_SAM_POSE),
        ("fastlio", FAST_LIO),
    ] {
        for data in ["ascii", "binary", "binary_compressed"] {
            let p = make(
                &dir,
                &format!("{lname}_{data}.pcd"),
                fields,
                pts.len() as u64,
                1,
                data,
                &pts,
            );
            assert_eq!(cloud::detect(&p).unwrap(), cloud::Format::Pcd);
            let (got, stats) = read(&p).unwrap_or_else(|e| panic!("{lname} {data}: {e}"));
            assert_eq!(got, pts, "{lname} {data}");
            assert_eq!(
                stats,
                ReadStats {
                    points: 1000,
                    skipped_nonfinite: 0
                }
            );
        }
    }
}

#[test]
fn open3d_ascii_with_packed_rgb_and_crlf() {
    let dir = tempfile::tempdir().unwrap();
    let text = "# .PCD v0.7 - Point Cloud Data file format\r\nVERSION 0.7\r\nFIELDS x y z rgb\r\nSIZE 4 4 4 4\r\n\
                TYPE F F F F\r\nCOUNT 1 1 1 1\r\nWIDTH 3\r\nHEIGHT 1\r\nVIEWPOINT 0 0 0 1 0 0 0\r\nPOINTS 3\r\nDATA ascii\r\n\
                1.5 2.5 3.5 4.2108e+06\r\n-1 -2 -3 0\r\n1e-3 2E2 -0.0 1.7e38\r\n";
    let p = file(&dir, "o3d.pcd", text.as_bytes());
    let (got, _) = read(&p).unwrap();
    assert_eq!(
        got,
        vec![[1.5, 2.5, 3.5], [-1.0, -2.0, -3.0], [1e-3, 200.0, -0.0]]
    );
}

#[test]
fn v05_header_without_count_viewpoint_or_width() {
    let dir = tempfile::tempdir().unwrap();
    let text = "# .PCD v.5 - Point Cloud Data file format\nVERSION .5\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n\
                POINTS 2\nDATA ascii\n1 2 3\n4 5 6\n";
    let p = file(&dir, "v05.pcd", text.as_bytes());
    assert_eq!(read(&p).unwrap().0, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
}

#[test]
fn xyz_anywhere_and_of_any_type() {
    let dir = tempfile::tempdir().unwrap();
    let fields: &[F] = &[
        ("intensity", 'F', 4, 1),
        ("z", 'I', 2, 1),
        ("pad", 'U', 1, 3),
        ("x", 'I', 4, 1),
        ("normal", 'F', 4, 3),
        ("y", 'U', 8, 1),
    ];
    let pts: Vec<[f64; 3]> = (0..100)
        .map(|i| [i as f64 - 50.0, i as f64 * 1000.0, -(i as f64)])
        .collect();
    for data in ["ascii", "binary", "binary_compressed"] {
        let p = make(
            &dir,
            &format!("mixed_{data}.pcd"),
            fields,
            100,
            1,
            data,
            &pts,
        );
        assert_eq!(read(&p).unwrap().0, pts, "{data}");
    }
    let f64s: &[F] = &[
        ("y", 'F', 8, 1),
        ("x", 'F', 8, 1),
        ("z", 'F', 8, 1),
        ("t", 'F', 8, 1),
    ];
    let big: Vec<[f64; 3]> = (0..100)
        .map(|i| {
            [
                350000.123456789 + i as f64 * 1e-9,
                4150000.987654321,
                12.000000001,
            ]
        })
        .collect();
    for data in ["ascii", "binary", "binary_compressed"] {
        let p = make(&dir, &format!("f64_{data}.pcd"), f64s, 100, 1, data, &big);
        assert_eq!(read(&p).unwrap().0, big, "{data}");
    }
}

#[test]
fn organised_cloud_skips_and_counts_nan_points() {
    let dir = tempfile::tempdir().unwrap();
    let mut pts = sample(12);
    for i in [0, 5, 6, 11] {
        pts[i] = [f64::NAN; 3];
    }
    pts[3][2] = f64::INFINITY;
    let want: Vec<[f64; 3]> = pts
        .iter()
        .copied()
        .filter(|p| p.iter().all(|v| v.is_finite()))
        .collect();
    for data in ["ascii", "binary", "binary_compressed"] {
        let p = make(&dir, &format!("org_{data}.pcd"), PCL_RGB, 4, 3, data, &pts);
        let (got, stats) = read(&p).unwrap();
        assert_eq!(got, want, "{data}");
        assert_eq!(
            stats,
            ReadStats {
                points: 7,
                skipped_nonfinite: 5
            },
            "{data}"
        );
    }
    // A chunk made only of NaN points is skipped, not returned empty.
    let p = make(
        &dir,
        "allnan.pcd",
        PCL_RGB,
        2,
        2,
        "binary",
        &[[f64::NAN; 3]; 4],
    );
    assert_eq!(
        read(&p).unwrap(),
        (
            vec![],
            ReadStats {
                points: 0,
                skipped_nonfinite: 4
            }
        )
    );
}

#[test]
fn large_binary_keeps_order_across_tasks_and_chunks() {
    let dir = tempfile::tempdir().unwrap();
    let n = CHUNK_POINTS + 3 * TASK_POINTS + 17;
    let mut pts: Vec<[f64; 3]> = (0..n).map(|i| [i as f64, (i % 1000) as f64, 1.0]).collect();
    let mut nan = 0;
    for i in (0..n).step_by(9973) {
        pts[i][1] = f64::NAN;
        nan += 1;
    }
    let fields: &[F] = &[("x", 'F', 4, 1), ("y", 'F', 4, 1), ("z", 'F', 4, 1)];
    let want: Vec<[f64; 3]> = pts.iter().copied().filter(|p| !p[1].is_nan()).collect();
    for data in ["binary", "binary_compressed"] {
        let p = make(
            &dir,
            &format!("big_{data}.pcd"),
            fields,
            n as u64,
            1,
            data,
            &pts,
        );
        let mut r = cloud::open(&p).unwrap();
        assert_eq!(r.info().declared_points, Some(n as u64));
        let mut buf = Vec::new();
        let mut got = Vec::new();
        let mut chunks = 0;
        while r.next_chunk(&mut buf).unwrap() {
            chunks += 1;
            got.extend(buf.iter().map(|p| [p.x, p.y, p.z]));
        }
        assert!(chunks >= 1);
        assert_eq!(r.bytes_read(), r.info().file_bytes);
        assert_eq!(got, want, "{data}");
        assert_eq!(r.stats().skipped_nonfinite, nan);
    }
}

#[test]
fn empty_cloud() {
    let dir = tempfile::tempdir().unwrap();
    let fields: &[F] = &[("x", 'F', 4, 1), ("y", 'F', 4, 1), ("z", 'F', 4, 1)];
    for data in ["ascii", "binary", "binary_compressed"] {
        let mut bytes = header(fields, 0, 1, data).into_bytes();
        if data == "binary_compressed" {
            bytes.extend_from_slice(&[0; 8]);
        }
        let p = file(&dir, &format!("empty_{data}.pcd"), &bytes);
        assert_eq!(read(&p).unwrap().0, Vec::<[f64; 3]>::new(), "{data}");
    }
}

fn replace_header(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from}");
    text.replacen(from, to, 1)
}

#[test]
fn header_errors_are_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let pts = sample(3);
    let fields: &[F] = &[
        ("x", 'F', 4, 1),
        ("y", 'F', 4, 1),
        ("z", 'F', 4, 1),
        ("i", 'U', 2, 1),
    ];
    let good =
        String::from_utf8(make(&dir, "good.pcd", fields, 3, 1, "ascii", &pts).pipe_read()).unwrap();
    let cases: &[(&str, &str, &str)] = &[
        (
            "TYPE F F F U",
            "TYPE F F F Q",
            "unknown TYPE 'Q' for field 'i'",
        ),
        (
            "SIZE 4 4 4 2",
            "SIZE 4 2 4 2",
            "field 'y' has TYPE F with SIZE 2",
        ),
        (
            "SIZE 4 4 4 2",
            "SIZE 4 4 4 2 4",
            "SIZE has 5 entries but FIELDS (line 3) has 4",
        ),
        (
            "COUNT 1 1 1 1",
            "COUNT 1 1 1",
            "COUNT has 3 entries but FIELDS (line 3) has 4",
        ),
        ("COUNT 1 1 1 1", "COUNT 1 0 1 1", "COUNT value '0'"),
        (
            "FIELDS x y z i",
            "FIELDS x y q i",
            "no field 'z' in FIELDS x y q i",
        ),
        ("DATA ascii", "DATA zip", "unknown DATA 'zip'"),
        ("DATA ascii\n", "", "header ends without a DATA line"),
        (
            "WIDTH 3",
            "WIDTH 4",
            "WIDTH 4 x HEIGHT 1 does not equal POINTS 3",
        ),
        ("POINTS 3", "POINTS three", "POINTS value 'three'"),
        (
            "POINTS 3",
            "POINTS 4",
            "header declares POINTS 4 but the data ends after 3 points",
        ),
        ("WIDTH 3", "WIDTH 4", "does not equal"),
    ];
    for (i, (from, to, want)) in cases.iter().enumerate() {
        let mut text = replace_header(&good, from, to);
        if *from == "POINTS 3" && *to == "POINTS 4" {
            text = replace_header(&text, "WIDTH 3", "WIDTH 4");
        }
        let p = file(&dir, &format!("bad{i}.pcd"), text.as_bytes());
        let e = err(&p);
        assert!(e.contains(want), "case {i}: got `{e}`, want `{want}`");
        assert!(e.contains(&format!("bad{i}.pcd")), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
    // Non-UTF-8 header line.
    let mut bytes = b"# .PCD v0.7\nVERSION 0.7\nFIELDS x y \xff z\n".to_vec();
    bytes.extend_from_slice(b"DATA ascii\n");
    let p = file(&dir, "utf.pcd", &bytes);
    assert!(
        err(&p).contains(".pcd:3: header line is not UTF-8"),
        "{}",
        err(&p)
    );
    // A header that never ends (no newline, no DATA, bigger than the limit).
    let mut bytes = b"VERSION 0.7\n# ".to_vec();
    bytes.resize(MAX_HEADER + 100, b'a');
    let p = file(&dir, "endless.pcd", &bytes);
    assert!(err(&p).contains("no DATA line within"), "{}", err(&p));
    // Bad ascii value names line and field.
    let text = replace_header(&good, "\n0.5 -0.25 1 100\n", "\n0.5 oops 1 100\n");
    let p = file(&dir, "badval.pcd", text.as_bytes());
    assert!(
        err(&p).contains(".pcd:13: field 'y' value 'oops' is not a number"),
        "{}",
        err(&p)
    );
    let text = replace_header(&good, "\n0.5 -0.25 1 100\n", "\n0.5 -0.25\n");
    let p = file(&dir, "short.pcd", text.as_bytes());
    assert!(
        err(&p).contains(".pcd:13: expected 4 values, found 2"),
        "{}",
        err(&p)
    );
}

trait PipeRead {
    fn pipe_read(&self) -> Vec<u8>;
}
impl PipeRead for PathBuf {
    fn pipe_read(&self) -> Vec<u8> {
        std::fs::read(self).unwrap()
    }
}

#[test]
fn binary_data_errors() {
    let dir = tempfile::tempdir().unwrap();
    let pts = sample(10);
    // Truncated binary: 10 declared, 7.5 present.
    let full = make(&dir, "full.pcd", PCL_RGB, 10, 1, "binary", &pts).pipe_read();
    let cut = &full[..full.len() - 32 * 2 - 16];
    let p = file(&dir, "cut.pcd", cut);
    let e = err(&p);
    assert!(
        e.contains("declares POINTS 10") && e.contains("(7 whole points)"),
        "{e}"
    );
    // POINTS larger than any file could hold: no allocation, clear error.
    let text = String::from_utf8_lossy(&full[..200]).to_string();
    let head_end = full
        .windows(12)
        .position(|w| w == b"DATA binary\n")
        .unwrap()
        + 12;
    let mut huge = String::from_utf8(full[..head_end].to_vec()).unwrap();
    huge = huge
        .replace("WIDTH 10", "WIDTH 18446744073709551615")
        .replace("POINTS 10", "POINTS 18446744073709551615");
    let p = file(&dir, "huge.pcd", huge.as_bytes());
    assert!(
        err(&p).contains("truncated binary data"),
        "{} {text}",
        err(&p)
    );
    // binary_compressed: sizes disagreeing with the header, truncation, corruption.
    let comp = make(&dir, "comp.pcd", PCL_RGB, 10, 1, "binary_compressed", &pts).pipe_read();
    let head_end = comp
        .windows(23)
        .position(|w| w == b"DATA binary_compressed\n")
        .unwrap()
        + 23;
    let mut wrong = comp.clone();
    wrong[head_end + 4..head_end + 8].copy_from_slice(&1000u32.to_le_bytes());
    let p = file(&dir, "wrongsize.pcd", &wrong);
    assert!(
        err(&p).contains("uncompressed size 1000 does not match POINTS 10 x 32-byte points = 320"),
        "{}",
        err(&p)
    );
    let p = file(&dir, "compcut.pcd", &comp[..comp.len() - 5]);
    assert!(
        err(&p).contains("truncated binary_compressed data"),
        "{}",
        err(&p)
    );
    let mut bad = comp.clone();
    bad[head_end + 8] = 0xff; // a back-reference before the start of the output
    let p = file(&dir, "corrupt.pcd", &bad);
    assert!(
        err(&p).contains("binary_compressed data is corrupt"),
        "{}",
        err(&p)
    );
    let p = file(&dir, "nosizes.pcd", &comp[..head_end + 3]);
    assert!(err(&p).contains("need at least 8"), "{}", err(&p));
}

#[test]
fn lzf_decoder_matches_lzf_crate() {
    let mut data = Vec::new();
    for i in 0..200_000u32 {
        data.extend_from_slice(&((i / 7) as f32).to_le_bytes());
        if i % 3 == 0 {
            data.push((i % 251) as u8);
        }
    }
    let packed = lzf::compress(&data).unwrap();
    assert_eq!(lzf_decompress(&packed, data.len()).unwrap(), data);
    assert!(lzf_decompress(&packed, data.len() - 1).is_err());
    assert!(lzf_decompress(&packed, data.len() + 1).is_err());
    assert!(lzf_decompress(&packed[..packed.len() - 1], data.len()).is_err());
}

#[test]
fn pcd_writer_round_trips_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let pts: Vec<Point> = (0..5000)
        .map(|i| {
            Point::new(
                4_150_000.123456789 + i as f64 * 1e-7,
                350_000.000000001 - i as f64,
                0.1 * i as f64,
            )
        })
        .collect();
    let p = dir.path().join("out.pcd");
    let mut w = CloudWriter::create(&p, OutFormat::Pcd).unwrap();
    w.write(&pts[..1234]).unwrap();
    w.write(&[]).unwrap();
    w.write(&pts[1234..]).unwrap();
    assert!(!p.exists(), "file appears only on finish");
    assert_eq!(w.finish().unwrap(), 5000);
    assert_eq!(cloud::read_all(&p).unwrap(), pts);
    let bytes = std::fs::read(&p).unwrap();
    let text = String::from_utf8_lossy(&bytes[..300]);
    assert!(text.starts_with("# .PCD v0.7"), "{text}");
    assert!(
        text.contains(
            "\nWIDTH 5000\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 5000\nDATA binary\n"
        ),
        "{text}"
    );
    // Only the final file is left in the directory.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("out.pcd")]);
    // Empty output is valid too.
    let e = dir.path().join("empty.pcd");
    cloud::write(&e, OutFormat::Pcd, &[]).unwrap();
    assert!(cloud::read_all(&e).unwrap().is_empty());
}

#[test]
fn ply_writer_output_is_standard_binary_ply() {
    let dir = tempfile::tempdir().unwrap();
    let pts: Vec<Point> = (0..321)
        .map(|i| Point::new(i as f64 + 0.5, -3.25 * i as f64, 4e6 + 1e-6 * i as f64))
        .collect();
    let p = dir.path().join("out.ply");
    cloud::write(&p, OutFormat::Ply, &pts).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let head = std::str::from_utf8(&bytes[..end]).unwrap();
    let lines: Vec<&str> = head.lines().map(|l| l.trim_end()).collect();
    assert_eq!(
        lines,
        [
            "ply",
            "format binary_little_endian 1.0",
            "comment written by mapgauge",
            "element vertex 321",
            "property double x",
            "property double y",
            "property double z",
            "end_header"
        ]
    );
    let body = &bytes[end..];
    assert_eq!(body.len(), 321 * 24);
    for (i, rec) in body.chunks_exact(24).enumerate() {
        let v: Vec<f64> = rec
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(v, [pts[i].x, pts[i].y, pts[i].z]);
    }
}

#[test]
fn unfinished_writer_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    for fmt in [OutFormat::Ply, OutFormat::Pcd] {
        let p = dir.path().join(format!("crash.{}", fmt.extension()));
        let mut w = CloudWriter::create(&p, fmt).unwrap();
        w.write(&[Point::new(1.0, 2.0, 3.0)]).unwrap();
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "temp file exists while writing"
        );
        drop(w);
        assert!(!p.exists());
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    // Overwriting an existing file replaces it atomically.
    let p = dir.path().join("again.pcd");
    cloud::write(&p, OutFormat::Pcd, &[Point::new(1.0, 1.0, 1.0)]).unwrap();
    cloud::write(
        &p,
        OutFormat::Pcd,
        &[Point::new(2.0, 2.0, 2.0), Point::new(3.0, 3.0, 3.0)],
    )
    .unwrap();
    assert_eq!(cloud::read_all(&p).unwrap().len(), 2);
    // A directory that does not exist is an I/O error naming the path.
    let bad = dir.path().join("no/such/dir/x.ply");
    let e = CloudWriter::create(&bad, OutFormat::Ply)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("no/such/dir"), "{e}");
}

#[test]
fn ascii_across_pieces_and_blocks() {
    let dir = tempfile::tempdir().unwrap();
    // Long lines so that the data spans several read blocks and parse pieces.
    let n = 25_000usize;
    let junk = "j".repeat(400);
    let mut text = header(
        &[
            ("x", 'F', 4, 1),
            ("y", 'F', 4, 1),
            ("z", 'F', 4, 1),
            ("tag", 'U', 1, 1),
        ],
        n as u64,
        1,
        "ascii",
    );
    let mut want = Vec::new();
    for i in 0..n {
        if i % 1000 == 7 {
            text.push_str(&format!("nan nan nan {junk}\n"));
        } else {
            text.push_str(&format!("{i} {}.25 -{i} {junk}\n", i % 13));
            want.push([i as f64, (i % 13) as f64 + 0.25, -(i as f64)]);
        }
        if i == 12_345 {
            text.push_str("\n  \r\n"); // blank lines are not points
        }
    }
    assert!(text.len() > TEXT_BLOCK + TEXT_PIECE);
    // Data after the declared points means POINTS lies: an error, not a silent cut.
    let more = format!("{text}\n1 2 3 {junk}\n");
    let p = file(&dir, "longmore.pcd", more.as_bytes());
    assert!(
        err(&p).contains("POINTS 25000 but the ascii data holds more points"),
        "{}",
        err(&p)
    );
    text.push_str("\n \r\n");
    let p = file(&dir, "long.pcd", text.as_bytes());
    let (got, stats) = read(&p).unwrap();
    assert_eq!(stats.skipped_nonfinite, 25);
    assert_eq!(got, want);
    // A bad value deep in the file is reported with its line number.
    let bad = text.replacen(
        &format!("\n20000 {}.25 -20000", 20000 % 13),
        "\n20000 x -20000",
        1,
    );
    let p = file(&dir, "longbad.pcd", bad.as_bytes());
    let e = err(&p);
    // 11 header lines + 20000 data lines before it + 2 blank lines.
    assert!(
        e.contains(".pcd:20014: field 'y' value 'x' is not a number"),
        "{e}"
    );
    // Missing final lines.
    let cut = &text[..text.len() - 3 - 3 * (junk.len() + 20)];
    let p = file(&dir, "longcut.pcd", cut.as_bytes());
    assert!(
        err(&p).contains("header declares POINTS 25000 but the data ends after"),
        "{}",
        err(&p)
    );
}

/// Reads every point through `next_batch` (pieces visited in order, one
/// scratch reused) and returns them with the stats.
fn read_batches(path: &Path) -> (Vec<[f64; 3]>, ReadStats) {
    let mut r = cloud::open(path).unwrap();
    let mut all = Vec::new();
    let mut buf = Vec::new();
    let mut scratch = cloud::Scratch::default();
    while let Some(b) = r.next_batch(&mut buf).unwrap() {
        for i in 0..b.pieces() {
            all.extend(
                b.piece(i, &mut scratch)
                    .unwrap()
                    .iter()
                    .map(|p| [p.x, p.y, p.z]),
            );
        }
    }
    (all, r.stats())
}

/// The reference: the whole-block / in-memory decoding path the readers had
/// before streaming (binary_compressed through `PcdReader` with the block
/// decompressed whole).
fn read_whole(path: &Path) -> (Vec<[f64; 3]>, ReadStats) {
    let (file, bytes, header) = read_header(path).unwrap();
    let mut r = PcdReader::open_with(path, file, bytes, header).unwrap();
    let mut all = Vec::new();
    let mut buf = Vec::new();
    while r.next_chunk(&mut buf).unwrap() {
        all.extend(buf.iter().map(|p| [p.x, p.y, p.z]));
    }
    (all, r.stats())
}

/// Points with NaNs sprinkled at and around piece/chunk boundaries.
fn boundary_points(n: usize) -> Vec<[f64; 3]> {
    (0..n)
        .map(|i| {
            let b = (i % 65_536 == 0) || (i % 5461 == 5460) || i == n - 1 || i % 997 == 3;
            let x = if b {
                f64::NAN
            } else {
                350_000.0 + i as f64 * 0.37
            };
            [
                x,
                4_150_000.0 - (i % 1000) as f64 * 0.001,
                (i % 77) as f64 * -0.5,
            ]
        })
        .collect()
}

fn bits(v: &[[f64; 3]]) -> Vec<[u64; 3]> {
    v.iter().map(|p| p.map(f64::to_bits)).collect()
}

#[test]
fn pread_records_equal_the_reference_across_piece_boundaries() {
    let dir = tempfile::tempdir().unwrap();
    let layouts: [&[F]; 3] = [
        &[("x", 'F', 8, 1), ("y", 'F', 8, 1), ("z", 'F', 8, 1)],
        &[
            ("x", 'F', 4, 1),
            ("y", 'F', 4, 1),
            ("z", 'F', 4, 1),
            ("intensity", 'F', 4, 1),
        ],
        &[
            ("rgb", 'U', 4, 1),
            ("z", 'F', 4, 1),
            ("x", 'I', 4, 1),
            ("pad", 'U', 1, 3),
            ("y", 'F', 8, 1),
        ],
    ];
    // Sizes around the piece and batch sizes (pieces are 128 KiB of file).
    for (l, fields) in layouts.iter().enumerate() {
        for n in [1usize, 5461, 5462, 10_923, 300_001] {
            let pts = boundary_points(n);
            let p = make(
                &dir,
                &format!("b{l}-{n}.pcd"),
                fields,
                n as u64,
                1,
                "binary",
                &pts,
            );
            // The reference: decode the records by hand.
            let rec = binary(fields, &pts);
            let size = rec.len() / n;
            let mut want = Vec::new();
            let (mut off, mut kinds) = ([0usize; 3], [('F', 8usize); 3]);
            let mut o = 0;
            for f in fields.iter() {
                if let Some(c) = ["x", "y", "z"].iter().position(|&a| a == f.0) {
                    off[c] = o;
                    kinds[c] = (f.1, f.2);
                }
                o += f.2 * f.3;
            }
            for r in rec.chunks_exact(size) {
                let v = [0, 1, 2].map(|c| {
                    let b = &r[off[c]..];
                    match kinds[c] {
                        ('F', 8) => f64::from_le_bytes(b[..8].try_into().unwrap()),
                        ('F', 4) => f32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
                        ('I', 4) => i32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
                        _ => unreachable!(),
                    }
                });
                if v.iter().all(|c| c.is_finite()) {
                    want.push(v);
                }
            }
            let (got, st) = read(&p).unwrap();
            assert_eq!(
                bits(&got),
                bits(&want),
                "layout {l}, {n} points, next_chunk"
            );
            assert_eq!(st.points as usize, want.len());
            assert_eq!(st.skipped_nonfinite as usize, n - want.len());
            let (got, st2) = read_batches(&p);
            assert_eq!(
                bits(&got),
                bits(&want),
                "layout {l}, {n} points, next_batch"
            );
            assert_eq!(st2, st);
        }
    }
}

#[test]
fn pread_records_report_a_file_shortened_after_open() {
    let dir = tempfile::tempdir().unwrap();
    let f: &[F] = &[("x", 'F', 8, 1), ("y", 'F', 8, 1), ("z", 'F', 8, 1)];
    let pts = boundary_points(100_000);
    let p = make(&dir, "short.pcd", f, 100_000, 1, "binary", &pts);
    let mut r = cloud::open(&p).unwrap();
    let len = std::fs::metadata(&p).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&p)
        .unwrap()
        .set_len(len / 2)
        .unwrap();
    let mut buf = Vec::new();
    let e = loop {
        match r.next_chunk(&mut buf) {
            Ok(true) => {}
            Ok(false) => panic!("read a shortened file to the end"),
            Err(e) => break e.to_string(),
        }
    };
    assert!(e.contains("short.pcd") && e.contains("truncated"), "{e}");
}

#[test]
fn streamed_lzf_equals_the_whole_block_decode() {
    let dir = tempfile::tempdir().unwrap();
    let layouts: [&[F]; 3] = [
        &[
            ("x", 'F', 4, 1),
            ("y", 'F', 4, 1),
            ("z", 'F', 4, 1),
            ("intensity", 'F', 4, 1),
        ],
        // x not first, a multi-count field between, double y.
        &[
            ("intensity", 'F', 4, 1),
            ("x", 'F', 4, 1),
            ("normal", 'F', 4, 3),
            ("y", 'F', 8, 1),
            ("z", 'F', 4, 1),
        ],
        &[("x", 'F', 8, 1), ("y", 'F', 8, 1), ("z", 'F', 8, 1)],
    ];
    // 1, a few, exactly one chunk, chunk + 1 and several chunks (64 Ki points each).
    for (l, fields) in layouts.iter().enumerate() {
        for n in [1usize, 7, 65_536, 65_537, 200_003] {
            let pts = boundary_points(n);
            let p = make(
                &dir,
                &format!("c{l}-{n}.pcd"),
                fields,
                n as u64,
                1,
                "binary_compressed",
                &pts,
            );
            let (want, wst) = read_whole(&p);
            let (got, st) = read(&p).unwrap();
            assert_eq!(bits(&got), bits(&want), "layout {l}, {n} points");
            assert_eq!(st, wst, "layout {l}, {n} points");
            let (got, st) = read_batches(&p);
            assert_eq!(bits(&got), bits(&want), "layout {l}, {n} points, batches");
            assert_eq!(st, wst);
        }
    }
    // Long runs (back-references that overlap their own output) and
    // incompressible stretches, written by the mapgauge writer.
    let pts: Vec<Point> = (0..150_000)
        .map(|i| {
            if i < 70_000 {
                Point::new(1.0, 2.0, 3.0)
            } else {
                let h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                Point::new(f64::from_bits(h >> 2), (h >> 11) as f64, i as f64)
            }
        })
        .collect();
    let p = dir.path().join("w.pcd");
    cloud::write(&p, OutFormat::PcdCompressed, &pts).unwrap();
    let (want, _) = read_whole(&p);
    let (got, _) = read(&p).unwrap();
    assert_eq!(bits(&got), bits(&want));
    assert_eq!(got.len(), pts.iter().filter(|q| q.x.is_finite()).count());
}

#[test]
fn corrupt_streamed_lzf_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let f: &[F] = &[("x", 'F', 4, 1), ("y", 'F', 4, 1), ("z", 'F', 4, 1)];
    let pts = boundary_points(100_000);
    let mut bytes = header(f, 100_000, 1, "binary_compressed").into_bytes();
    let head = bytes.len();
    bytes.extend(compressed(f, &pts));
    let mut rng = 12345u64;
    for k in 0..40 {
        let mut b = bytes.clone();
        // Flip bytes in the compressed stream (past the two sizes).
        for _ in 0..(1 + k % 5) {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let at = head + 8 + (rng >> 33) as usize % (b.len() - head - 8);
            b[at] ^= (rng >> 20) as u8 | 1;
        }
        let p = file(&dir, "bad.pcd", &b);
        // Either an error or some points; never a panic.
        let _ = read(&p);
        let _ = cloud::open(&p).map(|mut r| {
            let mut buf = Vec::new();
            let mut s = cloud::Scratch::default();
            while let Ok(Some(b)) = r.next_batch(&mut buf) {
                for i in 0..b.pieces() {
                    let _ = b.piece(i, &mut s);
                }
            }
        });
    }
    // Cut short: a clear error naming the file.
    let p = file(&dir, "cut.pcd", &bytes[..bytes.len() - 1000]);
    let e = err(&p);
    assert!(
        e.contains("cut.pcd") && e.contains("binary_compressed"),
        "{e}"
    );
}

#[test]
fn ascii_pcd_is_bit_identical_to_str_parse_across_blocks() {
    // Long enough for several 256 KiB parse pieces and an 8 MiB block.
    let dir = tempfile::tempdir().unwrap();
    let n = 400_000;
    let mut s = header(
        &[
            ("x", 'F', 8, 1),
            ("y", 'F', 8, 1),
            ("z", 'F', 8, 1),
            ("i", 'F', 4, 1),
        ],
        n,
        1,
        "ascii",
    );
    let mut want = Vec::new();
    let mut h = 7u64;
    for i in 0..n {
        h = h
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let toks = [
            format!("{:.6}", (h >> 11) as f64 / 1e9 - 4e3),
            format!("{}", f64::from_bits(h >> 2)),
            format!("{:e}", ((h >> 40) as f64) * 1e-3),
        ];
        let toks = if i % 50_001 == 3 {
            ["nan".to_string(), toks[1].clone(), toks[2].clone()]
        } else {
            toks
        };
        let v = toks.clone().map(|t| t.parse::<f64>().unwrap());
        if v.iter().all(|c| c.is_finite()) {
            want.push(v);
        }
        s.push_str(&format!("{} {}\t{},{}\n", toks[0], toks[1], toks[2], i));
    }
    let p = file(&dir, "a.pcd", s.as_bytes());
    let (got, st) = read(&p).unwrap();
    assert_eq!(bits(&got), bits(&want));
    assert_eq!(st.points as usize, want.len());
}
