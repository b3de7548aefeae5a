//! The sensor's path through the map, as SLAM software writes it: error
//! grows with the distance driven, so the report plots each target's error
//! against where along the route it stands.
//!
//! Two text formats, one pose a line (blank lines and `#` comments skipped,
//! spaces or commas between numbers), told apart by the number of columns:
//! - TUM (evo, the TUM RGB-D benchmark): `t x y z qx qy qz qw`, 8 numbers;
//! - KITTI: the 3 × 4 pose matrix row by row, 12 numbers, position in the
//!   4th, 8th and 12th.
//!
//! Only the positions are read; they are in the map's own frame (the frame
//! the SLAM software wrote the map in).
//!
//! ```
//! use mapgauge::trajectory::Trajectory;
//! let t = Trajectory::parse("# t x y z qx qy qz qw\n0 0 0 0 0 0 0 1\n1 3 4 0 0 0 0 1\n", "poses.txt").unwrap();
//! assert_eq!(t.length(), 5.0);
//! let s = t.station(&mapgauge::Point::new(1.5, 2.0, 0.0)).unwrap();
//! assert!((s.along - 2.5).abs() < 1e-12 && s.off < 1e-12);
//! ```

use crate::{Error, Point, Result};
use std::path::Path;

/// A trajectory's positions, in file order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trajectory {
    /// Sensor positions (map frame).
    pub positions: Vec<Point>,
    /// `tum` or `kitti`.
    pub format: &'static str,
}

/// Where a position stands against the route.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Station {
    /// Distance along the route to the closest point of it (m).
    pub along: f64,
    /// Horizontal distance from the route (m).
    pub off: f64,
}

/// Lines beyond this are refused: a trajectory is poses at 10–100 Hz, and a
/// file of tens of millions of lines is another file.
const MAX_POSES: usize = 10_000_000;

/// A file bigger than this is refused unread: [`MAX_POSES`] KITTI lines of
/// twelve numbers at up to 20 characters each.
const MAX_BYTES: u64 = MAX_POSES as u64 * 12 * 20;

impl Trajectory {
    /// Reads a TUM or KITTI trajectory file.
    pub fn read(path: &Path) -> Result<Trajectory> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        // Not read into memory to find out that it holds too many poses.
        if meta.len() > MAX_BYTES {
            return Err(Error::Input(format!(
                "{}: {} bytes is too big for a trajectory (at most {MAX_POSES} poses)",
                path.display(),
                meta.len()
            )));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Trajectory::parse(&text, &path.display().to_string())
    }

    /// Parses the text of a trajectory file named `name` (for messages).
    pub fn parse(text: &str, name: &str) -> Result<Trajectory> {
        let mut positions = Vec::new();
        let mut format: Option<&'static str> = None;
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let at = || format!("{name}:{}", i + 1);
            let v: Vec<f64> = line
                .split(|c: char| c.is_whitespace() || c == ',')
                .filter(|s| !s.is_empty())
                .map(|s| s.parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| {
                    Error::Input(format!("{}: not a line of numbers: {line:.60}", at()))
                })?;
            let this = match v.len() {
                8 => "tum",
                12 => "kitti",
                n => {
                    return Err(Error::Input(format!(
                        "{}: {n} numbers; a trajectory line is TUM's `t x y z qx qy qz qw` (8) or KITTI's 3 × 4 pose matrix (12)",
                        at()
                    )));
                }
            };
            if format.is_some_and(|f| f != this) {
                return Err(Error::Input(format!(
                    "{}: a {this} line in a {} file",
                    at(),
                    format.unwrap_or_default()
                )));
            }
            format = Some(this);
            let p = if this == "tum" {
                Point::new(v[1], v[2], v[3])
            } else {
                Point::new(v[3], v[7], v[11])
            };
            if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
                return Err(Error::Input(format!(
                    "{}: a position that is not finite",
                    at()
                )));
            }
            if positions.len() == MAX_POSES {
                return Err(Error::Input(format!(
                    "{}: more than {MAX_POSES} poses: is this a trajectory?",
                    at()
                )));
            }
            positions.push(p);
        }
        let Some(format) = format else {
            return Err(Error::Input(format!("{name}: no poses")));
        };
        Ok(Trajectory { positions, format })
    }

    /// The route's horizontal length (m).
    pub fn length(&self) -> f64 {
        self.positions
            .windows(2)
            .map(|w| (w[1] - w[0]).xy().norm())
            .sum()
    }

    /// The closest point of the route to `p` (horizontally), as the
    /// distance along the route to it and `p`'s distance from it; `None`
    /// without poses.
    pub fn station(&self, p: &Point) -> Option<Station> {
        let first = self.positions.first()?;
        let mut best = Station {
            along: 0.0,
            off: (p - first).xy().norm(),
        };
        let mut along = 0.0;
        for w in self.positions.windows(2) {
            let d = (w[1] - w[0]).xy();
            let len = d.norm();
            if len > 0.0 {
                let t = ((p - w[0]).xy().dot(&d) / (len * len)).clamp(0.0, 1.0);
                let off = ((p - w[0]).xy() - d * t).norm();
                if off < best.off {
                    best = Station {
                        along: along + t * len,
                        off,
                    };
                }
            }
            along += len;
        }
        Some(best)
    }

    /// The same route in another frame (the levelled one the targets'
    /// positions are given in).
    pub fn moved(&self, motion: &crate::cloud::RigidMotion) -> Trajectory {
        Trajectory {
            positions: self.positions.iter().map(|p| motion.apply(p)).collect(),
            format: self.format,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tum_and_kitti_lines_give_positions() {
        let t = Trajectory::parse("0 1 2 3 0 0 0 1\n0.1,4,6,3,0,0,0,1\n", "a").unwrap();
        assert_eq!(t.format, "tum");
        assert_eq!(t.positions[1], Point::new(4.0, 6.0, 3.0));
        assert_eq!(t.length(), 5.0);
        let k = Trajectory::parse("1 0 0 7 0 1 0 8 0 0 1 9\n", "b").unwrap();
        assert_eq!(k.format, "kitti");
        assert_eq!(k.positions[0], Point::new(7.0, 8.0, 9.0));
    }

    #[test]
    fn wrong_lines_are_named() {
        let e = Trajectory::parse("0 1 2 3 0 0 0 1\n1 2 3\n", "poses.txt").unwrap_err();
        assert!(e.to_string().contains("poses.txt:2: 3 numbers"), "{e}");
        let e = Trajectory::parse("0 1 2 3 0 0 0 x\n", "p").unwrap_err();
        assert!(e.to_string().contains("p:1: not a line of numbers"), "{e}");
        let e = Trajectory::parse("# nothing\n\n", "p").unwrap_err();
        assert!(e.to_string().contains("no poses"), "{e}");
        let e = Trajectory::parse("0 1 2 3 0 0 0 1\n1 0 0 7 0 1 0 8 0 0 1 9\n", "p").unwrap_err();
        assert!(e.to_string().contains("a kitti line in a tum file"), "{e}");
    }

    #[test]
    fn a_station_is_the_closest_point_of_the_route() {
        // An L-shaped route: 10 m east, then 10 m north.
        let t = Trajectory::parse(
            "0 0 0 0 0 0 0 1\n1 10 0 0 0 0 0 1\n2 10 10 0 0 0 0 1\n",
            "r",
        )
        .unwrap();
        let s = t.station(&Point::new(12.0, 6.0, 5.0)).unwrap();
        assert!((s.along - 16.0).abs() < 1e-12 && (s.off - 2.0).abs() < 1e-12);
        let s = t.station(&Point::new(4.0, -3.0, 0.0)).unwrap();
        assert!((s.along - 4.0).abs() < 1e-12 && (s.off - 3.0).abs() < 1e-12);
    }
}
