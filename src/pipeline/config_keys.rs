//! One line per configuration key, printed above it by `--print-config`,
//! so the printed file explains itself. The structs' doc comments say
//! more; a test keeps every printed key described here.

/// `section.key` → what it does, its unit and what it changes.
pub(super) const KEYS: &[(&str, &str)] = &[
    (
        "crop.radius",
        "loose crop radius around each expected position (m; the paper's 5 m)",
    ),
    (
        "crop.shape",
        "\"cylinder\" (within radius horizontally, any height) or \"sphere\" (within radius in 3D)",
    ),
    (
        "crop.max_points",
        "most points kept per crop, a deterministic uniform sample beyond (0 = all): bounds memory on dense maps",
    ),
    (
        "crop.by_level",
        "COPC only: find each target on the octree's coarse levels, then read every level near it (false: every level, as `crop` reads); other formats have no levels: each crop reads every point",
    ),
    (
        "crop.coarse_points",
        "COPC only (with by_level): points the coarse read wants near each target",
    ),
    ("tight.plate_width", "width of each of the L's plates (m)"),
    ("tight.plate_height", "height of the L's plates (m)"),
    ("tight.ground_cell", "cell of the local ground model (m)"),
    (
        "tight.min_height",
        "points lower than this above the local ground are ground (m)",
    ),
    (
        "tight.max_height",
        "points higher than this above the local ground are ignored (m)",
    ),
    (
        "tight.search_radius",
        "horizontal search radius for an L around its expected position (m)",
    ),
    (
        "tight.keep_distance",
        "half-width of the slab kept about each plate's plane (m)",
    ),
    (
        "tight.min_plate_points",
        "fewest points on each plate for a candidate L",
    ),
    (
        "tight.max_up_tilt_deg",
        "the local ground's normal is taken as up only within this of the map's +z (degrees)",
    ),
    ("tight.seed", "seed of the ground's RANSAC"),
    (
        "locate.kmeans_iterations",
        "Lloyd iterations of the k-means that splits the two plates",
    ),
    (
        "locate.kmeans_points",
        "k-means finds its centres on this many drawn points (paper: 0 = all)",
    ),
    (
        "locate.kmeans_space",
        "coordinates k-means compares: \"horizontal\" (as seen from above) or \"full\" (3D, the paper)",
    ),
    (
        "locate.kmeans_init",
        "k-means' starting centres: \"plusplus\" (k-means++) or \"random\" (the paper)",
    ),
    (
        "locate.ransac_iterations",
        "RANSAC hypotheses per plate (paper: 100)",
    ),
    (
        "locate.ransac_score_points",
        "hypotheses scored first on this many points, the best few on all (paper: 0)",
    ),
    (
        "locate.ransac_confidence",
        "adaptive RANSAC stop at this probability of having drawn the best plane (paper: 0 = draw all)",
    ),
    (
        "locate.inlier_threshold",
        "RANSAC / refit inlier distance (m; paper 0.03)",
    ),
    (
        "locate.refit_iterations",
        "extra SVD refits on the previous fit's inliers (paper: 0)",
    ),
    (
        "locate.corner_margin",
        "refits leave out points this close to the other plate (m; more than inlier_threshold)",
    ),
    (
        "locate.refit_sigmas",
        "refit band in noise σ, within [inlier_threshold, corner_margin]",
    ),
    (
        "locate.angle_tolerance_deg",
        "plates perpendicular to each other and to the ground within this (degrees; paper 1)",
    ),
    (
        "locate.samples",
        "accepted localisation draws averaged per target (paper: 100)",
    ),
    (
        "locate.min_samples",
        "fewest accepted draws for a result when max_attempts runs out",
    ),
    (
        "locate.max_attempts",
        "most localisation draws per target (bounds a hopeless crop)",
    ),
    ("locate.seed", "seed of every draw of the localisation"),
    (
        "sphere.diameter_m",
        "diameter of spheres whose survey row gives no size (m)",
    ),
    (
        "sphere.radius_sigma_m",
        "1-σ of the sphere's true radius about the nominal (m): build tolerance, beam footprint",
    ),
    ("sphere.min_points", "fewest surface points for a sphere"),
    (
        "sphere.search_radius_m",
        "horizontal search radius around a sphere's expected position (m)",
    ),
    (
        "sphere.max_points",
        "most crop points looked at (a deterministic uniform sample beyond)",
    ),
    (
        "sphere.seed",
        "seed of the hypotheses' and the resampling's draws",
    ),
    (
        "board.side_m",
        "side of checkerboard boards whose survey row gives no size (m)",
    ),
    ("board.min_points", "fewest points on a board"),
    (
        "board.search_radius_m",
        "horizontal search radius around a board's expected position (m)",
    ),
    (
        "board.max_points",
        "most crop points looked at (a deterministic uniform sample beyond)",
    ),
    (
        "board.seed",
        "seed of the plane hypotheses' and the resampling's draws",
    ),
    (
        "metrics.align",
        "map → survey alignment: rigid2d (the paper), rigid2d+z, rigid3d, similarity2d, similarity3d, robust2d, none",
    ),
    (
        "metrics.dim",
        "error dimension: \"2d\" (the paper) or \"3d\"",
    ),
    (
        "metrics.survey_sigma_h",
        "the survey's own horizontal 1-σ (m), folded into the ASPRS figures",
    ),
    (
        "metrics.survey_sigma_v",
        "the survey's own vertical 1-σ (m)",
    ),
    (
        "metrics.exclude_outliers",
        "refit without targets flagged as gross errors (they stay in the result as excluded)",
    ),
    (
        "metrics.threshold_m",
        "ISO 19157: count the checkpoints whose error exceeds this (m)",
    ),
    (
        "metrics.scores",
        "benchmark scores to add: \"hilti2022\", \"hilti2023\", \"hilti2026\"",
    ),
    (
        "frame.mode",
        "how the map's frame is found: auto (init or hints when given, else survey, else detect), survey, detect, hints",
    ),
    (
        "frame.hints",
        "CSV id,x,y[,z] of approximate map positions (±0.5 m) of two or more targets",
    ),
    (
        "frame.match_tolerance",
        "a detection matches a surveyed target within this (m); covers the map's own error",
    ),
    (
        "frame.init",
        "approximate map → survey transform [x, y, yaw_deg] (survey = R·map + t)",
    ),
    (
        "frame.origin",
        "ENU origin [lat, lon, alt] of a WGS84 survey",
    ),
    (
        "frame.second_pass",
        "search again for targets not found, where the found ones place them",
    ),
    (
        "frame.second_pass_min_shift",
        "only when that prediction moved more than this (m)",
    ),
    (
        "frame.max_tilt_deg",
        "the targets' common plumb line is trusted as the vertical up to this tilt (degrees)",
    ),
    (
        "frame.tilt_redo_deg",
        "Ls located with an up further than this from the common plumb line are located again (degrees)",
    ),
    (
        "frame.level_above_deg",
        "the map is levelled when its ground leans more than this (degrees)",
    ),
    (
        "frame.level_min_support",
        "... and at least this share of its flat 2 m ground blocks agree on the vertical",
    ),
    (
        "frame.ground_sample",
        "points the levelling's ground pass reads of a bigger map, an even sample of whole parts (0 = all)",
    ),
    (
        "gates.policy",
        "strict: a failed gate exits 1, an undecided one 3; point: values alone, intervals ignored; report-only: the exit code ignores gates",
    ),
    (
        "gates.checks",
        "the gates, e.g. \"E_abs<=0.05\"; --gate flags replace them",
    ),
];

/// The line for `section.key`, if any.
pub(super) fn doc(section: &str, key: &str) -> Option<&'static str> {
    KEYS.iter()
        .find(|(k, _)| k.split_once('.') == Some((section, key)))
        .map(|(_, d)| *d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every key `--print-config` prints has its line, and every line is
    /// of a key it prints (set, or as the comment of an unset one).
    #[test]
    fn every_printed_key_is_explained_and_every_explanation_printed() {
        let text = crate::pipeline::Config::default().to_toml();
        let mut section = "";
        let mut prev = "";
        for line in text.lines() {
            if let Some(s) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
                section = s;
            } else if let Some((k, _)) = line.split_once(" = ")
                && !line.starts_with('#')
            {
                let want =
                    doc(section, k.trim()).unwrap_or_else(|| panic!("{section}.{k} has no line"));
                assert_eq!(prev, format!("# {want}"), "{section}.{k}");
            }
            prev = line;
        }
        for (key, _) in KEYS {
            let (section, k) = key.split_once('.').unwrap();
            let body = text
                .split(&format!("[{section}]\n"))
                .nth(1)
                .unwrap_or_else(|| panic!("no [{section}]"));
            let body = body.split("\n[").next().unwrap();
            assert!(
                body.lines()
                    .any(|l| l.starts_with(&format!("{k} = "))
                        || l.starts_with(&format!("# {k} = "))),
                "{key} is not printed"
            );
        }
        // Still a configuration eval reads back.
        let back: crate::pipeline::Config = toml::from_str(&text).unwrap();
        assert_eq!(back.to_toml(), text);
    }
}
