//! Every encoding and writer layout read back exactly; NaN points counted.

use super::*;

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
        vec![
            [1.5, 2.5, 3.5],
            [-1.0, -2.0, -3.0],
            // TYPE F SIZE 4: the nearest f32, as PCL reads it.
            [f64::from(1e-3f32), 200.0, -0.0]
        ]
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
