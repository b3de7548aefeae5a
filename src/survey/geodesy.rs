//! WGS84 geodesy: geodetic ↔ ECEF ↔ local ENU, exact on the ellipsoid.
//!
//! RTK surveys often come as latitude/longitude/ellipsoidal height; the metrics need
//! metres in a local tangent frame. A flat-earth shortcut is wrong by centimetres over
//! a few hundred metres, which is the size of the errors being measured, so the full
//! ellipsoidal conversion is used.

use crate::Point;
use serde::{Deserialize, Serialize};

/// WGS84 semi-major axis (m).
pub const WGS84_A: f64 = 6_378_137.0;
/// WGS84 flattening.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;
/// WGS84 first eccentricity squared.
pub const WGS84_E2: f64 = WGS84_F * (2.0 - WGS84_F);

/// A WGS84 position: where a survey's ENU origin sits on the earth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Geodetic {
    /// Latitude, degrees north.
    pub lat: f64,
    /// Longitude, degrees east.
    pub lon: f64,
    /// Ellipsoidal height, metres.
    pub alt: f64,
}

impl Geodetic {
    /// Earth-centred earth-fixed coordinates (m), the common frame for ENU conversion.
    pub fn to_ecef(&self) -> Point {
        let (sl, cl) = self.lat.to_radians().sin_cos();
        let (so, co) = self.lon.to_radians().sin_cos();
        let n = WGS84_A / (1.0 - WGS84_E2 * sl * sl).sqrt();
        Point::new(
            (n + self.alt) * cl * co,
            (n + self.alt) * cl * so,
            (n * (1.0 - WGS84_E2) + self.alt) * sl,
        )
    }

    /// Inverse of [`Geodetic::to_ecef`] (fixed-point iteration on latitude; converges
    /// to machine precision in a handful of steps for any terrestrial point).
    pub fn from_ecef(p: &Point) -> Geodetic {
        let (x, y, z) = (p.x, p.y, p.z);
        let r = x.hypot(y);
        let lon = y.atan2(x);
        let mut lat = z.atan2(r * (1.0 - WGS84_E2));
        for _ in 0..20 {
            let s = lat.sin();
            let n = WGS84_A / (1.0 - WGS84_E2 * s * s).sqrt();
            let next = (z + WGS84_E2 * n * s).atan2(r);
            let done = (next - lat).abs() < 1e-15;
            lat = next;
            if done {
                break;
            }
        }
        let (s, c) = lat.sin_cos();
        let n = WGS84_A / (1.0 - WGS84_E2 * s * s).sqrt();
        // Valid at the poles too (no division by cos(lat)).
        let alt = r * c + z * s - WGS84_A * WGS84_A / n;
        Geodetic {
            lat: lat.to_degrees(),
            lon: lon.to_degrees(),
            alt,
        }
    }

    /// East, north, up (m) of `p` in the tangent frame at `self`.
    pub fn enu_of(&self, p: &Geodetic) -> Point {
        let o = self.to_ecef();
        let q = p.to_ecef();
        let d = q - o;
        let (sl, cl) = self.lat.to_radians().sin_cos();
        let (so, co) = self.lon.to_radians().sin_cos();
        Point::new(
            -so * d.x + co * d.y,
            -sl * co * d.x - sl * so * d.y + cl * d.z,
            cl * co * d.x + cl * so * d.y + sl * d.z,
        )
    }

    /// The geodetic position of local ENU coordinates `enu` about `self` (for writing
    /// synthetic surveys in lat/lon).
    pub fn geodetic_of(&self, enu: &Point) -> Geodetic {
        let (sl, cl) = self.lat.to_radians().sin_cos();
        let (so, co) = self.lon.to_radians().sin_cos();
        let (e, n, u) = (enu.x, enu.y, enu.z);
        let dx = -so * e - sl * co * n + cl * co * u;
        let dy = co * e - sl * so * n + cl * so * u;
        let dz = cl * n + sl * u;
        let o = self.to_ecef();
        Geodetic::from_ecef(&Point::new(o.x + dx, o.y + dy, o.z + dz))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_ecef_values() {
        let eq = Geodetic {
            lat: 0.0,
            lon: 0.0,
            alt: 0.0,
        }
        .to_ecef();
        assert!((eq.x - WGS84_A).abs() < 1e-9 && eq.y.abs() < 1e-9 && eq.z.abs() < 1e-9);
        let b = WGS84_A * (1.0 - WGS84_F);
        let pole = Geodetic {
            lat: 90.0,
            lon: 0.0,
            alt: 10.0,
        }
        .to_ecef();
        assert!((pole.z - (b + 10.0)).abs() < 1e-6, "{pole}");
        assert!((b - 6_356_752.314_245).abs() < 1e-6);
        // GeographicLib CartConvert documentation example (Mt Everest):
        // 27.99 86.93 8820 -> 302271.4 5635928.4 2979666.1
        let ev = Geodetic {
            lat: 27.99,
            lon: 86.93,
            alt: 8820.0,
        }
        .to_ecef();
        assert!((ev.x - 302_271.4).abs() < 0.1, "{ev}");
        assert!((ev.y - 5_635_928.4).abs() < 0.1, "{ev}");
        assert!((ev.z - 2_979_666.1).abs() < 0.1, "{ev}");
        let back = Geodetic::from_ecef(&ev);
        assert!((back.lat - 27.99).abs() < 1e-12 && (back.lon - 86.93).abs() < 1e-12);
        assert!((back.alt - 8820.0).abs() < 1e-6);
        let p = Geodetic::from_ecef(&pole);
        assert!((p.lat - 90.0).abs() < 1e-12 && (p.alt - 10.0).abs() < 1e-6);
    }

    #[test]
    fn enu_round_trip_sub_0_1_mm() {
        let origins = [
            Geodetic {
                lat: 36.3729,
                lon: 127.3604,
                alt: 68.2,
            },
            Geodetic {
                lat: -33.9,
                lon: 18.4,
                alt: 5.0,
            },
            Geodetic {
                lat: 78.2,
                lon: 15.6,
                alt: 400.0,
            },
        ];
        for o in origins {
            for enu in [
                Point::new(0.0, 0.0, 0.0),
                Point::new(-88.973, -55.393, 1.5),
                Point::new(1234.5, -4321.0, -20.0),
                Point::new(20_000.0, 15_000.0, 300.0),
            ] {
                let g = o.geodetic_of(&enu);
                let back = o.enu_of(&g);
                assert!((back - enu).norm() < 1e-4, "{o:?} {enu} -> {back}");
            }
        }
        // Up is up, north is north.
        let o = origins[0];
        let up = o.enu_of(&Geodetic {
            alt: o.alt + 10.0,
            ..o
        });
        assert!((up - Point::new(0.0, 0.0, 10.0)).norm() < 1e-6);
        let north = o.enu_of(&Geodetic {
            lat: o.lat + 0.001,
            ..o
        });
        assert!(north.y > 110.0 && north.y < 112.0 && north.x.abs() < 1e-6);
    }
}
