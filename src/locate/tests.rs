//! The locator's accuracy, behaviour and diagnostics on synthetic crops.

use super::testgen;
use super::*;
use rand::SeedableRng;

/// Corner accuracy and acceptance on random synthetic targets.
mod accuracy {
    use super::testgen;
    use super::*;

    fn rng(seed: u64) -> rand_pcg::Pcg64Mcg {
        rand_pcg::Pcg64Mcg::seed_from_u64(seed)
    }

    fn horizontal_error(a: &Point, b: &Point, up: &Vector3<f64>) -> f64 {
        let d = a - b;
        (d - up * up.dot(&d)).norm()
    }

    fn percentile(sorted: &[f64], q: f64) -> f64 {
        sorted[((sorted.len() - 1) as f64 * q).round() as usize]
    }

    /// Locates `n` random targets; returns sorted 3D errors, sorted horizontal
    /// errors, total accepted and total attempts.
    fn run_many(
        n: usize,
        seed: u64,
        params: &LocateParams,
    ) -> (Vec<f64>, Vec<f64>, usize, usize, Vec<String>) {
        let mut r = rng(seed);
        let (mut e3, mut e2, mut acc, mut att, mut fails) =
            (Vec::new(), Vec::new(), 0, 0, Vec::new());
        for i in 0..n {
            let spec = testgen::random_spec(&mut r, i % 2 == 1);
            let t = testgen::generate(&mut r, &spec);
            let p = LocateParams {
                seed: i as u64,
                ..params.clone()
            };
            let loc = match locate(&t.points, None, &p) {
                Ok(l) => l,
                Err(e) => {
                    fails.push(format!(
                        "target {i} (noise {:.3}, {} viewpoints): {e}",
                        spec.noise,
                        spec.viewpoints.len()
                    ));
                    continue;
                }
            };
            e3.push((loc.corner - t.corner).norm());
            e2.push(horizontal_error(&loc.corner, &t.corner, &t.up));
            acc += loc.accepted;
            att += loc.attempts;
        }
        e3.sort_by(f64::total_cmp);
        e2.sort_by(f64::total_cmp);
        (e3, e2, acc, att, fails)
    }

    #[test]
    fn corner_accuracy_on_random_targets() {
        // 50 targets, half at UTM-sized coordinates; 40 samples keep the test quick.
        let params = LocateParams {
            samples: 40,
            ..LocateParams::default()
        };
        let (e3, e2, acc, att, fails) = run_many(50, 11, &params);
        assert!(fails.is_empty(), "failures: {fails:#?}");
        let (med, p95) = (percentile(&e3, 0.5), percentile(&e3, 0.95));
        eprintln!(
            "3D error median {:.4} p95 {:.4} max {:.4}; 2D median {:.4} p95 {:.4}; acceptance {:.3}",
            med,
            p95,
            e3[e3.len() - 1],
            percentile(&e2, 0.5),
            percentile(&e2, 0.95),
            acc as f64 / att as f64
        );
        // The target position is horizontal (the paper evaluates in 2D); z is by
        // definition the mean height of the inliers, which the truth (mean height of
        // all noise-free plate hits) only approximates, so it gets a looser bound.
        let (med2, p95_2) = (percentile(&e2, 0.5), percentile(&e2, 0.95));
        assert!(med2 <= 0.005, "median horizontal corner error {med2}");
        assert!(
            p95_2 <= 0.015,
            "95th percentile horizontal corner error {p95_2}"
        );
        assert!(
            med <= 0.010 && p95 <= 0.020,
            "3D corner error median {med}, p95 {p95}"
        );
    }

    /// Acceptance and accuracy of the paper's algorithm against the default; run with
    /// `cargo test --release acceptance_report -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn acceptance_report() {
        let d = LocateParams::default;
        let variants = [
            ("default", d()),
            (
                // The default before the speed-ups: exact RANSAC and k-means.
                "exhaustive",
                LocateParams {
                    kmeans_points: 0,
                    ransac_score_points: 0,
                    ransac_confidence: 0.0,
                    ..d()
                },
            ),
            (
                "kmeans-all",
                LocateParams {
                    kmeans_points: 0,
                    ..d()
                },
            ),
            (
                "confidence-0.99999",
                LocateParams {
                    ransac_confidence: 0.99999,
                    ..d()
                },
            ),
            (
                "score64",
                LocateParams {
                    ransac_score_points: 64,
                    ..d()
                },
            ),
            (
                "refit1",
                LocateParams {
                    refit_iterations: 1,
                    ..d()
                },
            ),
            (
                "refit3",
                LocateParams {
                    refit_iterations: 3,
                    ..d()
                },
            ),
            (
                // The refit band before it followed the noise.
                "band-threshold",
                LocateParams {
                    refit_sigmas: 0.0,
                    refit_iterations: 1,
                    ..d()
                },
            ),
            ("paper", LocateParams::paper()),
        ];
        for (name, params) in variants {
            let (e3, e2, acc, att, fails) = run_many(60, 5, &params);
            eprintln!("{name}: {} failures: {fails:#?}", fails.len());
            eprintln!(
                "{name}: acceptance {:.4} ({acc}/{att}); 3D median {:.4} p95 {:.4}; 2D median {:.4} p95 {:.4}",
                acc as f64 / att as f64,
                percentile(&e3, 0.5),
                percentile(&e3, 0.95),
                percentile(&e2, 0.5),
                percentile(&e2, 0.95)
            );
        }
    }
}

/// Typed errors, determinism, the `up` vector.
mod behaviour {
    use super::testgen;
    use super::*;

    fn target(seed: u64, one_plate: bool) -> testgen::Target {
        let mut r = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
        let mut spec = testgen::random_spec(&mut r, true);
        spec.one_plate = one_plate;
        spec.noise = 0.02;
        testgen::generate(&mut r, &spec)
    }

    #[test]
    fn one_plate_fails_with_a_clear_reason() {
        let t = target(3, true);
        let e = locate(&t.points, None, &LocateParams::default()).unwrap_err();
        assert!(matches!(e, LocateError::OnePlate { .. }), "{e:?}");
        assert!(e.to_string().contains("only one plate"), "{e}");
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let t = target(4, false);
        let p = LocateParams::default();
        assert_eq!(
            locate(&t.points[..5], None, &p).unwrap_err(),
            LocateError::TooFewPoints { n: 5 }
        );
        let mut bad = t.points.clone();
        bad[7].y = f64::NAN;
        assert_eq!(
            locate(&bad, None, &p).unwrap_err(),
            LocateError::NonFinite { index: 7 }
        );
        assert_eq!(
            locate(&t.points, Some(Vector3::zeros()), &p).unwrap_err(),
            LocateError::BadUp
        );
        let q = LocateParams {
            inlier_threshold: -1.0,
            ..p
        };
        assert!(matches!(
            locate(&t.points, None, &q),
            Err(LocateError::Param(_))
        ));
    }

    #[test]
    fn deterministic_for_any_thread_count_and_seed_spread_is_honest() {
        let t = target(5, false);
        let p = LocateParams::default();
        let run = |threads: usize, p: &LocateParams| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| locate(&t.points, None, p).unwrap())
        };
        let a = run(1, &p);
        let b = run(3, &p);
        assert_eq!(a, b);
        assert_eq!(a.labels.len(), t.points.len());
        assert!(a.labels.contains(&Label::Plate1) && a.labels.contains(&Label::Plate2));
        let c = run(2, &LocateParams { seed: 99, ..p });
        assert_ne!(a.corner, c.corner);
        for k in 0..3 {
            let tol = 4.0 * a.std[k].max(c.std[k]) + 1e-4;
            assert!(
                (a.corner[k] - c.corner[k]).abs() <= tol,
                "axis {k}: {a:?} vs {c:?}"
            );
        }
    }

    /// An L seen from one side only (a forward-looking scanner): 2 cm of range
    /// noise along rays from the L's open quadrant. The returns pushed past
    /// each plate's free end turned the plates and put the corner 1.89 mm off
    /// on average (`FREE_END_CHI2` = ∞ measures it); the refit's free-end test
    /// drops them: 0.79 mm.
    #[test]
    fn one_sided_range_noise_does_not_turn_the_plates() {
        use rand::Rng;
        use rand_distr::{Distribution, Normal};
        let ray = Vector3::new(-1.0, -0.8, -0.15).normalize();
        let noise = Normal::new(0.0, 0.02).unwrap();
        let mut errors = Vec::new();
        for seed in 0..6u64 {
            let mut r = rand_pcg::Pcg64Mcg::seed_from_u64(100 + seed);
            let mut pts = Vec::new();
            for k in 0..2 {
                for _ in 0..8000 {
                    let (t, z) = (r.random_range(0.02..0.6), r.random_range(0.3..0.9));
                    let p = if k == 0 {
                        Vector3::new(t, 0.0, z)
                    } else {
                        Vector3::new(0.0, t, z)
                    };
                    let q = p + ray * noise.sample(&mut r);
                    pts.push(Point::new(q.x + 500.0, q.y - 200.0, q.z));
                }
            }
            let l = locate(&pts, None, &LocateParams::default()).unwrap();
            let truth = Point::new(500.0, -200.0, 0.6);
            errors.push((l.corner.x - truth.x).hypot(l.corner.y - truth.y));
        }
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        assert!(
            mean < 0.001,
            "corner {:.2} mm off on average: {errors:?}",
            1e3 * mean
        );
    }

    #[test]
    fn tilted_up_is_honoured() {
        let mut r = rand_pcg::Pcg64Mcg::seed_from_u64(8);
        let mut spec = testgen::random_spec(&mut r, false);
        spec.tilt = (3f64.to_radians(), 1.0);
        spec.noise = 0.01;
        let t = testgen::generate(&mut r, &spec);
        let p = LocateParams::default();
        // Against +z the plates lean 3°: every sample fails the vertical gate.
        assert!(locate(&t.points, None, &p).is_err());
        let l = locate(&t.points, Some(t.up), &p).unwrap();
        assert!(
            (l.corner - t.corner).norm() < 0.02,
            "{:?} vs {:?}",
            l.corner,
            t.corner
        );
        assert!(l.plates.iter().all(|q| q.tilt_deg <= 1.0));
    }
}

/// Reject breakdowns for tuning (ignored by default).
mod diag {
    use super::testgen;
    use super::*;

    /// The benchmark's target: reject breakdown per parameter set
    /// (`MG_DIAG_DEFAULT=1`: the default only, e.g. under `perf record`).
    #[test]
    #[ignore]
    fn bench_target_rejects() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(42);
        let mut spec = testgen::random_spec(&mut rng, true);
        spec.points = 950;
        spec.noise = 0.02;
        let t = testgen::generate(&mut rng, &spec);
        for (name, p) in [
            ("default", LocateParams::default()),
            ("paper", LocateParams::paper()),
            (
                "no-adaptive",
                LocateParams {
                    ransac_confidence: 0.0,
                    ..LocateParams::default()
                },
            ),
            (
                "margin0.15",
                LocateParams {
                    corner_margin: 0.15,
                    ..LocateParams::default()
                },
            ),
            (
                "exact-ransac",
                LocateParams {
                    ransac_score_points: 0,
                    ..LocateParams::default()
                },
            ),
            (
                "refit5",
                LocateParams {
                    refit_iterations: 5,
                    ..LocateParams::default()
                },
            ),
        ] {
            if std::env::var_os("MG_DIAG_DEFAULT").is_some() && name != "default" {
                continue;
            }
            let t0 = std::time::Instant::now();
            let r = locate(&t.points, None, &p);
            let dt = t0.elapsed();
            match r {
                Ok(l) => eprintln!(
                    "{name}: {:?} {}/{} {:?} err {:.4} plates {:?} {:.3}",
                    dt,
                    l.accepted,
                    l.attempts,
                    l.rejects,
                    (l.corner - t.corner).norm(),
                    l.plates,
                    l.plate_angle_deg
                ),
                Err(e) => eprintln!("{name}: {dt:?} {e}"),
            }
        }
    }
}
