//! Time to locate one ~1,000-point synthetic L-target (goal: ≤ 20 ms).

use criterion::{Criterion, criterion_group, criterion_main};
use mapgauge::locate::{LocateParams, locate, testgen};
use rand::SeedableRng;

fn bench(c: &mut Criterion) {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(42);
    let mut spec = testgen::random_spec(&mut rng, true);
    spec.points = 950; // + 5 % outliers ≈ 1,000
    spec.noise = 0.02;
    let target = testgen::generate(&mut rng, &spec);
    eprintln!("target: {} points", target.points.len());
    let params = LocateParams::default();
    let l = locate(&target.points, None, &params).expect("benchmark target locates");
    eprintln!("default: {}/{} accepted", l.accepted, l.attempts);
    c.bench_function("locate_1000_points_default", |b| {
        b.iter(|| locate(&target.points, None, &params))
    });
    let paper = LocateParams::paper();
    if let Ok(l) = locate(&target.points, None, &paper) {
        eprintln!("paper: {}/{} accepted", l.accepted, l.attempts);
    }
    let mut g = c.benchmark_group("paper");
    g.sample_size(10);
    g.bench_function("locate_1000_points_paper", |b| {
        b.iter(|| locate(&target.points, None, &paper))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
