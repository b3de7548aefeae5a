//! Estimate files: target positions found in a map by another tool.

use super::table::*;
use crate::{Error, Point, Result};
use std::collections::HashSet;
use std::path::Path;

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
        let id = t.unique_id(line, rec, id_c, &mut seen)?;
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
