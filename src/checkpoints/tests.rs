use super::*;
use crate::survey::Geodetic;

/// The gates' six-target fixture, turned by 90° (so σx and σy swap) with a
/// known covariance on target 1 and target 6 not located.
fn result() -> ResultFile {
    let mut r = crate::gate::tests::result();
    r.alignment.rotation_matrix = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
    r.alignment.scale = 1.0;
    r.targets[0].map_covariance = Some([[4e-6, 0.0, 0.0], [0.0, 1e-6, 0.0], [0.0, 0.0, 9e-6]]);
    r.targets[5].status = "not_found".into();
    r.targets[5].aligned = None;
    r.targets[5].abs_error = None;
    r
}

#[test]
fn rows_turn_the_covariance_into_the_surveys_axes() {
    let r = result();
    let (crs, rows) = rows(&r, Some(32633)).unwrap();
    assert_eq!(crs, Crs::Epsg(32633));
    let c = &rows[0];
    // Map x (σ 2 mm) is survey y after a quarter turn.
    let s = c.sigma.unwrap();
    assert!(
        (s[0] - 1e-3).abs() < 1e-12 && (s[1] - 2e-3).abs() < 1e-12 && (s[2] - 3e-3).abs() < 1e-12
    );
    let t = &r.targets[0];
    let a = t.aligned.unwrap();
    assert_eq!(c.surveyed, [t.survey.x, t.survey.y]);
    assert_eq!(c.measured, Some([a.x, a.y]));
    assert_eq!(c.d.unwrap()[0], Some(a.x - t.survey.x));
    assert_eq!(rows[5].measured, None);
    assert_eq!(rows[5].d, None);
    assert_eq!(rows[5].status, "not_found");
}

#[test]
fn a_wgs84_survey_is_written_in_lon_lat_and_refuses_an_epsg_code() {
    let mut r = result();
    let o = Geodetic {
        lat: 47.0,
        lon: 8.0,
        alt: 400.0,
    };
    r.survey_frame = SurveyFrame::Wgs84Enu;
    r.origin = Some(o);
    r.targets[1].survey.z = Some(2.0);
    let (crs, rows) = rows(&r, None).unwrap();
    assert_eq!(crs, Crs::Wgs84);
    let t = &r.targets[1];
    // Back to ENU: the written lon/lat/h are the surveyed ENU point's.
    let back = o.enu_of(&Geodetic {
        lat: rows[1].surveyed[1],
        lon: rows[1].surveyed[0],
        alt: rows[1].surveyed_z.unwrap(),
    });
    assert!((back.x - t.survey.x).abs() < 1e-6 && (back.y - t.survey.y).abs() < 1e-6);
    assert!((back.z - 2.0).abs() < 1e-6);
    // 30 m east of 8° E at 47° N: about 0.000395° of longitude.
    assert!(
        (rows[1].surveyed[0] - 8.0 - 30.0 / (111_320.0 * 47f64.to_radians().cos())).abs() < 2e-6
    );
    let e = super::rows(&r, Some(32632)).unwrap_err().to_string();
    assert!(e.contains("WGS84"), "{e}");
    let e = check(Path::new("c.gpkg"), SurveyFrame::Wgs84Enu, Some(32632))
        .unwrap_err()
        .to_string();
    assert!(e.contains("projected x, y"), "{e}");
}

#[test]
fn geojson_is_only_for_wgs84_and_unknown_extensions_are_refused() {
    let e = check(Path::new("c.geojson"), SurveyFrame::Local, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("RFC 7946") && e.contains(".gpkg or .csv"), "{e}");
    assert!(check(Path::new("c.geojson"), SurveyFrame::Wgs84Enu, None).is_ok());
    let e = check_path(Path::new("c.shp")).unwrap_err().to_string();
    assert!(e.contains(".gpkg, .geojson or .csv"), "{e}");
    assert_eq!(parse_epsg("EPSG:32633").unwrap(), 32633);
    assert_eq!(parse_epsg("4979").unwrap(), 4979);
    assert!(parse_epsg("EPSG:99").is_err() && parse_epsg("utm33").is_err());
}

#[test]
fn the_geopackage_reads_back_whole_and_leaves_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cp.gpkg");
    let mut r = result();
    for t in &mut r.targets {
        t.survey.z = Some(1.5);
    }
    let crs = write(&path, &r, Some(32633)).unwrap();
    assert_eq!(crs.label(), "EPSG:32633");
    // Written again over itself: replaced, not appended to.
    write(&path, &r, Some(32633)).unwrap();
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["cp.gpkg"]);
    let db = rusqlite::Connection::open(&path).unwrap();
    let app: i32 = db
        .query_row("PRAGMA application_id", [], |r| r.get(0))
        .unwrap();
    assert_eq!(app, 0x4750_4B47);
    let (srs, z): (i64, i32) = db
        .query_row(
            "SELECT srs_id, z FROM gpkg_geometry_columns WHERE table_name = 'checkpoints'",
            [],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )
        .unwrap();
    assert_eq!((srs, z), (32633, 1));
    let n: i64 = db
        .query_row("SELECT count(*) FROM checkpoints", [], |r| r.get(0))
        .unwrap();
    assert_eq!(n, 6);
    let (blob, id, dx): (Vec<u8>, String, f64) = db
        .query_row(
            "SELECT geom, id, dx_m FROM checkpoints WHERE fid = 1",
            [],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
        )
        .unwrap();
    let t = &r.targets[0];
    assert_eq!(id, t.id);
    assert_eq!(dx, t.aligned.unwrap().x - t.survey.x);
    // GP, version 0, little-endian without envelope, SRS id, WKB Point Z.
    assert_eq!(&blob[..4], b"GP\x00\x01");
    assert_eq!(i32::from_le_bytes(blob[4..8].try_into().unwrap()), 32633);
    assert_eq!(blob[8], 1);
    assert_eq!(u32::from_le_bytes(blob[9..13].try_into().unwrap()), 1001);
    let f = |k: usize| f64::from_le_bytes(blob[13 + 8 * k..21 + 8 * k].try_into().unwrap());
    assert_eq!([f(0), f(1), f(2)], [t.survey.x, t.survey.y, 1.5]);
    let nf: Option<f64> = db
        .query_row(
            "SELECT measured_x FROM checkpoints WHERE fid = 6",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(nf, None);
}

#[test]
fn csv_and_geojson_carry_every_target() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = result();
    let csv = dir.path().join("cp.csv");
    write(&csv, &r, None).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with("id,role,status,reason,crs,surveyed_x,")
    );
    assert_eq!(lines.count(), 6);
    r.survey_frame = SurveyFrame::Wgs84Enu;
    r.origin = Some(Geodetic {
        lat: -33.0,
        lon: 151.0,
        alt: 20.0,
    });
    let gj = dir.path().join("cp.geojson");
    write(&gj, &r, None).unwrap();
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&gj).unwrap()).unwrap();
    assert_eq!(v["type"], "FeatureCollection");
    let f = v["features"].as_array().unwrap();
    assert_eq!(f.len(), 6);
    let lon = f[0]["geometry"]["coordinates"][0].as_f64().unwrap();
    assert!((lon - 151.0).abs() < 0.01, "{lon}");
    assert!(f[5]["properties"]["measured_lon"].is_null());
    assert_eq!(f[5]["properties"]["status"], "not_found");
}
