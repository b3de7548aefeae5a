//! WGS84 geodesy: geodetic ↔ ECEF ↔ local ENU, exact on the ellipsoid.
//!
//! RTK surveys often come as latitude/longitude/ellipsoidal height; the metrics need
//! metres in a local tangent frame. A flat-earth shortcut is wrong by centimetres over
//! a few hundred metres, which is the size of the errors being measured, so the full
//! ellipsoidal conversion is used.

use crate::Point;
use serde::{Deserialize, Serialize};

/// WGS84 semi-major axis (m).
pub(crate) const WGS84_A: f64 = 6_378_137.0;
/// WGS84 flattening.
pub(crate) const WGS84_F: f64 = 1.0 / 298.257_223_563;
/// WGS84 first eccentricity squared.
pub(crate) const WGS84_E2: f64 = WGS84_F * (2.0 - WGS84_F);

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
    pub(crate) fn from_ecef(p: &Point) -> Geodetic {
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

/// Values computed outside mapgauge, so that a mistake made the same way in a
/// function and its inverse (east mirrored in both `enu_of` and `geodetic_of`,
/// say) cannot pass. Source: PROJ 9.5.1 through pyproj 3.7.2 (`pip install
/// pyproj`), WGS84: geodetic → ECEF with EPSG:4979 → EPSG:4978, and ENU with the
/// pipeline `+proj=cart +ellps=WGS84 +step +proj=topocentric +ellps=WGS84
/// +lat_0=… +lon_0=… +h_0=…`. The script: tests/data/geodesy_proj.py.
#[cfg(test)]
mod independent {
    use super::*;

    fn g(lat: f64, lon: f64, alt: f64) -> Geodetic {
        Geodetic { lat, lon, alt }
    }

    /// (lat°, lon°, h m) → ECEF (m), PROJ.
    const ECEF: [([f64; 3], [f64; 3]); 5] = [
        (
            [36.3725, 127.3631, 70.0],
            [-3120283.5835112003, 4086613.421387339, 3761593.4927074695],
        ),
        (
            [-33.9249, 18.4241, 10.0],
            [5026365.641629906, 1674397.8020781025, -3539543.028381],
        ),
        (
            [40.0, -105.0, 1600.0],
            [-1266643.1360426995, -4727176.53876973, 4079014.0323758745],
        ),
        (
            [-45.0, -70.5, -30.0],
            [1507995.7414588796, -4258448.605736865, -4487327.195662484],
        ),
        ([0.0, 0.0, 0.0], [6378137.0, 0.0, 0.0]),
    ];

    /// (origin lat, lon, h; point lat, lon, h) → the point's east, north, up about
    /// the origin (m), PROJ topocentric.
    const ENU: [([f64; 3], [f64; 3], [f64; 3]); 6] = [
        // North-east of the demo's origin (Daejeon).
        (
            [36.3725, 127.3631, 70.0],
            [36.3735, 127.365, 75.5],
            [170.50158107887387, 110.96892422451668, 5.496755368499592],
        ),
        // South-west of it.
        (
            [36.3725, 127.3631, 70.0],
            [36.371, 127.3612, 64.0],
            [-170.50672960566288, -166.44885900860953, -6.004455160600983],
        ),
        // South-east, southern hemisphere (Cape Town).
        (
            [-33.9249, 18.4241, 10.0],
            [-33.93, 18.43, 15.0],
            [545.518214793868, -565.7144989434465, 4.951517142598107],
        ),
        // South-west, western hemisphere (Colorado).
        (
            [40.0, -105.0, 1600.0],
            [39.99, -105.02, 1590.0],
            [
                -1708.5514407182125,
                -1110.4311883460737,
                -10.325353392992952,
            ],
        ),
        // Across the equator and the Greenwich meridian.
        (
            [0.001, -0.002, 0.0],
            [-0.05, 0.06, 12.0],
            [6901.817457060244, -5639.297952555787, 5.755936751064882],
        ),
        // 24 km away, where the earth's curvature shows in up (−40 m).
        (
            [52.0, 4.5, 40.0],
            [52.15, 4.75, 45.0],
            [17112.124500195197, 16719.834145694585, -39.83225114641573],
        ),
    ];

    #[test]
    fn ecef_matches_proj() {
        for ([lat, lon, h], [x, y, z]) in ECEF {
            let want = Point::new(x, y, z);
            let got = g(lat, lon, h).to_ecef();
            assert!(
                (got - want).norm() < 1e-6,
                "{lat},{lon},{h}: {got} vs PROJ {want}"
            );
            let back = Geodetic::from_ecef(&want);
            assert!(
                (back.lat - lat).abs() < 1e-11 && (back.lon - lon).abs() < 1e-11,
                "{want}: {back:?} vs PROJ {lat},{lon}"
            );
            assert!((back.alt - h).abs() < 1e-6, "{want}: {back:?} vs PROJ {h}");
        }
    }

    #[test]
    fn enu_matches_proj() {
        for ([olat, olon, oh], [lat, lon, h], [e, n, u]) in ENU {
            let o = g(olat, olon, oh);
            let want = Point::new(e, n, u);
            let got = o.enu_of(&g(lat, lon, h));
            // 0.1 mm: far below a survey's centimetres, far above rounding.
            assert!(
                (got - want).norm() < 1e-4,
                "{lat},{lon},{h} about {o:?}: {got} vs PROJ {want}"
            );
            let p = o.geodetic_of(&want);
            // 1e-9° is 0.1 mm on the ground.
            assert!(
                (p.lat - lat).abs() < 1e-9
                    && (p.lon - lon).abs() < 1e-9
                    && (p.alt - h).abs() < 1e-4,
                "{want} about {o:?}: {p:?} vs PROJ {lat},{lon},{h}"
            );
        }
    }
}
