//! The grids: the paper's Tables I and II across runs, and the per-target,
//! per-pair and statistics tables of one run.

use super::Grid;
use super::numbers::mm;
use crate::record::ResultFile;

/// The paper's label for a target: `t3` for id `3`, the id itself otherwise.
pub(crate) fn target_label(id: &str) -> String {
    if !id.is_empty() && id.chars().all(|c| c.is_ascii_digit()) {
        format!("t{id}")
    } else {
        id.to_string()
    }
}

/// Four decimals, never "-0.0000" (a tiny negative rotation or z offset).
pub(crate) fn f4(v: f64) -> String {
    if v.is_finite() {
        let s = format!("{v:.4}");
        if s == "-0.0000" { "0.0000".into() } else { s }
    } else {
        "–".into()
    }
}

/// Target ids of several runs in one order: each run's survey order, a target
/// first seen in a later run placed right after its predecessor there. One run
/// keeps its survey order; runs with different target sets line up.
pub(crate) fn merged_ids(runs: &[(String, &ResultFile)]) -> Vec<String> {
    let mut ids: Vec<String> = Vec::new();
    for (_, r) in runs {
        let mut after: Option<usize> = None;
        for t in &r.targets {
            match ids.iter().position(|i| i == &t.id) {
                Some(p) => after = Some(p),
                None => {
                    let at = after.map(|p| p + 1).unwrap_or(0);
                    ids.insert(at, t.id.clone());
                    after = Some(at);
                }
            }
        }
    }
    ids
}

/// A missing cell: blank when the run has no such target (or pair) at all,
/// "–" when it has the target but could not score it (not found, excluded).
fn missing_cell(r: &ResultFile, ids: &[&str]) -> String {
    if ids.iter().all(|id| r.targets.iter().any(|t| t.id == *id)) {
        "–".into()
    } else {
        String::new()
    }
}

/// Table I (relative errors) over several runs: E_rel, σ_rel, then every pair
/// "t1 & t2" in target order, columns keyed by id so different target sets
/// line up. A pair the run lacks is blank; one it could not score is "–".
pub fn relative_grid(runs: &[(String, &ResultFile)]) -> Grid {
    let ids = merged_ids(runs);
    let mut keys: Vec<(String, String)> = Vec::new();
    for (i, a) in ids.iter().enumerate() {
        for b in &ids[i + 1..] {
            // Pairs no run could score would be columns of dashes: Table II
            // already shows which targets were not found.
            let present = runs.iter().any(|(_, r)| {
                r.relative
                    .pairs
                    .iter()
                    .any(|p| (&p.a == a && &p.b == b) || (&p.a == b && &p.b == a))
            });
            if present {
                keys.push((a.clone(), b.clone()));
            }
        }
    }
    let mut header = vec!["Run".to_string(), "E_rel".into(), "σ_rel".into()];
    header.extend(
        keys.iter()
            .map(|(a, b)| format!("{} & {}", target_label(a), target_label(b))),
    );
    let (rows, values) = runs
        .iter()
        .map(|(name, r)| {
            let mut row = vec![name.clone(), f4(r.relative.mean), f4(r.relative.std)];
            let mut vals = vec![None, Some(r.relative.mean), Some(r.relative.std)];
            for (a, b) in &keys {
                let v = r
                    .relative
                    .pairs
                    .iter()
                    .find(|p| (&p.a == a && &p.b == b) || (&p.a == b && &p.b == a))
                    .map(|p| p.error);
                row.push(v.map(f4).unwrap_or_else(|| missing_cell(r, &[a, b])));
                vals.push(v);
            }
            (row, vals)
        })
        .unzip();
    Grid {
        header,
        rows,
        bold: vec![1, 2],
        values,
    }
}

/// Table II (absolute errors) over several runs: E_abs, σ_abs, then each target.
/// A target the run lacks is blank; one it could not locate is "–".
pub fn absolute_grid(runs: &[(String, &ResultFile)]) -> Grid {
    let ids = merged_ids(runs);
    let mut header = vec!["Run".to_string(), "E_abs".into(), "σ_abs".into()];
    header.extend(ids.iter().map(|i| target_label(i)));
    let (rows, values) = runs
        .iter()
        .map(|(name, r)| {
            let mut row = vec![name.clone(), f4(r.absolute.mean), f4(r.absolute.std)];
            let mut vals = vec![None, Some(r.absolute.mean), Some(r.absolute.std)];
            for id in &ids {
                let v = r
                    .targets
                    .iter()
                    .find(|t| &t.id == id)
                    .and_then(|t| t.abs_error);
                row.push(v.map(f4).unwrap_or_else(|| missing_cell(r, &[id])));
                vals.push(v);
            }
            (row, vals)
        })
        .unzip();
    Grid {
        header,
        rows,
        bold: vec![1, 2],
        values,
    }
}

/// Per-target detail of one run.
pub(crate) fn targets_grid(r: &ResultFile) -> Grid {
    let header = [
        "id",
        "status",
        "reason",
        "survey_x",
        "survey_y",
        "survey_z",
        "map_x",
        "map_y",
        "map_z",
        "aligned_x",
        "aligned_y",
        "aligned_z",
        "abs_error",
        "loo_error",
        "sigma_x",
        "sigma_y",
        "sigma_z",
    ];
    let o = |v: Option<f64>| v.map(|v| format!("{v:.6}")).unwrap_or_default();
    let rows = r
        .targets
        .iter()
        .map(|t| {
            let mut row = vec![
                t.id.clone(),
                t.status.clone(),
                t.reason.clone().unwrap_or_default(),
            ];
            for p in [Some(t.survey), t.map, t.aligned] {
                row.push(o(p.map(|p| p.x)));
                row.push(o(p.map(|p| p.y)));
                row.push(o(p.and_then(|p| p.z)));
            }
            row.push(o(t.abs_error));
            row.push(o(t.loo_error));
            // The corner's 1-σ per axis (map frame), from its covariance.
            for i in 0..3 {
                row.push(o(t.map_covariance.map(|c| c[i][i].max(0.0).sqrt())));
            }
            row
        })
        .collect();
    Grid {
        header: header.iter().map(|s| s.to_string()).collect(),
        rows,
        bold: vec![],
        values: Vec::new(),
    }
}

/// Per-pair detail of one run.
pub(crate) fn pairs_grid(r: &ResultFile) -> Grid {
    let header = [
        "a",
        "b",
        "survey_distance",
        "map_distance",
        "error",
        "error_per_100m",
    ];
    let rows = r
        .relative
        .pairs
        .iter()
        .map(|p| {
            vec![
                p.a.clone(),
                p.b.clone(),
                format!("{:.6}", p.survey_distance),
                format!("{:.6}", p.map_distance),
                format!("{:.6}", p.error),
                p.error_per_100m
                    .map(|v| format!("{v:.6}"))
                    .unwrap_or_default(),
            ]
        })
        .collect();
    Grid {
        header: header.iter().map(|s| s.to_string()).collect(),
        rows,
        bold: vec![],
        values: Vec::new(),
    }
}

/// The statistics beyond the paper (alignment, RMSE, honest errors, ASPRS), one
/// `name, value, unit` row each; lengths in millimetres.
pub(crate) fn extra_grid(r: &ResultFile) -> Grid {
    let mut rows: Vec<Vec<String>> = Vec::new();
    let mut add = |k: &str, v: String, u: &str| rows.push(vec![k.to_string(), v, u.to_string()]);
    let a = &r.alignment;
    add("alignment", format!("{} (n={})", a.method, a.n_used), "");
    add("rotation (map→survey)", f4(a.rotation_deg), "deg");
    add(
        "translation",
        format!(
            "({}, {}, {})",
            f4(a.translation[0]),
            f4(a.translation[1]),
            f4(a.translation[2])
        ),
        "m",
    );
    if a.method.starts_with("similarity") {
        add("scale", format!("{:.1}", a.scale_ppm), "ppm");
    }
    add("abs RMSE", mm(r.absolute.rmse), "mm");
    add("abs median", mm(r.absolute.median), "mm");
    add("abs max", mm(r.absolute.max), "mm");
    add("rel max", mm(r.relative.max), "mm");
    if let Some(l) = &r.leave_one_out {
        add("leave-one-out mean", mm(l.summary.mean), "mm");
        add("leave-one-out RMSE", mm(l.summary.rmse), "mm");
        add("leave-one-out max", mm(l.summary.max), "mm");
    }
    if let Some(s) = &r.sigma_hat {
        add("sigma_hat", mm(s.value), &format!("mm (dof {})", s.dof));
    }
    if let Some(c) = &r.control_check {
        add(
            "check mean (fit on control)",
            mm(c.check.summary.mean),
            &format!("mm (n={})", c.check.summary.n),
        );
        add(
            "check RMSE (fit on control)",
            mm(c.check.summary.rmse),
            "mm",
        );
    }
    let s = &r.asprs;
    add(
        "ASPRS checkpoints",
        format!(
            "{}{}",
            s.n_checkpoints,
            if s.independent { "" } else { " (fit targets)" }
        ),
        "",
    );
    add(
        "bias x / y",
        format!("{} / {}", mm(s.x.bias), mm(s.y.bias)),
        "mm",
    );
    add(
        "std x / y (sample)",
        format!("{} / {}", mm(s.x.std), mm(s.y.std)),
        "mm",
    );
    add(
        "RMSE_x / RMSE_y",
        format!("{} / {}", mm(s.rmse_x), mm(s.rmse_y)),
        "mm",
    );
    add("RMSE_H", mm(s.rmse_h), "mm");
    if let Some(z) = &s.z {
        add(
            "bias z / std z",
            format!("{} / {}", mm(z.bias), mm(z.std)),
            "mm",
        );
    }
    if let Some(v) = s.rmse_v {
        add("RMSE_V", mm(v), "mm");
    }
    if let Some(v) = s.rmse_3d {
        add("RMSE_3D", mm(v), "mm");
    }
    Grid {
        header: vec!["statistic".into(), "value".into(), "unit".into()],
        rows,
        bold: vec![],
        values: Vec::new(),
    }
}

/// The ids both runs surveyed but at other positions (more than 1 mm apart
/// horizontally, or in another survey frame): two sites, or two surveys of
/// one, whose errors do not compare.
pub fn surveyed_elsewhere<'a>(a: &ResultFile, b: &'a ResultFile) -> Vec<&'a str> {
    b.targets
        .iter()
        .filter(|t| {
            a.targets.iter().any(|u| {
                u.id == t.id
                    && ((u.survey.x - t.survey.x).hypot(u.survey.y - t.survey.y) > 1e-3
                        || a.survey_frame != b.survey_frame)
            })
        })
        .map(|t| t.id.as_str())
        .collect()
}

/// Runs compared in one table should share a survey: a target id whose
/// surveyed position differs between two runs (by more than 1 mm) means they
/// were measured against different surveys, and the columns do not compare.
/// Returns one warning per run that differs from the first (`mapgauge
/// table` prints them on stderr; Python's `table()` issues them as warnings).
pub fn survey_mismatches(runs: &[(String, &ResultFile)]) -> Vec<String> {
    let mut out = Vec::new();
    let Some((first, r0)) = runs.first() else {
        return out;
    };
    for (name, r) in &runs[1..] {
        let differ = surveyed_elsewhere(r0, r);
        if !differ.is_empty() {
            out.push(format!(
                "runs `{first}` and `{name}` were scored against different surveys (targets {} differ): their columns do not compare",
                differ.join(", ")
            ));
            continue;
        }
        // Same positions but other targets: a different survey too, and the
        // runs' E_abs and E_rel are means over different targets.
        let only = |a: &ResultFile, b: &ResultFile| -> Vec<String> {
            a.targets
                .iter()
                .filter(|t| !b.targets.iter().any(|u| u.id == t.id))
                .map(|t| t.id.clone())
                .collect()
        };
        let (in_first, in_this) = (only(r0, r), only(r, r0));
        if !in_first.is_empty() || !in_this.is_empty() {
            let list = |v: &[String]| {
                if v.is_empty() {
                    "none".to_string()
                } else {
                    v.join(", ")
                }
            };
            out.push(format!(
                "runs `{first}` and `{name}` were scored against different surveys (only in `{first}`: {}; only in `{name}`: {}): their E_abs and E_rel are over different targets",
                list(&in_first),
                list(&in_this)
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{Pair, SCHEMA, TargetOut, Xyz};
    use crate::render::TableFormat;

    #[test]
    fn grid_escapes_per_format() {
        let g = Grid {
            header: vec!["id".into(), "E_rel".into()],
            rows: vec![vec!["a|b,c_\"d\"".into(), "0.1".into()]],
            bold: vec![1],
            values: Vec::new(),
        };
        let md = g.render(TableFormat::Markdown);
        assert!(md.contains("a\\|b") && md.contains("**0.1**"), "{md}");
        let tex = g.render(TableFormat::Latex);
        assert!(
            tex.contains("$E_{rel}$") && tex.contains("c\\_") && tex.contains("\\textbf{0.1}"),
            "{tex}"
        );
        assert!(tex.contains("\\toprule") && tex.contains("\\bottomrule"));
        let csv = g.render(TableFormat::Csv);
        assert_eq!(csv.lines().nth(1), Some("\"a|b,c_\"\"d\"\"\",0.1"), "{csv}");
        let txt = g.render(TableFormat::Text);
        assert_eq!(txt.lines().count(), 2);
        assert_eq!(target_label("3"), "t3");
        let html = g.render(TableFormat::Html);
        assert!(
            html.contains("<td>a|b,c_&quot;d&quot;</td><td><strong>0.1</strong></td>"),
            "{html}"
        );
        assert_eq!(target_label("T3"), "T3");
        assert_eq!(f4(-0.00001), "0.0000");
        assert_eq!(f4(-0.00006), "-0.0001");
    }

    fn run(ids: &[&str], found: &[&str]) -> ResultFile {
        let mut r: ResultFile = serde_json::from_str(&format!(
            r#"{{"schema":"{SCHEMA}","mapgauge_version":"0","alignment":{{"method":"rigid2d","rotation_deg":0,"translation":[0,0,0],"scale":1}},
            "targets":[],"absolute":{{"n":0,"mean":0.01,"std":0.0,"rmse":0,"median":0,"max":0}},
            "relative":{{"n":0,"mean":0.02,"std":0,"pairs":[]}},
            "asprs":{{"n_checkpoints":0,"independent":false,"x":{{"bias":0,"std":0,"rmse":0}},"y":{{"bias":0,"std":0,"rmse":0}},"z":null,
            "rmse_x":0,"rmse_y":0,"rmse_h":0,"rmse_v":null,"rmse_3d":null,"rmse_h_measured":0,"rmse_v_measured":null,
            "survey_sigma_h":null,"survey_sigma_v":null,"nssda_horizontal_95":0,"nssda_vertical_95":null,"nssda_lines":[],"warnings":[]}}}}"#
        ))
        .unwrap();
        for id in ids {
            let ok = found.contains(id);
            r.targets.push(TargetOut {
                id: id.to_string(),
                status: if ok { "ok" } else { "not_found" }.into(),
                reason: None,
                survey: Xyz {
                    x: 0.0,
                    y: 0.0,
                    z: None,
                },
                map: None,
                aligned: None,
                abs_error: ok.then_some(0.005),
                loo_error: None,
                role: None,
                map_covariance: None,
            });
        }
        for (i, a) in found.iter().enumerate() {
            for b in &found[i + 1..] {
                r.relative.pairs.push(Pair {
                    a: a.to_string(),
                    b: b.to_string(),
                    survey_distance: 1.0,
                    map_distance: 1.0,
                    error: 0.001,
                    error_per_100m: None,
                });
            }
        }
        r
    }

    #[test]
    fn runs_with_different_targets_line_up() {
        let a = run(&["1", "2", "4"], &["1", "2", "4"]);
        let b = run(&["1", "2", "3", "4"], &["1", "3", "4"]);
        let runs = [("A".to_string(), &a), ("B".to_string(), &b)];
        assert_eq!(merged_ids(&runs), vec!["1", "2", "3", "4"]);
        let g = absolute_grid(&runs);
        assert_eq!(
            g.header,
            vec!["Run", "E_abs", "σ_abs", "t1", "t2", "t3", "t4"]
        );
        // A lacks t3 entirely (blank); B has t2 but did not find it ("–").
        assert_eq!(g.rows[0][5], "");
        assert_eq!(g.rows[1][4], "–");
        assert_eq!(g.rows[1][5], "0.0050");
        let r = relative_grid(&runs);
        assert_eq!(
            r.header[3..],
            ["t1 & t2", "t1 & t3", "t1 & t4", "t2 & t4", "t3 & t4"]
        );
        assert_eq!(r.rows[0][4], "", "A has no t3");
        assert_eq!(r.rows[1][3], "–", "B has t2 but no pair with it");
        assert_eq!(r.header.len(), 8, "t2 & t3 was scored by no run");
        let tex = r.render(TableFormat::Latex);
        assert!(tex.contains("\\textbf{0.0200}") && tex.contains("\\toprule"));
    }
}
