//! # mapgauge
//!
//! Measures how accurate a 3D point-cloud map built by LiDAR(-inertial) SLAM is,
//! from L-shaped targets whose corners were surveyed with RTK GNSS.
//!
//! Data flows one way, each stage a plain function of the previous one's output:
//!
//! | stage | module | what |
//! |---|---|---|
//! | geometry | `geom` (crate-internal) | planes, least-squares (SVD) plane fit, plane RANSAC: shared by crop and locate |
//! | map | [`cloud`] | streaming readers (PCD, PLY, LAS/LAZ, E57, XYZ) and crop writers |
//! | survey | [`survey`] | survey CSV, WGS84 → local ENU |
//! | frame | [`frame`] | which way is up (the ground's vertical), and the map → survey guess from hints or matched detections |
//! | detection | [`detect`] | target-shaped objects anywhere in a map (`mapgauge detect`, `--frame detect`) |
//! | crop | [`crop`] | loose crop (one pass for all targets), automatic tight crop (its L finder: `crop/tight/finder/`) |
//! | locate | [`locate`] | the paper's k-means → RANSAC → SVD corner, 100 samples |
//! | align | [`align`] | rigid / similarity / robust (Eq. 1) map → survey fits |
//! | accuracy | [`accuracy`] | absolute, relative, leave-one-out, ASPRS: typed numbers |
//! | all of it | [`pipeline`] | the stages composed, as `mapgauge eval` runs them: [`pipeline::run`] |
//! | many runs | [`batch`] | methods × sequences from a manifest, in parallel, resumable: tables per sequence, a leaderboard, each method against a baseline |
//! | gates | [`gate`] | quality gates (`E_abs<=0.05`) judged with their 95 % intervals, for CI |
//! | checkpoints | [`checkpoints`] | each target as a checkpoint in the survey's CRS: GeoPackage, GeoJSON, CSV |
//! | scores | [`scores`] | benchmark scores (Hilti 2022/2023/2026 points per checkpoint) |
//! | record | [`record`] | `result.json`: its schema, built from the typed values, read and written |
//! | render | [`render`] | the paper's tables and others as text, Markdown, LaTeX, CSV, HTML, JSON |
//! | report | [`report`] | report.html, SVG and PNG figures of an evaluation |
//! | comparison | [`compare`] | "is B better than A?": paired differences of two results with 95 % intervals (`mapgauge compare`) |
//! | test data | [`synth`] | LiDAR-like synthetic scenes with known truth |
//! | route | [`trajectory`] | the sensor's route (TUM or KITTI poses), for error against distance driven |
//!
//! The front desk is at the root: [`run`] evaluates a map ([`MapSource`]: a
//! file or points in memory) against a [`Survey`] with a [`Config`], and
//! [`ResultFile::from_evaluation`] is `mapgauge eval`'s `result.json`, caveats
//! included ([`write_outputs`] writes it with `targets.csv` and `pairs.csv`).
//! Here on a small synthetic scene made in memory:
//!
//! ```
//! use mapgauge::{Config, MapSource, ResultFile, synth};
//!
//! let params = synth::SynthParams { points: 300_000, ..Default::default() };
//! let mut map = Vec::new();
//! let truth = synth::generate(&params, &mut |block| {
//!     map.extend_from_slice(block);
//!     Ok(())
//! })?;
//! let survey = truth.survey();
//! let ev = mapgauge::run(MapSource::Points(&map), &survey, &Config::default(), |_, _| {})?;
//! let result = ResultFile::from_evaluation(&ev, &survey, "survey.csv");
//! assert_eq!(result.targets.len(), survey.targets.len());
//! assert!(ev.accuracy.absolute.mean < 0.05); // metres
//! # Ok::<(), mapgauge::Error>(())
//! ```
//!
//! Locating a target in a tight crop:
//!
//! ```
//! use mapgauge::locate::{locate, LocateParams};
//! use mapgauge::Point;
//!
//! // Two perpendicular 0.6 m plates meeting at (10, 20), seen as a grid of points.
//! let mut pts = Vec::new();
//! for i in 1..30 {
//!     for k in 0..30 {
//!         let (s, z) = (i as f64 * 0.02, 1.0 + k as f64 * 0.02);
//!         pts.push(Point::new(10.0 + s, 20.0, z));
//!         pts.push(Point::new(10.0, 20.0 + s, z));
//!     }
//! }
//! let found = locate(&pts, None, &LocateParams::default()).unwrap();
//! assert!((found.corner.x - 10.0).abs() < 1e-3 && (found.corner.y - 20.0).abs() < 1e-3);
//! ```
//!
//! Scoring positions against a survey, as `mapgauge errors` does:
//!
//! ```
//! use mapgauge::accuracy::{score, ScoreOptions};
//! use mapgauge::survey::{Estimate, Survey, SurveyFrame, SurveyTarget};
//! use mapgauge::Point;
//!
//! let truth = [(0.0, 0.0), (30.0, 0.0), (30.0, 40.0)];
//! let survey = Survey {
//!     targets: truth
//!         .iter()
//!         .enumerate()
//!         .map(|(i, &(x, y))| SurveyTarget {
//!             id: (i + 1).to_string(),
//!             position: Point::new(x, y, 0.0),
//!             has_z: false,
//!             role: None,
//!             antenna_height: 0.0,
//!             model: Default::default(),
//!             size: None,
//!             line: i as u64 + 2,
//!         })
//!         .collect(),
//!     frame: SurveyFrame::Local,
//!     origin: None,
//!     exchanged: None,
//! };
//! // The map is shifted by (5, -3) m and stretched 1 cm between targets 2 and 3.
//! let map = [(5.0, -3.0), (35.0, -3.0), (35.0, 37.01)];
//! let estimates: Vec<Estimate> = map
//!     .iter()
//!     .enumerate()
//!     .map(|(i, &(x, y))| Estimate::found((i + 1).to_string(), Point::new(x, y, 0.0)))
//!     .collect();
//! let r = score(&survey, &estimates, &ScoreOptions::default()).unwrap();
//! assert!((r.relative.pairs[2].error - 0.01).abs() < 1e-9); // t2 & t3
//! assert!(r.absolute.mean < 0.01); // the shift is aligned away
//! ```
#![deny(missing_docs)]
#![deny(unreachable_pub)]

pub mod accuracy;
pub mod align;
pub mod batch;
pub mod checkpoints;
pub mod cloud;
pub mod compare;
pub mod crop;
pub mod detect;
mod error;
pub mod frame;
pub mod gate;
pub(crate) mod geom;
pub mod locate;
pub mod model;
pub mod pipeline;
pub mod record;
pub mod render;
pub mod report;
pub mod scores;
pub mod survey;
pub mod synth;
pub mod trajectory;

pub use error::{Error, Result};

// The front desk: what a program that evaluates maps needs, at the root. The
// stage modules above stay public for the steps one by one (crop a map,
// locate one target, render a table); their internals are `pub(crate)`.
pub use accuracy::{Accuracy, ScoreOptions, score};
pub use cloud::MapSource;
pub use pipeline::{Config, Evaluation, run};
pub use record::ResultFile;
pub use render::write_outputs;
pub use survey::{Estimate, Survey, SurveyOptions, read_estimates, read_survey};

/// A point in a map or survey frame, metres, always f64.
pub type Point = nalgebra::Point3<f64>;
