//! Measures synthetic map generation speed with a counting sink (no I/O).
//!
//! `cargo run --release --example synth_speed -- [POINTS] [SEED] [TARGET_DISTANCE_M]`
//!
//! Measured 2026-11-23, release, 2 cores shared with other jobs (load ~6):
//! default scene (2.0 M points, 57 scans) 1.7 s = 1.15 M points/s;
//! 20 M points 22 s = 0.91 M points/s; one thread 0.86 M points/s (same checksum).
//! Profile: ~50 % in `sin` of the ground height field (sphere tracing).

use mapgauge::synth::{SynthParams, generate};

fn main() -> mapgauge::Result<()> {
    let mut args = std::env::args().skip(1);
    let points = args
        .next()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2_000_000u64);
    let seed = args.next().and_then(|s| s.parse().ok()).unwrap_or(1u64);
    let mut p = SynthParams {
        points,
        seed,
        ..Default::default()
    };
    if let Some(d) = args.next().and_then(|s| s.parse::<f64>().ok()) {
        p.target_distance_m = [d, d];
    }
    let start = std::time::Instant::now();
    let mut n = 0u64;
    let mut checksum = 0f64;
    let truth = generate(&p, &mut |b| {
        n += b.len() as u64;
        checksum += b.iter().map(|q| q.x + q.y + q.z).sum::<f64>();
        Ok(())
    })?;
    let s = start.elapsed().as_secs_f64();
    println!(
        "{} points, {} scans, {:.2} s, {:.2} M points/s, {} threads, checksum {:.6e}",
        n,
        truth.scans,
        s,
        n as f64 / s / 1e6,
        rayon::current_num_threads(),
        checksum
    );
    for t in &truth.targets {
        println!(
            "target {} at road distance {:.1} m: {} returns",
            t.id, t.road_distance_m, t.points
        );
    }
    Ok(())
}
