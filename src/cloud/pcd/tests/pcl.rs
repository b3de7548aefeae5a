//! Files laid out byte for byte as PCL writes them: the header of
//! `PCDWriter::generateHeader` and the page padding of `writeBinary` for
//! `PCLPointCloud2` (file = one page + the data, zeros after the points).

use super::*;

/// PCL's header for `fields` (name, size, type, count) and `n` points.
fn pcl_header(fields: &[(&str, usize, char, usize)], n: u64, data: &str) -> String {
    let col = |f: &dyn Fn(&(&str, usize, char, usize)) -> String| {
        fields
            .iter()
            .map(|x| format!(" {}", f(x)))
            .collect::<String>()
    };
    format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS{}\nSIZE{}\nTYPE{}\nCOUNT{}\n\
         WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {data}\n",
        col(&|f| f.0.to_string()),
        col(&|f| f.1.to_string()),
        col(&|f| f.2.to_string()),
        col(&|f| f.3.to_string()),
    )
}

/// LIO-SAM's `x y z intensity` (PointXYZI through PCLPointCloud2: 16 bytes).
const XYZI: &[(&str, usize, char, usize)] = &[
    ("x", 4, 'F', 1),
    ("y", 4, 'F', 1),
    ("z", 4, 'F', 1),
    ("intensity", 4, 'F', 1),
];
/// PointXYZ through PCLPointCloud2: PCL names its 4 padding bytes `_`.
const XYZ_PAD: &[(&str, usize, char, usize)] = &[
    ("x", 4, 'F', 1),
    ("y", 4, 'F', 1),
    ("z", 4, 'F', 1),
    ("_", 1, 'U', 4),
];

/// `n` points of 16-byte records (x, y, z, then intensity or padding).
fn records16(n: usize) -> (Vec<u8>, Vec<[f64; 3]>) {
    let mut data = Vec::new();
    let mut pts = Vec::new();
    for i in 0..n {
        let p = [i as f32 * 0.25, -(i as f32) * 0.5, (i % 9) as f32];
        for v in p {
            data.extend_from_slice(&v.to_le_bytes());
        }
        data.extend_from_slice(&[0u8; 4]);
        pts.push(p.map(f64::from));
    }
    (data, pts)
}

/// The file PCL writes on a machine with `page`-byte pages: header, data,
/// zeros up to `page + data` bytes.
fn pcl_binary(
    fields: &[(&str, usize, char, usize)],
    n: usize,
    page: usize,
) -> (Vec<u8>, Vec<[f64; 3]>) {
    let (data, pts) = records16(n);
    let mut bytes = pcl_header(fields, n as u64, "binary").into_bytes();
    bytes.extend_from_slice(&data);
    bytes.resize(page + data.len(), 0);
    (bytes, pts)
}

#[test]
fn pcl_page_padding_is_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let head = pcl_header(XYZI, 200_000, "binary").len();
    assert_eq!(head, 190, "PCL's header for x y z intensity");
    for (fields, tag) in [(XYZI, "xyzi"), (XYZ_PAD, "xyz_")] {
        for page in [4096, 16384, 65536] {
            for n in [0, 1, 1000] {
                let (bytes, want) = pcl_binary(fields, n, page);
                assert_eq!(bytes.len(), page + 16 * n);
                let p = file(&dir, &format!("{tag}-{page}-{n}.pcd"), &bytes);
                let mut r = cloud::open(&p).unwrap();
                assert_eq!(r.info().declared_points, Some(n as u64));
                let mut got = Vec::new();
                let mut buf = Vec::new();
                while r.next_chunk(&mut buf).unwrap() {
                    got.extend(buf.iter().map(|q| [q.x, q.y, q.z]));
                }
                assert_eq!(got, want, "{tag} page {page} n {n}");
                assert_eq!(r.bytes_read(), bytes.len() as u64);
            }
        }
    }
}

#[test]
fn trailing_bytes_that_could_be_points_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    // A non-zero byte anywhere in the padding: a point the header misses.
    let (mut bytes, _) = pcl_binary(XYZI, 100, 4096);
    let last = bytes.len() - 1;
    bytes[last] = 1;
    let e = err(&file(&dir, "nonzero.pcd", &bytes));
    assert!(
        e.contains("header declares POINTS 100 but the data holds")
            && e.contains("are not zero, so not PCL's page padding"),
        "{e}"
    );
    // Zeros, but the file is not one page longer than the data.
    let (mut bytes, _) = pcl_binary(XYZI, 100, 4096);
    bytes.extend_from_slice(&[0; 16]);
    let e = err(&file(&dir, "offpage.pcd", &bytes));
    assert!(e.contains("are zeros but not PCL's page padding"), "{e}");
    let (data, _) = records16(100);
    let mut bytes = pcl_header(XYZI, 100, "binary").into_bytes();
    bytes.extend_from_slice(&data);
    bytes.extend_from_slice(&[0; 32]);
    let e = err(&file(&dir, "twozeropoints.pcd", &bytes));
    assert!(e.contains("data holds 102 points"), "{e}");
    // A whole 64 KiB page of zeros or more is more than PCL pads.
    let (mut bytes, _) = pcl_binary(XYZI, 100, 65536);
    bytes.resize(bytes.len() + 65536, 0);
    let e = err(&file(&dir, "toolong.pcd", &bytes));
    assert!(e.contains("more than PCL's largest page padding"), "{e}");
    // Less than one point of trailing bytes stays accepted, as before.
    let (mut bytes, want) = pcl_binary(XYZI, 10, 4096);
    bytes.truncate(bytes.len() - 4096 + pcl_header(XYZI, 10, "binary").len() + 15);
    let last = bytes.len() - 1;
    bytes[last] = 7;
    assert_eq!(read(&file(&dir, "partial.pcd", &bytes)).unwrap().0, want);
}

/// `v` as C++ `ostream << std::setprecision(8)` prints it (PCL's ascii
/// writer; `%.8g`).
fn g8(v: f32) -> String {
    let v = f64::from(v);
    if v == 0.0 {
        return "0".into();
    }
    let e = v.abs().log10().floor() as i32;
    if (-5..8).contains(&e) {
        let s = format!("{:.*}", (7 - e) as usize, v);
        let s = if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        };
        s
    } else {
        format!("{v:.7e}")
    }
}

#[test]
fn ascii_float_coordinates_are_read_as_pcl_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    // UTM-frame map written by PCL at its default precision 8, with a double
    // column beside: TYPE F SIZE 4 -> nearest f32, SIZE 8 -> nearest f64.
    let fields = &[("x", 4, 'F', 1), ("y", 4, 'F', 1), ("z", 8, 'F', 1)];
    let mut text = pcl_header(fields, 2000, "ascii");
    let mut want = Vec::new();
    let mut h = 99u64;
    for _ in 0..2000 {
        h = h
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let x = 350_000.0 + (h >> 40) as f32 / 1e3;
        let y = 4_150_000.0 + (h >> 44) as f32 / 7e2;
        let z = format!("{:.9}", (h >> 50) as f64 / 3e3);
        let (xs, ys) = (g8(x), g8(y));
        text.push_str(&format!("{xs} {ys} {z}\n"));
        want.push([
            f64::from(xs.parse::<f32>().unwrap()),
            f64::from(ys.parse::<f32>().unwrap()),
            z.parse::<f64>().unwrap(),
        ]);
    }
    assert!(text.contains(" 4150"), "{}", &text[..400]);
    let (got, _) = read(&file(&dir, "utm.pcd", text.as_bytes())).unwrap();
    assert_eq!(got, want);
    // and the f32 read differs from the f64 one where it matters
    let differs = want
        .iter()
        .zip(text.lines().skip(11))
        .filter(|(w, l)| w[0] != l.split(' ').next().unwrap().parse::<f64>().unwrap())
        .count();
    assert!(differs > 1000, "{differs}");
}
