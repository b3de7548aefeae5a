//! Measures map reading throughput (M points/s) for binary PLY, LAS, LAZ and XYZ.
//!
//! Generates the files (default 3 million points, outside the repo in the system
//! temp directory), reads each twice (first run warms the page cache) and prints
//! the second run's rate.
//!
//!     cargo run --release --example read_throughput [-- POINTS [DIR]]
//!
//! `read_throughput read FILE` only reads FILE once (for peak-memory checks with
//! `/usr/bin/time -v`).

use mapgauge::Point;
use mapgauge::cloud::{self, OutFormat};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn cloud_points(n: usize) -> impl Iterator<Item = Point> {
    (0..n).map(|i| {
        let f = i as f64;
        Point::new(
            350000.0 + (f * 0.37) % 500.0,
            4150000.0 + (f * 0.011) % 700.0,
            (f * 0.003) % 30.0,
        )
    })
}

fn write_ply(path: &Path, n: usize) {
    let f = std::fs::File::create(path).unwrap();
    let mut w = std::io::BufWriter::new(f);
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n\
         property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
         property float intensity\nend_header\n"
    )
    .unwrap();
    for p in cloud_points(n) {
        for c in [p.x - 350000.0, p.y - 4150000.0, p.z] {
            w.write_all(&(c as f32).to_le_bytes()).unwrap();
        }
        w.write_all(&[1, 2, 3]).unwrap();
        w.write_all(&0.5f32.to_le_bytes()).unwrap();
    }
}

fn write_xyz(path: &Path, n: usize) {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    writeln!(w, "x y z intensity").unwrap();
    for p in cloud_points(n) {
        writeln!(w, "{:.3} {:.3} {:.3} 17", p.x, p.y, p.z).unwrap();
    }
}

fn write_laz(path: &Path, n: usize) {
    let mut b = las::Builder::from((1, 2));
    b.point_format = las::point::Format::new(0).unwrap();
    let tr = |o| las::Transform {
        scale: 0.001,
        offset: o,
    };
    b.transforms = las::Vector {
        x: tr(350000.0),
        y: tr(4150000.0),
        z: tr(0.0),
    };
    let mut w = las::Writer::from_path(path, b.into_header().unwrap()).unwrap();
    for p in cloud_points(n) {
        w.write_point(las::Point {
            x: p.x,
            y: p.y,
            z: p.z,
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
}

fn time_read(path: &Path) -> (u64, f64) {
    let mut best = f64::MAX;
    let mut count = 0;
    for _ in 0..2 {
        let t = Instant::now();
        let mut r = cloud::open(path).unwrap();
        let mut buf = Vec::new();
        let mut n = 0u64;
        let mut sum = 0.0;
        while r.next_chunk(&mut buf).unwrap() {
            n += buf.len() as u64;
            sum += buf.iter().map(|p| p.z).sum::<f64>();
        }
        std::hint::black_box(sum);
        best = best.min(t.elapsed().as_secs_f64());
        count = n;
    }
    (count, best)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("read") {
        let path = PathBuf::from(args.get(2).expect("FILE"));
        let t = Instant::now();
        let mut r = cloud::open(&path).unwrap();
        let mut buf = Vec::new();
        while r.next_chunk(&mut buf).unwrap() {}
        let s = t.elapsed().as_secs_f64();
        let n = r.stats().points;
        println!(
            "{n} points in {s:.3} s: {:.1} M points/s",
            n as f64 / s / 1e6
        );
        return;
    }
    let n: usize = args
        .get(1)
        .map_or(3_000_000, |s| s.parse().expect("POINTS"));
    let dir: PathBuf = args.get(2).map_or_else(
        || std::env::temp_dir().join("mapgauge-bench"),
        PathBuf::from,
    );
    std::fs::create_dir_all(&dir).unwrap();
    let ply = dir.join("bench.ply");
    let las_path = dir.join("bench.las");
    let laz = dir.join("bench.laz");
    let xyz = dir.join("bench.xyz");
    eprintln!("generating {n} points in {}", dir.display());
    write_ply(&ply, n);
    if args.get(3).map(String::as_str) == Some("ply-only") {
        return;
    }
    let pts: Vec<Point> = cloud_points(n).collect();
    let t = Instant::now();
    cloud::write(&las_path, OutFormat::Las, &pts).unwrap();
    let las_write = t.elapsed().as_secs_f64();
    drop(pts);
    write_laz(&laz, n);
    write_xyz(&xyz, n);
    println!(
        "{:<24} {:>10} {:>10} {:>10}",
        "file", "points", "seconds", "Mpts/s"
    );
    println!(
        "{:<24} {:>10} {:>10.3} {:>10.1}",
        "LAS write (las_sink)",
        n,
        las_write,
        n as f64 / las_write / 1e6
    );
    for p in [&ply, &las_path, &laz, &xyz] {
        let (count, s) = time_read(p);
        let mb = std::fs::metadata(p).unwrap().len() as f64 / 1e6;
        println!(
            "{:<24} {:>10} {:>10.3} {:>10.1}   ({mb:.0} MB, {:.0} MB/s)",
            p.file_name().unwrap().to_string_lossy(),
            count,
            s,
            count as f64 / s / 1e6,
            mb / s
        );
    }
}
