//! The terminal report of one run: a summary first (targets found, E_abs,
//! E_rel, RMSE_H in millimetres, the alignment), then one row per target,
//! then the rest. It stays one screen whatever the number of targets: the
//! paper's Table I has n(n−1)/2 columns, so it is printed only for a few
//! targets; every pair is in `pairs.csv`, on the terminal with `--verbose`,
//! and the paper's layouts stay available with `--format` and `mapgauge table`.

use super::Grid;
use super::TableFormat;
use super::numbers::{fixed, mm, signed_ppm};
use super::tables::{absolute_grid, extra_grid, relative_grid};
use crate::record::ResultFile;
use std::fmt::Write as _;

/// Up to this many targets the paper's Tables I and II are printed too
/// (the terminal summary and the report alike).
pub(crate) const PAPER_TABLES_UP_TO: usize = 6;

/// Every pair for the terminal: distances in metres, errors in millimetres as
/// everywhere else on the terminal and in the report (`pairs.csv` keeps metres).
fn pairs_mm(r: &ResultFile) -> Grid {
    let mut g = Grid {
        header: [
            "a",
            "b",
            "survey distance m",
            "map distance m",
            "error mm",
            "mm per 100 m",
        ]
        .map(String::from)
        .to_vec(),
        ..Default::default()
    };
    for p in &r.relative.pairs {
        g.rows.push(vec![
            p.a.clone(),
            p.b.clone(),
            format!("{:.3}", p.survey_distance),
            format!("{:.3}", p.map_distance),
            mm(p.error),
            p.error_per_100m.map(mm).unwrap_or_else(|| "–".into()),
        ]);
    }
    g
}

/// The terminal report of one run; `verbose` adds every pair.
pub fn render_text(r: &ResultFile, verbose: bool) -> String {
    let mut o = String::new();
    // A run held to gates says first whether it passed them.
    for line in super::gate_lines(r) {
        let _ = writeln!(o, "{line}");
    }
    headline(&mut o, r);
    intervals(&mut o, r);
    if let Some(sc) = &r.scale {
        scale_line(&mut o, r, sc);
    }
    alignment_line(&mut o, r);
    // What may change how the numbers read comes before the tables; the
    // caveats every small 2D run carries, folded into one note at the end.
    let stock = crate::record::warning_text(&crate::accuracy::Warning::VerticalNotReported);
    for w in r.warnings.iter().filter(|w| **w != stock) {
        let _ = writeln!(o, "warning: {w}");
    }
    o.push('\n');

    let g = targets_mm(r);
    let _ = writeln!(o, "Targets");
    o.push_str(&g.render(TableFormat::Text));
    o.push('\n');

    tables(&mut o, r, verbose);
    closing(&mut o, r, verbose, &stock);
    o
}

/// The summary's first lines: how many targets were found and the run's
/// figures in millimetres (E_abs, E_rel, RMSE_H and NSSDA's).
fn headline(o: &mut String, r: &ResultFile) {
    let dim = r.dim.label();
    let n = r.targets.len();
    let (found, excluded) = r.found();
    let a = &r.alignment;
    let apart = match excluded {
        0 => String::new(),
        1 => " (1 excluded as a gross error)".into(),
        k => format!(" ({k} excluded as gross errors)"),
    };
    if a.method == "none" {
        let _ = writeln!(
            o,
            "Found {found} of {n} targets{apart}; {dim} errors of the map as it is (no alignment) on {} targets",
            a.n_used
        );
    } else {
        let _ = writeln!(
            o,
            "Found {found} of {n} targets{apart}; {dim} errors after {} alignment on {} targets",
            a.method, a.n_used
        );
    }
    let _ = writeln!(
        o,
        "  E_abs  {:>7} mm   σ_abs {:>7} mm   RMSE {:>7} mm   max {:>7} mm",
        mm(r.absolute.mean),
        mm(r.absolute.std),
        mm(r.absolute.rmse),
        mm(r.absolute.max)
    );
    if let Some(line) = unfitted_line(r) {
        let _ = writeln!(o, "  {line}");
    }
    let _ = writeln!(
        o,
        "  E_rel  {:>7} mm   σ_rel {:>7} mm   over {} pairs",
        mm(r.relative.mean),
        mm(r.relative.std),
        r.relative.n
    );
    // With roles, E_abs and E_rel stay the paper's (every target fitted);
    // the check targets' errors under the control targets' own fit are
    // the independent ones, and say so before the figures drawn from them.
    if let Some(c) = &r.control_check {
        let _ = writeln!(
            o,
            "  check  {:>7} mm   mean over {} check targets ({}), max {} mm, under a fit on the {} control targets alone",
            mm(c.check.summary.mean),
            c.check.summary.n,
            c.check
                .targets
                .iter()
                .map(|t| t.id.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            mm(c.check.summary.max),
            c.control.len()
        );
    }
    let _ = writeln!(
        o,
        "  RMSE_H {:>7} mm   NSSDA 95 % horizontal {} mm ({} checkpoints{})",
        mm(r.asprs.rmse_h),
        mm(r.asprs.nssda_horizontal_95),
        r.asprs.n_checkpoints,
        if r.asprs.independent {
            ", not used to fit"
        } else {
            ", also used to fit"
        }
    );
    for line in super::score_lines(r) {
        let _ = writeln!(o, "  {line}");
    }
}

/// The error of the map as it is, beside the fitted one, and what the fit
/// took away: `without a fit: E_abs 412.3 mm, max …; the rigid2d fit absorbed
/// 96 % of it (rotation -1.004°, shift 1.80 m)`. `None` unless the map is in
/// the survey's frame.
fn unfitted_line(r: &ResultFile) -> Option<String> {
    let u = r.unfitted.as_ref()?;
    let a = &r.alignment;
    if a.method == "none" {
        return None;
    }
    let shift = a.translation[0].hypot(a.translation[1]);
    let share = r.fit_absorbed.unwrap_or(0.0) * 100.0;
    let what = if share >= 0.0 {
        format!("absorbed {} % of it", fixed(share, 0))
    } else {
        format!("made it {} % larger", fixed(-share, 0))
    };
    Some(format!(
        "without a fit (the map as it is, in the survey's frame): E_abs {} mm, max {} mm; the {} fit {what} (rotation {}°, shift {} m)",
        mm(u.mean),
        mm(u.max),
        a.method,
        fixed(a.rotation_deg, 3),
        fixed(shift, 3)
    ))
}

/// The 95 % intervals of the three figures, when the run computed any: how
/// much the measurement noise and the choice of targets could move them.
fn intervals(o: &mut String, r: &ResultFile) {
    let ci = |m: Option<[f64; 2]>, t: Option<[f64; 2]>| -> Option<String> {
        let f = |c: Option<[f64; 2]>| {
            c.map(|[lo, hi]| format!("[{}, {}]", mm(lo), mm(hi)))
                .unwrap_or_else(|| "–".into())
        };
        (m.is_some() || t.is_some()).then(|| format!("measurement {}, targets {}", f(m), f(t)))
    };
    let lines = [
        (
            "E_abs",
            ci(
                r.absolute.ci95_measurement.flatten(),
                r.absolute.ci95_targets.flatten(),
            ),
        ),
        (
            "E_rel",
            ci(r.relative.ci95_measurement, r.relative.ci95_targets),
        ),
        ("RMSE_H", ci(r.asprs.ci95_measurement, r.asprs.ci95_targets)),
    ];
    if lines.iter().any(|l| l.1.is_some()) {
        let _ = writeln!(
            o,
            "  95 % intervals (mm) from the measurement noise and from the choice of targets:"
        );
        for (k, v) in lines {
            if let Some(v) = v {
                let _ = writeln!(o, "    {k:<6} {v}");
            }
        }
    }
}

/// The map's scale against the survey's (ppm), saying whether it is
/// stretched or shrunk when the interval excludes zero.
fn scale_line(o: &mut String, r: &ResultFile, sc: &crate::accuracy::ScaleEstimate) {
    // A WGS84 survey is placed in a local east-north-up frame: a map in
    // a projected grid (UTM) carries the grid's scale against it.
    let grid = if r.survey_frame == crate::survey::SurveyFrame::Wgs84Enu {
        "; a map in a projected grid (UTM) differs from the WGS84 survey's local frame by its grid scale, up to ±1000 ppm"
    } else {
        ""
    };
    let _ = writeln!(
        o,
        "  scale  {} ppm, 95 % [{}, {}] (the map's horizontal distances against the survey's, from {} targets{}{grid})",
        signed_ppm(sc.ppm),
        signed_ppm(sc.ci95_ppm[0]),
        signed_ppm(sc.ci95_ppm[1]),
        sc.n,
        if sc.ci95_ppm[0] > 0.0 || sc.ci95_ppm[1] < 0.0 {
            if sc.ppm > 0.0 {
                ": the map is stretched"
            } else {
                ": the map is shrunk"
            }
        } else {
            ""
        }
    );
}

/// The map → survey transform the errors were measured after.
fn alignment_line(o: &mut String, r: &ResultFile) {
    let a = &r.alignment;
    let _ = writeln!(
        o,
        "  alignment map → survey: rotation {}°, translation ({}, {}, {}) m{}",
        fixed(a.rotation_deg, 4),
        fixed(a.translation[0], 3),
        fixed(a.translation[1], 3),
        fixed(a.translation[2], 3),
        if a.method.starts_with("similarity") {
            format!(
                ", scale {:+.1} ppm (it shrinks the map's distances when the map is stretched)",
                a.scale_ppm
            )
        } else {
            String::new()
        }
    );
}

/// One row a target: its status, error, leave-one-out error, spread and
/// the reason it was not found.
fn targets_mm(r: &ResultFile) -> Grid {
    let mut g = Grid {
        header: [
            "id",
            "status",
            "error mm",
            "leave-one-out mm",
            "σx σy mm",
            "reason",
        ]
        .map(String::from)
        .to_vec(),
        ..Default::default()
    };
    for t in &r.targets {
        g.rows.push(vec![
            t.id.clone(),
            t.status.clone(),
            t.abs_error.map(mm).unwrap_or_else(|| "–".into()),
            t.loo_error.map(mm).unwrap_or_else(|| "–".into()),
            t.map_covariance
                .map(|c| {
                    format!(
                        "{} {}",
                        mm(c[0][0].max(0.0).sqrt()),
                        mm(c[1][1].max(0.0).sqrt())
                    )
                })
                .unwrap_or_else(|| "–".into()),
            t.reason.clone().unwrap_or_default(),
        ]);
    }
    g
}

/// The tables after the targets': the paper's layouts for a few targets,
/// the statistics, and every pair with `verbose`.
fn tables(o: &mut String, r: &ResultFile, verbose: bool) {
    let dim = r.dim.label();
    let n = r.targets.len();
    if n <= PAPER_TABLES_UP_TO {
        // In mm as the rest of the terminal: `table` and --format give the
        // paper's metres.
        let runs = [("this run".to_string(), r)];
        let _ = writeln!(o, "Relative error (mm, {dim}) — paper Table I layout");
        o.push_str(&in_mm(relative_grid(&runs)).render(TableFormat::Text));
        o.push('\n');
        let _ = writeln!(o, "Absolute error (mm, {dim}) — paper Table II layout");
        o.push_str(&in_mm(absolute_grid(&runs)).render(TableFormat::Text));
        o.push('\n');
    }
    let _ = writeln!(o, "Statistics");
    o.push_str(&extra_grid(r).render(TableFormat::Text));
    o.push('\n');
    if verbose {
        let _ = writeln!(o, "Pairs");
        o.push_str(&pairs_mm(r).render(TableFormat::Text));
        o.push('\n');
    }
}

/// ISO 19157's measures in one line: `ISO 19157: bias x +1.2 [-3.0, 5.4] mm,
/// y …; CE90 35.1 mm, CE95 40.2 mm (bias included); LE90 …; 2 of 6
/// checkpoints beyond 50.0 mm`. `None` for results without them.
pub(crate) fn iso_line(r: &ResultFile) -> Option<String> {
    let m = r.iso19157.as_ref()?;
    if m.n == 0 {
        return None;
    }
    let axes = ["x", "y", "z"];
    let bias: Vec<String> = m
        .bias
        .iter()
        .zip(axes)
        .map(|(b, a)| {
            let ci = b
                .ci95
                .map(|c| format!(" [{}, {}]", mm(c[0]), mm(c[1])))
                .unwrap_or_default();
            format!("{a} {}{ci}", mm(b.mean))
        })
        .collect();
    let mut parts = vec![format!("bias {} mm", bias.join(", "))];
    if let (Some(a), Some(b)) = (m.ce90, m.ce95) {
        parts.push(format!("CE90 {} mm, CE95 {} mm", mm(a), mm(b)));
    }
    if let (Some(a), Some(b)) = (m.le90, m.le95) {
        parts.push(format!("LE90 {} mm, LE95 {} mm", mm(a), mm(b)));
    }
    if let (Some(t), Some(h)) = (m.threshold_m, m.above_h) {
        let v = m
            .above_v
            .map(|v| format!(" ({v} vertically)"))
            .unwrap_or_default();
        parts.push(format!(
            "{h} of {} checkpoints beyond {} mm horizontally{v}",
            m.n,
            mm(t)
        ));
    }
    Some(format!("ISO 19157 (bias included): {}", parts.join("; ")))
}

/// The last lines: NSSDA's statement, the folded caveats, and where to find
/// what the terminal left out.
fn closing(o: &mut String, r: &ResultFile, verbose: bool, stock: &str) {
    let n = r.targets.len();
    let _ = writeln!(
        o,
        "NSSDA (legacy: ASPRS Ed. 2 no longer uses it): tested {} mm horizontal accuracy at 95 % confidence level{}",
        mm(r.asprs.nssda_horizontal_95),
        r.asprs
            .nssda_vertical_95
            .map(|v| format!(", {} mm vertical", mm(v)))
            .unwrap_or_default()
    );
    if let Some(line) = iso_line(r) {
        let _ = writeln!(o, "{line}");
    }
    if let Some(note) = stock_note(r, stock) {
        let _ = writeln!(o, "note: {note}");
    }
    let mut more = Vec::new();
    if !verbose {
        more.push(format!(
            "all {} pairs: pairs.csv with --out, or --verbose",
            r.relative.n
        ));
    }
    if n > PAPER_TABLES_UP_TO {
        more.push(
            "the paper's Tables I and II: --format markdown|latex|csv, or `mapgauge table`".into(),
        );
    }
    if !more.is_empty() {
        let _ = writeln!(o, "({})", more.join("; "));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn millimetres_never_negative_zero() {
        assert_eq!(mm(-0.00001), "0.0");
        assert_eq!(mm(0.01234), "12.3");
        assert_eq!(mm(-0.0021), "-2.1");
        assert_eq!(mm(f64::NAN), "–");
        assert_eq!(fixed(-0.0001, 3), "0.000");
        assert_eq!(fixed(-0.0006, 3), "-0.001");
    }

    #[test]
    fn twelve_targets_fit_on_a_screen() {
        use crate::Point;
        use crate::accuracy::{ScoreOptions, score};
        use crate::survey::{Estimate, EstimateStatus, Survey, SurveyFrame, SurveyTarget};
        let survey = Survey {
            targets: (0..12)
                .map(|i| SurveyTarget {
                    id: (i + 1).to_string(),
                    position: Point::new(10.0 * i as f64, (i * i) as f64, 0.0),
                    has_z: false,
                    role: None,
                    antenna_height: 0.0,
                    model: Default::default(),
                    size: None,
                    line: i as u64 + 2,
                })
                .collect(),
            frame: SurveyFrame::Local,
            origin: None,
            exchanged: None,
        };
        let est: Vec<Estimate> = survey
            .targets
            .iter()
            .enumerate()
            .map(|(i, t)| Estimate {
                id: t.id.clone(),
                status: if i == 4 {
                    EstimateStatus::NotFound {
                        reason: "no points".into(),
                    }
                } else {
                    EstimateStatus::Found(
                        t.position + nalgebra::Vector3::new(0.003 * i as f64, 0.0, 0.0),
                    )
                },
                has_z: false,
            })
            .collect();
        let acc = score(&survey, &est, &ScoreOptions::default()).unwrap();
        let r = ResultFile::from_accuracy(&acc, &survey);
        let t = render_text(&r, false);
        assert!(t.starts_with("Found 11 of 12 targets"), "{t}");
        assert!(t.lines().all(|l| l.chars().count() <= 200), "{t}");
        assert!(t.lines().count() < 60, "{} lines:\n{t}", t.lines().count());
        assert!(!t.contains("t1 & t2"), "no Table I for 12 targets");
        let v = render_text(&r, true);
        assert!(v.lines().count() > t.lines().count() + 50);
        // A target excluded as a gross error was found: counted, said apart.
        let mut r = r;
        r.targets[7].status = "excluded".into();
        let t = render_text(&r, false);
        assert!(
            t.starts_with("Found 11 of 12 targets (1 excluded as a gross error);"),
            "{t}"
        );
    }
}

/// A paper table's numbers in millimetres (its cells from the values behind
/// them, never parsed back from text).
fn in_mm(mut g: Grid) -> Grid {
    for (row, vals) in g.rows.iter_mut().zip(&g.values) {
        for (cell, v) in row.iter_mut().zip(vals) {
            if let Some(v) = v {
                *cell = mm(*v);
            }
        }
    }
    g
}

/// The caveats that every run with few targets or a 2D alignment carries,
/// in one line: how many checkpoints against what the standards ask, whether
/// they also fitted the alignment, and the vertical accuracy not reported.
fn stock_note(r: &ResultFile, vertical_text: &str) -> Option<String> {
    let a = &r.asprs;
    let mut parts = Vec::new();
    let n = a.n_checkpoints;
    let s = if n == 1 { "" } else { "s" };
    match n {
        0..20 => parts.push(format!(
            "{n} checkpoint{s}, where NSSDA asks for 20 and ASPRS (2023) for 30"
        )),
        20..30 => parts.push(format!("{n} checkpoints, where ASPRS (2023) asks for 30")),
        _ => {}
    }
    // `--align none` fits nothing: its checkpoints are not "used".
    if !a.independent && r.alignment.method != "none" {
        parts.push(
            "the checkpoints also fitted the alignment, so the accuracy is optimistic (role=check targets are held out of it)"
                .into(),
        );
    }
    if r.warnings.iter().any(|w| w == vertical_text) {
        parts.push(
            "vertical accuracy not reported (heights need an alignment that fits z: rigid2d+z, rigid3d)"
                .into(),
        );
    }
    (!parts.is_empty()).then(|| parts.join("; "))
}

#[cfg(test)]
mod note_tests {
    use super::*;

    /// The folded note's wording (issue 31): singular for one checkpoint, no
    /// "fitted" clause when nothing was fitted, a subject of its own when the
    /// count needs no mention, nothing when nothing is to be said.
    #[test]
    fn the_stock_note_reads_right_for_every_count() {
        let mut r = crate::report::html::tests::result(&["1", "2", "3", "4"]);
        r.warnings.clear();
        let v = "vertical";
        r.asprs.n_checkpoints = 1;
        r.asprs.independent = true;
        let n = stock_note(&r, v).unwrap();
        assert!(n.starts_with("1 checkpoint, where NSSDA"), "{n}");
        r.asprs.independent = false;
        r.alignment.method = "none".into();
        assert!(!stock_note(&r, v).unwrap().contains("fitted"));
        r.alignment.method = "rigid2d".into();
        r.asprs.n_checkpoints = 25;
        let n = stock_note(&r, v).unwrap();
        assert!(
            n.starts_with(
                "25 checkpoints, where ASPRS (2023) asks for 30; the checkpoints also fitted"
            ),
            "{n}"
        );
        r.asprs.n_checkpoints = 35;
        let n = stock_note(&r, v).unwrap();
        assert!(n.starts_with("the checkpoints also fitted"), "{n}");
        r.warnings.push(v.into());
        assert!(stock_note(&r, v).unwrap().ends_with("rigid2d+z, rigid3d)"));
        r.warnings.clear();
        r.asprs.independent = true;
        assert_eq!(stock_note(&r, v), None);
    }
}
