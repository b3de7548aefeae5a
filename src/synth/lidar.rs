//! The LiDAR and the road it is driven along.
//!
//! Spinning (the default): one scan is a full revolution, `ncols` azimuth
//! columns of `beams` rays each, emitted column by column as a real sensor
//! does. The sensor moves during the revolution (each column is cast from
//! where the vehicle is at that instant), which is what a SLAM map with
//! perfect de-skewing contains.
//!
//! Rosette: a forward-looking Risley-prism sensor (Livox-like): two wedge
//! prisms turning in opposite directions at incommensurate rates deflect one
//! beam along a rose curve that never repeats, densest at the centre of a
//! round field of view `fov_deg` wide. One scan is `columns × beams` rays
//! (360/`az_step_deg` × `beams`: set them for the sensor's point rate) over
//! 1/`rate_hz` seconds; with `sway_deg`, the boresight wobbles in yaw and
//! pitch as a hand-held sensor does.

use super::geometry::{Hit, Ray, World, splitmix, unit_from};
use crate::Point;
use nalgebra::Vector3;
use std::f64::consts::TAU;

/// The sensor model.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarParams {
    /// Number of beams (rings), evenly spread between the two vertical angles.
    pub beams: u32,
    /// Lowest beam elevation, degrees.
    pub vmin_deg: f64,
    /// Highest beam elevation, degrees.
    pub vmax_deg: f64,
    /// Azimuth step, degrees (0.2° → 1800 columns).
    pub az_step_deg: f64,
    /// Revolutions per second.
    pub rate_hz: f64,
    /// Gaussian range noise, 1σ, metres.
    pub range_noise_m: f64,
    /// Returns beyond this range are lost, metres.
    pub max_range_m: f64,
    /// Returns closer than this are dropped (the vehicle itself), metres.
    pub min_range_m: f64,
    /// Sensor height above the ground under the vehicle, metres.
    pub height_m: f64,
    /// Vehicle speed, m/s (motion within a revolution).
    pub speed_mps: f64,
    /// How the rays sweep the scene.
    pub pattern: ScanPattern,
    /// Rosette: full width of the round field of view around the heading, degrees.
    pub fov_deg: f64,
    /// Rosette: amplitude of a hand-held sensor's wobble in yaw and pitch, degrees.
    pub sway_deg: f64,
}

/// How a LiDAR's rays sweep the scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ScanPattern {
    /// Rings of `beams` elevations, all around (Velodyne, Ouster, Hesai).
    #[default]
    Spinning,
    /// A non-repetitive rose curve in a forward cone (Livox Mid/Avia/HAP).
    Rosette,
}

/// The prisms' rates (Hz): Livox Mid-40's motors, 7 294 and −4 664 rpm.
const PRISM_HZ: [f64; 2] = [7294.0 / 60.0, -4664.0 / 60.0];

impl Default for LidarParams {
    fn default() -> Self {
        LidarParams {
            beams: 32,
            vmin_deg: -25.0,
            vmax_deg: 15.0,
            az_step_deg: 0.2,
            rate_hz: 10.0,
            range_noise_m: 0.02,
            max_range_m: 100.0,
            min_range_m: 1.0,
            height_m: 1.8,
            speed_mps: 5.0,
            pattern: ScanPattern::Spinning,
            fov_deg: 70.0,
            sway_deg: 0.0,
        }
    }
}

impl LidarParams {
    /// Azimuth columns per revolution.
    pub fn columns(&self) -> u32 {
        (360.0 / self.az_step_deg).round().max(1.0) as u32
    }
    /// Rays per revolution.
    pub(crate) fn rays_per_scan(&self) -> u64 {
        self.columns() as u64 * self.beams as u64
    }
    pub(crate) fn validate(&self) -> crate::Result<()> {
        let bad = |m: &str| Err(crate::Error::Param(format!("lidar.{m}")));
        if self.beams == 0 || self.beams > 1024 {
            return bad("beams must be in 1..=1024");
        }
        if !(self.az_step_deg >= 0.01 && self.az_step_deg <= 360.0) {
            return bad("az_step_deg must be in [0.01, 360]");
        }
        if !(self.vmin_deg >= -89.0 && self.vmax_deg <= 89.0 && self.vmin_deg <= self.vmax_deg) {
            return bad("vmin_deg <= vmax_deg, both within ±89");
        }
        if !(self.rate_hz > 0.0 && self.rate_hz.is_finite()) {
            return bad("rate_hz must be positive");
        }
        if !(self.range_noise_m >= 0.0 && self.range_noise_m < 1.0) {
            return bad("range_noise_m must be in [0, 1)");
        }
        if !(self.min_range_m >= 0.0
            && self.max_range_m > self.min_range_m
            && self.max_range_m <= 1000.0)
        {
            return bad("need 0 <= min_range_m < max_range_m <= 1000");
        }
        if !(self.height_m > 0.1 && self.height_m < 20.0) {
            return bad("height_m must be in (0.1, 20)");
        }
        if !(self.speed_mps >= 0.0 && self.speed_mps < 100.0) {
            return bad("speed_mps must be in [0, 100)");
        }
        if !(self.fov_deg >= 1.0 && self.fov_deg <= 120.0) {
            return bad("fov_deg must be in [1, 120]");
        }
        if !(self.sway_deg >= 0.0 && self.sway_deg <= 30.0) {
            return bad("sway_deg must be in [0, 30]");
        }
        Ok(())
    }
}

/// The road: from `x0` to `x1` along x, gently curving sideways.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Road {
    /// Start x.
    pub x0: f64,
    /// End x.
    pub x1: f64,
    /// Sideways amplitude of the curve, metres.
    pub amp: f64,
    /// Wavelength of the curve, metres.
    pub wavelength: f64,
}

impl Road {
    /// Lateral position of the road centre at `x`.
    pub fn y(&self, x: f64) -> f64 {
        self.amp * (std::f64::consts::TAU * (x - self.x0) / self.wavelength).sin()
    }
    /// Heading (rad) of the road at `x`.
    pub fn heading(&self, x: f64) -> f64 {
        let k = std::f64::consts::TAU / self.wavelength;
        (self.amp * k * (k * (x - self.x0)).cos()).atan()
    }
    /// Road length along x.
    pub fn length(&self) -> f64 {
        self.x1 - self.x0
    }
}

/// Where a scan was taken (the sensor at the start of the revolution).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Pose {
    /// Sensor x, world frame.
    pub x: f64,
    /// Sensor y.
    pub y: f64,
    /// Sensor z.
    pub z: f64,
    /// Heading, degrees from +x counter-clockwise.
    pub yaw_deg: f64,
}

/// Sensor pose when the vehicle is at road station `x`.
pub(crate) fn pose_at(world: &World, road: &Road, lidar: &LidarParams, x: f64) -> Pose {
    let y = road.y(x);
    let z = world.ground.height(x, y) + lidar.height_m;
    Pose {
        x,
        y,
        z,
        yaw_deg: road.heading(x).to_degrees(),
    }
}

/// A standard normal from a hash key (Box–Muller).
#[inline]
fn normal_from(key: u64) -> f64 {
    let u1 = unit_from(key).max(1e-300);
    let u2 = unit_from(key ^ 0xA5A5_A5A5_A5A5_A5A5);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Casts one revolution starting at road station `x_start`, appending the world-frame
/// returns to `out` in firing order and counting returns per target in `per_target`;
/// with `hits`, what each return struck, `(object, part)` (`None` for the ground;
/// see [`Hit`]), in the same order.
/// Randomness comes only from (seed, scan, ray), so the result does not depend on
/// which thread runs it.
#[allow(clippy::too_many_arguments)]
pub fn scan(
    world: &World,
    road: &Road,
    lidar: &LidarParams,
    seed: u64,
    scan_index: u64,
    x_start: f64,
    out: &mut Vec<Point>,
    per_target: &mut [u64],
    mut hits: Option<&mut Vec<(Option<u32>, u32)>>,
) {
    let ncols = lidar.columns();
    let beams = lidar.beams;
    let dx_rev = lidar.speed_mps / lidar.rate_hz;
    let start = pose_at(world, road, lidar, x_start);
    let centre = Vector3::new(start.x, start.y, start.z);
    let active = world.near(&centre, lidar.max_range_m + dx_rev);
    let scan_key = splitmix(seed ^ splitmix(scan_index.wrapping_add(0x1234_5678)));
    // One return per ray: cast, add range noise, keep within range.
    let mut shoot = |o: Vector3<f64>, dir: Vector3<f64>, key: u64| {
        let ray = Ray::new(o, dir);
        let Some(Hit { t, object, prim }) = world.cast(&ray, lidar.max_range_m, &active, key)
        else {
            return;
        };
        let r = t + lidar.range_noise_m * normal_from(key ^ 0x0F0F_0F0F_0F0F_0F0F);
        if r < lidar.min_range_m || r > lidar.max_range_m {
            return;
        }
        if let Some(i) = object
            && let Some(n) = per_target.get_mut(i as usize)
        {
            *n += 1;
        }
        out.push(Point::from(ray.at(r)));
        if let Some(h) = hits.as_mut() {
            h.push((object, prim));
        }
    };
    if lidar.pattern == ScanPattern::Rosette {
        let rays = lidar.rays_per_scan();
        let half = (lidar.fov_deg / 2.0).to_radians();
        // Scan i covers [i, i + 1) / rate_hz: the curve goes on from scan to scan.
        let t0 = (scan_index % (1 << 40)) as f64 / lidar.rate_hz;
        for k in 0..rays {
            let f = k as f64 / rays as f64;
            let t = t0 + f / lidar.rate_hz;
            let p = pose_at(world, road, lidar, x_start + dx_rev * f);
            let o = Vector3::new(p.x, p.y, p.z);
            // Each prism deflects by half the cone's half-angle: the beam
            // leaves the boresight by the angle |d| towards the direction of d.
            let (a1, a2) = (TAU * PRISM_HZ[0] * t, TAU * PRISM_HZ[1] * t);
            let dy = 0.5 * half * (a1.cos() + a2.cos());
            let dz = 0.5 * half * (a1.sin() + a2.sin());
            let off = dy.hypot(dz);
            let (so, co) = off.sin_cos();
            let (ly, lz) = if off > 0.0 {
                (so * dy / off, so * dz / off)
            } else {
                (0.0, 0.0)
            };
            // Sensor frame (forward, left, up), pitched and yawed by the sway
            // and the heading.
            let sway = lidar.sway_deg.to_radians();
            let (sp, cp) = (sway * (TAU * 1.1 * t).sin()).sin_cos();
            let (fx, fz) = (co * cp - lz * sp, co * sp + lz * cp);
            let yaw = p.yaw_deg.to_radians() + sway * (TAU * 0.7 * t).sin();
            let (sy, cy) = yaw.sin_cos();
            let dir = Vector3::new(fx * cy - ly * sy, fx * sy + ly * cy, fz);
            shoot(o, dir, splitmix(scan_key ^ k));
        }
        return;
    }
    let elev: Vec<(f64, f64)> = (0..beams)
        .map(|b| {
            let f = if beams > 1 {
                b as f64 / (beams - 1) as f64
            } else {
                0.5
            };
            let e = (lidar.vmin_deg + f * (lidar.vmax_deg - lidar.vmin_deg)).to_radians();
            (e.cos(), e.sin())
        })
        .collect();
    let az_step = lidar.az_step_deg.to_radians();
    for c in 0..ncols {
        let x = x_start + dx_rev * c as f64 / ncols as f64;
        let p = pose_at(world, road, lidar, x);
        let o = Vector3::new(p.x, p.y, p.z);
        let az = p.yaw_deg.to_radians() + c as f64 * az_step;
        let (sa, ca) = az.sin_cos();
        for (b, &(ce, se)) in elev.iter().enumerate() {
            let key = splitmix(scan_key ^ (c as u64 * beams as u64 + b as u64));
            shoot(o, Vector3::new(ce * ca, ce * sa, se), key);
        }
    }
}
