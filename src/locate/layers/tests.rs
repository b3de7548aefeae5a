use super::*;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

fn values(seps: &[(f64, usize)], sigma: f64, seed: u64) -> Vec<f64> {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma).unwrap();
    let mut v: Vec<f64> = seps
        .iter()
        .flat_map(|&(at, k)| (0..k).map(move |_| at).collect::<Vec<_>>())
        .map(|at| at + noise.sample(&mut rng))
        .collect();
    v.sort_unstable_by(f64::total_cmp);
    v
}

/// An L of two 0.6 m plates (corner at the origin, plate 1 along +x,
/// plate 2 along +y), points every 1.5 cm with 12 mm of noise along
/// each plate's normal, and a copy `shift` away when given.
fn l_target(shift: Option<Vector3<f64>>, seed: u64) -> Vec<Point> {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.012).unwrap();
    let mut pts = Vec::new();
    let copies = [Some(Vector3::zeros()), shift];
    for s in copies.iter().flatten() {
        for i in 0..40 {
            for j in 0..40 {
                let (a, z) = (i as f64 * 0.015, j as f64 * 0.015 - 0.3);
                pts.push(Point::new(a, noise.sample(&mut rng), z) + s);
                pts.push(Point::new(noise.sample(&mut rng), a, z) + s);
            }
        }
    }
    pts
}

/// `doubled` of the map `loose` about the target located in `tight`
/// (here always the single target: the locator's gates may refuse a
/// blend outright, which is not what this checks).
fn check(loose: &[Point], tight: &[Point]) -> Option<Doubled> {
    let l = crate::locate::locate(tight, None, &crate::locate::LocateParams::default()).unwrap();
    layering(loose, &l, &Vector3::z(), 0.6, 0.6)?.doubled(Some(0.012))
}

/// A copy 6 cm off is two layers on plate 2 (and 3 cm along plate 1's
/// normal, within its noise), the copies named 6 cm apart; one plate is
/// one layer; a wall 10 cm behind plate 1, seen through it and going
/// on past its edge, is not a copy.
#[test]
fn a_copy_is_two_layers_a_wall_behind_is_not() {
    for seed in 0..3 {
        let one = l_target(None, seed);
        assert_eq!(check(&one, &one), None, "seed {seed}: one target");
        let two = l_target(Some(Vector3::new(0.06, 0.03, 0.0)), seed);
        let d = check(&two, &one).expect("a copy 6 cm off");
        assert!(d.plates[1].doubled, "{d:?}");
        let apart = d.plates[1].offsets[1] - d.plates[1].offsets[0];
        assert!(
            (apart - 0.06).abs() < 0.01,
            "plate 2's layers {apart:.3} m apart"
        );
        // The copies as far as the map parts them: along plate 2's normal.
        assert!(d.separation > 0.05 && d.separation < 0.07, "{d:?}");
        let mut wall = one.clone();
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed + 100);
        let noise = Normal::new(0.0, 0.012).unwrap();
        for i in 0..150 {
            for j in 0..80 {
                let (x, z) = (i as f64 * 0.015 - 0.6, j as f64 * 0.015 - 0.6);
                wall.push(Point::new(x, -0.1 + noise.sample(&mut rng), z));
            }
        }
        assert_eq!(check(&wall, &one), None, "seed {seed}: a wall behind");
        // A wall 0.3 m inside the L along plate 1 crosses plate 2's
        // middle at one distance from the corner.
        let mut inside = one.clone();
        for i in 0..150 {
            for j in 0..80 {
                let (x, z) = (0.1 + i as f64 * 0.015, j as f64 * 0.015 - 0.6);
                inside.push(Point::new(x, 0.3 + noise.sample(&mut rng), z));
            }
        }
        assert_eq!(check(&inside, &one), None, "seed {seed}: a wall inside");
        // Foliage through the lower plates: a volume on both sides.
        let mut bush = one.clone();
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed + 200);
        for _ in 0..3000 {
            let (x, y, z): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
            bush.push(Point::new(x * 1.6 - 0.5, 0.05 + 0.15 * y, z * 0.4 - 0.3));
        }
        assert_eq!(check(&bush, &one), None, "seed {seed}: foliage");
    }
}

/// The stated limit is where copies start to be seen: a copy 0.6 times
/// it away along plate 1's normal is hardly ever two layers, one 1.4
/// times it away nearly always (12 mm plates: a 30 mm limit).
#[test]
fn the_stated_limit_is_where_copies_start_to_be_seen() {
    let limit = DoublingLimit::of(0.012).resolved_from_m;
    assert!((limit - 0.03).abs() < 1e-12, "{limit}");
    let seen = |k: f64| {
        (0..6)
            .filter(|&seed| {
                let one = l_target(None, seed);
                let two = l_target(Some(Vector3::new(0.0, k * limit, 0.0)), seed);
                check(&two, &one).is_some()
            })
            .count()
    };
    assert!(
        seen(0.6) <= 1,
        "{} of 6 seen at 0.6 times the limit",
        seen(0.6)
    );
    assert!(
        seen(1.4) >= 5,
        "{} of 6 seen at 1.4 times the limit",
        seen(1.4)
    );
}

/// One layer's best two-component fit leaves its halves within 2.5 σ;
/// two layers 4 σ apart are found at their offsets.
#[test]
fn two_layers_stand_apart_one_does_not() {
    for seed in 0..20 {
        let one = values(&[(0.0, 400)], 0.015, seed);
        let m = two_layers(&one).unwrap();
        assert!(
            m.means[1] - m.means[0] < MIN_SEPARATION_SIGMAS * m.sigma,
            "seed {seed}: one layer split {:.4} apart at σ {:.4}",
            m.means[1] - m.means[0],
            m.sigma
        );
        let two = values(&[(-0.03, 250), (0.035, 150)], 0.015, seed);
        let m = two_layers(&two).unwrap();
        assert!((m.means[0] + 0.03).abs() < 0.006, "{:?}", m.means);
        assert!((m.means[1] - 0.035).abs() < 0.008, "{:?}", m.means);
        assert!(m.means[1] - m.means[0] > MIN_SEPARATION_SIGMAS * m.sigma);
        assert!((m.counts[1] as f64 - 150.0).abs() < 30.0, "{:?}", m.counts);
    }
}

/// A sparse single layer that the mixture splits past 2.5 of its halves'
/// σ (about 1 % of 132-point layers seen face on, 17 mm thick) is not two
/// layers: a sparse plate's must stand 2.8 σ apart; two real layers of as
/// few points, 5 σ apart, still are.
#[test]
fn a_sparse_layer_split_by_chance_is_one_layer() {
    let (mut past_dense, mut past_sparse) = (0, 0);
    for seed in 0..1500 {
        let one = values(&[(0.0, 132)], 0.017, seed);
        let Some(m) = two_layers(&one) else { continue };
        past_dense += usize::from(stands_apart_by(&m, one.len(), MIN_SEPARATION_SIGMAS));
        past_sparse += usize::from(stands_apart(&m, one.len()));
    }
    assert!(
        past_dense >= 5,
        "only {past_dense} of 1500 split past 2.5 σ"
    );
    assert!(
        past_sparse <= 2,
        "{past_sparse} of 1500 single layers taken for two"
    );
    for seed in 0..10 {
        let two = values(&[(-0.025, 80), (0.025, 52)], 0.01, seed);
        let m = two_layers(&two).unwrap();
        assert!(stands_apart(&m, two.len()), "seed {seed}: {:?}", m.means);
    }
}
