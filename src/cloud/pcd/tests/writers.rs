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
