//! PCD read throughput (points per second) for binary, binary_compressed and
//! ascii data in the common x y z intensity (4 x F4) layout.
//!
//! Run: `cargo bench --bench read_pcd` (files are generated in a temp dir;
//! set `READ_PCD_POINTS` to change the binary cloud size, default 4 M).

mod common;

use common::cat;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mapgauge::cloud;
use std::io::Write;
use std::path::Path;

fn header(n: usize, data: &str) -> String {
    format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\n\
         TYPE F F F F\nCOUNT 1 1 1 1\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {data}\n"
    )
}

/// A deterministic pseudo-random scene: values differ per point like a real scan.
fn point(i: usize) -> [f32; 4] {
    let h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    let f = |s: u32| ((h >> s) & 0xFFFF) as f32 / 655.36;
    [f(0) - 50.0, f(16) - 50.0, f(32) * 0.1, (h >> 56) as f32]
}

fn write(path: &Path, n: usize, data: &str) {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    out.write_all(header(n, data).as_bytes()).unwrap();
    match data {
        "binary" => {
            for i in 0..n {
                for v in point(i) {
                    out.write_all(&v.to_le_bytes()).unwrap();
                }
            }
        }
        "binary_compressed" => {
            let mut cols = Vec::with_capacity(n * 16);
            for c in 0..4 {
                for i in 0..n {
                    cols.extend_from_slice(&point(i)[c].to_le_bytes());
                }
            }
            let packed = lzf::compress(&cols).unwrap();
            out.write_all(&(packed.len() as u32).to_le_bytes()).unwrap();
            out.write_all(&(cols.len() as u32).to_le_bytes()).unwrap();
            out.write_all(&packed).unwrap();
        }
        _ => {
            for i in 0..n {
                let p = point(i);
                writeln!(out, "{} {} {} {}", p[0], p[1], p[2], p[3]).unwrap();
            }
        }
    }
}

fn read(path: &Path) -> u64 {
    let mut r = cloud::open(path).unwrap();
    let mut buf = Vec::new();
    let mut n = 0u64;
    while r.next_chunk(&mut buf).unwrap() {
        n += buf.len() as u64;
    }
    n
}

fn bench(c: &mut Criterion) {
    let n: usize = std::env::var("READ_PCD_POINTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4_000_000);
    let dir = tempfile::tempdir().unwrap();
    let mut g = c.benchmark_group("read_pcd");
    g.sample_size(10);
    for (data, points) in [("binary", n), ("binary_compressed", n), ("ascii", n / 4)] {
        let path = dir.path().join(format!("{data}.pcd"));
        write(&path, points, data);
        assert_eq!(read(&path), points as u64);
        g.throughput(Throughput::Elements(points as u64));
        g.bench_function(format!("{data}/{points}"), |b| b.iter(|| read(&path)));
        if data == "binary" {
            // Baseline: the cost of just reading the same bytes (like `cat`).
            g.bench_function(format!("read_bytes_baseline/{points}"), |b| {
                b.iter(|| cat(&path))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
