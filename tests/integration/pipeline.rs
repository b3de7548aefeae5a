//! The library's entry point called directly (not through the CLI): a map
//! file and the same points in memory give the same evaluation, and the id →
//! file-name rule is the same for saving crops and reading them back.

use mapgauge::cloud::{MapSource, OutFormat};
use mapgauge::pipeline::{self, Config};
use mapgauge::record::{EvalInfo, ResultFile};
use mapgauge::survey::{SurveyOptions, read_survey};
use mapgauge::synth::{self, SynthParams};
use std::process::Command;

fn params() -> SynthParams {
    SynthParams {
        seed: 4,
        ..SynthParams::default()
    }
}

#[test]
fn file_and_memory_give_the_same_evaluation() {
    let dir = tempfile::tempdir().unwrap();
    let (files, _, _) = synth::write_scene(dir.path(), &params(), OutFormat::Pcd).unwrap();
    let survey = read_survey(&files.survey, &SurveyOptions::default()).unwrap();
    let mut map = Vec::new();
    synth::generate(&params(), &mut |p| {
        map.extend_from_slice(p);
        Ok(())
    })
    .unwrap();
    let cfg = Config::default();
    let from_file = pipeline::run(MapSource::File(&files.map), &survey, &cfg, |_, _| {}).unwrap();
    let in_memory = pipeline::run(MapSource::Points(&map), &survey, &cfg, |_, _| {}).unwrap();
    assert_eq!(from_file.accuracy, in_memory.accuracy);
    assert!(from_file.targets.iter().all(|t| t.outcome.is_ok()));
    let a = ResultFile::from_accuracy(&from_file.accuracy, &survey).to_json();
    let b = ResultFile::from_accuracy(&in_memory.accuracy, &survey).to_json();
    assert_eq!(a, b);
    // The per-target record matches too; only the map's name and size differ.
    let (ia, ib) = (
        EvalInfo::from_evaluation(&from_file, "s"),
        EvalInfo::from_evaluation(&in_memory, "s"),
    );
    assert_eq!(ia.targets, ib.targets);
    assert_eq!(
        (ia.map_points, ib.map_points),
        (map.len() as u64, map.len() as u64)
    );
    assert_eq!(ib.map, "<memory>");
    assert_eq!(ib.map_bytes, 0);
}

#[test]
fn non_finite_points_in_memory_are_skipped_and_counted() {
    let mut map = Vec::new();
    let truth = synth::generate(&params(), &mut |p| {
        map.extend_from_slice(p);
        Ok(())
    })
    .unwrap();
    let clean = pipeline::run(
        MapSource::Points(&map),
        &truth.survey(),
        &Config::default(),
        |_, _| {},
    )
    .unwrap();
    map.push(mapgauge::Point::new(f64::NAN, 0.0, 0.0));
    map.insert(0, mapgauge::Point::new(1.0, f64::INFINITY, 0.0));
    let dirty = pipeline::run(
        MapSource::Points(&map),
        &truth.survey(),
        &Config::default(),
        |_, _| {},
    )
    .unwrap();
    assert_eq!(dirty.map.skipped_nonfinite, 2);
    assert_eq!(clean.accuracy, dirty.accuracy);
}

/// Ids with characters a file name cannot hold: `--save-crops` writes the
/// tight crops under the safe stem, and `--crops` finds them there.
#[test]
fn saved_crops_are_found_by_crops_whatever_the_id() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (files, _, _) = synth::write_scene(&d.join("scene"), &params(), OutFormat::Pcd).unwrap();
    let text = std::fs::read_to_string(&files.survey).unwrap();
    let ids = ["T 1/a", "t*2", "..", "ü3", "5:x"];
    let mut renamed = String::new();
    for (k, line) in text.lines().enumerate() {
        if k == 0 {
            renamed += line;
        } else {
            let rest = line.split_once(',').unwrap().1;
            renamed += &format!("\"{}\",{rest}", ids[k - 1]);
        }
        renamed.push('\n');
    }
    let survey = d.join("odd.csv");
    std::fs::write(&survey, renamed).unwrap();
    let bin = crate::util::BIN;
    let out = d.join("eval");
    let run = |args: &[&std::ffi::OsStr]| {
        let o = Command::new(bin).args(args).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let first = run(&[
        "eval".as_ref(),
        "--map".as_ref(),
        files.map.as_os_str(),
        "--survey".as_ref(),
        survey.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--save-crops".as_ref(),
        "--no-report".as_ref(),
        "--format".as_ref(),
        "json".as_ref(),
    ]);
    let tight = out.join("crops/tight");
    let again = run(&[
        "eval".as_ref(),
        "--map".as_ref(),
        files.map.as_os_str(),
        "--survey".as_ref(),
        survey.as_os_str(),
        "--crops".as_ref(),
        tight.as_os_str(),
        "--format".as_ref(),
        "json".as_ref(),
    ]);
    for (a, b) in first["targets"]
        .as_array()
        .unwrap()
        .iter()
        .zip(again["targets"].as_array().unwrap())
    {
        assert_eq!(a["status"], "ok", "{a}");
        assert_eq!(
            b["status"], "ok",
            "{} via --crops: {}",
            b["id"], b["reason"]
        );
    }
    assert!(tight.join("T_1_a.ply").is_file() && tight.join("_...ply").is_file());
}

/// A survey blunder on one target: flagged as a gross error; with
/// `exclude_outliers` the fit is redone without it, and it stays in the
/// result as excluded with the reason.
#[test]
fn a_gross_error_is_flagged_and_excluded_on_request() {
    let dir = tempfile::tempdir().unwrap();
    let p = SynthParams {
        targets: 8,
        points: 3_000_000,
        ..params()
    };
    let (files, _, _) = synth::write_scene(dir.path(), &p, OutFormat::Pcd).unwrap();
    let mut survey = read_survey(&files.survey, &SurveyOptions::default()).unwrap();
    survey.targets[2].position.x += 0.3;
    let mut cfg = Config::default();
    let flagged = pipeline::run(MapSource::File(&files.map), &survey, &cfg, |_, _| {}).unwrap();
    let gross: Vec<&str> = flagged
        .accuracy
        .warnings
        .iter()
        .filter_map(|w| match w {
            mapgauge::accuracy::Warning::GrossError { id, .. } => Some(id.as_str()),
            _ => None,
        })
        .collect();
    assert_eq!(gross, ["3"]);
    assert_eq!(flagged.accuracy.absolute.n, 8);
    cfg.metrics.exclude_outliers = true;
    let ev = pipeline::run(MapSource::File(&files.map), &survey, &cfg, |_, _| {}).unwrap();
    assert_eq!(ev.accuracy.absolute.n, 7);
    assert!(matches!(
        &ev.accuracy.targets[2].status,
        mapgauge::accuracy::Status::Excluded(why) if why.contains("gross error")
    ));
    assert_eq!(
        ev.warnings,
        [pipeline::Warning::OutliersExcluded(vec!["3".into()])]
    );
    assert!(ev.accuracy.absolute.mean < 0.5 * flagged.accuracy.absolute.mean);
}

/// Issue 29: `run_reporting` names every pass its progress belongs to, in
/// the order `eval.reads` lists them, and each pass over a plain file ends
/// with its whole size.
#[test]
fn progress_names_each_pass_as_reads_lists_them() {
    let dir = tempfile::tempdir().unwrap();
    let (files, _, _) = synth::write_scene(dir.path(), &params(), OutFormat::Pcd).unwrap();
    let survey = read_survey(&files.survey, &SurveyOptions::default()).unwrap();
    let mut seen: Vec<(&str, u64, u64)> = Vec::new();
    let ev = pipeline::run_reporting(
        MapSource::File(&files.map),
        &survey,
        None,
        &Config::default(),
        |p| match seen.last_mut() {
            Some(last) if last.0 == p.pass && p.done >= last.1 => last.1 = p.done,
            _ => seen.push((p.pass, p.done, p.total)),
        },
    )
    .unwrap();
    let size = std::fs::metadata(&files.map).unwrap().len();
    let passes: Vec<&str> = seen.iter().map(|s| s.0).collect();
    let reads: Vec<&str> = ev.reads.iter().map(|r| r.pass.as_str()).collect();
    assert_eq!(passes, ["ground", "crops"], "{seen:?}");
    assert_eq!(reads, passes);
    for (pass, done, total) in &seen {
        assert_eq!((*done, *total), (size, size), "{pass}");
    }
    for r in &ev.reads {
        assert_eq!((r.points, r.bytes), (ev.map.points, size), "{r:?}");
    }
}

/// Issue 29: a target whose loose crop is far denser than the others'
/// (seed 1's first target, 147 k points beside a car, against 19–62 k)
/// waits for them and is searched only where their fit puts it. Found there,
/// it is the corner the whole search finds; with the others' fit 2.66 m off
/// for it, nothing is there, and the whole radius about its first guess is
/// searched, as before: the object is found and set aside as far from the
/// others.
#[test]
fn a_dense_target_is_searched_where_the_others_put_it() {
    use mapgauge::pipeline::{Failure, Pass};
    let dir = tempfile::tempdir().unwrap();
    let p = SynthParams {
        seed: 1,
        points: 6_000_000,
        ..SynthParams::default()
    };
    let (files, truth, _) = synth::write_scene(dir.path(), &p, OutFormat::Pcd).unwrap();
    let mut survey = read_survey(&files.survey, &SurveyOptions::default()).unwrap();
    let cfg = Config::default();
    let ev = pipeline::run(MapSource::File(&files.map), &survey, &cfg, |_, _| {}).unwrap();
    // The first guess is the survey's own frame, unlevelled.
    assert!(ev.frame.levelling.is_identity());
    let guess = |i: usize| survey.targets[i].reference();
    assert!((ev.targets[1].expected - guess(1)).xy().norm() < 1e-9);
    // Target 1's crop is the one far denser than the others'.
    let sizes: Vec<usize> = ev.targets.iter().map(|t| t.loose.len()).collect();
    let mut sorted = sizes.clone();
    sorted.sort_unstable();
    assert!(sizes[0] > 100_000 && sizes[0] > 2 * sorted[2], "{sizes:?}");
    assert!(ev.targets.iter().all(|t| t.pass == Pass::First));
    // Searched within 0.3 m + 5 % of the 30.7 m to target 2, plus a plate;
    // the others over the whole radius.
    let radii: Vec<f64> = ev.targets.iter().map(|t| t.search_radius).collect();
    assert!(
        (radii[0] - (0.3 + 0.05 * 30.7 + 0.6)).abs() < 0.01,
        "{radii:?}"
    );
    assert!(radii[1..].iter().all(|&r| r == cfg.tight.search_radius));
    let waited: Vec<bool> = ev.targets.iter().map(|t| t.waited).collect();
    assert_eq!(waited, [true, false, false, false, false]);
    let t = &ev.targets[0];
    let at = t.corner().expect("the dense target is located");
    let first_guess = guess(0);
    assert!(
        (t.expected - first_guess).xy().norm() > 1.5,
        "searched at the fit's place"
    );
    assert!((at - t.expected).xy().norm() < 0.1);
    let true_map = truth.targets[0].map;
    assert!((at.x - true_map[0]).hypot(at.y - true_map[1]) < 0.01);
    // The whole search, at the survey's place, finds the same corner.
    let whole = mapgauge::crop::tight_crop(&t.loose, &first_guess, &cfg.tight).unwrap();
    let up = nalgebra::Vector3::from(whole.up);
    let alone = pipeline::locate_with(&whole.points, &[up], &cfg).unwrap();
    // (Its height is the paper's mean; the run's is moved to the middle of
    // the plates seen, along the plates' line.)
    assert!((alone.located.corner - at).xy().norm() < 3e-4);

    // The report says where it was searched.
    let out = dir.path().join("out");
    crate::util::stdout_ok(
        crate::util::bin()
            .args(["eval", "--map"])
            .arg(&files.map)
            .arg("--survey")
            .arg(&files.survey)
            .arg("--out")
            .arg(&out),
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert_eq!(
        html.matches("searched within 2.44 m of where the other targets place it")
            .count(),
        1
    );

    // The other four surveyed 2.66 m off together (each still within its
    // search, its first guess nearer its object): their fit puts target 1
    // 2.66 m from its corner, beyond the narrowed disc (2.44 m), which still
    // lies inside its loose crop (5 m about the first guess), so the
    // narrowed search is tried.
    let dense = sizes[0];
    let fits_place = at - nalgebra::Vector3::new(2.2, -1.5, 0.0);
    assert!((fits_place - first_guess).xy().norm() + radii[0] < 4.9);
    for t in &mut survey.targets[1..] {
        t.position.x += 2.2;
        t.position.y -= 1.5;
    }
    // Without the second pass, which would also search the whole radius
    // about the fit's place.
    let mut cfg = cfg;
    cfg.frame.second_pass = false;
    let ev = pipeline::run(MapSource::File(&files.map), &survey, &cfg, |_, _| {}).unwrap();
    // It still waited: its crop (the same) is still over twice the median.
    assert!(ev.targets[1..].iter().all(|t| t.pass == Pass::First));
    let mut sizes: Vec<usize> = ev.targets[1..].iter().map(|t| t.loose.len()).collect();
    sizes.push(dense);
    sizes.sort_unstable();
    assert!(dense > 2 * sizes[2], "{sizes:?}");
    // Where the object was found says the whole radius was searched: the
    // narrowed search alone would have left no object to name.
    assert!(!ev.targets[0].waited);
    match &ev.targets[0].outcome {
        Err(Failure::FarFromOthers { at: there, .. } | Failure::OffLayout { at: there, .. }) => {
            assert!((there - at).xy().norm() < 0.01, "{there:?} against {at:?}")
        }
        other => panic!("{other:?}"),
    }
}
