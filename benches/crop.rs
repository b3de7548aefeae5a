//! The loose crop against the floor it is measured by (`cat`: one copy of the
//! page-cached file), for the double PCD mapgauge writes and the float32
//! layouts SLAM tools write (LIO-SAM's `x y z intensity`, FAST-LIO2's eight
//! floats, GLIM's float PLY). `cargo bench --bench crop`; `CROP_POINTS` sets
//! the map size (default 4 M points of a synthetic scene, in a temp dir),
//! `CROP_LAYOUTS` a subset (`pcd pcd-xyzi pcd-fastlio ply-f32`). Compare `cat`
//! and `loose_crop` of one layout in one run: the ratio is what issues 7 and
//! 21 are about.

mod common;

use clap::ValueEnum;
use common::cat;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mapgauge::Point;
use mapgauge::cloud::{self, OutFormat};
use mapgauge::crop::{LooseParams, loose_crop_each};
use mapgauge::synth::{SynthParams, write_scene};
use std::path::Path;

fn crop(path: &Path, centres: &[Point]) -> u64 {
    let mut r = cloud::open(path).unwrap();
    let mut kept = 0u64;
    loose_crop_each(
        &mut *r,
        centres,
        &LooseParams::default(),
        |_| {},
        |_, p| {
            kept += p.len() as u64;
            Ok(())
        },
    )
    .unwrap();
    kept
}

fn bench(c: &mut Criterion) {
    let n: u64 = std::env::var("CROP_POINTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4_000_000);
    let layouts =
        std::env::var("CROP_LAYOUTS").unwrap_or_else(|_| "pcd pcd-xyzi pcd-fastlio ply-f32".into());
    let dir = tempfile::tempdir().unwrap();
    let params = SynthParams {
        points: n,
        ..SynthParams::default()
    };
    let mut kept_first = None;
    for name in layouts.split_whitespace() {
        let format = OutFormat::from_str(name, true).unwrap();
        let (files, truth, _) = write_scene(&dir.path().join(name), &params, format).unwrap();
        let path = files.map;
        let centres: Vec<Point> = truth
            .targets
            .iter()
            .map(|t| Point::new(t.map[0], t.map[1], t.map[2]))
            .collect();
        let bytes = std::fs::metadata(&path).unwrap().len();
        let kept = crop(&path, &centres);
        assert!(kept > 0);
        // The float32 layouts hold the same rounded coordinates: the same
        // points are kept (the double map may differ by a point on a rim).
        if format != OutFormat::Pcd {
            assert_eq!(*kept_first.get_or_insert(kept), kept, "{name}");
        }
        let mut g = c.benchmark_group(format!("crop/{name}"));
        g.sample_size(20);
        g.throughput(Throughput::Bytes(bytes));
        g.bench_function("cat", |b| b.iter(|| cat(&path)));
        g.bench_function("loose_crop", |b| b.iter(|| crop(&path, &centres)));
        g.finish();
        let _ = std::fs::remove_dir_all(dir.path().join(name));
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
