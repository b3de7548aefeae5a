//! Survey files (the ground truth) and estimate files (positions found in the map).
//!
//! Both are CSV with a header line; `#` starts a comment line. Every bad row is
//! reported with its file and line, so a 200-target survey can be fixed quickly.

mod estimates;
mod geodesy;
mod projection;
mod table;
#[cfg(test)]
mod tests;

pub use estimates::{Estimate, EstimateStatus, read_estimates};
pub use geodesy::Geodetic;
pub use projection::Projector;

use crate::{Error, Point, Result};
use serde::{Deserialize, Serialize};
use std::collections::HashSet;
use std::path::Path;
use table::*;

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

/// Longest `antenna_height` taken (m, either way): survey poles are 2 m,
/// extended 5 m at most.
pub const MAX_ANTENNA_M: f64 = 5.0;

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
    /// Metres from the antenna down to the target's reference height (0 if
    /// absent; at most [`MAX_ANTENNA_M`] either way).
    pub antenna_height: f64,
    /// What the target is (the `model` column; the L when absent).
    pub model: crate::model::ModelKind,
    /// Its size (m: the L's plate width, a sphere's diameter, a board's
    /// side), when the survey gives it; else the configuration's.
    pub size: Option<f64>,
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
    /// For [`SurveyFrame::Wgs84Map`]: the positions with each row's latitude
    /// and longitude read the other way round, placed by the same
    /// projection, when every longitude could be a latitude (a swapped
    /// survey lands thousands of kilometres off the map, and only this says
    /// why); `None` otherwise.
    pub exchanged: Option<Vec<Point>>,
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
                    model: Default::default(),
                    size: None,
                    line: i as u64 + 2,
                })
                .collect(),
            frame: SurveyFrame::Local,
            origin: None,
            exchanged: None,
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
    let cols = Columns::of(&t, path)?;
    let (targets, geo) = cols.targets(&t, path)?;
    if targets.is_empty() {
        return Err(Error::table(path, 0, "no targets in survey"));
    }
    placed(targets, geo, cols.geodetic, opts, projector)
}

/// Where a survey table keeps what mapgauge reads: checked against the
/// column names people misspell or use for the other kind of coordinates.
struct Columns {
    id: usize,
    /// lat, lon (and alt) when `geodetic`, else x, y (and z), with their names.
    at: [usize; 2],
    height: Option<usize>,
    names: [&'static str; 3],
    role: Option<usize>,
    antenna: Option<usize>,
    model: Option<usize>,
    size: Option<usize>,
    geodetic: bool,
}

impl Columns {
    fn of(t: &Table, path: &Path) -> Result<Columns> {
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
        let id = t.require(ID)?;
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
        let (at, height, names) = if geodetic {
            (
                [t.require(LAT)?, t.require(LON)?],
                t.col(ALT),
                ["lat", "lon", "alt"],
            )
        } else {
            ([t.require(X)?, t.require(Y)?], t.col(Z), ["x", "y", "z"])
        };
        Ok(Columns {
            id,
            at,
            height,
            names,
            role: t.col(ROLE),
            antenna: t.col(ANTENNA),
            model: t.col(MODEL),
            size: t.col(SIZE),
            geodetic,
        })
    }

    /// Every row as a target (its position as written: lat, lon, alt for a
    /// geodetic survey, also returned apart), each id once.
    fn targets(&self, t: &Table, path: &Path) -> Result<(Vec<SurveyTarget>, Vec<Geodetic>)> {
        let mut seen = HashSet::new();
        let mut targets = Vec::with_capacity(t.rows.len());
        let mut geo = Vec::new();
        for (line, rec) in &t.rows {
            let line = *line;
            let id = t.unique_id(line, rec, self.id, &mut seen)?;
            let a = t.number(line, rec, self.at[0], self.names[0])?;
            let b = t.number(line, rec, self.at[1], self.names[1])?;
            let c = t.opt_number(line, rec, self.height, self.names[2])?;
            if self.geodetic {
                if !(-90.0..=90.0).contains(&a) {
                    // A longitude where the latitude goes (127.36, 36.37 at
                    // Daejeon) is the likely slip: say so.
                    let swapped = if (-90.0..=90.0).contains(&b) {
                        format!(
                            " (its longitude {b} would be a latitude: are the {} and {} columns swapped?)",
                            t.headers[self.at[0]], t.headers[self.at[1]]
                        )
                    } else {
                        String::new()
                    };
                    return Err(Error::table(
                        path,
                        line,
                        format!("latitude {a} is outside -90..90{swapped}"),
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
            let role = match self.role.and_then(|c| rec.get(c)).filter(|s| !s.is_empty()) {
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
                .opt_number(line, rec, self.antenna, "antenna_height")?
                .unwrap_or(0.0);
            // A survey pole is a few metres at most: more is another unit
            // (42 for 0.42 m), and would put every height that far off.
            if antenna_height.abs() > MAX_ANTENNA_M {
                return Err(Error::table(
                    path,
                    line,
                    format!(
                        "antenna_height {antenna_height} is more than {MAX_ANTENNA_M} m: is it in centimetres or millimetres? (metres from the surveyed point down to the target's reference height; mapgauge reads every column of a survey in metres: if the survey was written in another unit, convert its {} too)",
                        if self.geodetic {
                            format!(
                                "{} (heights)",
                                t.headers
                                    .get(self.height.unwrap_or(usize::MAX))
                                    .map_or("alt", |h| h.as_str())
                            )
                        } else {
                            format!(
                                "{}, {} and {}",
                                t.headers[self.at[0]],
                                t.headers[self.at[1]],
                                t.headers
                                    .get(self.height.unwrap_or(usize::MAX))
                                    .map_or("z", |h| h.as_str())
                            )
                        }
                    ),
                ));
            }
            let (model, size) = self.model_and_size(t, path, line, rec)?;
            targets.push(SurveyTarget {
                id,
                position: Point::new(a, b, c.unwrap_or(0.0)),
                has_z: c.is_some(),
                role,
                antenna_height,
                model,
                size,
                line,
            });
        }
        Ok((targets, geo))
    }
}

impl Columns {
    /// A row's `model` (the L when empty or absent) and `size` (m), each
    /// refused with the line when it is not one mapgauge knows or builds.
    fn model_and_size(
        &self,
        t: &Table,
        path: &Path,
        line: u64,
        rec: &csv::StringRecord,
    ) -> Result<(crate::model::ModelKind, Option<f64>)> {
        let model = match self.model.and_then(|c| rec.get(c)).map(str::trim) {
            None | Some("") => crate::model::ModelKind::L,
            Some(s) => s
                .parse::<crate::model::ModelKind>()
                .map_err(|e| Error::table(path, line, e))?,
        };
        let size = t.opt_number(line, rec, self.size, "size")?;
        if let Some(s) = size {
            model
                .check_size(s)
                .map_err(|e| Error::table(path, line, e))?;
        }
        Ok((model, size))
    }
}

/// The survey in its frame: as written (local), projected by the map's
/// projector file, or east-north-up about `--origin` (else the first target).
fn placed(
    mut targets: Vec<SurveyTarget>,
    geo: Vec<Geodetic>,
    geodetic: bool,
    opts: &SurveyOptions,
    projector: Option<&Path>,
) -> Result<Survey> {
    if let (true, Some(pf)) = (geodetic, projector) {
        if opts.origin.is_some() {
            return Err(Error::Param(format!(
                "--origin: the map's {} places the survey; drop --origin",
                pf.display()
            )));
        }
        let proj = Projector::read(pf, targets.iter().any(|t| t.has_z))?;
        let place = |t: &SurveyTarget, g: &Geodetic| {
            let p = proj.forward(g);
            if t.has_z {
                p
            } else {
                Point::new(p.x, p.y, 0.0)
            }
        };
        let exchanged: Option<Vec<Point>> = geo
            .iter()
            .all(|g| g.lon.abs() <= 90.0)
            .then(|| {
                targets
                    .iter()
                    .zip(&geo)
                    .map(|(t, g)| {
                        let other = Geodetic {
                            lat: g.lon,
                            lon: g.lat,
                            alt: g.alt,
                        };
                        place(t, &other)
                    })
                    .collect()
            })
            .filter(|v: &Vec<Point>| v.iter().all(|p| p.coords.iter().all(|c| c.is_finite())));
        for (t, g) in targets.iter_mut().zip(&geo) {
            t.position = place(t, g);
        }
        return Ok(Survey {
            targets,
            frame: SurveyFrame::Wgs84Map,
            origin: None,
            exchanged,
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
        exchanged: None,
    })
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
