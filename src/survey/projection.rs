//! Autoware's map projections (`map_projector_info.yaml`): where a WGS84
//! position lies in an Autoware map's frame, so a lat/lon survey is placed in
//! the map without fitting.
//!
//! The conventions are Autoware's (`geography_utils::project_forward` and
//! `lanelet2_extension`'s projectors):
//! - `LocalCartesianUTM`: UTM in the origin's zone, minus the origin's UTM
//!   easting and northing;
//! - `LocalCartesian`: east and north of the tangent plane at the origin;
//! - `TransverseMercator`: transverse Mercator with UTM's scale 0.9996 about
//!   the origin's meridian, minus the origin's northing;
//! - for those three, z = altitude − the origin's altitude;
//! - `MGRS`: UTM within the 100 km grid square `mgrs_grid`, relative to the
//!   square's south-west corner; z = altitude. (Autoware takes each point's
//!   own square; here points beyond the square keep counting from its
//!   corner, so a survey across a square's edge stays continuous.)
//!
//! Transverse Mercator is Krüger's series to sixth order in n (Karney 2011):
//! within a few nanometres of the exact projection up to 3 900 km from the
//! central meridian.

use super::geodesy::{Geodetic, WGS84_A, WGS84_F};
use crate::cloud::tiles::yaml::{self, Entry, Value};
use crate::{Error, Point, Result};
use std::path::Path;

/// UTM's central scale factor.
const UTM_K0: f64 = 0.9996;

/// A map projection from `map_projector_info.yaml`.
#[derive(Debug, Clone, PartialEq)]
pub enum Projector {
    /// UTM about the origin (in the origin's zone).
    LocalCartesianUtm {
        /// The map origin.
        origin: Geodetic,
    },
    /// East-north-up about the origin.
    LocalCartesian {
        /// The map origin.
        origin: Geodetic,
    },
    /// Transverse Mercator about the origin's meridian (scale 0.9996).
    TransverseMercator {
        /// The map origin.
        origin: Geodetic,
    },
    /// UTM within a 100 km MGRS grid square.
    Mgrs {
        /// The square as given, e.g. `54SUE`.
        grid: String,
        /// UTM zone 1–60.
        zone: u32,
        /// Northern hemisphere.
        north: bool,
        /// UTM easting and northing of the square's south-west corner.
        corner: [f64; 2],
    },
}

impl Projector {
    /// Reads `map_projector_info.yaml`. The survey's heights are WGS84
    /// ellipsoidal, so a map whose `vertical_datum` is another (EGM2008)
    /// needs a geoid model mapgauge does not have: refused when `heights`.
    pub fn read(path: &Path, heights: bool) -> Result<Projector> {
        let text = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let text = String::from_utf8(text)
            .map_err(|_| Error::format(path, "not UTF-8 text (a YAML file is expected)"))?;
        Projector::parse(&text, heights).map_err(|(l, m)| Error::table(path, l, m))
    }

    /// [`Projector::read`] on text.
    pub(crate) fn parse(text: &str, heights: bool) -> std::result::Result<Projector, yaml::Fail> {
        let entries = yaml::parse(text)?;
        yaml::check_unique(&entries)?;
        let get = |k: &str| entries.iter().find(|e| e.key == k);
        let Some(t) = get("projector_type") else {
            return Err((0, "no `projector_type`".into()));
        };
        let kind = scalar(t)?;
        let known = known_keys(&kind, t.line)?;
        if let Some(e) = entries.iter().find(|e| !known.contains(&e.key.as_str())) {
            return Err((e.line, format!("unexpected key `{}`", e.key)));
        }
        if let Some(v) = get("vertical_datum") {
            check_datum(v, heights)?;
        }
        if kind == "MGRS" {
            let Some(g) = get("mgrs_grid") else {
                return Err((t.line, "projector_type MGRS needs `mgrs_grid`".into()));
            };
            return mgrs(g);
        }
        let Some(o) = get("map_origin") else {
            return Err((t.line, format!("projector_type {kind} needs `map_origin`")));
        };
        let origin = map_origin(o)?;
        Ok(match kind.as_str() {
            "LocalCartesianUTM" => Projector::LocalCartesianUtm { origin },
            "LocalCartesian" => Projector::LocalCartesian { origin },
            _ => Projector::TransverseMercator { origin },
        })
    }

    /// The map-frame position of `g`.
    pub fn forward(&self, g: &Geodetic) -> Point {
        match self {
            Projector::LocalCartesianUtm { origin } => {
                let zone = utm_zone(origin.lat, origin.lon);
                let north = origin.lat >= 0.0;
                let (e, n) = utm(g.lat, g.lon, zone, north);
                let (e0, n0) = utm(origin.lat, origin.lon, zone, north);
                Point::new(e - e0, n - n0, g.alt - origin.alt)
            }
            Projector::LocalCartesian { origin } => {
                let enu = origin.enu_of(g);
                Point::new(enu.x, enu.y, g.alt - origin.alt)
            }
            Projector::TransverseMercator { origin } => {
                let (x, y) = tm(g.lat, g.lon, origin.lon, UTM_K0);
                let (_, y0) = tm(origin.lat, origin.lon, origin.lon, UTM_K0);
                Point::new(x, y - y0, g.alt - origin.alt)
            }
            Projector::Mgrs {
                zone,
                north,
                corner,
                ..
            } => {
                let (e, n) = utm(g.lat, g.lon, *zone, *north);
                Point::new(e - corner[0], n - corner[1], g.alt)
            }
        }
    }

    /// A short description for messages and results.
    pub fn describe(&self) -> String {
        let o = |g: &Geodetic| format!("{:.7}, {:.7}, {:.3} m", g.lat, g.lon, g.alt);
        match self {
            Projector::LocalCartesianUtm { origin } => format!(
                "LocalCartesianUTM (zone {}) about {}",
                utm_zone(origin.lat, origin.lon),
                o(origin)
            ),
            Projector::LocalCartesian { origin } => format!("LocalCartesian about {}", o(origin)),
            Projector::TransverseMercator { origin } => {
                format!("TransverseMercator about {}", o(origin))
            }
            Projector::Mgrs { grid, .. } => format!("MGRS grid square {grid}"),
        }
    }
}

/// An entry's single value (a key with a block under it, or none, is a
/// mistake in any of the projector's keys).
fn scalar(e: &Entry) -> std::result::Result<String, yaml::Fail> {
    match &e.value {
        Value::Scalar(s) if !s.is_empty() => Ok(s.clone()),
        _ => Err((e.line, format!("`{}` must be a single value", e.key))),
    }
}

/// The keys a projector of type `kind` (given on `line`) may have; an
/// error for a type that cannot place a WGS84 survey.
fn known_keys(kind: &str, line: u64) -> std::result::Result<&'static [&'static str], yaml::Fail> {
    match kind {
        "LocalCartesianUTM" | "LocalCartesian" | "TransverseMercator" => Ok(&[
            "projector_type",
            "vertical_datum",
            "map_origin",
            "mgrs_grid",
        ]),
        "MGRS" => Ok(&[
            "projector_type",
            "vertical_datum",
            "mgrs_grid",
            "map_origin",
        ]),
        "Local" => Err((
            line,
            "projector_type Local: the map is not georeferenced, so a WGS84 survey cannot be placed in it (give the survey in the map's x,y or use --frame)".into(),
        )),
        other => Err((
            line,
            format!(
                "projector_type `{other}` is not one of LocalCartesianUTM, LocalCartesian, TransverseMercator, MGRS"
            ),
        )),
    }
}

/// Refuses a `vertical_datum` other than WGS84 when the survey has
/// `heights`: converting them needs a geoid model.
fn check_datum(v: &Entry, heights: bool) -> std::result::Result<(), yaml::Fail> {
    let d = scalar(v)?;
    if d != "WGS84" && heights {
        return Err((
            v.line,
            format!(
                "vertical_datum {d}: the survey's heights are WGS84 ellipsoidal and mapgauge has no geoid model to convert them; drop the survey's alt column (2D evaluation) or convert its heights to {d} and the map's to WGS84"
            ),
        ));
    }
    Ok(())
}

/// The MGRS projector of the grid square in `mgrs_grid` (entry `g`).
fn mgrs(g: &Entry) -> std::result::Result<Projector, yaml::Fail> {
    let grid = scalar(g)?;
    let (zone, north, corner) = mgrs_square(&grid).map_err(|m| (g.line, m))?;
    Ok(Projector::Mgrs {
        grid,
        zone,
        north,
        corner,
    })
}

/// The `map_origin` entry `o`: latitude, longitude and altitude, each once,
/// within UTM's range.
fn map_origin(o: &Entry) -> std::result::Result<Geodetic, yaml::Fail> {
    let Value::Map(fields) = &o.value else {
        return Err((
            o.line,
            "`map_origin` must hold latitude, longitude and altitude".into(),
        ));
    };
    yaml::check_unique(fields)?;
    let mut v = [None; 3];
    for f in fields {
        let k = match f.key.as_str() {
            "latitude" => 0,
            "longitude" => 1,
            "altitude" => 2,
            other => return Err((f.line, format!("unexpected key `{other}` in map_origin"))),
        };
        v[k] = Some(yaml::number(f, &scalar(f)?)?);
    }
    let [Some(lat), Some(lon), Some(alt)] = v else {
        let missing =
            ["latitude", "longitude", "altitude"][v.iter().position(Option::is_none).unwrap_or(0)];
        return Err((o.line, format!("map_origin has no `{missing}`")));
    };
    if !(-80.0..=84.0).contains(&lat) || !(-180.0..=180.0).contains(&lon) {
        return Err((
            o.line,
            format!(
                "map_origin {lat}, {lon}: latitude must be within -80..84 (UTM's range) and longitude within -180..180"
            ),
        ));
    }
    Ok(Geodetic { lat, lon, alt })
}

/// The standard UTM zone of a position, with the Norway and Svalbard
/// exceptions.
pub(crate) fn utm_zone(lat: f64, lon: f64) -> u32 {
    let lon = (lon + 180.0).rem_euclid(360.0) - 180.0;
    let mut z = (((lon + 180.0) / 6.0).floor() as i64).clamp(0, 59) as u32 + 1;
    if (56.0..64.0).contains(&lat) && (3.0..12.0).contains(&lon) {
        z = 32;
    }
    if (72.0..84.0).contains(&lat) && (0.0..42.0).contains(&lon) {
        z = match lon {
            l if l < 9.0 => 31,
            l if l < 21.0 => 33,
            l if l < 33.0 => 35,
            _ => 37,
        };
    }
    z
}

/// UTM easting and northing in `zone` (false easting 500 km, false
/// northing 10 000 km south of the equator when not `north`).
pub(crate) fn utm(lat: f64, lon: f64, zone: u32, north: bool) -> (f64, f64) {
    let lon0 = f64::from(zone) * 6.0 - 183.0;
    let (x, y) = tm(lat, lon, lon0, UTM_K0);
    (500_000.0 + x, if north { y } else { y + 10_000_000.0 })
}

/// Transverse Mercator on WGS84 about meridian `lon0` with scale `k0`, no
/// false origin: Krüger's series in n to sixth order.
pub(crate) fn tm(lat: f64, lon: f64, lon0: f64, k0: f64) -> (f64, f64) {
    let f = WGS84_F;
    let n = f / (2.0 - f);
    let (n2, n3) = (n * n, n * n * n);
    let (n4, n5, n6) = (n2 * n2, n2 * n3, n3 * n3);
    let a_big = WGS84_A / (1.0 + n) * (1.0 + n2 / 4.0 + n4 / 64.0 + n6 / 256.0);
    let alpha = [
        n / 2.0 - 2.0 * n2 / 3.0 + 5.0 * n3 / 16.0 + 41.0 * n4 / 180.0 - 127.0 * n5 / 288.0
            + 7891.0 * n6 / 37800.0,
        13.0 * n2 / 48.0 - 3.0 * n3 / 5.0 + 557.0 * n4 / 1440.0 + 281.0 * n5 / 630.0
            - 1983433.0 * n6 / 1935360.0,
        61.0 * n3 / 240.0 - 103.0 * n4 / 140.0 + 15061.0 * n5 / 26880.0 + 167603.0 * n6 / 181440.0,
        49561.0 * n4 / 161280.0 - 179.0 * n5 / 168.0 + 6601661.0 * n6 / 7257600.0,
        34729.0 * n5 / 80640.0 - 3418889.0 * n6 / 1995840.0,
        212378941.0 * n6 / 319334400.0,
    ];
    let e = (f * (2.0 - f)).sqrt();
    let phi = lat.to_radians();
    let lam = ((lon - lon0 + 180.0).rem_euclid(360.0) - 180.0).to_radians();
    let s = phi.sin();
    // Conformal latitude's tangent.
    let t = (s.atanh() - e * (e * s).atanh()).sinh();
    let xi_p = t.atan2(lam.cos());
    let eta_p = (lam.sin() / t.hypot(lam.cos())).asinh();
    let (mut xi, mut eta) = (xi_p, eta_p);
    for (j, a) in alpha.iter().enumerate() {
        let k = 2.0 * (j + 1) as f64;
        xi += a * (k * xi_p).sin() * (k * eta_p).cosh();
        eta += a * (k * xi_p).cos() * (k * eta_p).sinh();
    }
    (k0 * a_big * eta, k0 * a_big * xi)
}

/// Zone, hemisphere and south-west corner (UTM easting, northing) of an
/// MGRS 100 km square such as `54SUE`.
fn mgrs_square(grid: &str) -> std::result::Result<(u32, bool, [f64; 2]), String> {
    const BANDS: &str = "CDEFGHJKLMNPQRSTUVWX";
    const LETTERS: &str = "ABCDEFGHJKLMNPQRSTUVWXYZ";
    const ROWS: &str = "ABCDEFGHJKLMNPQRSTUV";
    let bad = |why: &str| format!("mgrs_grid `{grid}`: {why} (expected e.g. 54SUE)");
    let g = grid.trim().to_ascii_uppercase();
    let digits = g.bytes().take_while(u8::is_ascii_digit).count();
    let letters: Vec<char> = g[digits..].chars().collect();
    if !(1..=2).contains(&digits) || letters.len() != 3 {
        return Err(bad("a zone number and three letters"));
    }
    let zone: u32 = g[..digits].parse().map_err(|_| bad("bad zone"))?;
    if !(1..=60).contains(&zone) {
        return Err(bad("zone must be 1 to 60"));
    }
    let band = BANDS
        .find(letters[0])
        .ok_or_else(|| bad("latitude band must be C to X (not I or O)"))?;
    let set = ((zone - 1) % 3) as usize;
    let col = LETTERS
        .find(letters[1])
        .filter(|&c| c / 8 == set)
        .ok_or_else(|| bad("the column letter is not used in this zone"))?;
    let row = ROWS
        .find(letters[2])
        .ok_or_else(|| bad("the row letter must be A to V (not I or O)"))?;
    let north = band >= BANDS.find('N').unwrap_or(10);
    let easting = ((col % 8) + 1) as f64 * 100_000.0;
    // Row letters repeat every 2 000 km, offset by 5 in even zones; the band
    // picks the repetition (bands are at most 12° ≈ 1 330 km tall).
    let row_km = ((row + 20 - if zone % 2 == 0 { 5 } else { 0 }) % 20) as f64 * 100.0;
    let lat_lo = -80.0 + 8.0 * band as f64;
    let lat_hi = if letters[0] == 'X' {
        84.0
    } else {
        lat_lo + 8.0
    };
    let lon0 = f64::from(zone) * 6.0 - 183.0;
    let (_, mid) = utm((lat_lo + lat_hi) / 2.0, lon0, zone, north);
    let k = ((mid - 50_000.0 - row_km * 1000.0) / 2_000_000.0).round();
    let northing = row_km * 1000.0 + k * 2_000_000.0;
    Ok((zone, north, [easting, northing]))
}

#[cfg(test)]
mod tests {
    use super::*;

    // Reference values from PROJ 9 through pyproj (EPSG:326xx/327xx UTM and
    // `+proj=tmerc +k=0.9996 +lon_0=…`), the GeoTrans MGRS codes through the
    // `mgrs` package, and an ECEF-based ENU through PROJ's geocentric
    // conversion; to the micrometre.
    fn g(lat: f64, lon: f64, alt: f64) -> Geodetic {
        Geodetic { lat, lon, alt }
    }

    #[test]
    fn utm_matches_proj_to_a_micrometre() {
        for (lat, lon, zone, e, n) in [
            (35.6812, 139.7671, 54, 388_433.374_621, 3_949_290.013_536),
            (-33.8688, 151.2093, 56, 334_368.633_648, 6_250_948.345_385),
            (60.17, 24.94, 35, 385_700.421_386, 6_672_126.743_134),
            (0.5, 9.0, 32, 500_000.0, 55_265.037_143),
            (-0.3, -78.5, 17, 778_272.522_942, 9_966_809.180_394),
            (78.2, 15.6, 33, 513_696.945_417, 8_680_760.053_196),
            (59.9, 10.7, 32, 595_101.146_298, 6_641_495.240_238),
        ] {
            assert_eq!(utm_zone(lat, lon), zone, "{lat} {lon}");
            let (x, y) = utm(lat, lon, zone, lat >= 0.0);
            assert!(
                (x - e).abs() < 2e-6 && (y - n).abs() < 2e-6,
                "{lat} {lon}: {x} {y}"
            );
        }
        // Far from the central meridian (zone 54's is 141°E): 9° and 6.5° off.
        for (lat, lon, e, n) in [
            (35.0, 132.0, -322_423.299_237, 3_910_273.105_051),
            (-40.0, 147.5, 1_055_045.542_882, 5_551_957.630_846),
            (10.0, 141.0, 0.0, 1_105_412.491_301),
        ] {
            let (x, y) = tm(lat, lon, 141.0, UTM_K0);
            let y = if lat < 0.0 { y + 10_000_000.0 } else { y };
            let want_x = if e == 0.0 { 0.0 } else { e - 500_000.0 };
            assert!(
                (x - want_x).abs() < 2e-6 && (y - n).abs() < 2e-6,
                "{lat} {lon}: {x} {y}"
            );
        }
    }

    #[test]
    fn autoware_projectors_place_a_point_as_proj_does() {
        let o = "map_origin:\n  latitude: 35.68\n  longitude: 139.76\n  altitude: 30.0\n";
        let p = g(35.6812, 139.7671, 40.0);
        let utm = Projector::parse(
            &format!("projector_type: LocalCartesianUTM\nvertical_datum: WGS84\n{o}"),
            true,
        )
        .unwrap();
        let q = utm.forward(&p);
        // 388433.374621 - 387789.174303, 3949290.013536 - 3949165.001789.
        assert!(
            (q.x - 644.200_318).abs() < 2e-6 && (q.y - 125.011_747).abs() < 2e-6,
            "{q}"
        );
        assert_eq!(q.z, 10.0);
        let lc = Projector::parse(&format!("projector_type: LocalCartesian\n{o}"), true).unwrap();
        let q = lc.forward(&p);
        assert!(
            (q.x - 642.732_791).abs() < 2e-6 && (q.y - 133.167_774).abs() < 2e-6,
            "{q}"
        );
        assert_eq!(q.z, 10.0, "Autoware's z: altitude minus the origin's");
        let tmp =
            Projector::parse(&format!("projector_type: TransverseMercator\n{o}"), true).unwrap();
        for (p, x, y) in [
            (p, 642.471_675, 133.113_670),
            (g(35.7, 139.7, 0.0), -5_428.064_547, 2_219.836_163),
            (g(36.5, 141.5, 0.0), 155_833.227_677, 92_359.095_947),
        ] {
            let q = tmp.forward(&p);
            assert!((q.x - x).abs() < 2e-6 && (q.y - y).abs() < 2e-6, "{q}");
        }
        let mgrs = Projector::parse(
            "projector_type: MGRS\nvertical_datum: WGS84\nmgrs_grid: 54SUE\n",
            true,
        )
        .unwrap();
        // 54SUE 88433.374 49290.013 (GeoTrans: 54SUE8843349290).
        let q = mgrs.forward(&p);
        assert!(
            (q.x - 88_433.374_621).abs() < 2e-6 && (q.y - 49_290.013_536).abs() < 2e-6,
            "{q}"
        );
        assert_eq!(q.z, 40.0);
        assert!(mgrs.describe().contains("54SUE"));
    }

    #[test]
    fn mgrs_squares_match_geotrans() {
        // (grid, a point inside, its UTM) from GeoTrans codes above.
        for (grid, lat, lon) in [
            ("56HLH", -33.8688, 151.2093),
            ("35VLG", 60.17, 24.94),
            ("32NNF", 0.5, 9.0),
            ("17MQV", -0.3, -78.5),
            ("33XWG", 78.2, 15.6),
            ("32VNM", 59.9, 10.7),
            ("54SUE", 35.7, 139.5),
        ] {
            let (zone, north, c) = mgrs_square(grid).unwrap();
            let (e, n) = utm(lat, lon, zone, north);
            let (de, dn) = (e - c[0], n - c[1]);
            assert!(
                (0.0..100_000.0).contains(&de) && (0.0..100_000.0).contains(&dn),
                "{grid}: {de} {dn}"
            );
            assert_eq!(north, lat >= 0.0, "{grid}");
        }
        let (_, _, c) = mgrs_square("17mqv").unwrap();
        assert_eq!(c, [700_000.0, 9_900_000.0]);
        for bad in [
            "54SIE", "54SAE", "54S", "61SUE", "0SUE", "54SUZ", "54OUE", "x",
        ] {
            assert!(mgrs_square(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn bad_projector_files_are_refused_with_their_line() {
        for (text, line, what) in [
            ("vertical_datum: WGS84\n", 0, "projector_type"),
            ("projector_type: Foo\n", 1, "not one of"),
            ("projector_type: Local\n", 1, "not georeferenced"),
            ("projector_type: MGRS\n", 1, "mgrs_grid"),
            ("projector_type: MGRS\nmgrs_grid: 54SIE\n", 2, "mgrs_grid"),
            ("projector_type: LocalCartesianUTM\n", 1, "map_origin"),
            (
                "projector_type: LocalCartesian\nmap_origin:\n  latitude: 1\n  longitude: 2\n",
                2,
                "altitude",
            ),
            (
                "projector_type: LocalCartesian\nmap_origin:\n  latitude: 1\n  latitude: 2\n",
                4,
                "twice",
            ),
            (
                "projector_type: LocalCartesian\nmap_origin:\n  latitude: 91\n  longitude: 2\n  altitude: 0\n",
                2,
                "latitude",
            ),
            (
                "projector_type: LocalCartesian\nmap_origin:\n  latitude: x\n  longitude: 2\n  altitude: 0\n",
                3,
                "finite",
            ),
            (
                "projector_type: MGRS\nmgrs_grid: 54SUE\nvertical_datum: EGM2008\n",
                3,
                "geoid",
            ),
            (
                "projector_type: MGRS\nmgrs_grid: 54SUE\nscale: 2\n",
                3,
                "unexpected",
            ),
        ] {
            let (l, m) = Projector::parse(text, true).unwrap_err();
            assert_eq!(l, line, "{text:?}: {m}");
            assert!(m.contains(what), "{text:?}: {m}");
        }
        // Without survey heights, another vertical datum does not matter.
        assert!(
            Projector::parse(
                "projector_type: MGRS\nmgrs_grid: 54SUE\nvertical_datum: EGM2008\n",
                false
            )
            .is_ok()
        );
    }
}
