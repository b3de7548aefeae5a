//! Time to locate one ~1,000-point synthetic L-target (goal: ≤ 20 ms).
//!
//! `locate_1000_points_*`: one fixed target (a hard one: ~6 % acceptance, so
//! ~1,500 attempts for 100 samples) with the default and the paper's parameters.
//! `random_targets/locate_20_default`: 20 random targets as the accuracy tests
//! draw them (800–1,300 points, 1–3 cm noise); divide the time by 20.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
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

    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
    let targets: Vec<_> = (0..20)
        .map(|i| {
            let spec = testgen::random_spec(&mut rng, i % 2 == 1);
            testgen::generate(&mut rng, &spec)
        })
        .collect();
    let (mut acc, mut att) = (0, 0);
    for t in &targets {
        if let Ok(l) = locate(&t.points, None, &params) {
            (acc, att) = (acc + l.accepted, att + l.attempts);
        }
    }
    eprintln!("20 random targets, default: {acc}/{att} accepted");
    let mut g = c.benchmark_group("random_targets");
    g.throughput(Throughput::Elements(targets.len() as u64));
    g.sample_size(20);
    g.bench_function("locate_20_default", |b| {
        b.iter(|| {
            targets
                .iter()
                .map(|t| locate(&t.points, None, &params).is_ok())
                .count()
        })
    });
    g.finish();

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
