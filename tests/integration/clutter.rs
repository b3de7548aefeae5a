//! Issue 16: targets in real clutter. Each case is a small local synth scene
//! (one surveyed target, `POINTS` = 3 M points) with one obstacle from
//! `SynthParams::obstacles`, run through the automatic tight crop and the
//! localisation as `mapgauge eval` does, over several seeds. The error is the
//! horizontal distance (the paper's 2D error) of the located corner from the
//! true corner in the map frame.
//!
//! `cargo test --release --test integration clutter::table -- --ignored --nocapture` prints
//! the table of every case (`CLUTTER_CASE`, `|`-separated parts of case names,
//! and `CLUTTER_SEED` narrow it; `CLUTTER_SEEDS=N` runs seeds 1..=N; `CLUTTER_EACH`
//! prints every error, to compare two builds seed by seed).

use crate::util::oracle_corner;
use mapgauge::Point;
use mapgauge::crop::{TightParams, tight_crop};
use mapgauge::pipeline::{Config, locate_with};
use mapgauge::synth::{self, ObstacleParams, PointLabel, SynthParams, Truth};
use nalgebra::Vector3;

const SEEDS: [u64; 4] = [1, 2, 3, 4];

/// Points of a scene: a target 4–8 m from the path gets 1.7–4.6 k returns,
/// fewer than a 16-ring LiDAR passing at walking pace leaves (thousands per
/// plate) and several times the far case (150–300 per plate). At 1 M
/// points it got 0.6–1.5 k, close to the far case, and the open target's
/// median over 12 seeds was 3.3 mm: a sparse scene, not clutter, set the error.
const POINTS: u64 = 3_000_000;

/// A one-target local scene.
fn params(seed: u64, obstacles: ObstacleParams) -> SynthParams {
    let mut p = SynthParams {
        seed,
        points: std::env::var("CLUTTER_POINTS")
            .map_or(POINTS, |s| s.parse().expect("CLUTTER_POINTS is a count")),
        targets: 1,
        spread_m: 0.0,
        obstacles,
        ..SynthParams::default()
    };
    p.clutter.poles = 2;
    p.clutter.bushes = 1;
    p.clutter.cars = 1;
    p.clutter.wall = false;
    // A frame already roughly aligned (as `frame.init` or the second pass
    // gives): the survey position is within ~0.3 m of the target in the map.
    p.target_distance_m = [4.0, 8.0];
    p.distortion.offset_m = [0.2, -0.15, 0.05];
    p.distortion.yaw_deg = 0.3;
    // Returns beyond 40 m are of no use here: more scans for the same points.
    p.lidar.max_range_m = 40.0;
    p
}

/// A scene's map, what each point is a return from, and its truth.
struct Scene {
    map: Vec<Point>,
    labels: Vec<PointLabel>,
    truth: Truth,
}

fn generate(p: &SynthParams) -> Scene {
    let mut map = Vec::new();
    let mut labels = Vec::new();
    let truth = synth::generate_labelled(p, &mut |pts, l| {
        map.extend_from_slice(pts);
        labels.extend_from_slice(l);
        Ok(())
    })
    .unwrap();
    Scene { map, labels, truth }
}

/// The oracle's horizontal error (mm) for target `i` ([`oracle_corner`]):
/// what the locator would do if it knew which points are the plates; its
/// error over the oracle's is the cost of finding them.
fn oracle_mm(s: &Scene, i: usize) -> Option<f64> {
    let t = Vector3::from(s.truth.targets[i].map);
    let c = oracle_corner(&s.map, &s.labels, i, t)?;
    Some(1e3 * (c.x - t.x).hypot(c.y - t.y))
}

/// Tight crop and localisation of survey target `i` as the pipeline's first
/// pass does them (ground normal then +z as up; refit then plain draws).
fn locate_target(map: &[Point], truth: &Truth, i: usize) -> Result<Point, String> {
    let survey = truth.survey();
    let expected = survey.targets[i].reference();
    let loose: Vec<Point> = map
        .iter()
        .filter(|p| (p.x - expected.x).hypot(p.y - expected.y) < 5.0)
        .copied()
        .collect();
    let tight =
        tight_crop(&loose, &expected, &TightParams::default()).map_err(|e| e.to_string())?;
    let up = Vector3::from(tight.up);
    let mut ups = vec![up];
    if up != Vector3::z() {
        ups.push(Vector3::z());
    }
    locate_with(&tight.points, &ups, &Config::default())
        .map(|f| f.located.corner)
        .map_err(|e| format!("localisation failed: {e}"))
}

/// Horizontal error (mm) of target `i`, or why it was not found.
fn error_mm(map: &[Point], truth: &Truth, i: usize) -> Result<f64, String> {
    let c = locate_target(map, truth, i)?;
    let t = truth.targets[i].map;
    // Every corner, to compare two builds seed by seed.
    if std::env::var("CLUTTER_EACH").is_ok() {
        eprintln!(
            "corner of target {}: ({:+.4}, {:+.4}, {:+.4}) mm from the truth",
            i + 1,
            1e3 * (c.x - t[0]),
            1e3 * (c.y - t[1]),
            1e3 * (c.z - t[2])
        );
    }
    Ok(1e3 * (c.x - t[0]).hypot(c.y - t[1]))
}

/// One case over the seeds: per seed the error of every surveyed target.
struct Case {
    errors: Vec<f64>,
    /// The oracle's errors (`oracle_mm`), for the targets found.
    oracle: Vec<f64>,
    misses: Vec<String>,
    open: Vec<f64>,
    /// Returns from the target per seed (target 1).
    points: Vec<u64>,
}

impl Case {
    fn run(obstacles: &ObstacleParams, tweak: fn(&mut SynthParams)) -> Case {
        let mut case = Case {
            errors: Vec::new(),
            oracle: Vec::new(),
            misses: Vec::new(),
            open: Vec::new(),
            points: Vec::new(),
        };
        let seeds: Vec<u64> = match (
            std::env::var("CLUTTER_SEED"),
            std::env::var("CLUTTER_SEEDS"),
        ) {
            (Ok(s), _) => vec![s.parse().expect("CLUTTER_SEED is a seed")],
            (_, Ok(n)) => (1..=n.parse().expect("CLUTTER_SEEDS is a count")).collect(),
            _ => SEEDS.to_vec(),
        };
        for seed in seeds {
            let mut p = params(seed, obstacles.clone());
            tweak(&mut p);
            let scene = generate(&p);
            let (map, truth) = (&scene.map, &scene.truth);
            case.points.push(truth.targets[0].points);
            let mut q = p.clone();
            q.obstacles = ObstacleParams::default();
            let open = generate(&q);
            let (open_map, open_truth) = (&open.map, &open.truth);
            for i in 0..truth.targets.len() {
                match error_mm(map, truth, i) {
                    Ok(e) => {
                        // Every error, to compare two builds seed by seed.
                        if std::env::var("CLUTTER_EACH").is_ok() {
                            eprintln!("each seed {seed} target {}: {e:.4} mm", i + 1);
                        }
                        case.errors.push(e);
                        if let Some(o) = oracle_mm(&scene, i) {
                            case.oracle.push(o);
                        }
                    }
                    Err(why) => case
                        .misses
                        .push(format!("seed {seed} target {}: {why}", i + 1)),
                }
                // The same target without the obstacles (target 1's twin for a
                // second target: the same build, in the open).
                let j = i.min(open_truth.targets.len() - 1);
                if let Ok(e) = error_mm(open_map, open_truth, j) {
                    case.open.push(e);
                }
            }
        }
        case
    }
    fn found(&self) -> String {
        format!(
            "{}/{}",
            self.errors.len(),
            self.errors.len() + self.misses.len()
        )
    }
}

/// The median (the mean of the middle two of an even count).
fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::NAN, f64::max)
}

/// The far case: 30–34 m from the path, 150–300 returns per plate.
fn far(p: &mut SynthParams) {
    p.target_distance_m = [30.0, 34.0];
    p.points = 6_000_000;
    p.lidar.max_range_m = 60.0;
}

fn none(_: &mut SynthParams) {}

/// The cases of the issue.
fn cases() -> Vec<(&'static str, ObstacleParams, fn(&mut SynthParams))> {
    let o = ObstacleParams::default;
    vec![
        ("open", o(), none),
        (
            "wall 0.1 m behind",
            ObstacleParams {
                wall_behind_m: Some(0.1),
                ..o()
            },
            none,
        ),
        (
            "wall 0.3 m behind",
            ObstacleParams {
                wall_behind_m: Some(0.3),
                ..o()
            },
            none,
        ),
        (
            "wall 0.5 m behind",
            ObstacleParams {
                wall_behind_m: Some(0.5),
                ..o()
            },
            none,
        ),
        (
            "stack 0.65 m inside the L",
            ObstacleParams {
                inside_object_m: Some(0.65),
                ..o()
            },
            none,
        ),
        (
            "lower 40 % hidden",
            ObstacleParams {
                hide_lower: Some(0.4),
                ..o()
            },
            none,
        ),
        (
            "plate 2 a quarter",
            ObstacleParams {
                plate2_keep: Some(0.25),
                ..o()
            },
            none,
        ),
        (
            "grass through lower plates",
            ObstacleParams {
                grass_m: Some(0.25),
                ..o()
            },
            none,
        ),
        (
            "second target 1.5 m",
            ObstacleParams {
                second_target_m: Some(1.5),
                ..o()
            },
            none,
        ),
        ("seen from 30+ m", o(), far),
    ]
}

/// Checks one case: every target found, median ≤ 3 mm, none above 10 mm, and
/// no worse than twice the open scene's (with 1 mm of slack for a tiny open error).
fn check(name: &str) {
    let (_, o, tweak) = cases().into_iter().find(|c| c.0 == name).unwrap();
    let c = Case::run(&o, tweak);
    let (med, mx) = (median(&c.errors), max(&c.errors));
    let (omed, omx) = (median(&c.open), max(&c.open));
    eprintln!(
        "{name}: found {} median {med:.2} max {mx:.2} mm (open: median {omed:.2} max {omx:.2}); misses {:?}",
        c.found(),
        c.misses
    );
    assert!(c.misses.is_empty(), "{name}: not found: {:?}", c.misses);
    assert!(med <= 3.0, "{name}: median {med:.2} mm > 3 mm");
    assert!(mx <= 10.0, "{name}: max {mx:.2} mm > 10 mm");
    // Against the oracle (planes through the labelled plate returns): what
    // finding the plates costs. 8 seeds: every case pooled 1.06x, the
    // worst case (grass through the plates) 1.51x.
    let orc = median(&c.oracle);
    eprintln!("{name}: oracle median {orc:.2} mm, {:.2}x", med / orc);
    assert!(
        c.oracle.len() == c.errors.len() && med <= 1.75 * orc.max(1.0),
        "{name}: median {med:.2} mm, the oracle's {orc:.2} mm"
    );
    assert!(
        med <= 2.0 * omed.max(1.0) && mx <= 2.0 * omx.max(1.0),
        "{name}: median {med:.2} / max {mx:.2} mm, more than twice the open scene's {omed:.2} / {omx:.2} mm"
    );
}

#[test]
#[ignore = "prints the table of every case (slow): --ignored --nocapture table"]
fn table() {
    let only = std::env::var("CLUTTER_CASE").ok();
    println!(
        "| case | found | median mm | max mm | open median | open max | oracle median | median / oracle's | target returns |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let (mut all, mut all_oracle) = (Vec::new(), Vec::new());
    for (name, o, tweak) in cases() {
        if only
            .as_deref()
            .is_some_and(|s| !s.split('|').any(|s| name.contains(s)))
        {
            continue;
        }
        let c = Case::run(&o, tweak);
        println!(
            "| {name} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:?} |",
            c.found(),
            median(&c.errors),
            max(&c.errors),
            median(&c.open),
            max(&c.open),
            median(&c.oracle),
            median(&c.errors) / median(&c.oracle),
            c.points
        );
        for m in &c.misses {
            println!("|  ↳ {m} | | | | | | | |");
        }
        all.extend(c.errors);
        all_oracle.extend(c.oracle);
    }
    println!(
        "every case: locator median {:.2} mm, oracle median {:.2} mm ({} targets): {:.2}x",
        median(&all),
        median(&all_oracle),
        all.len(),
        median(&all) / median(&all_oracle)
    );
    let (found, n) = decoys(0..20);
    println!("decoys only: located {found} of {n} seeds");
}

/// Seeds in `seeds` of scenes whose target 1 is absent but decoys stand near
/// it: how many located something, of how many.
fn decoys(seeds: std::ops::Range<u64>) -> (usize, usize) {
    let mut located = 0;
    let n = seeds.end - seeds.start;
    for seed in seeds {
        let mut p = params(
            seed,
            ObstacleParams {
                target1_absent: true,
                decoys: 5,
                ..ObstacleParams::default()
            },
        );
        // The sparser scene: fewer returns leave the size checks more slack
        // (a sparse plate's width may fall short by 0.22 w/√n), so decoys
        // pass for targets more easily. Seeds 100–199 at 3 M points also
        // located nothing (session 8); this keeps CI's time down.
        if std::env::var("CLUTTER_POINTS").is_err() {
            p.points = 1_000_000;
        }
        let Scene { map, truth, .. } = generate(&p);
        if let Ok(c) = locate_target(&map, &truth, 0) {
            located += 1;
            let near = truth
                .clutter
                .iter()
                .min_by(|a, b| {
                    let da = (a.x - c.x).hypot(a.y - c.y);
                    let db = (b.x - c.x).hypot(b.y - c.y);
                    da.total_cmp(&db)
                })
                .map_or(String::new(), |k| k.role.clone());
            eprintln!("seed {seed}: located something at {c}, nearest obstacle: {near}");
        }
    }
    (located, n as usize)
}

#[test]
fn open() {
    check("open");
}

#[test]
fn wall_half_a_metre_behind() {
    check("wall 0.5 m behind");
}

#[test]
fn wall_a_tenth_behind() {
    check("wall 0.1 m behind");
}

#[test]
fn wall_a_third_behind() {
    check("wall 0.3 m behind");
}

#[test]
fn stack_inside_the_l() {
    check("stack 0.65 m inside the L");
}

#[test]
fn lower_plates_hidden() {
    check("lower 40 % hidden");
}

#[test]
fn one_plate_a_quarter() {
    check("plate 2 a quarter");
}

#[test]
fn grass_through_the_plates() {
    check("grass through lower plates");
}

#[test]
fn second_target_close_by() {
    check("second target 1.5 m");
}

#[test]
fn seen_only_from_afar() {
    check("seen from 30+ m");
}

/// The surveyed target is absent; a 0.4 × 0.5 m L, a 1.2 m L, a cabinet, an
/// L of 110° and a wall segment stand 0.6–2.5 m from where it should be.
/// Before issue 16's width check the small L was located in 14 of 20 seeds.
#[test]
fn decoys_are_never_located() {
    let range = match std::env::var("DECOY_SEED") {
        Ok(s) => {
            let k: u64 = s.parse().expect("DECOY_SEED is a seed");
            k..k + 1
        }
        Err(_) => 100..200,
    };
    let (located, n) = decoys(range);
    assert_eq!(located, 0, "a decoy was located in {located} of {n} seeds");
}
