//! Every parameter of a map evaluation, as the TOML configuration file and
//! `--print-config` show them, and the range checks that keep a typo from
//! making a run allocate or loop without bound.

use crate::accuracy::Dim;
use crate::align::AlignMethod;
use crate::crop::{LooseParams, TightParams};
use crate::locate::LocateParams;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Every parameter of `mapgauge eval`; also the TOML configuration file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Loose crop around each expected position.
    pub crop: LooseParams,
    /// Automatic tight crop (ground removal, target detection).
    pub tight: TightParams,
    /// Target localisation (the paper's algorithm).
    pub locate: LocateParams,
    /// Sphere targets (survey rows with `model = sphere`).
    pub sphere: crate::model::SphereParams,
    /// Checkerboard boards (survey rows with `model = board`).
    pub board: crate::model::BoardParams,
    /// Alignment and metrics.
    pub metrics: MetricsConfig,
    /// Frames: where to look for the targets in the map.
    pub frame: FrameConfig,
    /// Quality gates the result is held to (none by default).
    pub gates: crate::gate::GateConfig,
}

impl Default for Config {
    /// The locator's defaults (one refit in a noise-scaled band); the paper's
    /// plain draws are the fallback (see `locate_with`).
    fn default() -> Self {
        Config {
            crop: LooseParams::default(),
            tight: TightParams::default(),
            locate: LocateParams::default(),
            sphere: crate::model::SphereParams::default(),
            board: crate::model::BoardParams::default(),
            metrics: MetricsConfig::default(),
            frame: FrameConfig::default(),
            gates: crate::gate::GateConfig::default(),
        }
    }
}

/// Alignment and metric settings.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MetricsConfig {
    /// Map → survey alignment method.
    pub align: AlignMethod,
    /// Error dimension, "2d" (the paper) or "3d".
    pub dim: Dim,
    /// The survey's own horizontal 1-σ error (m), folded into the ASPRS figures.
    pub survey_sigma_h: Option<f64>,
    /// The survey's own vertical 1-σ error (m).
    pub survey_sigma_v: Option<f64>,
    /// Refit without targets flagged as gross errors (their residual is
    /// inconsistent with their covariance and with the other targets); they
    /// stay in the result as `excluded`, with the reason.
    pub exclude_outliers: bool,
    /// ISO 19157's threshold (m): the result counts the checkpoints whose
    /// horizontal (and vertical) error exceeds it; unset: not counted.
    pub threshold_m: Option<f64>,
    /// Benchmark scores to add to the result: "hilti2022", "hilti2023",
    /// "hilti2026" (none by default).
    pub scores: Vec<crate::scores::ScoreKind>,
}

impl Config {
    /// What the configuration asks of a finished result beyond the
    /// measurement: its benchmark scores, then its gates' verdicts. One
    /// place, so `eval`, `batch` and Python's `evaluate` write the same
    /// `result.json`.
    pub fn finish(&self, result: &mut crate::record::ResultFile) {
        crate::scores::apply(&self.metrics.scores, result);
        crate::gate::judge(&self.gates.checks, self.gates.policy, result);
    }
}

/// How the map → survey frame is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum FrameMode {
    /// `init` or `hints` when given; else the survey frame when the targets
    /// are found there; else detection and matching.
    #[default]
    Auto,
    /// The map is in the survey frame (to within a few metres), or `init` places it.
    Survey,
    /// Detect target-shaped objects map-wide and match them to the survey.
    Detect,
    /// The transform fitted to `hints` (approximate map positions of ≥ 2 targets).
    Hints,
}

/// Where targets are expected in the map.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FrameConfig {
    /// How the frame is found.
    pub mode: FrameMode,
    /// CSV `id,x,y[,z]` of approximate map positions (±0.5 m) of ≥ 2 targets.
    pub hints: Option<std::path::PathBuf>,
    /// A detection matches a surveyed target within this (m) when matching
    /// frames; it must cover the map's own error.
    pub match_tolerance: f64,
    /// Approximate map → survey transform, written `[x, y, yaw_deg]`
    /// (survey = R·map + t); `None` = the map is in the survey frame to
    /// within a few metres.
    pub init: Option<crate::frame::MapToSurvey>,
    /// ENU origin `[lat, lon, alt]` of a WGS84 survey (degrees, metres);
    /// `None` = the survey's first target. Used where the survey is read.
    /// `[lat, lon]` is read with alt 0, as `--origin lat,lon` is.
    #[serde(deserialize_with = "origin_2_or_3")]
    pub origin: Option<[f64; 3]>,
    /// Search again for targets not found, around the positions predicted by
    /// the alignment of the ones that were.
    pub second_pass: bool,
    /// Only search again when the prediction moved more than this (m).
    pub second_pass_min_shift: f64,
    /// The targets' common plumb line is trusted as the map's vertical up to this
    /// tilt from +z (degrees).
    pub max_tilt_deg: f64,
    /// Targets located with an "up" further than this from the common plumb line
    /// are located again with it (degrees).
    pub tilt_redo_deg: f64,
    /// The map is levelled (read rotated so that its ground's vertical is +z)
    /// when its ground leans more than this (degrees); the targets' plumb line
    /// refines it afterwards. Below it, a site's own slope could be most of
    /// the lean, and the map is read as it is (the plumb lines may still turn
    /// it when they lean significantly).
    pub level_above_deg: f64,
    /// ... and when at least this share of its flat 2 m ground blocks agree
    /// (within 1°) on that vertical. A SLAM map's tilt turns all of its flat
    /// ground alike (the tilted golden scene: 88 % agree), while terrain's
    /// own slopes scatter (PDAL's sample_c.las, 5.0°: 40 %; issue 30's
    /// LIO-SAM map, 5.1°: 19 %): below this share the lean is taken as the
    /// terrain's and the map is read as it is (the plumb lines may still
    /// turn it).
    pub level_min_support: f64,
    /// Points the levelling's ground pass reads of a bigger map: an even
    /// sample of its tiles, COPC nodes, LAZ chunks or record blocks, each
    /// part whole (0: every point). Formats that cannot skip part of a file
    /// (ASCII, E57, compressed PCD) are read whole.
    pub ground_sample: u64,
}

/// `origin = [lat, lon]` or `[lat, lon, alt]` (alt 0 when left out).
fn origin_2_or_3<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<[f64; 3]>, D::Error> {
    let v: Vec<f64> = Deserialize::deserialize(d)?;
    match v[..] {
        [lat, lon] => Ok(Some([lat, lon, 0.0])),
        [lat, lon, alt] => Ok(Some([lat, lon, alt])),
        _ => Err(serde::de::Error::custom(format!(
            "origin takes [lat, lon] or [lat, lon, alt], got {} numbers",
            v.len()
        ))),
    }
}

impl Default for FrameConfig {
    fn default() -> Self {
        FrameConfig {
            mode: FrameMode::Auto,
            hints: None,
            match_tolerance: 0.5,
            init: None,
            origin: None,
            second_pass: true,
            second_pass_min_shift: 0.5,
            max_tilt_deg: 3.0,
            tilt_redo_deg: 0.25,
            level_above_deg: 5.0,
            level_min_support: 0.5,
            ground_sample: super::GROUND_SAMPLE_POINTS,
        }
    }
}

impl Config {
    /// Reads a TOML configuration; unknown keys are errors (a typo must not be ignored).
    pub fn from_toml_file(path: &Path) -> Result<Config> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let text = std::str::from_utf8(&bytes).map_err(|e| {
            let line = bytes[..e.valid_up_to()].split(|&b| b == b'\n').count() as u64;
            Error::table(path, line, "not UTF-8 text")
        })?;
        let cfg: Config = toml::from_str(text).map_err(|e| {
            let line = e.span().map_or(0, |s| {
                text.as_bytes()[..s.start.min(text.len())]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count()
                    + 1
            });
            let msg = e.message().trim().replace('\n', " ");
            Error::table(path, line as u64, msg)
        })?;
        cfg.validate().map_err(|e| match e {
            Error::Param(m) => {
                let key = m.split(" = ").next().unwrap_or("");
                Error::table(path, key_line(text, key), m)
            }
            other => other,
        })?;
        Ok(cfg)
    }
    /// Checks every value is in a physically sensible range, so a typo cannot
    /// make a run allocate or loop without bound (flags are checked too). Each
    /// group checks its own.
    pub fn validate(&self) -> Result<()> {
        validate_loose(&self.crop)?;
        validate_tight(&self.tight)?;
        validate_locate(&self.locate)?;
        validate_sphere(&self.sphere)?;
        validate_board(&self.board)?;
        self.metrics.validate()?;
        self.frame.validate()
    }
    /// BLAKE3 (hex) of the settings alone, without `to_toml`'s
    /// explanations: rewording those changes no run's identity (the
    /// provenance line, batch's reuse of a finished run).
    pub fn settings_hash(&self) -> String {
        let settings = toml::to_string(self).unwrap_or_default();
        blake3::hash(settings.as_bytes()).to_hex().to_string()
    }

    /// The configuration as TOML, every default written out.
    /// Settings left unset (TOML has no null) appear as comments that say
    /// what unset means.
    pub fn to_toml(&self) -> String {
        let text = toml::to_string_pretty(self)
            .unwrap_or_else(|e| format!("# cannot print configuration: {e}\n"));
        let mut unset: Vec<(&str, &str)> = Vec::new();
        if self.metrics.survey_sigma_h.is_none() {
            unset.push((
                "metrics",
                "# survey_sigma_h = 0.02   # unset: the survey's own error is not folded in",
            ));
        }
        if self.metrics.survey_sigma_v.is_none() {
            unset.push((
                "metrics",
                "# survey_sigma_v = 0.03   # unset: the survey's own error is not folded in",
            ));
        }
        if self.metrics.threshold_m.is_none() {
            unset.push((
                "metrics",
                "# threshold_m = 0.05   # unset: ISO 19157's count of checkpoints beyond a threshold is not given",
            ));
        }
        if self.frame.init.is_none() {
            unset.push(("frame", "# init = [x, y, yaw_deg]   # unset: no guess (mode auto: the survey frame, else detection; survey = R(yaw)·map + (x, y))"));
        }
        if self.frame.hints.is_none() {
            unset.push((
                "frame",
                "# hints = \"hints.csv\"   # unset: no hints (CSV id,x,y[,z] of approximate map positions)",
            ));
        }
        if self.frame.origin.is_none() {
            unset.push((
                "frame",
                "# origin = [lat, lon, alt]   # unset: a WGS84 survey's first target ([lat, lon]: alt 0)",
            ));
        }
        if self.gates.checks.is_empty() {
            unset.push((
                "gates",
                "# e.g. checks = [\"E_abs<=0.05\", \"max_abs<=10cm\", \"found>=0.9\"]   # none: exit 0 whenever a result is produced; each gate is judged with its 95 % interval (pass, fail, undecided)",
            ));
            unset.push((
                "gates",
                "# statistics: E_abs E_rel max_abs median_abs max_rel E_loo RMSE_H RMSE_V RMSE_3D NSSDA_H NSSDA_V (m), scale_ppm, found (0-1)",
            ));
        }
        let mut out = String::new();
        let mut section = "";
        for line in text.lines() {
            // Each key with its line of explanation above it.
            let key = line.split_once(" = ").map(|(k, _)| k.trim());
            if let Some(d) = key.and_then(|k| super::config_keys::doc(section, k)) {
                out.push_str("# ");
                out.push_str(d);
                out.push('\n');
            }
            out.push_str(line);
            out.push('\n');
            if let Some(s) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
                section = s;
                for (_, c) in unset.iter().filter(|(s, _)| *s == section) {
                    out.push_str(c);
                    out.push('\n');
                }
            }
        }
        out
    }
}

/// The line of `section.key` in a TOML text (0 when not found): so a value
/// out of range is reported where it was written.
fn key_line(text: &str, dotted: &str) -> u64 {
    let Some((section, key)) = dotted.split_once('.') else {
        return 0;
    };
    let mut current = "";
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if let Some(s) = l.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            current = s.trim();
        } else if current == section
            && l.split('=').next().is_some_and(|k| k.trim() == key)
            && l.contains('=')
        {
            return i as u64 + 1;
        }
    }
    0
}

/// `v` within `lo..=hi`, or an error naming the key.
fn range(key: &str, v: f64, lo: f64, hi: f64) -> Result<()> {
    if v >= lo && v <= hi {
        Ok(())
    } else {
        Err(Error::Param(format!(
            "{key} = {v}: must be within {lo}..{hi}"
        )))
    }
}

/// A count within `lo..=hi`, or an error naming the key.
fn count(key: &str, v: usize, lo: usize, hi: usize) -> Result<()> {
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(Error::Param(format!(
            "{key} = {v}: must be within {lo}..{hi}"
        )))
    }
}

fn validate_loose(c: &LooseParams) -> Result<()> {
    range("crop.radius", c.radius, 1e-3, 1e4)?;
    let coarse = usize::try_from(c.coarse_points).unwrap_or(usize::MAX);
    count("crop.coarse_points", coarse, 1, 1_000_000_000)
}

fn validate_tight(t: &TightParams) -> Result<()> {
    range("tight.plate_width", t.plate_width, 0.05, 10.0)?;
    range("tight.plate_height", t.plate_height, 0.05, 10.0)?;
    range("tight.ground_cell", t.ground_cell, 0.05, 100.0)?;
    range("tight.min_height", t.min_height, -100.0, 100.0)?;
    range("tight.max_height", t.max_height, t.min_height, 1000.0)?;
    range("tight.search_radius", t.search_radius, 1e-3, 1e4)?;
    range("tight.keep_distance", t.keep_distance, 1e-4, 10.0)?;
    count("tight.min_plate_points", t.min_plate_points, 1, 1 << 24)?;
    range("tight.max_up_tilt_deg", t.max_up_tilt_deg, 0.0, 90.0)
}

fn validate_sphere(s: &crate::model::SphereParams) -> Result<()> {
    crate::model::ModelKind::Sphere
        .check_size(s.diameter_m)
        .map_err(|e| Error::Param(format!("sphere.diameter_m: {e}")))?;
    range("sphere.radius_sigma_m", s.radius_sigma_m, 0.0, 0.05)?;
    count("sphere.min_points", s.min_points, 8, 100_000)?;
    range("sphere.search_radius_m", s.search_radius_m, 0.01, 50.0)?;
    count("sphere.max_points", s.max_points, 1_000, 10_000_000)
}

fn validate_board(b: &crate::model::BoardParams) -> Result<()> {
    crate::model::ModelKind::Board
        .check_size(b.side_m)
        .map_err(|e| Error::Param(format!("board.side_m: {e}")))?;
    count("board.min_points", b.min_points, 12, 1_000_000)?;
    range("board.search_radius_m", b.search_radius_m, 0.01, 50.0)?;
    count("board.max_points", b.max_points, 1_000, 10_000_000)
}

fn validate_locate(l: &LocateParams) -> Result<()> {
    count("locate.kmeans_iterations", l.kmeans_iterations, 1, 1 << 16)?;
    count("locate.kmeans_points", l.kmeans_points, 0, 1 << 24)?;
    count("locate.ransac_iterations", l.ransac_iterations, 1, 1 << 24)?;
    count(
        "locate.ransac_score_points",
        l.ransac_score_points,
        0,
        1 << 24,
    )?;
    count("locate.refit_iterations", l.refit_iterations, 0, 1 << 16)?;
    count("locate.samples", l.samples, 1, 1 << 20)?;
    count("locate.max_attempts", l.max_attempts, 1, 1 << 24)?;
    // The localisation's own consistency rules (thresholds, margins, angles).
    l.check()
}

impl MetricsConfig {
    /// Checks the survey sigmas and the threshold.
    pub fn validate(&self) -> Result<()> {
        for (k, v) in [
            ("metrics.survey_sigma_h", self.survey_sigma_h),
            ("metrics.survey_sigma_v", self.survey_sigma_v),
            ("metrics.threshold_m", self.threshold_m),
        ] {
            if let Some(v) = v {
                range(k, v, 0.0, 1e3)?;
            }
        }
        Ok(())
    }
}

impl FrameConfig {
    /// Checks the initial transform, shift and tilt limits.
    pub fn validate(&self) -> Result<()> {
        if let Some(i) = self.init {
            for v in <[f64; 3]>::from(i) {
                range("frame.init", v, -1e8, 1e8)?;
            }
        }
        if let Some([lat, lon, alt]) = self.origin {
            range("frame.origin", lat, -90.0, 90.0)?;
            range("frame.origin", lon, -180.0, 360.0)?;
            range("frame.origin", alt, -1e5, 1e5)?;
        }
        range(
            "frame.second_pass_min_shift",
            self.second_pass_min_shift,
            0.0,
            1e4,
        )?;
        range("frame.max_tilt_deg", self.max_tilt_deg, 0.0, 90.0)?;
        range("frame.tilt_redo_deg", self.tilt_redo_deg, 0.0, 90.0)?;
        range("frame.level_above_deg", self.level_above_deg, 0.0, 90.0)?;
        range("frame.level_min_support", self.level_min_support, 0.0, 1.0)?;
        range("frame.match_tolerance", self.match_tolerance, 0.01, 100.0)?;
        if self.mode == FrameMode::Hints && self.hints.is_none() {
            return Err(Error::Param(
                "frame.mode = hints needs frame.hints (a CSV id,x,y[,z] of map positions)".into(),
            ));
        }
        if self.mode == FrameMode::Hints && self.init.is_some() {
            return Err(Error::Param(
                "frame.mode = hints fits the transform to the hints: leave frame.init unset".into(),
            ));
        }
        if self.mode == FrameMode::Detect && self.init.is_some() {
            return Err(Error::Param(
                "frame.mode = detect finds the transform itself: leave frame.init unset".into(),
            ));
        }
        Ok(())
    }
}
