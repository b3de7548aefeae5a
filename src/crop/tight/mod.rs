//! Automatic tight crop: from a loose crop, find the L-shaped target and keep
//! only its plates.
//!
//! 1. **Ground.** The lowest point of every 0.5 m cell is a ground candidate; a
//!    RANSAC plane through those gives the local ground normal, and the lowest
//!    height in each 3×3 cell block follows bumps the plane cannot.
//! 2. **Above ground.** Points between `min_height` and `max_height` over the
//!    local ground, within `search_radius` of the expected position.
//! 3. **L detection.** Windows about the size of a target are centred on every
//!    occupied cell. In each, a Hough vote over headings finds the pair of
//!    perpendicular vertical planes with the most support (the weaker plate's
//!    count is the score). A window passes when both plates lie on one side of
//!    their intersection (an L, not a T or a cross), are no longer than a plate,
//!    the supporting points span no more than a plate's height (plus 0.25 m),
//!    and the faces stop where a plate stops (a car's or a cabinet's go on).
//! 4. **Choice.** Among windows scoring at least a quarter of the best (solid
//!    clutter returns more points than a mesh plate), the one whose corner is
//!    nearest the expected position wins, unless it is nearer another
//!    target's expected position (`tight_crop_among`).
//! 5. **Crop.** Points near either plate plane, on the plate's side of the
//!    corner, inside the plates' height band (the post below and the antenna
//!    above are dropped, so the corner height is the plates' mean height).

mod finder;
mod ground;
#[cfg(test)]
mod tests;

use crate::Point;
use finder::{Rejected, find_l};
use ground::Ground;
use nalgebra::Vector3;

/// Most above-ground points the L finder looks at in one crop, so its cost
/// stays bounded however dense the map. Measured: a cluttered target of a
/// 3-target 3 M-point scene had 40 k (looked at whole), the clutter tests'
/// one-target 3 M-point scenes with a container 127 k and the 20 M-point
/// synth map's target beside a wall 157 k (both sampled). 60 k against
/// 100 k moved 3 of 176 clutter-table corners, by at most 0.35 mm
/// (docs/algorithm.md); 40 k moved 8 and saved no more time.
const DETECT_POINTS: usize = 60_000;

/// Tight-crop parameters; the target size is the physical build.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TightParams {
    /// Plate width in metres (each arm of the L).
    pub plate_width: f64,
    /// Plate height in metres.
    pub plate_height: f64,
    /// Ground cell size in metres.
    pub ground_cell: f64,
    /// Points lower than this above the local ground are ground (metres).
    pub min_height: f64,
    /// Points higher than this above the local ground are ignored (metres).
    pub max_height: f64,
    /// Horizontal search radius around the expected position (metres).
    pub search_radius: f64,
    /// Half-width of the slab kept around each plate plane (metres).
    pub keep_distance: f64,
    /// Minimum points on each plate for a candidate.
    pub min_plate_points: usize,
    /// The ground normal is used as "up" only when it is within this angle of
    /// the map's +z (degrees); steeper ground is a slope, not a tilted map.
    pub max_up_tilt_deg: f64,
    /// Seed for the ground RANSAC.
    pub seed: u64,
}

impl Default for TightParams {
    fn default() -> Self {
        TightParams {
            plate_width: 0.6,
            plate_height: 0.6,
            ground_cell: 0.5,
            min_height: 0.2,
            max_height: 4.0,
            search_radius: 4.5,
            keep_distance: 0.08,
            min_plate_points: 12,
            max_up_tilt_deg: 0.75,
            seed: 0,
        }
    }
}

/// A tight crop and what was learned on the way.
#[derive(Debug, Clone, serde::Serialize)]
pub struct TightCrop {
    /// The target's points (map frame).
    pub points: Vec<Point>,
    /// The direction used as vertical by the localisation gates.
    pub up: [f64; 3],
    /// Estimated local ground normal.
    pub ground_normal: [f64; 3],
    /// Tilt of the ground normal from +z (degrees).
    pub ground_tilt_deg: f64,
    /// Points classified as ground.
    pub ground_points: usize,
    /// Points above ground inside the search radius.
    pub above_ground: usize,
    /// Corner found by the L detector (map frame; a first guess).
    pub corner_guess: Point,
    /// Support of the weaker plate in the winning window.
    pub score: usize,
    /// Windows that looked like a target.
    pub candidates: usize,
    /// Heading of the L's bisector (corner → inside), degrees from +x.
    pub heading_deg: f64,
    /// Plate widths measured from the points (m).
    pub plate_widths: [f64; 2],
    /// Height of the plates' band measured from the points (m).
    pub plate_height: f64,
}

/// Why no tight crop could be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum TightError {
    /// The loose crop is empty: the target is outside the map.
    #[error("no map points near the expected position")]
    NoPoints,
    /// Everything near the target is ground.
    #[error(
        "nothing stands above the ground near the expected position ({points} points, all ground)"
    )]
    NothingAboveGround {
        /// Points in the loose crop.
        points: usize,
    },
    /// Objects stand there, but none is shaped like the target.
    #[error(
        "no target-shaped object within {radius} m ({above} points above ground; best plate support {best}){}",
        seen.as_ref().map_or(String::new(), |s| format!("; closest thing seen: {s}"))
    )]
    NoTargetShape {
        /// Search radius used.
        radius: f64,
        /// Points above ground.
        above: usize,
        /// Best weaker-plate support seen in any window.
        best: usize,
        /// What the best-supported rejected window looked like ("a 0.38 ×
        /// 0.46 m L", "a plane continuing 1.2 m past the corner"), and where.
        #[serde(skip_serializing_if = "Option::is_none")]
        seen: Option<Seen>,
    },
}

/// The object the tight crop saw and refused where a target was expected:
/// what it looked like and where it stands, so a user (and the report's
/// panel) can tell a target hidden behind clutter from a target that is not
/// there.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Seen {
    /// What it looked like ("a plane continuing 1.2 m past the corner").
    pub what: String,
    /// Its corner (x, y), in the frame the crop was made in.
    pub at: [f64; 2],
    /// Ends of its two faces (x, y), a plate's width from the corner, when
    /// the checks got as far as telling which side of the corner each lies on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub faces: Option<[[f64; 2]; 2]>,
    /// Its distance from the expected position (m, horizontal).
    pub from_expected: f64,
    /// Its plates' widths and height (m; `None` where not measured) when
    /// its size alone refused it: an L of other plates than configured
    /// (`--plate-size`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plate_size: Option<Box<[Option<f64>; 3]>>,
}

impl std::fmt::Display for Seen {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} at ({:.2}, {:.2}), {:.1} m from the expected position",
            self.what, self.at[0], self.at[1], self.from_expected
        )
    }
}

/// Finds the target in `points` (a loose crop) near `expected` (map frame).
pub fn tight_crop(
    points: &[Point],
    expected: &Point,
    params: &TightParams,
) -> Result<TightCrop, TightError> {
    tight_crop_among(points, expected, &[], params)
}

/// [`tight_crop`] when other targets are expected nearby (`others`, the same
/// frame): an L nearer another target's expected position than this one's is
/// that target's, so two targets a metre or two apart each keep their own.
pub fn tight_crop_among(
    points: &[Point],
    expected: &Point,
    others: &[Point],
    params: &TightParams,
) -> Result<TightCrop, TightError> {
    if points.is_empty() {
        return Err(TightError::NoPoints);
    }
    // Local coordinates about the expected position keep squares small.
    let q: Vec<Vector3<f64>> = points.iter().map(|p| p - expected).collect();
    let ground = Ground::fit(&q, params);
    let heights: Vec<f64> = q.iter().map(|v| ground.height(v)).collect();
    let r2 = params.search_radius * params.search_radius;
    let above: Vec<usize> = (0..q.len())
        .filter(|&i| {
            heights[i] > params.min_height
                && heights[i] < params.max_height
                && q[i].x * q[i].x + q[i].y * q[i].y < r2
        })
        .collect();
    let ground_points = heights.iter().filter(|&&h| h <= params.min_height).count();
    if above.is_empty() {
        return Err(TightError::NothingAboveGround {
            points: points.len(),
        });
    }
    let up = if ground.normal.angle(&Vector3::z()).to_degrees() <= params.max_up_tilt_deg {
        ground.normal
    } else {
        Vector3::z()
    };
    let ap: Vec<Vector3<f64>> = above.iter().map(|&i| q[i]).collect();
    let others: Vec<Vector3<f64>> = others.iter().map(|o| o - expected).collect();
    // The L finder's cost grows with the points it looks at, not with what it
    // needs to see: beyond `DETECT_POINTS` it sees a uniform sample (the same
    // hash as the loose crop's thinning, so the sets nest), which keeps every
    // density ratio its checks compare (a face going on against the plate,
    // the slab against its shells). The kept points are taken from them all.
    let sample: Vec<Vector3<f64>>;
    let seen_by_finder = if ap.len() > DETECT_POINTS {
        sample = finder_sample(points, &above, expected);
        &sample
    } else {
        &ap
    };
    let (best, candidates, best_score, seen) = find_l(seen_by_finder, &up, params, &others);
    let seen = seen.map(|r| seen_of(r, expected, params.plate_width));
    let Some(l) = best else {
        return Err(TightError::NoTargetShape {
            radius: params.search_radius,
            above: above.len(),
            best: best_score,
            seen,
        });
    };
    let kept: Vec<Point> = ap
        .iter()
        .filter(|v| l.keeps(v, &up, params))
        .map(|v| expected + v)
        .collect();
    Ok(TightCrop {
        points: kept,
        up: up.into(),
        ground_normal: ground.normal.into(),
        ground_tilt_deg: ground.normal.angle(&Vector3::z()).to_degrees(),
        ground_points,
        above_ground: above.len(),
        corner_guess: Point::new(
            expected.x + l.corner.x,
            expected.y + l.corner.y,
            expected.z + (l.band.0 + l.band.1) / 2.0,
        ),
        score: l.score,
        candidates,
        heading_deg: {
            let b = l.bisector();
            b.y.atan2(b.x).to_degrees().rem_euclid(360.0)
        },
        plate_widths: l.widths,
        plate_height: l.band.1 - l.band.0,
    })
}

/// The uniform sample of the above-ground points (`above`, indices into
/// `points`) that the L finder sees beyond `DETECT_POINTS`, local about
/// `expected`: thinned by the loose crop's hash, so the sets nest.
fn finder_sample(points: &[Point], above: &[usize], expected: &Point) -> Vec<Vector3<f64>> {
    let mut t = crate::crop::loose::Thinned::new(DETECT_POINTS);
    t.extend(&above.iter().map(|&i| points[i]).collect::<Vec<_>>());
    t.points.iter().map(|p| p - expected).collect()
}

/// A refused window in the crop's frame, for the user: where it stands, its
/// faces' ends when the checks decided which side each lies on, and its
/// measured size when only its size refused it.
fn seen_of(r: Rejected, expected: &Point, plate_width: f64) -> Seen {
    let at = expected + r.corner;
    let decided = r.along.iter().all(|a| a.norm() > 0.5);
    Seen {
        what: r.why,
        at: [at.x, at.y],
        faces: decided.then(|| {
            r.along.map(|a| {
                let e = at + a * plate_width;
                [e.x, e.y]
            })
        }),
        from_expected: r.corner.xy().norm(),
        plate_size: r
            .size
            .map(|s| Box::new(s.map(|v| v.is_finite().then_some(v)))),
    }
}
