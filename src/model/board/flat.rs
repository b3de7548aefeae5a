//! Boards on a surface wider than a board: lying on the ground (the UAV
//! ground-control board) or on a larger level surface, or hung on a wall
//! (the lattice then lies in the wall's plane). Their face is the
//! surface's, so its extent cannot tell them (`judge` refuses it as "a flat
//! face wider than a board"); only the print can.
//!
//! 1. **Where the print is.** On a lattice of a tenth of a side over the
//!    search disc, the points within 0.42 side (inside the board wherever the
//!    crossing lies within a lattice step) are split halfway between their
//!    intensity's 10th and 90th percentiles and scored at 5° steps by how well the quarters' signs
//!    predict bright and dark: 1 on a checkerboard, ~1/√n on an even or a
//!    random surface, about 0 on a straight edge (a road marking's side).
//! 2. **The print.** The best-scoring places, a board apart, are read as a
//!    standing board's face is (`read_print`: the blurred checkerboard's fit
//!    and every check on it), on the surface's plane fitted to their points.
//! 3. **The print stops.** A board's squares meet at its centre only and its
//!    lines end at its edges: where they meet at its corners too (tiles of a
//!    square's size), or its lines go on past its edges (larger tiles), the
//!    surface is checkered, not a board.

use super::*;

/// Lattice step over the search disc, in sides.
const STEP: f64 = 0.1;

/// Radius of a lattice place's points, in sides: with the crossing within a
/// lattice step's half-diagonal (0.071 side), the disc stays on the board.
const DISC: f64 = 0.42;

/// Least score of a place worth reading.
const MIN_SCORE: f64 = 0.5;

/// Places read, best first.
const PLACES: usize = 6;

/// Plane hypotheses drawn for a square's face.
const TRIPLES: u64 = 64;

/// Half-width of a face's band (m): a map's range noise on a board.
const FACE_BAND: f64 = 0.01;

/// The boards lying in the surface points `g` (local frame, intensities
/// `gi`) within `radius` of the expected position (the origin), and the
/// places refused with why.
pub(super) fn flat_prints(
    g: &[Vector3<f64>],
    gi: &[f64],
    up: &Vector3<f64>,
    side: f64,
    (radius, spread): (f64, f64),
    p: &BoardParams,
) -> (Vec<Candidate>, Vec<Refusal>) {
    // Axes in the surface: x's share in it (y's on a wall facing x).
    let e1 = if up.x.abs() < 0.9 {
        (Vector3::x() - up * up.x).normalize()
    } else {
        (Vector3::y() - up * up.y).normalize()
    };
    let e2 = up.cross(&e1);
    let flat: Vec<[f64; 2]> = g.iter().map(|q| [e1.dot(q), e2.dot(q)]).collect();
    let cell = side / 2.0;
    let key = |a: f64, b: f64| ((a / cell).floor() as i64, (b / cell).floor() as i64);
    let mut cells: crate::frame::grid::TileMap<(i64, i64), Vec<u32>> = Default::default();
    for (i, q) in flat.iter().enumerate() {
        cells.entry(key(q[0], q[1])).or_default().push(i as u32);
    }
    let disc = |c: [f64; 2], r: f64| -> Vec<u32> {
        let (kx, ky) = key(c[0], c[1]);
        let n = (r / cell).ceil() as i64;
        let mut out = Vec::new();
        for dx in -n..=n {
            for dy in -n..=n {
                if let Some(ids) = cells.get(&(kx + dx, ky + dy)) {
                    out.extend(ids.iter().copied().filter(|&i| {
                        let q = flat[i as usize];
                        (q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2) <= r * r
                    }));
                }
            }
        }
        out.sort_unstable();
        out
    };
    // 1. Scores on the lattice.
    let step = STEP * side;
    let m = (radius / step).ceil() as i64;
    let mut places: Vec<(f64, [f64; 2], f64)> = Vec::new();
    for i in -m..=m {
        for j in -m..=m {
            let c = [i as f64 * step, j as f64 * step];
            if c[0].hypot(c[1]) > radius {
                continue;
            }
            let ids = disc(c, DISC * side);
            if ids.len() < p.min_points / 2 {
                continue;
            }
            // Seen all round: a disc the data covers in part (its edge, a
            // gap) scores a strip of anything as a crossing.
            let mean = ids.iter().fold([0.0, 0.0], |a, &i| {
                let q = flat[i as usize];
                [a[0] + q[0], a[1] + q[1]]
            });
            let n = ids.len() as f64;
            if (mean[0] / n - c[0]).hypot(mean[1] / n - c[1]) > 0.25 * DISC * side {
                continue;
            }
            let (score, angle) = checker_score(&flat, gi, &ids, c);
            if score >= MIN_SCORE {
                places.push((score, c, angle));
            }
        }
    }
    // Best first, in steps of 0.1 (a score's noise at a board's ~300
    // points); nearer the expected position first within a step.
    let rank = |q: &(f64, [f64; 2], f64)| ((q.0 / 0.1).floor() as i64, q.1[0].hypot(q.1[1]));
    places.sort_by(|a, b| {
        let (ra, rb) = (rank(a), rank(b));
        rb.0.cmp(&ra.0).then(ra.1.total_cmp(&rb.1))
    });
    let mut kept: Vec<([f64; 2], f64)> = Vec::new();
    for (_, c, angle) in places {
        if kept
            .iter()
            .all(|(k, _)| (k[0] - c[0]).hypot(k[1] - c[1]) >= 0.5 * side)
        {
            kept.push((c, angle));
            if kept.len() == PLACES {
                break;
            }
        }
    }
    // 2–3. Each place's print on the surface's plane there.
    let grid = Grid::new(g, side / 2.0);
    let (mut found, mut refused) = (Vec::new(), Vec::new());
    for (c, angle) in kept {
        match read_square(
            g,
            gi,
            &grid,
            &flat,
            &disc,
            (c, angle),
            [e1, e2],
            up,
            (side, spread),
            p,
        ) {
            Ok(b) => match stops(b, &flat, gi, &disc, [e1, e2], side) {
                Ok(b) => found.push(b),
                Err(r) => refused.push(r),
            },
            Err(r) => refused.push(r),
        }
    }
    (found, refused)
}

/// The print on the board-sized square about the place `c` (its sides along
/// the lines the place's score found, `angle` from `e1`), read on the
/// plane fitted to its points; then again on the square about the crossing
/// found, which the lattice place missed by up to a step's half-diagonal.
#[allow(clippy::too_many_arguments)]
fn read_square(
    g: &[Vector3<f64>],
    gi: &[f64],
    grid: &Grid,
    flat: &[[f64; 2]],
    disc: &impl Fn([f64; 2], f64) -> Vec<u32>,
    (c, angle): ([f64; 2], f64),
    [e1, e2]: [Vector3<f64>; 2],
    up: &Vector3<f64>,
    (side, spread): (f64, f64),
    p: &BoardParams,
) -> Result<Candidate, Refusal> {
    let (s, co) = angle.sin_cos();
    let (a, b) = ([co, s], [-s, co]);
    let h = side / 2.0;
    let square = |c: [f64; 2]| -> Vec<u32> {
        disc(c, h * std::f64::consts::SQRT_2)
            .into_iter()
            .filter(|&i| {
                let q = flat[i as usize];
                let d = [q[0] - c[0], q[1] - c[1]];
                (d[0] * a[0] + d[1] * a[1]).abs() <= h && (d[0] * b[0] + d[1] * b[1]).abs() <= h
            })
            .collect()
    };
    let refuse = |why: &str, n: usize| Refusal {
        points: n,
        why: why.into(),
        from: c[0].hypot(c[1]),
        wider: None,
    };
    let mut centre = c;
    let mut read = Err(refuse("no points", 0));
    for _ in 0..2 {
        // The square's face: the plane most of its points lie within 1 cm
        // of (triples drawn as `plane_seeds` draws them), refitted on those.
        // Not a least-squares fit of them all: the ground seen under a
        // board's raised edge lies centimetres below it, and tilted such a
        // fit by up to 6° (synth, boards on a 1.5° slope).
        let mut ids = square(centre);
        if ids.len() < 3 {
            return Err(refuse("too few points for a plane", ids.len()));
        }
        let mut best: Option<(usize, Plane)> = None;
        for t in 0..TRIPLES {
            let pick = |j: u64| {
                g[ids[(unit(p.seed ^ 0xf1a7, t * 3 + j) * ids.len() as f64) as usize] as usize]
            };
            let Some(pl) = Plane::through(&pick(0), &pick(1), &pick(2)) else {
                continue;
            };
            let support = ids
                .iter()
                .filter(|&&i| (pl.normal.dot(&g[i as usize]) - pl.offset).abs() < FACE_BAND)
                .count();
            if best.as_ref().is_none_or(|b| support > b.0) {
                best = Some((support, pl));
            }
        }
        let Some((_, seed_plane)) = best else {
            return Err(refuse("too few points for a plane", ids.len()));
        };
        ids.retain(|&i| {
            (seed_plane.normal.dot(&g[i as usize]) - seed_plane.offset).abs() < FACE_BAND
        });
        let Some(plane) = plane_fit(g, &ids) else {
            return Err(refuse("too few points for a plane", ids.len()));
        };
        let at = ids.iter().map(|&i| g[i as usize]).sum::<Vector3<f64>>() / ids.len() as f64;
        // Facing up, as the report and `Candidate::e` read it.
        let plane = if plane.normal.dot(up) < 0.0 {
            plane.flipped()
        } else {
            plane
        };
        let n = plane.normal;
        // The face's axes along the square's sides.
        let along = e1 * a[0] + e2 * a[1];
        let e0 = (along - n * n.dot(&along)).normalize();
        let e = [e0, n.cross(&e0)];
        // The place on the face (the lattice lies at the expected height,
        // which on a slope is beside the face, not over it).
        let place = e1 * centre[0] + e2 * centre[1];
        let place = place + up * up.dot(&(at - place));
        let mid = [e[0].dot(&(place - at)), e[1].dot(&(place - at))];
        let face = Face {
            ids,
            plane,
            e,
            at,
            bounds: [mid[0] - h, mid[0] + h, mid[1] - h, mid[1] + h],
            spread,
        };
        read = read_print(g, gi, grid, &face, side, p);
        let Ok(b) = &read else { break };
        centre = [e1.dot(&b.centre), e2.dot(&b.centre)];
    }
    read
}

/// How well the quarters about `c` (at the best of 5° steps) predict which
/// of the points `ids` are brighter than their median: |mean of sign(quarter)
/// × sign(brighter)|, 1 on a checkerboard crossing at `c`.
fn checker_score(flat: &[[f64; 2]], inten: &[f64], ids: &[u32], c: [f64; 2]) -> (f64, f64) {
    // Split halfway between the 10th and 90th percentiles (`read_print`'s):
    // a median ties with half of a print's points when its levels are exact.
    let mut iv: Vec<f64> = ids.iter().map(|&i| inten[i as usize]).collect();
    let med = (pct(&mut iv, 0.1) + pct(&mut iv, 0.9)) / 2.0;
    let pts: Vec<(f64, f64, f64)> = ids
        .iter()
        .map(|&i| {
            let q = flat[i as usize];
            let b = inten[i as usize];
            let sign = if b > med {
                1.0
            } else if b < med {
                -1.0
            } else {
                0.0
            };
            (q[0] - c[0], q[1] - c[1], sign)
        })
        .collect();
    let mut best = (0.0f64, 0.0);
    for k in 0..18 {
        let angle = (5.0 * k as f64).to_radians();
        let (s, co) = angle.sin_cos();
        let sum: f64 = pts
            .iter()
            .map(|&(du, dv, b)| {
                let q = (du * co + dv * s) * (-du * s + dv * co);
                q.signum() * b
            })
            .sum();
        if sum.abs() > best.0 {
            best = (sum.abs(), angle);
        }
    }
    (best.0 / pts.len() as f64, best.1)
}

/// How far the side of `q` a point lies on (the sign of `side_of` its
/// offset from `q`) predicts its colour (bright or dark of halfway between
/// the 10th and 90th percentiles of `ids`' intensities), 0–1 either way
/// round; 0 with under 20 points (too few to say).
fn colours_split(
    flat: &[[f64; 2]],
    inten: &[f64],
    ids: &[u32],
    q: [f64; 2],
    side_of: impl Fn([f64; 2]) -> f64,
) -> f64 {
    if ids.len() < 20 {
        return 0.0;
    }
    let mut iv: Vec<f64> = ids.iter().map(|&i| inten[i as usize]).collect();
    let mid = (pct(&mut iv, 0.1) + pct(&mut iv, 0.9)) / 2.0;
    let sum: f64 = ids
        .iter()
        .map(|&i| {
            let p = flat[i as usize];
            side_of([p[0] - q[0], p[1] - q[1]]).signum() * (inten[i as usize] - mid).signum()
        })
        .sum();
    (sum / ids.len() as f64).abs()
}

/// Step 3: the board found, unless the surface about it is checkered too: a
/// board's squares meet at its centre only, a tiled floor's at every
/// corner. At the board's four corners (half a side along both lines from
/// the crossing), the quarters about each (by the board's lines) must not
/// predict the intensity as a crossing's do.
fn stops(
    b: Candidate,
    flat: &[[f64; 2]],
    inten: &[f64],
    disc: &impl Fn([f64; 2], f64) -> Vec<u32>,
    [e1, e2]: [Vector3<f64>; 2],
    side: f64,
) -> Result<Candidate, Refusal> {
    let c = [e1.dot(&b.centre), e2.dot(&b.centre)];
    // The print's lines, seen from above.
    let dir = |k: usize| {
        let l = b.line(k);
        let d = [e1.dot(&l), e2.dot(&l)];
        let n = d[0].hypot(d[1]);
        [d[0] / n, d[1] / n]
    };
    let (l0, l1) = (dir(0), dir(1));
    let mut crossings = 0;
    for (a, bb) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        let h = side / 2.0;
        let q = [
            c[0] + h * (a * l0[0] + bb * l1[0]),
            c[1] + h * (a * l0[1] + bb * l1[1]),
        ];
        let quarter = |d: [f64; 2]| (d[0] * l0[0] + d[1] * l0[1]) * (d[0] * l1[0] + d[1] * l1[1]);
        if colours_split(flat, inten, &disc(q, 0.25 * side), q, quarter) > 0.6 {
            crossings += 1;
        }
    }
    // ... and its lines end at its edges: a floor of tiles larger than a
    // board's squares puts no crossing at its corners, but the lines go on.
    let mut going_on = 0;
    for (l, other) in [
        (l0, l1),
        ([-l0[0], -l0[1]], l1),
        (l1, l0),
        ([-l1[0], -l1[1]], l0),
    ] {
        let r = side / 2.0 + 0.15 * side;
        let q = [c[0] + r * l[0], c[1] + r * l[1]];
        // The line along `l` splits the colours across it (along `other`).
        let across = |d: [f64; 2]| d[0] * other[0] + d[1] * other[1];
        if colours_split(flat, inten, &disc(q, 0.15 * side), q, across) > 0.6 {
            going_on += 1;
        }
    }
    if crossings >= 3 || going_on >= 3 {
        return Err(Refusal {
            points: b.pts.len(),
            why: format!(
                "a checkered surface (of the board's 4 corners {crossings} are crossings of squares too, \
                 and {going_on} of its 4 lines' ends go on past its edges: tiles, not a board)"
            ),
            from: b.centre.xy().norm(),
            wider: None,
        });
    }
    Ok(b)
}
