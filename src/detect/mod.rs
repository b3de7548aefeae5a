//! Map-wide detection: every object shaped like a target, anywhere in the map.
//!
//! Two passes over the (levelled) map after the ground pass of
//! [`crate::frame::level`]:
//! 1. **Occupancy.** Points between `min_height` and `max_height` above the
//!    ground fall into 0.1 m cells. Connected groups of cells as small as a
//!    target (no side longer than `max_extent`, nothing above `max_height`)
//!    are candidates; walls, hedges, vehicles and buildings are groups too
//!    large to be one.
//! 2. **Shape.** One loose-crop pass gathers the points around every
//!    candidate; the tight crop's L detector ([`crate::crop::tight_crop`])
//!    decides, with its checks of the physical target: two perpendicular
//!    plates meeting at a vertical edge, each as wide and as tall as a plate,
//!    faces that stop where a plate stops.
//!
//! 3. **Spheres**, when asked for: a candidate with no L is given to the
//!    sphere locator ([`crate::model::sphere::locate`]), with its checks: round
//!    every way and of the surveyed diameter, not a pole, a post's top or a
//!    bush.
//!
//! 4. **Boards**, when asked for and the map has intensity: the candidates
//!    that are neither are read again with their intensities and given to
//!    the board locator ([`crate::model::board::locate`]), with its checks:
//!    a face of a board's size, its print's four squares, their contrast
//!    against the map's intensity. A board lying flat on the ground is no
//!    candidate (nothing stands above the ground there): only boards that
//!    stand are detected map-wide.
//!
//! Memory follows the site's area (the two grids), not its number of points.

use crate::cloud::{MapSource, PointReader, RigidMotion, fold_points};
use crate::crop::{LooseParams, Shape, TightParams, loose_crop, tight_crop};
use crate::frame::MapGround;
use crate::frame::grid::CellGrid;
use crate::{Point, Result};
use rayon::prelude::*;
use std::collections::{HashMap, VecDeque};

/// Detection settings; the target's size comes from [`TightParams`].
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DetectParams {
    /// Occupancy cell side (m).
    pub cell: f64,
    /// Points lower than this above the ground are ground (m).
    pub min_height: f64,
    /// Groups reaching higher than this above the ground are not targets (m).
    pub max_height: f64,
    /// Groups longer than this on a side are not targets (m).
    pub max_extent: f64,
    /// Points a group needs to be looked at.
    pub min_points: u64,
    /// Radius of the crop gathered around a candidate (m; ground included).
    pub crop_radius: f64,
    /// The L must stand within this of the candidate's centre (m).
    pub search_radius: f64,
}

impl Default for DetectParams {
    fn default() -> Self {
        DetectParams {
            cell: 0.1,
            min_height: 0.3,
            max_height: 2.6,
            max_extent: 1.8,
            min_points: 30,
            crop_radius: 2.5,
            search_radius: 1.2,
        }
    }
}

impl DetectParams {
    /// Range checks.
    pub fn validate(&self) -> Result<()> {
        let ok = self.cell > 0.01
            && self.cell <= 1.0
            && self.min_height >= 0.0
            && self.max_height > self.min_height
            && self.max_height <= 50.0
            && self.max_extent > 0.0
            && self.max_extent <= 20.0
            && self.crop_radius > 0.0
            && self.crop_radius <= 20.0
            && self.search_radius > 0.0
            && self.search_radius <= self.crop_radius;
        if ok {
            Ok(())
        } else {
            Err(crate::Error::Param(
                "detect: need 0.01 < cell <= 1, 0 <= min_height < max_height <= 50, 0 < max_extent <= 20, 0 < search_radius <= crop_radius <= 20".into(),
            ))
        }
    }
}

/// One object shaped like a target.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// What it is: an L, a sphere (then `corner` is its centre, the plate
    /// sizes its diameter, `heading_deg` 0 and `support` its surface points)
    /// or a board (`corner` where its squares meet, `heading_deg` that of
    /// its face's normal in [-90°, 90°) (the normal's sign is the fit's), the plate widths its face's extent seen, the plate
    /// height its side, `support` its points and `score` the share of them
    /// its print's colours predict).
    pub model: crate::model::ModelKind,
    /// Corner (plates' intersection, z at the plates' mid-height), levelled frame.
    pub corner: Point,
    /// The same corner in the map's own frame.
    pub corner_map: Point,
    /// Heading of the L's bisector (corner → inside), degrees from +x, levelled frame.
    pub heading_deg: f64,
    /// Plate widths measured from the points (m).
    pub plate_widths: [f64; 2],
    /// Height of the plates measured from the points (m).
    pub plate_height: f64,
    /// Points on the weaker plate.
    pub support: usize,
    /// Closeness to the configured target, 0–1: 1 when both plates have the
    /// configured width and height.
    pub score: f64,
}

/// What a whole-map detection found.
#[derive(Debug, Clone)]
pub struct MapDetections {
    /// Detections, strongest first.
    pub detections: Vec<Detection>,
    /// Groups of cells looked at.
    pub candidates: usize,
    /// Why the others were not targets: (reason, count), most common first.
    pub rejected: Vec<(String, usize)>,
    /// Memory of the occupancy grid (bytes).
    pub grid_bytes: usize,
    /// What its passes read: the cells above the ground, and the crops
    /// around the candidates (when there were any), and those crops again
    /// with intensities (when boards were looked for).
    pub reads: Vec<crate::cloud::PassRead>,
    /// Why boards were asked for and not looked for (the map has no
    /// intensity).
    pub boards_not_looked_for: Option<String>,
}

#[derive(Clone, Copy)]
struct Occ {
    n: u32,
    hi: f32,
}

/// A target found map-wide, with no surveyed position to vouch for it,
/// shows at least this share of its plates' height (the tight crop accepts
/// 40 %, for a target at its surveyed place with its lower part hidden).
/// Real scans without targets gave Ls 0.23-0.41 m tall (a Velodyne frame's
/// 0.35 m clutter, an airborne scan's low walls: `tests/data/real`, PDAL's
/// lone-star), and a plate seen whole measures 0.55-0.6 m between its 2nd
/// and 98th percentile heights. A frame needs only three targets detected:
/// the rest are located at their predicted places with the looser test.
const DETECT_MIN_HEIGHT_SHARE: f64 = 0.7;

/// What to detect: the L (always), and spheres of a diameter and boards of
/// a side when given.
#[derive(Debug, Clone, Copy)]
pub struct Models<'a> {
    /// The L's size.
    pub tight: &'a TightParams,
    /// Spheres: their parameters and diameter (m), when looked for.
    pub sphere: Option<(&'a crate::model::SphereParams, f64)>,
    /// Checkerboard boards: their parameters and side (m), when looked for.
    pub board: Option<(&'a crate::model::BoardParams, f64)>,
}

/// Detects targets in `source`, read through `motion` (the levelling; the
/// identity for a level map). `ground` is the ground pass of the same map.
pub fn detect_map(
    source: MapSource,
    ground: &MapGround,
    motion: &RigidMotion,
    params: &DetectParams,
    models: Models,
    mut progress: impl FnMut(u64),
) -> Result<MapDetections> {
    let tight = models.tight;
    params.validate()?;
    // Boards are told by their print: none looked for in a map without
    // intensity, and said so whatever the candidates.
    let mut reader = source.open_moved(Some(motion))?;
    let boards_not_looked_for = match models.board {
        Some(_) if !reader.has_intensity() => Some(match source {
            MapSource::Points(_) => "a map handed over in memory has no intensity".to_string(),
            MapSource::File(path) => format!("{} has no intensity", path.display()),
        }),
        _ => None,
    };
    let board = models.board.filter(|_| boards_not_looked_for.is_none());
    // A board stands on its legs about as wide as its side: groups of up to
    // that size are candidates too.
    let params = &match board {
        Some((_, side)) if 1.2 * side > params.max_extent => DetectParams {
            max_extent: 1.2 * side,
            max_height: params.max_height.max(side + 1.5),
            ..params.clone()
        },
        _ => params.clone(),
    };
    let floor = ground.floor(motion);
    let occ = occupancy(reader.as_mut(), &floor, ground.z0, params, &mut progress)?;
    let grid_bytes = occ.bytes() + floor.bytes() + ground.lowest.bytes();
    let mut reads = vec![crate::cloud::PassRead::of("detect-cells", reader.as_ref())];
    let mut rejected: HashMap<String, usize> = HashMap::new();
    let centres = candidate_centres(&occ, params, &mut rejected);
    let candidates = centres.len();
    let mut detections = Vec::new();
    if !centres.is_empty() {
        // Candidate centres at their ground height (the crop is a cylinder).
        let mut reader = source.open_moved_within(Some(motion), ground.z_range)?;
        let loose = LooseParams {
            radius: params.crop_radius,
            shape: Shape::Cylinder,
            max_points: 200_000,
            by_level: false,
            ..LooseParams::default()
        };
        let crop = loose_crop(reader.as_mut(), &centres, &loose, &mut progress)?;
        reads.push(crate::cloud::PassRead::of("detect-crops", reader.as_ref()));
        let mut found = shapes(&crop.points, &centres, motion, params, models);
        // The coordinates are done with before the intensities are read.
        drop(crop);
        if let Some(bp) = board {
            reads.extend(boards(
                source, ground, &centres, &mut found, motion, params, bp,
            )?);
        }
        for f in found {
            match f {
                Ok(d) => detections.push(d),
                Err(why) => *rejected.entry(why).or_default() += 1,
            }
        }
    }
    Ok(MapDetections {
        detections: one_per_object(detections, tight),
        candidates,
        rejected: most_common_first(rejected),
        grid_bytes,
        reads,
        boards_not_looked_for,
    })
}

/// Boards among the candidates that are no L and no sphere: their crops
/// read again with intensities (one more pass, over those places only),
/// each given to the board locator, whose checks are the print's (a face of
/// a board's size, its four squares' colours, their contrast against the
/// map's intensity, each quarter its square's colour). A found board takes
/// the candidate's place in `found`; a face the locator refused gives the
/// candidate's reason, unless the L's or sphere's is a near miss of its
/// own (another size: the hint a user acts on). Returns the pass's read.
fn boards(
    source: MapSource,
    ground: &MapGround,
    centres: &[Point],
    found: &mut [std::result::Result<Detection, String>],
    motion: &RigidMotion,
    params: &DetectParams,
    (bp, side): (&crate::model::BoardParams, f64),
) -> Result<Option<crate::cloud::PassRead>> {
    let at: Vec<Option<Point>> = centres
        .iter()
        .zip(found.iter())
        .map(|(c, f)| f.is_err().then_some(*c))
        .collect();
    let p = crate::model::BoardParams {
        search_radius_m: params.search_radius,
        ..bp.clone()
    };
    let (crops, read) = crate::crop::crops_with_intensity(
        source,
        &at,
        p.search_radius_m + side,
        p.max_points,
        motion,
        ground.z_range,
    )?;
    let judged: Vec<(usize, std::result::Result<Detection, Option<String>>)> = crops
        .into_par_iter()
        .enumerate()
        .filter_map(|(i, c)| c.map(|c| (i, c)))
        .filter_map(|(i, c)| match c {
            Ok((pts, inten)) => Some((i, board_at(&pts, &inten, &centres[i], motion, &p, side))),
            Err(_) => None,
        })
        .collect();
    for (i, j) in judged {
        let near_miss = |why: &str| why == L_OF_ANOTHER_SIZE || why == NOT_A_SPHERE;
        match j {
            Ok(d) => found[i] = Ok(d),
            Err(Some(why)) if !found[i].as_ref().is_err_and(|w| near_miss(w)) => {
                found[i] = Err(why)
            }
            Err(_) => {}
        }
    }
    Ok(read)
}

/// A board of side `side` within the search radius of a candidate's centre
/// `c`, when the board locator finds one; else why a face it judged was
/// refused (`None`: no board-like face there).
fn board_at(
    pts: &[Point],
    inten: &[f32],
    c: &Point,
    motion: &RigidMotion,
    p: &crate::model::BoardParams,
    side: f64,
) -> std::result::Result<Detection, Option<String>> {
    let search = crate::model::board::Search {
        points: pts,
        intensity: inten,
        expected: *c,
        others: &[],
        side,
        up: nalgebra::Vector3::z(),
        on_surfaces: false,
    };
    let (fit, _) = crate::model::board::locate(&search, p).map_err(|e| match e {
        // Counted by kind (the locator's reasons carry numbers; `eval` at a
        // surveyed place names them).
        crate::model::BoardError::NoBoard { seen: Some(s), .. } => Some(
            if s.contains("fewer than") {
                "a board-sized face with too few points to read a print"
            } else if ["wider than a ", "smaller than a ", "narrower than a "]
                .iter()
                .any(|k| s.contains(k))
            {
                "a flat face of another size than a board"
            } else {
                "a flat face without a board's print"
            }
            .to_string(),
        ),
        _ => None,
    })?;
    // The heading of the face's normal, horizontally (a board lying flat
    // has none: 0).
    // The normal's sign is the fit's: the heading is taken in [-90°, 90°).
    let n = fit.normal;
    let heading_deg = if n[0].hypot(n[1]) > 0.5 {
        let h = n[1].atan2(n[0]).to_degrees();
        (h + 90.0).rem_euclid(180.0) - 90.0
    } else {
        0.0
    };
    Ok(Detection {
        model: crate::model::ModelKind::Board,
        corner: fit.centre,
        corner_map: motion.invert(&fit.centre),
        heading_deg,
        plate_widths: [fit.extent_m[0], fit.extent_m[1]],
        plate_height: side,
        support: fit.points,
        score: fit.agreement,
    })
}

/// The occupancy pass: the points between `min_height` and a metre above
/// `max_height` over the ground (`floor`, heights from `z0`) counted per
/// cell, with the highest of them.
fn occupancy(
    reader: &mut dyn PointReader,
    floor: &CellGrid<f32>,
    z0: f64,
    params: &DetectParams,
    progress: impl FnMut(u64),
) -> Result<CellGrid<Occ>> {
    let (lo_h, hi_h) = (params.min_height as f32, params.max_height as f32);
    let origin = floor.origin;
    let cell = params.cell;
    fold_points(
        reader,
        || CellGrid::new(cell, origin, Occ { n: 0, hi: 0.0 }),
        |g, pts| {
            for p in pts {
                let Some(fk) = floor.key(p.x, p.y) else {
                    continue;
                };
                let Some(&f) = floor.get(fk) else { continue };
                let h = (p.z - z0) as f32 - f;
                // Up to a metre above the limit counts (a group reaching
                // there is not a target); higher is an overhang (a canopy, a
                // roof) that must not hide a target standing under it.
                if h > lo_h && h < hi_h + 1.0 && f.is_finite() {
                    if let Some(k) = g.key(p.x, p.y) {
                        let c = g.entry(k);
                        c.n += 1;
                        c.hi = c.hi.max(h.min(hi_h + 1.0));
                    }
                }
            }
        },
        |a, b| {
            a.merge(b, |x, y| {
                x.n += y.n;
                x.hi = x.hi.max(y.hi);
            })
        },
        progress,
    )
}

/// The centres of the groups of cells small enough to be a target; why each
/// other group is not one is counted in `rejected`.
fn candidate_centres(
    occ: &CellGrid<Occ>,
    params: &DetectParams,
    rejected: &mut HashMap<String, usize>,
) -> Vec<Point> {
    groups(occ, params)
        .iter()
        .filter_map(|g| match g {
            Ok(c) => Some(*c),
            Err(why) => {
                *rejected.entry(why.to_string()).or_default() += 1;
                None
            }
        })
        .collect()
}

/// The tight crop's L detector on each candidate's crop (in parallel): a
/// detection, or why the candidate is not a target.
fn shapes(
    crops: &[Vec<Point>],
    centres: &[Point],
    motion: &RigidMotion,
    params: &DetectParams,
    models: Models,
) -> Vec<std::result::Result<Detection, String>> {
    let tight = models.tight;
    let tp = TightParams {
        search_radius: params.search_radius,
        ..tight.clone()
    };
    crops
        .par_iter()
        .zip(centres)
        .map(|(pts, c)| {
            // No L there: a sphere, when they are looked for.
            let or_sphere = |why: String| match models.sphere {
                Some(sp) => sphere_at(pts, c, motion, params, sp).map_err(|s| s.unwrap_or(why)),
                None => Err(why),
            };
            let t = match tight_crop(pts, c, &tp) {
                Ok(t) => t,
                Err(e) => return or_sphere(short_reason(&e.to_string())),
            };
            if t.plate_height < DETECT_MIN_HEIGHT_SHARE * tight.plate_height {
                return or_sphere(format!(
                    "an L under {:.0} % of a plate's height",
                    100.0 * DETECT_MIN_HEIGHT_SHARE
                ));
            }
            let corner = t.corner_guess;
            let [wa, wb] = t.plate_widths;
            let fit = |m: f64, want: f64| 1.0 - ((m - want).abs() / want).min(1.0);
            let score = (fit(wa, tight.plate_width)
                * fit(wb, tight.plate_width)
                * fit(t.plate_height, tight.plate_height))
            .cbrt();
            Ok(Detection {
                model: crate::model::ModelKind::L,
                corner,
                corner_map: motion.invert(&corner),
                heading_deg: t.heading_deg,
                plate_widths: t.plate_widths,
                plate_height: t.plate_height,
                support: t.score,
                score,
            })
        })
        .collect()
}

/// A sphere of the surveyed diameter within the search radius of a
/// candidate's centre `c`, when the sphere locator finds and keeps one;
/// else why a sphere it found was refused (`None`: no sphere there).
fn sphere_at(
    pts: &[Point],
    c: &Point,
    motion: &RigidMotion,
    params: &DetectParams,
    (sp, diameter): (&crate::model::SphereParams, f64),
) -> std::result::Result<Detection, Option<String>> {
    let p = crate::model::SphereParams {
        search_radius_m: params.search_radius,
        ..sp.clone()
    };
    let search = crate::model::sphere::Search {
        points: pts,
        expected: *c,
        others: &[],
        radius: diameter / 2.0,
        up: nalgebra::Vector3::z(),
        surveyed: false,
    };
    let (fit, _) = crate::model::sphere::locate(&search, &p).map_err(|e| match e {
        // Counted as one kind (the sphere locator's reasons carry numbers;
        // `eval` at a surveyed place names them).
        crate::model::SphereError::NoSphere { seen: Some(_), .. } => Some(NOT_A_SPHERE.to_string()),
        _ => None,
    })?;
    let score = 1.0 - ((fit.free_radius - fit.radius).abs() / fit.radius).min(1.0);
    Ok(Detection {
        model: crate::model::ModelKind::Sphere,
        corner: fit.centre,
        corner_map: motion.invert(&fit.centre),
        heading_deg: 0.0,
        plate_widths: [diameter; 2],
        plate_height: diameter,
        support: fit.inliers,
        score,
    })
}

/// One detection per object, strongest first: candidates close together
/// may find the same L (or sphere; an L and a sphere are two objects).
fn one_per_object(mut detections: Vec<Detection>, tight: &TightParams) -> Vec<Detection> {
    detections.sort_by(|a, b| {
        b.support
            .cmp(&a.support)
            .then(a.corner.x.total_cmp(&b.corner.x))
            .then(a.corner.y.total_cmp(&b.corner.y))
    });
    let mut kept: Vec<Detection> = Vec::new();
    for d in detections {
        if kept.iter().all(|k| {
            k.model != d.model || (k.corner - d.corner).xy().norm() > 0.3 * tight.plate_width / 0.6
        }) {
            kept.push(d);
        }
    }
    kept
}

/// The rejections' reasons, most common first (then by reason, so the list
/// does not depend on the hash map's order).
fn most_common_first(rejected: HashMap<String, usize>) -> Vec<(String, usize)> {
    let mut rejected: Vec<(String, usize)> = rejected.into_iter().collect();
    rejected.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    rejected
}

/// The rejections that are near misses of a model: the hint a user acts on
/// (`--plate-size`, `--sphere-diameter`).
const L_OF_ANOTHER_SIZE: &str = "an L of another size than the target's";
const NOT_A_SPHERE: &str = "a round object, not a sphere target";

/// A tight-crop error as a kind, without its numbers, so that rejections can
/// be counted.
fn short_reason(e: &str) -> String {
    let kinds = [
        ("m wide plates expected", L_OF_ANOTHER_SIZE),
        ("continuing", "a plane going on past the corner"),
        ("tall", "an L taller than a plate"),
        ("T or a cross", "a T or a cross"),
        ("faces going on", "faces going on past a plate's edge"),
        ("nothing stands above", "nothing above the ground"),
    ];
    for (k, v) in kinds {
        if e.contains(k) {
            return v.into();
        }
    }
    if e.starts_with("no target-shaped object") {
        return "no L of two perpendicular plates".into();
    }
    e.split(['(', ';']).next().unwrap_or(e).trim().to_string()
}

/// Connected groups of occupied cells: the centre of each small enough to be
/// a target, or why not.
fn groups(occ: &CellGrid<Occ>, p: &DetectParams) -> Vec<std::result::Result<Point, &'static str>> {
    let cells: Vec<((i64, i64), Occ)> = occ
        .cells()
        .filter(|(_, c)| c.n > 0)
        .map(|(k, c)| (k, *c))
        .collect();
    let index: HashMap<(i64, i64), usize> =
        cells.iter().enumerate().map(|(i, c)| (c.0, i)).collect();
    let mut seen = vec![false; cells.len()];
    let max_cells = (p.max_extent / p.cell).ceil() as i64;
    let mut out = Vec::new();
    let mut queue = VecDeque::new();
    for start in 0..cells.len() {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        queue.push_back(start);
        let (mut x0, mut x1, mut y0, mut y1) = (i64::MAX, i64::MIN, i64::MAX, i64::MIN);
        let (mut n, mut sx, mut sy, mut hi) = (0u64, 0.0, 0.0, 0.0f32);
        while let Some(i) = queue.pop_front() {
            let (k, c) = cells[i];
            x0 = x0.min(k.0);
            x1 = x1.max(k.0);
            y0 = y0.min(k.1);
            y1 = y1.max(k.1);
            n += c.n as u64;
            sx += (k.0 - cells[start].0.0) as f64 * c.n as f64;
            sy += (k.1 - cells[start].0.1) as f64 * c.n as f64;
            hi = hi.max(c.hi);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(&j) = index.get(&(k.0 + dx, k.1 + dy))
                        && !seen[j]
                    {
                        seen[j] = true;
                        queue.push_back(j);
                    }
                }
            }
        }
        if n < p.min_points {
            continue; // specks: not worth a reason
        }
        if x1 - x0 + 1 > max_cells || y1 - y0 + 1 > max_cells {
            out.push(Err(
                "larger than a target (a wall, a vehicle, a hedge, a building)",
            ));
            continue;
        }
        if hi > p.max_height as f32 {
            out.push(Err("taller than a target"));
            continue;
        }
        let (kx, ky) = cells[start].0;
        let c = occ.centre((kx, ky));
        let (fx, fy) = (sx / n as f64, sy / n as f64);
        out.push(Ok(Point::new(c[0] + fx * p.cell, c[1] + fy * p.cell, 0.0)));
    }
    out
}
