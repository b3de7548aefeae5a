//! Why a run could not score, told from what each surveyed place showed:
//! nothing, L's of another size than `--plate-size`, targets elsewhere in
//! the map (another frame), a survey of another map (issue 31). Only the
//! failure paths of the evaluation read this.

use super::*;

/// A map too spread out to be in metres, set against the survey: a map in
/// millimetres spans a thousand times the site the survey covers.
pub(super) fn against_survey(e: Error, survey: &Survey) -> Error {
    match e {
        Error::NotMetres { extent, msg: m } => {
            let (lo, hi) = survey.targets.iter().fold(
                ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
                |(lo, hi), t| {
                    let p = t.position;
                    (
                        [lo[0].min(p.x), lo[1].min(p.y)],
                        [hi[0].max(p.x), hi[1].max(p.y)],
                    )
                },
            );
            let span = (hi[0] - lo[0]).max(hi[1] - lo[1]);
            let msg = if span.is_finite() {
                format!("{m}. The survey's targets span {span:.0} m")
            } else {
                m
            };
            Error::NotMetres { extent, msg }
        }
        e => e,
    }
}

/// A map that spans under a metre across where the survey's targets span
/// more than five, refused: no frame puts the survey in it. A map written in
/// degrees (longitude, latitude) without a header that says so is the
/// usual cause, and the error says so when its coordinates could be such.
pub(super) fn too_small_for_survey(
    map: &MapStats,
    ground: &crate::frame::MapGround,
    survey: &Survey,
) -> Result<()> {
    let Some(span) = ground.horizontal_span() else {
        return Ok(());
    };
    let widest = survey
        .targets
        .iter()
        .flat_map(|a| {
            let a = a.position;
            survey
                .targets
                .iter()
                .map(move |b| (b.position - a).xy().norm())
        })
        .fold(0.0_f64, f64::max);
    if span[0].max(span[1]) > 1.0 || widest <= 5.0 {
        return Ok(());
    }
    let c = ground.centre;
    let degrees = if c.x.abs() <= 180.0 && c.y.abs() <= 90.0 && (c.x != 0.0 || c.y != 0.0) {
        format!(
            ". Its x and y (about {:.0}, {:.0}) may be longitude and latitude in degrees: mapgauge measures in metres, so reproject the map to a projected CRS (its UTM zone) and give the survey in the same one",
            c.x, c.y
        )
    } else {
        String::new()
    };
    Err(Error::Input(format!(
        "{}: its {} points lie within {:.1} × {:.1} m horizontally, where the survey's targets lie up to {widest:.0} m apart: no frame puts the survey in this map{degrees}",
        map.name, map.points, span[0], span[1]
    )))
}

/// A map whose up may not be its +z, told from its extent: little of it is
/// ground facing +z, from above it is a strip (three times longer than
/// wide), and its points spread over more height (tens of metres) than
/// three times the strip's width and a third of its length, where a site's
/// ground spreads across x and y and rises a few metres. Said only
/// when no target was found anywhere, and as a question (a mine drift or a
/// stairwell without a floor seen can look so too).
pub(super) fn up_not_z(map: &str, ground: &crate::frame::MapGround) -> Option<String> {
    // Half the map's blocks flat is a ground facing +z (a y-up synth scene:
    // a quarter, its walls; z-up corridors, trails, stairwells: most).
    if ground.flat_share() >= 0.5 {
        return None;
    }
    let span = ground.horizontal_span()?;
    let relief = ground.z_extent()?;
    let narrow = span[0].min(span[1]);
    // The narrower axis is the likelier up.
    let axis = if span[1] <= span[0] { "y" } else { "x" };
    // A site written y up is a strip from above (its height across, its
    // length along) and deep in z (its width); a stairwell is no strip, a
    // hillside trail or a mine drift is one but rises a fraction of its
    // length.
    let long = span[0].max(span[1]);
    let strip = long >= 3.0 * narrow;
    (relief >= 10.0 && relief > 3.0 * narrow && strip && relief >= 0.3 * long).then(|| {
        format!(
            " Or was the map written with {axis} up or down (Open3D's or Unity's y-up convention, a camera's y-down)? Little of it is ground facing +z, it spans {:.0} × {:.0} m across x and y, and its points spread {relief:.0} m in z; mapgauge takes +z as up, and `mapgauge convert --map {map} --out map_z.pcd --up {axis}` (or --up -{axis}) turns such a map",
            span[0], span[1]
        )
    })
}

/// What the surveyed places showed, counted by kind: "4 nothing standing
/// above the ground, 1 no target-shaped object (closest: …)".
pub(super) fn places_seen(found: &[TargetRun]) -> String {
    let mut kinds: Vec<(String, usize)> = Vec::new();
    let mut closest: Option<&crop::Seen> = None;
    for r in found {
        let kind = match &r.outcome {
            Ok(_) => "a target located",
            Err(Failure::NoLoosePoints) | Err(Failure::Tight(crop::TightError::NoPoints)) => {
                "no map points"
            }
            Err(Failure::Tight(crop::TightError::NothingAboveGround { .. })) => {
                "nothing standing above the ground"
            }
            Err(Failure::Tight(crop::TightError::NoTargetShape { seen, .. })) => {
                if let Some(s) = seen
                    && closest.is_none_or(|c| s.from_expected < c.from_expected)
                {
                    closest = Some(s);
                }
                "no target-shaped object"
            }
            Err(Failure::Locate(_)) => "a target-shaped object that could not be located",
            Err(_) if refused_there(&r.outcome) => "an object refused by the checks",
            Err(Failure::Sphere(_)) => "no sphere of the size given standing there",
            Err(Failure::Board(crate::model::BoardError::NoIntensity { .. })) => {
                "a board, in a map without intensity to read it by"
            }
            Err(Failure::Board(_)) => "no board of the size given standing there",
            Err(_) => "an object refused by the checks",
        };
        match kinds.iter_mut().find(|k| k.0 == kind) {
            Some(k) => k.1 += 1,
            None => kinds.push((kind.to_string(), 1)),
        }
    }
    kinds.sort_by_key(|k| std::cmp::Reverse(k.1));
    let mut s = kinds
        .iter()
        .map(|(k, n)| format!("{n} {k}"))
        .collect::<Vec<_>>()
        .join(", ");
    if let Some(c) = closest {
        s += &format!(" (the closest object seen: {})", c.what);
    }
    s
}

/// The error when the targets are not where the survey places them and
/// detection found no frame: what each told, and the mistakes that fit
/// (a map in another frame only when the map holds target-shaped objects).
pub(super) fn not_there(
    map: &str,
    found: &[TargetRun],
    detections: usize,
    why: &crate::frame::matching::MatchError,
    cfg: &Config,
) -> Error {
    let places = places_seen(found);
    let n = found.len();
    // Spheres or boards of another size near the places: detection looked
    // for the size given, so found none; the size is the first suspect.
    let other_size: Vec<String> = found
        .iter()
        .filter_map(|r| {
            let e = r.outcome.as_ref().err()?.to_string();
            let said = ["a sphere of ", "a board of "].iter().find_map(|k| {
                e.match_indices(k).find_map(|(at, _)| {
                    let said = e[at..].split(':').next()?;
                    said.contains(" mm stands ").then_some(said.to_string())
                })
            })?;
            Some(format!("{}: {said}", r.id))
        })
        .collect();
    if !other_size.is_empty() {
        // One such place may be chance in a map of another frame: the
        // frame is then named too.
        let frame_too = if other_size.len() < 2 {
            format!(
                ". If the size is right, the map may be in another frame than the survey ({})",
                frame::NoFrame::remedy(why)
            )
        } else {
            String::new()
        };
        return Error::FrameNotFound {
            detections,
            msg: format!(
                "{map}: no target where the survey places them (of its {n} places: {places}), but near {} of them a target of another size than given stands ({}): is the size given right (the survey's `size` column, or the config's `[sphere] diameter_m` / `[board] side_m`)? Detection map-wide looks for the size given too, so it found no frame{frame_too}",
                other_size.len(),
                other_size.join("; ")
            ),
        };
    }
    if detections == 0 {
        use crate::model::ModelKind;
        // The remedies that fit the survey's models: a plate size only for
        // Ls; boards lying flat are never detected map-wide, so none found
        // there says nothing of them.
        let mut hint = String::new();
        if found.iter().any(|r| r.model == ModelKind::L) {
            hint += &format!(
                " (For plates of another size than {:.2} × {:.2} m, give --plate-size W,H)",
                cfg.tight.plate_width, cfg.tight.plate_height
            );
        }
        if found.iter().any(|r| r.model == ModelKind::Board) {
            hint += " Map-wide detection finds checkerboard boards that stand (by their print: the map must carry intensity); boards lying flat are looked for only where the survey places them. failed.csv (with --out) gives each place's reason.";
        }
        return Error::FrameNotFound {
            detections,
            msg: format!(
                "{map}: no target where the survey places them (of its {n} places: {places}), and none anywhere else: detection map-wide found no target-shaped object. The map holds none of the surveyed targets: is it the map of this survey's site, made while the targets stood?{hint}"
            ),
        };
    }
    // Objects stand at most of the surveyed places and were refused there:
    // the map is in the survey's frame, and the checks are the story (a
    // 2 M-point scene of spheres at 2 cm of noise: each refused for its
    // size, told "the map is in another frame").
    let refused: Vec<String> = found
        .iter()
        .filter(|r| refused_there(&r.outcome))
        .filter_map(|r| r.outcome.as_ref().err().map(|e| format!("{}: {e}", r.id)))
        .collect();
    if refused.len() >= 3 && 2 * refused.len() >= n {
        let mut listed = refused[..refused.len().min(5)].join("; ");
        if refused.len() > 5 {
            listed += "; ...";
        }
        return Error::FrameNotFound {
            detections,
            msg: format!(
                "{map}: no target accepted where the survey places them, though at {} of its {n} places an object stands there that the checks refused: the map looks to be in the survey's frame, and its targets not seen well enough, or not as the survey describes them (model, size). {listed}. (Detection map-wide found {detections} target-shaped object(s), but {why}; if the map is in another frame after all: {})",
                refused.len(),
                frame::NoFrame::remedy(why)
            ),
        };
    }
    // Spheres missing at every place may be there and too noisy to fit:
    // the frame is then not the only suspect.
    let spheres = found
        .iter()
        .all(|r| matches!(r.outcome, Err(Failure::Sphere(_))));
    let sphere_hint = if spheres {
        format!(
            " Or the spheres stand there but show too few points on their surface to fit: a sphere needs {} or more within about 15 % of its radius of it, and a map whose noise is a good share of the radius (2 cm against a 145 mm sphere's 72 mm) leaves too few (failed.csv, with --out, gives each place's closest candidate)",
            cfg.sphere.min_points
        )
    } else {
        String::new()
    };
    Error::FrameNotFound {
        detections,
        msg: format!(
            "{map}: no target where the survey places them (of its {n} places: {places}); detection map-wide found {detections} target-shaped object(s), but {why}. Either the map is in another frame than the survey ({}), or the survey does not describe the targets in this map (another site, another survey file).{sphere_hint}",
            frame::NoFrame::remedy(why)
        ),
    }
}

/// Whether a place's failure is an object standing there that the checks
/// refused (a sphere or board judged and turned down within
/// [`AT_PLACE_M`] of where the survey places it, an L that would not
/// locate, a target mapped twice), not an empty place or a post metres off.
fn refused_there(outcome: &std::result::Result<Found, Failure>) -> bool {
    use crate::model::{BoardError, SphereError};
    let near = |d: &Option<f64>| d.is_some_and(|d| d <= AT_PLACE_M);
    match outcome {
        Err(Failure::Locate(_) | Failure::Doubled(_)) => true,
        Err(Failure::Sphere(SphereError::NoSphere { seen_from, .. }))
        | Err(Failure::Board(BoardError::NoBoard { seen_from, .. })) => near(seen_from),
        _ => false,
    }
}

/// An object this close (m, horizontally) to where the survey places a
/// target stands at its place: a map in the survey's frame is within a
/// few decimetres of it.
const AT_PLACE_M: f64 = 0.5;

/// The error when too few targets were located to align: which were not and
/// why, and the remedy that fits the survey's frame.
pub(super) fn too_few_found(
    found: &[TargetRun],
    survey: &Survey,
    n_found: usize,
    need: usize,
    cfg: &Config,
    map: &str,
    how: &FrameHow,
) -> Error {
    let why: Vec<String> = found
        .iter()
        .filter_map(|r| r.outcome.as_ref().err().map(|e| format!("{}: {e}", r.id)))
        .collect();
    let mut msg = format!(
        "{map}: only {n_found} of {} targets found in the map (need {need} for {})",
        survey.targets.len(),
        cfg.metrics.align.name(),
    );
    // Objects located where the survey says, but in a layout no map bends
    // to: the survey (or the unit) is the first suspect, not the frame.
    if let Some(off) = off_layout(found, survey) {
        msg += &off;
        return Error::TooFewFound {
            found: n_found,
            need,
            msg,
        };
    }
    // The plates' size first: the frame is not to blame.
    if let Some(size) = other_plate_size(found, cfg) {
        msg += ". ";
        msg += &size;
        return Error::TooFewFound {
            found: n_found,
            need,
            msg,
        };
    }
    if !why.is_empty() {
        msg += "; ";
        msg += &why[..why.len().min(5)].join("; ");
        if why.len() > 5 {
            msg += "; ...";
        }
    }
    msg += &remedy(found, survey, n_found, need, cfg, how);
    Error::TooFewFound {
        found: n_found,
        need,
        msg,
    }
}

/// The sentence when objects were located where the survey says, but not
/// standing as the survey places them (their distances to each other);
/// `None` when no such object was refused.
fn off_layout(found: &[TargetRun], survey: &Survey) -> Option<String> {
    if !found
        .iter()
        .any(|r| matches!(r.outcome, Err(Failure::OffLayout { alone: false, .. })))
    {
        return None;
    }
    let off: Vec<String> = found
        .iter()
        .filter_map(|r| match &r.outcome {
            Err(Failure::OffLayout {
                misfit, distance, ..
            }) if *misfit > 0.0 => Some(format!("{} {misfit:.2} m off over {distance:.1} m", r.id)),
            _ => None,
        })
        .collect();
    let mut msg = format!(
        ". The objects located at the surveyed places do not stand as the survey places them (their distances to each other: {})",
        off.join(", ")
    );
    if let Some(r) = layout::distance_ratio(&layout::placed(found), survey) {
        msg += &format!("; map distances are {r:.3} × the survey's, median over the pairs");
    }
    msg += ", by more than a working map's error: check the survey's positions, ids and unit (metres, both files), that these objects are the targets, and the map itself (a failed loop closure bends a map by metres)";
    Some(msg)
}

/// What to try, from what the survey and the frame say: too few surveyed
/// targets, a detected frame whose targets would not locate, a seam, or
/// the frame (empty when none fits).
fn remedy(
    found: &[TargetRun],
    survey: &Survey,
    n_found: usize,
    need: usize,
    cfg: &Config,
    how: &FrameHow,
) -> String {
    if survey.targets.len() < need {
        format!(
            ". The survey has {} target(s): {need} are needed to align",
            survey.targets.len()
        )
    } else if let FrameHow::Detected { matched, .. } = how {
        format!(
            ". The map's frame was found by matching {} detected targets to the survey, but they could not be located there (see the reasons above)",
            matched.len()
        )
    } else if n_found
        + found
            .iter()
            .filter(|r| matches!(r.outcome, Err(Failure::Doubled(_))))
            .count()
        >= need
    {
        // Counting the targets seen twice, enough were where the survey
        // puts them: the frame is right, the map has a seam.
        ". Targets mapped twice are where the survey places them: the map has a seam there (a loop closed badly?), which no frame or flag can mend; each such target's reason names its copies".into()
    } else if n_found < survey.targets.len()
        && !found
            .iter()
            .all(|r| r.outcome.is_ok() || matches!(r.outcome, Err(Failure::HandCrop(_))))
    {
        // The guess given places too few targets: say so, not "give one".
        let init_hint = cfg.frame.init.as_ref().map(|i| format!(
            ". The --init given ({}, {}, {}°) puts the surveyed targets where the map shows too few of them: check its convention (survey = R(yaw)·map + (x, y): x, y the map origin's survey position, yaw the map's +x axis from the survey's, anticlockwise), or run without it{} (eval then looks for the targets map-wide)",
            i.x, i.y, i.yaw_deg,
            if cfg.frame.mode == config::FrameMode::Survey { " and without --frame survey" } else { "" }
        ));
        match (survey.frame, survey.origin) {
            (crate::survey::SurveyFrame::Wgs84Enu, Some(o)) => format!(
                ". The survey is WGS84, placed in a local east-north-up frame about {:.7}, {:.7}; if the map's origin is elsewhere, give --origin LAT,LON[,ALT] of the map's origin (and --init x,y,yaw_deg if its axes are not east and north)",
                o.lat, o.lon
            ),
            _ if init_hint.is_some() => init_hint.unwrap_or_default(),
            // Told to look in the survey frame only: detection never ran.
            _ if cfg.frame.mode == config::FrameMode::Survey => ". Is the map in the survey frame? If not, run without --frame survey (eval then looks for the targets map-wide) or give --init x,y,yaw_deg".into(),
            _ => ". Is the map in the survey frame? If not, give --init x,y,yaw_deg".into(),
        }
    } else {
        String::new()
    }
}

/// The sentence for L's of one other size seen at two or more of the
/// surveyed places (refused for their size alone): the plates are likely not
/// the configured ones, which every later message would hide.
pub(super) fn other_plate_size(found: &[TargetRun], cfg: &Config) -> Option<String> {
    let sizes: Vec<[f64; 3]> = found
        .iter()
        .filter_map(|r| match &r.outcome {
            Err(Failure::Tight(crop::TightError::NoTargetShape { seen: Some(s), .. })) => s
                .plate_size
                .as_ref()
                .map(|s| s.map(|v| v.unwrap_or(f64::NAN))),
            _ => None,
        })
        .collect();
    if sizes.len() < 2 {
        return None;
    }
    // Per dimension, over the places where it was measured.
    let median = |ks: &[usize]| {
        let mut v: Vec<f64> = sizes
            .iter()
            .flat_map(|s| ks.iter().map(|&k| s[k]))
            .filter(|v| v.is_finite())
            .collect();
        v.sort_unstable_by(f64::total_cmp);
        v.get(v.len() / 2).copied()
    };
    let (w, h) = (median(&[0, 1]), median(&[2]));
    let (cw, ch) = (cfg.tight.plate_width, cfg.tight.plate_height);
    let off = |m: Option<f64>, c: f64| m.is_some_and(|m| (m - c).abs() > 0.15 * c);
    if !off(w, cw) && !off(h, ch) {
        return None;
    }
    // The same L at each place: what was measured within a sixth of the median.
    let near = |v: f64, m: Option<f64>| !v.is_finite() || m.is_none_or(|m| (v - m).abs() < m / 6.0);
    let alike = sizes
        .iter()
        .filter(|s| near(s[0], w) && near(s[1], w) && near(s[2], h))
        .count();
    let said = |m: Option<f64>, what: &str| m.map(|m| format!("{m:.2} m {what}"));
    let size: Vec<String> = [said(w, "wide"), said(h, "tall")]
        .into_iter()
        .flatten()
        .collect();
    let flag = format!("{:.2},{:.2}", w.unwrap_or(cw), h.unwrap_or(ch));
    // The same L at two places or more, and at half of those that showed an
    // L-like object at all: two kerbs among ten places are not a plate size.
    let shown = found
        .iter()
        .filter(|r| {
            matches!(
                r.outcome,
                Err(Failure::Tight(crop::TightError::NoTargetShape {
                    seen: Some(_),
                    ..
                }))
            )
        })
        .count();
    (alike >= 2 && 2 * alike >= shown).then(|| {
        format!(
            "L's of other plates than configured stand at {alike} of the surveyed places: plates about {} (where measured), against {cw},{ch} m configured (--plate-size). Is that their size? If so, give --plate-size {flag} (a hidden lower part makes an L look shorter; if they are not the targets, the map may be in another frame: --init x,y,yaw_deg)",
            size.join(", ")
        )
    })
}

/// Fewer finite points than this is not a map (see `run`).
const MIN_MAP_POINTS: u64 = 100;

/// A float32 map whose coordinates are rounded to this step (m) or more is
/// refused: a uniform rounding of 0.1 m is 29 mm of noise on every point,
/// beyond a LiDAR map's own.
const FLOAT32_REFUSED_STEP: f64 = 0.1;

/// What the ground pass says of the map before anything is located: too few
/// points to be a map (`needs_points`: not when hand crops are given), or
/// float32 coordinates too far from their origin to measure anything.
pub(super) fn check_map(
    map: &MapStats,
    ground: &crate::frame::MapGround,
    needs_points: bool,
    warnings: &mut Vec<Warning>,
) -> Result<()> {
    // A located target alone takes hundreds of points: a "map" of fewer than
    // a hundred is another file (the survey, a list of positions) given as
    // the map, and every later message (no frame found, no target) would
    // hide that.
    if needs_points && map.points < MIN_MAP_POINTS {
        return Err(Error::Input(format!(
            "{}: only {} finite points{}; a map holds thousands around each target: is this the map?",
            map.name,
            map.points,
            if map.skipped_nonfinite > 0 {
                format!(" ({} non-finite skipped)", map.skipped_nonfinite)
            } else {
                String::new()
            }
        )));
    }
    if let Some((step_m, reach_m)) = ground.float32_step {
        let w = Warning::Float32Steps { step_m, reach_m };
        // Rounding of a tenth of a metre (coordinates beyond 1 048 576 m: UTM
        // northings) is noise no plate fit averages away; below, a warning.
        if step_m >= FLOAT32_REFUSED_STEP {
            return Err(Error::Input(format!(
                "{}: {w}. At that step no target can be measured: refused",
                map.name
            )));
        }
        warnings.push(w);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::up_not_z;
    use crate::Point;
    use crate::cloud::MapSource;

    /// A small random step, the same every run.
    fn jitter(s: &mut u64) -> f64 {
        *s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*s >> 33) as f64) / (1u64 << 31) as f64 - 0.5
    }

    fn asked(pts: &[Point]) -> bool {
        let g = crate::frame::ground_level(MapSource::Points(pts), None, None, |_| {}).unwrap();
        up_not_z("m", &g).is_some()
    }

    /// The y-up question (review of 8 Dec 2026): asked of a wooded site
    /// written with y up; not of a stairwell 16 m tall on a 5 m plan, nor
    /// of a 300 m trail climbing 45 m through rough ground, both z up.
    #[test]
    fn only_a_strip_deep_in_z_is_asked_about_its_up() {
        let mut s = 1u64;
        // A 120 × 60 m site with a tree (12 m) every 10 m.
        let mut site = Vec::new();
        for i in 0..600 {
            for j in 0..300 {
                let (x, y) = (i as f64 * 0.2, j as f64 * 0.2);
                site.push(Point::new(x, y, 0.01 * jitter(&mut s)));
            }
        }
        for tx in 0..12 {
            for ty in 0..6 {
                for h in 0..60 {
                    let z = h as f64 * 0.2;
                    site.push(Point::new(
                        5.0 + 10.0 * tx as f64,
                        5.0 + 10.0 * ty as f64,
                        z,
                    ));
                }
            }
        }
        let yup: Vec<Point> = site.iter().map(|p| Point::new(p.x, p.z, -p.y)).collect();
        assert!(!asked(&site));
        assert!(asked(&yup));
        // An open stairwell: flights of 22° (steeper than ground), one
        // above the other every 2 m, walls all round; no floor seen.
        let mut stair = Vec::new();
        for k in 0..8 {
            for i in 0..25 {
                for j in 0..13 {
                    let (x, y) = (i as f64 * 0.2, j as f64 * 0.2 + 2.5 * (k % 2) as f64);
                    stair.push(Point::new(x, y, 2.0 * k as f64 + 0.4 * x));
                }
            }
        }
        for h in 0..90 {
            for t in 0..25 {
                let (t, z) = (t as f64 * 0.2, h as f64 * 0.2);
                stair.extend([
                    Point::new(t, 0.0, z),
                    Point::new(t, 5.0, z),
                    Point::new(0.0, t, z),
                    Point::new(5.0, t, z),
                ]);
            }
        }
        assert!(!asked(&stair));
        // A trail 10 m wide climbing 45 m over 300 m, its ground rough
        // (a point every 0.5 m, stones of ±20 cm: no block flat), trees
        // 15 m tall every 10 m.
        let mut trail = Vec::new();
        for i in 0..600 {
            for j in 0..20 {
                let (x, y) = (i as f64 * 0.5 + 0.25, j as f64 * 0.5 + 0.25);
                trail.push(Point::new(x, y, 0.15 * x + 0.4 * jitter(&mut s)));
            }
            if i % 20 == 0 {
                let x = i as f64 * 0.5 + 0.25;
                for h in 0..75 {
                    trail.push(Point::new(x, 5.25, 0.15 * x + h as f64 * 0.2));
                }
            }
        }
        assert!(!asked(&trail));
    }
}
