//! Calibration of the per-target covariance (issue 17): on synthetic targets
//! with known corners, the 95 % and 68 % horizontal ellipses (χ²₂) of
//! `Located::covariance` must contain the true corner about that often.
//!
//! `cargo test --release --test integration uncertainty:: -- --nocapture`
//! prints the coverage per condition (the table in docs/uncertainty.md).

use mapgauge::locate::{self, LocateParams, testgen};
use nalgebra::{Matrix2, Vector2, Vector3};
use rand::{Rng, SeedableRng};

/// χ²₂ quantiles: −2 ln(1 − p).
const CHI2_95: f64 = 5.991_464_547_107_979;
const CHI2_68: f64 = 2.278_869_232_352_346;

/// One condition of the calibration grid.
#[derive(Clone, Copy)]
struct Condition {
    noise: f64,
    range: (f64, f64),
    tilted: bool,
}

impl Condition {
    fn label(&self) -> String {
        format!(
            "{:.0} cm, {:.0}–{:.0} m, {}",
            self.noise * 100.0,
            self.range.0,
            self.range.1,
            if self.tilted { "tilted" } else { "level" }
        )
    }
}

/// Tally of one condition.
#[derive(Default, Clone, Copy)]
struct Tally {
    n: usize,
    in95: usize,
    in68: usize,
    failed: usize,
}

/// A target seen from `range` metres: 1–3 viewpoints, points falling off with
/// the square of the distance (1,300 at 8 m, at least 200), 5–15 % clutter.
fn spec<R: Rng>(rng: &mut R, c: &Condition) -> testgen::Spec {
    let nv = rng.random_range(1..=3);
    let viewpoints: Vec<Vector3<f64>> = (0..nv)
        .map(|i| {
            let v = testgen::viewpoint(rng, i == 0);
            let d = rng.random_range(c.range.0..c.range.1);
            let h = Vector3::new(v.x, v.y, 0.0).normalize() * d;
            Vector3::new(h.x, h.y, v.z)
        })
        .collect();
    let nearest = viewpoints
        .iter()
        .map(|v| v.xy().norm())
        .fold(f64::INFINITY, f64::min);
    let points = ((1300.0 * (8.0 / nearest).powi(2)).round() as usize).clamp(200, 1300);
    testgen::Spec {
        origin: Vector3::new(
            rng.random_range(-200.0..200.0),
            rng.random_range(-200.0..200.0),
            rng.random_range(-2.0..2.0),
        ),
        heading: rng.random_range(0.0..std::f64::consts::TAU),
        tilt: if c.tilted {
            (
                rng.random_range(0.2f64..0.7).to_radians(),
                rng.random_range(0.0..std::f64::consts::TAU),
            )
        } else {
            (0.0, 0.0)
        },
        noise: c.noise,
        viewpoints,
        points,
        outlier_fraction: rng.random_range(0.05..0.15),
        one_plate: false,
    }
}

/// Runs `per` targets of condition `c` from `seed`.
fn run(c: &Condition, seed: u64, per: usize) -> Tally {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let mut t = Tally::default();
    for i in 0..per {
        let s = spec(&mut rng, c);
        let target = testgen::generate(&mut rng, &s);
        let params = LocateParams {
            seed: seed ^ i as u64,
            ..LocateParams::default()
        };
        let up = c.tilted.then_some(target.up);
        let Ok(l) = locate::locate(&target.points, up, &params) else {
            t.failed += 1;
            continue;
        };
        let e = Vector2::new(l.corner.x - target.corner.x, l.corner.y - target.corner.y);
        let cov = Matrix2::new(
            l.covariance[0][0],
            l.covariance[0][1],
            l.covariance[1][0],
            l.covariance[1][1],
        );
        let m2 = (e.transpose() * cov.try_inverse().expect("covariance invertible") * e)[(0, 0)];
        t.n += 1;
        t.in95 += usize::from(m2 <= CHI2_95);
        t.in68 += usize::from(m2 <= CHI2_68);
    }
    t
}

fn pct(k: usize, n: usize) -> f64 {
    100.0 * k as f64 / n.max(1) as f64
}

#[test]
fn covariance_ellipses_are_calibrated() {
    let mut conditions = Vec::new();
    for noise in [0.01, 0.02, 0.03] {
        for range in [(5.0, 15.0), (15.0, 35.0)] {
            for tilted in [false, true] {
                conditions.push(Condition {
                    noise,
                    range,
                    tilted,
                });
            }
        }
    }
    // 12 conditions × 2 seeds × 14 targets = 336 targets.
    let seeds = [17u64, 1017];
    let per = 14;
    let mut total = Tally::default();
    println!("| condition | targets | in 68 % ellipse | in 95 % ellipse | not located |");
    println!("|---|---|---|---|---|");
    for (k, c) in conditions.iter().enumerate() {
        let mut t = Tally::default();
        for s in seeds {
            let r = run(c, s * 100 + k as u64, per);
            t.n += r.n;
            t.in95 += r.in95;
            t.in68 += r.in68;
            t.failed += r.failed;
        }
        println!(
            "| {} | {} | {:.0} % | {:.0} % | {} |",
            c.label(),
            t.n,
            pct(t.in68, t.n),
            pct(t.in95, t.n),
            t.failed
        );
        total.n += t.n;
        total.in95 += t.in95;
        total.in68 += t.in68;
        total.failed += t.failed;
    }
    let (c95, c68) = (pct(total.in95, total.n), pct(total.in68, total.n));
    println!(
        "| all | {} | {c68:.1} % | {c95:.1} % | {} |",
        total.n, total.failed
    );
    assert!(total.n >= 300, "only {} targets located", total.n);
    assert!(
        (92.0..=98.0).contains(&c95),
        "95 % ellipse covers {c95:.1} %"
    );
    assert!(
        (62.0..=74.0).contains(&c68),
        "68 % ellipse covers {c68:.1} %"
    );
}

/// `compare` on two committed result files: the verdict, the tables, JSON, and
/// a clear refusal of a wrong `--names`.
#[test]
fn compare_cli_gives_a_verdict() {
    use crate::util::{bin, stderr, stdout_ok};
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/tilted");
    let (a, b) = (dir.join("a__result.json"), dir.join("b__result.json"));
    let out = stdout_ok(
        bin()
            .arg("compare")
            .arg(&a)
            .arg(&b)
            .args(["--names", "a,b"]),
    );
    // The tilted golden's 3D run (a) and its robust run (b) differ by less
    // than their targets' scatter allows since the map is levelled by its
    // heights (a significant verdict: `compare`'s unit tests).
    assert!(
        out.starts_with("E_abs: no significant difference (b − a = -3 mm, 95 % CI [-12, 8] mm)\n"),
        "{out}"
    );
    assert!(out.contains("E_rel: no significant difference"), "{out}");
    let json = stdout_ok(
        bin()
            .arg("compare")
            .arg(&a)
            .arg(&b)
            .args(["--format", "json"]),
    );
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["targets"].as_array().unwrap().len(), 5);
    let ci = &v["e_abs"]["ci95"];
    assert!(
        ci[0].as_f64().unwrap() < 0.0 && ci[1].as_f64().unwrap() > 0.0,
        "{ci}"
    );
    let o = bin()
        .arg("compare")
        .arg(&a)
        .arg(&b)
        .args(["--names", "x"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("--names has 1 names for 2 result files"),
        "{}",
        stderr(&o)
    );
}

/// `table --stats`: three rows (mean, 95 % interval ends) after the runs, in
/// text and JSON.
#[test]
fn table_stats_adds_mean_and_interval_rows() {
    use crate::util::{bin, stdout_ok};
    let g = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden");
    let files = [
        g.join("tilted/a__result.json"),
        g.join("tilted/b__result.json"),
    ];
    let out = stdout_ok(bin().arg("table").args(&files).args([
        "--stats", "--which", "absolute", "--format", "text", "--names", "a,b",
    ]));
    let mean = out
        .lines()
        .find(|l| l.starts_with("mean (2 runs)"))
        .expect(&out);
    // E_abs 0.0224 and 0.0191: mean 0.0207 (rounding of the cells aside).
    assert!(mean.split_whitespace().nth(3) == Some("0.0207"), "{out}");
    assert!(
        out.contains("95 % CI low") && out.contains("95 % CI high"),
        "{out}"
    );
    let json = stdout_ok(
        bin()
            .arg("table")
            .args(&files)
            .args(["--stats", "--which", "absolute", "--format", "json"]),
    );
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let rows = v["absolute"].as_array().unwrap();
    assert_eq!(rows.len(), 5);
    let (lo, hi) = (
        rows[3]["E_abs"].as_f64().unwrap(),
        rows[4]["E_abs"].as_f64().unwrap(),
    );
    // Two runs: Student's t of one degree of freedom, far wider than both
    // (12.7 × the 3.3 mm between them: 42 mm wide).
    assert!(lo < 0.0191 && hi > 0.0224 && hi - lo > 0.03, "{lo} {hi}");
}

/// Issue 31: a map stretched by 1.5 ‰ came out "no significant difference"
/// from the same map unstretched. Each run now states its horizontal scale
/// with an interval, and `compare` the difference: +1500 ppm within its
/// interval, which excludes 0.
#[test]
fn a_stretched_map_shows_its_scale_and_compare_says_so() {
    use crate::util::{bin, stdout_ok, tempdir};
    let dir = tempdir();
    let scene = dir.path().join("scene");
    stdout_ok(
        bin()
            .args(["synth", "--points", "1000000", "--seed", "4", "--out"])
            .arg(&scene),
    );
    let map = scene.join("map.ply");
    let pts = mapgauge::cloud::read_all(&map).unwrap();
    let c = pts
        .iter()
        .fold(nalgebra::Vector3::zeros(), |a, p| a + p.coords)
        / pts.len() as f64;
    let k = 1.0015;
    let stretched: Vec<mapgauge::Point> = pts
        .iter()
        .map(|p| mapgauge::Point::new(c.x + k * (p.x - c.x), c.y + k * (p.y - c.y), p.z))
        .collect();
    let map_b = dir.path().join("stretched.ply");
    mapgauge::cloud::write(&map_b, mapgauge::cloud::OutFormat::Ply, &stretched).unwrap();
    let survey = scene.join("survey.csv");
    let mut scales = Vec::new();
    for (m, out) in [(&map, "a"), (&map_b, "b")] {
        let text = stdout_ok(
            bin()
                .args(["eval", "--no-report", "--map"])
                .arg(m)
                .arg("--survey")
                .arg(&survey)
                .arg("--out")
                .arg(dir.path().join(out)),
        );
        assert!(text.contains("  scale  "), "{text}");
        let r: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join(out).join("result.json")).unwrap(),
        )
        .unwrap();
        scales.push(r["scale"]["ppm"].as_f64().unwrap());
    }
    // The synthetic map's own drift stretches it a little; the difference
    // is the 1500 ppm put in.
    assert!((scales[1] - scales[0] - 1500.0).abs() < 150.0, "{scales:?}");
    let out = stdout_ok(
        bin()
            .arg("compare")
            .arg(dir.path().join("a/result.json"))
            .arg(dir.path().join("b/result.json"))
            .args(["--names", "a,b"]),
    );
    assert!(
        out.contains("scale: b's map is stretched against a's by 1"),
        "{out}"
    );
}

/// A synth scene (`config`, `seed`, `points`) in `dir`, evaluated by the CLI
/// (`dir/out`); its result beside its truth.
fn synth_and_eval(
    config: &std::path::Path,
    seed: u64,
    points: u64,
    dir: &std::path::Path,
) -> crate::truth::Run {
    crate::util::stdout_ok(crate::util::bin().args([
        "synth",
        "--config",
        config.to_str().unwrap(),
        "--seed",
        &seed.to_string(),
        "--points",
        &points.to_string(),
        "--out",
        dir.to_str().unwrap(),
    ]));
    let out = dir.join("out");
    crate::util::stdout_ok(
        crate::util::bin()
            .args(["eval", "--no-report", "--map"])
            .arg(dir.join("map.ply"))
            .arg("--survey")
            .arg(dir.join("survey.csv"))
            .arg("--out")
            .arg(&out),
    );
    crate::truth::Run::read(&out.join("result.json"), &dir.join("truth.json"))
}

/// A located target's vertical σ (mm) from result.json's map covariance.
fn sigma_z_mm(r: &crate::truth::Run, id: &str) -> f64 {
    let t = r.result["targets"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["id"] == id)
        .unwrap();
    1e3 * t["map_covariance"][2][2].as_f64().unwrap().sqrt()
}

/// Issue 30: a target whose lower plates are hidden (a barrier between it
/// and the road, grass through the plates) has its corner's height placed in
/// the middle of what is seen, up to 10 cm above the plates' middle (18 cm
/// as the paper's mean height). Its vertical σ must say so (it said 7–15 mm:
/// 8–22 σ off), and the run must name it. The other targets' heights (the
/// scan lines crowd toward part of a plate) must be covered too (they were
/// up to 4.3 σ off). `bench/heights_table.py` measures more seeds.
#[test]
fn heights_of_plates_seen_in_part_are_covered() {
    let tmp = crate::util::tempdir();
    let mut worst: f64 = 0.0;
    for (case, seed) in [
        ("hide_lower = 0.5", 1),
        ("hide_lower = 0.5", 2),
        ("grass_m = 0.4", 2),
    ] {
        let dir = tmp.path().join(format!("{}-{seed}", &case[..4]));
        let cfg = tmp.path().join("obstacles.toml");
        std::fs::write(&cfg, format!("[obstacles]\n{case}\n")).unwrap();
        let r = synth_and_eval(&cfg, seed, 2_000_000, &dir);
        let errors = r.corner_errors().expect("every target found");
        for e in &errors {
            let sz = sigma_z_mm(&r, &e.id);
            let z = e.dz / sz;
            println!(
                "{case}, seed {seed}, target {}: dz {:+.1} mm, σz {sz:.1} mm, {z:+.2} σ",
                e.id, e.dz
            );
            worst = worst.max(z.abs());
            if e.id == "1" && case.starts_with("hide") {
                assert!(
                    e.dz > 50.0,
                    "the barrier no longer hides the plates: {}",
                    e.dz
                );
            }
        }
        // "the heights of targets 1, 4 are uncertain by up to …"
        let said = r.result["warnings"].as_array().unwrap().iter().any(|w| {
            let w = w.as_str().unwrap();
            w.strip_prefix("the height of target ")
                .or_else(|| w.strip_prefix("the heights of targets "))
                .and_then(|w| w.split(" uncertain by").next())
                .is_some_and(|ids| ids.split([' ', ',']).any(|id| id == "1"))
        });
        assert!(
            !case.starts_with("hide") || said,
            "{}",
            r.result["warnings"]
        );
    }
    // Measured 1.77 at most over 6 seeds of each of four such cases (2.02
    // with the mean height; docs/uncertainty.md).
    assert!(worst < 2.5, "a height {worst:.2} σ from the truth");
}

/// Plates taller than configured (0.68 m measured as 0.6 m ones) span more
/// than a plate: nothing says where in that span a 0.6 m plate's middle is,
/// and the mean height, kept there, was up to 3.3 σ off with nothing said
/// (`bench/heights_table.py`). Seed 1 shows it on every target: each is
/// named, the run asks about the plate height, and each height is covered.
#[test]
fn plates_taller_than_configured_are_named_and_covered() {
    let tmp = crate::util::tempdir();
    let cfg = tmp.path().join("tall.toml");
    std::fs::write(&cfg, "[target]\nplate_height_m = 0.68\n").unwrap();
    let r = synth_and_eval(&cfg, 1, 2_000_000, &tmp.path().join("s"));
    let errors = r.corner_errors().expect("every target found");
    for e in &errors {
        let sz = sigma_z_mm(&r, &e.id);
        println!("target {}: dz {:+.1} mm, σz {sz:.1} mm", e.id, e.dz);
        // Measured 1.56 at most (3.3 σ on seeds 2–3 where a span fits
        // inside the crop's band: docs/uncertainty.md).
        assert!(
            e.dz.abs() < 2.0 * sz,
            "target {}: {} mm, σz {sz}",
            e.id,
            e.dz
        );
    }
    let w = r.result["warnings"].as_array().unwrap();
    let said = w
        .iter()
        .filter_map(|w| w.as_str())
        .find(|w| w.contains("more than the 0.60 m plate height"))
        .unwrap_or_else(|| panic!("{w:?}"));
    assert!(
        said.starts_with("the heights of targets 1, 2, 3, 4, 5 are uncertain")
            && said.ends_with("are the plates 0.60 m tall (--plate-size W,H)?"),
        "{said}"
    );
}

/// Issue 30: a map whose second pass drifted in height alone (4 cm) holds
/// every target twice in one plane: the plates cannot show it, and heights
/// were up to 6.9 σ from the first pass's (`bench/heights_table.py`). The
/// ground about each target shows two layers: the run names them, and each
/// height's σ covers either copy. The horizontal errors stay as they were.
#[test]
fn a_seam_in_height_is_seen_in_the_ground_and_covered() {
    let tmp = crate::util::tempdir();
    let cfg = tmp.path().join("seam.toml");
    std::fs::write(
        &cfg,
        "[second_pass]\nshare = 1.0\noffset_m = [0.0, 0.0, 0.04]\n",
    )
    .unwrap();
    for seed in [1, 2] {
        let r = synth_and_eval(&cfg, seed, 2_000_000, &tmp.path().join(format!("s{seed}")));
        let errors = r.corner_errors().expect("every target found");
        for e in &errors {
            let sz = sigma_z_mm(&r, &e.id);
            println!(
                "seed {seed}, target {}: dz {:+.1} mm, σz {sz:.1} mm",
                e.id, e.dz
            );
            // Measured 1.69 at most on these seeds.
            assert!(
                e.dz.abs() < 2.0 * sz,
                "target {}: {} mm, σz {sz}",
                e.id,
                e.dz
            );
            assert!(sz > 20.0 && sz < 45.0, "target {}: σz {sz}", e.id);
        }
        let w = r.result["warnings"].as_array().unwrap();
        assert!(
            w.iter().filter_map(|w| w.as_str()).any(|w| w.starts_with(
                "the ground around targets 1, 2, 3, 4, 5 shows two thin layers 40 mm apart in height"
            )),
            "{w:?}"
        );
    }
}

/// Issue 30: the covariance must hold for scan patterns other than a
/// spinning LiDAR's. A hand-held Livox-like sensor (a rosette in a 70°
/// forward cone, 240 k points/s, walking pace, 3° of sway) sees each target
/// from one side, obliquely, densest where the rose passes its centre.
/// `ROSETTE_SEEDS=N` runs seeds 1..=N and prints every target (measured over
/// 12 seeds at 3 M points and 8 at 6 M, `ROSETTE_POINTS`: 83 of 90 located
/// targets inside their 95 % ellipse, 80 before the refit's free-end test:
/// see docs/uncertainty.md; `ROSETTE_SPINNING=1` scans with synth's spinning
/// LiDAR instead); the test asserts seeds 1–2 at 3 M points.
#[test]
fn covariance_holds_for_a_rosette_scan() {
    let seeds: u64 = std::env::var("ROSETTE_SEEDS").map_or(2, |s| s.parse().unwrap());
    let points: u64 = std::env::var("ROSETTE_POINTS").map_or(3_000_000, |s| s.parse().unwrap());
    // ROSETTE_SPINNING=1: synth's spinning LiDAR instead, for comparison.
    let spinning = std::env::var("ROSETTE_SPINNING").is_ok_and(|v| v == "1");
    let tmp = crate::util::tempdir();
    let cfg = tmp.path().join("rosette.toml");
    std::fs::write(
        &cfg,
        if spinning {
            ""
        } else {
            "[lidar]\npattern = \"rosette\"\nfov_deg = 70.0\nsway_deg = 3.0\nbeams = 1\n\
             az_step_deg = 0.015\nspeed_mps = 1.4\nheight_m = 1.5\nmax_range_m = 60.0\n"
        },
    )
    .unwrap();
    let (mut located, mut inside, mut targets) = (0, 0, 0);
    for seed in 1..=seeds {
        let r = synth_and_eval(&cfg, seed, points, &tmp.path().join(format!("s{seed}")));
        let truth = r.truth["targets"].as_array().unwrap();
        targets += truth.len();
        for t in r.result["targets"].as_array().unwrap() {
            if t["status"] != "ok" {
                println!("seed {seed}, target {}: {}", t["id"], t["reason"]);
                continue;
            }
            let tt = truth.iter().find(|x| x["id"] == t["id"]).unwrap();
            let got = |k: &str| t["map"][k].as_f64().unwrap();
            let want = |i: usize| tt["map"][i].as_f64().unwrap();
            let d = Vector3::new(got("x") - want(0), got("y") - want(1), got("z") - want(2));
            let c = |i: usize, j: usize| t["map_covariance"][i][j].as_f64().unwrap();
            let m = Matrix2::new(c(0, 0), c(0, 1), c(1, 0), c(1, 1));
            let dxy = Vector2::new(d.x, d.y);
            let chi2 = (dxy.transpose() * m.try_inverse().unwrap() * dxy)[(0, 0)];
            let z = d.z / c(2, 2).sqrt();
            println!(
                "seed {seed}, target {}: {:.1} mm off horizontally, chi2 {chi2:.2}, height {z:+.2} σ",
                t["id"],
                1e3 * dxy.norm()
            );
            located += 1;
            inside += usize::from(chi2 <= CHI2_95);
            if seeds <= 2 && points == 3_000_000 && !spinning {
                // Seeds 1-2: the largest is 6.9 (99 % ellipse: 9.21).
                assert!(
                    chi2 < 9.21,
                    "seed {seed}, target {}: chi2 {chi2:.2}",
                    t["id"]
                );
                assert!(z.abs() < 2.5, "seed {seed}, target {}: {z:+.2} σ", t["id"]);
            }
        }
    }
    println!("rosette: {located} of {targets} located, {inside} inside the 95 % ellipse");
    assert!(
        located * 10 >= targets * 7,
        "{located} of {targets} located"
    );
}

/// The rosette scans' coverage gap against an oracle (docs/uncertainty.md):
/// per located target, its error and the oracle's ([`oracle_corner`]:
/// planes through the labelled plate returns) in the locator's 95 %
/// ellipse, and the oracle's in its own least-squares ellipse (each plate's
/// offset at the corner, from the residuals). `ROSETTE_SEEDS=N` (default
/// 6), `ROSETTE_POINTS` (default 6 M), `ROSETTE_NOISE` (range noise, m;
/// default the pattern's 2 cm); `--ignored --nocapture`.
#[test]
#[ignore = "a measurement (slow): --ignored --nocapture rosette_against_the_oracle"]
fn rosette_against_the_oracle() {
    use crate::util::oracle_corner;
    use mapgauge::cloud::MapSource;
    use mapgauge::pipeline::{self, Config};
    use mapgauge::synth::{self, PointLabel, SynthParams};
    use nalgebra::Matrix3;
    let env = |k: &str, d: f64| std::env::var(k).map_or(d, |s| s.parse().unwrap());
    let seeds = env("ROSETTE_SEEDS", 6.0) as u64;
    let (mut n, mut loc_in, mut orc_in, mut own_in) = (0, 0, 0, 0);
    for seed in 1..=seeds {
        let mut p: SynthParams = toml::from_str(
            "[lidar]\npattern = \"rosette\"\nfov_deg = 70.0\nsway_deg = 3.0\nbeams = 1\n\
             az_step_deg = 0.015\nspeed_mps = 1.4\nheight_m = 1.5\nmax_range_m = 60.0\n",
        )
        .unwrap();
        p.seed = seed;
        p.points = env("ROSETTE_POINTS", 6e6) as u64;
        p.lidar.range_noise_m = env("ROSETTE_NOISE", p.lidar.range_noise_m);
        let (mut map, mut labels) = (Vec::new(), Vec::new());
        let truth = synth::generate_labelled(&p, &mut |pts, l| {
            map.extend_from_slice(pts);
            labels.extend_from_slice(l);
            Ok(())
        })
        .unwrap();
        let ev = match pipeline::run(
            MapSource::Points(&map),
            &truth.survey(),
            &Config::default(),
            |_, _| {},
        ) {
            Ok(e) => e,
            Err(e) => {
                println!("seed {seed}: {e}");
                continue;
            }
        };
        for (i, (t, tt)) in ev.targets.iter().zip(&truth.targets).enumerate() {
            let Ok(f) = &t.outcome else { continue };
            let tm = Vector3::from(tt.map);
            let Some(o) = oracle_corner(&map, &labels, i, tm) else {
                continue;
            };
            let cov = f.located.covariance;
            let m = Matrix2::new(cov[0][0], cov[0][1], cov[1][0], cov[1][1]);
            let inv = m.try_inverse().unwrap();
            let chi2 = |d: Vector2<f64>, inv: &Matrix2<f64>| (d.transpose() * inv * d)[(0, 0)];
            let c = f.located.corner;
            let d_loc = Vector2::new(c.x - tm.x, c.y - tm.y);
            let d_orc = Vector2::new(o.x - tm.x, o.y - tm.y);
            // The oracle's own covariance: each plate's offset at the corner
            // (intercept, slope along, slope up, from the residuals), along
            // its normal; the plates stand square, so the two add.
            let mut own = Matrix2::zeros();
            for k in 0..2u8 {
                let pts: Vec<Vector3<f64>> = map
                    .iter()
                    .zip(&labels)
                    .filter(|(_, l)| {
                        **l == PointLabel::Plate {
                            target: i as u32,
                            plate: k,
                        }
                    })
                    .map(|(q, _)| q.coords - o)
                    .collect();
                let cm = pts.iter().sum::<Vector3<f64>>() / pts.len() as f64;
                let mut s = Matrix3::zeros();
                for q in &pts {
                    s += (q - cm) * (q - cm).transpose();
                }
                let e = s.symmetric_eigen();
                let nrm = e.eigenvectors.column(e.eigenvalues.imin()).into_owned();
                let along = nrm.cross(&Vector3::z()).normalize();
                let row = |q: &Vector3<f64>| Vector3::new(1.0, along.dot(q), q.z);
                let mut ata = Matrix3::zeros();
                let mut rss = 0.0;
                for q in &pts {
                    ata += row(q) * row(q).transpose();
                    rss += nrm.dot(&(q - cm)).powi(2);
                }
                let var = rss / (pts.len() as f64 - 3.0);
                let at = row(&Vector3::zeros());
                let v = (at.transpose() * ata.try_inverse().unwrap() * at)[(0, 0)] * var;
                let h = Vector2::new(nrm.x, nrm.y).normalize();
                own += h * h.transpose() * v;
            }
            let own_inv = own.try_inverse().unwrap();
            n += 1;
            loc_in += usize::from(chi2(d_loc, &inv) <= CHI2_95);
            orc_in += usize::from(chi2(d_orc, &inv) <= CHI2_95);
            own_in += usize::from(chi2(d_orc, &own_inv) <= CHI2_95);
            println!(
                "seed {seed} target {}: locator ({:+.1}, {:+.1}) mm chi2 {:.1}; oracle ({:+.1}, {:+.1}) mm chi2 {:.1}, in its own ellipse {:.1}",
                i + 1,
                1e3 * d_loc.x,
                1e3 * d_loc.y,
                chi2(d_loc, &inv),
                1e3 * d_orc.x,
                1e3 * d_orc.y,
                chi2(d_orc, &inv),
                chi2(d_orc, &own_inv)
            );
        }
    }
    println!(
        "rosette: {n} targets; in the locator's 95 % ellipse: locator {loc_in}, oracle {orc_in}; the oracle in its own: {own_in}"
    );
}
