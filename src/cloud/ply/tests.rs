//! PLY files of every encoding and layout, and their errors.

use super::*;
use crate::Point;
use body::CHUNK;
use std::io::Write;

fn tmp(bytes: &[u8]) -> tempfile::NamedTempFile {
    let mut f = tempfile::Builder::new().suffix(".ply").tempfile().unwrap();
    f.write_all(bytes).unwrap();
    f.flush().unwrap();
    f
}

fn read_bytes(bytes: &[u8]) -> Result<(Vec<Point>, ReadStats)> {
    let f = tmp(bytes);
    let mut r = open(f.path())?;
    let mut all = Vec::new();
    let mut buf = Vec::new();
    while r.next_chunk(&mut buf)? {
        all.extend_from_slice(&buf);
    }
    assert_eq!(r.stats().points, all.len() as u64);
    Ok((all, r.stats()))
}

fn pts() -> Vec<Point> {
    vec![
        Point::new(1.5, -2.25, 3.0),
        Point::new(350123.456, 4150234.567, 12.5),
        Point::new(f64::NAN, 0.0, 0.0),
        Point::new(-7.0, 8.0, 0.125),
    ]
}

/// A PLY with a vertex element (float or double x, y; float z; uchar rgb;
/// float intensity) and a face element after it.
fn ply(enc: &str, double: bool) -> Vec<u8> {
    let t = if double { "double" } else { "float" };
    let p = pts();
    let mut out = format!(
        "ply\nformat {enc} 1.0\ncomment made by hand\nobj_info test\nelement vertex {}\n\
         property {t} x\nproperty uchar red\nproperty {t} y\nproperty uint8 green\n\
         property float32 z\nproperty uchar blue\nproperty float intensity\n\
         element face 2\nproperty list uchar int vertex_indices\nend_header\n",
        p.len()
    )
    .into_bytes();
    if enc == "ascii" {
        for q in &p {
            out.extend_from_slice(format!("{} 200 {} 100 {} 50 0.75\n", q.x, q.y, q.z).as_bytes());
        }
        out.extend_from_slice(b"3 0 1 2\n3 1 2 3\n");
        return out;
    }
    let be = enc == "binary_big_endian";
    let w = |v: f64, dbl: bool| -> Vec<u8> {
        match (dbl, be) {
            (true, true) => v.to_be_bytes().to_vec(),
            (true, false) => v.to_le_bytes().to_vec(),
            (false, true) => (v as f32).to_be_bytes().to_vec(),
            (false, false) => (v as f32).to_le_bytes().to_vec(),
        }
    };
    for q in &p {
        out.extend(w(q.x, double));
        out.push(200);
        out.extend(w(q.y, double));
        out.push(100);
        out.extend(w(q.z, false));
        out.push(50);
        out.extend(w(0.75, false));
    }
    for _ in 0..2 {
        out.push(3);
        for i in 0..3i32 {
            out.extend_from_slice(&if be { i.to_be_bytes() } else { i.to_le_bytes() });
        }
    }
    out
}

fn expect(double: bool) -> Vec<Point> {
    pts()
        .into_iter()
        .filter(|p| p.x.is_finite())
        .map(|p| {
            if double {
                p
            } else {
                Point::new(p.x as f32 as f64, p.y as f32 as f64, p.z as f32 as f64)
            }
        })
        .map(|p| Point::new(p.x, p.y, p.z as f32 as f64))
        .collect()
}

#[test]
fn ascii_le_be_with_extra_properties_and_faces() {
    for enc in ["ascii", "binary_little_endian", "binary_big_endian"] {
        for double in [false, true] {
            let (got, st) = read_bytes(&ply(enc, double)).unwrap();
            let want = if enc == "ascii" {
                // ascii keeps full precision for x, y; z parsed as written.
                pts().into_iter().filter(|p| p.x.is_finite()).collect()
            } else {
                expect(double)
            };
            assert_eq!(got, want, "{enc} double={double}");
            assert_eq!(st.skipped_nonfinite, 1, "{enc}");
        }
    }
}

#[test]
fn vertex_not_first_and_list_in_vertex() {
    // binary: a fixed-size element and a list element before the vertices,
    // and a list property inside the vertex element (variable stride).
    let mut b = b"ply\r\nformat binary_little_endian 1.0\r\nelement camera 2\r\nproperty float a\r\n\
property double b\r\nelement face 2\r\nproperty list uchar uint idx\r\nelement vertex 2\r\n\
property list uint8 float extra\r\nproperty double x\r\nproperty double y\r\nproperty double z\r\nend_header\r\n"
        .to_vec();
    b.extend_from_slice(&[0u8; 24]);
    b.push(2);
    b.extend_from_slice(&[0u8; 8]);
    b.push(0);
    for (i, k) in [(1.0f64, 3u8), (2.0, 0)] {
        b.push(k);
        b.extend(std::iter::repeat_n(0u8, 4 * k as usize));
        for v in [i, i + 0.5, -i] {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    let (got, _) = read_bytes(&b).unwrap();
    assert_eq!(
        got,
        vec![Point::new(1., 1.5, -1.), Point::new(2., 2.5, -2.)]
    );
    // truncated variable-stride data
    let e = read_bytes(&b[..b.len() - 3]).unwrap_err().to_string();
    assert!(e.contains("declares 2 vertices, found 1"), "{e}");

    let a = b"ply\nformat ascii 1.0\nelement face 2\nproperty list uchar int vertex_indices\n\
element vertex 2\nproperty list uchar float n\nproperty float x\nproperty float y\nproperty float z\n\
end_header\n3 0 1 2\n3 1 2 0\n2 9 9 1 2 3\n0 4 5 6\n";
    let (got, _) = read_bytes(a).unwrap();
    assert_eq!(got, vec![Point::new(1., 2., 3.), Point::new(4., 5., 6.)]);
}

#[test]
fn many_points_keep_order_and_count_nan() {
    let n = CHUNK + 3 * (1 << 15) + 17;
    let mut b = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\n\
         property float y\nproperty float z\nproperty uchar r\nend_header\n"
    )
    .into_bytes();
    for i in 0..n {
        let x = if i % 1000 == 7 { f32::NAN } else { i as f32 };
        for v in [x, 1.0, -(i as f32)] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.push(0);
    }
    let (got, st) = read_bytes(&b).unwrap();
    let want: Vec<Point> = (0..n)
        .filter(|i| i % 1000 != 7)
        .map(|i| Point::new(i as f32 as f64, 1.0, -(i as f32) as f64))
        .collect();
    assert_eq!(st.skipped_nonfinite, (n - want.len()) as u64);
    assert_eq!(got, want);
}

#[test]
fn ascii_across_blocks_stops_at_vertex_count() {
    let n = 300_000;
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement edge {n}\nproperty int a\nproperty int b\n\
         element vertex {n}\nproperty double x\nproperty double y\nproperty double z\n\
         element face {n}\nproperty list uchar int vertex_indices\nend_header\n"
    );
    for i in 0..n {
        s.push_str(&format!("{i} {}\n", i + 1));
    }
    for i in 0..n {
        s.push_str(&format!("{i}.25 {} -{i}\n", 350000 + i));
    }
    for _ in 0..n {
        s.push_str("3 0 1 2\n");
    }
    let (got, st) = read_bytes(s.as_bytes()).unwrap();
    assert_eq!(st.points, n as u64);
    for (i, p) in got.iter().enumerate() {
        assert_eq!(
            *p,
            Point::new(i as f64 + 0.25, (350000 + i) as f64, -(i as f64))
        );
    }
}

fn err(bytes: &[u8]) -> String {
    read_bytes(bytes).unwrap_err().to_string()
}

#[test]
fn clear_errors() {
    let head = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                property float y\nproperty float z\nend_header\n";
    let mut b = head.as_bytes().to_vec();
    b.extend_from_slice(&[0u8; 12 * 2 + 5]);
    let e = err(&b);
    assert!(e.contains("declares 3 vertices, the file holds 2"), "{e}");
    let e = err(
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
property float z\nend_header\n1 2 3\n",
    );
    assert!(e.contains("declares 3 vertices, found 1"), "{e}");
    let e = err(
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
property float z\nend_header\n1 2\n",
    );
    assert!(
        e.contains(".ply:8: ") && e.contains("too few values"),
        "{e}"
    );
    let e = err(
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
property float z\nend_header\n1 2 q\n",
    );
    assert!(
        e.contains(".ply:8: ") && e.contains("\"q\" is not a number"),
        "{e}"
    );
    let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float16 x\nend_header\n");
    assert!(
        e.contains(".ply:4: PLY header: unknown property type \"float16\""),
        "{e}"
    );
    let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\nend_header\n");
    assert!(e.contains("no 'y' property"), "{e}");
    let e = err(b"ply\nformat ascii 1.0\ncomment \xff\xfe\nend_header\n");
    assert!(
        e.contains(".ply:3: PLY header") && e.contains("UTF-8"),
        "{e}"
    );
    let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
    assert!(e.contains("never ends"), "{e}");
    let e = err(b"ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int v\nend_header\n");
    assert!(e.contains("no 'vertex' element"), "{e}");
    let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty float y\nproperty float z\nend_header\n1 2 3\n");
    assert!(e.contains("'x' must be float or double"), "{e}");
    // Every message names the file.
    assert!(e.contains(".ply"), "{e}");
}

/// Every point and its intensity, read as the boards' pass reads them.
fn read_with_intensity(bytes: &[u8]) -> Result<(Vec<Point>, Vec<f32>)> {
    let f = tmp(bytes);
    let mut r = open(f.path())?;
    assert!(r.has_intensity());
    let (mut all, mut inten) = (Vec::new(), Vec::new());
    let (mut buf, mut ib) = (Vec::new(), Vec::new());
    while r.next_chunk_intensity(&mut buf, &mut ib)? {
        assert_eq!(buf.len(), ib.len());
        all.extend_from_slice(&buf);
        inten.extend_from_slice(&ib);
    }
    Ok((all, inten))
}

#[test]
fn intensity_from_every_encoding_and_layout() {
    // Fixed stride (the record reader) and ascii, from the shared file.
    for enc in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let (got, inten) = read_with_intensity(&ply(enc, true)).unwrap();
        assert_eq!(got.len(), 3, "{enc}");
        assert_eq!(inten, vec![0.75; 3], "{enc}");
    }
    // Ascii: CloudCompare's name, before x, after a list, with a NaN point.
    let a = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty list uchar float n\n\
property ushort scalar_Intensity\nproperty double x\nproperty double y\nproperty double z\n\
end_header\n2 9 9 1200 1 2 3\n0 7 nan 5 6\n1 4 65535 -1 -2 -3.5\n";
    let (got, inten) = read_with_intensity(a).unwrap();
    assert_eq!(
        got,
        vec![Point::new(1., 2., 3.), Point::new(-1., -2., -3.5)]
    );
    assert_eq!(inten, vec![1200.0, 65535.0]);
    // Binary with a list in the vertex (variable stride): intensity last.
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 2\n\
property list uint8 float extra\nproperty double x\nproperty double y\nproperty double z\n\
property float intensity\nend_header\n"
        .to_vec();
    for (i, k) in [(1.0f64, 2u8), (2.0, 0)] {
        b.push(k);
        b.extend(std::iter::repeat_n(0u8, 4 * k as usize));
        for v in [i, i + 0.5, -i] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&(i as f32 * 10.0).to_le_bytes());
    }
    let (got, inten) = read_with_intensity(&b).unwrap();
    assert_eq!(
        got,
        vec![Point::new(1., 1.5, -1.), Point::new(2., 2.5, -2.)]
    );
    assert_eq!(inten, vec![10.0, 20.0]);
}

#[test]
fn ascii_intensity_is_parsed_only_when_asked_for() {
    // A bad intensity token: the coordinate passes never read it; the
    // boards' pass says where it is.
    let a = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
property float z\nproperty float intensity\nend_header\n1 2 3 0.5\n4 5 6 bright\n";
    let (got, _) = read_bytes(a).unwrap();
    assert_eq!(got.len(), 2);
    let e = read_with_intensity(a).unwrap_err().to_string();
    assert!(
        e.contains(":10:") && e.contains("\"bright\" is not a number"),
        "{e}"
    );
    // No intensity property: said, and nothing is given.
    let f = tmp(
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
property float z\nend_header\n1 2 3\n",
    );
    assert!(!open(f.path()).unwrap().has_intensity());
}
