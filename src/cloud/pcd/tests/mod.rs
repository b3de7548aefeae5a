//! Tests of the PCD reader and the PLY/PCD writers, on hand-written fixtures in
//! the layouts PCL, Open3D, LIO-SAM and FAST-LIO produce.

use super::ascii::{TEXT_BLOCK, TEXT_PIECE};
use super::reference::{CHUNK_POINTS, TASK_POINTS, lzf_decompress, read_whole};
use super::*;
use crate::Point;
use crate::cloud::ReadStats;
use crate::cloud::{self, CloudWriter, OutFormat};
use std::path::{Path, PathBuf};

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
    compressed_with(fields, pts, &|name, k, _, p| value(name, k, p))
}

/// [`compressed`] with each field's value from `value(name, element,
/// point index, point)`.
fn compressed_with(
    fields: &[F],
    pts: &[[f64; 3]],
    value: &dyn Fn(&str, usize, usize, &[f64; 3]) -> f64,
) -> Vec<u8> {
    let mut cols = Vec::new();
    for f in fields {
        for (i, p) in pts.iter().enumerate() {
            for k in 0..f.3 {
                encode(f.1, f.2, value(f.0, k, i, p), &mut cols);
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

fn replace_header(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from}");
    text.replacen(from, to, 1)
}

trait PipeRead {
    fn pipe_read(&self) -> Vec<u8>;
}
impl PipeRead for PathBuf {
    fn pipe_read(&self) -> Vec<u8> {
        std::fs::read(self).unwrap()
    }
}

mod errors;
mod pcl;
mod reading;
mod slam;
mod streaming;
mod writers;
