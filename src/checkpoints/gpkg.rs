//! Checkpoints as an OGC GeoPackage (1.2): one point layer `checkpoints`
//! at the surveyed positions, in the survey's CRS, read by GDAL/QGIS/ArcGIS
//! as the USGS delivers checkpoints. SQLite through `rusqlite` (bundled: no
//! system library); the GeoPackage tables and the point blobs by hand, as
//! the standard lays them out (a point needs no geometry library).

use super::{Checkpoint, Crs};
use crate::{Error, Result};
use rusqlite::{Connection, params};
use std::path::Path;

/// `PRAGMA application_id` of a GeoPackage: "GPKG".
const APPLICATION_ID: i32 = 0x4750_4B47;
/// GeoPackage 1.2.0 (`PRAGMA user_version`): what GDAL 3.6 reads without
/// a warning; the tables written here are the same in 1.3 and 1.4.
const USER_VERSION: i32 = 10200;
/// The WGS84 row every GeoPackage holds (the standard's own definition).
const WGS84_WKT: &str = "GEOGCS[\"WGS 84\",DATUM[\"WGS_1984\",SPHEROID[\"WGS 84\",6378137,298.257223563,AUTHORITY[\"EPSG\",\"7030\"]],AUTHORITY[\"EPSG\",\"6326\"]],PRIMEM[\"Greenwich\",0,AUTHORITY[\"EPSG\",\"8901\"]],UNIT[\"degree\",0.0174532925199433,AUTHORITY[\"EPSG\",\"9122\"]],AUTHORITY[\"EPSG\",\"4326\"]]";

/// Writes `rows` to `path` through a temporary file beside it, renamed
/// over `path` only once whole.
pub(super) fn write(path: &Path, crs: &Crs, rows: &[Checkpoint]) -> Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "checkpoints.gpkg".into());
    let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
    let _ = std::fs::remove_file(&tmp);
    let done = fill(&tmp, crs, rows)
        .and_then(|()| std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e)));
    if done.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    done
}

fn fill(file: &Path, crs: &Crs, rows: &[Checkpoint]) -> Result<()> {
    let sql = |e: rusqlite::Error| Error::Input(format!("{}: GeoPackage: {e}", file.display()));
    let mut db = Connection::open(file).map_err(sql)?;
    db.pragma_update(None, "application_id", APPLICATION_ID)
        .map_err(sql)?;
    db.pragma_update(None, "user_version", USER_VERSION)
        .map_err(sql)?;
    let tx = db.transaction().map_err(sql)?;
    tx.execute_batch(
        "CREATE TABLE gpkg_spatial_ref_sys (srs_name TEXT NOT NULL, srs_id INTEGER PRIMARY KEY, \
           organization TEXT NOT NULL, organization_coordsys_id INTEGER NOT NULL, \
           definition TEXT NOT NULL, description TEXT);
         CREATE TABLE gpkg_contents (table_name TEXT NOT NULL PRIMARY KEY, data_type TEXT NOT NULL, \
           identifier TEXT UNIQUE, description TEXT DEFAULT '', last_change DATETIME NOT NULL, \
           min_x DOUBLE, min_y DOUBLE, max_x DOUBLE, max_y DOUBLE, srs_id INTEGER, \
           CONSTRAINT fk_gc_r_srs_id FOREIGN KEY (srs_id) REFERENCES gpkg_spatial_ref_sys(srs_id));
         CREATE TABLE gpkg_geometry_columns (table_name TEXT NOT NULL, column_name TEXT NOT NULL, \
           geometry_type_name TEXT NOT NULL, srs_id INTEGER NOT NULL, z TINYINT NOT NULL, m TINYINT NOT NULL, \
           CONSTRAINT pk_geom_cols PRIMARY KEY (table_name, column_name), \
           CONSTRAINT fk_gc_tn FOREIGN KEY (table_name) REFERENCES gpkg_contents(table_name), \
           CONSTRAINT fk_gc_srs FOREIGN KEY (srs_id) REFERENCES gpkg_spatial_ref_sys (srs_id));",
    )
    .map_err(sql)?;
    // OR IGNORE: a user-named EPSG:4326 is the row every GeoPackage holds.
    let mut srs = tx
        .prepare("INSERT OR IGNORE INTO gpkg_spatial_ref_sys VALUES (?1, ?2, ?3, ?4, ?5, ?6)")
        .map_err(sql)?;
    srs.execute(params![
        "Undefined cartesian SRS",
        -1,
        "NONE",
        -1,
        "undefined",
        "undefined cartesian coordinate reference system"
    ])
    .map_err(sql)?;
    srs.execute(params![
        "Undefined geographic SRS",
        0,
        "NONE",
        0,
        "undefined",
        "undefined geographic coordinate reference system"
    ])
    .map_err(sql)?;
    srs.execute(params![
        "WGS 84 geodetic",
        4326,
        "EPSG",
        4326,
        WGS84_WKT,
        "longitude/latitude coordinates in decimal degrees on the WGS 84 spheroid"
    ])
    .map_err(sql)?;
    // Readers (GDAL) take the system from its EPSG code.
    let srs_id: i64 = match crs {
        Crs::Wgs84 => {
            srs.execute(params![
                "WGS 84 (3D)",
                4979,
                "EPSG",
                4979,
                "undefined",
                "longitude, latitude (degrees), ellipsoidal height (m)"
            ])
            .map_err(sql)?;
            4979
        }
        Crs::Epsg(c) => {
            srs.execute(params![
                format!("EPSG:{c}"),
                c,
                "EPSG",
                c,
                "undefined",
                "as named by --checkpoints-crs"
            ])
            .map_err(sql)?;
            i64::from(*c)
        }
        Crs::Undefined(_) => -1,
    };
    drop(srs);
    let has_z = !rows.is_empty() && rows.iter().all(|c| c.surveyed_z.is_some());
    let (xs, ys): (Vec<f64>, Vec<f64>) =
        rows.iter().map(|c| (c.surveyed[0], c.surveyed[1])).unzip();
    let lo = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let axes = match crs {
        Crs::Wgs84 => ["lon", "lat", "h"],
        _ => ["x", "y", "z"],
    };
    tx.execute_batch(&format!(
        "CREATE TABLE checkpoints (fid INTEGER PRIMARY KEY AUTOINCREMENT, geom POINT, \
           id TEXT NOT NULL, role TEXT, status TEXT NOT NULL, reason TEXT, \
           measured_{0} REAL, measured_{1} REAL, measured_{2} REAL, \
           dx_m REAL, dy_m REAL, dz_m REAL, error_m REAL, \
           sigma_x_m REAL, sigma_y_m REAL, sigma_z_m REAL);",
        axes[0], axes[1], axes[2]
    ))
    .map_err(sql)?;
    let stamp = crate::report::utc_string(crate::report::report_time());
    // `YYYY-MM-DD HH:MM:SS UTC` → the standard's `YYYY-MM-DDTHH:MM:SS.000Z`.
    let stamp = format!("{}T{}.000Z", &stamp[..10], &stamp[11..19]);
    let finite = |v: f64| v.is_finite().then_some(v);
    tx.execute(
        "INSERT INTO gpkg_contents (table_name, data_type, identifier, description, last_change, \
           min_x, min_y, max_x, max_y, srs_id) VALUES ('checkpoints', 'features', 'checkpoints', ?1, ?2, ?3, ?4, ?5, ?6, ?7)",
        params![
            format!("mapgauge checkpoints: surveyed positions, measured positions and differences; CRS {}", crs.label()),
            stamp,
            finite(lo(&xs)),
            finite(lo(&ys)),
            finite(hi(&xs)),
            finite(hi(&ys)),
            srs_id
        ],
    )
    .map_err(sql)?;
    tx.execute(
        "INSERT INTO gpkg_geometry_columns VALUES ('checkpoints', 'geom', 'POINT', ?1, ?2, 0)",
        params![srs_id, i32::from(has_z)],
    )
    .map_err(sql)?;
    let mut ins = tx
        .prepare(
            "INSERT INTO checkpoints (geom, id, role, status, reason, measured_x, measured_y, measured_z, \
               dx_m, dy_m, dz_m, error_m, sigma_x_m, sigma_y_m, sigma_z_m) \
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15)"
                .replace("measured_x, measured_y, measured_z", &format!("measured_{}, measured_{}, measured_{}", axes[0], axes[1], axes[2]))
                .as_str(),
        )
        .map_err(sql)?;
    for c in rows {
        let z = if has_z { c.surveyed_z } else { None };
        let d = c.d.unwrap_or([None; 3]);
        let s = c.sigma.map(|s| s.map(Some)).unwrap_or([None; 3]);
        ins.execute(params![
            point_blob(srs_id as i32, c.surveyed, z),
            c.id,
            c.role.map(|r| format!("{r:?}").to_lowercase()),
            c.status,
            c.reason,
            c.measured.map(|m| m[0]),
            c.measured.map(|m| m[1]),
            c.measured_z,
            d[0],
            d[1],
            d[2],
            c.error,
            s[0],
            s[1],
            s[2],
        ])
        .map_err(sql)?;
    }
    drop(ins);
    tx.commit().map_err(sql)?;
    db.close().map_err(|(_, e)| sql(e))
}

/// A GeoPackage geometry blob of one point: the `GP` header (version 0,
/// little-endian, no envelope), the SRS id, then ISO WKB (Point or Point Z).
fn point_blob(srs_id: i32, xy: [f64; 2], z: Option<f64>) -> Vec<u8> {
    let mut b = Vec::with_capacity(8 + 5 + 24);
    b.extend_from_slice(b"GP");
    b.push(0);
    b.push(0b0000_0001);
    b.extend_from_slice(&srs_id.to_le_bytes());
    b.push(1);
    let kind: u32 = if z.is_some() { 1001 } else { 1 };
    b.extend_from_slice(&kind.to_le_bytes());
    b.extend_from_slice(&xy[0].to_le_bytes());
    b.extend_from_slice(&xy[1].to_le_bytes());
    if let Some(z) = z {
        b.extend_from_slice(&z.to_le_bytes());
    }
    b
}
