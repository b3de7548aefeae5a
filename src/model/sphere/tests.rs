use super::*;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;

const R: f64 = 0.0725;

/// Points on the cap of a sphere (centre `c`, radius `r`) seen from
/// direction `view` (unit, from the centre towards the sensor), covering
/// `share` of the surface, with radial noise `sigma`.
fn cap(
    rng: &mut Pcg64,
    c: Vector3<f64>,
    r: f64,
    view: Vector3<f64>,
    share: f64,
    n: usize,
    sigma: f64,
) -> Vec<Point> {
    let cos_max = 1.0 - 2.0 * share;
    let a = view.normalize();
    let b = a
        .cross(&Vector3::z())
        .try_normalize(1e-9)
        .unwrap_or(Vector3::x());
    let d = a.cross(&b);
    let noise = Normal::new(0.0, sigma).unwrap();
    (0..n)
        .map(|_| {
            let ct: f64 = rng.random_range(cos_max..1.0);
            let st = (1.0 - ct * ct).sqrt();
            let ph: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let u = a * ct + (b * ph.cos() + d * ph.sin()) * st;
            Point::from(c + u * (r + noise.sample(rng)))
        })
        .collect()
}

/// A vertical cylinder's side seen from `view` (half of it), heights z0..z1.
fn post(
    rng: &mut Pcg64,
    (x, y): (f64, f64),
    rad: f64,
    (z0, z1): (f64, f64),
    view: Vector3<f64>,
    n: usize,
    sigma: f64,
) -> Vec<Point> {
    let noise = Normal::new(0.0, sigma).unwrap();
    let h = view.y.atan2(view.x);
    (0..n)
        .map(|_| {
            let a = h + rng.random_range(-1.4..1.4);
            let z = rng.random_range(z0..z1);
            let rr = rad + noise.sample(rng);
            Point::new(x + rr * f64::cos(a), y + rr * f64::sin(a), z)
        })
        .collect()
}

/// The pole of a sphere centred at `c`, 2 cm thick, from the ground up to
/// it: 300 points.
fn its_pole(rng: &mut Pcg64, c: Vector3<f64>, view: Vector3<f64>, sigma: f64) -> Vec<Point> {
    post(rng, (c.x, c.y), 0.02, (0.0, c.z - R), view, 300, sigma)
}

/// A flat ground patch about the origin.
fn ground(rng: &mut Pcg64, n: usize) -> Vec<Point> {
    (0..n)
        .map(|_| {
            Point::new(
                rng.random_range(-4.0..4.0),
                rng.random_range(-4.0..4.0),
                rng.random_range(-0.005..0.005),
            )
        })
        .collect()
}

fn search<'a>(points: &'a [Point], expected: Point) -> Search<'a> {
    Search {
        points,
        expected,
        others: &[],
        radius: R,
        up: Vector3::z(),
        surveyed: true,
    }
}

/// A sphere on a thin pole among a pole of the sphere's own radius, a
/// bollard with a round top, a bush and a plain sign is found, within 2 mm,
/// seen on 15 % of its surface.
#[test]
fn a_sphere_among_round_clutter_is_found() {
    let mut rng = Pcg64::seed_from_u64(7);
    let view = Vector3::new(-1.0, -0.3, 0.1);
    let c = Vector3::new(0.4, 0.3, 1.5);
    let mut pts = ground(&mut rng, 20_000);
    pts.extend(cap(&mut rng, c, R, view, 0.15, 150, 0.002));
    pts.extend(its_pole(&mut rng, c, view, 0.002));
    // A pole as thick as the sphere, a bollard with a domed top, a bush, a sign.
    pts.extend(post(
        &mut rng,
        (-1.5, 1.0),
        R,
        (0.0, 3.0),
        view,
        3000,
        0.002,
    ));
    pts.extend(post(
        &mut rng,
        (1.5, -1.5),
        R,
        (0.0, 0.9),
        view,
        1500,
        0.002,
    ));
    pts.extend(cap(
        &mut rng,
        Vector3::new(1.5, -1.5, 0.9),
        R,
        Vector3::new(-1.0, -0.3, 1.2),
        0.3,
        300,
        0.002,
    ));
    for _ in 0..1500 {
        let d = Vector3::new(
            rng.random_range(-0.4..0.4),
            rng.random_range(-0.4..0.4),
            rng.random_range(-0.4..0.4),
        );
        if d.norm() < 0.4 {
            pts.push(Point::from(Vector3::new(-1.0, -1.5, 0.6) + d));
        }
    }
    for _ in 0..3000 {
        pts.push(Point::new(
            -2.5,
            rng.random_range(-0.4..0.4),
            rng.random_range(1.0..1.8),
        ));
    }
    let (fit, near) = locate(
        &search(&pts, Point::new(0.0, 0.0, 1.4)),
        &SphereParams::default(),
    )
    .unwrap();
    let err = (fit.centre - Point::from(c)).norm();
    assert!(
        err < 0.002,
        "centre {:?} is {:.2} mm off",
        fit.centre,
        err * 1e3
    );
    assert!(fit.inliers >= 120, "{}", fit.inliers);
    assert!((fit.free_radius - R).abs() < 0.005, "{}", fit.free_radius);
    assert!(fit.cap_deg > 25.0 && fit.cap_deg < 60.0, "{}", fit.cap_deg);
    assert!(near.len() >= fit.inliers);
    let sigma = [0, 1, 2].map(|i| fit.covariance[i][i].sqrt());
    assert!(sigma.iter().all(|s| *s > 1e-4 && *s < 0.005), "{sigma:?}");
}

/// Alone, each of the clutter is refused, with what it looked like.
#[test]
fn poles_bollards_bushes_and_wrong_sizes_are_not_spheres() {
    let mut rng = Pcg64::seed_from_u64(11);
    let view = Vector3::new(-1.0, 0.2, 0.05);
    let p = SphereParams::default();
    let refused = |pts: Vec<Point>| -> String {
        match locate(&search(&pts, Point::new(0.0, 0.0, 1.0)), &p) {
            Err(SphereError::NoSphere { seen, .. }) => seen.unwrap_or_default(),
            other => panic!("found {:?}", other.map(|f| f.0.centre)),
        }
    };
    let mut pole = ground(&mut rng, 5000);
    pole.extend(post(&mut rng, (0.2, 0.1), R, (0.0, 3.0), view, 4000, 0.002));
    let why = refused(pole);
    assert!(
        why.contains("round one way only") || why.contains("post"),
        "{why}"
    );

    let mut bollard = ground(&mut rng, 5000);
    bollard.extend(post(&mut rng, (0.2, 0.1), R, (0.0, 1.0), view, 2000, 0.002));
    bollard.extend(cap(
        &mut rng,
        Vector3::new(0.2, 0.1, 1.0),
        R,
        Vector3::new(-1.0, 0.2, 1.0),
        0.3,
        400,
        0.002,
    ));
    let why = refused(bollard);
    assert!(why.contains("post or bollard"), "{why}");

    let mut bush = ground(&mut rng, 5000);
    for _ in 0..4000 {
        let d = Vector3::new(
            rng.random_range(-0.5..0.5),
            rng.random_range(-0.5..0.5),
            rng.random_range(-0.5..0.5),
        );
        if d.norm() < 0.5 {
            bush.push(Point::from(Vector3::new(0.3, 0.0, 0.8) + d));
        }
    }
    // Refused (any reason: a random ball of leaves shows several).
    refused(bush);

    // A 200 mm sphere where 145 mm was surveyed.
    let mut big = ground(&mut rng, 5000);
    big.extend(cap(
        &mut rng,
        Vector3::new(0.2, 0.1, 1.2),
        0.1,
        view,
        0.3,
        600,
        0.001,
    ));
    let why = refused(big);
    assert!(why.contains("not the 145 mm given"), "{why}");
}

/// A wall panel seen from the sensor's side (the plane `y = y0`, 0.6 m
/// square about (x, z)), with its points along the view (`-y`) noisy by
/// `sigma`, less the shadow of a ball of radius `shadow` at `c`.
fn panel(rng: &mut Pcg64, c: Vector3<f64>, y0: f64, shadow: f64, sigma: f64) -> Vec<Point> {
    let noise = Normal::new(0.0, sigma).unwrap();
    let mut pts = Vec::new();
    for i in 0..60 {
        for j in 0..60 {
            let (x, z) = (c.x - 0.3 + i as f64 * 0.01, c.z - 0.3 + j as f64 * 0.01);
            if (x - c.x).powi(2) + (z - c.z).powi(2) < shadow * shadow {
                continue;
            }
            pts.push(Point::new(x, y0 + noise.sample(rng), z));
        }
    }
    pts
}

/// A sphere a magnetic nest holds 15 mm off a wall panel is found (the
/// panel, all around it just outside its surface, is its mount: a plane
/// that does not cut it), within 3 mm at 5 mm noise and its size told
/// right; a dome of the same radius on a wall (the wall through its centre)
/// and a ball sunk halfway into one (the wall cuts it) are refused: the
/// wall is no mount of theirs.
#[test]
fn a_sphere_held_to_a_wall_is_found_a_dome_on_one_is_not() {
    let mut rng = Pcg64::seed_from_u64(5);
    let view = Vector3::new(0.1, -1.0, 0.1);
    let c = Vector3::new(0.2, 0.1, 1.3);
    let p = SphereParams::default();
    let mut wall = ground(&mut rng, 5000);
    wall.extend(cap(&mut rng, c, R, view, 0.3, 250, 0.005));
    wall.extend(panel(&mut rng, c, c.y + R + 0.015, R, 0.005));
    let (fit, _) = locate(&search(&wall, Point::new(0.0, 0.0, 1.3)), &p)
        .unwrap_or_else(|e| panic!("the sphere on a wall: {e}"));
    let err = (fit.centre - Point::from(c)).norm();
    assert!(err < 0.003, "centre {:.2} mm off", err * 1e3);
    assert!((fit.free_radius - R).abs() < 0.006, "{}", fit.free_radius);
    for (name, front) in [("a dome", 0.0), ("a ball sunk halfway", 0.5 * R)] {
        let mut pts = ground(&mut rng, 5000);
        // The half facing the sensor, its centre `front` before the wall.
        let ball = cap(&mut rng, c, R, view, 0.3, 250, 0.002);
        pts.extend(ball.into_iter().filter(|q| q.y < c.y + front));
        pts.extend(panel(
            &mut rng,
            c,
            c.y + front,
            (R * R - front * front).sqrt(),
            0.002,
        ));
        match locate(&search(&pts, Point::new(0.0, 0.0, 1.3)), &p) {
            // Refused as a post's top or as not standing alone: were the
            // wall taken for its mount, neither would refuse it.
            Err(SphereError::NoSphere { seen, .. }) => {
                let why = seen.unwrap_or_default();
                assert!(
                    why.contains("not standing alone") || why.contains("post"),
                    "{name}: {why}"
                );
            }
            other => panic!("{name} found: {:?}", other.map(|f| f.0.centre)),
        }
    }
}

/// A cylinder's side seen from `view` (the half facing it): `len` along
/// `axis` from `base`, radius `rad`, noisy by `sigma` along the view.
#[allow(clippy::too_many_arguments)]
fn cyl_side(
    rng: &mut Pcg64,
    base: Vector3<f64>,
    axis: Vector3<f64>,
    len: f64,
    rad: f64,
    view: Vector3<f64>,
    n: usize,
    sigma: f64,
) -> Vec<Point> {
    let a = axis.normalize();
    let v = (view - a * a.dot(&view)).normalize();
    let w = a.cross(&v);
    let noise = Normal::new(0.0, sigma).unwrap();
    let vv = view.normalize();
    (0..n)
        .map(|_| {
            let s: f64 = rng.random_range(-0.98..0.98);
            let t = rng.random_range(0.0..len);
            let p = base + a * t + (v * (1.0 - s * s).sqrt() + w * s) * rad;
            Point::from(p + vv * noise.sample(rng))
        })
        .collect()
}

/// A bollard of the sphere's radius with a domed top, and a pipe of it
/// with a round cap on its end, are never taken for spheres, at any map
/// noise: at 5-10 mm a tilted slab through the cylinder's band just past
/// the dome held the shell's points, the flat-mount rule took it for a
/// mount and 3 of 20 bollards were accepted (the review of 0df293e); the
/// mount must go on flat beyond the shell, as a wall does.
#[test]
fn bollards_and_capped_pipes_are_no_mounted_spheres() {
    let p = SphereParams::default();
    for sigma in [0.002, 0.005, 0.01, 0.015] {
        for seed in 0..20u64 {
            let mut rng = Pcg64::seed_from_u64(100 + seed);
            let view = Vector3::new(-1.0, 0.2, 0.15).normalize();
            let top = Vector3::new(0.2, 0.1, 1.0);
            let mut b = ground(&mut rng, 5000);
            b.extend(cyl_side(
                &mut rng,
                top - Vector3::z(),
                Vector3::z(),
                1.0,
                R,
                view,
                1500,
                sigma,
            ));
            let dome = cap(
                &mut rng,
                top,
                R,
                Vector3::new(-1.0, 0.2, 1.0),
                0.3,
                250,
                sigma,
            );
            b.extend(dome.into_iter().filter(|q| q.z >= top.z));
            let found = locate(&search(&b, Point::new(0.0, 0.0, 1.0)), &p);
            assert!(
                found.is_err(),
                "bollard, noise {sigma}, seed {seed}: {:?}",
                found.map(|f| f.0.centre)
            );
            let c = Vector3::new(0.2, 0.1, 1.3);
            let view2 = Vector3::new(-1.0, -0.6, 0.2).normalize();
            let mut pipe = ground(&mut rng, 5000);
            pipe.extend(cyl_side(
                &mut rng,
                c,
                Vector3::x(),
                1.5,
                R,
                view2,
                2500,
                sigma,
            ));
            let end = cap(&mut rng, c, R, view2, 0.3, 250, sigma);
            pipe.extend(end.into_iter().filter(|q| q.x <= c.x));
            let found = locate(&search(&pipe, Point::new(0.0, 0.0, 1.3)), &p);
            assert!(
                found.is_err(),
                "capped pipe, noise {sigma}, seed {seed}: {:?}",
                found.map(|f| f.0.centre)
            );
        }
    }
}

/// A wall 0.9 r behind a ball's centre cuts it (a ball sunk a little into
/// a wall, a knob): no mount, at any seed. (That the mount's points are
/// left out of a held sphere's surface is tested end to end:
/// `models::spheres_held_to_walls_are_located` locates 3 of 5, one 10 mm
/// off, without it.)
#[test]
fn a_wall_cutting_the_sphere_is_no_mount() {
    let p = SphereParams::default();
    let view = Vector3::new(0.1, -1.0, 0.1);
    let c = Vector3::new(0.2, 0.1, 1.3);
    for seed in 0..10u64 {
        let mut rng = Pcg64::seed_from_u64(400 + seed);
        let mut cut = ground(&mut rng, 5000);
        let f = 0.9 * R;
        let ball = cap(&mut rng, c, R, view, 0.3, 300, 0.002);
        cut.extend(ball.into_iter().filter(|q| q.y < c.y + f));
        cut.extend(panel(&mut rng, c, c.y + f, (R * R - f * f).sqrt(), 0.002));
        let found = locate(&search(&cut, Point::new(0.0, 0.0, 1.3)), &p);
        assert!(
            found.is_err(),
            "seed {seed}: a wall 0.9 r behind: {:?}",
            found.map(|f| f.0.centre)
        );
    }
}

/// The 95 % ellipsoid of the centre holds the truth 92–98 % of the time
/// over caps of 15–50 % of the surface, 30–400 points, 1–5 mm noise.
#[test]
fn the_covariance_is_calibrated_on_independent_noise() {
    let mut rng = Pcg64::seed_from_u64(3);
    let p = SphereParams {
        radius_sigma_m: 0.0,
        ..SphereParams::default()
    };
    let (mut inside, mut total) = (0, 0);
    for _ in 0..300 {
        let c = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            1.5,
        );
        let view = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-0.2..0.4),
        );
        let share = rng.random_range(0.15..0.5);
        let n = rng.random_range(30..400);
        let sigma = rng.random_range(0.001..0.005);
        let pts = cap(&mut rng, c, R, view, share, n, sigma);
        let Ok((fit, _)) = locate(&search(&pts, Point::from(c)), &p) else {
            continue;
        };
        let cov = Matrix3::from_fn(|i, j| fit.covariance[i][j]);
        let e = fit.centre.coords - c;
        let m2 = e.dot(&(cov.try_inverse().unwrap() * e));
        total += 1;
        if m2 <= 7.815 {
            inside += 1;
        }
    }
    let share = inside as f64 / total as f64;
    assert!(total >= 280, "only {total} of 300 located");
    assert!(
        (0.92..=0.98).contains(&share),
        "{inside} of {total} inside: {share:.3}"
    );
}

/// A sphere (centre `c`) scanned by a LiDAR passing by on a straight road
/// `road` metres away: stations every metre over ±`half` m along x, each
/// casting rays on an angular grid (a random phase per station), the first
/// hit along each ray returned with Gaussian noise `range_sigma` along it,
/// as a spinning LiDAR's range noise is.
fn passed_by(
    rng: &mut Pcg64,
    c: Vector3<f64>,
    road: f64,
    half: f64,
    range_sigma: f64,
) -> Vec<Point> {
    passed_by_r(rng, c, R, road, half, range_sigma)
}

/// [`passed_by`] for a sphere of radius `radius`.
fn passed_by_r(
    rng: &mut Pcg64,
    c: Vector3<f64>,
    radius: f64,
    road: f64,
    half: f64,
    range_sigma: f64,
) -> Vec<Point> {
    let noise = Normal::new(0.0, range_sigma).unwrap();
    let (d_az, d_el) = (0.004, 0.01);
    let mut out = Vec::new();
    let mut x = -half;
    while x <= half {
        let s = Vector3::new(c.x + x, c.y - road, c.z + 0.3);
        let to = c - s;
        let (az0, el0) = (to.y.atan2(to.x), (to.z / to.norm()).asin());
        let reach = (radius / to.norm()).asin() + 0.02;
        let (pa, pe): (f64, f64) = (rng.random_range(0.0..d_az), rng.random_range(0.0..d_el));
        let mut el = el0 - reach + pe;
        while el < el0 + reach {
            let mut az = az0 - reach + pa;
            while az < az0 + reach {
                let d = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
                let oc = s - c;
                let b = d.dot(&oc);
                let disc = b * b - (oc.norm_squared() - radius * radius);
                if disc > 0.0 {
                    let t = -b - disc.sqrt() + noise.sample(rng);
                    out.push(Point::from(s + d * t));
                }
                az += d_az;
            }
            el += d_el;
        }
        x += 1.0;
    }
    out
}

/// Range noise of 2 cm on a 145 mm sphere (s/r ≈ 0.28, a SLAM map's noise):
/// least squares alone put the centre ~3 mm towards the side seen and its
/// 95 % ellipsoid held ~70 % of the truths (issue 33). With the noise's
/// second-order pull taken off and its scatter carried, the error along the
/// view averages about nothing and the ellipsoid holds about 95 %.
#[test]
fn range_noise_on_a_small_sphere_neither_pulls_nor_overstates() {
    let mut rng = Pcg64::seed_from_u64(11);
    let p = SphereParams::default();
    let (mut inside, mut along, mut total) = (0, Vec::new(), 0);
    for _ in 0..240 {
        let c = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            1.3,
        );
        let road = rng.random_range(5.0..12.0);
        let half = rng.random_range(5.0..15.0);
        let pts = passed_by(&mut rng, c, road, half, 0.02);
        let Ok((fit, _)) = locate(&search(&pts, Point::from(c)), &p) else {
            continue;
        };
        let cov = Matrix3::from_fn(|i, j| fit.covariance[i][j]);
        let e = fit.centre.coords - c;
        total += 1;
        inside += usize::from(e.dot(&(cov.try_inverse().unwrap() * e)) <= 7.815);
        along.push(e.dot(&Vector3::from(fit.seen_from)));
    }
    // The rest are refused, most as too little seen to tell their size.
    assert!(total >= 120, "only {total} of 240 located");
    let n = along.len() as f64;
    let mean = along.iter().sum::<f64>() / n;
    let sd = (along.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!(
        mean.abs() < 3.0 * sd / n.sqrt() + 0.0005,
        "mean error along the view {:.2} mm (sd {:.2} mm, {n} spheres)",
        mean * 1e3,
        sd * 1e3
    );
    let share = inside as f64 / total as f64;
    assert!(
        (0.9..=0.99).contains(&share),
        "{inside} of {total} inside: {share:.3}"
    );
}

/// A sphere scanned from a road 5-8 m away with 2 cm of range noise, on a
/// post of radius `post_r` laid in beam rings 8 cm apart (a spinning LiDAR
/// driving past), the first 13 cm below the centre, each ring as many
/// returns as a third of the sphere's; and the sphere alone.
fn on_a_ringed_post(seed: u64, post_r: f64) -> (Vec<Point>, Vec<Point>, Vector3<f64>) {
    let mut rng = Pcg64::seed_from_u64(100 + seed);
    let c = Vector3::new(0.0, 0.0, 1.3);
    let road = rng.random_range(5.0..8.0);
    let half = rng.random_range(5.0..10.0);
    let sphere = passed_by(&mut rng, c, road, half, 0.02);
    let mut with = sphere.clone();
    for k in 0..15 {
        let z = c.z - 0.13 - 0.08 * k as f64;
        with.extend(post(
            &mut rng,
            (c.x, c.y),
            post_r,
            (z - 0.005, z + 0.005),
            Vector3::new(0.0, -1.0, 0.0),
            sphere.len() / 3,
            0.02,
        ));
    }
    with.extend(ground(&mut rng, 2000));
    (sphere, with, c)
}

/// A survey sphere stands on a thin pole, and a SLAM map's range noise
/// (2 cm, along the rays: across the pole) scatters the pole's returns
/// past the pole's own radius. A ring just below the sphere, within its
/// footprint, is its mount, not a larger object going on beyond its
/// surface: the sphere is located as often with its pole as without
/// (issue 33: synth's 20 M-point mixed scenes lost one sphere in 18 this
/// way, 8 of the 11 points "beyond" it the pole's, from one ring of 36).
/// A ball on a post 0.7 of its radius thick (a finial, a ball-topped
/// bollard) is no survey sphere, noise or not.
#[test]
fn a_noisy_pole_under_a_sphere_is_its_mount_a_thick_post_is_not() {
    let p = SphereParams::default();
    let (mut alone, mut on_pole, mut refused_pole) = (0, 0, Vec::new());
    let mut on_post = 0;
    for seed in 0..40u64 {
        let (sphere, with, c) = on_a_ringed_post(seed, 0.015);
        alone += usize::from(locate(&search(&sphere, Point::from(c)), &p).is_ok());
        match locate(&search(&with, Point::from(c)), &p) {
            Ok(_) => on_pole += 1,
            Err(e) => refused_pole.push(e.to_string()),
        }
        let (_, with, c) = on_a_ringed_post(seed, 0.7 * R);
        on_post += usize::from(locate(&search(&with, Point::from(c)), &p).is_ok());
    }
    let standing = refused_pole
        .iter()
        .filter(|e| e.contains("not standing alone"))
        .count();
    assert!(
        standing <= 1 && on_pole + 3 >= alone,
        "{on_pole} located on a pole, {alone} alone; {standing} refused as not standing alone: {refused_pole:?}"
    );
    assert!(
        on_post <= 2,
        "{on_post} of 40 balls on a thick post taken for spheres"
    );
}

/// A sphere seen too little to be taken, with a bollard's round top 3 m
/// off holding far more points: the reason names the sphere (the candidate
/// nearest where it should be), not the bollard.
#[test]
fn the_reason_names_the_refused_candidate_nearest_the_expected_place() {
    let mut rng = Pcg64::seed_from_u64(5);
    let view = Vector3::new(-1.0, 0.2, 0.05);
    let mut pts = ground(&mut rng, 5000);
    pts.extend(cap(
        &mut rng,
        Vector3::new(0.1, 0.05, 1.0),
        R,
        view,
        0.3,
        24,
        0.001,
    ));
    pts.extend(post(&mut rng, (3.0, 0.5), R, (0.0, 1.0), view, 2000, 0.002));
    pts.extend(cap(
        &mut rng,
        Vector3::new(3.0, 0.5, 1.0),
        R,
        Vector3::new(-1.0, 0.2, 1.0),
        0.3,
        400,
        0.002,
    ));
    let p = SphereParams::default();
    match locate(&search(&pts, Point::new(0.0, 0.0, 1.3)), &p) {
        Err(SphereError::NoSphere {
            seen: Some(why), ..
        }) => {
            assert!(
                why.contains("fewer points than a sphere needs (30)"),
                "{why}"
            );
            // Horizontal, as searched: the 0.3 m of height is not in it.
            assert!(why.contains("0.11 m from the expected position"), "{why}");
        }
        other => panic!("{other:?}"),
    }
}

/// A survey that gives the radius where the diameter belongs: the sphere
/// is not taken (it is not of that size), and the reason says which size
/// stands there.
#[test]
fn a_sphere_surveyed_at_half_its_size_is_named_with_its_size() {
    let mut rng = Pcg64::seed_from_u64(9);
    let view = Vector3::new(-1.0, 0.2, 0.05);
    let mut pts = ground(&mut rng, 5000);
    pts.extend(cap(
        &mut rng,
        Vector3::new(0.1, 0.05, 1.0),
        R,
        view,
        0.3,
        300,
        0.002,
    ));
    pts.extend(post(
        &mut rng,
        (0.1, 0.05),
        0.01,
        (0.0, 1.0 - R),
        view,
        100,
        0.002,
    ));
    let s = Search {
        radius: 0.5 * R,
        ..search(&pts, Point::new(0.0, 0.0, 1.0))
    };
    match locate(&s, &SphereParams::default()) {
        Err(SphereError::NoSphere {
            seen: Some(why), ..
        }) => {
            assert!(why.contains("a sphere of 145 mm stands 0.11 m"), "{why}");
            assert!(
                why.contains("size given (72 mm: the survey's `size`"),
                "{why}"
            );
        }
        other => panic!("{other:?}"),
    }
}

/// A survey's word that a sphere of this size stands here lets a size told
/// to ±r/5 suffice; map-wide detection, with nothing but the points, asks
/// ±r/10. Spheres passed by 9-15 m away with 2 cm of range noise (tens of
/// returns): most are too few to tell their size to r/10 and are refused
/// map-wide, found where surveyed, and what is found there stays near the
/// truth and inside its ellipsoid as often as its 95 % says.
#[test]
fn a_surveyed_sphere_needs_its_size_told_less_closely_than_a_detected_one() {
    let mut rng = Pcg64::seed_from_u64(23);
    let p = SphereParams::default();
    let (mut surveyed, mut detected, mut inside, mut worst) = (0, 0, 0, 0.0f64);
    let mut too_little = 0;
    let n = 60;
    for _ in 0..n {
        let c = Vector3::new(0.0, 0.0, 1.3);
        let road = rng.random_range(9.0..15.0);
        let half = rng.random_range(8.0..15.0);
        let pts = passed_by(&mut rng, c, road, half, 0.02);
        let mut s = search(&pts, Point::from(c));
        if let Ok((fit, _)) = locate(&s, &p) {
            surveyed += 1;
            let cov = Matrix3::from_fn(|i, j| fit.covariance[i][j]);
            let e = fit.centre.coords - c;
            inside += usize::from(e.dot(&(cov.try_inverse().unwrap() * e)) <= 7.815);
            worst = worst.max(e.norm());
        }
        s.surveyed = false;
        match locate(&s, &p) {
            Ok(_) => detected += 1,
            Err(SphereError::NoSphere { seen: Some(w), .. }) => {
                too_little += usize::from(w.contains("too little of it seen to tell its size"));
            }
            Err(_) => {}
        }
    }
    assert!(
        detected <= surveyed,
        "{detected} detected, {surveyed} surveyed"
    );
    // Measured: 56 found surveyed, 18 detected, 38 refused map-wide as too
    // little seen, 53 of 56 inside, the worst 15.8 mm off.
    assert!(
        surveyed >= detected + n / 3,
        "{surveyed} surveyed against {detected} detected of {n}"
    );
    assert!(
        too_little >= n / 3,
        "{too_little} refused map-wide as too little seen"
    );
    assert!(worst < 0.02, "worst {:.1} mm", worst * 1e3);
    let share = inside as f64 / surveyed as f64;
    assert!(
        (0.9..=1.0).contains(&share),
        "{inside} of {surveyed} inside"
    );
}

/// A 200 mm sphere where a 145 mm one is surveyed (the other common size),
/// passed by 15-24 m away at 2 cm of range noise (tens of points): its
/// centre, fitted with the surveyed radius, would be off by the radii's
/// difference along the view, so it is never taken. Its size told only to
/// the ±r/5 a surveyed sphere is allowed, 3 of these 60 were, up to 46 mm
/// off, until the sizes a survey mistakes were fitted against it
/// (`fits_as_well`).
#[test]
fn a_sphere_of_the_other_common_size_is_not_taken_where_one_is_surveyed() {
    let mut rng = Pcg64::seed_from_u64(29);
    let p = SphereParams::default();
    let (mut taken, mut worst) = (0, 0.0f64);
    for _ in 0..60 {
        let c = Vector3::new(0.0, 0.0, 1.3);
        let road = rng.random_range(15.0..24.0);
        let half = rng.random_range(8.0..15.0);
        let pts = passed_by_r(&mut rng, c, 0.1, road, half, 0.02);
        if let Ok((fit, _)) = locate(&search(&pts, Point::from(c)), &p) {
            taken += 1;
            worst = worst.max((fit.centre.coords - c).norm());
        }
    }
    assert_eq!(
        taken,
        0,
        "{taken} of 60 taken, the worst {:.1} mm off",
        worst * 1e3
    );
}

/// The reverse: a 145 mm sphere on its 15 mm pole where a 200 mm one is
/// surveyed, passed by 9-24 m away at 2 cm of range noise. Fitted at the
/// surveyed radius its centre would be 27.5 mm off along the view; never
/// taken. (A review found 2 of 480 such spheres taken, 36 and 46 mm off,
/// when the given size had only to fit no worse than the other.)
#[test]
fn a_smaller_sphere_on_its_pole_is_not_taken_for_the_surveyed_larger_one() {
    let mut rng = Pcg64::seed_from_u64(31);
    let p = SphereParams::default();
    let (mut taken, mut worst) = (0, 0.0f64);
    for _ in 0..160 {
        let c = Vector3::new(0.0, 0.0, 1.3);
        let road = rng.random_range(9.0..24.0);
        let half = rng.random_range(8.0..15.0);
        let mut pts = passed_by_r(&mut rng, c, R, road, half, 0.02);
        let view = Vector3::new(0.0, -1.0, 0.0);
        pts.extend(post(
            &mut rng,
            (c.x, c.y),
            0.0075,
            (0.0, c.z - R),
            view,
            200,
            0.02,
        ));
        pts.extend(ground(&mut rng, 3000));
        let s = Search {
            radius: 0.1,
            ..search(&pts, Point::from(c))
        };
        if let Ok((fit, _)) = locate(&s, &p) {
            taken += 1;
            worst = worst.max((fit.centre.coords - c).norm());
        }
    }
    assert_eq!(
        taken,
        0,
        "{taken} of 160 taken, the worst {:.1} mm off",
        worst * 1e3
    );
}

/// A crop denser than `max_points` is searched as a sample, but the sphere
/// found is fitted on all its points: on a ground of 120 k points sampled
/// to 40 k, a sphere of 400 points keeps them all (about 130 sampled), and
/// its centre is as close as a fit on all of them gives. (A sample that
/// leaves too few to judge the sphere by still refuses it: the search is
/// the sample's.)
#[test]
fn a_sphere_in_a_dense_crop_is_fitted_on_all_its_points() {
    let mut rng = Pcg64::seed_from_u64(11);
    let view = Vector3::new(-1.0, -0.2, 0.2);
    let c = Vector3::new(0.3, -0.2, 1.5);
    let mut pts = ground(&mut rng, 120_000);
    let sphere = cap(&mut rng, c, R, view, 0.3, 400, 0.006);
    pts.extend(sphere.iter().copied());
    pts.extend(its_pole(&mut rng, c, view, 0.006));
    let p = SphereParams {
        max_points: 40_000,
        ..SphereParams::default()
    };
    let (fit, near) = locate(&search(&pts, Point::new(0.0, 0.0, 1.4)), &p).unwrap();
    assert!(fit.inliers >= 380, "{} of 400 points fitted", fit.inliers);
    assert!(near.len() >= fit.inliers);
    let all: Vec<Vector3<f64>> = sphere.iter().map(|q| q.coords).collect();
    let oracle = known_radius_fit(&all, c, R, 10);
    let err = (fit.centre.coords - c).norm();
    assert!(
        err < (oracle - c).norm() + 0.0015,
        "{:.2} mm off, a fit on all the sphere's points {:.2} mm",
        err * 1e3,
        (oracle - c).norm() * 1e3
    );
}
