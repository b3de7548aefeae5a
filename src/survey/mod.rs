//! Survey files (the ground truth) and estimate files (positions found in the map).
//!
//! Both are CSV with a header line; `#` starts a comment line. Every bad row is
//! reported with its file and line, so a 200-target survey can be fixed quickly.

mod geodesy;
mod projection;

pub use geodesy::{Geodetic, WGS84_A, WGS84_E2, WGS84_F};
pub use projection::Projector;

use crate::{Error, Point, Result};
use serde::{Deserialize, Serialize};
use std::collections::HashSet;
use std::path::Path;

/// How a survey's coordinates were given, so reports say which frame errors are in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SurveyFrame {
    /// `x, y[, z]` already in a local metric frame (ENU about a base, UTM/TM, ...).
    Local,
    /// `lat, lon[, alt]` in WGS84, converted to ENU about [`Survey::origin`].
    Wgs84Enu,
    /// `lat, lon[, alt]` in WGS84, placed in the map's own frame by the map's
    /// projection (an Autoware map's `map_projector_info.yaml`).
    Wgs84Map,
}

/// Whether a target may be used to fit the alignment or only to check it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Used to fit the alignment.
    Control,
    /// Held out: scored with an alignment fitted without it (an honest error).
    Check,
}

/// One surveyed target.
#[derive(Debug, Clone, PartialEq)]
pub struct SurveyTarget {
    /// Name, matched against estimate ids.
    pub id: String,
    /// Position in the survey frame as given (antenna position; z = 0 when absent).
    pub position: Point,
    /// Whether the survey gives a height for this target.
    pub has_z: bool,
    /// Control or check, when the survey says.
    pub role: Option<Role>,
    /// Metres from the antenna down to the target's reference height (0 if absent).
    pub antenna_height: f64,
    /// 1-based line in the survey file, for messages.
    pub line: u64,
}

impl SurveyTarget {
    /// The target's reference point: the antenna position lowered by the antenna
    /// height. This is what map estimates are compared with.
    pub fn reference(&self) -> Point {
        Point::new(
            self.position.x,
            self.position.y,
            self.position.z - self.antenna_height,
        )
    }
}

/// A whole survey: the ground truth every map is measured against.
#[derive(Debug, Clone, PartialEq)]
pub struct Survey {
    /// Targets in file order.
    pub targets: Vec<SurveyTarget>,
    /// The frame the positions are in.
    pub frame: SurveyFrame,
    /// ENU origin, for [`SurveyFrame::Wgs84Enu`].
    pub origin: Option<Geodetic>,
}

impl Survey {
    /// A local-frame survey of `positions`, ids `t1`, `t2`, … (the unit
    /// tests' scenes).
    #[cfg(test)]
    pub(crate) fn local(positions: &[(f64, f64, f64)], has_z: bool) -> Survey {
        Survey {
            targets: positions
                .iter()
                .enumerate()
                .map(|(i, p)| SurveyTarget {
                    id: format!("t{}", i + 1),
                    position: Point::new(p.0, p.1, p.2),
                    has_z,
                    role: None,
                    antenna_height: 0.0,
                    line: i as u64 + 2,
                })
                .collect(),
            frame: SurveyFrame::Local,
            origin: None,
        }
    }

    /// True when every target has a height (3D metrics are possible).
    pub fn has_z(&self) -> bool {
        !self.targets.is_empty() && self.targets.iter().all(|t| t.has_z)
    }
    /// Looks a target up by id.
    pub fn get(&self, id: &str) -> Option<&SurveyTarget> {
        self.targets.iter().find(|t| t.id == id)
    }
}

/// How to read a survey.
#[derive(Debug, Clone, Default)]
pub struct SurveyOptions {
    /// ENU origin for lat/lon surveys; `None` = the first target (its altitude too).
    pub origin: Option<Geodetic>,
}

/// Why a target has no usable estimate, or the estimate itself.
#[derive(Debug, Clone, PartialEq)]
pub enum EstimateStatus {
    /// The target was located at this map-frame position.
    Found(Point),
    /// The target could not be located (reported, never scored).
    NotFound {
        /// Human-readable cause.
        reason: String,
    },
    /// The target was deliberately left out (reported, never scored).
    Excluded {
        /// Human-readable cause.
        reason: String,
    },
    /// The target was seen, but as two copies (mapped twice): no one
    /// position is its (reported, never scored).
    Ambiguous {
        /// Human-readable cause, with both copies.
        reason: String,
    },
}

/// A target position estimated in the map frame (from `locate`, `eval`, or a file).
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// Target name, matched against the survey.
    pub id: String,
    /// The position, or why there is none.
    pub status: EstimateStatus,
    /// Whether the estimate has a meaningful z (3D metrics need it).
    pub has_z: bool,
}

impl Estimate {
    /// A located target with a full 3D position.
    pub fn found(id: impl Into<String>, p: Point) -> Self {
        Estimate {
            id: id.into(),
            status: EstimateStatus::Found(p),
            has_z: true,
        }
    }
}

/// A header-indexed CSV reader with file/line error reporting.
struct Table {
    path: std::path::PathBuf,
    headers: Vec<String>,
    /// The header's line in the file (comments may come first).
    header_line: u64,
    rows: Vec<(u64, csv::StringRecord)>,
}

/// The field separator of a survey or estimates table, from its first line
/// that is neither blank nor a comment: `;` or a tab when that line has no
/// comma but has those (spreadsheet exports in many locales), else `,`.
fn sniff_delimiter(bytes: &[u8]) -> u8 {
    let first = bytes
        .split(|b| *b == b'\n')
        .map(|l| l.trim_ascii())
        .find(|l| !l.is_empty() && *l != b",")
        .unwrap_or(b"");
    if first.contains(&b',') {
        b','
    } else if first.contains(&b';') {
        b';'
    } else if first.contains(&b'\t') {
        b'\t'
    } else {
        b','
    }
}

impl Table {
    fn read(path: &Path) -> Result<Table> {
        let raw = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        // Blank out comment lines but keep their newlines, so csv's line numbers
        // stay those of the file (csv counts neither its comments nor blank lines;
        // a lone comma is a record of empty fields, skipped below).
        let mut bytes = Vec::with_capacity(raw.len());
        for l in raw.split_inclusive(|b| *b == b'\n') {
            let t = l.trim_ascii_start();
            if t.is_empty() && l.ends_with(b"\n") || t.starts_with(b"#") {
                bytes.extend_from_slice(b",\n");
            } else {
                bytes.extend_from_slice(l);
            }
        }
        let delimiter = sniff_delimiter(&bytes);
        // A blanked comment line is a lone separator: keep it one for `;`/tab files.
        if delimiter != b',' {
            for l in bytes.split_mut(|b| *b == b'\n') {
                if l == b"," {
                    l[0] = delimiter;
                }
            }
        }
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .delimiter(delimiter)
            .trim(csv::Trim::All)
            .from_reader(bytes.as_slice());
        let mut headers = None;
        let mut header_line = 1;
        let mut rows = Vec::new();
        for rec in rdr.records() {
            let rec = rec.map_err(|e| {
                let line = e.position().map(|p| p.line()).unwrap_or(0);
                Error::table(path, line, format!("not valid CSV: {e}"))
            })?;
            let line = rec.position().map(|p| p.line()).unwrap_or(0);
            if rec.iter().all(|f| f.is_empty()) {
                continue;
            }
            if headers.is_none() {
                // A first row of numbers is data, not names: say so rather than
                // guess which columns they are.
                if rec.len() >= 3 && rec.iter().skip(1).all(|f| f.parse::<f64>().is_ok()) {
                    return Err(Error::table(
                        path,
                        line,
                        format!(
                            "no header line (this row holds numbers: `{}`); the first line must name the columns, e.g. `id,x,y,z` (local metres) or `id,lat,lon,alt` (WGS84)",
                            rec.iter().collect::<Vec<_>>().join(",")
                        ),
                    ));
                }
                let h: Vec<String> = rec.iter().map(|f| f.to_ascii_lowercase()).collect();
                let mut seen = HashSet::new();
                for name in &h {
                    if !name.is_empty() && !seen.insert(name.clone()) {
                        return Err(Error::table(
                            path,
                            line,
                            format!("column `{name}` appears twice"),
                        ));
                    }
                }
                headers = Some(h);
                header_line = line;
            } else {
                rows.push((line, rec));
            }
        }
        let headers = headers.ok_or_else(|| Error::table(path, 0, "empty file: no header line"))?;
        Ok(Table {
            path: path.to_path_buf(),
            headers,
            header_line,
            rows,
        })
    }

    fn col(&self, names: &[&str]) -> Option<usize> {
        self.headers
            .iter()
            .position(|h| names.contains(&h.as_str()))
    }

    fn field<'a>(
        &self,
        line: u64,
        rec: &'a csv::StringRecord,
        col: usize,
        name: &str,
    ) -> Result<&'a str> {
        match rec.get(col) {
            Some(s) if !s.is_empty() => Ok(s),
            _ => Err(Error::table(
                &self.path,
                line,
                format!("missing value in column `{name}`"),
            )),
        }
    }

    fn number(&self, line: u64, rec: &csv::StringRecord, col: usize, name: &str) -> Result<f64> {
        let s = self.field(line, rec, col, name)?;
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(Error::table(
                &self.path,
                line,
                format!("column `{name}`: `{s}` is not a finite number"),
            )),
        }
    }

    fn opt_number(
        &self,
        line: u64,
        rec: &csv::StringRecord,
        col: Option<usize>,
        name: &str,
    ) -> Result<Option<f64>> {
        match col {
            Some(c) if rec.get(c).is_some_and(|s| !s.is_empty()) => {
                self.number(line, rec, c, name).map(Some)
            }
            _ => Ok(None),
        }
    }

    fn require(&self, names: &[&str]) -> Result<usize> {
        self.col(names).ok_or_else(|| {
            Error::table(
                &self.path,
                self.header_line,
                format!(
                    "missing column `{}` (header has: {})",
                    names[0],
                    self.headers.join(",")
                ),
            )
        })
    }
}

const ID: &[&str] = &["id", "name", "target"];
const X: &[&str] = &["x", "east", "easting", "e"];
const Y: &[&str] = &["y", "north", "northing", "n"];
const Z: &[&str] = &["z", "up", "u", "height"];
const LAT: &[&str] = &["lat", "latitude"];
const LON: &[&str] = &["lon", "lng", "long", "longitude"];
const ALT: &[&str] = &["alt", "altitude", "h", "ellipsoidal_height"];
const ROLE: &[&str] = &["role"];
const ANTENNA: &[&str] = &["antenna_height", "antenna"];

/// Height columns under names mapgauge does not read.
const ELEVATION: &[&str] = &[
    "elevation",
    "elev",
    "orthometric_height",
    "ortho_height",
    "hgt",
];

/// The survey column that header `h` (lowercase) most likely meant, when it
/// is not itself one: the same letters but for separators (`antenna height`),
/// a name with a unit after it (`alt_m`, `lat (deg)`), or one of the long
/// names (seven letters or more: `antenna_height`, `latitude`, `easting`...)
/// with up to two typos and at most one letter more or less. Other extra
/// columns (`description`, `note`, `weight`, `easting_sd`) are ignored.
fn misspelt_column(h: &str) -> Option<&'static str> {
    let known = || {
        [ID, X, Y, Z, LAT, LON, ALT, ROLE, ANTENNA]
            .into_iter()
            .flatten()
            .copied()
    };
    if h.is_empty() || known().any(|k| k == h) {
        return None;
    }
    let norm = |s: &str| -> String { s.chars().filter(|c| c.is_ascii_alphanumeric()).collect() };
    // A unit after a separator: `alt_m`, `z [m]`, `lat(deg)`.
    let stem = ["metres", "meters", "degrees", "deg", "m"]
        .iter()
        .find_map(|u| {
            let t = h.trim_end_matches([')', ']', ' ']);
            let head = t.strip_suffix(u)?;
            let head2 = head.trim_end_matches(['_', '-', ' ', '(', '[']);
            (head2.len() < head.len()).then_some(head2)
        });
    let n = norm(h);
    known().find(|k| {
        let nk = norm(k);
        nk == n
            || stem.is_some_and(|s| norm(s) == nk)
            || (nk.len() >= 7 && n.len().abs_diff(nk.len()) <= 1 && levenshtein(&n, &nk) <= 2)
    })
}

/// Edit distance between two short ASCII strings.
fn levenshtein(a: &str, b: &str) -> usize {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, &ca) in a.iter().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// Reads a survey CSV: `id` and either `x,y[,z]` (local metres) or `lat,lon[,alt]`
/// (WGS84 degrees, converted to ENU about `opts.origin` or the first target);
/// optional `role` (control|check) and `antenna_height`.
pub fn read_survey(path: &Path, opts: &SurveyOptions) -> Result<Survey> {
    read_survey_for_map(path, opts, None)
}

/// [`read_survey`] for a map with a projection file (an Autoware map's
/// `map_projector_info.yaml`, see [`crate::cloud::TiledMap::projector`]): a
/// WGS84 survey is placed in the map's frame through it
/// ([`SurveyFrame::Wgs84Map`]), so the map needs no fitted frame. A local
/// survey is read as it is. `opts.origin` is refused with a projection: the
/// map says where its origin is.
pub fn read_survey_for_map(
    path: &Path,
    opts: &SurveyOptions,
    projector: Option<&Path>,
) -> Result<Survey> {
    let t = Table::read(path)?;
    // A misspelt column (`antena_height`, `alt_m`) would be ignored like any
    // extra column, and its values lost without a word: refuse it instead.
    for h in &t.headers {
        if let Some(meant) = misspelt_column(h) {
            let caveat = if ANTENNA.contains(&meant) {
                " (coordinates already reduced to the ground mark, as many GNSS exports give them, must not also give an antenna height)"
            } else {
                ""
            };
            return Err(Error::table(
                path,
                t.header_line,
                format!(
                    "column `{h}` is not one mapgauge reads; did you mean `{meant}`? Rename it for its values to be used, or remove it{caveat}"
                ),
            ));
        }
    }
    let id_c = t.require(ID)?;
    let (xy, ll) = ((t.col(X), t.col(Y)), (t.col(LAT), t.col(LON)));
    let geodetic = match (xy, ll) {
        ((Some(_), Some(_)), (Some(_), Some(_))) => {
            return Err(Error::table(
                path,
                t.header_line,
                "both x,y and lat,lon columns: keep only one kind",
            ));
        }
        ((Some(_), Some(_)), _) => false,
        (_, (Some(_), Some(_))) => true,
        _ => {
            return Err(Error::table(
                path,
                t.header_line,
                format!(
                    "missing position columns: need x,y[,z] or lat,lon[,alt] (header has: {})",
                    t.headers.join(",")
                ),
            ));
        }
    };
    // Heights under the other kind's names, or under a name read by neither,
    // would be dropped without a word.
    let (theirs, ours) = if geodetic {
        (
            Z,
            "`alt` (or altitude, h, ellipsoidal_height) in a lat,lon survey",
        )
    } else {
        (ALT, "`z` (or up, height) in an x,y survey")
    };
    if let Some(h) = t
        .headers
        .iter()
        .find(|h| theirs.contains(&h.as_str()) || ELEVATION.contains(&h.as_str()))
    {
        return Err(Error::table(
            path,
            t.header_line,
            format!(
                "column `{h}` holds heights mapgauge does not read under that name: heights go in {ours}; rename it, or remove it"
            ),
        ));
    }
    let (c1, c2, c3, n1, n2, n3) = if geodetic {
        (
            t.require(LAT)?,
            t.require(LON)?,
            t.col(ALT),
            "lat",
            "lon",
            "alt",
        )
    } else {
        (t.require(X)?, t.require(Y)?, t.col(Z), "x", "y", "z")
    };
    let role_c = t.col(ROLE);
    let ah_c = t.col(ANTENNA);
    let mut seen = HashSet::new();
    let mut targets = Vec::with_capacity(t.rows.len());
    let mut geo = Vec::new();
    for (line, rec) in &t.rows {
        let line = *line;
        let id = t.field(line, rec, id_c, "id")?.to_string();
        if !seen.insert(id.clone()) {
            return Err(Error::table(
                path,
                line,
                format!("duplicate target id `{id}`"),
            ));
        }
        let a = t.number(line, rec, c1, n1)?;
        let b = t.number(line, rec, c2, n2)?;
        let c = t.opt_number(line, rec, c3, n3)?;
        if geodetic {
            if !(-90.0..=90.0).contains(&a) {
                return Err(Error::table(
                    path,
                    line,
                    format!("latitude {a} is outside -90..90"),
                ));
            }
            if !(-360.0..=360.0).contains(&b) {
                return Err(Error::table(
                    path,
                    line,
                    format!("longitude {b} is outside -360..360"),
                ));
            }
            geo.push(Geodetic {
                lat: a,
                lon: b,
                alt: c.unwrap_or(0.0),
            });
        }
        let role = match role_c.and_then(|c| rec.get(c)).filter(|s| !s.is_empty()) {
            None => None,
            Some(s) => match s.to_ascii_lowercase().as_str() {
                "control" | "gcp" => Some(Role::Control),
                "check" | "checkpoint" => Some(Role::Check),
                _ => {
                    return Err(Error::table(
                        path,
                        line,
                        format!("role `{s}` is neither control nor check"),
                    ));
                }
            },
        };
        let antenna_height = t
            .opt_number(line, rec, ah_c, "antenna_height")?
            .unwrap_or(0.0);
        targets.push(SurveyTarget {
            id,
            position: Point::new(a, b, c.unwrap_or(0.0)),
            has_z: c.is_some(),
            role,
            antenna_height,
            line,
        });
    }
    if targets.is_empty() {
        return Err(Error::table(path, 0, "no targets in survey"));
    }
    if let (true, Some(pf)) = (geodetic, projector) {
        if opts.origin.is_some() {
            return Err(Error::Param(format!(
                "--origin: the map's {} places the survey; drop --origin",
                pf.display()
            )));
        }
        let proj = Projector::read(pf, targets.iter().any(|t| t.has_z))?;
        for (t, g) in targets.iter_mut().zip(&geo) {
            let p = proj.forward(g);
            t.position = if t.has_z {
                p
            } else {
                Point::new(p.x, p.y, 0.0)
            };
        }
        return Ok(Survey {
            targets,
            frame: SurveyFrame::Wgs84Map,
            origin: None,
        });
    }
    let (frame, origin) = if geodetic {
        let origin = opts.origin.unwrap_or(geo[0]);
        for (t, g) in targets.iter_mut().zip(&geo) {
            let enu = origin.enu_of(g);
            t.position = if t.has_z {
                enu
            } else {
                Point::new(enu.x, enu.y, 0.0)
            };
        }
        (SurveyFrame::Wgs84Enu, Some(origin))
    } else {
        (SurveyFrame::Local, None)
    };
    Ok(Survey {
        targets,
        frame,
        origin,
    })
}

/// Reads an estimates CSV `id,x,y[,z]` (map frame; extra columns ignored).
/// Empty x/y cells mean "not found" (the reason column `reason`, if any, is kept).
/// `eval`'s own `targets.csv` is read too: without `x`/`y` columns its
/// `map_x,map_y,map_z` are the estimates, and a row whose `status` is
/// `not_found` is not found whatever its cells hold.
pub fn read_estimates(path: &Path) -> Result<Vec<Estimate>> {
    let t = Table::read(path)?;
    let id_c = t.require(ID)?;
    let from_eval = t.col(X).is_none() && t.col(&["map_x"]).is_some();
    let (x_c, y_c, z_c) = if from_eval {
        (
            t.require(&["map_x"])?,
            t.require(&["map_y"])?,
            t.col(&["map_z"]),
        )
    } else {
        (t.require(X)?, t.require(Y)?, t.col(Z))
    };
    let status_c = t.col(&["status"]).filter(|_| from_eval);
    let reason_c = t.col(&["reason"]);
    let mut seen = HashSet::new();
    let mut out = Vec::with_capacity(t.rows.len());
    for (line, rec) in &t.rows {
        let line = *line;
        let id = t.field(line, rec, id_c, "id")?.to_string();
        if !seen.insert(id.clone()) {
            return Err(Error::table(
                path,
                line,
                format!("duplicate target id `{id}`"),
            ));
        }
        let empty = |c: usize| rec.get(c).is_none_or(|s| s.is_empty());
        let status = status_c.and_then(|c| rec.get(c));
        // (An excluded row keeps its position: `errors` judges it again.)
        let not_found = matches!(status, Some("not_found" | "ambiguous"));
        if not_found || (empty(x_c) && empty(y_c)) {
            let reason = reason_c
                .and_then(|c| rec.get(c))
                .filter(|s| !s.is_empty())
                .unwrap_or("no position in estimates file")
                .to_string();
            // A target eval saw twice stays ambiguous.
            let status = match status {
                Some("ambiguous") => EstimateStatus::Ambiguous { reason },
                _ => EstimateStatus::NotFound { reason },
            };
            out.push(Estimate {
                id,
                status,
                has_z: false,
            });
            continue;
        }
        let x = t.number(line, rec, x_c, "x")?;
        let y = t.number(line, rec, y_c, "y")?;
        let z = t.opt_number(line, rec, z_c, "z")?;
        out.push(Estimate {
            id,
            status: EstimateStatus::Found(Point::new(x, y, z.unwrap_or(0.0))),
            has_z: z.is_some(),
        });
    }
    if out.is_empty() {
        return Err(Error::table(path, 0, "no estimates in file"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn file(content: &str) -> tempfile::NamedTempFile {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        f.write_all(content.as_bytes()).unwrap();
        f
    }

    fn err(content: &str) -> String {
        let f = file(content);
        read_survey(f.path(), &SurveyOptions::default())
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn a_misspelt_column_is_refused_and_extra_columns_are_not() {
        for (head, meant) in [
            ("id,x,y,z,antena_height", "antenna_height"),
            ("id,x,y,z,antenna height", "antenna_height"),
            ("id,x,y,z_m", "z"),
            ("id,lat,lon,alt_m", "alt"),
            ("id,lat,lon,alt (m)", "alt"),
            ("id,lattitude,lon", "latitude"),
            ("id,latitude,longitud", "longitude"),
            ("id,x,y,z,antena", "antenna"),
            ("id,easting,northing,height [m]", "height"),
        ] {
            let cols = head.split(',').count();
            let row = vec!["1"; cols].join(",");
            let e = err(&format!("# comment first\n{head}\n{row}\n"));
            assert!(
                e.contains(":2: column `") && e.contains(&format!("did you mean `{meant}`?")),
                "{head}: {e}"
            );
        }
        assert!(
            err("id,x,y,antenna height\n1,2,3,4\n")
                .contains("must not also give an antenna height")
        );
        // Columns a survey export carries that mapgauge does not read.
        let f = file(
            "id,x,y,z,description,notes,note,code,type,date,time,sigma_x,hrms,status,geoid_height,weight,names,easting_sd,northing rms,along,east2,rol\nT1,1,2,3,a,b,c,d,e,f,g,0.01,0.02,fix,40,1,n,0.1,0.1,a,b,c\n",
        );
        let s = read_survey(f.path(), &SurveyOptions::default()).unwrap();
        assert_eq!(s.targets.len(), 1);
        // Heights under the other kind of survey's names, or under a name
        // read by neither, would be lost: refused, saying where they go.
        for (head, want) in [
            ("id,lat,lon,height", "heights go in `alt`"),
            ("id,lat,lon,z", "heights go in `alt`"),
            ("id,x,y,alt", "heights go in `z`"),
            ("id,x,y,elevation", "heights go in `z`"),
            ("id,lat,lon,elev", "heights go in `alt`"),
        ] {
            let e = err(&format!("{head}\n1,2,3,4\n"));
            assert!(
                e.contains(":1: column `") && e.contains(want),
                "{head}: {e}"
            );
        }
    }

    #[test]
    fn local_survey_with_comments_roles_and_antenna() {
        let f = file(
            "# site A\nid,x,y,z,role,antenna_height\n# base at pillar\nT1,350000.123456,4150000.654321,12.5,control,1.8\nT2,350010,4150005,13,check,\n",
        );
        let s = read_survey(f.path(), &SurveyOptions::default()).unwrap();
        assert_eq!(s.frame, SurveyFrame::Local);
        assert_eq!(s.targets.len(), 2);
        let t1 = &s.targets[0];
        assert_eq!(t1.id, "T1");
        assert_eq!(t1.position.x, 350000.123456);
        assert_eq!(t1.position.y, 4150000.654321);
        assert_eq!(t1.role, Some(Role::Control));
        assert!((t1.reference().z - 10.7).abs() < 1e-12);
        assert_eq!(t1.line, 4);
        assert_eq!(s.targets[1].antenna_height, 0.0);
        assert!(s.has_z());
    }

    #[test]
    fn geodetic_survey_about_first_target_and_given_origin() {
        let f = file("id,lat,lon,alt\na,36.0,127.0,50\nb,36.001,127.0,51\n");
        let s = read_survey(f.path(), &SurveyOptions::default()).unwrap();
        assert_eq!(s.frame, SurveyFrame::Wgs84Enu);
        assert!(s.targets[0].position.coords.norm() < 1e-9);
        let b = s.targets[1].position;
        assert!(
            (b.y - 110.95).abs() < 0.1 && b.x.abs() < 1e-6 && (b.z - 1.0).abs() < 0.01,
            "{b}"
        );
        let o = Geodetic {
            lat: 36.0,
            lon: 127.0,
            alt: 0.0,
        };
        let s2 = read_survey(f.path(), &SurveyOptions { origin: Some(o) }).unwrap();
        assert!((s2.targets[0].position.z - 50.0).abs() < 1e-6);
        assert_eq!(s2.origin, Some(o));
    }

    #[test]
    fn bad_surveys_name_file_and_line() {
        let e = err("id,x,y\n1,0,0\n\n# c\n\n1,1,1\n");
        assert!(e.contains(":6:") && e.contains("duplicate"), "{e}");
        let e = err("id,x\n1,0\n");
        assert!(
            e.contains(":1:") && e.contains("missing position columns"),
            "{e}"
        );
        let e = err("x,y\n1,0\n");
        assert!(e.contains("missing column `id`"), "{e}");
        let e = err("id,x,y\n1,0,0\n2,abc,0\n");
        assert!(
            e.contains(":3:") && e.contains("`abc` is not a finite number"),
            "{e}"
        );
        let e = err("id,x,y\n1,0,0\n2,5\n");
        assert!(
            e.contains(":3:") && e.contains("missing value in column `y`"),
            "{e}"
        );
        let e = err("id,lat,lon\n1,91,0\n");
        assert!(e.contains(":2:") && e.contains("latitude"), "{e}");
        let e = err("id,x,y,role\n1,0,0,boss\n");
        assert!(e.contains(":2:") && e.contains("role"), "{e}");
        let e = err("# only a comment\n");
        assert!(e.contains("no header"), "{e}");
        let e = err("id,x,y\n");
        assert!(e.contains("no targets"), "{e}");
        let e = err("id,x,y,lat,lon\n1,0,0,0,0\n");
        assert!(e.contains("both"), "{e}");
        let e = err("id,x,y\n1,NaN,0\n");
        assert!(e.contains("not a finite number"), "{e}");
    }

    #[test]
    fn estimates_reader() {
        let f = file("id,x,y,z,score\n1,1.5,2.5,3.5,0.9\n2,,,,\n");
        let e = read_estimates(f.path()).unwrap();
        assert_eq!(
            e[0].status,
            EstimateStatus::Found(Point::new(1.5, 2.5, 3.5))
        );
        assert!(e[0].has_z);
        assert!(matches!(e[1].status, EstimateStatus::NotFound { .. }));
        let f = file("id,x,y\n1,1,2\n1,1,2\n");
        let m = read_estimates(f.path()).unwrap_err().to_string();
        assert!(m.contains(":3:") && m.contains("duplicate"), "{m}");
        let f = file("id,x,y\n1,1,\n");
        let m = read_estimates(f.path()).unwrap_err().to_string();
        assert!(m.contains(":2:") && m.contains("`y`"), "{m}");
    }

    /// eval's targets.csv: the map columns are the estimates; excluded rows
    /// keep their position (errors judges them again), not-found rows none.
    #[test]
    fn estimates_from_evals_targets_csv() {
        let f = file(
            "id,status,reason,survey_x,survey_y,survey_z,map_x,map_y,map_z,aligned_x\n\
             1,ok,,10,20,1,1.5,2.5,3.5,10\n\
             2,not_found,no target here,11,21,1,,,,\n\
             3,excluded,gross error,12,22,1,4,5,,12\n\
             4,not_found,wrong object,13,23,1,7,8,9,\n\
             5,ambiguous,mapped twice,14,24,1,,,,\n",
        );
        let e = read_estimates(f.path()).unwrap();
        assert_eq!(
            e[0].status,
            EstimateStatus::Found(Point::new(1.5, 2.5, 3.5))
        );
        assert!(e[0].has_z);
        assert!(
            matches!(&e[1].status, EstimateStatus::NotFound { reason } if reason == "no target here")
        );
        assert_eq!(
            e[2].status,
            EstimateStatus::Found(Point::new(4.0, 5.0, 0.0))
        );
        assert!(!e[2].has_z);
        assert!(
            matches!(&e[3].status, EstimateStatus::NotFound { reason } if reason == "wrong object")
        );
        assert!(
            matches!(&e[4].status, EstimateStatus::Ambiguous { reason } if reason == "mapped twice")
        );
    }
}

/// A target id made safe as a file name: the one rule for crops saved by
/// `eval --save-crops` and `crop`, hand-made crops read by `--crops`, and the
/// report's figure files. ASCII letters, digits, `.`, `_` and `-` stay; any
/// other character becomes `_`; an empty or all-dot stem gets a leading `_`.
pub fn file_stem(id: &str) -> String {
    let s: String = id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.chars().all(|c| c == '.') {
        format!("_{s}")
    } else {
        s
    }
}
