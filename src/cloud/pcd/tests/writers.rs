//! The LZF decoder and the PCD/PLY writers, checked against other tools.

use super::*;

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
    // Overwriting an existing file replaces it, and only once the new one is
    // complete: an unfinished writer leaves the old file as it was.
    let p = dir.path().join("again.pcd");
    cloud::write(&p, OutFormat::Pcd, &[Point::new(1.0, 1.0, 1.0)]).unwrap();
    let mut w = CloudWriter::create(&p, OutFormat::Pcd).unwrap();
    w.write(&[Point::new(5.0, 5.0, 5.0)]).unwrap();
    drop(w);
    assert_eq!(cloud::read_all(&p).unwrap(), [Point::new(1.0, 1.0, 1.0)]);
    cloud::write(
        &p,
        OutFormat::Pcd,
        &[Point::new(2.0, 2.0, 2.0), Point::new(3.0, 3.0, 3.0)],
    )
    .unwrap();
    assert_eq!(cloud::read_all(&p).unwrap().len(), 2);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    // A folder where the file should go is an error naming it; the folder
    // and its contents stay, and no temporary is left.
    let d = dir.path().join("taken.ply");
    std::fs::create_dir(&d).unwrap();
    std::fs::write(d.join("keep"), b"x").unwrap();
    let e = cloud::write(&d, OutFormat::Ply, &[Point::new(1.0, 1.0, 1.0)])
        .unwrap_err()
        .to_string();
    assert!(e.contains("taken.ply"), "{e}");
    assert!(d.join("keep").exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    std::fs::remove_dir_all(&d).unwrap();
    // A directory that does not exist is an I/O error naming the path.
    let bad = dir.path().join("no/such/dir/x.ply");
    let e = CloudWriter::create(&bad, OutFormat::Ply)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("no/such/dir"), "{e}");
}

#[test]
fn float32_pcd_writer_rounds_and_refuses_what_f32_cannot_hold() {
    let dir = tempfile::tempdir().unwrap();
    let pts: Vec<Point> = (0..40_000)
        .map(|i| Point::new(-32_767.9 + i as f64 * 1.6, 0.123456789 * i as f64, -5.5))
        .collect();
    let p = dir.path().join("f32.pcd");
    let mut w = CloudWriter::create(&p, OutFormat::PcdF32).unwrap();
    w.write(&pts[..20_000]).unwrap();
    w.write(&pts[20_000..]).unwrap();
    assert_eq!(w.finish().unwrap(), 40_000);
    let bytes = std::fs::read(&p).unwrap();
    let text = String::from_utf8_lossy(&bytes[..300]);
    assert!(
        text.contains("\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 40000\n"),
        "{text}"
    );
    // Header, then exactly 12 bytes a point: nothing else.
    let head = text.find("DATA binary\n").unwrap() + 12;
    assert_eq!(bytes.len(), head + 12 * 40_000);
    let got = cloud::read_all(&p).unwrap();
    let want: Vec<Point> = pts
        .iter()
        .map(|q| Point::new(q.x as f32 as f64, q.y as f32 as f64, q.z as f32 as f64))
        .collect();
    assert_eq!(got, want);
    assert!(
        got.iter()
            .zip(&pts)
            .all(|(g, q)| (g - q).abs().max() < 0.001)
    );
    // A UTM coordinate would move by centimetres: refused, naming the point,
    // and no file (or temporary) is left behind.
    let utm = dir.path().join("utm.pcd");
    let mut w = CloudWriter::create(&utm, OutFormat::PcdF32).unwrap();
    w.write(&pts[..10]).unwrap();
    let e = w
        .write(&[
            Point::new(1.0, 2.0, 3.0),
            Point::new(350_123.456, 4_150_234.567, 12.0),
        ])
        .unwrap_err()
        .to_string();
    drop(w);
    assert!(
        e.contains("utm.pcd")
            && e.contains("point 11 has a coordinate of 350123.456 m")
            && e.contains("spacing 0.03125 m")
            && e.contains("--format pcd"),
        "{e}"
    );
    assert!(!e.contains('\n'));
    let mut left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    left.sort();
    assert_eq!(left, ["f32.pcd"]);
    // Exactly at the limit is refused, just under it is written.
    let e = cloud::write(&utm, OutFormat::PcdF32, &[Point::new(0.0, -32_768.0, 0.0)]);
    assert!(e.is_err());
    cloud::write(&utm, OutFormat::PcdF32, &[Point::new(0.0, -32_767.99, 0.0)]).unwrap();
}

/// The binary_compressed writer keeps an intensity when asked (a fourth,
/// float column; NaN for points written without one), which the reader
/// gives back beside its point; without, the file is x, y, z as before.
#[test]
fn compressed_pcd_writer_keeps_the_intensity_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let pts: Vec<Point> = (0..150_000)
        .map(|i| {
            Point::new(
                500_000.25 + i as f64 * 1e-3,
                -12.5 * i as f64,
                (i % 97) as f64,
            )
        })
        .collect();
    let inten: Vec<f32> = (0..150_000).map(|i| (i % 4096) as f32 * 0.5).collect();
    let p = dir.path().join("ci.pcd");
    let mut w = CloudWriter::create_with(&p, OutFormat::PcdCompressed, true).unwrap();
    w.write_intensity(&pts[..70_000], &inten[..70_000]).unwrap();
    w.write(&pts[70_000..70_010]).unwrap();
    w.write_intensity(&pts[70_010..], &inten[70_010..]).unwrap();
    assert!(w.write_intensity(&pts[..3], &inten[..2]).is_err());
    assert_eq!(w.finish().unwrap(), 150_000);
    let (got, got_i, has) = cloud::read_with_intensity(&p);
    assert!(has);
    assert_eq!(got, pts);
    for (k, (a, b)) in got_i.iter().zip(&inten).enumerate() {
        if (70_000..70_010).contains(&k) {
            assert!(a.is_nan(), "point {k}: {a}");
        } else {
            assert_eq!(a, b, "point {k}");
        }
    }
    let head = String::from_utf8_lossy(&std::fs::read(&p).unwrap()[..200]).into_owned();
    assert!(
        head.contains("FIELDS x y z intensity\nSIZE 8 8 8 4\nTYPE F F F F\n"),
        "{head}"
    );
    // A float intensity beside double coordinates: still double coordinates
    // (the float32 map checks must not take the map for a float one).
    assert!(!cloud::open(&p).unwrap().float32_coords());
    let q = dir.path().join("plain.pcd");
    cloud::write(&q, OutFormat::PcdCompressed, &pts).unwrap();
    let head = String::from_utf8_lossy(&std::fs::read(&q).unwrap()[..200]).into_owned();
    assert!(head.contains("FIELDS x y z\n"), "{head}");
    let (got, _, has) = cloud::read_with_intensity(&q);
    assert!(!has);
    assert_eq!(got, pts);
}
