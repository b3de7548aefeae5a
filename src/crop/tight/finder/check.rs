//! Step 4 of the L finder: is a pairing of planes a target? An L of two
//! plate-sized faces that stop, each filling a rectangle.

use super::*;

/// Whether the planes `n·x = off` (at one heading) are an L of the configured
/// size in this window; else the score and what the points looked like.
///
/// The plates' height band is chosen first: the densest band of a plate's
/// height, among those with clear space above and below in the plates'
/// planes (a grill plate is a band; a stack under it, a cabinet or a car side
/// goes on). Every other check looks inside that band only, so an object at
/// the target's feet or foliage below the plates cannot make it "too tall".
pub(super) fn check_l(
    p: &TightParams,
    [na, nb]: [Vector3<f64>; 2],
    [oa, ob]: [f64; 2],
    planes: [&PlanePoints; 2],
    score: usize,
) -> Result<LShape, Rejected> {
    let corner = na * oa + nb * ob;
    let mut seen = Seen {
        along: [Vector3::zeros(); 2],
        size: None,
    };
    let judged = (|| {
        let (near, placed) = place_plates(p, [nb, na], corner, planes, &mut seen)?;
        let (lo, hi) = choose_band(p, &near, &mut seen)?;
        let mut plates = [PlateSeen::default(); 2];
        for k in 0..2 {
            plates[k] = plate_in_band(p, k, planes[k], placed[k], &near[k], (lo, hi), &mut seen)?;
        }
        check_size(p, &plates, (lo, hi), &mut seen)?;
        Ok(LShape {
            n: [na, nb],
            off: [oa, ob],
            along: seen.along,
            corner,
            band: (lo, hi),
            score: plates[0].planar.min(plates[1].planar),
            widths: [plates[0].width, plates[1].width],
        })
    })();
    judged.map_err(|why| Rejected {
        score,
        why,
        corner,
        along: seen.along,
        size: seen.size,
    })
}

/// What a refusal reports besides its reason: the faces as far as decided,
/// and the L's size when that alone refused it.
struct Seen {
    along: [Vector3<f64>; 2],
    size: Option<Box<[f64; 3]>>,
}

/// One plate as the band saw it: its width (95th percentile of its points'
/// distance from the corner), its points in the band, and those of its plane
/// that stand out from their surroundings (the L's support).
#[derive(Clone, Copy, Default)]
struct PlateSeen {
    width: f64,
    count: usize,
    planar: usize,
}

/// Each plate's side of the corner (the side most of its slab points near
/// the corner are on) and its near points measured from the corner along
/// it; per plate, the corner's position along its plane and the side.
/// `dirs` are the directions along the plates (plate k runs along the other
/// plate's normal).
#[allow(clippy::type_complexity)]
fn place_plates(
    p: &TightParams,
    dirs: [Vector3<f64>; 2],
    corner: Vector3<f64>,
    planes: [&PlanePoints; 2],
    seen: &mut Seen,
) -> Result<([Vec<Near>; 2], [(f64, f64); 2]), String> {
    let w = p.plate_width;
    // Ordered by height, as their planes' points are.
    let mut near: [Vec<Near>; 2] = [Vec::new(), Vec::new()];
    let mut placed = [(0.0, 1.0); 2];
    for (k, dir) in dirs.into_iter().enumerate() {
        let plane = planes[k];
        // Distance along the plane from the corner: `s` less the corner's.
        let c = dir.dot(&corner);
        // Points spread along the plane, less its densest 0.12 m: a surface
        // standing across the plane (a wall behind the other plate) puts
        // many points at one distance from the corner, a plate spreads them.
        // (The count itself is checked whole: a sparse plate's frame edge
        // may hold a third of its points.) `x - c` grows with `x`, so the
        // slab's sorted `s` give the sorted distances of a span by two
        // binary searches.
        let side = |lo: f64, hi: f64| {
            let s = &plane.slab;
            let span = s.partition_point(|a| a.0 - c <= lo)..s.partition_point(|a| a.0 - c < hi);
            let t: Vec<f64> = s[span].iter().map(|a| a.0 - c).collect();
            (t.len() - densest_run(&t, 0.12), t.len())
        };
        let (pos, neg) = (side(0.05, w + 0.15), side(-w - 0.15, -0.05));
        let (sign, count) = if pos.0 >= neg.0 {
            (1.0, pos.1)
        } else {
            (-1.0, neg.1)
        };
        if count < p.min_plate_points {
            return Err(String::new());
        }
        seen.along[k] = dir * sign;
        placed[k] = (c, sign);
        near[k] = plane
            .pts
            .iter()
            .map(|q| Near {
                t: (q.t - c) * sign,
                ..*q
            })
            .collect();
    }
    Ok((near, placed))
}

/// The plates' height band ([`plate_band`]), or, when none is clear, how
/// tall the faces are.
fn choose_band(
    p: &TightParams,
    near: &[Vec<Near>; 2],
    seen: &mut Seen,
) -> Result<(f64, f64), String> {
    // The plates' heights, once: the band is chosen from them, and when
    // none is clear they say how tall the faces are.
    let z = on_plate_heights(near, p.plate_width);
    if let Some(band) = plate_band(near, &z, p) {
        return Ok(band);
    }
    if z.len() < 2 * p.min_plate_points {
        return Err(String::new());
    }
    let tall = z[z.len() - 1 - z.len() / 50] - z[z.len() / 50];
    // Its faces stop within a few plate heights: an L of taller plates.
    if tall < 2.5 * p.plate_height {
        seen.size = Some(Box::new([f64::NAN, f64::NAN, tall]));
    }
    Err(format!(
        "an L {tall:.1} m tall (its faces go on above or below a plate's height)"
    ))
}

/// Plate `k` inside the band: on one side of the corner, no wider than a
/// plate, reaching the corner, thin, and filling a rectangle.
fn plate_in_band(
    p: &TightParams,
    k: usize,
    plane: &PlanePoints,
    (c, sign): (f64, f64),
    near: &[Near],
    (lo, hi): (f64, f64),
    seen: &mut Seen,
) -> Result<PlateSeen, String> {
    let w = p.plate_width;
    // The slab's distances along the plate in the band, ascending.
    let ts = plane.slab_distances(c, sign, lo - 0.05, hi + 0.05);
    let major = ts.iter().filter(|&&t| t > 0.05).count();
    if major < p.min_plate_points {
        return Err(String::new());
    }
    // An L: the plate lies on one side of the corner. Behind the corner,
    // this plate's plane crosses whatever stands parallel behind the
    // other plate (a wall seen through its grill): those points sit at
    // one distance, while a plate going on spreads along its plane.
    let behind = &ts[..ts.partition_point(|&t| t < -0.05)];
    let minor = behind.len() - densest_run(behind, 0.12);
    if minor * 3 > major {
        return Err("a plane running through the corner (a T or a cross)".into());
    }
    let ext = &ts[ts.partition_point(|&t| t <= 0.0)..];
    let far = ext[(ext.len() * 9) / 10];
    if far > w + 0.15 {
        // A plane that stops within a few plate widths: a wider plate.
        let edge = ext[(ext.len() * 19) / 20];
        if edge < 2.5 * w {
            seen.size = Some(Box::new([edge, f64::NAN, f64::NAN]));
        }
        return Err(format!("a plane continuing {far:.1} m past the corner"));
    }
    // A plate is as wide as a plate: occlusion from below or foliage
    // thins it but leaves its top edge whole.
    let width = ext[(ext.len() * 19) / 20];
    // ... and its points reach from the corner to that edge: a plane
    // crossing a wall obliquely holds a strip of wall at one distance.
    let first = ext[ext.len() / 10];
    if first > 0.35 * w {
        return Err(format!(
            "plate {}'s points start {first:.2} m from the corner, not at it",
            k + 1
        ));
    }
    // A plate is thin: points spread through a volume (foliage, a bush)
    // fill the shells beside the plane as much as the slab.
    let (slab, excess) = planar_count(near, 0.1 * w, w, lo, hi);
    if 2 * excess < slab {
        return Err(format!(
            "points spread through a volume, not a plate (foliage?): {} of {slab} in plate {}'s plane stand out from their surroundings",
            excess,
            k + 1
        ));
    }
    // ... and a rectangle: its points span its width at each height or
    // its band at each place along it. A slanted object crossing the
    // plane (a pipe, a machine's sloping face) does neither (issue 30:
    // a pump room's machine base).
    if let [Some(rows), Some(columns)] = spanning(&plane.slab, c, sign, lo, hi, w)
        && rows.max(columns) < MIN_SPANNING_SHARE
    {
        return Err(format!(
            "plate {}'s points do not fill a rectangle ({:.0} % of them in rows spanning its width, {:.0} % in columns spanning its height): a slanted object, not a plate",
            k + 1,
            100.0 * rows,
            100.0 * columns
        ));
    }
    Ok(PlateSeen {
        width,
        count: ext.len(),
        planar: excess,
    })
}

/// Both plates as wide as a plate, and the band as tall as one less what
/// may hide its lower part.
fn check_size(
    p: &TightParams,
    plates: &[PlateSeen; 2],
    (lo, hi): (f64, f64),
    seen: &mut Seen,
) -> Result<(), String> {
    let w = p.plate_width;
    let width = [plates[0].width, plates[1].width];
    // The 95th percentile of n points spread over a plate scatters by about
    // 0.22 w / √n: a plate is allowed one of those (3 cm with 20 points).
    let slack = |k: usize| 0.22 * w / (plates[k].count.max(1) as f64).sqrt();
    let short = (0..2).any(|k| width[k] < MIN_WIDTH_SHARE * w - slack(k));
    let long = (0..2).any(|k| width[k] > MAX_WIDTH_SHARE * w + slack(k));
    let tall = hi - lo;
    let low = tall < MIN_HEIGHT_SHARE * p.plate_height - 0.02;
    if short || long || low {
        seen.size = Some(Box::new([width[0], width[1], tall]));
    }
    if short || long {
        return Err(format!(
            "an L of plates {:.2} and {:.2} m wide, {:.2} m tall ({} m wide plates expected)",
            width[0],
            width[1],
            hi - lo,
            w
        ));
    }
    // ... and as tall as a plate, less what may hide its lower part (grass,
    // a barrier): the rim of a mound, a log, a kerb or a bumper make an L of
    // the right width a hand's height tall (issue 30: 0.12 m "plates").
    if low {
        return Err(format!(
            "an L {tall:.2} m tall ({} m plates expected, at most {:.0} % of them hidden)",
            p.plate_height,
            100.0 * (1.0 - MIN_HEIGHT_SHARE)
        ));
    }
    Ok(())
}

/// How far a plate's slab points (`slab`: raw position along the plate,
/// height; `c`, `sign`: the corner and the side, as `check_l` placed them)
/// in the band `lo..hi` fill a rectangle: the share of them in `SPAN_ROW`
/// rows that stretch `MIN_SPAN` of the width, and the share in `SPAN_COLUMNS`
/// columns that stretch `MIN_SPAN` of the band's height (each stretch from
/// the 5th to the 95th percentile, over cells of `MIN_CELL_POINTS` or more).
/// A plate's points fill it: a scan line crossing it level makes rows that
/// span it, one crossing it aslant (a sensor above the plate, the plate
/// turned) rows that do not, but then every column meets every line; hidden
/// parts (grass, a barrier below, returns thinned) leave cells sparse, not
/// short. A slanted object crossing the plane (a machine's sloping face)
/// holds a short stretch at each height and a short one at each place
/// along: both shares low. Each is `None` without `MIN_SPAN_EVIDENCE` (a far
/// or sparse plate, a rosette's few petals).
pub(super) fn spanning(
    slab: &[(f64, f64)],
    c: f64,
    sign: f64,
    lo: f64,
    hi: f64,
    w: f64,
) -> [Option<f64>; 2] {
    let n_rows = ((hi - lo) / SPAN_ROW).ceil().max(1.0) as usize;
    let mut rows: Vec<Vec<f64>> = vec![Vec::new(); n_rows];
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); SPAN_COLUMNS];
    for &(x, z) in slab {
        let t = (x - c) * sign;
        if z > lo && z < hi && t > 0.0 && t < w {
            rows[(((z - lo) / SPAN_ROW) as usize).min(n_rows - 1)].push(t);
            columns[((t / w * SPAN_COLUMNS as f64) as usize).min(SPAN_COLUMNS - 1)].push(z);
        }
    }
    [
        spanning_share(rows, MIN_SPAN * w),
        spanning_share(columns, MIN_SPAN * (hi - lo)),
    ]
}

/// The share of the points of `cells` (those with `MIN_CELL_POINTS` or
/// more) in cells whose 5th–95th percentile stretch is at least `need`;
/// `None` without `MIN_SPAN_EVIDENCE`.
pub(super) fn spanning_share(cells: Vec<Vec<f64>>, need: f64) -> Option<f64> {
    let (mut counted, mut spanning, mut judged) = (0usize, 0usize, 0usize);
    for mut v in cells {
        if v.len() < MIN_CELL_POINTS {
            continue;
        }
        judged += 1;
        v.sort_unstable_by(f64::total_cmp);
        let n = v.len();
        counted += n;
        if v[n - 1 - n / 20] - v[n / 20] >= need {
            spanning += n;
        }
    }
    (counted >= MIN_SPAN_EVIDENCE.0 && judged >= MIN_SPAN_EVIDENCE.1)
        .then(|| spanning as f64 / counted as f64)
}

/// Points and cells `spanning_share` needs to judge: a sparse plate's few
/// rows are arcs of whichever scan lines crossed it (a rosette's petals
/// cross a plate in part), and a row of 20 points may be one short arc.
pub(super) const MIN_SPAN_EVIDENCE: (usize, usize) = (200, 3);

/// Rows of `spanning` (m): a level scan line's returns on a plate lie
/// within a few centimetres of one height.
pub(super) const SPAN_ROW: f64 = 0.05;

/// Columns of `spanning` across a plate's width.
pub(super) const SPAN_COLUMNS: usize = 6;

/// Fewest points in a row or column whose stretch counts.
pub(super) const MIN_CELL_POINTS: usize = 20;

/// A row or column spans the plate when its points stretch this share of
/// the plate's width or band (a whole one stretches ~0.9 between its 5th
/// and 95th percentiles).
pub(super) const MIN_SPAN: f64 = 0.6;

/// A plate has at least this share of its counted points in spanning rows,
/// or in spanning columns.
pub(super) const MIN_SPANNING_SHARE: f64 = 0.5;

/// A plate narrower than this share of the configured width (from the 95th
/// percentile of its points' distance from the corner) is not the target's:
/// the grill's frame returns at the far edge, so a whole plate reaches ~0.97.
pub(super) const MIN_WIDTH_SHARE: f64 = 0.85;

/// A located or detected L's plates are at least this share of the plate
/// height tall: up to 60 % of a plate may be hidden from below (the clutter
/// cases hide 40 %), and nothing a hand's height tall is a target.
pub(super) const MIN_HEIGHT_SHARE: f64 = 0.4;

/// A plate wider than this share of the configured width is not the
/// target's either (a 0.8 m cabinet side); the range noise along a plate
/// seen at a grazing angle moves its far edge by a few centimetres.
pub(super) const MAX_WIDTH_SHARE: f64 = 1.12;
