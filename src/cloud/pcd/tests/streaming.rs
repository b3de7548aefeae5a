//! The streaming paths (ascii blocks, `pread` records, streamed LZF) equal
//! their references across piece, chunk and block boundaries.

use super::*;

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

/// binary_compressed PCD's intensity column (PCL's `pcl_convert_pcd_ascii_binary
/// … 2`, Autoware's map tools): each intensity stays with its point over
/// several chunks, with points dropped for a non-finite coordinate, in any
/// field order and type, and the coordinates-only read is unchanged.
#[test]
fn compressed_intensity_is_read_beside_its_point() {
    let dir = tempfile::tempdir().unwrap();
    let n = 200_003usize;
    let layouts: [(&[F], &str); 3] = [
        (
            &[
                ("x", 'F', 4, 1),
                ("y", 'F', 4, 1),
                ("z", 'F', 4, 1),
                ("intensity", 'F', 4, 1),
            ],
            "after",
        ),
        (
            &[
                ("intensity", 'U', 2, 1),
                ("x", 'F', 8, 1),
                ("normal", 'F', 4, 3),
                ("y", 'F', 8, 1),
                ("z", 'F', 8, 1),
            ],
            "first",
        ),
        (
            &[
                ("x", 'F', 4, 1),
                ("y", 'F', 4, 1),
                ("z", 'F', 4, 1),
                ("i", 'F', 4, 1),
            ],
            "short name",
        ),
    ];
    for (fields, tag) in layouts {
        let pts: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let y = if i % 977 == 5 {
                    f64::NAN
                } else {
                    i as f64 * 0.25
                };
                [i as f64 * 0.5, y, 1.0 + (i % 100) as f64]
            })
            .collect();
        let inten = |i: usize| (i % 50_000) as f64;
        let mut bytes = header(fields, n as u64, 1, "binary_compressed").into_bytes();
        bytes.extend(compressed_with(fields, &pts, &|name, k, i, p| match name {
            "intensity" | "i" => inten(i),
            _ => value(name, k, p),
        }));
        let p = file(&dir, "ci.pcd", &bytes);
        let (got, got_i, has) = cloud::read_with_intensity(&p);
        assert!(has, "{tag}");
        let keep: Vec<usize> = (0..n).filter(|&i| pts[i][1].is_finite()).collect();
        assert_eq!(got.len(), keep.len(), "{tag}");
        assert_eq!(got_i.len(), keep.len(), "{tag}");
        // Each coordinate as its field stores it.
        let size = |name: &str| fields.iter().find(|f| f.0 == name).unwrap().2;
        let stored = |v: f64, name: &str| if size(name) == 4 { v as f32 as f64 } else { v };
        for (k, &i) in keep.iter().enumerate() {
            let want = Point::new(
                stored(pts[i][0], "x"),
                stored(pts[i][1], "y"),
                stored(pts[i][2], "z"),
            );
            assert_eq!(got[k], want, "{tag} point {i}");
            assert_eq!(got_i[k], inten(i) as f32, "{tag} intensity {i}");
        }
        let (plain, _) = read(&p).unwrap();
        let got: Vec<[f64; 3]> = got.iter().map(|q| [q.x, q.y, q.z]).collect();
        assert_eq!(plain, got, "{tag}: the coordinates-only read");
    }
}
