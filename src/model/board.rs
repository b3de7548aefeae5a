//! The checkerboard board: a flat square of four squares, two bright and two
//! dark, found near its expected position and located by the point where
//! the four squares meet.
//!
//! 1. **Planes.** Above the local ground, the crop is binned in cells half a
//!    board wide; in each occupied cell, triples of its points give planes
//!    scored by the points within 2 cm of them nearby.
//! 2. **What a board is, by shape.** The best planes, one per place, are
//!    refitted (SVD) on their points within a board's reach and measured in
//!    the plane: a face wider than the board (a wall, a van's side) or much
//!    smaller (a post, a leg) is refused.
//! 3. **What a board is, by pattern.** On the board's points, the intensity
//!    must show the checkerboard: a coarse search over the two boundary
//!    lines' angle and crossing (counts of bright and dark points per
//!    quadrant, from prefix sums), refined by a least-squares fit of a
//!    blurred checkerboard, `lo + (hi − lo)·P`, where `P` is the chance a
//!    footprint at that point lands on a bright square (logistic edges of a
//!    fitted width `w`: mixed pixels at the square edges are what the blur
//!    models, and `lo`, `hi` are fitted, so any sensor's intensity scale
//!    does). A flat sign of one colour (no contrast over the intensity
//!    noise), a sign with another print (the pattern explains too little of
//!    the intensity) or a board seen too little to place both lines (a
//!    quadrant nearly empty) is refused.
//! 4. **Choice.** Of the boards with a quarter of the best's support or
//!    more, the one nearest the expected position, unless nearer another
//!    target's.
//! 5. **On a surface** (`flat.rs`), when nothing standing free is a board:
//!    the ground, then each standing wall, searched for the print alone (a
//!    board lying there or hung flush has the surface's face).
//!
//! The covariance in the plane is the least-squares one of the crossing,
//! s² (JᵀWJ)⁻¹ (Huber weights), or the spread of refits on resampled points
//! where larger; across the plane, the plane's offset error, from its
//! residual and point count.

mod flat;

use super::sphere::{Grid, unit};
use crate::Point;
use crate::geom::plane::{Plane, fit as plane_fit};
use nalgebra::{Matrix2, SMatrix, SVector, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// Board parameters; the default size is a common 0.6 m ground-control board.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoardParams {
    /// Side (m) of boards the survey gives no `size` for.
    pub side_m: f64,
    /// Fewest points on the board for a board: fewer leave its lines to a
    /// few rows (synth boards 15–30 m off with 60–99 points: 2 of 13 outside
    /// their 99.9 % ellipsoid).
    pub min_points: usize,
    /// Horizontal search radius around the expected position (m).
    pub search_radius_m: f64,
    /// Most points of a crop looked at (a uniform, deterministic sample
    /// beyond), so the cost stays bounded however dense the map.
    pub max_points: usize,
    /// Seed of the plane hypotheses' and the resampling's draws.
    pub seed: u64,
}

impl Default for BoardParams {
    fn default() -> Self {
        BoardParams {
            side_m: 0.6,
            min_points: 100,
            search_radius_m: 4.5,
            max_points: 60_000,
            seed: 0,
        }
    }
}

/// A located board.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BoardFit {
    /// Where the four squares meet, on the board's face (the points' frame).
    #[serde(serialize_with = "ser_point")]
    pub centre: Point,
    /// The face's unit normal (towards the side the points were seen from
    /// is not known: its sign is the fit's).
    pub normal: [f64; 3],
    /// The two boundary lines' directions in the face (unit vectors; the
    /// first is the direction of the line where the fit's second offset
    /// changes sign, so the order says nothing more than which is which).
    pub lines: [[f64; 3]; 2],
    /// Points on the board the pattern was fitted to.
    pub points: usize,
    /// The face's extent seen, along its two in-plane axes (horizontal
    /// first), m.
    pub extent_m: [f64; 2],
    /// The fitted intensity of the dark and the bright squares.
    pub levels: [f64; 2],
    /// Their difference over the intensity noise (residual σ).
    pub contrast: f64,
    /// The edges' fitted blur (logistic scale, m).
    pub blur_m: f64,
    /// Share of the intensity's variance the pattern explains.
    pub explained: f64,
    /// Share of the points away from the edges whose colour the pattern
    /// predicts.
    pub agreement: f64,
    /// RMS distance of the board's points from its plane, m.
    pub plane_rms: f64,
    /// Covariance of the centre (m², row-major).
    pub covariance: [[f64; 3]; 3],
    /// Centres refitted on resampled points (their spread is in the
    /// covariance too).
    #[serde(skip)]
    pub samples: Vec<Point>,
    /// Whether each of the board's points (as returned with the fit) reads
    /// as a bright square: the report draws the print with it.
    #[serde(skip)]
    pub bright: Vec<bool>,
    /// Boards seen in the search.
    pub candidates: usize,
}

fn ser_point<S: serde::Serializer>(p: &Point, s: S) -> Result<S::Ok, S::Error> {
    [p.x, p.y, p.z].serialize(s)
}

/// Why no board was located.
#[derive(Debug, Clone, PartialEq, thiserror::Error, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum BoardError {
    /// Nothing within the search radius.
    #[error("no map points within {radius} m of the expected position")]
    NoPoints {
        /// Search radius (m).
        radius: f64,
    },
    /// The map carries no intensity mapgauge reads, and a board is told
    /// only by its pattern.
    #[error("a checkerboard is told by its intensity pattern, and {why}")]
    NoIntensity {
        /// What the map lacks.
        why: String,
    },
    /// Nothing flat, of the surveyed size and with the pattern, stood there.
    #[error(
        "no checkerboard board of {side_mm:.0} mm within {radius} m ({points} points looked at){}",
        seen.as_ref().map_or(String::new(), |s| format!("; closest thing seen: {s}"))
    )]
    NoBoard {
        /// Search radius (m).
        radius: f64,
        /// The surveyed side (mm).
        side_mm: f64,
        /// Points looked at.
        points: usize,
        /// What was refused where the board should be (of the faces within
        /// [`super::SAME_PLACE_M`] of the nearest, the best supported), and why.
        seen: Option<String>,
        /// How far (m, horizontally) from the expected position the nearer
        /// of those stood: whether something stood at the place at all.
        #[serde(skip_serializing_if = "Option::is_none")]
        seen_from: Option<f64>,
    },
}

/// What a board needs to be found.
pub struct Search<'a> {
    /// The loose crop.
    pub points: &'a [Point],
    /// One intensity per point, in the sensor's own scale.
    pub intensity: &'a [f32],
    /// Where the survey places the centre (the points' frame).
    pub expected: Point,
    /// The other targets' expected positions: objects nearer them are theirs.
    pub others: &'a [Point],
    /// The board's side (m).
    pub side: f64,
    /// The vertical: the face's first axis is horizontal.
    pub up: Vector3<f64>,
    /// Whether a board on a surface wider than a board (lying on the
    /// ground, hung on a wall) may be it, when nothing standing free is:
    /// where a survey places a board, yes; about an object map-wide
    /// detection saw standing, no (its few metres of ground are too little
    /// intensity to tell a print from a scanner's rings by).
    pub on_surfaces: bool,
}

/// Finds and locates the board; returns it with its points (the tight crop).
pub fn locate(s: &Search, p: &BoardParams) -> Result<(BoardFit, Vec<Point>), BoardError> {
    let side = s.side;
    let o = s.expected;
    let reach = p.search_radius_m + side;
    let n_all = s.points.len().min(s.intensity.len());
    let mut idx: Vec<usize> = (0..n_all)
        .filter(|&i| (s.points[i] - o).xy().norm() <= reach)
        .collect();
    if idx.is_empty() {
        return Err(BoardError::NoPoints {
            radius: p.search_radius_m,
        });
    }
    if idx.len() > p.max_points {
        let keep = p.max_points as f64 / idx.len() as f64;
        idx.retain(|&i| unit(p.seed ^ 0x6b0a_7d31, i as u64) < keep);
    }
    let up = s.up.normalize();
    let all: Vec<Vector3<f64>> = idx.iter().map(|&i| s.points[i] - o).collect();
    let above = above_ground(&all, &up);
    let v: Vec<Vector3<f64>> = above.iter().map(|&k| all[k]).collect();
    let inten: Vec<f64> = above
        .iter()
        .map(|&k| f64::from(s.intensity[idx[k]]))
        .collect();
    // What the map's intensity spans here (5th–95th percentile of the crop:
    // a few retroreflectors, a sign or a plate, do not move it): a printed
    // board's squares differ by a good share of it.
    let spread = {
        let mut all_i: Vec<f64> = idx.iter().map(|&i| f64::from(s.intensity[i])).collect();
        all_i.retain(|x| x.is_finite());
        if all_i.is_empty() {
            0.0
        } else {
            pct(&mut all_i, 0.95) - pct(&mut all_i, 0.05)
        }
    };
    let look = Looked {
        all: &all,
        above: &above,
        v: &v,
        inten: &inten,
        intensity: &s.intensity,
        idx: &idx,
        spread,
        up,
        on_surfaces: s.on_surfaces,
    };
    let (cands, refused) = faces_of(&look, side, p);
    let others: Vec<Vector3<f64>> = s.others.iter().map(|q| q - o).collect();
    let Some(best) = choose(&cands, &others) else {
        let refused: Vec<&(usize, String, f64)> =
            refused.iter().filter(|r| r.0 >= p.min_points / 2).collect();
        let named = super::at_same_place(&refused, |r| r.2, |r| r.0);
        let seen = named.map(|(n, why, at)| {
            format!("{why} ({n} points, {at:.2} m from the expected position)")
        });
        // Where a survey places a board, one of a size it mistakes for
        // this one standing there is named (detection map-wide asks none).
        let hint = s
            .on_surfaces
            .then(|| other_side(&look, side, p, &others))
            .flatten();
        let seen_from = [named.map(|r| r.2), hint.as_ref().map(|h| h.1)]
            .into_iter()
            .flatten()
            .reduce(f64::min);
        let seen = super::with_hint(seen, hint.map(|h| h.0));
        return Err(BoardError::NoBoard {
            radius: p.search_radius_m,
            side_mm: side * 1e3,
            points: all.len(),
            seen,
            seen_from,
        });
    };
    let c = &cands[best];
    let samples = resampled(c, p.seed);
    let covariance = covariance(c, &samples);
    let fit = BoardFit {
        centre: o + c.centre,
        normal: c.normal.into(),
        lines: [c.line(0).into(), c.line(1).into()],
        points: c.pts.len(),
        extent_m: c.extent,
        levels: [c.x[3].min(c.x[4]), c.x[3].max(c.x[4])],
        contrast: (c.x[4] - c.x[3]).abs() / c.sigma,
        blur_m: c.x[5].exp(),
        explained: c.explained,
        agreement: c.agreement,
        plane_rms: c.plane_rms,
        covariance,
        samples: samples.iter().map(|v| o + v).collect(),
        bright: {
            let mid = (c.x[3] + c.x[4]) / 2.0;
            c.pts.iter().map(|q| q[2] > mid).collect()
        },
        candidates: cands.len(),
    };
    let near = c.pts3.iter().map(|v| o + v).collect();
    Ok((fit, near))
}

/// The board's search area, read once: its points (`all`, about the
/// expected position), those above the ground (`above`, their indices in
/// `all`; `v`, `inten`), the map's intensities and the crop's indices of
/// `all` (`intensity`, `idx`), what the intensity spans there, and whether
/// a board lying or hung may be it.
struct Looked<'a> {
    all: &'a [Vector3<f64>],
    above: &'a [usize],
    v: &'a [Vector3<f64>],
    inten: &'a [f64],
    intensity: &'a [f32],
    idx: &'a [usize],
    spread: f64,
    up: Vector3<f64>,
    on_surfaces: bool,
}

/// The boards of `side` in the search area, and the faces refused (points,
/// why, distance from the expected position): standing first, then lying,
/// then hung on a wall.
fn faces_of(l: &Looked, side: f64, p: &BoardParams) -> (Vec<Candidate>, Vec<(usize, String, f64)>) {
    let (all, above, v, inten, spread, up) = (l.all, l.above, l.v, l.inten, l.spread, l.up);
    let grid = Grid::new(v, side / 2.0);
    let mut cands: Vec<Candidate> = Vec::new();
    let mut refused: Vec<(usize, String, f64)> = Vec::new();
    // Planes of faces refused as walls (flat well beyond twice a board): a
    // wall or a van's side seeds a plane in every cell it crosses, each
    // judged the same. A face refused as wider only because its reach took
    // in a sign or a panel beside the board is not one: the board's own
    // seeds are still judged.
    let mut wide: Vec<Plane> = Vec::new();
    // The faces refused: where they were seeded, and their planes.
    let mut seen: Vec<(Vector3<f64>, Plane)> = Vec::new();
    for seed_plane in plane_seeds(v, &grid, side, p.seed) {
        if cands.len() + refused.len() >= CANDIDATES {
            break;
        }
        let sp = &seed_plane.plane;
        let on = |w: &Plane| {
            w.normal.dot(&sp.normal).abs() > 0.9
                && (w.normal.dot(&seed_plane.at) - w.offset).abs() < 0.03
        };
        let judged = cands
            .iter()
            .map(|c| {
                (
                    c.centre,
                    Plane {
                        normal: c.normal,
                        offset: c.normal.dot(&c.centre),
                    },
                )
            })
            .chain(seen.iter().copied())
            .any(|(at, w)| (at - seed_plane.at).norm() < 0.5 * side && on(&w))
            || wide.iter().any(|w| {
                w.normal.dot(&sp.normal).abs() > 0.98
                    && (w.normal.dot(&seed_plane.at) - w.offset).abs() < 0.03
            });
        if judged {
            continue;
        }
        match judge(v, inten, &grid, &seed_plane, side, &up, spread, p) {
            Ok(c) => cands.push(c),
            Err(r) => {
                wide.extend(r.wider);
                seen.push((seed_plane.at, *sp));
                refused.push((r.points, r.why, r.from))
            }
        }
    }
    // Nothing standing: a board lying on the ground (or flush with a
    // larger level surface) is told by its print alone.
    if cands.is_empty() && l.on_surfaces {
        let mut is_above = vec![false; all.len()];
        for &k in above {
            is_above[k] = true;
        }
        let low: Vec<usize> = (0..all.len()).filter(|&k| !is_above[k]).collect();
        let g: Vec<Vector3<f64>> = low.iter().map(|&k| all[k]).collect();
        let gi: Vec<f64> = low
            .iter()
            .map(|&k| f64::from(l.intensity[l.idx[k]]))
            .collect();
        let (found, flat_refused) =
            flat::flat_prints(&g, &gi, &up, side, (p.search_radius_m, spread), p);
        cands = found;
        refused.extend(flat_refused.into_iter().map(|r| (r.points, r.why, r.from)));
    }
    // Nor lying: a board hung on a wall (or a panel, a façade) is told by its
    // print on the wall's plane, searched as the ground is. The wall's
    // points within `ON_WALL` of its plane: a board mounted proud of it
    // stands that far off, and its own face is fitted again.
    if cands.is_empty() && l.on_surfaces {
        for w in walls(&wide, &up, p.search_radius_m) {
            let on: Vec<usize> = (0..v.len())
                .filter(|&i| (w.normal.dot(&v[i]) - w.offset).abs() < ON_WALL)
                .collect();
            if on.len() < p.min_points {
                continue;
            }
            let g: Vec<Vector3<f64>> = on.iter().map(|&i| v[i]).collect();
            let gi: Vec<f64> = on.iter().map(|&i| inten[i]).collect();
            let (found, wall_refused) =
                flat::flat_prints(&g, &gi, &w.normal, side, (p.search_radius_m, spread), p);
            refused.extend(wall_refused.into_iter().map(|r| (r.points, r.why, r.from)));
            // The best-supported wall with a print is the board's: its plane
            // is the best fitted. (A wall seen from both sides, or fitted
            // within a board's reach about its edge, is also a plane a few
            // centimetres off and leaning; gathered about such a plane the
            // board's points beyond the band are cut, and its crossing was
            // read 8-13 mm off along the normal.)
            if !found.is_empty() {
                cands = found;
                break;
            }
        }
    }
    (cands, refused)
}

/// When no board of `side` was taken: a board of a size a survey mistakes
/// for it (twice or half it; the configured side) that would be taken
/// here, named as a hint. Looked for only on failure.
fn other_side(
    l: &Looked,
    side: f64,
    p: &BoardParams,
    others: &[Vector3<f64>],
) -> Option<(String, f64)> {
    let mut sides = vec![2.0 * side, 0.5 * side, p.side_m];
    sides.retain(|&x| (x - side).abs() > 0.15 * side && (0.1..=3.0).contains(&x));
    sides.sort_by(|a, b| b.total_cmp(a));
    sides.dedup_by(|a, b| (*a - *b).abs() < 0.1 * *b);
    // Of the sizes taken, the one nearest the board's width as the largest
    // of them measures it (its reach takes in the whole board): a board is
    // taken at sizes up to a fifth larger than its own (a 0.6 m board
    // surveyed as 0.36 m was named a 720 mm one, the configured 600 mm
    // untried), and its middle is a smaller board's pattern too.
    let taken: Vec<(f64, f64, f64)> = sides
        .into_iter()
        .filter_map(|other| {
            let (cands, _) = faces_of(l, other, p);
            choose(&cands, others).map(|i| (other, cands[i].centre.xy().norm(), cands[i].extent[0]))
        })
        .collect();
    let width = taken.first()?.2;
    let nearest = taken
        .iter()
        .min_by(|a, b| (a.0 - width).abs().total_cmp(&(b.0 - width).abs()))
        .copied();
    nearest.map(|(other, from, _)| {
        (
            format!(
                "a board of {:.0} mm stands {from:.2} m from the expected position: is the size given ({:.0} mm: the survey's `size`, or `[board] side_m`) right?",
                other * 1e3,
                side * 1e3
            ),
            from,
        )
    })
}

/// A board's squares differ by at least this share of what the map's
/// intensity spans about it (5th–95th percentile of the crop): a printed
/// black and white differ by most of a sensor's range (synth: 185 of 255),
/// while the rings of one scan frame, each beam with its own gain, differ
/// by a few counts and fooled the fit on quantised intensity (a Velodyne
/// frame's ground: 3 of 100, its robust σ under one count).
const MIN_SPREAD_SHARE: f64 = 0.2;

/// Each quarter of a board (points away from the lines) reads mostly as
/// its square's colour.
const MIN_QUARTER_AGREEMENT: f64 = 0.7;

/// The walls a board may hang on, each once, best supported first (the
/// order `wide` was refused in: seeds by their support): the standing (a
/// slanted face, a roof's or a windshield's, holds no board) faces refused
/// as wider than a board whose plane passes within the search radius of
/// the expected position (the origin), a wall's repeats (planes within
/// `ON_WALL` and 10° of one kept) left out, at most `WALLS`; the first
/// with a print is taken.
fn walls(wide: &[Plane], up: &Vector3<f64>, radius: f64) -> Vec<Plane> {
    let w = wide
        .iter()
        .filter(|w| w.normal.dot(up).abs() < WALL_LEAN.sin() && w.offset.abs() <= radius)
        .copied();
    let mut kept: Vec<Plane> = Vec::new();
    for p in w {
        let again = kept.iter().any(|k| {
            let d = k.normal.dot(&p.normal);
            d.abs() > 0.985 && (k.offset - p.offset * d.signum()).abs() < ON_WALL
        });
        if !again {
            kept.push(p);
            if kept.len() == WALLS {
                break;
            }
        }
    }
    kept
}

/// Walls searched for a board hung on them, at most: each costs a
/// lattice over the search disc.
const WALLS: usize = 4;

/// The two squares of one colour differ by at most this share of the
/// difference between the colours (medians of their points away from the
/// lines): one paint, at one range.
const MAX_SQUARE_MISMATCH: f64 = 0.3;

/// The most a wall a board hangs on may lean (rad): walls and façades
/// stand, within a few degrees.
const WALL_LEAN: f64 = 0.26;

/// How far off a wall's plane (m) a board hung on it may stand: its
/// thickness and a bracket's.
const ON_WALL: f64 = 0.1;

/// Places judged: enough that other flat things (signs, walls' patches, the
/// ground's bumps) cannot crowd the board out before it is judged.
const CANDIDATES: usize = 96;

/// Points above the local ground: more than 12 cm over the lowest point of
/// the 0.5 m cells about them (a board stands on legs; its pattern is told
/// from the ground's, which has none, by its plane's extent anyway).
fn above_ground(v: &[Vector3<f64>], up: &Vector3<f64>) -> Vec<usize> {
    use crate::frame::grid::TileMap;
    let cell = 0.5;
    let e1 = (Vector3::x() - up * up.x).normalize();
    let e2 = up.cross(&e1);
    let key = |q: &Vector3<f64>| {
        (
            (e1.dot(q) / cell).floor() as i64,
            (e2.dot(q) / cell).floor() as i64,
        )
    };
    let mut low: TileMap<(i64, i64), f64> = TileMap::default();
    for q in v {
        let h = up.dot(q);
        low.entry(key(q)).and_modify(|m| *m = m.min(h)).or_insert(h);
    }
    (0..v.len())
        .filter(|&i| {
            let (kx, ky) = key(&v[i]);
            let mut floor = f64::INFINITY;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    if let Some(&h) = low.get(&(kx + dx, ky + dy)) {
                        floor = floor.min(h);
                    }
                }
            }
            up.dot(&v[i]) - floor > 0.12
        })
        .collect()
}

/// A plane hypothesis: the plane, where it was drawn, its support.
struct Seed {
    plane: Plane,
    at: Vector3<f64>,
    support: usize,
}

/// Triples drawn per occupied cell.
const TRIPLES: u64 = 16;

/// Step 1: the best plane of each occupied cell, best supported first.
fn plane_seeds(v: &[Vector3<f64>], grid: &Grid, side: f64, seed: u64) -> Vec<Seed> {
    let mut keys: Vec<(i64, i64, i64)> = grid
        .cells
        .iter()
        .filter(|(_, ids)| ids.len() >= 6)
        .map(|(k, _)| *k)
        .collect();
    keys.sort_unstable();
    let tol = 0.02;
    let mut seeds: Vec<Seed> = keys
        .iter()
        .filter_map(|k| {
            let ids = &grid.cells[k];
            let centre =
                ids.iter().map(|&i| v[i as usize]).sum::<Vector3<f64>>() / ids.len() as f64;
            let near: Vec<usize> = grid.near(v, &centre, 0.7 * side).collect();
            let key = (k.0 as u64) ^ ((k.1 as u64) << 21) ^ ((k.2 as u64) << 42);
            let mut best: Option<Seed> = None;
            for t in 0..TRIPLES {
                let pick = |j: u64| {
                    let r = unit(seed ^ key.rotate_left(7), t * 3 + j);
                    v[ids[(r * ids.len() as f64) as usize] as usize]
                };
                let Some(plane) = Plane::through(&pick(0), &pick(1), &pick(2)) else {
                    continue;
                };
                let support = near
                    .iter()
                    .filter(|&&i| (plane.normal.dot(&v[i]) - plane.offset).abs() < tol)
                    .count();
                if best.as_ref().is_none_or(|b| support > b.support) {
                    best = Some(Seed {
                        plane,
                        at: centre,
                        support,
                    });
                }
            }
            best
        })
        .collect();
    seeds.sort_by(|a, b| b.support.cmp(&a.support));
    seeds
}

/// A board accepted: its face, its points in the face's axes, the fitted
/// pattern `x = [cu, cv, θ, lo, hi, ln w]`, and what judged it.
#[derive(Debug, Clone)]
struct Candidate {
    /// The crossing (local frame).
    centre: Vector3<f64>,
    normal: Vector3<f64>,
    /// The face's axes: `e[0]` horizontal on a standing board (along the
    /// print's first line on a surface's), `e[1] = normal × e[0]`.
    e: [Vector3<f64>; 2],
    /// The face's origin (the points' centroid); `u, v` are from it.
    origin: Vector3<f64>,
    /// (u, v, intensity) of the board's points.
    pts: Vec<[f64; 3]>,
    /// The same points in 3D (local frame).
    pts3: Vec<Vector3<f64>>,
    x: [f64; 6],
    /// Robust σ of the intensity residuals.
    sigma: f64,
    explained: f64,
    agreement: f64,
    extent: [f64; 2],
    plane_rms: f64,
    /// Points the face's offset was measured on.
    face_points: usize,
}

impl Candidate {
    /// Boundary line `k`'s direction in 3D.
    fn line(&self, k: usize) -> Vector3<f64> {
        let (s, c) = self.x[2].sin_cos();
        let d = if k == 0 { [c, s] } else { [-s, c] };
        self.e[0] * d[0] + self.e[1] * d[1]
    }
}

/// The face's in-plane axes: the first horizontal (along the face), unless
/// the face lies flat, when it is the map's x projected.
fn face_axes(n: &Vector3<f64>, up: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let h = up.cross(n);
    let a = if h.norm() > 0.3 {
        h.normalize()
    } else {
        (Vector3::x() - n * n.x).normalize()
    };
    [a, n.cross(&a)]
}

/// Keeps of a face's points `ids` those on the seed's side of any gap
/// along the face's horizontal axis (at least 4 cm and 4 times the points'
/// median spacing there): a sign or a panel standing beside a board in its
/// plane is another object, and taking both in made the face "wider than a
/// board" (a sign 5 cm off lost 5 boards of 15). Only along the horizontal:
/// a spinning scanner's rows leave gaps up the face that are not edges.
fn own_side(
    v: &[Vector3<f64>],
    ids: &mut Vec<u32>,
    n: &Vector3<f64>,
    up: &Vector3<f64>,
    at: &Vector3<f64>,
) {
    if ids.len() < 3 {
        return;
    }
    let e0 = face_axes(n, up)[0];
    let mut u: Vec<(f64, u32)> = ids
        .iter()
        .map(|&i| (e0.dot(&(v[i as usize] - at)), i))
        .collect();
    u.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut steps: Vec<f64> = u.windows(2).map(|w| w[1].0 - w[0].0).collect();
    let gap = (4.0 * pct(&mut steps, 0.5)).max(0.04);
    // The run of points, split at the gaps, that holds the seed (u = 0), or
    // the one nearest it.
    let (mut best, mut best_d) = ((0, u.len()), f64::INFINITY);
    let mut start = 0;
    for k in 0..u.len() {
        let end = k + 1 == u.len() || u[k + 1].0 - u[k].0 > gap;
        if end {
            let (lo, hi) = (u[start].0, u[k].0);
            let d = if lo <= 0.0 && 0.0 <= hi {
                0.0
            } else {
                lo.abs().min(hi.abs())
            };
            if d < best_d {
                best = (start, k + 1);
                best_d = d;
            }
            start = k + 1;
        }
    }
    let mut kept: Vec<u32> = u[best.0..best.1].iter().map(|q| q.1).collect();
    kept.sort_unstable();
    *ids = kept;
}

/// Percentile `q` (0..=1) of `x` (sorted in place).
fn pct(x: &mut [f64], q: f64) -> f64 {
    x.sort_unstable_by(f64::total_cmp);
    x[((x.len() - 1) as f64 * q).round() as usize]
}

/// A face of `n` points at `at` (local frame) refused as a board, and why.
fn refuse<T>(n: usize, why: String, at: &Vector3<f64>) -> Result<T, Refusal> {
    Err(Refusal {
        points: n,
        why,
        from: at.xy().norm(),
        wider: None,
    })
}

/// A face judged not to be a board.
struct Refusal {
    /// Its points.
    points: usize,
    why: String,
    /// Its horizontal distance from the expected position (m).
    from: f64,
    /// Its plane, when refused as wider than a board.
    wider: Option<Plane>,
}

/// Steps 2–3 for one plane: the board, or why not.
#[allow(clippy::too_many_arguments)]
fn judge(
    v: &[Vector3<f64>],
    inten: &[f64],
    grid: &Grid,
    seed: &Seed,
    side: f64,
    up: &Vector3<f64>,
    spread: f64,
    p: &BoardParams,
) -> Result<Candidate, Refusal> {
    // The face: points near the plane within a board's reach, refitted twice
    // about their centroid.
    let mut plane = seed.plane;
    let mut at = seed.at;
    let mut tol = 0.03;
    let mut ids: Vec<u32> = Vec::new();
    for _ in 0..3 {
        ids = grid
            .near(v, &at, 0.75 * side)
            .filter(|&i| (plane.normal.dot(&v[i]) - plane.offset).abs() < tol)
            .map(|i| i as u32)
            .collect();
        ids.sort_unstable();
        own_side(v, &mut ids, &plane.normal, up, &seed.at);
        let Some(f) = plane_fit(v, &ids) else {
            return refuse(ids.len(), "too few points for a plane".into(), &at);
        };
        plane = f;
        at = ids.iter().map(|&i| v[i as usize]).sum::<Vector3<f64>>() / ids.len() as f64;
        let rms = (ids
            .iter()
            .map(|&i| (plane.normal.dot(&v[i as usize]) - plane.offset).powi(2))
            .sum::<f64>()
            / ids.len() as f64)
            .sqrt();
        tol = (3.0 * rms).clamp(0.01, 0.03);
    }
    let n = plane.normal;
    let e = face_axes(&n, up);
    let uv = |q: &Vector3<f64>| [e[0].dot(&(q - at)), e[1].dot(&(q - at))];
    let mut us: Vec<f64> = ids.iter().map(|&i| uv(&v[i as usize])[0]).collect();
    let mut vs: Vec<f64> = ids.iter().map(|&i| uv(&v[i as usize])[1]).collect();
    if ids.len() < p.min_points {
        return refuse(
            ids.len(),
            format!(
                "a flat face with fewer points than a board needs ({})",
                p.min_points
            ),
            &at,
        );
    }
    let (u0, u1) = (pct(&mut us, 0.02), pct(&mut us, 0.98));
    let (v0, v1) = (pct(&mut vs, 0.02), pct(&mut vs, 0.98));
    let extent = [u1 - u0, v1 - v0];
    if extent[0] > 1.2 * side || extent[1] > 1.2 * side {
        // A wall (or a panel a board is fixed to), when the plane goes on
        // flat beyond one and a half boards: a 0.6 m board flush on a plain
        // 1.2 m panel spans 1.15 m of the 0.9 m reach, and was refused as a
        // face wider than a board without its panel searched for the print.
        let mut far: Vec<[f64; 2]> = grid
            .near(v, &at, 1.5 * side)
            .filter(|&i| (plane.normal.dot(&v[i]) - plane.offset).abs() < tol)
            .map(|i| uv(&v[i]))
            .collect();
        let span = |k: usize, far: &mut Vec<[f64; 2]>| {
            let mut a: Vec<f64> = far.iter().map(|q| q[k]).collect();
            pct(&mut a, 0.98) - pct(&mut a, 0.02)
        };
        let wall =
            far.len() >= 10 && (span(0, &mut far) > 1.5 * side || span(1, &mut far) > 1.5 * side);
        return Err(Refusal {
            points: ids.len(),
            why: format!(
                "a flat face wider than a {:.2} m board ({:.2} × {:.2} m seen within {:.2} m of its middle)",
                side,
                extent[0],
                extent[1],
                0.75 * side
            ),
            from: at.xy().norm(),
            wider: wall.then_some(Plane {
                normal: n,
                offset: n.dot(&at),
            }),
        });
    }
    if extent[0] < 0.45 * side || extent[1] < 0.45 * side {
        return refuse(
            ids.len(),
            format!(
                "a flat face of {:.2} × {:.2} m, smaller than a {:.2} m board",
                extent[0], extent[1], side
            ),
            &at,
        );
    }
    let face = Face {
        ids,
        plane,
        e,
        at,
        bounds: [u0, u1, v0, v1],
        spread,
    };
    let c = read_print(v, inten, grid, &face, side, p)?;
    // Standing free (a surface's own test, `flat.rs`, says "checkered").
    let off = c.normal.dot(&c.centre);
    let face = (&c.origin, &c.e, &c.normal, off);
    if let Some(k) = print_goes_on(v, inten, grid, face, &c.x, side, c.plane_rms) {
        return refuse(
            c.pts.len(),
            format!(
                "a print that goes on past a {side:.2} m board's edges ({k} points of its \
                 squares beyond them): a larger board"
            ),
            &c.centre,
        );
    }
    Ok(c)
}

/// A face a print is read on: its plane, in-face axes and origin, its
/// points near the plane (`ids`), and the box `[u0, u1, v0, v1]` (in the
/// axes, from the origin) the board fills.
struct Face {
    ids: Vec<u32>,
    plane: Plane,
    e: [Vector3<f64>; 2],
    at: Vector3<f64>,
    bounds: [f64; 4],
    /// What the map's intensity spans about here (5th–95th percentile).
    spread: f64,
}

/// Step 3 on a face: the checkerboard in its points' intensity, or why not.
fn read_print(
    v: &[Vector3<f64>],
    inten: &[f64],
    grid: &Grid,
    face: &Face,
    side: f64,
    p: &BoardParams,
) -> Result<Candidate, Refusal> {
    let Face {
        ids,
        plane,
        e,
        at,
        bounds: [u0, u1, v0, v1],
        spread,
    } = face;
    let (plane, e, at, ids) = (*plane, *e, *at, ids.as_slice());
    let (u0, u1, v0, v1) = (*u0, *u1, *v0, *v1);
    let n = plane.normal;
    let uv = |q: &Vector3<f64>| [e[0].dot(&(q - at)), e[1].dot(&(q - at))];
    let extent = [u1 - u0, v1 - v0];
    // The board's own points: within its size of the face's middle.
    let mid = [(u0 + u1) / 2.0, (v0 + v1) / 2.0];
    // Less its rim: a footprint on the board's edge is part background, and
    // its mixed intensity pulled a sharp line onto it (a far board: 39 mm).
    let half = 0.6 * side;
    let rim = (0.06 * side).max(0.02);
    let inside = |a: f64, lo: f64, hi: f64, m: f64| {
        (a - m).abs() <= half && a >= lo - 0.02 + rim && a <= hi + 0.02 - rim
    };
    let mut pts = Vec::new();
    let mut pts3 = Vec::new();
    for &i in ids {
        let q = uv(&v[i as usize]);
        if inside(q[0], u0, u1, mid[0]) && inside(q[1], v0, v1, mid[1]) {
            pts.push([q[0], q[1], inten[i as usize]]);
            pts3.push(v[i as usize]);
        }
    }
    let plane_rms = (pts3
        .iter()
        .map(|q| (n.dot(q) - plane.offset).powi(2))
        .sum::<f64>()
        / pts3.len().max(1) as f64)
        .sqrt();
    let np = pts.len();
    if np < p.min_points {
        return refuse(
            np,
            format!(
                "{np} points inside a board-sized face, fewer than {} to place its lines",
                p.min_points
            ),
            &at,
        );
    }
    let mut iv: Vec<f64> = pts.iter().map(|q| q[2]).collect();
    let (lo, hi) = (pct(&mut iv, 0.1), pct(&mut iv, 0.9));
    if !(hi > lo) {
        return refuse(
            np,
            "a flat face of one intensity: a plain sign, not a checkerboard".into(),
            &at,
        );
    }
    let coarse = coarse_pattern(&pts, (lo + hi) / 2.0, side, mid);
    let x0 = if coarse.phase {
        [
            coarse.c[0],
            coarse.c[1],
            coarse.theta,
            lo,
            hi,
            (0.005f64).ln(),
        ]
    } else {
        [
            coarse.c[0],
            coarse.c[1],
            coarse.theta,
            hi,
            lo,
            (0.005f64).ln(),
        ]
    };
    let fit = settle(&pts, refine(&pts, x0, 40), 0.25 * extent[0].min(extent[1]));
    let x = fit.x;
    let contrast = (x[4] - x[3]).abs() / fit.sigma;
    let w = x[5].exp();
    // Points away from both edges: their colour is the pattern's.
    let (s, c) = x[2].sin_cos();
    let thr = (x[3] + x[4]) / 2.0;
    let mut quad = [0usize; 4];
    let (mut agree, mut away) = (0usize, 0usize);
    // Per quarter, away from the edges: points, and those of its colour.
    let mut quarter = [(0usize, 0usize); 4];
    let mut level: [Vec<f64>; 4] = Default::default();
    for q in &pts {
        let (du, dv) = (q[0] - x[0], q[1] - x[1]);
        let (d1, d2) = (du * c + dv * s, -du * s + dv * c);
        let k = usize::from(d1 > 0.0) * 2 + usize::from(d2 > 0.0);
        quad[k] += 1;
        if d1.abs() > 3.0 * w && d2.abs() > 3.0 * w {
            away += 1;
            quarter[k].0 += 1;
            level[k].push(q[2]);
            let same = (d1 > 0.0) == (d2 > 0.0);
            let bright_side = (q[2] > thr) == (x[4] > x[3]);
            if same == bright_side {
                agree += 1;
                quarter[k].1 += 1;
            }
        }
    }
    let agreement = agree as f64 / away.max(1) as f64;
    // Every quarter of its own colour: one bright patch on a dark face (a
    // reflector, a lit corner) fits as a checkerboard whose other bright
    // quarter holds a few points at the face's edge (a Velodyne frame's
    // slanted face: 91 % agreement overall, the fourth quarter wrong).
    let odd_quarter = quarter
        .iter()
        .find(|(n, a)| *n >= 5 && (*a as f64) < MIN_QUARTER_AGREEMENT * *n as f64);
    // The two squares of a colour are one paint at one range: they read
    // alike. A face whose "squares" are different surfaces (a Velodyne
    // frame's object corner: bright quarters at 35 and 50, dark at 2 and
    // 17, of a 0-70 range) does not.
    // Five points a square, as for its colour's share: judged on twenty
    // (review: the medians of fewer scatter by a share of a faint print's
    // contrast) a real frame's ring-banded wall passed as a print of 184
    // points.
    let median = level.map(|mut l| (l.len() >= 5).then(|| pct(&mut l, 0.5)));
    let uneven = [(0, 3), (1, 2)].into_iter().find_map(|(a, b)| {
        let (ma, mb) = (median[a]?, median[b]?);
        ((ma - mb).abs() > MAX_SQUARE_MISMATCH * (x[4] - x[3]).abs()).then_some((ma, mb))
    });
    let least = *quad.iter().min().unwrap_or(&0);
    // The face's offset from its inside only (at its rims the rays graze
    // the board's edges and catch the legs behind it), from a band wide
    // enough for the range noise: the median, then the mean within three
    // robust σ of it. The band the pattern's points were cut with is
    // narrower than a noisy map's range noise, and would keep the offset
    // where the first plane put it.
    let cross = at + e[0] * x[0] + e[1] * x[1];
    let mut across: Vec<f64> = grid
        .near(v, &cross, 0.6 * side)
        .map(|i| v[i])
        .filter(|q| {
            let d = q - cross;
            e[0].dot(&d).abs() <= 0.4 * side
                && e[1].dot(&d).abs() <= 0.4 * side
                && (n.dot(q) - plane.offset).abs() < 0.08
        })
        .map(|q| n.dot(&q))
        .collect();
    let (off, plane_rms, n_face) = if across.len() >= 10 {
        let m = pct(&mut across, 0.5);
        let mut dev: Vec<f64> = across.iter().map(|a| (a - m).abs()).collect();
        let sr = (1.4826 * pct(&mut dev, 0.5)).max(1e-4);
        let kept: Vec<f64> = across
            .iter()
            .copied()
            .filter(|a| (a - m).abs() < 3.0 * sr)
            .collect();
        let k = kept.len() as f64;
        let mean = kept.iter().sum::<f64>() / k;

        let rms = (kept.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / k).sqrt();
        (mean, rms, kept.len())
    } else {
        (plane.offset, plane_rms, pts.len().max(1))
    };
    let centre = at + e[0] * x[0] + e[1] * x[1];
    let centre = centre - n * (n.dot(&centre) - off);
    let why = if contrast < 5.0 {
        Some(format!(
            "no checkerboard in its intensity (contrast {contrast:.1} σ of the intensity noise)"
        ))
    } else if (x[4] - x[3]).abs() < MIN_SPREAD_SHARE * spread {
        Some(format!(
            "a print too faint for a checkerboard (its squares differ by {:.1}, of the {spread:.1} \
             the map's intensity spans here: a scanner's rings or a surface's shades)",
            (x[4] - x[3]).abs()
        ))
    } else if fit.explained < 0.5 || agreement < 0.85 {
        Some(format!(
            "a print that is not a checkerboard (the pattern explains {:.0} % of the intensity, \
             {:.0} % of the points have its colours)",
            100.0 * fit.explained,
            100.0 * agreement
        ))
    } else if let Some((a, b)) = uneven {
        Some(format!(
            "a print whose squares of one colour read differently ({a:.0} and {b:.0}, against \
             {:.0} between the colours): not one board's paint",
            (x[4] - x[3]).abs()
        ))
    } else if let Some((n, a)) = odd_quarter {
        Some(format!(
            "a print whose quarters are not a checkerboard's (one has {a} of its {n} points in \
             the pattern's colour)"
        ))
    } else if least < (np / 20).max(3) {
        Some(format!(
            "a checkerboard seen too little to place both lines ({least} points in a quarter)"
        ))
    } else if let Some(free) = (0..2)
        .map(|k| free_half_width(&pts, &x, k, 0.25 * extent[0].min(extent[1])))
        .find(|h| *h > 0.1 * side)
    {
        Some(format!(
            "a print whose lines its points do not pin (one is free over ±{:.0} mm)",
            free * 1e3
        ))
    } else if w > 0.1 * side {
        Some(format!(
            "edges {:.0} mm wide, not a board's sharp squares",
            w * 1e3
        ))
    } else if !(u0 + 0.05 * side..=u1 - 0.05 * side).contains(&x[0])
        || !(v0 + 0.05 * side..=v1 - 0.05 * side).contains(&x[1])
        || (extent[0] > 0.9 * side && (x[0] - mid[0]).abs() > 0.15 * side)
        || (extent[1] > 0.9 * side && (x[1] - mid[1]).abs() > 0.15 * side)
    {
        Some("a pattern whose crossing is not the board's middle".into())
    } else if let Some(w) = narrower(extent, ids.len(), x[0] - mid[0], side) {
        Some(format!(
            "a board {w:.2} m wide, its print centred in it: narrower than a {side:.2} m board"
        ))
    } else {
        None
    };
    if let Some(why) = why {
        return refuse(np, why, &centre);
    }
    Ok(Candidate {
        centre,
        normal: n,
        e,
        origin: at,
        pts,
        pts3,
        x,
        sigma: fit.sigma,
        explained: fit.explained,
        agreement,
        extent,
        plane_rms,
        face_points: n_face,
    })
}

/// How many points carry the print past the edges of a board of `side`
/// whose pattern `x` was fitted, when it goes on there as a larger board's
/// would: the face's plane continues beyond the edges (within half a side
/// past them, the legs' side below left out) at a quarter or more of the
/// board's own density, and those points have the colours the pattern
/// extended gives them (85 %, as on the board; both colours seen). A board
/// on a larger panel or hung on a wall has the panel's one colour there, and
/// stays a board. `face`: the face's origin, axes, normal and offset. A
/// 0.6 m board surveyed as 0.4 m was taken where its face within 0.3 m of
/// its middle spanned less than 1.2 × 0.4 m (2 of 3 on a synth scene).
fn print_goes_on(
    v: &[Vector3<f64>],
    inten: &[f64],
    grid: &Grid,
    (at, e, n, off): (&Vector3<f64>, &[Vector3<f64>; 2], &Vector3<f64>, f64),
    x: &[f64; 6],
    side: f64,
    plane_rms: f64,
) -> Option<usize> {
    let (s, c) = x[2].sin_cos();
    let w = x[5].exp();
    let thr = (x[3] + x[4]) / 2.0;
    let half = side / 2.0;
    // Past the edge's mixed footprints and the blur.
    let m = (3.0 * w).max(0.03);
    let reach = 0.75 * side;
    let tol = (3.0 * plane_rms).clamp(0.01, 0.03);
    let cross = at + e[0] * x[0] + e[1] * x[1];
    let (mut inner, mut beyond, mut agree) = (0usize, 0usize, 0usize);
    let mut colours = [0usize; 2];
    for i in grid.near(v, &cross, reach * std::f64::consts::SQRT_2) {
        let q = v[i];
        if (n.dot(&q) - off).abs() >= tol {
            continue;
        }
        let (du, dv) = (e[0].dot(&(q - at)) - x[0], e[1].dot(&(q - at)) - x[1]);
        let (d1, d2) = (du * c + dv * s, -du * s + dv * c);
        let out = d1.abs().max(d2.abs());
        if out <= half - m {
            inner += 1;
        } else if out > half + m && out <= reach && dv >= -half {
            beyond += 1;
            let same = (d1 > 0.0) == (d2 > 0.0);
            colours[usize::from(same)] += 1;
            let bright_side = (inten[i] > thr) == (x[4] > x[3]);
            agree += usize::from(same == bright_side);
        }
    }
    // The beyond band's area (the strip below the board left out: about
    // three quarters of the frame) against the inner square's.
    let frame = 0.75 * ((2.0 * reach).powi(2) - (side + 2.0 * m).powi(2));
    let expected = inner as f64 / (side - 2.0 * m).powi(2) * frame;
    (beyond as f64 >= 0.25 * expected
        && colours.iter().all(|&k| k >= 8)
        && agree as f64 >= 0.85 * beyond as f64)
        .then_some(beyond)
}

/// A face `extent` (m, along its axes, horizontal first) of `n` points,
/// whose print's crossing lies `off` from its horizontal middle: its width
/// when it is a whole board narrower than `side` (a 0.6 m board surveyed as
/// 0.8 m, or one tried at twice its size for a hint). Horizontal only: a
/// standing board's legs lengthen it upright, and scan lines thin it there.
/// A board hidden in part is seen narrower too, but off its print's middle;
/// the points' spacing is added back (a far board's few points per scan
/// line span less than its width).
fn narrower(extent: [f64; 2], n: usize, off: f64, side: f64) -> Option<f64> {
    let spacing = (extent[0] * extent[1] / n.max(1) as f64).sqrt();
    (extent[0] + spacing < NARROWEST * side && off.abs() < 0.1 * side).then_some(extent[0])
}

/// A whole board is seen at least this share of its side wide.
const NARROWEST: f64 = 0.8;

/// The coarse pattern: lines' angle θ (from the face's first axis), their
/// crossing `c` in the face, and which diagonal is bright (`phase`: the
/// quarters where both offsets have the same sign).
struct Coarse {
    theta: f64,
    c: [f64; 2],
    phase: bool,
}

/// Step 3's coarse search: for each angle (2° steps over the quarter turn
/// a checkerboard repeats in), the points' bright and dark counts on a 1 cm
/// grid of the two offsets; every crossing within a third of a side of the
/// face's middle is scored from prefix sums, in constant time each.
fn coarse_pattern(pts: &[[f64; 3]], thr: f64, side: f64, mid: [f64; 2]) -> Coarse {
    let bin = 0.01;
    let half = ((side / 3.0) / bin).ceil() as i64;
    let nb = (2 * half + 2) as usize;
    let mut best = (
        0i64,
        Coarse {
            theta: 0.0,
            c: mid,
            phase: true,
        },
    );
    let mut cnt = vec![[0i64; 2]; nb * nb];
    let mut pre = vec![[0i64; 2]; (nb + 1) * (nb + 1)];
    for step in 0..45 {
        let th = (2.0 * step as f64).to_radians();
        let (s, c) = th.sin_cos();
        let m1 = mid[0] * c + mid[1] * s;
        let m2 = -mid[0] * s + mid[1] * c;
        cnt.iter_mut().for_each(|x| *x = [0, 0]);
        for q in pts {
            let a = q[0] * c + q[1] * s - m1;
            let b = -q[0] * s + q[1] * c - m2;
            let ia = ((a / bin).floor() as i64 + half + 1).clamp(0, nb as i64 - 1) as usize;
            let ib = ((b / bin).floor() as i64 + half + 1).clamp(0, nb as i64 - 1) as usize;
            cnt[ia * nb + ib][usize::from(q[2] > thr)] += 1;
        }
        for i in 0..nb {
            for j in 0..nb {
                for k in 0..2 {
                    pre[(i + 1) * (nb + 1) + j + 1][k] = cnt[i * nb + j][k]
                        + pre[i * (nb + 1) + j + 1][k]
                        + pre[(i + 1) * (nb + 1) + j][k]
                        - pre[i * (nb + 1) + j][k];
                }
            }
        }
        let n = nb + 1;
        let total = pre[nb * n + nb];
        // Counts with a < split i (bins 0..i) and b < split j.
        for i in 1..nb {
            for j in 1..nb {
                let ll = pre[i * n + j];
                let l_all = pre[i * n + nb];
                let b_all = pre[nb * n + j];
                let lh = [l_all[0] - ll[0], l_all[1] - ll[1]];
                let hl = [b_all[0] - ll[0], b_all[1] - ll[1]];
                let hh = [
                    total[0] - ll[0] - lh[0] - hl[0],
                    total[1] - ll[1] - lh[1] - hl[1],
                ];
                // Same-sign quarters bright, the others dark; or the reverse.
                let same = ll[1] + hh[1] + lh[0] + hl[0];
                let other = ll[0] + hh[0] + lh[1] + hl[1];
                let (score, phase) = if same >= other {
                    (same, true)
                } else {
                    (other, false)
                };
                if score > best.0 {
                    let ca = (i as i64 - half - 1) as f64 * bin;
                    let cb = (j as i64 - half - 1) as f64 * bin;
                    best = (
                        score,
                        Coarse {
                            theta: th,
                            c: [mid[0] + ca * c - cb * s, mid[1] + ca * s + cb * c],
                            phase,
                        },
                    );
                }
            }
        }
    }
    best.1
}

/// The blurred checkerboard at face point (u, v): `lo + (hi − lo)·P`.
fn model(x: &[f64; 6], u: f64, v: f64) -> f64 {
    let (s, c) = x[2].sin_cos();
    let (du, dv) = (u - x[0], v - x[1]);
    let w = x[5].exp();
    // Logistic edges at 1.702/w: close to a Gaussian footprint's erf.
    let s1 = 1.0 / (1.0 + (-1.702 * (du * c + dv * s) / w).exp());
    let s2 = 1.0 / (1.0 + (-1.702 * (-du * s + dv * c) / w).exp());
    let p = s1 * s2 + (1.0 - s1) * (1.0 - s2);
    x[3] + (x[4] - x[3]) * p
}

/// A pattern fit: the parameters, the robust σ of the residuals (from
/// their median absolute value), the share of the variance explained, and
/// (JᵀWJ)⁻¹ s².
struct Fit {
    x: [f64; 6],
    sigma: f64,
    explained: f64,
    cov: SMatrix<f64, 6, 6>,
}

/// Levenberg–Marquardt on the pattern with Huber weights (1.5 robust σ),
/// from `x0`, at most `iters` steps.
fn refine(pts: &[[f64; 3]], x0: [f64; 6], iters: usize) -> Fit {
    let resid =
        |x: &[f64; 6]| -> Vec<f64> { pts.iter().map(|q| q[2] - model(x, q[0], q[1])).collect() };
    let scale = |r: &[f64]| {
        let mut a: Vec<f64> = r.iter().map(|v| v.abs()).collect();
        (1.4826 * pct(&mut a, 0.5)).max(1e-9)
    };
    let weights = |r: &[f64], s: f64| -> Vec<f64> {
        r.iter()
            .map(|v| {
                let a = v.abs();
                if a <= 1.5 * s { 1.0 } else { 1.5 * s / a }
            })
            .collect()
    };
    let cost = |r: &[f64], w: &[f64]| r.iter().zip(w).map(|(r, w)| w * r * r).sum::<f64>();
    let jac = |x: &[f64; 6]| -> Vec<[f64; 6]> {
        let steps = [
            1e-5,
            1e-5,
            1e-5,
            1e-4 * (1.0 + x[3].abs()),
            1e-4 * (1.0 + x[4].abs()),
            1e-5,
        ];
        pts.iter()
            .map(|q| {
                let mut j = [0.0; 6];
                for k in 0..6 {
                    let mut a = *x;
                    let mut b = *x;
                    a[k] += steps[k];
                    b[k] -= steps[k];
                    j[k] = (model(&a, q[0], q[1]) - model(&b, q[0], q[1])) / (2.0 * steps[k]);
                }
                j
            })
            .collect()
    };
    let normal = |x: &[f64; 6], w: &[f64], r: &[f64]| {
        let j = jac(x);
        let mut a = SMatrix::<f64, 6, 6>::zeros();
        let mut g = SVector::<f64, 6>::zeros();
        for ((ji, wi), ri) in j.iter().zip(w).zip(r) {
            let jv = SVector::<f64, 6>::from_row_slice(ji);
            a += jv * jv.transpose() * *wi;
            g += jv * (*wi * *ri);
        }
        (a, g)
    };
    let mut x = x0;
    let mut r = resid(&x);
    let mut lambda = 1e-3;
    for _ in 0..iters {
        let s = scale(&r);
        let w = weights(&r, s);
        let c0 = cost(&r, &w);
        let (a, g) = normal(&x, &w, &r);
        let mut stepped = false;
        for _ in 0..8 {
            let mut m = a;
            for k in 0..6 {
                m[(k, k)] += lambda * a[(k, k)].max(1e-12);
            }
            let Some(d) = m.lu().solve(&g) else {
                lambda *= 10.0;
                continue;
            };
            let mut xn = x;
            for k in 0..6 {
                xn[k] += d[k];
            }
            // A footprint is never sharper than 2 mm (0.3 mrad at 7 m), and a
            // sharper edge lets single points pin a line.
            xn[5] = xn[5].clamp((2e-3f64).ln(), (0.2f64).ln());
            let rn = resid(&xn);
            if cost(&rn, &w) < c0 {
                let small = d[0].abs() < 1e-7 && d[1].abs() < 1e-7 && d[2].abs() < 1e-6;
                x = xn;
                r = rn;
                lambda = (lambda / 3.0).max(1e-9);
                stepped = !small;
                break;
            }
            lambda *= 10.0;
        }
        if !stepped {
            break;
        }
    }
    let s = scale(&r);
    let w = weights(&r, s);
    let (a, _) = normal(&x, &w, &r);
    let wsum: f64 = w.iter().sum();
    let s2 = cost(&r, &w) / (wsum - 6.0).max(1.0);
    let cov = a
        .try_inverse()
        .map_or(SMatrix::repeat(f64::INFINITY), |m| m * s2);
    // The share explained and the noise, robustly: a few returns of a
    // saturated or broken intensity (65535) must not decide them (three
    // such among 2000 read as "explains 0 %"). Residuals are clipped at 3
    // robust σ, deviations from the median at the middle 90 %'s span.
    let mut iv: Vec<f64> = pts.iter().map(|q| q[2]).collect();
    let (p5, med, p95) = (pct(&mut iv, 0.05), pct(&mut iv, 0.5), pct(&mut iv, 0.95));
    let span = (p95 - p5).max(1e-12);
    let var = iv
        .iter()
        .map(|v| (v - med).clamp(-span, span).powi(2))
        .sum::<f64>();
    let sse = r
        .iter()
        .map(|v| v.clamp(-3.0 * s, 3.0 * s).powi(2))
        .sum::<f64>();
    Fit {
        x,
        sigma: s,
        explained: if var > 0.0 { 1.0 - sse / var } else { 0.0 },
        cov,
    }
}

/// Step 4: of the boards with a quarter of the best's support or more, the
/// one nearest the expected position (the origin), unless nearer another
/// target's.
fn choose(cands: &[Candidate], others: &[Vector3<f64>]) -> Option<usize> {
    let best = cands.iter().map(|c| c.pts.len()).max()?;
    cands
        .iter()
        .enumerate()
        .filter(|(_, c)| 4 * c.pts.len() >= best)
        .filter(|(_, c)| {
            let own = c.centre.xy().norm();
            others.iter().all(|o| (c.centre - o).xy().norm() >= own)
        })
        .min_by(|a, b| a.1.centre.xy().norm().total_cmp(&b.1.centre.xy().norm()))
        .map(|(i, _)| i)
}

/// Refits on the board's points resampled with replacement: how much the
/// crossing moves with which points happened to be seen.
fn resampled(c: &Candidate, seed: u64) -> Vec<Vector3<f64>> {
    const DRAWS: u64 = 24;
    let n = c.pts.len();
    (0..DRAWS)
        .map(|k| {
            let draw: Vec<[f64; 3]> = (0..n as u64)
                .map(|i| c.pts[(unit(seed ^ (k << 32) ^ 0xb0a4d, i) * n as f64) as usize])
                .collect();
            let f = refine(&draw, c.x, 8);
            // In the face: the crossing's offset across it is not resampled.
            let q = c.origin + c.e[0] * f.x[0] + c.e[1] * f.x[1];
            q + c.normal * c.normal.dot(&(c.centre - q))
        })
        .collect()
}

/// The crossing's covariance (see the module's doc).
fn covariance(c: &Candidate, samples: &[Vector3<f64>]) -> [[f64; 3]; 3] {
    let f = refine(&c.pts, c.x, 1);
    let mut c2 = Matrix2::new(f.cov[(0, 0)], f.cov[(0, 1)], f.cov[(1, 0)], f.cov[(1, 1)]);
    // With no return near an edge the fit sharpens the blur to its floor and
    // the curvature vanishes (JᵀWJ singular: σ of 10⁹ m on a far board of
    // 188 points): the profiles below and the refits then say how far the
    // lines are free.
    let size = c.extent[0].min(c.extent[1]);
    if !(c2.iter().all(|v| v.is_finite()) && c2.trace() < (0.25 * size).powi(2)) {
        c2 = Matrix2::zeros();
    }
    if samples.len() > 1 {
        let m = samples.iter().sum::<Vector3<f64>>() / samples.len() as f64;
        let mut sc = Matrix2::zeros();
        for s in samples {
            let d = Vector2::new(c.e[0].dot(&(s - m)), c.e[1].dot(&(s - m)));
            sc += d * d.transpose();
        }
        sc /= (samples.len() - 1) as f64;
        if sc.trace() > c2.trace() {
            c2 = sc;
        }
    }
    // Across each line, at least what the data leave open: a scanner's rows
    // or columns may cross an edge with no return on it, and the line can
    // then lie anywhere in the gap at almost the same cost, which the
    // curvature at the fit does not see (simulated: a 5 cm gap between a
    // multi-beam scanner's rows left one line 4 cm off with a 0.3 mm σ).
    let (sn, cs) = c.x[2].sin_cos();
    let rot = Matrix2::new(cs, sn, -sn, cs);
    let mut across = rot * c2 * rot.transpose();
    for k in 0..2 {
        // At least a uniform error over the gap in the points that the line
        // lies in (a spinning scanner's rows far off: 10 cm apart).
        let open = (0.8 * open_half_width(c, k)).max(straddled_gap(c, k) / 12f64.sqrt());
        let var = across[(k, k)];
        if open * open > var {
            let scale = open / var.sqrt().max(1e-12);
            // Keep the correlation: scale the row and column.
            for j in 0..2 {
                if j != k {
                    across[(k, j)] *= scale;
                    across[(j, k)] *= scale;
                }
            }
            across[(k, k)] = open * open;
        }
    }
    let c2 = rot.transpose() * across * rot;
    let var_n = c.plane_rms.powi(2) / c.face_points as f64;
    let b = nalgebra::Matrix3x2::from_columns(&[c.e[0], c.e[1]]);
    let cov = b * c2 * b.transpose() + c.normal * c.normal.transpose() * var_n;
    let cov = (cov + cov.transpose()) / 2.0;
    [0, 1, 2].map(|i| [0, 1, 2].map(|j| cov[(i, j)]))
}

/// The fit's weighted cost with line `k` (0: where the first offset
/// changes sign) moved by each of `-reach..=reach` in 0.5 mm steps, the
/// rest held, and the residual variance s² it is judged by (weights fixed
/// at the fit's).
fn profile(pts: &[[f64; 3]], x: &[f64; 6], k: usize, reach: f64) -> (Vec<(f64, f64)>, f64) {
    let (sn, cs) = x[2].sin_cos();
    let dir = if k == 0 { [cs, sn] } else { [-sn, cs] };
    let r0: Vec<f64> = pts.iter().map(|q| q[2] - model(x, q[0], q[1])).collect();
    let mut a: Vec<f64> = r0.iter().map(|v| v.abs()).collect();
    let s = (1.4826 * pct(&mut a, 0.5)).max(1e-9);
    let w: Vec<f64> = r0
        .iter()
        .map(|v| {
            if v.abs() <= 1.5 * s {
                1.0
            } else {
                1.5 * s / v.abs()
            }
        })
        .collect();
    let cost = |d: f64| {
        let mut y = *x;
        y[0] += d * dir[0];
        y[1] += d * dir[1];
        pts.iter()
            .zip(&w)
            .map(|(q, wi)| wi * (q[2] - model(&y, q[0], q[1])).powi(2))
            .sum::<f64>()
    };
    let step = 5e-4;
    let n = (reach / step).ceil() as i64;
    let curve: Vec<(f64, f64)> = (-n..=n)
        .map(|i| {
            let d = step * i as f64;
            (d, cost(d))
        })
        .collect();
    let c0 = cost(0.0);
    let wsum: f64 = w.iter().sum();
    (curve, c0 / (wsum - 6.0).max(1.0))
}

/// Moves each line to its profile's lowest cost when that is lower than
/// the fit's by more than s², and refits: the edges' blur is a few
/// millimetres, so between a scanner's rows the cost is flat and the
/// steepest descent stops wherever the coarse search left a line.
fn settle(pts: &[[f64; 3]], mut fit: Fit, reach: f64) -> Fit {
    for _ in 0..3 {
        let mut moved = false;
        for k in 0..2 {
            let (curve, s2) = profile(pts, &fit.x, k, reach);
            let c0 = curve[curve.len() / 2].1;
            let Some(&(d, c)) = curve.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
                continue;
            };
            if c < c0 - s2 {
                let (sn, cs) = fit.x[2].sin_cos();
                let dir = if k == 0 { [cs, sn] } else { [-sn, cs] };
                let mut x = fit.x;
                x[0] += d * dir[0];
                x[1] += d * dir[1];
                fit = refine(pts, x, 40);
                moved = true;
            }
        }
        if !moved {
            break;
        }
    }
    // A line free to lie anywhere in a gap is put in its middle: the error
    // is then at most half the gap.
    for k in 0..2 {
        let (curve, s2) = profile(pts, &fit.x, k, reach);
        // The run of offsets within s² of the lowest cost, about it.
        let Some(m) = (0..curve.len()).min_by(|&a, &b| curve[a].1.total_cmp(&curve[b].1)) else {
            continue;
        };
        let low = curve[m].1;
        let (mut a, mut b) = (m, m);
        while a > 0 && curve[a - 1].1 <= low + s2 {
            a -= 1;
        }
        while b + 1 < curve.len() && curve[b + 1].1 <= low + s2 {
            b += 1;
        }
        let mid = (curve[a].0 + curve[b].0) / 2.0;
        if mid.abs() > 1e-3 {
            let (sn, cs) = fit.x[2].sin_cos();
            let dir = if k == 0 { [cs, sn] } else { [-sn, cs] };
            fit.x[0] += mid * dir[0];
            fit.x[1] += mid * dir[1];
        }
    }
    fit
}

/// How far line `k` can lie from the fit at a cost within s² of the
/// profile's lowest (one σ for a well-curved minimum): half the span of
/// those offsets, a gap between a scanner's rows or a second minimum
/// included.
fn open_half_width(c: &Candidate, k: usize) -> f64 {
    free_half_width(&c.pts, &c.x, k, 0.25 * c.extent[0].min(c.extent[1]))
}

/// The gap in the points' offsets across line `k` that the line lies in:
/// from the nearest point on one side to the nearest on the other.
fn straddled_gap(c: &Candidate, k: usize) -> f64 {
    let (sn, cs) = c.x[2].sin_cos();
    let dir = if k == 0 { [cs, sn] } else { [-sn, cs] };
    let (mut below, mut above) = (f64::INFINITY, f64::INFINITY);
    for q in &c.pts {
        let d = (q[0] - c.x[0]) * dir[0] + (q[1] - c.x[1]) * dir[1];
        if d < 0.0 {
            below = below.min(-d);
        } else {
            above = above.min(d);
        }
    }
    if below.is_finite() && above.is_finite() {
        below + above
    } else {
        f64::INFINITY
    }
}

/// [`open_half_width`] of a fit `x` to `pts`, the profile out to `reach`.
fn free_half_width(pts: &[[f64; 3]], x: &[f64; 6], k: usize, reach: f64) -> f64 {
    let (curve, s2) = profile(pts, x, k, reach);
    let low = curve.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let within: Vec<f64> = curve
        .iter()
        .filter(|p| p.1 <= low + s2)
        .map(|p| p.0)
        .collect();
    let (lo, hi) = (
        within.iter().copied().fold(0.0, f64::min),
        within.iter().copied().fold(0.0, f64::max),
    );
    // A minimum sharper than the grid: half a step either way.
    ((hi - lo) / 2.0).max(2.5e-4)
}

#[cfg(test)]
#[path = "board/tests.rs"]
mod tests;
