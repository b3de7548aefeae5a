//! Hostile input through the command line: for every parser (PCD, PLY, LAS/LAZ,
//! E57, PTS, XYZ, survey CSV, estimates CSV, TOML config, result.json) a table of
//! malformed files, each of which must end the run with exit code 1 and exactly
//! one line `error: <file>...` on stderr — never a panic (exit 101), never an
//! allocation out of proportion to the file (every run has its address space
//! capped, so a header declaring terabytes that were allocated would abort).
//! Where carrying on makes sense (non-finite points), the run must succeed and
//! count what it skipped.
//!
//! The files are generated here; they are a few hundred bytes each.

use crate::util::{BIN, stderr, tempdir};
use std::path::Path;
use std::process::{Command, Output};

/// Address-space cap for every run (KiB). A tiny file never needs more; a
/// terabyte `Vec` (or even a 4 GB one) cannot be reserved under it.
const VM_LIMIT_KIB: u64 = 3 << 20;

/// Runs mapgauge with `args` under the address-space cap.
fn run(args: &[&std::ffi::OsStr]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {VM_LIMIT_KIB} && exec \"$0\" \"$@\""))
        .arg(BIN)
        .args(args)
        // report.html carries the run's date; a fixed one makes reruns byte-identical.
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .output()
        .unwrap()
}

/// Exit code 1, one stderr line `error: <file>...` containing every `want`.
fn assert_one_line_error(o: &Output, file: &Path, want: &[&str], case: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(4), "{case}: exit code; stderr: {err}");
    assert_eq!(
        err.lines().count(),
        1,
        "{case}: expected exactly one stderr line, got: {err}"
    );
    let head = format!("error: {}", file.display());
    assert!(
        err.starts_with(&head),
        "{case}: expected `{head}...`, got: {err}"
    );
    for w in want {
        assert!(err.contains(w), "{case}: expected `{w}` in: {err}");
    }
}

/// What reads the hostile file.
#[derive(Clone, Copy, Debug)]
enum Reader {
    /// `crop --map FILE` (reads the whole map).
    Map,
    /// `crop --survey FILE`.
    Survey,
    /// `errors --estimates FILE`.
    Estimates,
    /// `eval --config FILE --print-config`.
    Config,
    /// `table FILE`.
    Result,
}

struct Case {
    name: &'static str,
    reader: Reader,
    /// File name (the extension matters for content sniffing ties).
    file: &'static str,
    bytes: Vec<u8>,
    /// Fragments the error line must contain.
    want: &'static [&'static str],
}

fn case(
    name: &'static str,
    reader: Reader,
    file: &'static str,
    bytes: impl Into<Vec<u8>>,
    want: &'static [&'static str],
) -> Case {
    Case {
        name,
        reader,
        file,
        bytes: bytes.into(),
        want,
    }
}

const GOOD_SURVEY: &str = "id,x,y,z\n1,0,0,0\n2,10,0,0\n";
const GOOD_ESTIMATES: &str = "id,x,y\n1,0.01,0\n2,10,0.02\n";

/// A valid little ascii PCD (the map when the survey is under test).
fn good_pcd() -> String {
    pcd_head("x y z", "4 4 4", "F F F", "1 1 1", 3, "ascii") + "0 0 0\n1 1 1\n10 0 1\n"
}

fn pcd_head(fields: &str, size: &str, ty: &str, count: &str, n: u64, data: &str) -> String {
    format!(
        "# .PCD v0.7\nVERSION 0.7\nFIELDS {fields}\nSIZE {size}\nTYPE {ty}\nCOUNT {count}\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {data}\n"
    )
}

fn xyz3(n: u64, data: &str) -> String {
    pcd_head("x y z", "4 4 4", "F F F", "1 1 1", n, data)
}

/// `n` float points as little-endian f32 triples.
fn f32_points(n: usize) -> Vec<u8> {
    (0..n)
        .flat_map(|i| [i as f32, 1.0, 2.0])
        .flat_map(f32::to_le_bytes)
        .collect()
}

fn cat(a: impl AsRef<[u8]>, b: impl AsRef<[u8]>) -> Vec<u8> {
    let mut v = a.as_ref().to_vec();
    v.extend_from_slice(b.as_ref());
    v
}

fn ply_head(format: &str, n: u64, props: &str) -> String {
    format!("ply\nformat {format} 1.0\nelement vertex {n}\n{props}end_header\n")
}

const PLY_XYZ: &str = "property float x\nproperty float y\nproperty float z\n";

/// A 1.2 LAS (or LAZ) file with `n` points.
fn las_bytes(dir: &Path, n: usize, compressed: bool) -> Vec<u8> {
    let mut b = las::Builder::from((1, 2));
    b.point_format.is_compressed = compressed;
    let header = b.into_header().unwrap();
    let path = dir.join(if compressed { "src.laz" } else { "src.las" });
    {
        let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        let mut w = las::Writer::new(file, header).unwrap();
        for i in 0..n {
            w.write_point(las::Point {
                x: i as f64,
                y: 1.0,
                z: 2.0,
                ..Default::default()
            })
            .unwrap();
        }
        w.close().unwrap();
    }
    let b = std::fs::read(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    b
}

/// Sets the legacy point count (LAS 1.2 header offset 107).
fn las_with_count(mut b: Vec<u8>, n: u32) -> Vec<u8> {
    b[107..111].copy_from_slice(&n.to_le_bytes());
    b
}

/// An E57 file with one cartesian scan of the given points.
fn e57_bytes(dir: &Path, pts: &[[f64; 3]], bitpacked_invalid: bool) -> Vec<u8> {
    use e57::{E57Writer, Record, RecordValue};
    let path = dir.join("tmp-src.e57");
    {
        let mut w = E57Writer::from_file(&path, "guid-file").unwrap();
        let mut proto = vec![
            Record::CARTESIAN_X_F64,
            Record::CARTESIAN_Y_F64,
            Record::CARTESIAN_Z_F64,
        ];
        if bitpacked_invalid {
            proto.push(Record::CARTESIAN_INVALID_STATE);
        }
        let mut pc = w.add_pointcloud("guid-1", proto).unwrap();
        for p in pts {
            let mut v = vec![
                RecordValue::Double(p[0]),
                RecordValue::Double(p[1]),
                RecordValue::Double(p[2]),
            ];
            if bitpacked_invalid {
                v.push(RecordValue::Integer(0));
            }
            pc.add_point(v).unwrap();
        }
        pc.finalize().unwrap();
        w.finalize().unwrap();
    }
    let b = std::fs::read(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    b
}

/// `b` with `from` replaced by `to` (same length) and every page's CRC-32C
/// recomputed, so the E57 reader gets past its checksums to the lie.
fn e57_patched(b: &[u8], from: &str, to: &str) -> Vec<u8> {
    assert_eq!(from.len(), to.len());
    let i = b
        .windows(from.len())
        .position(|w| w == from.as_bytes())
        .unwrap();
    let mut v = b.to_vec();
    v[i..i + to.len()].copy_from_slice(to.as_bytes());
    for page in v.chunks_exact_mut(1024) {
        let mut crc = !0u32;
        for &x in &page[..1020] {
            crc ^= u32::from(x);
            for _ in 0..8 {
                crc = if crc & 1 != 0 {
                    (crc >> 1) ^ 0x82F6_3B78
                } else {
                    crc >> 1
                };
            }
        }
        page[1020..].copy_from_slice(&(!crc).to_be_bytes());
    }
    v
}

fn cases(dir: &Path) -> Vec<Case> {
    use Reader::*;
    let lzf_pcd = |raw: u32, comp: u32, body: &[u8]| {
        let mut v = xyz3(2, "binary_compressed").into_bytes();
        v.extend_from_slice(&comp.to_le_bytes());
        v.extend_from_slice(&raw.to_le_bytes());
        v.extend_from_slice(body);
        v
    };
    let las10 = las_bytes(dir, 10, false);
    let laz10 = las_bytes(dir, 10, true);
    let e57_good = e57_bytes(dir, &[[1.0, 2.0, 3.0]; 40], false);
    vec![
        // ---------------------------------------------------------------- PCD
        case("pcd empty", Map, "m.pcd", "", &["empty file"]),
        // Issue 31: a map repository cloned without `git lfs pull`.
        case(
            "pcd that is a Git LFS pointer",
            Map,
            "m.pcd",
            "version https://git-lfs.github.com/spec/v1\noid sha256:4d7a214614ab2935c943f9e0ff69d22eadbb8f32b1258daaa5e2ca24d17e2393\nsize 132453889\n",
            &["Git LFS pointer", "132453889 bytes", "git lfs pull"],
        ),
        case(
            "las that is a Git LFS pointer",
            Map,
            "m.las",
            "version https://git-lfs.github.com/spec/v1\noid sha256:4d7a214614ab2935c943f9e0ff69d22eadbb8f32b1258daaa5e2ca24d17e2393\nsize 9000\n",
            &["Git LFS pointer", "git lfs pull"],
        ),
        case(
            "pcd header only, no DATA",
            Map,
            "m.pcd",
            "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n",
            &["without a DATA line"],
        ),
        case(
            "pcd header only, binary, no data",
            Map,
            "m.pcd",
            xyz3(4, "binary"),
            &["truncated binary data", "POINTS 4"],
        ),
        case(
            "pcd binary truncated mid-point",
            Map,
            "m.pcd",
            cat(xyz3(4, "binary"), &f32_points(4)[..40]),
            &["truncated binary data", "(3 whole points)"],
        ),
        case(
            "pcd binary POINTS too high",
            Map,
            "m.pcd",
            cat(xyz3(9, "binary"), f32_points(4)),
            &["POINTS 9", "(4 whole points)"],
        ),
        case(
            "pcd binary POINTS too low",
            Map,
            "m.pcd",
            cat(xyz3(2, "binary"), f32_points(4)),
            &["POINTS 2", "4 points"],
        ),
        case(
            "pcd ascii POINTS too high",
            Map,
            "m.pcd",
            xyz3(5, "ascii") + "0 0 0\n1 1 1\n",
            &["POINTS 5", "ends after 2 points"],
        ),
        case(
            "pcd ascii POINTS too low",
            Map,
            "m.pcd",
            xyz3(1, "ascii") + "0 0 0\n1 1 1\n2 2 2\n",
            &["POINTS 1", "holds more points"],
        ),
        case(
            "pcd SIZE has fewer entries than FIELDS",
            Map,
            "m.pcd",
            pcd_head("x y z", "4 4", "F F F", "1 1 1", 1, "ascii") + "0 0 0\n",
            &[":4: SIZE has 2 entries", "FIELDS (line 3) has 3"],
        ),
        case(
            "pcd TYPE has more entries than FIELDS",
            Map,
            "m.pcd",
            pcd_head("x y z", "4 4 4", "F F F F", "1 1 1", 1, "ascii") + "0 0 0\n",
            &[":5: TYPE has 4 entries"],
        ),
        case(
            "pcd COUNT disagrees with FIELDS",
            Map,
            "m.pcd",
            pcd_head("x y z", "4 4 4", "F F F", "1 1", 1, "ascii") + "0 0 0\n",
            &[":6: COUNT has 2 entries"],
        ),
        case(
            "pcd TYPE F with SIZE 2",
            Map,
            "m.pcd",
            pcd_head("x y z", "4 2 4", "F F F", "1 1 1", 1, "binary"),
            &["field 'y'", "SIZE 2"],
        ),
        case(
            "pcd COUNT 0",
            Map,
            "m.pcd",
            pcd_head("x y z", "4 4 4", "F F F", "1 0 1", 1, "binary"),
            &[":6: COUNT value '0'"],
        ),
        case(
            "pcd COUNT huge",
            Map,
            "m.pcd",
            pcd_head("x y z", "4 4 4", "F F F", "1 1 99999999999", 1, "binary"),
            &["point records larger than"],
        ),
        case(
            "pcd WIDTH x HEIGHT != POINTS",
            Map,
            "m.pcd",
            "VERSION 0.7\nFIELDS x y z\nWIDTH 3\nHEIGHT 2\nPOINTS 5\nDATA ascii\n",
            &["WIDTH 3 x HEIGHT 2 does not equal POINTS 5"],
        ),
        case(
            "pcd binary declares terabytes",
            Map,
            "m.pcd",
            cat(xyz3(100_000_000_000_000, "binary"), f32_points(2)),
            &["truncated binary data", "POINTS 100000000000000"],
        ),
        // Bytes after the declared points: PCL's page padding (zeros up to
        // one page past the data) is read; anything that could be points is not.
        case(
            "pcd binary padding with a non-zero byte",
            Map,
            "m.pcd",
            {
                let mut v = cat(xyz3(2, "binary"), f32_points(2));
                v.resize(4096 + 24, 0);
                *v.last_mut().unwrap() = 1;
                v
            },
            &["declares POINTS 2", "not zero, so not PCL's page padding"],
        ),
        case(
            "pcd binary zeros that are not a page",
            Map,
            "m.pcd",
            cat(cat(xyz3(2, "binary"), f32_points(2)), [0u8; 100]),
            &["declares POINTS 2", "are zeros but not PCL's page padding"],
        ),
        case(
            "pcd binary zeros past the largest page",
            Map,
            "m.pcd",
            cat(cat(xyz3(2, "binary"), f32_points(2)), vec![0u8; 65536]),
            &["declares POINTS 2", "more than PCL's largest page padding"],
        ),
        case(
            "pcd ascii declares terabytes",
            Map,
            "m.pcd",
            xyz3(100_000_000_000_000, "ascii") + "0 0 0\n",
            &["POINTS 100000000000000", "ends after 1 points"],
        ),
        case(
            "pcd binary_compressed declares terabytes",
            Map,
            "m.pcd",
            {
                let mut v = xyz3(100_000_000_000_000, "binary_compressed").into_bytes();
                v.extend_from_slice(&[8, 0, 0, 0, 0, 0, 0, 255, 1, 2, 3, 4, 5, 6, 7, 8]);
                v
            },
            &["uncompressed size"],
        ),
        case(
            "pcd binary_compressed raw size wrong",
            Map,
            "m.pcd",
            lzf_pcd(25, 4, &[3, 1, 2, 3]),
            &["uncompressed size 25 does not match POINTS 2 x 12-byte points = 24"],
        ),
        case(
            "pcd binary_compressed compressed size past the end",
            Map,
            "m.pcd",
            lzf_pcd(24, 1000, &[3, 1, 2, 3]),
            &["compressed size 1000 but only 4 bytes follow"],
        ),
        case(
            "pcd binary_compressed 4 GB from 10 bytes",
            Map,
            "m.pcd",
            {
                let mut v = pcd_head("x y z", "4 4 4", "F F F", "1 1 1", 357_913_941, "binary_compressed")
                    .into_bytes();
                v.extend_from_slice(&10u32.to_le_bytes());
                v.extend_from_slice(&(357_913_941u32 * 12).to_le_bytes());
                v.extend_from_slice(&[0; 10]);
                v
            },
            &["cannot hold"],
        ),
        case(
            "pcd binary_compressed corrupt LZF (back-reference before start)",
            Map,
            "m.pcd",
            lzf_pcd(24, 4, &[0xe0, 0xff, 0x10, 0x00]),
            &["binary_compressed data is corrupt", "back-reference"],
        ),
        case(
            "pcd binary_compressed corrupt LZF (literal past end)",
            Map,
            "m.pcd",
            lzf_pcd(24, 4, &[23, 1, 2, 3]),
            &["binary_compressed data is corrupt", "literal run"],
        ),
        case(
            "pcd binary_compressed LZF output short",
            Map,
            "m.pcd",
            lzf_pcd(24, 4, &[2, 1, 2, 3]),
            &["binary_compressed data decompresses to 3 bytes", "declares 24"],
        ),
        case(
            "pcd non-UTF-8 header",
            Map,
            "m.pcd",
            cat(
                b"# .PCD v0.7\nVERSION 0.7\nFIELDS x y \xff\xfe\n",
                "SIZE 4 4 4\nTYPE F F F\nPOINTS 0\nDATA ascii\n",
            ),
            &[":3: header line is not UTF-8"],
        ),
        case(
            "pcd no z field",
            Map,
            "m.pcd",
            pcd_head("x y i", "4 4 4", "F F F", "1 1 1", 1, "ascii") + "0 0 0\n",
            &["no field 'z'"],
        ),
        case(
            "pcd non-numeric cell",
            Map,
            "m.pcd",
            xyz3(2, "ascii") + "0 0 0\n1 abc 1\n",
            &[":13: field 'y' value 'abc' is not a number"],
        ),
        case(
            "pcd missing column",
            Map,
            "m.pcd",
            xyz3(2, "ascii") + "0 0 0\n1 1\n",
            &[":13: expected 3 values, found 2"],
        ),
        case(
            "pcd unknown DATA",
            Map,
            "m.pcd",
            xyz3(1, "zip"),
            &[":11: unknown DATA 'zip'"],
        ),
        // ---------------------------------------------------------------- PLY
        case("ply empty", Map, "m.ply", "", &["empty file"]),
        case(
            "ply header only, no end_header",
            Map,
            "m.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n",
            &["no end_header"],
        ),
        case(
            "ply header only, ascii, no data",
            Map,
            "m.ply",
            ply_head("ascii", 3, PLY_XYZ),
            &["PLY data truncated", "declares 3 vertices, found 0"],
        ),
        case(
            "ply header only, binary, no data",
            Map,
            "m.ply",
            ply_head("binary_little_endian", 3, PLY_XYZ),
            &["PLY data truncated", "declares 3 vertices"],
        ),
        case(
            "ply binary truncated mid-vertex",
            Map,
            "m.ply",
            cat(
                ply_head("binary_little_endian", 4, PLY_XYZ),
                &f32_points(4)[..40],
            ),
            &["PLY data truncated", "holds 3"],
        ),
        case(
            "ply binary count too high",
            Map,
            "m.ply",
            cat(ply_head("binary_little_endian", 9, PLY_XYZ), f32_points(4)),
            &["declares 9 vertices", "holds 4"],
        ),
        case(
            "ply binary count too low",
            Map,
            "m.ply",
            cat(ply_head("binary_little_endian", 2, PLY_XYZ), f32_points(4)),
            &["declares 2 vertices", "4"],
        ),
        case(
            "ply ascii count too high",
            Map,
            "m.ply",
            ply_head("ascii", 5, PLY_XYZ) + "0 0 0\n1 1 1\n",
            &["declares 5 vertices, found 2"],
        ),
        case(
            "ply ascii count too low",
            Map,
            "m.ply",
            ply_head("ascii", 1, PLY_XYZ) + "0 0 0\n1 1 1\n",
            &[":9: ", "declares 1 vertices"],
        ),
        case(
            "ply binary declares terabytes",
            Map,
            "m.ply",
            cat(
                ply_head("binary_little_endian", 100_000_000_000_000, PLY_XYZ),
                f32_points(2),
            ),
            &["declares 100000000000000 vertices"],
        ),
        case(
            "ply binary element before vertex declares terabytes",
            Map,
            "m.ply",
            cat(
                "ply\nformat binary_little_endian 1.0\nelement junk 18446744073709551615\nproperty double a\nelement vertex 2\n".to_string()
                    + PLY_XYZ
                    + "end_header\n",
                f32_points(2),
            ),
            &["element 'junk'"],
        ),
        case(
            "ply ascii elements before vertex overflow a count",
            Map,
            "m.ply",
            "ply\nformat ascii 1.0\nelement a 18446744073709551615\nproperty float q\nelement b 18446744073709551615\nproperty float q\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1\n",
            &["PLY data ends before the vertex element"],
        ),
        case(
            "ply ascii list count huge",
            Map,
            "m.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar int idx\nproperty float x\nproperty float y\nproperty float z\nend_header\n200 1 2 3\n",
            &[":9: ", "too few values"],
        ),
        case(
            "ply binary list past the end",
            Map,
            "m.ply",
            cat(
                "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty list uint int idx\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
                [255u8, 255, 255, 255, 0, 0, 0, 0],
            ),
            &["PLY data truncated"],
        ),
        case(
            "ply non-UTF-8 header",
            Map,
            "m.ply",
            cat(b"ply\nformat ascii 1.0\ncomment \xff\xfe\n", PLY_XYZ),
            &[":3: PLY header", "UTF-8"],
        ),
        case(
            "ply no z property",
            Map,
            "m.ply",
            ply_head("ascii", 1, "property float x\nproperty float y\n") + "0 0\n",
            &["no 'z' property"],
        ),
        case(
            "ply non-numeric cell",
            Map,
            "m.ply",
            ply_head("ascii", 2, PLY_XYZ) + "0 0 0\n1 abc 1\n",
            &[":9: ", "\"abc\" is not a number"],
        ),
        case(
            "ply missing column",
            Map,
            "m.ply",
            ply_head("ascii", 2, PLY_XYZ) + "0 0 0\n1 1\n",
            &[":9: ", "too few values"],
        ),
        case(
            "ply unknown property type",
            Map,
            "m.ply",
            ply_head("ascii", 1, "property quad x\n"),
            &[":4: PLY header: unknown property type \"quad\""],
        ),
        case(
            "ply no format line",
            Map,
            "m.ply",
            "ply\nelement vertex 1\nproperty float x\nend_header\n",
            &["no format line"],
        ),
        // ---------------------------------------------------------------- LAS
        case("las empty", Map, "m.las", "", &["empty file"]),
        case(
            "las header only",
            Map,
            "m.las",
            las_with_count(las10[..227].to_vec(), 10),
            &["LAS"],
        ),
        case(
            "las truncated data",
            Map,
            "m.las",
            las10[..las10.len() - 30].to_vec(),
            &["LAS point data truncated", "declares 10 points", "holds 8"],
        ),
        case(
            "las count too high",
            Map,
            "m.las",
            las_with_count(las10.clone(), 11),
            &["declares 11 points", "holds 10"],
        ),
        case(
            "las count too low",
            Map,
            "m.las",
            las_with_count(las10.clone(), 4),
            &["declares 4 points", "10"],
        ),
        case(
            "las declares terabytes",
            Map,
            "m.las",
            las_with_count(las10.clone(), u32::MAX),
            &["declares 4294967295 points"],
        ),
        case(
            "las header cut short",
            Map,
            "m.las",
            las10[..100].to_vec(),
            &["LAS"],
        ),
        case(
            "laz corrupt data",
            Map,
            "m.laz",
            {
                let mut v = laz10.clone();
                let n = v.len();
                for b in &mut v[n - 60..n - 20] {
                    *b ^= 0x5a;
                }
                v
            },
            &["LAS"],
        ),
        case(
            "laz truncated",
            Map,
            "m.laz",
            laz10[..laz10.len() - 40].to_vec(),
            &["LAZ: chunk table offset"],
        ),
        case(
            "laz declares terabytes",
            Map,
            "m.laz",
            las_with_count(laz10.clone(), u32::MAX),
            // The laz crate's debug assertion (a caught panic) or, without
            // debug assertions, its read error: either way one line.
            &[],
        ),
        case(
            "laz fixed chunk size of 1.3 G points in a 400-byte file (fuzz find)",
            Map,
            "m.laz",
            include_bytes!("../corpus/fuzz-laz-chunk-bytes.laz").to_vec(),
            &["LAZ: chunk size 1275118416 points is absurd"],
        ),
        case(
            "laz chunk table of 1.6 G chunks in a 391-byte file (fuzz find)",
            Map,
            "m.laz",
            include_bytes!("../corpus/fuzz-laz-chunk-count.laz").to_vec(),
            &["LAZ: chunk table declares 1560281089 chunks"],
        ),
        case(
            "laz with 64 KiB records: no 17 GB block buffer (fuzz find)",
            Map,
            "m.laz",
            include_bytes!("../corpus/fuzz-laz-record-64k.laz").to_vec(),
            &[], // as above: the message depends on the laz crate's build
        ),
        case(
            "las header whose size arithmetic overflows in the las crate (fuzz find)",
            Map,
            "m.las",
            include_bytes!("../corpus/fuzz-las-header-overflow.las").to_vec(),
            // With overflow checks the crate panics (caught: "the decoder failed");
            // without them its arithmetic wraps and the sizes are refused.
            &[],
        ),
        case(
            "laz chunk table that sends the laz crate out of bounds (fuzz find)",
            Map,
            "m.las",
            include_bytes!("../../fuzz/upstream/laz-decoders-index-out-of-bounds.las").to_vec(),
            &["the decoder failed on malformed data"],
        ),
        // ---------------------------------------------------------------- E57
        case("e57 empty", Map, "m.e57", "", &["empty file"]),
        case(
            "e57 signature only",
            Map,
            "m.e57",
            "ASTM-E57",
            &["E57"],
        ),
        case(
            "e57 truncated",
            Map,
            "m.e57",
            e57_good[..e57_good.len() / 2].to_vec(),
            &["E57"],
        ),
        case(
            "e57 corrupt page",
            Map,
            "m.e57",
            {
                let mut v = e57_good.clone();
                for b in &mut v[1100..1200] {
                    *b ^= 0x33;
                }
                v
            },
            &["E57"],
        ),
        case(
            "e57 recordCount too high (checksums valid)",
            Map,
            "m.e57",
            e57_patched(&e57_good, "recordCount=\"40\"", "recordCount=\"99\""),
            &["E57"],
        ),
        // (A recordCount lower than the data is not detectable through the
        // e57 crate: the declared records are read, the rest ignored.)
        case(
            "e57 3-point bit-packed scan (crate limitation)",
            Map,
            "m.e57",
            e57_bytes(dir, &[[1.0, 2.0, 3.0]; 3], true),
            &["E57"],
        ),
        // ---------------------------------------------------------------- PTS
        case("pts empty", Map, "m.pts", "", &["empty file"]),
        case(
            "pts blank lines only",
            Map,
            "m.pts",
            "\n \n",
            &["no point count line"],
        ),
        case(
            "pts no count line",
            Map,
            "m.pts",
            "1 2 3\n4 5 6\n",
            &["m.pts:1: expected the point count"],
        ),
        case(
            "pts count larger than the data",
            Map,
            "m.pts",
            "5\n1 2 3\n4 5 6\n",
            &["m.pts:1: count line declares 5 points but the file ends after 2"],
        ),
        case(
            "pts count smaller than the data",
            Map,
            "m.pts",
            "1\n1 2 3\n4 5 6\n",
            &["m.pts:3: count line 1 declares 1 points but more follow"],
        ),
        case(
            "pts section cut short by the next count",
            Map,
            "m.pts",
            "3\n1 2 3\n1\n4 5 6\n",
            &["m.pts:1: count line declares 3 points but line 3 starts another section after 1"],
        ),
        case(
            "pts count declares terabytes",
            Map,
            "m.pts",
            "100000000000000\n1 2 3\n",
            &["declares 100000000000000 points but the file ends after 1"],
        ),
        case(
            "pts non-numeric coordinate",
            Map,
            "m.pts",
            "2\n1 2 3\n1 2 zz\n",
            &["m.pts:3: z value 'zz' is not a number"],
        ),
        case(
            "pts wrong number of values",
            Map,
            "m.pts",
            "2\n1 2 3\n1 2 3 4 5\n",
            &["m.pts:3: expected x y z [intensity [r g b]]", "found 5"],
        ),
        // ---------------------------------------------------------------- XYZ
        case("xyz empty", Map, "m.xyz", "", &["empty file"]),
        case(
            "xyz non-numeric cell",
            Map,
            "m.xyz",
            "x y z\n0 0 0\n1 abc 1\n",
            &[":3:", "column 2 is not a number", "abc"],
        ),
        case(
            "xyz missing column",
            Map,
            "m.xyz",
            "0,0,0\n1,1\n",
            &[":2:", "expected at least 3 columns, found 2"],
        ),
        case(
            "xyz non-UTF-8 cell",
            Map,
            "m.xyz",
            cat("0 0 0\n", b"1 \xff\xfe 1\n"),
            &[":2:", "column 2 is not a number"],
        ),
        case(
            "xyz binary garbage",
            Map,
            "m.xyz",
            (0u8..=255).collect::<Vec<u8>>(),
            &[":1:"],
        ),
        // ------------------------------------------------------------- survey
        case("survey empty", Survey, "s.csv", "", &["empty file"]),
        case(
            "survey header only",
            Survey,
            "s.csv",
            "id,x,y,z\n",
            &["no targets"],
        ),
        case(
            "survey truncated row",
            Survey,
            "s.csv",
            "id,x,y,z\n1,0,0,0\n2,10",
            &[":3:", "missing value in column `y`"],
        ),
        case(
            "survey missing id column",
            Survey,
            "s.csv",
            "x,y\n0,0\n",
            &[":1:", "missing column `id`"],
        ),
        case(
            "survey missing position columns",
            Survey,
            "s.csv",
            "id,x,z\n1,0,0\n",
            &[":1:", "missing position columns"],
        ),
        case(
            "survey duplicate id",
            Survey,
            "s.csv",
            "id,x,y\n1,0,0\n2,1,1\n1,2,2\n",
            &[":4:", "duplicate target id `1`"],
        ),
        case(
            "survey duplicate column",
            Survey,
            "s.csv",
            "id,x,y,x\n1,0,0,0\n",
            &[":1:", "column `x` appears twice"],
        ),
        case(
            "survey non-numeric cell",
            Survey,
            "s.csv",
            "id,x,y\n1,0,0\n2,ten,0\n",
            &[":3:", "`ten` is not a finite number"],
        ),
        case(
            "survey NaN coordinate",
            Survey,
            "s.csv",
            "id,x,y\n1,0,0\n2,NaN,0\n",
            &[":3:", "`NaN` is not a finite number"],
        ),
        case(
            "survey infinite coordinate",
            Survey,
            "s.csv",
            "id,x,y\n1,0,0\n2,0,-inf\n",
            &[":3:", "`-inf` is not a finite number"],
        ),
        case(
            "survey latitude above 90",
            Survey,
            "s.csv",
            "id,lat,lon\n1,36,127\n2,90.5,127\n",
            &[":3:", "latitude 90.5 is outside -90..90"],
        ),
        case(
            "survey latitude below -90",
            Survey,
            "s.csv",
            "id,lat,lon\n1,-91,127\n",
            &[":2:", "latitude -91"],
        ),
        case(
            "survey non-UTF-8",
            Survey,
            "s.csv",
            cat("id,x,y\n1,0,0\n", b"2,\xff\xfe,0\n"),
            &[":3:", "UTF-8"],
        ),
        case(
            "survey unterminated quote",
            Survey,
            "s.csv",
            "id,x,y\n1,0,0\n\"2,1,1\n",
            &[":3:"],
        ),
        // ---------------------------------------------------------- estimates
        case("estimates empty", Estimates, "e.csv", "", &["empty file"]),
        case(
            "estimates header only",
            Estimates,
            "e.csv",
            "id,x,y\n",
            &["no estimates"],
        ),
        case(
            "estimates missing y column",
            Estimates,
            "e.csv",
            "id,x\n1,0\n",
            &[":1:", "missing column `y`"],
        ),
        case(
            "estimates duplicate id",
            Estimates,
            "e.csv",
            "id,x,y\n1,0,0\n1,0,0\n",
            &[":3:", "duplicate target id `1`"],
        ),
        case(
            "estimates non-numeric cell",
            Estimates,
            "e.csv",
            "id,x,y\n1,0,0\n2,1,one\n",
            &[":3:", "`one` is not a finite number"],
        ),
        case(
            "estimates infinite coordinate",
            Estimates,
            "e.csv",
            "id,x,y\n1,0,0\n2,inf,0\n",
            &[":3:", "not a finite number"],
        ),
        case(
            "estimates truncated row",
            Estimates,
            "e.csv",
            "id,x,y\n1,0,0\n2,1",
            &[":3:", "missing value in column `y`"],
        ),
        case(
            "estimates non-UTF-8",
            Estimates,
            "e.csv",
            cat(b"id,x,y\n1,0,\xff\n", ""),
            &[":2:", "UTF-8"],
        ),
        // ------------------------------------------------------------- config
        case(
            "config non-UTF-8",
            Config,
            "c.toml",
            cat(b"[crop]\nradius = 5 # \xff\n", ""),
            &["UTF-8"],
        ),
        case(
            "config truncated",
            Config,
            "c.toml",
            "[crop]\nradius = ",
            &[":2:"],
        ),
        case(
            "config unknown key",
            Config,
            "c.toml",
            "[crop]\nradius = 5\nradios = 4\n",
            &[":3:", "radios"],
        ),
        case(
            "config wrong type",
            Config,
            "c.toml",
            "[locate]\nsamples = \"many\"\n",
            &[":2:"],
        ),
        case(
            "config NaN radius",
            Config,
            "c.toml",
            "[crop]\nradius = nan\n",
            &["crop.radius"],
        ),
        case(
            "config negative count",
            Config,
            "c.toml",
            "[locate]\nsamples = -1\n",
            &[":2:"],
        ),
        case(
            "config huge search radius",
            Config,
            "c.toml",
            "[tight]\nsearch_radius = 1e300\n",
            &["tight.search_radius"],
        ),
        case(
            "config zero ground cell",
            Config,
            "c.toml",
            "[tight]\nground_cell = 0\n",
            &["tight.ground_cell"],
        ),
        // --------------------------------------------------------- result.json
        case("result empty", Result, "r.json", "", &["not a mapgauge result"]),
        case(
            "result truncated",
            Result,
            "r.json",
            "{\n  \"schema\": \"mapgauge.result/1\",\n  \"targets\": [",
            &[":3:", "not a mapgauge result"],
        ),
        case(
            "result wrong schema",
            Result,
            "r.json",
            "{\"schema\": \"other/9\"}",
            &["not a mapgauge result"],
        ),
        case(
            "result non-UTF-8",
            Result,
            "r.json",
            cat(b"{\"schema\": \"\xff\"}", ""),
            &["UTF-8"],
        ),
        case(
            "result not an object",
            Result,
            "r.json",
            "[1, 2, 3]\n",
            &[":1:", "not a mapgauge result"],
        ),
    ]
}

#[test]
fn every_malformed_file_is_one_line_error() {
    let tmp = tempdir();
    let dir = tmp.path();
    let good_map = dir.join("good.pcd");
    std::fs::write(&good_map, good_pcd()).unwrap();
    let good_survey = dir.join("good.csv");
    std::fs::write(&good_survey, GOOD_SURVEY).unwrap();
    let good_est = dir.join("good-est.csv");
    std::fs::write(&good_est, GOOD_ESTIMATES).unwrap();
    let mut failures = Vec::new();
    for (i, c) in cases(dir).into_iter().enumerate() {
        let sub = dir.join(format!("case{i:03}"));
        std::fs::create_dir_all(&sub).unwrap();
        let file = sub.join(c.file);
        std::fs::write(&file, &c.bytes).unwrap();
        let out = sub.join("out");
        let (f, o, g) = (file.as_os_str(), out.as_os_str(), good_map.as_os_str());
        let s = good_survey.as_os_str();
        let args: Vec<&std::ffi::OsStr> = match c.reader {
            Reader::Map => vec![
                "crop".as_ref(),
                "--map".as_ref(),
                f,
                "--survey".as_ref(),
                s,
                "--out".as_ref(),
                o,
            ],
            Reader::Survey => vec![
                "crop".as_ref(),
                "--map".as_ref(),
                g,
                "--survey".as_ref(),
                f,
                "--out".as_ref(),
                o,
            ],
            Reader::Estimates => vec![
                "errors".as_ref(),
                "--survey".as_ref(),
                s,
                "--estimates".as_ref(),
                f,
            ],
            Reader::Config => vec![
                "eval".as_ref(),
                "--print-config".as_ref(),
                "--config".as_ref(),
                f,
            ],
            Reader::Result => vec!["table".as_ref(), f],
        };
        let outp = run(&args);
        let res = std::panic::catch_unwind(|| {
            assert_one_line_error(&outp, &file, c.want, c.name);
        });
        if res.is_err() {
            failures.push(format!(
                "{} [{:?}]: exit {:?}: {}",
                c.name,
                c.reader,
                outp.status.code(),
                stderr(&outp).trim_end()
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{} case(s) failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

fn os(s: &str) -> &std::ffi::OsStr {
    s.as_ref()
}

/// Runs and requires success.
fn ok(args: &[&std::ffi::OsStr]) -> Output {
    let o = run(args);
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    o
}

#[test]
fn an_output_that_is_an_input_is_refused_under_any_spelling() {
    let tmp = tempdir();
    let d = tmp.path();
    let survey = d.join("survey.csv");
    std::fs::write(&survey, GOOD_SURVEY).unwrap();
    let out = d.join("out");
    std::fs::create_dir_all(&out).unwrap();
    // crop writes OUT/1.ply: make the map that very file, spelt three ways.
    let map_bytes = ply_head("ascii", 3, PLY_XYZ) + "0 0 0\n1 1 1\n10 0 1\n";
    let map = out.join("1.ply");
    std::fs::write(&map, &map_bytes).unwrap();
    let dotted = d.join("out/./../out/1.ply");
    std::fs::create_dir_all(d.join("elsewhere")).unwrap();
    let linked = d.join("elsewhere/map.ply");
    std::fs::hard_link(&map, &linked).unwrap();
    let alias = d.join("alias");
    std::os::unix::fs::symlink(&out, &alias).unwrap();
    for (m, o) in [
        (&map, &out),
        (&dotted, &out),
        (&linked, &out),
        (&map, &alias),
    ] {
        let r = run(&[
            os("crop"),
            os("--map"),
            m.as_os_str(),
            os("--survey"),
            survey.as_os_str(),
            os("--out"),
            o.as_os_str(),
        ]);
        assert_one_line_error(
            &r,
            &o.join("1.ply"),
            &["is the input", "refusing to overwrite"],
            &format!("crop map {} out {}", m.display(), o.display()),
        );
        assert_eq!(std::fs::read_to_string(&map).unwrap(), map_bytes);
    }
    // errors --out: the survey is OUT/targets.csv (spelt with ..).
    let est = d.join("est.csv");
    std::fs::write(&est, GOOD_ESTIMATES).unwrap();
    let s2 = out.join("targets.csv");
    std::fs::write(&s2, GOOD_SURVEY).unwrap();
    let r = run(&[
        os("errors"),
        os("--survey"),
        d.join("elsewhere/../out/targets.csv").as_os_str(),
        os("--estimates"),
        est.as_os_str(),
        os("--out"),
        out.as_os_str(),
    ]);
    assert_one_line_error(
        &r,
        &out.join("targets.csv"),
        &["is the input"],
        "errors --out",
    );
    assert_eq!(std::fs::read_to_string(&s2).unwrap(), GOOD_SURVEY);
    assert!(!out.join("result.json").exists());
    // eval --out: the survey is OUT/result.json.
    let s3 = out.join("result.json");
    std::fs::write(&s3, GOOD_SURVEY).unwrap();
    let good_map = d.join("good.pcd");
    std::fs::write(&good_map, good_pcd()).unwrap();
    let r = run(&[
        os("eval"),
        os("--map"),
        good_map.as_os_str(),
        os("--survey"),
        s3.as_os_str(),
        os("--out"),
        out.as_os_str(),
    ]);
    assert_one_line_error(&r, &s3, &["is the input"], "eval --out");
    assert_eq!(std::fs::read_to_string(&s3).unwrap(), GOOD_SURVEY);
    // synth --config: the configuration is one of the files synth writes.
    let cfg = out.join("truth.json");
    std::fs::write(&cfg, "seed = 3\n").unwrap();
    let r = run(&[
        os("synth"),
        os("--config"),
        cfg.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--points"),
        os("1000"),
    ]);
    assert_eq!(r.status.code(), Some(4), "{}", stderr(&r));
    assert!(stderr(&r).contains("is the input"), "{}", stderr(&r));
    assert_eq!(std::fs::read_to_string(&cfg).unwrap(), "seed = 3\n");
    // An --out that is a file is a one-line error too.
    let file_out = d.join("plain-file");
    std::fs::write(&file_out, "x").unwrap();
    let r = run(&[
        os("errors"),
        os("--survey"),
        survey.as_os_str(),
        os("--estimates"),
        est.as_os_str(),
        os("--out"),
        file_out.as_os_str(),
    ]);
    assert_one_line_error(&r, &file_out, &[], "errors --out FILE");
}

/// The files of a directory tree, relative, with their contents.
fn tree(dir: &Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    let mut m = std::collections::BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(p) = stack.pop() {
        for e in std::fs::read_dir(&p).unwrap() {
            let e = e.unwrap().path();
            if e.is_dir() {
                stack.push(e);
            } else {
                let rel = e.strip_prefix(dir).unwrap().display().to_string();
                m.insert(rel, std::fs::read(&e).unwrap());
            }
        }
    }
    m
}

/// Synthesises a small binary-PCD scene in `dir`; returns (map, survey).
fn small_scene(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    ok(&[
        os("synth"),
        os("--out"),
        dir.as_os_str(),
        os("--points"),
        os("400000"),
        os("--seed"),
        os("5"),
        os("--format"),
        os("pcd"),
    ]);
    (dir.join("map.pcd"), dir.join("survey.csv"))
}

#[test]
fn existing_out_dirs_keep_the_users_files_and_nonfinite_points_are_skipped() {
    let tmp = tempdir();
    let d = tmp.path();
    let (map, survey) = small_scene(&d.join("scene"));
    // The user's files in the output directories, some where mapgauge writes.
    let out = d.join("out");
    let mine: [(&str, &[u8]); 4] = [
        ("notes.txt", b"mine"),
        (".hidden", b"mine too"),
        ("crops/loose/my-edit.ply", b"hand-made"),
        ("crops/tight/old/keep.pcd", b"keep"),
    ];
    for (p, b) in mine {
        let f = out.join(p);
        std::fs::create_dir_all(f.parent().unwrap()).unwrap();
        std::fs::write(&f, b).unwrap();
    }
    let eval = |map: &Path, out: &Path| {
        ok(&[
            os("eval"),
            os("--map"),
            map.as_os_str(),
            os("--survey"),
            survey.as_os_str(),
            os("--out"),
            out.as_os_str(),
            os("--save-crops"),
        ])
    };
    eval(&map, &out);
    let after = tree(&out);
    for (p, b) in mine {
        assert_eq!(after.get(p).map(|v| &v[..]), Some(b), "{p} lost or changed");
    }
    for p in ["result.json", "targets.csv", "pairs.csv"] {
        assert!(after.contains_key(p), "{p} missing");
    }
    // No temporary files are left behind.
    assert!(
        after.keys().all(|k| !k.contains(".tmp")),
        "{:?}",
        after.keys()
    );
    // A second run into the same directory replaces only its own files, with
    // the same bytes.
    eval(&map, &out);
    assert_eq!(tree(&out), after);

    // The same map with non-finite coordinates in 40 points: they are skipped
    // and counted, and the targets are still found.
    let mut bytes = std::fs::read(&map).unwrap();
    let data = bytes
        .windows(12)
        .position(|w| w == b"DATA binary\n")
        .unwrap()
        + 12;
    let n = (bytes.len() - data) / 24;
    for k in 0..40 {
        let i = data + (k * (n / 40)) * 24 + (k % 3) * 8;
        let v = if k % 2 == 0 {
            f64::NAN
        } else {
            f64::NEG_INFINITY
        };
        bytes[i..i + 8].copy_from_slice(&v.to_le_bytes());
    }
    let nan_map = d.join("nan.pcd");
    std::fs::write(&nan_map, &bytes).unwrap();
    let out2 = d.join("out-nan");
    eval(&nan_map, &out2);
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out2.join("result.json")).unwrap()).unwrap();
    assert_eq!(j["eval"]["skipped_nonfinite"], 40, "{}", j["eval"]);
    let clean: serde_json::Value = serde_json::from_slice(&after["result.json"]).unwrap();
    let status = |v: &serde_json::Value| -> Vec<String> {
        v["targets"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| t["status"].to_string())
            .collect()
    };
    assert_eq!(status(&j), status(&clean));
}
