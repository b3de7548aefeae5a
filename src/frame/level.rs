//! Levelling: the map's vertical from its ground, map-wide.
//!
//! One pass keeps the lowest point of every 0.5 m cell (the ground, where
//! anything was seen of it). Blocks of 4 × 4 cells (2 m) that are planar give
//! one ground normal each; the map's vertical is the *mode* of those normals
//! (the direction most of the ground shares, within 1°), not their mean: ramps,
//! embankments, pitched roofs and the foot of walls each lean their own way and
//! are outvoted by the roads, yards and flat roofs of any real site.
//!
//! The ground is not always level, so this vertical is a coarse one (a site's
//! general slope is in it); [`crate::pipeline`] refines it with the targets'
//! own plumb lines, which are built vertical.

use super::grid::CellGrid;
use crate::cloud::{MapSource, RigidMotion, fold_points_until};
use crate::{Point, Result};
use nalgebra::Vector3;
use std::collections::HashMap;

/// Ground cell side (metres).
const CELL: f64 = 0.5;
/// Block side in cells.
const BLOCK: i64 = 4;
/// A block is ground when its lowest points lie within this of a plane (m).
const PLANAR: f64 = 0.06;
/// Ground steeper than this is not evidence of the vertical (degrees).
const MAX_SLOPE_DEG: f64 = 20.0;
/// Half-width of the mode window (degrees).
const MODE_DEG: f64 = 1.0;

/// What the map's ground says about its vertical.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundLevel {
    /// The ground's common upward normal (map frame).
    pub up: Vector3<f64>,
    /// Its angle from +z (degrees).
    pub tilt_deg: f64,
    /// Azimuth of the direction the ground rises towards, degrees from +x.
    pub azimuth_deg: f64,
    /// Planar 2 m ground blocks seen.
    pub blocks: usize,
    /// Share of them within 1° of `up`.
    pub support: f64,
    /// A point near the map's middle: the centre of rotation when levelling.
    pub centre: Point,
    /// Memory the ground grid took (bytes).
    pub grid_bytes: usize,
}

impl GroundLevel {
    /// The rotation about `centre` that makes `up` vertical.
    pub fn motion(&self) -> RigidMotion {
        RigidMotion::levelling(self.centre, &self.up)
    }
}

/// Most cells a [`Footprint`] keeps (a 1 km² site at 4 m).
pub const FOOTPRINT_CELLS: usize = 65_536;

/// The map from above: where it holds points (for the report's overview).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Footprint {
    /// Cell side (m).
    pub cell: f64,
    /// Each cell that holds points: its centre at the ground (x, y, z) in
    /// the frame the targets' map positions are given in (the levelled one),
    /// and the share of its 0.5 m cells that do (a sampled ground pass leaves
    /// some out).
    pub cells: Vec<([f64; 3], f32)>,
}

/// The map's ground as one pass saw it: its vertical, and the lowest point of
/// every cell (for heights above ground in later passes).
#[derive(Debug, Clone)]
pub struct MapGround {
    /// The vertical, or `None` when too little ground was seen.
    pub level: Option<GroundLevel>,
    /// Finite points read.
    pub points: u64,
    /// The reader's counters over the whole map (finite points, non-finite
    /// ones skipped).
    pub read: crate::cloud::ReadStats,
    /// What the pass read (points and bytes).
    pub pass_read: crate::cloud::PassRead,
    /// A point near the map's middle (whole metres): the centre of
    /// rotation for any turn of the map, whether or not a vertical was found.
    pub centre: Point,
    /// Lowest and highest z of the map (`None` without points, or when only a
    /// sample was read: its range may miss the map's extremes): how far a
    /// tilted map's points can move sideways when it is levelled.
    pub z_range: Option<[f64; 2]>,
    /// Lowest and highest z of the points read, a sample's too.
    pub z_seen: Option<[f64; 2]>,
    /// The step float32 coordinates keep at the map's farthest coordinate,
    /// and that coordinate (m), when the file stores them so and the step
    /// exceeds a millimetre (a UTM map written as float32: 0.5 m at
    /// northings of 5.4e6 m).
    pub float32_step: Option<(f64, f64)>,
    /// Only a sample of the map was read (see [`ground_level`]): the
    /// vertical and centre are the sample's, and `lowest` has no ground
    /// where the sample had no points.
    pub sampled: bool,
    pub(crate) lowest: CellGrid<f32>,
    pub(crate) z0: f64,
}

impl MapGround {
    /// How far the points seen lie apart in z (m), sample or not: a site's
    /// relief and buildings, where a map with y up spreads over its length.
    pub fn z_extent(&self) -> Option<f64> {
        self.z_seen.map(|[lo, hi]| hi - lo)
    }

    /// The share of the map's 2 m blocks (those with ten or more cells
    /// seen) whose lowest points are flat and face within 20° of +z: most,
    /// on a site mapped z up (a stairwell's landings, a hillside trail);
    /// a few walls, on one mapped y up (its walls are its "floors").
    pub fn flat_share(&self) -> f64 {
        let blocks = blocks_of(&self.lowest);
        let eligible = blocks.values().filter(|c| c.len() >= 10).count();
        let min_cos = MAX_SLOPE_DEG.to_radians().cos();
        let flat = blocks
            .values()
            .filter_map(|c| block_normal(c))
            .filter(|n| n.z >= min_cos)
            .count();
        if eligible == 0 {
            0.0
        } else {
            flat as f64 / eligible as f64
        }
    }

    /// How far the ground's cells (0.5 m) reach along x and y, `None` for a
    /// map without points: a map in degrees (longitude, latitude) spans a
    /// cell or two.
    pub fn horizontal_span(&self) -> Option<[f64; 2]> {
        let mut k = self
            .lowest
            .cells()
            .filter(|(_, z)| z.is_finite())
            .map(|(k, _)| k);
        let first = k.next()?;
        let (lo, hi) = k.fold((first, first), |(lo, hi), (x, y)| {
            ((lo.0.min(x), lo.1.min(y)), (hi.0.max(x), hi.1.max(y)))
        });
        let cells = |a: i64, b: i64| (b - a + 1) as f64 * CELL;
        Some([cells(lo.0, hi.0), cells(lo.1, hi.1)])
    }

    /// The motion that levels the map: the ground's vertical made +z when it
    /// leans more than `above_deg` (below, a site's own slope could be most of
    /// it, and the targets' plumb lines decide later) and at least
    /// `min_support` of the flat ground blocks agree on it (fewer: the lean
    /// is terrain's, see [`MapGround::leans_weakly`]); else the identity.
    pub fn levelling(&self, above_deg: f64, min_support: f64) -> RigidMotion {
        match &self.level {
            Some(l) if l.tilt_deg > above_deg && l.support >= min_support => l.motion(),
            _ => RigidMotion::identity_at(self.centre),
        }
    }

    /// The ground's lean when it is beyond `above_deg` but too few of its
    /// flat blocks agree on it (below `min_support`) to level the map by.
    pub fn leans_weakly(&self, above_deg: f64, min_support: f64) -> Option<&GroundLevel> {
        self.level
            .as_ref()
            .filter(|l| l.tilt_deg > above_deg && l.support < min_support)
    }

    /// This ground with every cell seen: a sampled one is read again whole
    /// (map-wide detection needs the ground under every cell), keeping the
    /// sample's vertical and centre, which the map was already levelled by.
    pub fn completed(&self, source: MapSource, progress: impl FnMut(u64)) -> Result<MapGround> {
        if !self.sampled {
            return Ok(self.clone());
        }
        let mut all = ground_level(source, None, None, progress)?;
        all.level = self.level.clone();
        all.centre = self.centre;
        Ok(all)
    }

    /// The map seen from above, in the frame `motion` moves it into: which
    /// of the ground pass's 0.5 m cells hold a point, merged into cells of
    /// 0.5 × 2^k m until at most [`FOOTPRINT_CELLS`] remain (a report's
    /// figure is a few hundred pixels across). Rendered under the target
    /// positions; costs no pass of its own.
    pub fn footprint(&self, motion: &RigidMotion) -> Footprint {
        // Counted first and folded straight from the grid: a list of every
        // occupied 0.5 m cell would take four times the grid's memory.
        let occupied = self.lowest.cells().filter(|(_, z)| z.is_finite()).count() as i64;
        let mut f: i64 = 1;
        while occupied / (f * f) > FOOTPRINT_CELLS as i64 {
            f *= 2;
        }
        // Coarse cell → (0.5 m cells occupied, their summed ground height).
        type Coarse = std::collections::BTreeMap<(i64, i64), (u32, f64)>;
        let mut coarse: Coarse = Default::default();
        loop {
            coarse.clear();
            for (k, &z) in self.lowest.cells().filter(|(_, z)| z.is_finite()) {
                let c = coarse
                    .entry((k.0.div_euclid(f), k.1.div_euclid(f)))
                    .or_default();
                c.0 += 1;
                c.1 += z as f64;
            }
            // Coarse cells of a sparse set stay many.
            if coarse.len() <= FOOTPRINT_CELLS {
                break;
            }
            f *= 2;
        }
        let cell = CELL * f as f64;
        let o = self.lowest.origin;
        Footprint {
            cell,
            cells: coarse
                .into_iter()
                .map(|((x, y), (n, zs))| {
                    // Turned at the ground's own height, as `floor` does: a
                    // tilted map's cells move sideways by height × angle.
                    let c = Point::new(
                        o[0] + (x as f64 + 0.5) * cell,
                        o[1] + (y as f64 + 0.5) * cell,
                        self.z0 + zs / n as f64,
                    );
                    let q = motion.apply(&c);
                    ([q.x, q.y, q.z], n as f32 / (f * f) as f32)
                })
                .collect(),
        }
    }

    /// The ground's height under every 0.5 m cell of the frame `motion` moves
    /// the map into: the lowest moved ground point in the cell's 3 × 3
    /// neighbourhood (bumps and the residual slope cost a few centimetres).
    pub(crate) fn floor(&self, motion: &RigidMotion) -> CellGrid<f32> {
        let mut moved = CellGrid::new(CELL, self.lowest.origin, f32::INFINITY);
        for (k, &z) in self.lowest.cells() {
            if z.is_finite() {
                let c = self.lowest.centre(k);
                let q = motion.apply(&Point::new(c[0], c[1], self.z0 + z as f64));
                if let Some(k) = moved.key(q.x, q.y) {
                    let m = moved.entry(k);
                    *m = m.min((q.z - self.z0) as f32);
                }
            }
        }
        let mut floor = CellGrid::new(CELL, self.lowest.origin, f32::INFINITY);
        for (k, &z) in moved.cells() {
            if z.is_finite() {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let f = floor.entry((k.0 + dx, k.1 + dy));
                        *f = f.min(z);
                    }
                }
            }
        }
        floor
    }
}

/// Lowest z per cell, relative to the grid's origin height.
#[derive(Clone)]
struct Lowest {
    grid: CellGrid<f32>,
    z0: f64,
    count: u64,
    /// Sums of the offsets from the origin in whole millimetres: integers, so
    /// the centre does not depend on the order threads add them in.
    sum: [i128; 3],
    /// Lowest and highest z seen.
    z: [f64; 2],
    /// The grid is spread too thin for a map in metres: no more is added.
    thin: bool,
    /// The largest |coordinate| seen (m), for float32's step there.
    reach: f64,
}

/// What the error of a map spread too thin says first (the pipeline adds
/// the survey's extent to it).
pub(crate) const TOO_THIN: &str = "the map's points are spread too thin for a map in metres";

/// The error of a pass whose grid was spread too thin
/// ([`CellGrid::spread_thin`]), `extent` (m) the points' spread when it
/// stopped.
pub(crate) fn too_thin(source: &MapSource, extent: [f64; 2]) -> crate::Error {
    let km = |m: f64| {
        if m >= 1e4 {
            format!("{:.0} km", m / 1e3)
        } else {
            format!("{:.1} km", m / 1e3)
        }
    };
    let msg = format!(
        "{}: {TOO_THIN}: the points read so far span {} × {}, and over {} squares of 32 m held fewer than {} points each on average, where a map's surfaces give thousands a square. Is it in millimetres or another unit? mapgauge reads coordinates as metres (for millimetres: `mapgauge convert --map MAP --out MAP_m.pcd --scale 0.001`, then run again); reading stopped before its memory grew with that extent",
        source.name(),
        km(extent[0]),
        km(extent[1]),
        super::grid::THIN_TILES,
        super::grid::THIN_PER_TILE,
    );
    crate::Error::NotMetres { extent, msg }
}

/// Streams the map once and estimates its vertical from the ground. `None`
/// when the map shows too little ground (fewer than 20 planar blocks).
///
/// With `sample`, a map of more points may be read in part: an even
/// selection of its tiles, COPC nodes, LAZ chunks or blocks of records
/// holding about that many points ([`crate::cloud::PointReader::hint_sample`]),
/// each part whole so its ground cells are seen as densely as in the whole
/// map. The vertical is the mode of many block normals, so a sample of
/// millions of points finds it as the whole map does.
pub fn ground_level(
    source: MapSource,
    motion: Option<&RigidMotion>,
    sample: Option<u64>,
    progress: impl FnMut(u64),
) -> Result<MapGround> {
    let first = match first_point(&source, motion)? {
        Ok(p) => p,
        Err(empty) => return Ok(empty),
    };
    let origin = [first.x.round(), first.y.round()];
    let z0 = first.z.round();
    let mut reader = source.open_moved(motion)?;
    if let Some(n) = sample {
        reader.hint_sample(n);
    }
    let low = fold_points_until(
        reader.as_mut(),
        || Lowest::new(origin, z0),
        |acc, pts| acc.add(pts, origin),
        Lowest::merge,
        |a| a.thin,
        progress,
    )?;
    if low.thin {
        return Err(too_thin(&source, low.grid.extent()));
    }
    let centre = low.centre(origin);
    let level = level_of(&low.grid, centre);
    let sampled = reader.sampled().is_some();
    let step = crate::cloud::float32_step(low.reach);
    let float32_step = (reader.float32_coords() && step > 1e-3).then_some((step, low.reach));
    Ok(MapGround {
        level,
        centre,
        z_range: (low.z[0] <= low.z[1] && !sampled).then_some(low.z),
        z_seen: (low.z[0] <= low.z[1]).then_some(low.z),
        sampled,
        float32_step,
        points: low.count,
        read: reader.stats(),
        pass_read: crate::cloud::PassRead::of("ground", reader.as_ref()),
        lowest: low.grid,
        z0,
    })
}

/// The map's first point, the grid's origin (cell keys and heights stay
/// small for georeferenced maps); or, for a map without points, its ground.
fn first_point(
    source: &MapSource,
    motion: Option<&RigidMotion>,
) -> Result<std::result::Result<Point, MapGround>> {
    let mut r = source.open_moved(motion)?;
    let mut buf = Vec::new();
    let mut p = None;
    while p.is_none() && r.next_chunk(&mut buf)? {
        p = buf.first().copied();
    }
    Ok(match p {
        Some(p) => Ok(p),
        None => Err(MapGround {
            level: None,
            points: 0,
            read: r.stats(),
            pass_read: crate::cloud::PassRead::of("ground", r.as_ref()),
            centre: Point::origin(),
            z_range: None,
            z_seen: None,
            sampled: false,
            float32_step: None,
            lowest: CellGrid::new(CELL, [0.0, 0.0], f32::INFINITY),
            z0: 0.0,
        }),
    })
}

impl Lowest {
    /// An empty grid about the first point (`origin`, `z0`).
    fn new(origin: [f64; 2], z0: f64) -> Self {
        Lowest {
            grid: CellGrid::new(CELL, origin, f32::INFINITY),
            z0,
            count: 0,
            sum: [0; 3],
            z: [f64::INFINITY, f64::NEG_INFINITY],
            thin: false,
            reach: 0.0,
        }
    }

    /// Adds a batch's points, in runs of 1024 so that a grid spread too thin
    /// stops growing within a run of where it became so.
    fn add(&mut self, pts: &[Point], origin: [f64; 2]) {
        let z0 = self.z0;
        for run in pts.chunks(1024) {
            if self.thin {
                return;
            }
            let mut s = [0i128; 3];
            let mut n = 0;
            for p in run {
                self.z = [self.z[0].min(p.z), self.z[1].max(p.z)];
                if let Some(k) = self.grid.key(p.x, p.y) {
                    // Of the points kept (a stray one beyond the
                    // Earth's radius is no part of the site).
                    self.reach = self.reach.max(p.x.abs()).max(p.y.abs()).max(p.z.abs());
                    let z = (p.z - self.z0) as f32;
                    let c = self.grid.entry(k);
                    if z < *c {
                        *c = z;
                    }
                    // Through i64: f64 -> i128 is a slow library call (7 %
                    // of a 20 M-point eval), and i64 holds any offset from
                    // the first point below 9e15 m exactly.
                    let mm = |v: f64| (v * 1000.0).round_ties_even() as i64 as i128;
                    s[0] += mm(p.x - origin[0]);
                    s[1] += mm(p.y - origin[1]);
                    s[2] += mm(p.z - z0);
                    n += 1;
                }
            }
            self.count += n;
            for k in 0..3 {
                self.sum[k] += s[k];
            }
            self.thin = self.grid.spread_thin();
        }
    }

    /// Merges another thread's grid; a grid spread too thin is kept as it is
    /// (whichever shows it), and no more is merged into it.
    fn merge(&mut self, b: Lowest) {
        if self.thin || b.thin {
            if b.thin && !self.thin {
                *self = b;
            }
            return;
        }
        self.grid.merge(b.grid, |x, y| {
            if *y < *x {
                *x = *y
            }
        });
        self.thin = self.grid.spread_thin();
        self.count += b.count;
        for k in 0..3 {
            self.sum[k] += b.sum[k];
        }
        self.z = [self.z[0].min(b.z[0]), self.z[1].max(b.z[1])];
        self.reach = self.reach.max(b.reach);
    }

    /// The points' mean position rounded to whole metres: the centre of
    /// rotation, the same whatever order the threads added the points in.
    fn centre(&self, origin: [f64; 2]) -> Point {
        let n = self.count.max(1) as f64 * 1000.0;
        Point::new(
            origin[0] + (self.sum[0] as f64 / n).round(),
            origin[1] + (self.sum[1] as f64 / n).round(),
            self.z0 + (self.sum[2] as f64 / n).round(),
        )
    }
}

/// The ground's vertical from the grid of lowest points, with the angles a
/// report states it by; `None` when too little ground was seen.
fn level_of(grid: &CellGrid<f32>, centre: Point) -> Option<GroundLevel> {
    estimate(grid).map(|(up, blocks, support)| {
        let tilt_deg = up.angle(&Vector3::z()).to_degrees();
        GroundLevel {
            up,
            tilt_deg,
            azimuth_deg: (-up.y).atan2(-up.x).to_degrees().rem_euclid(360.0),
            blocks,
            support,
            centre,
            grid_bytes: grid.bytes(),
        }
    })
}

/// Each 2 m block's cells with a lowest point (local x, y, z).
fn blocks_of(grid: &CellGrid<f32>) -> HashMap<(i64, i64), Vec<[f64; 3]>> {
    let mut blocks: HashMap<(i64, i64), Vec<[f64; 3]>> = HashMap::new();
    for (k, &z) in grid.cells() {
        if z.is_finite() {
            let b = (k.0.div_euclid(BLOCK), k.1.div_euclid(BLOCK));
            let x = (k.0.rem_euclid(BLOCK) as f64 + 0.5) * CELL;
            let y = (k.1.rem_euclid(BLOCK) as f64 + 0.5) * CELL;
            blocks.entry(b).or_default().push([x, y, z as f64]);
        }
    }
    blocks
}

/// The mode of planar blocks' normals: (up, blocks, share within 1°).
fn estimate(grid: &CellGrid<f32>) -> Option<(Vector3<f64>, usize, f64)> {
    let blocks = blocks_of(grid);
    let mut keys: Vec<(i64, i64)> = blocks.keys().copied().collect();
    keys.sort_unstable();
    let min_cos = MAX_SLOPE_DEG.to_radians().cos();
    let normals: Vec<Vector3<f64>> = keys
        .iter()
        .filter_map(|k| block_normal(&blocks[k]))
        .filter(|n| n.z >= min_cos)
        .collect();
    if normals.len() < 20 {
        return None;
    }
    // Histogram of the normals' horizontal components, bins of a quarter
    // degree; the window of ±1° with the most normals is the mode.
    let bin = 0.25_f64.to_radians();
    let mut hist: HashMap<(i64, i64), u32> = HashMap::new();
    for n in &normals {
        *hist
            .entry(((n.x / bin).round() as i64, (n.y / bin).round() as i64))
            .or_default() += 1;
    }
    let reach = (MODE_DEG / 0.25).round() as i64;
    let mut bins: Vec<(i64, i64)> = hist.keys().copied().collect();
    bins.sort_unstable();
    let mut best = ((0, 0), 0u32);
    for &(bx, by) in &bins {
        let mut s = 0;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                s += hist.get(&(bx + dx, by + dy)).copied().unwrap_or(0);
            }
        }
        if s > best.1 {
            best = ((bx, by), s);
        }
    }
    let (bx, by) = best.0;
    let mut up = Vector3::new(bx as f64 * bin, by as f64 * bin, 1.0).normalize();
    // Refine: the mean of the normals near the mode, twice.
    let window = MODE_DEG.to_radians();
    let mut support = 0;
    for _ in 0..2 {
        let near: Vec<&Vector3<f64>> = normals.iter().filter(|n| n.angle(&up) <= window).collect();
        if near.is_empty() {
            break;
        }
        support = near.len();
        up = near
            .iter()
            .fold(Vector3::zeros(), |s, n| s + *n)
            .normalize();
    }
    Some((up, normals.len(), support as f64 / normals.len() as f64))
}

/// Least-squares plane z = a·x + b·y + c through a block's lowest points, when
/// at least 10 of its 16 cells saw ground and they lie on the plane.
fn block_normal(cells: &[[f64; 3]]) -> Option<Vector3<f64>> {
    if cells.len() < 10 {
        return None;
    }
    let n = cells.len() as f64;
    let m = cells
        .iter()
        .fold([0.0; 3], |s, c| [s[0] + c[0], s[1] + c[1], s[2] + c[2]]);
    let m = [m[0] / n, m[1] / n, m[2] / n];
    let (mut sxx, mut sxy, mut syy, mut sxz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for c in cells {
        let (x, y, z) = (c[0] - m[0], c[1] - m[1], c[2] - m[2]);
        sxx += x * x;
        sxy += x * y;
        syy += y * y;
        sxz += x * z;
        syz += y * z;
    }
    let det = sxx * syy - sxy * sxy;
    if det.abs() < 1e-9 {
        return None;
    }
    let a = (sxz * syy - syz * sxy) / det;
    let b = (syz * sxx - sxz * sxy) / det;
    let worst = cells
        .iter()
        .map(|c| ((c[2] - m[2]) - a * (c[0] - m[0]) - b * (c[1] - m[1])).abs())
        .fold(0.0, f64::max);
    (worst <= PLANAR).then(|| Vector3::new(-a, -b, 1.0).normalize())
}

#[cfg(test)]
mod tests;
