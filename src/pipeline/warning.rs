//! What a run tells its user besides the numbers: each warning typed,
//! with its sentence.

/// Something the caller should tell the user.
#[derive(Debug, Clone, PartialEq)]
pub enum Warning {
    /// A sphere crop was asked for but the survey has no heights: a vertical
    /// cylinder was used.
    SphereWithoutHeights,
    /// These targets were flagged as gross errors and left out of the fit
    /// and the statistics (`metrics.exclude_outliers`).
    OutliersExcluded(Vec<String>),
    /// Objects located for these targets were far from where the others put
    /// them and were rejected (the targets are not found).
    WrongObjects(Vec<String>),
    /// These targets are mapped twice (their plates show two layers): they
    /// are reported as ambiguous and left out of the fit.
    Doubled(Vec<String>),
    /// Few targets were found where expected, and detection could not find
    /// another frame; the first guess was kept.
    DetectionFailed(String),
    /// The frame the user gave (`--init` or `--hints`) found too few targets
    /// where it put them; detection found another frame, which was used.
    GivenFrameReplaced {
        /// `init` or `hints`.
        given: &'static str,
        /// Targets found with the given frame.
        found: usize,
        /// Targets in the survey.
        targets: usize,
    },
    /// The map stores float32 coordinates far from its origin: every
    /// position in it is rounded to a coarse step.
    Float32Steps {
        /// The step (m).
        step_m: f64,
        /// The farthest coordinate from the origin (m).
        reach_m: f64,
    },
    /// The ground leans, but the map's header declares a coordinate
    /// reference system: not levelled.
    Georeferenced {
        /// The CRS as named (`EPSG:32633`).
        crs: String,
        /// The ground's lean (degrees).
        tilt_deg: f64,
    },
    /// The surveyed heights lean otherwise than the targets' plumb lines,
    /// by more than both their uncertainties allow: not used to level.
    HeightsDisagree {
        /// The heights' lean and its standard error (degrees).
        heights_deg: f64,
        /// See `heights_deg`.
        heights_se_deg: f64,
        /// The plumb lines' lean and its standard error (degrees).
        plumb_deg: f64,
        /// See `plumb_deg`.
        plumb_se_deg: f64,
        /// Angle between the two verticals (degrees).
        apart_deg: f64,
    },
    /// The targets' plumb lines lean beyond twice their standard error,
    /// but not as far as levelling by them asks: the map was not levelled,
    /// and its heights may carry that lean.
    LeanNotLevelled {
        /// Their lean and its standard error (degrees).
        tilt_deg: f64,
        /// See `tilt_deg`.
        se_deg: f64,
        /// Targets that gave a plumb line.
        targets: usize,
        /// The lean levelling asks for (degrees).
        bar_deg: f64,
        /// The map's header declares a CRS: the bar is higher.
        georeferenced: bool,
        /// The surveyed heights were part of the lean.
        heights: bool,
    },
    /// The ground about these targets shows two layers at heights
    /// centimetres apart: the map has a seam there (a loop closed badly),
    /// and their σz was raised to cover either copy.
    GroundDoubled {
        /// The targets.
        ids: Vec<String>,
        /// The least and most separation among them (m).
        separation_m: (f64, f64),
        /// The largest vertical σ after widening (m).
        sigma_m: f64,
    },
    /// These targets' plates were seen over part of their height only, or
    /// (`taller`) their points span more than a plate's height: their
    /// heights' σ was raised to cover what that leaves open.
    HeightsUncertain {
        /// The targets.
        ids: Vec<String>,
        /// The least and most plate height seen among them (m; at most the
        /// plate height unless `taller`).
        seen_m: (f64, f64),
        /// The plates' configured height (m).
        plate_height_m: f64,
        /// The largest vertical σ after widening (m).
        sigma_m: f64,
        /// Their points span more than a plate's height (plates taller than
        /// configured, a target mapped twice at heights centimetres apart,
        /// something else in the plates' planes).
        taller: bool,
        /// Enough located targets show it to ask about the plates' size:
        /// every one (three or more) for short spans, half of them (three
        /// or more) for tall ones, which plates of the configured size do
        /// not show.
        every: bool,
    },
    /// These targets' plates leaned beyond the vertical gate in the frame
    /// they were first located in; with the others' they shared one plumb
    /// line, located them at that common vertical, and the targets' plumb
    /// lines levelled the map.
    LeaningTargets {
        /// The targets located at the common vertical.
        ids: Vec<String>,
        /// Its tilt from the frame's +z (degrees).
        tilt_deg: f64,
    },
    /// The ground leans, but too few of its flat blocks agree on the lean to
    /// level the map by: not levelled.
    GroundWeak {
        /// The ground's lean (degrees).
        tilt_deg: f64,
        /// Share of the flat 2 m ground blocks within 1° of that vertical.
        support: f64,
        /// Flat ground blocks.
        blocks: usize,
        /// The share levelling asks for (`frame.level_min_support`).
        min_support: f64,
    },
    /// The map leans; it was read levelled and positions are in that frame.
    Levelled {
        /// Total tilt corrected (degrees).
        tilt_deg: f64,
        /// Standard error of the vertical it was turned to (degrees).
        se_deg: f64,
        /// What that angle does to the targets' levelled positions: the
        /// largest height change (m: distance from the levelling origin × the
        /// angle) and horizontal change (mm: height above it × the angle).
        height_m: f64,
        /// See `height_m`.
        across_mm: f64,
        /// And what it does to distances across the site (mm): the farthest
        /// two targets apart × (1 − cos angle), a tilt error's
        /// foreshortening of every horizontal distance.
        shorter_mm: f64,
    },
}

impl Warning {
    /// What it does to the numbers, for ordering what a reader sees first:
    /// 0 a number may be wrong or targets were set aside, 1 the frame was
    /// chosen or turned, 2 how a step was done.
    pub fn weight(&self) -> u8 {
        match self {
            Warning::Float32Steps { .. }
            | Warning::Doubled(_)
            | Warning::HeightsUncertain { .. }
            | Warning::GroundDoubled { .. }
            | Warning::WrongObjects(_)
            | Warning::OutliersExcluded(_) => 0,
            Warning::Levelled { .. }
            | Warning::HeightsDisagree { .. }
            | Warning::LeanNotLevelled { .. }
            | Warning::Georeferenced { .. }
            | Warning::GroundWeak { .. }
            | Warning::LeaningTargets { .. }
            | Warning::GivenFrameReplaced { .. }
            | Warning::DetectionFailed(_) => 1,
            Warning::SphereWithoutHeights => 2,
        }
    }
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Warning::SphereWithoutHeights => f.write_str(
                "the survey has no heights; cropping with a vertical cylinder instead of a sphere",
            ),
            Warning::OutliersExcluded(ids) => write!(
                f,
                "gross errors excluded and the alignment refitted without them: {}",
                ids.join(", ")
            ),
            Warning::Doubled(ids) => write!(
                f,
                "{} {} mapped twice, the copies centimetres apart (the map has a seam there: a loop closed badly?): reported as ambiguous and left out of the fit",
                if ids.len() == 1 { "target" } else { "targets" },
                ids.join(", ")
            ),
            Warning::GroundDoubled {
                ids,
                separation_m,
                sigma_m,
            } => {
                let one = ids.len() == 1;
                let apart = if separation_m.1 - separation_m.0 < 0.0005 {
                    format!("{:.0} mm", separation_m.0 * 1e3)
                } else {
                    format!("{:.0}-{:.0} mm", separation_m.0 * 1e3, separation_m.1 * 1e3)
                };
                write!(
                    f,
                    "the ground around {} {} shows two thin layers {apart} apart in height everywhere, as a map does where a loop closed badly and mapped it twice (or a surface of two levels: a grating over a floor). A seam in height hides in a target's own points, so {} {} uncertain by that much: {} vertical σ (up to {:.0} mm) includes it; horizontal positions are unaffected by it",
                    if one { "target" } else { "targets" },
                    ids.join(", "),
                    if one { "its height" } else { "their heights" },
                    if one { "is" } else { "are" },
                    if one { "its" } else { "their" },
                    sigma_m * 1e3,
                )
            }
            Warning::HeightsUncertain {
                ids,
                seen_m,
                plate_height_m,
                sigma_m,
                taller,
                every,
            } => heights_uncertain(f, ids, *seen_m, *plate_height_m, *sigma_m, *taller, *every),
            Warning::WrongObjects(ids) => write!(
                f,
                "{} {}: the object located there is not that target (far from where the other targets place it, or another target's object); reported as not found, each with its reason",
                if ids.len() == 1 { "target" } else { "targets" },
                ids.join(", ")
            ),
            Warning::DetectionFailed(e) => write!(
                f,
                "few targets were found where expected and detection found no other frame ({e}); the expected frame was kept"
            ),
            Warning::GivenFrameReplaced {
                given,
                found,
                targets,
            } => write!(
                f,
                "the frame from --{given} found {found} of {targets} targets where it put them; the targets were detected in the map and that frame was used instead (result.json eval.frame)"
            ),
            Warning::Float32Steps { step_m, reach_m } => write!(
                f,
                "the map stores its coordinates as float32, and they reach {reach_m:.0} m from the origin, where float32 keeps steps of {}: every point (and every located target) is rounded to that step, whatever the map's own accuracy. Have the map written in double precision, or about a local origin",
                if *step_m >= 0.1 {
                    format!("{step_m:.2} m")
                } else {
                    format!("{:.1} mm", step_m * 1e3)
                }
            ),
            Warning::Georeferenced { crs, tilt_deg } => write!(
                f,
                "the map's header declares a coordinate reference system ({crs}), so its z is vertical by construction: the ground's lean of {tilt_deg:.1}° is taken as the terrain's, not the map's, and the ground does not level it (the targets' plumb lines, with their surveyed heights, still may when they lean by a degree and five times their scatter)"
            ),
            Warning::LeaningTargets { ids, tilt_deg } => write!(
                f,
                "target(s) {} leaned beyond the vertical gate (locate.angle_tolerance_deg) in the frame they were first located in; with the other targets they share a plumb line {tilt_deg:.2}° from that frame's +z, and the map was levelled by the targets' plumb lines",
                ids.join(", ")
            ),
            Warning::GroundWeak {
                tilt_deg,
                support,
                blocks,
                min_support,
            } => write!(
                f,
                "the ground leans {tilt_deg:.1}°, but only {:.0} % of its {blocks} flat 2 m blocks agree on that vertical (levelling by the ground asks for {:.0} %, frame.level_min_support): taken as the terrain's slopes, not the map's tilt, and the map was not levelled by it (the targets' plumb lines still may, when they all lean beyond their scatter)",
                100.0 * support,
                100.0 * min_support
            ),
            Warning::HeightsDisagree {
                heights_deg,
                heights_se_deg,
                plumb_deg,
                plumb_se_deg,
                apart_deg,
            } => write!(
                f,
                "the surveyed heights say the map leans {heights_deg:.2}° ± {heights_se_deg:.2}° and its targets' plumb lines {plumb_deg:.2}° ± {plumb_se_deg:.2}° (1σ), verticals {apart_deg:.2}° apart: further apart than their uncertainties together allow, so the heights were not used for the vertical. The map's heights may drift (odometry's vertical drift bends a map without leaning it: evaluate heights with care), or the survey's heights are not the targets' corners' (check the antenna heights and the height datum)"
            ),
            Warning::LeanNotLevelled {
                tilt_deg,
                se_deg,
                targets,
                bar_deg,
                georeferenced,
                heights,
            } => write!(
                f,
                "the plumb lines of {targets} targets{} lean {tilt_deg:.2}° ± {se_deg:.2}° (1σ): beyond twice their standard error, but short of the {bar_deg:.2}° {}, so the map was not levelled. If it leans that much, heights 100 m apart differ by {:.2} m in it: evaluate heights with care ({})",
                if *heights {
                    ", with the surveyed heights,"
                } else {
                    ""
                },
                if *georeferenced {
                    "a map whose header declares a coordinate reference system must lean before its targets turn it (5σ, and at least 1°: its z is vertical by construction)"
                } else {
                    "levelling by plumb lines alone asks (3σ, and at least 0.5°)"
                },
                100.0 * tilt_deg.to_radians().tan(),
                match (georeferenced, heights) {
                    (true, true) => {
                        "the surveyed heights lean alike: check the map's georeferencing, its vertical datum or the transform it was written with"
                    }
                    (true, false) => {
                        "check that the targets stand upright; surveyed heights of five or more located targets would tell a leaning map from leaning targets"
                    }
                    _ => "surveyed heights of five or more located targets would settle the lean",
                }
            ),
            Warning::Levelled {
                tilt_deg,
                se_deg,
                height_m,
                across_mm,
                shorter_mm,
            } => write!(
                f,
                "the map leans {tilt_deg:.2}° from the vertical; it was levelled, and located positions are given in the levelled frame (result.json eval.frame.levelling maps them back). The vertical is known to ±{se_deg:.2}° (1σ): the targets' levelled heights are uncertain by up to {height_m:.2} m (distance from the levelling origin × that angle), their horizontal positions by up to {across_mm:.1} mm (height above it × that angle), and distances across the site may read short by up to {shorter_mm:.1} mm (the farthest located targets' distance × (1 − cos of that angle)): the first two included in each target's σ, all three in the intervals (as one tilt shared by all)"
            ),
        }
    }
}

/// [`Warning::HeightsUncertain`]'s sentence, singular or plural, short
/// spans or tall, with the plate height asked about when enough targets
/// show it.
fn heights_uncertain(
    f: &mut std::fmt::Formatter<'_>,
    ids: &[String],
    seen_m: (f64, f64),
    plate_height_m: f64,
    sigma_m: f64,
    taller: bool,
    every: bool,
) -> std::fmt::Result {
    let one = ids.len() == 1;
    let span = if seen_m.1 - seen_m.0 < 0.005 {
        format!("{:.2} m", seen_m.0)
    } else {
        format!("{:.2}-{:.2} m", seen_m.0, seen_m.1)
    };
    let seen = if taller {
        format!(
            "span {span}, more than the {plate_height_m:.2} m plate height (plates taller than configured, a target mapped twice at heights centimetres apart where a loop closed badly, or something else in the plates' planes)"
        )
    } else {
        format!(
            "cover {span} of the {plate_height_m:.2} m plate height (a barrier, grass or a vehicle hiding the plates from below, or sparse scan lines)"
        )
    };
    write!(
        f,
        "the {} {} {} uncertain by up to {:.0} mm (1σ): {} plates' points {seen}, and the reference point at mid plate height is placed only to within that. The vertical σ includes it; horizontal positions are unaffected while the plates stand upright",
        if one {
            "height of target"
        } else {
            "heights of targets"
        },
        ids.join(", "),
        if one { "is" } else { "are" },
        sigma_m * 1e3,
        if one { "its" } else { "their" },
    )?;
    if every {
        write!(
            f,
            ". {} located target{} show{} it: are the plates {plate_height_m:.2} m tall (--plate-size W,H)?",
            if taller {
                "Half or more of the"
            } else {
                "Every"
            },
            if taller { "s" } else { "" },
            if taller { "" } else { "s" },
        )?;
    }
    Ok(())
}
