//! The locator's acceptance rate (the share of sampling attempts whose fit passes
//! the 1° gates) on a fixed set of synthetic targets, default against the paper's
//! algorithm. Acceptance is what the locator's speed rests on: it stops after
//! `samples` accepted attempts, so half the acceptance is about twice the time.
//! README.md quotes what this measures.

use mapgauge::locate::{LocateParams, locate, testgen};
use rand::SeedableRng;
use std::time::Instant;

/// What one parameter set did over the fixed targets.
struct Tally {
    accepted: usize,
    attempts: usize,
    located: usize,
    /// Median horizontal corner error (m) of the located targets.
    median_h: f64,
    seconds: f64,
}

impl Tally {
    fn acceptance(&self) -> f64 {
        self.accepted as f64 / self.attempts as f64
    }
}

/// The fixed set: `n` targets drawn as the locator's unit tests draw them (800–1,300
/// points, 1–3 cm noise, 5 % outliers, 1–3 viewpoints; every other one at UTM-sized
/// coordinates), from seed 5.
fn targets(n: usize) -> Vec<testgen::Target> {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
    (0..n)
        .map(|i| {
            let spec = testgen::random_spec(&mut rng, i % 2 == 1);
            testgen::generate(&mut rng, &spec)
        })
        .collect()
}

fn tally(targets: &[testgen::Target], params: &LocateParams) -> Tally {
    let t0 = Instant::now();
    let (mut accepted, mut attempts, mut errs) = (0, 0, Vec::new());
    for (i, t) in targets.iter().enumerate() {
        let p = LocateParams {
            seed: i as u64,
            ..params.clone()
        };
        if let Ok(l) = locate(&t.points, None, &p) {
            accepted += l.accepted;
            attempts += l.attempts;
            let d = l.corner - t.corner;
            errs.push((d - t.up * t.up.dot(&d)).norm());
        }
    }
    errs.sort_by(f64::total_cmp);
    Tally {
        accepted,
        attempts,
        located: errs.len(),
        median_h: errs.get(errs.len() / 2).copied().unwrap_or(f64::NAN),
        seconds: t0.elapsed().as_secs_f64(),
    }
}

fn report(name: &str, n: usize, t: &Tally) {
    eprintln!(
        "{name}: acceptance {:.4} ({}/{}), located {}/{n}, median horizontal error {:.1} mm, {:.2} s",
        t.acceptance(),
        t.accepted,
        t.attempts,
        t.located,
        t.median_h * 1000.0,
        t.seconds
    );
}

/// Today (this code, 20 targets): 1882 of 9657 attempts accepted (19.5 %), every
/// target located, median horizontal error 3.4 mm, about 1 s in release on a
/// loaded 2-core machine. The floors are well below, the ceilings well above,
/// so only a real regression trips them.
#[test]
fn default_acceptance_on_fixed_targets() {
    let ts = targets(N);
    let d = tally(&ts, &LocateParams::default());
    report("default", N, &d);
    assert_eq!(d.located, N, "targets the locator no longer finds");
    assert!(
        d.acceptance() >= 0.12,
        "acceptance {:.4} fell well below today's 0.195",
        d.acceptance()
    );
    // The work: attempts are what the time is made of (deterministic, unlike time).
    assert!(
        d.attempts <= 15_000,
        "{} attempts for {N} targets, today 9657",
        d.attempts
    );
    assert!(
        d.median_h <= 0.005,
        "median horizontal error {} m",
        d.median_h
    );
    // The speed budget is 20 ms a target on a quiet machine; 25 times that only
    // trips on a collapse (or a debug build, which this is not meant for).
    if !cfg!(debug_assertions) {
        assert!(
            d.seconds <= 10.0,
            "{N} targets took {:.1} s (budget 20 ms each, quiet machine)",
            d.seconds
        );
    }
}

/// The same targets with the paper's algorithm (3D k-means from random points,
/// exhaustive RANSAC, up to 10 000 attempts): 284 of 12 279 attempts accepted
/// (2.3 %), 3 of 20 targets located, about 50 s. Too slow for CI:
/// `cargo test --release --test integration locate_acceptance -- --ignored`.
#[test]
#[ignore = "about 50 s: the paper's algorithm gives up only after 10 000 attempts"]
fn default_acceptance_is_several_times_the_papers() {
    let ts = targets(N);
    let d = tally(&ts, &LocateParams::default());
    let p = tally(&ts, &LocateParams::paper());
    report("default", N, &d);
    report("paper", N, &p);
    assert!(
        d.acceptance() >= 5.0 * p.acceptance(),
        "default {:.4} vs paper {:.4}",
        d.acceptance(),
        p.acceptance()
    );
    assert!(d.located > p.located);
}

/// Targets in the fixed set.
const N: usize = 20;
