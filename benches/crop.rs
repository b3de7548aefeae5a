//! The loose crop against the floor it is measured by (`cat`: one copy of the
//! page-cached file). `cargo bench --bench crop`; `CROP_POINTS` sets the map
//! size (default 4 M points of a synthetic scene, binary PCD, in a temp dir).
//! Compare the two in one run: the ratio is what issue 7's goal is about.

mod common;

use common::cat;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mapgauge::Point;
use mapgauge::cloud::{self, CloudWriter, OutFormat};
use mapgauge::crop::{LooseParams, loose_crop_each};
use mapgauge::synth::{SynthParams, generate};
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
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("map.pcd");
    let params = SynthParams {
        points: n,
        ..SynthParams::default()
    };
    let mut w = CloudWriter::create(&path, OutFormat::Pcd).unwrap();
    let truth = generate(&params, &mut |p| w.write(p)).unwrap();
    w.finish().unwrap();
    let centres: Vec<Point> = truth
        .targets
        .iter()
        .map(|t| Point::new(t.map[0], t.map[1], t.map[2]))
        .collect();
    let bytes = std::fs::metadata(&path).unwrap().len();
    let kept = crop(&path, &centres);
    assert!(kept > 0);
    let mut g = c.benchmark_group("crop");
    g.sample_size(20);
    g.throughput(Throughput::Bytes(bytes));
    g.bench_function("cat", |b| b.iter(|| cat(&path)));
    g.bench_function("loose_crop", |b| b.iter(|| crop(&path, &centres)));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
