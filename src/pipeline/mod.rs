//! The whole evaluation, map to accuracy: loose crop → tight crop → locate →
//! align → accuracy. Each stage is a plain function of the previous stage's
//! output; this module only composes them, searches again where the first
//! pass missed, and records what happened — it writes no file and prints
//! nothing.
//!
//! Read `steps.rs` first: `evaluate` is the list of steps, in order.
//! Then one idea a file: `frame.rs` (where to look: the map → survey
//! guess), `vertical.rs` (which way is up: the ground, the targets' plumb
//! lines and heights), `crops.rs` (the loose crops around the expected
//! positions), `target.rs` (one target's tight crop and locator),
//! `passes.rs` (searching again), `layout.rs` (objects far from where the
//! others put them), `score.rs` (the found objects checked, then scored),
//! `diagnosis.rs` (why a run could not score), `warning.rs`, `config.rs`.
//!
//! ```no_run
//! use mapgauge::cloud::MapSource;
//! use mapgauge::pipeline::{self, Config};
//! use mapgauge::survey::{SurveyOptions, read_survey};
//! # fn main() -> mapgauge::Result<()> {
//! let survey = read_survey("survey.csv".as_ref(), &SurveyOptions::default())?;
//! let map = MapSource::File("map.pcd".as_ref());
//! let ev = pipeline::run(map, &survey, &Config::default(), |_, _| {})?;
//! println!("E_abs = {:.4} m", ev.accuracy.absolute.mean);
//! # Ok(()) }
//! ```

mod config;
mod config_keys;
mod crops;
mod detail;
mod diagnosis;
mod frame;
mod heights;
mod layout;
mod passes;
mod score;
mod steps;
mod target;
mod vertical;
mod warning;
mod waves;

pub use config::{Config, FrameConfig, FrameMode, MetricsConfig};
pub use frame::{FrameFound, FrameHow};
pub use heights::HeightsLean;
pub use target::{Failure, FarBy, Found, Pass, TargetRun, locate_with};
pub use vertical::Plumb;
pub(crate) use vertical::vertical_se_deg;

use crate::accuracy::{self, Accuracy, ScoreOptions};
use crate::cloud::{MapSource, RigidMotion};
use crate::crop::{self, LooseParams};
use crate::survey::{Estimate, EstimateStatus, Survey};
use crate::{Error, Point, Result};
use crops::{expected_positions, others_than, read_crops};
use diagnosis::{against_survey, check_map, not_there, other_plate_size, too_few_found};
use score::{check_found, estimates, score};
use std::path::Path;
use steps::evaluate;
use vertical::{first_levelling, more_ups, refine_vertical};
pub use warning::Warning;

/// What the map gave.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MapStats {
    /// The map as named in results (path as given, or `<memory>`).
    pub name: String,
    /// Size in bytes (0 in memory).
    pub bytes: u64,
    /// Finite points in the map when a pass read all of it; else the most
    /// any pass read (`Evaluation::reads` says what each read).
    pub points: u64,
    /// Points skipped as NaN or infinite (by the ground pass, or the crops'
    /// when it read the whole map).
    pub skipped_nonfinite: u64,
}

/// Everything an evaluation produces.
#[derive(Debug)]
pub struct Evaluation {
    /// The errors.
    pub accuracy: Accuracy,
    /// Per survey target, in survey order: crops, located corner or failure.
    pub targets: Vec<TargetRun>,
    /// What the map gave.
    pub map: MapStats,
    /// Caveats for the user.
    pub warnings: Vec<Warning>,
    /// How the map's frame was found, and its levelling.
    pub frame: FrameFound,
    /// What each pass over the map read, in order.
    pub reads: Vec<crate::cloud::PassRead>,
    /// The map from above, as the ground pass saw it (the report draws the
    /// target positions on it).
    pub footprint: crate::frame::Footprint,
    /// How close two copies of a target (a seam) may be and still be seen
    /// in this map; `None` with fewer than three targets located.
    pub doubling: Option<crate::locate::DoublingLimit>,
    /// Every parameter the run used (result.json echoes it, so a result
    /// says what produced it even without its report).
    pub config: Config,
}

/// Points the levelling's ground pass reads of a bigger map by default
/// (`frame.ground_sample`): an even sample of its tiles, COPC nodes, LAZ
/// chunks or record blocks ([`crate::frame::ground_level`]). Millions of points give thousands of
/// 2 m ground blocks, more than the vertical's mode needs, at a tenth of a
/// pass over a 20 M-point map and a hundredth of a 200 M-point one (4 M
/// cost 0.08 s more of a 0.6 s eval of the former, with the same levelling
/// on the tilted scenes).
pub(crate) const GROUND_SAMPLE_POINTS: u64 = 2_000_000;

/// Where a running evaluation is: the pass over the map and its bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// The pass: `ground` (the map's vertical and ground, from an even
    /// sample of a big map),
    /// `detection` (map-wide detection of the targets, when the frame is
    /// not known), `crops` (around the expected positions), `second-pass`
    /// (around the positions the found targets predict).
    pub pass: &'static str,
    /// Bytes of this pass read so far.
    pub done: u64,
    /// Bytes this pass reads in all (a tiled map's or COPC file's crops
    /// may stop short of it: only the tiles or nodes near the targets).
    pub total: u64,
}

/// Evaluates a map against a survey. `progress` gets (bytes read, total
/// bytes) while a map file streams; each pass starts again from 0
/// ([`run_reporting`] says which pass).
pub fn run(
    source: MapSource,
    survey: &Survey,
    cfg: &Config,
    mut progress: impl FnMut(u64, u64),
) -> Result<Evaluation> {
    evaluate(source, survey, None, cfg, |p: Progress| {
        progress(p.done, p.total)
    })
    .map_err(|f| f.error)
}

/// [`run`] with hand-made tight crops `crops_dir/<id>.ply|pcd|…` (the paper's
/// manual workflow) instead of the automatic tight crop. The map is still read
/// for the loose crops the report shows.
pub fn run_with_crops(
    source: MapSource,
    survey: &Survey,
    crops_dir: &Path,
    cfg: &Config,
    mut progress: impl FnMut(u64, u64),
) -> Result<Evaluation> {
    evaluate(source, survey, Some(crops_dir), cfg, |p: Progress| {
        progress(p.done, p.total)
    })
    .map_err(|f| f.error)
}

/// [`run`] (or [`run_with_crops`] with `crops_dir`) telling `progress` which
/// pass over the map it is in, for a progress display that names it.
pub fn run_reporting(
    source: MapSource,
    survey: &Survey,
    crops_dir: Option<&Path>,
    cfg: &Config,
    progress: impl FnMut(Progress),
) -> Result<Evaluation> {
    evaluate(source, survey, crops_dir, cfg, progress).map_err(|f| f.error)
}

/// An evaluation that could not score, with what it found at each surveyed
/// place (crops, located corner or why not) when it got that far: what a
/// user needs to see why.
#[derive(Debug)]
pub struct Failed {
    /// Why the evaluation could not score.
    pub error: Error,
    /// Per survey target, in survey order, when the crops were read (empty
    /// when the run failed before them).
    pub targets: Vec<TargetRun>,
    /// Map → the frame the targets' positions are in (the levelling; the
    /// identity for a map read as it is).
    pub levelling: RigidMotion,
}

impl From<Error> for Failed {
    fn from(error: Error) -> Self {
        Failed {
            error,
            targets: Vec::new(),
            levelling: RigidMotion::identity_at(Point::origin()),
        }
    }
}

/// [`run_reporting`] that, when the evaluation cannot score, keeps what it
/// saw at each surveyed place ([`Failed`]) for the user to inspect.
// A large error is returned once a run: not worth a box.
#[allow(clippy::result_large_err)]
pub fn run_keeping_failures(
    source: MapSource,
    survey: &Survey,
    crops_dir: Option<&Path>,
    cfg: &Config,
    progress: impl FnMut(Progress),
) -> std::result::Result<Evaluation, Failed> {
    evaluate(source, survey, crops_dir, cfg, progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn survey(at: &[(f64, f64)]) -> Survey {
        let at: Vec<(f64, f64, f64)> = at.iter().map(|&(x, y)| (x, y, 0.0)).collect();
        Survey::local(&at, false)
    }

    /// The failures a caller acts on come typed, with their numbers (issue
    /// 32): a patch of bare ground locates no target, and the same ground
    /// read in millimetres is not a map in metres.
    #[test]
    fn failures_to_act_on_are_typed() {
        let ground: Vec<Point> = (0..4_000)
            .map(|i| Point::new((i % 60) as f64 * 0.5, (i / 60) as f64 * 0.5, 0.0))
            .collect();
        let s = survey(&[(5.0, 5.0), (20.0, 20.0)]);
        let cfg = Config::default();
        match run(MapSource::Points(&ground), &s, &cfg, |_, _| ()) {
            Err(Error::TooFewFound {
                found: 0,
                need: 2,
                msg,
            }) => {
                assert!(msg.contains("only 0 of 2 targets found"), "{msg}")
            }
            other => panic!("{:?}", other.map(|_| ())),
        }
        // Three places (auto mode then looks map-wide): no frame.
        let s3 = survey(&[(5.0, 5.0), (20.0, 20.0), (25.0, 5.0)]);
        match run(MapSource::Points(&ground), &s3, &cfg, |_, _| ()) {
            Err(Error::FrameNotFound { detections: 0, msg }) => {
                assert!(msg.contains("none anywhere else"), "{msg}")
            }
            other => panic!("{:?}", other.map(|_| ())),
        }
        // A site of tens of metres in millimetres: tens of kilometres.
        let mm: Vec<Point> = (0..400_000)
            .map(|i| Point::new((i % 600) as f64 * 50.0, (i / 600) as f64 * 50.0, 0.0))
            .collect();
        match run(MapSource::Points(&mm), &s, &cfg, |_, _| ()) {
            Err(Error::NotMetres { extent, msg }) => {
                assert!(extent[0] > 1e3 && msg.contains("millimetres"), "{msg}")
            }
            other => panic!("{:?}", other.map(|_| ())),
        }
    }
}
