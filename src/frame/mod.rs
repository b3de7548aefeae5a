//! Where the map is: its vertical ([`level`]), and the transform that puts the
//! survey on it when the map is in a frame of its own ([`matching`], [`hints`]).
//! Everything here runs before the targets are cropped; its product is where
//! to look and which way is up.

pub(crate) mod grid;
pub mod hints;
pub mod level;
pub mod matching;

pub use level::{Footprint, GroundLevel, MapGround, ground_level};

use crate::Point;

/// How the map lies in the survey frame, horizontally: the map's origin at
/// (`x`, `y`) of the survey frame and its +x axis `yaw_deg` anticlockwise
/// from the survey's, so that survey = R(yaw)·map + (x, y) (heights apart).
/// `--init X,Y,YAW_DEG` and result.json's `eval.frame.init` write it as
/// that triple.
///
/// ```
/// use mapgauge::Point;
/// use mapgauge::frame::MapToSurvey;
/// let f = MapToSurvey { x: 100.0, y: 50.0, yaw_deg: 90.0 };
/// let survey = Point::new(100.0, 52.0, 1.0);
/// let map = f.to_map(&survey);
/// assert!((map - Point::new(2.0, 0.0, 1.0)).norm() < 1e-12);
/// assert!((f.to_survey(&map) - survey).norm() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(from = "[f64; 3]", into = "[f64; 3]")]
pub struct MapToSurvey {
    /// The map origin's x in the survey frame (m).
    pub x: f64,
    /// The map origin's y in the survey frame (m).
    pub y: f64,
    /// The map's +x axis from the survey's +x, anticlockwise (degrees).
    pub yaw_deg: f64,
}

impl MapToSurvey {
    /// The map is in the survey frame.
    pub const IDENTITY: MapToSurvey = MapToSurvey {
        x: 0.0,
        y: 0.0,
        yaw_deg: 0.0,
    };

    /// A survey-frame point in the map's frame (the height kept).
    pub fn to_map(&self, p: &Point) -> Point {
        let (s, c) = self.yaw_deg.to_radians().sin_cos();
        let (dx, dy) = (p.x - self.x, p.y - self.y);
        Point::new(c * dx + s * dy, -s * dx + c * dy, p.z)
    }

    /// A map point in the survey frame (the height kept).
    pub fn to_survey(&self, p: &Point) -> Point {
        let (s, c) = self.yaw_deg.to_radians().sin_cos();
        Point::new(c * p.x - s * p.y + self.x, s * p.x + c * p.y + self.y, p.z)
    }
}

impl From<[f64; 3]> for MapToSurvey {
    fn from([x, y, yaw_deg]: [f64; 3]) -> Self {
        MapToSurvey { x, y, yaw_deg }
    }
}

impl From<MapToSurvey> for [f64; 3] {
    fn from(f: MapToSurvey) -> Self {
        [f.x, f.y, f.yaw_deg]
    }
}

/// 2D rigid least squares on local coordinates: the yaw and translation with
/// `to ≈ R(yaw)·from + t` for the pairs `(from, to)`. Callers subtract an
/// origin first, so no large coordinate is squared.
pub(crate) fn rigid2d(pairs: &[([f64; 2], [f64; 2])]) -> (f64, [f64; 2]) {
    let n = pairs.len().max(1) as f64;
    let mf = pairs
        .iter()
        .fold([0.0; 2], |a, (f, _)| [a[0] + f[0] / n, a[1] + f[1] / n]);
    let mt = pairs
        .iter()
        .fold([0.0; 2], |a, (_, t)| [a[0] + t[0] / n, a[1] + t[1] / n]);
    let (mut c, mut s) = (0.0, 0.0);
    for (f, t) in pairs {
        let (ax, ay) = (f[0] - mf[0], f[1] - mf[1]);
        let (bx, by) = (t[0] - mt[0], t[1] - mt[1]);
        c += ax * bx + ay * by;
        s += ax * by - ay * bx;
    }
    let yaw = s.atan2(c);
    let (sn, cs) = yaw.sin_cos();
    (
        yaw,
        [
            mt[0] - (cs * mf[0] - sn * mf[1]),
            mt[1] - (sn * mf[0] + cs * mf[1]),
        ],
    )
}
