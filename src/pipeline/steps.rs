//! The evaluation as its steps, in the order they run (issue 32): the
//! ground pass, the first levelling, the first guess at the map's frame, the first pass at it,
//! detection instead when that found too few, the targets' plumb lines,
//! the search again, the objects checked against the target and each
//! other, the score. [`evaluate`] is that list; each step is a method of
//! [`Run`], which holds the inputs and what the passes add to as they go.

use super::frame::{self, FrameHow};
use super::target::{self, Pass, TargetRun};
use super::{Config, not_there, other_plate_size, vertical, waves};
use super::{
    Evaluation, Failed, FrameFound, MapStats, Progress, Warning, against_survey, check_found,
    check_map, config, expected_positions, first_levelling, more_ups, others_than, passes,
    read_crops, refine_vertical, score, too_few_found,
};
use crate::accuracy::{self, ScoreOptions};
use crate::cloud::{MapSource, PassRead, RigidMotion};
use crate::crop::{LooseParams, Shape};
use crate::detect::Detection;
use crate::frame::{MapGround, MapToSurvey};
use crate::survey::Survey;
use crate::{Error, Point, Result};
use rayon::prelude::*;
use std::cell::Cell;
use std::path::Path;

/// Evaluates `survey`'s targets in the map: the steps in order.
#[allow(clippy::result_large_err)]
pub(super) fn evaluate(
    source: MapSource,
    survey: &Survey,
    crops_dir: Option<&Path>,
    cfg: &Config,
    report: impl FnMut(Progress),
) -> std::result::Result<Evaluation, Failed> {
    cfg.validate()?;
    if survey.targets.is_empty() {
        return Err(Error::Input("the survey has no targets".into()).into());
    }
    let mut run = Run::new(source, survey, crops_dir, cfg, report);
    let (ground, mut map) = run.ground_pass()?;
    // `--align none` scores the map in the survey frame as it is: nothing
    // may turn it.
    let no_turn = cfg.metrics.align == crate::align::AlignMethod::None;
    let (mut motion, turning) = first_levelling(source, &ground, no_turn, cfg, &mut run.warnings);
    run.turning = turning;
    let mut guess = run.first_guess(&ground, &motion)?;
    let first = run.first_pass_at(&ground, &motion);
    let mut targets = run.first_pass(&first, &guess, &mut map)?;
    if run.falls_back_to_detection(&guess, &targets) {
        run.detect_instead(&first, &mut guess, &mut targets, &mut map)?;
    }
    let lines = vertical::plumb_line_count(&targets.found);
    let (mut plumb, mut said) = run.level_by_plumb_lines(&mut targets, &mut motion);
    let mut opts = score_options(cfg, &motion, plumb.as_ref());
    let far = run.search_again(&mut targets, &opts, &motion, &ground)?;
    // The plumb lines again when the later passes located more targets and
    // the first look did not turn the frame: a sparse map's first pass may
    // find three targets, whose lines alone cannot show a lean that five
    // lines and their surveyed heights do. What the first look said is
    // said again by the second.
    if plumb.as_ref().is_none_or(|p| !p.applied)
        && vertical::plumb_line_count(&targets.found) > lines
    {
        (plumb, said) = run.level_by_plumb_lines(&mut targets, &mut motion);
        opts = score_options(cfg, &motion, plumb.as_ref());
        if plumb.as_ref().is_some_and(|p| p.applied) {
            // Ls that failed the vertical gate in the frame before the turn.
            super::passes::common_vertical(&mut targets.found, cfg);
        }
    }
    run.warnings.extend(said);
    let doubling = check_found(&mut targets.found, survey, &opts, &far, &mut run.warnings);
    let frame = FrameFound {
        how: guess.how,
        init: guess.init,
        dz: guess.dz,
        ground: None,
        levelling: motion,
        plumb,
        unmatched: guess.unmatched,
    };
    run.score(targets.found, map, ground, frame, &opts, doubling)
}

/// One evaluation's inputs, and what its steps add to as they go.
struct Run<'a, R> {
    source: MapSource<'a>,
    survey: &'a Survey,
    /// Hand-made tight crops, when given (the paper's manual workflow).
    crops_dir: Option<&'a Path>,
    cfg: &'a Config,
    crop_params: LooseParams,
    /// The map's bytes (0 for points in memory): each pass's progress total.
    total: u64,
    /// What may turn the frame, once the map's header was read.
    turning: vertical::Turning,
    warnings: Vec<Warning>,
    /// What each pass read, in order (result.json `eval.reads`).
    reads: Vec<PassRead>,
    /// The pass the bytes belong to: set before each pass, read by the one
    /// byte callback every reader is given.
    pass: Cell<&'static str>,
    report: R,
}

/// The map's frame as far as it is known: how it was found, the guess of
/// map → survey and the vertical offset, and the detections no surveyed
/// target took.
struct Guess {
    how: FrameHow,
    init: MapToSurvey,
    dz: f64,
    unmatched: Vec<Detection>,
}

impl Guess {
    fn of((how, init, dz, unmatched): (FrameHow, MapToSurvey, f64, Vec<Detection>)) -> Self {
        Guess {
            how,
            init,
            dz,
            unmatched,
        }
    }
}

/// The targets as the passes leave them: where each was expected in the
/// map, and what was found there (survey order).
struct Targets {
    expected: Vec<Point>,
    found: Vec<TargetRun>,
}

impl<'a, R: FnMut(Progress)> Run<'a, R> {
    fn new(
        source: MapSource<'a>,
        survey: &'a Survey,
        crops_dir: Option<&'a Path>,
        cfg: &'a Config,
        report: R,
    ) -> Self {
        let mut warnings = Vec::new();
        let crop_params = crop_shape(cfg, survey, &mut warnings);
        let total = match source {
            MapSource::File(p) => crate::cloud::map_bytes(p),
            MapSource::Points(_) => 0,
        };
        Run {
            source,
            survey,
            crops_dir,
            cfg,
            crop_params,
            total,
            turning: vertical::Turning::Free,
            warnings,
            reads: Vec::new(),
            pass: Cell::new("ground"),
            report,
        }
    }

    /// The byte callback of the pass now reading, the pass itself (a step
    /// that runs more than one pass sets it), and the list of reads.
    fn io(
        &mut self,
    ) -> (
        impl FnMut(u64, u64) + '_,
        &Cell<&'static str>,
        &mut Vec<PassRead>,
    ) {
        let (pass, report) = (&self.pass, &mut self.report);
        let progress = move |done: u64, total: u64| {
            report(Progress {
                pass: pass.get(),
                done,
                total,
            })
        };
        (progress, &self.pass, &mut self.reads)
    }

    /// The ground pass: the map's vertical (and, for detection, its
    /// ground), and the map's counts as far as it saw them.
    fn ground_pass(&mut self) -> Result<(MapGround, MapStats)> {
        let (source, survey, cfg, total) = (self.source, self.survey, self.cfg, self.total);
        let needs_points = self.crops_dir.is_none();
        let mut warnings = std::mem::take(&mut self.warnings);
        let got = {
            let (mut progress, _, reads) = self.io();
            let got = ground_pass(
                source,
                survey,
                needs_points,
                cfg,
                total,
                &mut progress,
                &mut warnings,
            );
            if let Ok((ground, _)) = &got {
                reads.push(ground.pass_read.clone());
            }
            got
        };
        self.warnings = warnings;
        got
    }

    /// The first guess at the map's frame: `--init`, hints, the survey's
    /// own frame, or (`--frame detect`) map-wide detection.
    fn first_guess(&mut self, ground: &MapGround, motion: &RigidMotion) -> Result<Guess> {
        let (how, init, dz) = frame::given(self.survey, self.cfg, motion)?;
        if self.cfg.frame.mode != config::FrameMode::Detect {
            return Ok(Guess {
                how,
                init,
                dz,
                unmatched: Vec::new(),
            });
        }
        self.pass.set("detection");
        self.detect(ground, motion)
            .map(Guess::of)
            .map_err(frame::NoFrame::into_error)
    }

    /// Map-wide detection of the targets, matched to the survey.
    fn detect(
        &mut self,
        ground: &MapGround,
        motion: &RigidMotion,
    ) -> std::result::Result<(FrameHow, MapToSurvey, f64, Vec<Detection>), frame::NoFrame> {
        let (source, survey, cfg, total) = (self.source, self.survey, self.cfg, self.total);
        let (mut progress, _, reads) = self.io();
        frame::detect_and_match(
            source,
            survey,
            ground,
            motion,
            cfg,
            total,
            &mut progress,
            reads,
        )
    }

    /// What the first pass needs besides the frame guess (auto mode may
    /// run it again at detection's frame).
    fn first_pass_at<'b>(&self, ground: &'b MapGround, motion: &'b RigidMotion) -> FirstPass<'b>
    where
        'a: 'b,
    {
        FirstPass {
            source: self.source,
            survey: self.survey,
            crop_params: self.crop_params,
            motion,
            ground,
            ground_up: ground.level.as_ref().map(|l| l.up),
            crops_dir: self.crops_dir,
            cfg: self.cfg,
        }
    }

    /// The crops at the guess, each target located.
    fn first_pass(
        &mut self,
        first: &FirstPass,
        guess: &Guess,
        map: &mut MapStats,
    ) -> Result<Targets> {
        self.pass.set("crops");
        let (mut progress, _, reads) = self.io();
        let (expected, found) = first.run(
            &guess.init,
            guess.dz,
            own(&guess.how),
            map,
            &mut progress,
            reads,
        )?;
        Ok(Targets { expected, found })
    }

    /// In auto mode, a guess (not detection's) whose first pass found too
    /// few of three or more targets gives way to detection.
    fn falls_back_to_detection(&self, guess: &Guess, targets: &Targets) -> bool {
        self.cfg.frame.mode == config::FrameMode::Auto
            && !matches!(guess.how, FrameHow::Detected { .. })
            && self.crops_dir.is_none()
            && self.survey.targets.len() >= 3
            && !frame::targets_there(&targets.found)
    }

    /// Detection instead of the guess: the first pass again at its frame,
    /// or the guess's targets kept (and why), or the run's failure.
    #[allow(clippy::result_large_err)]
    fn detect_instead(
        &mut self,
        first: &FirstPass,
        guess: &mut Guess,
        targets: &mut Targets,
        map: &mut MapStats,
    ) -> std::result::Result<(), Failed> {
        self.pass.set("detection");
        let detected = self.detect(first.ground, first.motion);
        let found = std::mem::take(&mut targets.found);
        match first.instead(detected, &guess.how, found, &map.name, &mut self.warnings)? {
            Instead::Detected(d) => {
                *guess = Guess::of(d);
                *targets = self.first_pass(first, guess, map)?;
            }
            Instead::Kept(f) => targets.found = f,
        }
        Ok(())
    }

    /// The targets' plumb lines (and surveyed heights) refine the vertical;
    /// with what the look has to say (kept apart: a second look replaces it).
    fn level_by_plumb_lines(
        &mut self,
        targets: &mut Targets,
        motion: &mut RigidMotion,
    ) -> (Option<vertical::Plumb>, Vec<Warning>) {
        let mut said = Vec::new();
        let plumb = refine_vertical(
            &mut targets.found,
            &mut targets.expected,
            motion,
            self.survey,
            self.turning,
            self.cfg,
            &mut said,
        );
        (plumb, said)
    }

    /// Objects far from where the others put them are looked for again
    /// there (hand crops: the common vertical only).
    fn search_again(
        &mut self,
        targets: &mut Targets,
        opts: &ScoreOptions,
        motion: &RigidMotion,
        ground: &MapGround,
    ) -> Result<Vec<super::layout::Far>> {
        if self.crops_dir.is_some() {
            passes::common_vertical(&mut targets.found, self.cfg);
            return Ok(Vec::new());
        }
        let crop_params = self.crop_params;
        let search = passes::Search {
            source: self.source,
            survey: self.survey,
            expected: &targets.expected,
            crop_params: &crop_params,
            cfg: self.cfg,
            opts,
            motion,
            ground,
        };
        let (mut progress, pass, reads) = self.io();
        search.again(&mut targets.found, pass, &mut progress, reads)
    }

    /// The score, when enough targets were found to align; else the run's
    /// failure with what each surveyed place showed.
    #[allow(clippy::result_large_err)]
    fn score(
        self,
        found: Vec<TargetRun>,
        mut map: MapStats,
        ground: MapGround,
        mut frame: FrameFound,
        opts: &ScoreOptions,
        doubling: Option<crate::locate::DoublingLimit>,
    ) -> std::result::Result<Evaluation, Failed> {
        let (survey, cfg, mut warnings) = (self.survey, self.cfg, self.warnings);
        let n_found = found.iter().filter(|r| r.outcome.is_ok()).count();
        let need = cfg.metrics.align.min_points().max(2);
        if n_found < need {
            return Err(Failed {
                error: too_few_found(&found, survey, n_found, need, cfg, &map.name, &frame.how),
                targets: found,
                levelling: frame.levelling,
            });
        }
        let mut accuracy = score(&found, survey, opts, cfg, &mut warnings)?;
        let mut found = found;
        row_hints(&mut found, survey, &mut accuracy);
        // No pass may have read the whole map (a sampled ground, crops of
        // some tiles): the most any pass read is what is known of it.
        map.points = self
            .reads
            .iter()
            .map(|r| r.points)
            .fold(map.points, u64::max);
        let footprint = ground.footprint(&frame.levelling);
        frame.ground = ground.level;
        Ok(Evaluation {
            accuracy,
            targets: found,
            map,
            warnings,
            reads: self.reads,
            footprint,
            doubling,
            frame,
            config: cfg.clone(),
        })
    }
}

/// Each object found far from where the others place it, and nothing
/// there, gets where the final fit puts it in the survey's frame against
/// its row (in its reason too): a row mistyped by metres then names its own
/// mend.
fn row_hints(found: &mut [TargetRun], survey: &Survey, accuracy: &mut accuracy::Accuracy) {
    for r in found.iter_mut() {
        let target::TargetRun { id, outcome, .. } = r;
        let Err(failure) = outcome else {
            continue;
        };
        let target::Failure::FarFromOthers {
            at,
            searched: true,
            row,
            ..
        } = failure
        else {
            continue;
        };
        let Some(t) = survey.targets.iter().find(|t| &t.id == id) else {
            continue;
        };
        let p = accuracy.fit.alignment.apply(at);
        if !p.iter().all(|v| v.is_finite()) {
            continue;
        }
        *row = Some(target::RowHint {
            object: [p.x, p.y],
            row: [t.position.x, t.position.y],
            line: t.line,
            geodetic: survey.frame != crate::survey::SurveyFrame::Local,
        });
        let reason = failure.to_string();
        for s in accuracy.targets.iter_mut().filter(|s| &s.id == id) {
            if let accuracy::Status::NotFound(r) = &mut s.status {
                *r = reason.clone();
            }
        }
    }
}

/// The configured crop, a cylinder when a sphere was asked for but the
/// survey has no heights (and a warning says so).
fn crop_shape(cfg: &Config, survey: &Survey, warnings: &mut Vec<Warning>) -> LooseParams {
    let mut crop_params = cfg.crop;
    if crop_params.shape == Shape::Sphere && !survey.has_z() {
        warnings.push(Warning::SphereWithoutHeights);
        crop_params.shape = Shape::Cylinder;
    }
    crop_params
}

/// The ground pass: the map's vertical (and, for detection, its ground),
/// and the map's counts as far as it saw them (the crops' pass, when it
/// reads the whole map, gives every point's). Refused when the map is no
/// map to measure (`check_map`; `needs_points`: no hand crops given).
fn ground_pass(
    source: MapSource,
    survey: &Survey,
    needs_points: bool,
    cfg: &Config,
    total: u64,
    progress: &mut impl FnMut(u64, u64),
    warnings: &mut Vec<Warning>,
) -> Result<(crate::frame::MapGround, MapStats)> {
    if let MapSource::File(p) = source {
        crate::cloud::refuse_non_metric(p)?;
    }
    let sample = (cfg.frame.ground_sample > 0).then_some(cfg.frame.ground_sample);
    let ground = crate::frame::ground_level(source, None, sample, |b| progress(b, total))
        .map_err(|e| against_survey(e, survey))?;
    let map = MapStats {
        name: source.name(),
        bytes: total,
        points: ground.read.points,
        skipped_nonfinite: ground.read.skipped_nonfinite,
    };
    check_map(&map, &ground, needs_points, warnings)?;
    if needs_points {
        super::diagnosis::too_small_for_survey(&map, &ground, survey)?;
    }
    Ok((ground, map))
}

/// How the errors are scored: the configured alignment and dimension, the
/// survey's σ, and, for a turned frame, its vertical's standard error:
/// shared by every target, it goes into the intervals as one tilt per draw,
/// and into each target's covariance as what it does there alone.
fn score_options(
    cfg: &Config,
    motion: &RigidMotion,
    plumb: Option<&vertical::Plumb>,
) -> ScoreOptions {
    let vertical = (!motion.is_identity()).then(|| accuracy::Vertical {
        origin: motion.origin,
        // Of the angle: half its square in each direction.
        se_rad: vertical::vertical_se_deg(plumb).to_radians() / std::f64::consts::SQRT_2,
    });
    ScoreOptions {
        method: cfg.metrics.align,
        dim: cfg.metrics.dim,
        survey_sigma: cfg
            .metrics
            .survey_sigma_h
            .map(|h| (h, cfg.metrics.survey_sigma_v)),
        vertical,
        threshold: cfg.metrics.threshold_m,
    }
}

/// A target that waits for the others: its index, loose crop (points, and
/// how many the map offered) and board crop.
type Waiting = (usize, ((Vec<Point>, u64), Option<super::crops::BoardCrop>));

/// Where target `i` of `survey` is looked for: at `at`, among `others`.
fn place_of<'p>(
    survey: &'p Survey,
    i: usize,
    at: Point,
    others: &'p [Point],
    ups: &'p [nalgebra::Vector3<f64>],
    board: Option<super::crops::BoardCrop>,
) -> target::Place<'p> {
    let t = &survey.targets[i];
    target::Place {
        id: &t.id,
        expected: at,
        others,
        more_ups: ups,
        model: (t.model, t.size),
        board,
    }
}

/// `--init` and the survey frame are the map's own; hints and detections
/// were moved into the levelled frame already.
fn own(how: &FrameHow) -> bool {
    matches!(how, FrameHow::Init | FrameHow::Survey)
}

/// What the first pass needs besides the frame guess, which auto mode may
/// replace by detection (then the pass runs again).
struct FirstPass<'a> {
    source: MapSource<'a>,
    survey: &'a Survey,
    crop_params: LooseParams,
    motion: &'a RigidMotion,
    ground: &'a crate::frame::MapGround,
    ground_up: Option<nalgebra::Vector3<f64>>,
    crops_dir: Option<&'a Path>,
    cfg: &'a Config,
}

/// What auto mode's detection left of a first pass that found too few.
enum Instead {
    /// Detection matched the survey: this frame, for a first pass again.
    Detected((FrameHow, MapToSurvey, f64, Vec<Detection>)),
    /// Detection failed, but the guess found enough to align: kept.
    Kept(Vec<TargetRun>),
}

impl FirstPass<'_> {
    /// The crops at the survey's positions moved by the guess (`init`, `dz`;
    /// `own`: in the map's own frame, so levelled here), each target located.
    fn run(
        &self,
        init: &MapToSurvey,
        dz: f64,
        own: bool,
        map: &mut MapStats,
        progress: &mut impl FnMut(u64, u64),
        reads: &mut Vec<crate::cloud::PassRead>,
    ) -> Result<(Vec<Point>, Vec<TargetRun>)> {
        let cfg = self.cfg;
        let expected = expected_positions(self.survey, init, dz, own.then_some(self.motion));
        let super::crops::CropsRead {
            crops,
            coarse,
            read,
            again,
        } = read_crops(
            self.source,
            &expected,
            &self.crop_params,
            self.motion,
            self.ground.z_range,
            map,
            progress,
        )?;
        reads.push(read);
        reads.extend(again);
        let (boards, board_read) = super::crops::board_crops_of(
            self.source,
            self.survey,
            &expected,
            (0..expected.len()).collect::<Vec<_>>().as_slice(),
            self.crops_dir.is_none(),
            cfg,
            self.motion,
            self.ground.z_range,
        )?;
        reads.extend(board_read);
        let ups = more_ups(self.motion, self.ground_up);
        // Only Ls wait (their finder's windows are the cost), by the points
        // the map had about them (a crop is thinned beyond `crop.max_points`);
        // none when some crops hold a COPC octree's coarse levels only, whose
        // counts are the levels', not the map's.
        let late: Vec<bool> = if self.crops_dir.is_some() || coarse.contains(&true) {
            vec![false; expected.len()]
        } else {
            waves::dense(&crops.iter().map(|c| c.1 as usize).collect::<Vec<_>>())
                .into_iter()
                .zip(&self.survey.targets)
                .map(|(d, t)| d && t.model == crate::model::ModelKind::L)
                .collect()
        };
        let (now, later): (Vec<_>, Vec<_>) = crops
            .into_iter()
            .zip(boards)
            .enumerate()
            .partition(|(i, _)| !late[*i]);
        let mut found: Vec<(usize, TargetRun)> = now
            .into_par_iter()
            .map(|(i, (crop, board))| {
                let others = others_than(&expected, i);
                let at = place_of(self.survey, i, expected[i], &others, &ups, board);
                (i, self.locate(at, crop, &cfg.tight, Pass::First))
            })
            .collect();
        if !later.is_empty() {
            found.extend(self.after_the_others(later, &found, &expected, &ups));
            found.sort_by_key(|f| f.0);
        }
        let mut found: Vec<TargetRun> = found.into_iter().map(|f| f.1).collect();
        if self.crops_dir.is_none() && coarse.contains(&true) {
            let detail = super::detail::Detail {
                source: self.source,
                survey: self.survey,
                crop: &self.crop_params,
                motion: self.motion,
                z_range: self.ground.z_range,
                cfg,
                ups: &ups,
                expected: &expected,
            };
            detail.run(&mut found, &coarse, progress, reads)?;
        }
        Ok((expected, found))
    }

    /// The targets that waited (`waves::dense`), each searched where the
    /// ones located first (`found`) put it, else as they were.
    fn after_the_others(
        &self,
        later: Vec<Waiting>,
        found: &[(usize, TargetRun)],
        expected: &[Point],
        ups: &[nalgebra::Vector3<f64>],
    ) -> Vec<(usize, TargetRun)> {
        let (cfg, survey) = (self.cfg, self.survey);
        let located = found
            .iter()
            .filter_map(|(i, r)| r.corner().map(|c| (*i, c)))
            .collect();
        let fit = waves::FirstFit::of(located, survey);
        let radii = (cfg.tight.search_radius, self.crop_params.radius);
        later
            .into_par_iter()
            .map(|(i, (crop, board))| {
                let others = others_than(expected, i);
                let plate = target::l_plates(survey.targets[i].size, &cfg.tight).0;
                let plan = fit.as_ref().and_then(|f| {
                    let n = f.narrowed(survey, i, &expected[i], plate, radii)?;
                    Some((n, f.others(survey, i, expected)))
                });
                let Some(((at, radius), near)) = plan else {
                    let at = place_of(survey, i, expected[i], &others, ups, board);
                    return (i, self.locate(at, crop, &cfg.tight, Pass::First));
                };
                let tight = crate::crop::TightParams {
                    search_radius: radius,
                    ..cfg.tight.clone()
                };
                let offered = crop.1;
                let at = place_of(survey, i, at, &near, ups, board.clone());
                // Still the first pass: `Pass::Second` is the search again
                // after the checks (`score::check_found` trusts it).
                let mut r = self.locate(at, crop, &tight, Pass::First);
                if r.outcome.is_ok() {
                    r.waited = true;
                    return (i, r);
                }
                // Not where the others put it: searched as they were.
                let crop = (std::mem::take(&mut r.loose), offered);
                let at = place_of(survey, i, expected[i], &others, ups, board);
                (i, self.locate(at, crop, &cfg.tight, Pass::First))
            })
            .collect()
    }

    /// One target located at `place` in its loose crop (points, and how many
    /// the map offered before thinning).
    fn locate(
        &self,
        place: target::Place,
        (pts, offered): (Vec<Point>, u64),
        tight: &crate::crop::TightParams,
        pass: Pass,
    ) -> TargetRun {
        let thinned = (offered > pts.len() as u64).then_some(offered);
        let mut r = target::locate_target(place, pts, self.crops_dir, tight, self.cfg, pass);
        r.loose_thinned_from = thinned;
        r
    }

    /// Auto mode's answer to a guess (`how`) whose first pass (`found`)
    /// found too few targets: the frame detection gave, or the guess kept
    /// when it found enough to align (saying why detection did not take
    /// over), or the run's failure, told from what the survey's places
    /// showed: a wrong plate size, a map in another frame, a survey of
    /// another map.
    // Its large error is the run's, returned once (as `evaluate`'s).
    #[allow(clippy::result_large_err)]
    fn instead(
        &self,
        detected: std::result::Result<(FrameHow, MapToSurvey, f64, Vec<Detection>), frame::NoFrame>,
        how: &FrameHow,
        found: Vec<TargetRun>,
        map_name: &str,
        warnings: &mut Vec<Warning>,
    ) -> std::result::Result<Instead, Failed> {
        let cfg = self.cfg;
        let n_ok = found.iter().filter(|r| r.outcome.is_ok()).count();
        let enough = n_ok >= cfg.metrics.align.min_points().max(2);
        let error = match detected {
            Ok(d) => {
                let given = match how {
                    FrameHow::Init => Some("init"),
                    FrameHow::Hints { .. } => Some("hints"),
                    _ => None,
                };
                if let Some(given) = given {
                    warnings.push(Warning::GivenFrameReplaced {
                        given,
                        found: n_ok,
                        targets: found.len(),
                    });
                }
                return Ok(Instead::Detected(d));
            }
            Err(e) if enough => {
                warnings.push(Warning::DetectionFailed(e.into_error().to_string()));
                return Ok(Instead::Kept(found));
            }
            Err(error) => match (error, other_plate_size(&found, cfg)) {
                (frame::NoFrame::Failed(e), _) => e,
                (e, Some(size)) => Error::TooFewFound {
                    found: n_ok,
                    need: cfg.metrics.align.min_points().max(2),
                    msg: format!(
                        "{size}. (Read in the survey frame, the map showed {n_ok} of {} targets; and detection map-wide: {})",
                        found.len(),
                        e.into_error()
                    ),
                },
                (frame::NoFrame::NotMatched { detections, why }, None) => {
                    let e = not_there(map_name, &found, detections, &why, cfg);
                    match (e, super::diagnosis::up_not_z(map_name, self.ground)) {
                        (Error::FrameNotFound { detections: 0, msg }, Some(up)) => {
                            Error::FrameNotFound {
                                detections: 0,
                                msg: msg + &up,
                            }
                        }
                        (e, _) => e,
                    }
                }
            },
        };
        Err(Failed {
            error,
            targets: found,
            levelling: *self.motion,
        })
    }
}
