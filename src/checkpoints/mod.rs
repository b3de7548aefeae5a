//! Checkpoints out (issue 35): each target's surveyed and measured
//! positions, their difference and its σ, in the survey's coordinate
//! reference system, for the tools surveyors use — a GeoPackage (as USGS
//! delivers checkpoints), GeoJSON (WGS84 by RFC 7946), or CSV.
//!
//! The rows come from a result alone ([`rows`]); each format is one file
//! beside this one. Positions are written in the CRS the survey was given
//! in: a WGS84 survey's as longitude, latitude and ellipsoidal height
//! (EPSG:4979); a survey in projected x, y as given, under the EPSG code the
//! user names (`--checkpoints-crs`; mapgauge cannot know it from the CSV),
//! or as an undefined Cartesian system without one. Differences and σ are
//! metres along the survey's axes (east, north, up for a WGS84 survey).

mod csv_out;
mod geojson;
mod gpkg;

use crate::record::ResultFile;
use crate::survey::{Role, SurveyFrame};
use crate::{Error, Result};
use std::path::Path;

/// The coordinate reference system the rows are in.
#[derive(Debug, Clone, PartialEq)]
pub enum Crs {
    /// WGS84 longitude, latitude (degrees) and ellipsoidal height (m):
    /// EPSG:4979.
    Wgs84,
    /// Projected x, y (m) under this EPSG code, as the user named it.
    Epsg(u32),
    /// x, y (m) of a local system nobody named (or the map's own frame, for
    /// a WGS84 survey placed by an Autoware map's projection): described.
    Undefined(String),
}

impl Crs {
    /// As written beside the numbers: `EPSG:4979`, `EPSG:32633`, or the
    /// description.
    pub fn label(&self) -> String {
        match self {
            Crs::Wgs84 => "EPSG:4979".into(),
            Crs::Epsg(c) => format!("EPSG:{c}"),
            Crs::Undefined(d) => d.clone(),
        }
    }
}

/// One target as a checkpoint.
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    /// Target id.
    pub id: String,
    /// Control or check, when the survey says.
    pub role: Option<Role>,
    /// `ok`, `not_found`, `excluded`, `ambiguous`.
    pub status: String,
    /// Why, when not ok.
    pub reason: Option<String>,
    /// Surveyed position in the CRS (z `None` without heights).
    pub surveyed: [f64; 2],
    /// Surveyed height (m).
    pub surveyed_z: Option<f64>,
    /// Measured position (the map's, aligned onto the survey) in the CRS.
    pub measured: Option<[f64; 2]>,
    /// Measured height (m), when heights were compared.
    pub measured_z: Option<f64>,
    /// Measured − surveyed along the survey's axes (m); dz `None` unless
    /// heights were compared (a 2D fit leaves the map's z uncorrected).
    pub d: Option<[Option<f64>; 3]>,
    /// The absolute error the result reports (m, in its dimension).
    pub error: Option<f64>,
    /// 1-σ of the measured position along the survey's axes (m): its
    /// covariance turned by the alignment.
    pub sigma: Option<[f64; 3]>,
}

/// The result's targets as checkpoints in the survey's CRS. `epsg` names a
/// projected survey's CRS; refused for a WGS84 survey (its CRS is known).
pub fn rows(r: &ResultFile, epsg: Option<u32>) -> Result<(Crs, Vec<Checkpoint>)> {
    let crs = match (r.survey_frame, epsg, r.origin) {
        (SurveyFrame::Local, Some(c), _) => Crs::Epsg(c),
        (SurveyFrame::Local, None, _) => Crs::Undefined(
            "undefined: the survey's x, y (--checkpoints-crs names its EPSG code)".into(),
        ),
        (SurveyFrame::Wgs84Enu, None, Some(_)) => Crs::Wgs84,
        (SurveyFrame::Wgs84Enu, None, None) => {
            return Err(Error::Input(
                "the result has no ENU origin for its WGS84 survey: its checkpoints cannot be given in lat/lon".into(),
            ));
        }
        (SurveyFrame::Wgs84Map, None, _) => Crs::Undefined(
            "undefined: the map's frame (the WGS84 survey placed by map_projector_info.yaml)"
                .into(),
        ),
        (_, Some(c), _) => return Err(wgs84_has_its_crs(c)),
    };
    // Heights are compared only when the alignment fitted them (or none was
    // fitted): a 2D fit leaves the map's own z, whose difference from the
    // survey's means nothing.
    let heights = r.asprs.z.is_some();
    let rot = r.alignment.rotation_matrix;
    let s2 = r.alignment.scale * r.alignment.scale;
    let rows = r
        .targets
        .iter()
        .map(|t| {
            let place = |x: f64, y: f64, z: Option<f64>| -> ([f64; 2], Option<f64>) {
                match (&crs, r.origin) {
                    (Crs::Wgs84, Some(o)) => {
                        let g = o.geodetic_of(&crate::Point::new(x, y, z.unwrap_or(0.0)));
                        ([g.lon, g.lat], z.map(|_| g.alt))
                    }
                    _ => ([x, y], z),
                }
            };
            let (surveyed, surveyed_z) = place(t.survey.x, t.survey.y, t.survey.z);
            let (measured, measured_z) = match t.aligned {
                Some(a) => {
                    let (p, z) = place(a.x, a.y, a.z.filter(|_| heights));
                    (Some(p), z)
                }
                None => (None, None),
            };
            let d = t.aligned.map(|a| {
                [
                    Some(a.x - t.survey.x),
                    Some(a.y - t.survey.y),
                    a.z.zip(t.survey.z).filter(|_| heights).map(|(m, s)| m - s),
                ]
            });
            // The covariance in the survey's axes: s² R Σ Rᵀ.
            let sigma = t.map_covariance.filter(|_| t.aligned.is_some()).map(|c| {
                let mut out = [0.0; 3];
                for (i, o) in out.iter_mut().enumerate() {
                    let mut v = 0.0;
                    for j in 0..3 {
                        for k in 0..3 {
                            v += rot[i][j] * c[j][k] * rot[i][k];
                        }
                    }
                    *o = (s2 * v).max(0.0).sqrt();
                }
                out
            });
            Checkpoint {
                id: t.id.clone(),
                role: t.role,
                status: t.status.clone(),
                reason: t.reason.clone(),
                surveyed,
                surveyed_z,
                measured,
                measured_z,
                d,
                error: t.abs_error,
                sigma,
            }
        })
        .collect();
    Ok((crs, rows))
}

/// The formats, by the file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Gpkg,
    GeoJson,
    Csv,
}

fn format_of(path: &Path) -> Result<Format> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "gpkg" => Ok(Format::Gpkg),
        "geojson" | "json" => Ok(Format::GeoJson),
        "csv" => Ok(Format::Csv),
        _ => Err(Error::Param(format!(
            "--checkpoints {}: name a .gpkg, .geojson or .csv file",
            path.display()
        ))),
    }
}

/// Refuses a path of no known format.
pub fn check_path(path: &Path) -> Result<()> {
    format_of(path).map(|_| ())
}

/// Refuses, before any work, what [`write`] would refuse after it: a path
/// of no known format, GeoJSON for a survey not in WGS84, an EPSG code for
/// a WGS84 survey.
pub fn check(path: &Path, survey_frame: SurveyFrame, epsg: Option<u32>) -> Result<()> {
    if let (Some(c), SurveyFrame::Wgs84Enu | SurveyFrame::Wgs84Map) = (epsg, survey_frame) {
        return Err(wgs84_has_its_crs(c));
    }
    if format_of(path)? == Format::GeoJson && survey_frame != SurveyFrame::Wgs84Enu {
        return Err(Error::Param(format!(
            "--checkpoints {}: GeoJSON positions are WGS84 longitude, latitude (RFC 7946), but this survey is in {}, which mapgauge cannot convert to WGS84: write a .gpkg or .csv, which keep the survey's coordinates",
            path.display(),
            match survey_frame {
                SurveyFrame::Wgs84Map => "the map's projected frame",
                _ => "projected or local x, y",
            }
        )));
    }
    Ok(())
}

fn wgs84_has_its_crs(c: u32) -> Error {
    Error::Param(format!(
        "--checkpoints-crs EPSG:{c}: the survey is in WGS84 lat/lon, so its checkpoints are written in WGS84; the flag names the CRS of a survey in projected x, y"
    ))
}

/// Writes the result's checkpoints to `path` (.gpkg, .geojson or .csv),
/// whole or not at all; returns the CRS they are in.
pub fn write(path: &Path, r: &ResultFile, epsg: Option<u32>) -> Result<Crs> {
    check(path, r.survey_frame, epsg)?;
    let (crs, rows) = rows(r, epsg)?;
    match format_of(path)? {
        Format::Gpkg => gpkg::write(path, &crs, &rows)?,
        Format::GeoJson => {
            crate::record::write_atomic(path, geojson::text(&rows).as_bytes())?;
        }
        Format::Csv => crate::record::write_atomic(path, &csv_out::bytes(&crs, &rows)?)?,
    }
    Ok(crs)
}

/// Parses `EPSG:32633` (or `32633`) for `--checkpoints-crs`.
pub fn parse_epsg(s: &str) -> Result<u32> {
    let t = s.trim();
    let code = t
        .strip_prefix("EPSG:")
        .or_else(|| t.strip_prefix("epsg:"))
        .unwrap_or(t);
    match code.parse::<u32>() {
        Ok(c) if (1024..=32767).contains(&c) => Ok(c),
        _ => Err(Error::Param(format!(
            "`{s}` is not an EPSG code (EPSG:1024-32767, e.g. EPSG:32633 for UTM zone 33N)"
        ))),
    }
}

#[cfg(test)]
mod tests;
