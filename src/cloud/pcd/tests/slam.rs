//! The float32 layouts SLAM tools write: mapgauge's writers of them
//! (`pcd-xyzi`, `pcd-fastlio`, `ply-f32`) byte for byte, and files with a
//! packed float `rgb` (FAST-LIVO2, PCL's `PointXYZRGB`) and `_` padding
//! fields (clouds saved from ROS `PointCloud2` messages) read exactly, by the
//! whole-cloud path and by the region path of the loose crop.

use super::*;
use crate::cloud::{Region, Scratch};

/// `n` points within ±60 m (f32-exact), crossing many 128 KiB pieces.
fn points(n: usize) -> Vec<Point> {
    (0..n)
        .map(|i| {
            let a = i as f64 * 0.001;
            Point::new(
                (50.0 * a.sin() * 1024.0).round() / 1024.0,
                (40.0 * (1.7 * a).cos() * 1024.0).round() / 1024.0,
                (i % 13) as f64 * 0.25,
            )
        })
        .collect()
}

/// Every finite point of `path` through `next_chunk`, and those the region
/// path keeps (`next_batch` + `piece_within`), with the reader's stats.
fn read_both(path: &Path, reg: &Region) -> (Vec<Point>, Vec<Point>, ReadStats) {
    let all = cloud::read_all(path).unwrap();
    let mut r = cloud::open(path).unwrap();
    let mut buf = Vec::new();
    let mut scratch = Scratch::default();
    let mut kept = Vec::new();
    while let Some(batch) = r.next_batch(&mut buf).unwrap() {
        for i in 0..batch.pieces() {
            kept.extend_from_slice(batch.piece_within(i, &mut scratch, reg).unwrap());
        }
    }
    let stats = r.stats();
    (all, kept, stats)
}

fn region() -> Region {
    Region::discs(&[[10.0, 20.0], [-35.0, -12.0], [45.0, 30.0]], 5.0).unwrap()
}

#[test]
fn slam_layout_writers_write_the_tools_bytes_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let pts = points(50_000);
    let inten: Vec<f32> = (0..pts.len()).map(|i| (i % 256) as f32).collect();
    let xyzi = "FIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n";
    let fastlio = "FIELDS x y z intensity normal_x normal_y normal_z curvature\n\
                   SIZE 4 4 4 4 4 4 4 4\nTYPE F F F F F F F F\nCOUNT 1 1 1 1 1 1 1 1\n";
    let ply_i = "property float x\nproperty float y\nproperty float z\nproperty float intensity\nend_header\n";
    let ply = "property float x\nproperty float y\nproperty float z\nend_header\n";
    for (format, with, want_head, stride, end) in [
        (OutFormat::PcdXyzi, true, xyzi, 16, "DATA binary\n"),
        (OutFormat::PcdXyzi, false, xyzi, 16, "DATA binary\n"),
        (OutFormat::PcdFastlio, true, fastlio, 32, "DATA binary\n"),
        (OutFormat::PlyF32, true, ply_i, 16, "end_header\n"),
        (OutFormat::PlyF32, false, ply, 12, "end_header\n"),
    ] {
        let tag = format!("{format:?} intensity {with}");
        let p = dir
            .path()
            .join(format!("{format:?}-{with}.{}", format.extension()));
        let mut w = CloudWriter::create_with(&p, format, with).unwrap();
        if with {
            w.write_intensity(&pts[..7000], &inten[..7000]).unwrap();
            w.write_intensity(&pts[7000..], &inten[7000..]).unwrap();
        } else {
            w.write(&pts).unwrap();
        }
        assert_eq!(w.finish().unwrap(), pts.len() as u64, "{tag}");
        let bytes = std::fs::read(&p).unwrap();
        let text = String::from_utf8_lossy(&bytes[..400]);
        assert!(text.contains(want_head), "{tag}: {text}");
        let head = text.find(end).unwrap() + end.len();
        assert_eq!(bytes.len(), head + stride * pts.len(), "{tag}");
        for (k, r) in bytes[head..].chunks_exact(stride).enumerate() {
            let f = |o: usize| f32::from_le_bytes(r[o..o + 4].try_into().unwrap());
            assert_eq!(
                [f(0), f(4), f(8)].map(f64::from),
                [pts[k].x, pts[k].y, pts[k].z],
                "{tag} {k}"
            );
            if stride >= 16 {
                let want = if with { inten[k] } else { 0.0 };
                assert_eq!(f(12), want, "{tag} intensity {k}");
            }
            // FAST-LIO2's normals and curvature: 0, as it saves its maps.
            assert!(
                r.get(16..).unwrap_or_default().iter().all(|&b| b == 0),
                "{tag} {k}"
            );
        }
        let reg = region();
        let (all, kept, stats) = read_both(&p, &reg);
        assert_eq!(all, pts, "{tag}");
        let want: Vec<Point> = pts
            .iter()
            .copied()
            .filter(|q| reg.contains(q.x, q.y))
            .collect();
        assert!(!want.is_empty() && want.len() < pts.len() / 4, "{tag}");
        assert_eq!(kept, want, "{tag}");
        assert_eq!(stats.points, pts.len() as u64, "{tag}");
    }
    // Mismatched intensity counts are an error, not a short read.
    let p = dir.path().join("bad.pcd");
    let mut w = CloudWriter::create(&p, OutFormat::PcdXyzi).unwrap();
    let e = w.write_intensity(&pts[..3], &inten[..2]).unwrap_err();
    assert!(e.to_string().contains("2 intensities for 3 points"), "{e}");
    // Float32 limits as for pcd-f32.
    for format in [OutFormat::PcdXyzi, OutFormat::PcdFastlio, OutFormat::PlyF32] {
        let p = dir.path().join(format!("utm.{}", format.extension()));
        let e = cloud::write(&p, format, &[Point::new(350_123.5, 0.0, 0.0)]).unwrap_err();
        assert!(e.to_string().contains("float32"), "{format:?}: {e}");
    }
}

/// A record of float x, y, z then the bytes `rest(point index)`.
fn record(p: [f32; 3], rest: &[u8]) -> Vec<u8> {
    let mut r: Vec<u8> = p.iter().flat_map(|v| v.to_le_bytes()).collect();
    r.extend_from_slice(rest);
    r
}

#[test]
fn packed_rgb_and_padding_fields_are_read_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let pts = points(30_000);
    // A packed rgb with alpha 255 (PCL's PointXYZRGB default) is a NaN as a
    // float; it must neither skip the point nor disturb the coordinates.
    let rgb = |i: usize| (0xff00_0000u32 | (i as u32 * 2_654_435_761 & 0xff_ffff)).to_le_bytes();
    let layouts: [Layout; 4] = [
        (
            // FAST-LIVO2's map: PointXYZRGB through pcl::io::savePCDFileBinary.
            "fastlivo2",
            &[
                ("x", 'F', 4, 1),
                ("y", 'F', 4, 1),
                ("z", 'F', 4, 1),
                ("rgb", 'F', 4, 1),
            ],
            16,
            &|i| rgb(i).to_vec(),
        ),
        (
            // PointXYZRGBNormal (PCL's registered fields: 32 bytes).
            "rgbnormal",
            &[
                ("x", 'F', 4, 1),
                ("y", 'F', 4, 1),
                ("z", 'F', 4, 1),
                ("rgb", 'F', 4, 1),
                ("normal_x", 'F', 4, 1),
                ("normal_y", 'F', 4, 1),
                ("normal_z", 'F', 4, 1),
                ("curvature", 'F', 4, 1),
            ],
            32,
            &|i| {
                let mut r = rgb(i).to_vec();
                r.extend_from_slice(&f32::NAN.to_le_bytes());
                r.extend_from_slice(&f32::INFINITY.to_le_bytes());
                r.extend_from_slice(&[0xff; 8]);
                r
            },
        ),
        (
            // An Ouster scan saved from its PointCloud2 message by
            // pcl_ros: the message's gaps become `_` fields.
            "ouster_ros",
            &[
                ("x", 'F', 4, 1),
                ("y", 'F', 4, 1),
                ("z", 'F', 4, 1),
                ("_", 'U', 1, 4),
                ("intensity", 'F', 4, 1),
                ("t", 'U', 4, 1),
                ("reflectivity", 'U', 2, 1),
                ("ring", 'U', 2, 1),
                ("ambient", 'U', 2, 1),
                ("_", 'U', 1, 2),
                ("range", 'U', 4, 1),
                ("_", 'U', 1, 12),
            ],
            48,
            &|i| {
                let mut r = vec![0xff; 4];
                r.extend_from_slice(&(i as f32).to_le_bytes());
                r.extend_from_slice(&(i as u32).to_le_bytes());
                r.extend_from_slice(&[7, 0, 3, 0, 9, 0, 0xff, 0xff]);
                r.extend_from_slice(&1234u32.to_le_bytes());
                r.extend_from_slice(&[0xff; 12]);
                r
            },
        ),
        (
            // PointXYZ through PCLPointCloud2, padding first-class: x, y, z
            // after a `_` (offsets 4, 8, 12: the general loop).
            "pad_first",
            &[
                ("_", 'U', 1, 4),
                ("x", 'F', 4, 1),
                ("y", 'F', 4, 1),
                ("z", 'F', 4, 1),
            ],
            16,
            &|_| Vec::new(),
        ),
    ];
    let reg = region();
    for layout in layouts {
        reads_exactly(&dir, &pts, &reg, layout);
    }
}

/// A SLAM writer's record layout: name, fields, record size, and the bytes
/// after x, y, z of point `i`.
type Layout<'a> = (&'a str, &'a [F], usize, &'a dyn Fn(usize) -> Vec<u8>);

/// `pts` written with `layout` (some without a return) read back exactly,
/// whole and within `reg`, with the points without a return counted.
fn reads_exactly(dir: &tempfile::TempDir, pts: &[Point], reg: &Region, layout: Layout) {
    let (name, fields, stride, rest) = layout;
    let mut body = Vec::new();
    let mut want = Vec::new();
    for (i, p) in pts.iter().enumerate() {
        let mut c = [p.x as f32, p.y as f32, p.z as f32];
        // Some points without a return (NaN, as organised clouds hold them).
        if i % 1009 == 5 {
            c[i % 3] = f32::NAN;
        } else {
            want.push(*p);
        }
        let r = if name == "pad_first" {
            let mut r = vec![0xff; 4];
            r.extend(record(c, &[]));
            r
        } else {
            record(c, &rest(i))
        };
        assert_eq!(r.len(), stride, "{name}");
        body.extend(r);
    }
    let mut bytes = header(fields, pts.len() as u64, 1, "binary").into_bytes();
    bytes.extend(body);
    let p = file(&dir, &format!("{name}.pcd"), &bytes);
    let (all, kept, stats) = read_both(&p, &reg);
    assert_eq!(all, want, "{name}");
    let in_reg: Vec<Point> = want
        .iter()
        .copied()
        .filter(|q| reg.contains(q.x, q.y))
        .collect();
    assert_eq!(kept, in_reg, "{name}");
    assert_eq!(
        stats,
        ReadStats {
            points: want.len() as u64,
            skipped_nonfinite: (pts.len() - want.len()) as u64
        },
        "{name}"
    );
}

#[test]
fn float_ply_with_colour_bytes_is_read_exactly() {
    // Float x, y, z with uchar colour (15-byte records: the general loop).
    let dir = tempfile::tempdir().unwrap();
    let pts = points(20_000);
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nproperty uchar red\nproperty uchar green\n\
         property uchar blue\nend_header\n",
        pts.len()
    )
    .into_bytes();
    for p in &pts {
        bytes.extend(record(
            [p.x as f32, p.y as f32, p.z as f32],
            &[0xff, 0xff, 0xff],
        ));
    }
    let p = file(&dir, "rgb.ply", &bytes);
    let reg = region();
    let (all, kept, _) = read_both(&p, &reg);
    assert_eq!(all, pts);
    let want: Vec<Point> = pts
        .iter()
        .copied()
        .filter(|q| reg.contains(q.x, q.y))
        .collect();
    assert_eq!(kept, want);
}

/// Every point and intensity of a file that has intensities.
fn read_intensity(path: &Path) -> (Vec<Point>, Vec<f32>) {
    let (pts, inten, has) = cloud::read_with_intensity(path);
    assert!(has, "{}", path.display());
    (pts, inten)
}

#[test]
fn intensity_is_read_beside_its_point_and_written_where_it_fits() {
    let dir = tempfile::tempdir().unwrap();
    let pts = points(30_000);
    // A ROS layout with `_` before intensity, and points without a return:
    // each intensity stays with its point.
    let fields: &[F] = &[
        ("x", 'F', 4, 1),
        ("y", 'F', 4, 1),
        ("z", 'F', 4, 1),
        ("_", 'U', 1, 4),
        ("Intensity", 'U', 2, 1),
        ("ring", 'U', 2, 1),
    ];
    let mut bytes = header(fields, pts.len() as u64, 1, "binary").into_bytes();
    let (mut want, mut want_i) = (Vec::new(), Vec::new());
    for (i, p) in pts.iter().enumerate() {
        let mut c = [p.x as f32, p.y as f32, p.z as f32];
        if i % 777 == 3 {
            c[1] = f32::INFINITY;
        } else {
            want.push(*p);
            want_i.push((i % 60_000) as f32);
        }
        let mut rest = vec![0xff; 4];
        rest.extend_from_slice(&((i % 60_000) as u16).to_le_bytes());
        rest.extend_from_slice(&[5, 0]);
        bytes.extend(record(c, &rest));
    }
    let src = file(&dir, "ros.pcd", &bytes);
    let (got, got_i) = read_intensity(&src);
    assert_eq!(got, want);
    assert_eq!(got_i, want_i);
    // The short name `i` some writers use: the same intensities.
    let short = &bytes;
    let at = short
        .windows(9)
        .position(|w| w == b"Intensity")
        .expect("the header names it");
    let mut renamed = short[..at].to_vec();
    renamed.push(b'i');
    renamed.extend_from_slice(&short[at + 9..]);
    let (got_s, got_si) = read_intensity(&file(&dir, "short.pcd", &renamed));
    assert_eq!(got_s, want);
    assert_eq!(got_si, want_i);
    // Written by the formats with an intensity field, read back the same.
    for format in [OutFormat::PcdXyzi, OutFormat::PcdFastlio, OutFormat::PlyF32] {
        let p = dir
            .path()
            .join(format!("i-{format:?}.{}", format.extension()));
        let mut w = CloudWriter::create_with(&p, format, true).unwrap();
        w.write_intensity(&got, &got_i).unwrap();
        w.finish().unwrap();
        let (back, back_i) = read_intensity(&p);
        assert_eq!(back, want, "{format:?}");
        assert_eq!(back_i, want_i, "{format:?}");
    }
    // XYZ text: a fourth column, named by a header line, read back.
    let p = dir.path().join("i.xyz");
    let mut w = CloudWriter::create_with(&p, OutFormat::Xyz, true).unwrap();
    w.write_intensity(&got[..3], &got_i[..3]).unwrap();
    w.finish().unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    let first = format!(
        "x y z intensity\n{:.6} {:.6} {:.6} 0\n",
        got[0].x, got[0].y, got[0].z
    );
    assert!(text.starts_with(&first), "{text}");
    assert_eq!(text.lines().count(), 4);
    let (back, back_i) = read_intensity(&p);
    assert_eq!((back.len(), &back_i[..]), (3, &got_i[..3]));
    // A cloud without intensity says so, and gives none.
    let p = dir.path().join("plain.pcd");
    cloud::write(&p, OutFormat::Pcd, &got[..10]).unwrap();
    let mut r = cloud::open(&p).unwrap();
    assert!(!r.has_intensity());
    let (mut buf, mut inten) = (Vec::new(), vec![1.0]);
    assert!(r.next_chunk_intensity(&mut buf, &mut inten).unwrap());
    assert_eq!(buf.len(), 10);
    assert!(inten.is_empty());
}

/// ASCII PCD: the intensity column comes with its point (also after x, y,
/// z and before other fields, and NaN where a line's value is not a
/// number); a cloud without one has none.
#[test]
fn ascii_intensity_is_read_beside_its_point() {
    let dir = tempfile::tempdir().unwrap();
    let n = 2000;
    let mut text = format!(
        "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity ring\nSIZE 4 4 4 4 2\nTYPE F F F F U\n\
         COUNT 1 1 1 1 1\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA ascii\n"
    );
    let mut want = Vec::new();
    for k in 0..n {
        let (x, y, z) = (k as f32 * 0.5, 2.0_f32, -1.25_f32);
        match k % 500 {
            7 => text.push_str(&format!("nan {y} {z} 5 1\n")),
            9 => {
                text.push_str(&format!("{x} {y} {z} nan 1\n"));
                want.push(f32::NAN);
            }
            _ => {
                text.push_str(&format!("{x} {y} {z} {} 1\n", k % 256));
                want.push((k % 256) as f32);
            }
        }
    }
    let p = file(&dir, "a.pcd", text.as_bytes());
    let (pts, inten) = read_intensity(&p);
    assert_eq!(pts.len(), want.len());
    assert_eq!(inten.len(), want.len());
    for (a, b) in inten.iter().zip(&want) {
        assert!(a == b || (a.is_nan() && b.is_nan()), "{a} {b}");
    }
    // Coordinates as the coordinates-only read gives them.
    assert_eq!(pts, cloud::read_all(&p).unwrap());
    let plain = text.replace("FIELDS x y z intensity ring", "FIELDS x y z power ring");
    let r = cloud::open(&file(&dir, "b.pcd", plain.as_bytes())).unwrap();
    assert!(!r.has_intensity());
}
