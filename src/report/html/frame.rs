//! The report's frame section: how the map's frame was found.

use super::*;

/// How the map's frame was found: the transform, its residual, the levelling,
/// detections left unmatched.
pub(super) fn frame_section(
    o: &mut String,
    f: &crate::record::FrameInfo,
    doubling: Option<&crate::locate::DoublingLimit>,
) {
    o.push_str("<section id=\"frame\"><h2>Map frame</h2><table class=\"grid\"><tbody>");
    let mut rows = vec![
        ("how it was found", how_found(f)),
        (
            "map → survey used to crop",
            format!(
                "x {:.3} m, y {:.3} m, yaw {:.3}°, z offset {:.3} m",
                f.init[0], f.init[1], f.init[2], f.dz
            ),
        ),
    ];
    levelling_rows(&mut rows, &f.levelling);
    if let Some(d) = doubling {
        rows.push(("targets mapped twice", doubling_row(d)));
    }
    if let Some(d) = &f.detection
        && !d.unmatched.is_empty()
    {
        rows.push((
            "detections left unmatched",
            d.unmatched
                .iter()
                .enumerate()
                .map(|(i, c)| {
                    // An L's corner, a sphere's centre (older results name no model).
                    let model = d.unmatched_models.get(i).map_or("", String::as_str);
                    let named = if model.is_empty() || model == "l" {
                        String::new()
                    } else {
                        format!("{model} ")
                    };
                    format!("{named}({:.2}, {:.2}, {:.2})", c[0], c[1], c[2])
                })
                .collect::<Vec<_>>()
                .join(", "),
        ));
    }
    for (k, v) in rows {
        let _ = write!(
            o,
            "<tr><th>{}</th><td class=\"w\" style=\"text-align:left\">{}</td></tr>",
            escape(k),
            escape(&v)
        );
    }
    o.push_str("</tbody></table></section>\n");
}

/// The first row: which of the ways in found the frame, and for a map-wide
/// detection how convincingly it matched the survey.
fn how_found(f: &crate::record::FrameInfo) -> String {
    match f.how.as_str() {
        "survey" => {
            "the targets were where the survey says: the map is in the survey frame".to_string()
        }
        "init" => "given with --init".to_string(),
        "hints" => "fitted to --hints (approximate map positions of targets)".to_string(),
        "detect" => match &f.detection {
            Some(d) => format!(
                "detected {} target-shaped object(s) map-wide and matched {} to the survey (RMS {:.3} m; the best other frame matched {})",
                d.detections,
                d.matched.len(),
                d.rms,
                d.runner_up
            ),
            None => "detected and matched".to_string(),
        },
        other => other.to_string(),
    }
}

/// Three angles, each with the sentence that relates it to the others: the
/// ground's lean and the plumb lines' are two estimates of the vertical, the
/// turn is what was applied; the surveyed heights a third estimate.
fn levelling_rows(rows: &mut Vec<(&'static str, String)>, l: &crate::record::Levelling) {
    if let (Some(t), Some(s)) = (l.ground_tilt_deg, l.ground_support) {
        rows.push((
            "ground",
            format!(
                "leans {t:.2}° from the map's +z ({:.0} % of 2 m ground blocks agree). The first estimate of the vertical, from the lowest points of 2 m blocks across the map; a site's own slope is in it too, so it turns a map only beyond frame.level_above_deg and when frame.level_min_support of the blocks agree, and never one whose header declares a CRS",
                100.0 * s
            ),
        ));
    }
    rows.push((
        "turned",
        if l.tilt_deg > 0.0 {
            format!(
                "by {:.2}° about ({:.1}, {:.1}, {:.1}). The rotation applied to the map: positions in this report are in that levelled frame, and the map as stored differs from it by this angle",
                l.tilt_deg, l.origin[0], l.origin[1], l.origin[2]
            )
        } else {
            "not at all. The map was read as it is (the ground and plumb-line rows, and the warnings above, say what it showed)".to_string()
        },
    ));
    if let (Some(t), Some(s)) = (l.plumb_tilt_deg, l.plumb_se_deg) {
        rows.push((
            "targets' plumb lines",
            format!(
                "lean {t:.2}° ± {s:.2}° from the vertical used to locate them{}. Each target's plates meet in a line built plumb: their weighted mean is a second estimate of the vertical, from the targets themselves. With the ground's (in a frame the ground turned) and the surveyed heights' (below), it turns a ground-levelled frame always, and a map read as it is when their combined lean exceeds 3 standard errors and 0.5° (0.1° with the surveyed heights; 5 standard errors and 1° where the map's header declares a coordinate reference system){}",
                if l.plumb_applied {
                    "; the frame was turned to them"
                } else {
                    ""
                },
                l.plumb_bar_deg
                    .filter(|b| *b > 0.01)
                    .map(|b| format!(". This run's bar: {b:.2}°"))
                    .unwrap_or_default()
            ),
        ));
    }
    if let (Some(t), Some(s), Some(n)) = (l.heights_tilt_deg, l.heights_se_deg, l.heights_targets) {
        rows.push((
            "surveyed heights",
            format!(
                "lean {t:.3}° ± {s:.3}° over {n} targets ({}). The located corners' heights less the surveyed ones, fitted as a plane over the site: a lean raises a corner by its distance times the angle, so heights hundreds of metres apart give it far more precisely than plumb lines. Combined with the plumb lines when the two agree within their uncertainties and the map itself shows a lean (the ground turned it, or its plumb lines lean beyond 2 standard errors): heights alone cannot tell a lean from a vertical drift{}",
                if l.heights_used == Some(true) {
                    "used"
                } else {
                    "not used"
                },
                l.vertical_se_deg
                    .map(|v| format!(
                        "; the vertical the frame was turned to is known to ±{v:.3}° (1σ)"
                    ))
                    .unwrap_or_default()
            ),
        ));
    }
}

/// How far apart two copies of a target must be to be told apart, against
/// this map's plate thickness: closer copies blend unflagged.
fn doubling_row(d: &crate::locate::DoublingLimit) -> String {
    format!(
        "copies about {:.0} mm or more apart along a plate's normal are usually seen (reported ambiguous and left out of the fit; each copy needs a fifth of a plate's points, on plates of 120 or more points in their middle); this map's plates are {:.0} mm thick (1σ of their points along the normal, the median single target's thinner plate), and closer copies (a seam of a few centimetres) look like one plate and blend into one corner between them, unflagged",
        d.resolved_from_m * 1000.0,
        d.plate_thickness_m * 1000.0
    )
}
