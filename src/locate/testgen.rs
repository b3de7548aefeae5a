//! Synthetic L-targets with known corners, for tests and benchmarks.
//!
//! A target in its own frame: plate A in the plane y = 0 (x, z ∈ [0, 0.6]),
//! plate B in x = 0 (y, z ∈ [0, 0.6]), both a grill mesh (5 cm pitch, 3.5 cm
//! square holes: about half open, with a solid 1.5 cm rim); a pole of radius
//! 2 cm below the corner down to the ground at z = -1; an antenna (mast and a
//! disc) on top of the corner edge. Points come from ray casting out of 1–3
//! LiDAR positions, with rays uniform in azimuth/elevation (so faces towards a
//! near sensor are dense and far ones sparse, with occlusion and see-through
//! holes), then Gaussian noise and uniform outliers. Not part of the stable API.

use crate::Point;
use nalgebra::{Rotation3, Vector3};
use rand::Rng;
use rand_distr::{Distribution, Normal};

const SIZE: f64 = 0.6;
const PITCH: f64 = 0.05;
const HOLE: f64 = 0.035;
const RIM: f64 = 0.015;
const POLE_R: f64 = 0.02;
const POLE_C: (f64, f64) = (-0.025, -0.025);
const GROUND: f64 = -1.0;
const BOX_LO: Vector3<f64> = Vector3::new(-0.1, -0.1, GROUND);
const BOX_HI: Vector3<f64> = Vector3::new(0.65, 0.65, 0.76);

/// What to generate.
#[derive(Debug, Clone)]
pub struct Spec {
    /// World position of the corner's foot (target frame origin).
    pub origin: Vector3<f64>,
    /// Rotation of the target about its vertical, radians.
    pub heading: f64,
    /// Tilt of the target's vertical away from +z (radians) and the azimuth of that tilt.
    pub tilt: (f64, f64),
    /// Gaussian noise per axis, metres.
    pub noise: f64,
    /// Sensor positions in the target frame.
    pub viewpoints: Vec<Vector3<f64>>,
    /// Target hits to collect (before outliers).
    pub points: usize,
    /// Outliers as a fraction of the final cloud.
    pub outlier_fraction: f64,
    /// Omit plate B (a crop that shows one plate only).
    pub one_plate: bool,
}

/// A generated crop and its truth.
#[derive(Debug, Clone)]
pub struct Target {
    /// The crop.
    pub points: Vec<Point>,
    /// True corner: the planes' intersection at the mean height of the noise-free plate hits.
    pub corner: Point,
    /// The target's vertical.
    pub up: Vector3<f64>,
}

/// A random sensor position in the target frame: 3–12 m away, 1.8 m above the
/// ground; the first one looks at the L roughly along its diagonal (so both
/// plates are in view), the others anywhere.
pub fn viewpoint<R: Rng>(rng: &mut R, first: bool) -> Vector3<f64> {
    let az = if first {
        let side = if rng.random::<bool>() { 45f64 } else { 225.0 };
        (side + rng.random_range(-30.0..30.0)).to_radians()
    } else {
        rng.random_range(0.0..std::f64::consts::TAU)
    };
    let d = rng.random_range(3.0..12.0);
    Vector3::new(d * az.cos(), d * az.sin(), GROUND + 1.8)
}

/// A random target as the tests use it: 1–3 cm noise, 1–3 viewpoints, ~1,000
/// points, 5 % outliers, random heading, and with `utm` a UTM-sized position.
pub fn random_spec<R: Rng>(rng: &mut R, utm: bool) -> Spec {
    let origin = if utm {
        Vector3::new(350_000.0, 4_150_000.0, 50.0)
            + Vector3::new(
                rng.random_range(-5e3..5e3),
                rng.random_range(-5e3..5e3),
                rng.random_range(-20.0..20.0),
            )
    } else {
        Vector3::new(
            rng.random_range(-50.0..50.0),
            rng.random_range(-50.0..50.0),
            rng.random_range(-2.0..2.0),
        )
    };
    let nv = rng.random_range(1..=3);
    Spec {
        origin,
        heading: rng.random_range(0.0..std::f64::consts::TAU),
        tilt: (0.0, 0.0),
        noise: rng.random_range(0.01..0.03),
        viewpoints: (0..nv).map(|i| viewpoint(rng, i == 0)).collect(),
        points: rng.random_range(800..1300),
        outlier_fraction: 0.05,
        one_plate: false,
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Hit {
    Plate,
    Other,
}

fn solid(u: f64, v: f64) -> bool {
    if !(0.0..=SIZE).contains(&u) || !(0.0..=SIZE).contains(&v) {
        return false;
    }
    let rim = u < RIM || v < RIM || u > SIZE - RIM || v > SIZE - RIM;
    rim || (u - RIM).rem_euclid(PITCH) >= HOLE || (v - RIM).rem_euclid(PITCH) >= HOLE
}

fn cylinder(
    o: &Vector3<f64>,
    d: &Vector3<f64>,
    c: (f64, f64),
    r: f64,
    z0: f64,
    z1: f64,
) -> Option<f64> {
    let (ox, oy) = (o.x - c.0, o.y - c.1);
    let a = d.x * d.x + d.y * d.y;
    let b = 2.0 * (ox * d.x + oy * d.y);
    let cc = ox * ox + oy * oy - r * r;
    let disc = b * b - 4.0 * a * cc;
    if a <= 0.0 || disc < 0.0 {
        return None;
    }
    let t = (-b - disc.sqrt()) / (2.0 * a);
    let z = o.z + t * d.z;
    (t > 0.0 && z >= z0 && z <= z1).then_some(t)
}

fn cast(o: &Vector3<f64>, d: &Vector3<f64>, one_plate: bool) -> Option<(f64, Hit)> {
    let mut best: Option<(f64, Hit)> = None;
    let mut take = |t: f64, h: Hit| {
        if best.is_none_or(|(bt, _)| t < bt) {
            best = Some((t, h));
        }
    };
    if d.y.abs() > 1e-12 {
        let t = -o.y / d.y;
        let p = o + d * t;
        if t > 0.0 && solid(p.x, p.z) {
            take(t, Hit::Plate);
        }
    }
    if !one_plate && d.x.abs() > 1e-12 {
        let t = -o.x / d.x;
        let p = o + d * t;
        if t > 0.0 && solid(p.y, p.z) {
            take(t, Hit::Plate);
        }
    }
    if let Some(t) = cylinder(o, d, POLE_C, POLE_R, GROUND, 0.0) {
        take(t, Hit::Other);
    }
    if let Some(t) = cylinder(o, d, (0.0, 0.0), 0.01, SIZE, 0.68) {
        take(t, Hit::Other);
    }
    if let Some(t) = cylinder(o, d, (0.0, 0.0), 0.08, 0.68, 0.75) {
        take(t, Hit::Other);
    }
    best
}

/// Generates the crop described by `spec`.
pub fn generate<R: Rng>(rng: &mut R, spec: &Spec) -> Target {
    // Angular window of the target's box from each sensor.
    let windows: Vec<(f64, f64, f64, f64, f64)> = spec
        .viewpoints
        .iter()
        .map(|o| {
            let (mut a0, mut a1, mut e0, mut e1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
            let centre_az = ((BOX_LO + BOX_HI) / 2.0 - o)
                .y
                .atan2(((BOX_LO + BOX_HI) / 2.0 - o).x);
            for i in 0..8 {
                let c = Vector3::new(
                    if i & 1 == 0 { BOX_LO.x } else { BOX_HI.x },
                    if i & 2 == 0 { BOX_LO.y } else { BOX_HI.y },
                    if i & 4 == 0 { BOX_LO.z } else { BOX_HI.z },
                );
                let v = c - o;
                let az = centre_az
                    + (v.y.atan2(v.x) - centre_az + std::f64::consts::PI)
                        .rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
                let el = v.z.atan2((v.x * v.x + v.y * v.y).sqrt());
                (a0, a1, e0, e1) = (a0.min(az), a1.max(az), e0.min(el), e1.max(el));
            }
            (a0, a1, e0, e1, (a1 - a0) * (e1 - e0))
        })
        .collect();
    let total_area: f64 = windows.iter().map(|w| w.4).sum();
    let mut local = Vec::with_capacity(spec.points);
    let mut plate_z = (0.0, 0usize);
    let mut rays = 0usize;
    while local.len() < spec.points && rays < spec.points * 200 {
        rays += 1;
        let mut pick = rng.random::<f64>() * total_area;
        let mut v = 0;
        while v + 1 < windows.len() && pick >= windows[v].4 {
            pick -= windows[v].4;
            v += 1;
        }
        let (a0, a1, e0, e1, _) = windows[v];
        let (az, el) = (rng.random_range(a0..a1), rng.random_range(e0..e1));
        let d = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
        let o = spec.viewpoints[v];
        if let Some((t, hit)) = cast(&o, &d, spec.one_plate) {
            let p = o + d * t;
            if hit == Hit::Plate {
                plate_z.0 += p.z;
                plate_z.1 += 1;
            }
            local.push(p);
        }
    }
    let normal = Normal::new(0.0, spec.noise).expect("noise is a finite standard deviation");
    for p in &mut local {
        *p += Vector3::new(normal.sample(rng), normal.sample(rng), normal.sample(rng));
    }
    let n_out = (local.len() as f64 * spec.outlier_fraction / (1.0 - spec.outlier_fraction)).round()
        as usize;
    let (lo, hi) = (BOX_LO - Vector3::repeat(0.3), BOX_HI + Vector3::repeat(0.3));
    for _ in 0..n_out {
        local.push(Vector3::new(
            rng.random_range(lo.x..hi.x),
            rng.random_range(lo.y..hi.y),
            rng.random_range(lo.z..hi.z),
        ));
    }
    let (tilt, tilt_az) = spec.tilt;
    let rot = Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(tilt_az.cos(), tilt_az.sin(), 0.0)),
        tilt,
    ) * Rotation3::from_axis_angle(&Vector3::z_axis(), spec.heading);
    let zc = if plate_z.1 > 0 {
        plate_z.0 / plate_z.1 as f64
    } else {
        SIZE / 2.0
    };
    Target {
        points: local
            .iter()
            .map(|p| Point::from(spec.origin + rot * p))
            .collect(),
        corner: Point::from(spec.origin + rot * Vector3::new(0.0, 0.0, zc)),
        up: rot * Vector3::z(),
    }
}
