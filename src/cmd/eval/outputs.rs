//! What `eval` writes under `--out`: the result files and crops of a run
//! that scored, or what a run that could not score leaves.

use super::*;

/// Writes result files (and crops) into `out`.
pub fn write_outputs(
    ev: &Evaluation,
    result: &ResultFile,
    out: &Path,
    save_crops: bool,
    inputs: &[&Path],
) -> Result<()> {
    render::refuse_overwriting_inputs(out, inputs)?;
    render::write_outputs(result, out)?;
    // An earlier failed run's reasons would read as this run's.
    let stale = out.join("failed.csv");
    if stale.exists() && !inputs.iter().any(|i| *i == stale) {
        std::fs::remove_file(&stale).map_err(|e| Error::io(&stale, e))?;
    }
    if save_crops {
        write_crops(&ev.targets, out, inputs)?;
    }
    Ok(())
}

/// Each located target's fitted plates and corner as a small PLY mesh: two
/// quadrilaterals (blue, orange) and the corner as a red vertex, in the
/// crops' frame, to open beside them in CloudCompare or MeshLab.
pub(super) fn fit_ply(t: &pipeline::TargetRun) -> Option<String> {
    let located = &t.outcome.as_ref().ok()?.located;
    let plates = located.plate_outlines(&t.tight)?;
    let c = located.corner;
    let mut o = String::from(
        "ply\nformat ascii 1.0\ncomment mapgauge: the fitted plates and their corner\nelement vertex 9\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n",
    );
    for (quad, rgb) in plates.iter().zip(["31 119 180", "230 126 34"]) {
        for p in quad {
            o.push_str(&format!("{:.5} {:.5} {:.5} {rgb}\n", p.x, p.y, p.z));
        }
    }
    o.push_str(&format!("{:.5} {:.5} {:.5} 220 30 30\n", c.x, c.y, c.z));
    o.push_str("3 0 1 2\n3 0 2 3\n3 4 5 6\n3 4 6 7\n");
    Some(o)
}

/// Each target's loose and tight crops as `out/crops/{loose,tight}/ID.ply`,
/// and each located one's fitted plates as `out/crops/fit/ID.ply`.
pub(super) fn write_crops(
    targets: &[pipeline::TargetRun],
    out: &Path,
    inputs: &[&Path],
) -> Result<()> {
    let dir = out.join("crops").join("fit");
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    for t in targets {
        let p = dir.join(format!("{}.ply", file_stem(&t.id)));
        refuse_overwrite(&p, inputs)?;
        match fit_ply(t) {
            Some(text) => mapgauge::record::write_atomic(&p, text.as_bytes())?,
            // An earlier run's plates for a target not located now would
            // read as this run's.
            None if p.exists() => std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?,
            None => {}
        }
    }
    for kind in ["loose", "tight"] {
        let dir = out.join("crops").join(kind);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        for t in targets {
            let pts = if kind == "loose" { &t.loose } else { &t.tight };
            if pts.is_empty() {
                continue;
            }
            let p = dir.join(format!("{}.ply", file_stem(&t.id)));
            refuse_overwrite(&p, inputs)?;
            cloud::write(&p, OutFormat::Ply, pts)?;
        }
    }
    Ok(())
}

/// What a run that could not score leaves under `--out`: `failed.csv` with
/// what each surveyed place showed (the corner located there, or why none
/// was), the page `page` drawing each place's crops, and with `crops` the
/// crops themselves: when a user needs them most.
pub(super) fn save_failure(
    f: &pipeline::Failed,
    out: &Path,
    crops: bool,
    page: Option<&Path>,
    cfg: &Config,
    inputs: &[&Path],
) -> Result<()> {
    let targets = &f.targets;
    crate::cmd::check_out_dir(out)?;
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    // An earlier run's result beside this run's failure would read as this
    // run's: said, not deleted (it is the user's).
    if out.join("result.json").exists() {
        errln!(
            "warning: {} (and its targets.csv, pairs.csv) is from an earlier run: this run did not score",
            out.join("result.json").display()
        );
    }
    if crops {
        write_crops(targets, out, inputs)?;
    }
    let rows = targets
        .iter()
        .map(|t| {
            // In the map's own frame, as result.json's corner_in_map.
            let l = &f.levelling;
            let c = t
                .corner()
                .map(|c| if l.is_identity() { c } else { l.invert(&c) });
            let at = |k: usize| c.map_or(String::new(), |c| format!("{:.4}", c[k]));
            let (status, reason) = report::place_status(&t.outcome);
            let stage = t
                .outcome
                .as_ref()
                .err()
                .map_or("", |e| e.stage())
                .to_string();
            vec![
                t.id.clone(),
                status.into(),
                at(0),
                at(1),
                at(2),
                t.loose.len().to_string(),
                t.tight.len().to_string(),
                stage,
                reason,
            ]
        })
        .collect();
    let g = render::Grid {
        header: [
            "id",
            "status",
            "x_map",
            "y_map",
            "z_map",
            "loose_points",
            "tight_points",
            "stage",
            "reason",
        ]
        .map(String::from)
        .to_vec(),
        rows,
        bold: Vec::new(),
        values: Vec::new(),
    };
    let path = out.join("failed.csv");
    refuse_overwrite(&path, inputs)?;
    mapgauge::record::write_atomic(&path, g.render(TableFormat::Csv).as_bytes())?;
    if let Some(p) = page {
        refuse_overwrite(p, inputs)?;
        let prov = report::Provenance::new(Some(cfg.locate.seed), Some(cfg.to_toml()));
        let map = inputs
            .first()
            .map(|m| m.display().to_string())
            .unwrap_or_default();
        report::write_failure(p, &map, f, &prov)?;
    }
    Ok(())
}
