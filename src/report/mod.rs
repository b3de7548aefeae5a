//! Reports people read: `report.html` (one self-contained page: inline SVG and
//! CSS, no script, no network) and the same figures as SVG and PNG files.
//!
//! Data flows one way: a [`Report`] borrows what [`crate::pipeline::run`]
//! produced (the result file, the crops and the per-target fits) and only
//! draws it; it never runs localisation again.
//!
//! ```no_run
//! # fn main() -> mapgauge::Result<()> {
//! use mapgauge::report::{Provenance, Report};
//! # let ev: mapgauge::pipeline::Evaluation = unimplemented!();
//! # let result: mapgauge::record::ResultFile = unimplemented!();
//! let prov = Provenance::new(Some(0), None);
//! let report = Report::from_evaluation(&ev, &result, prov);
//! report.write_html(std::path::Path::new("out/report.html"))?;
//! report.write_plots(std::path::Path::new("out/plots"))?;
//! # Ok(()) }
//! ```

pub(crate) mod figure;
pub mod html;
pub(crate) mod plots;
pub(crate) mod png;
pub(crate) mod svg;

mod failure;
mod files;

pub use failure::{failure_page, place_status, write_failure};
pub use files::{HashedInputs, Written, hash_inputs, write_report};
pub use plots::{ROUTE_FAR_M, located_stations};

use crate::align::Alignment;
use crate::locate::Label;
use crate::pipeline::Evaluation;
use crate::record::{ResultFile, write_atomic};
use crate::{Error, Point, Result};
use std::io::Read;
use std::path::{Path, PathBuf};

/// One input file as the report names it: what it was, how big, its BLAKE3
/// hash (`b3sum` prints the same for a file; a tiled map is hashed as one
/// stream of its metadata and tiles in reading order). BLAKE3 hashes a map
/// 3-4x faster than SHA-256 does even with the CPU's SHA extensions, and the
/// hash runs alongside the evaluation on the same cores.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputFile {
    /// Its role (`map`, `survey`, `config`).
    pub role: String,
    /// Path as given on the command line.
    pub path: String,
    /// Size in bytes.
    pub bytes: u64,
    /// BLAKE3 (256 bits), lowercase hex, as `b3sum` prints it.
    pub blake3: String,
}

impl InputFile {
    /// Reads `path` once, streaming (1 MiB at a time: a map need not fit in
    /// memory), and returns its size and BLAKE3 hash.
    pub fn hash(role: &str, path: &Path) -> Result<InputFile> {
        let never = std::sync::atomic::AtomicBool::new(false);
        InputFile::hash_unless(role, path, &never)?
            .ok_or_else(|| Error::Input(format!("{}: hashing stopped", path.display())))
    }

    /// [`InputFile::hash`] that gives up (`Ok(None)`) as soon as `stop` is
    /// set: for hashing on a thread of its own alongside a run that may fail.
    pub(crate) fn hash_unless(
        role: &str,
        path: &Path,
        stop: &std::sync::atomic::AtomicBool,
    ) -> Result<Option<InputFile>> {
        // A tiled map is its metadata and tiles, hashed as one stream in
        // reading order.
        let files: Vec<std::path::PathBuf> = if crate::cloud::is_tiled(path) {
            crate::cloud::TiledMap::discover(path)?
                .files()
                .into_iter()
                .map(Path::to_path_buf)
                .collect()
        } else {
            vec![path.to_path_buf()]
        };
        let mut h = blake3::Hasher::new();
        let mut buf = vec![0u8; 1 << 20];
        let mut bytes = 0u64;
        for file in &files {
            let mut f = std::fs::File::open(file).map_err(|e| Error::io(file, e))?;
            loop {
                if stop.load(std::sync::atomic::Ordering::Relaxed) {
                    return Ok(None);
                }
                let n = f.read(&mut buf).map_err(|e| Error::io(file, e))?;
                if n == 0 {
                    break;
                }
                h.update(&buf[..n]);
                bytes += n as u64;
            }
        }
        let blake3 = h.finalize().to_hex().to_string();
        Ok(Some(InputFile {
            role: role.into(),
            path: path.display().to_string(),
            bytes,
            blake3,
        }))
    }
}

/// Where a report's numbers came from: tool version, inputs, seed, date and
/// parameters. Kept out of result.json (the date would make reruns differ).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Provenance {
    /// mapgauge version.
    pub version: String,
    /// When the report was written, `YYYY-MM-DD HH:MM:SS UTC`.
    pub date_utc: String,
    /// Seed of the random draws.
    pub seed: Option<u64>,
    /// Input files with sizes and hashes.
    pub inputs: Vec<InputFile>,
    /// Every parameter, as the TOML that reproduces the run.
    pub config_toml: Option<String>,
}

impl Provenance {
    /// Provenance stamped now (or at `SOURCE_DATE_EPOCH`, for reproducible pages).
    pub fn new(seed: Option<u64>, config_toml: Option<String>) -> Provenance {
        Provenance {
            version: env!("CARGO_PKG_VERSION").into(),
            date_utc: utc_string(report_time()),
            seed,
            inputs: Vec::new(),
            config_toml,
        }
    }
}

/// Seconds since 1970 from `SOURCE_DATE_EPOCH` when set, else the clock.
pub(crate) fn report_time() -> i64 {
    if let Some(t) = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<i64>().ok())
    {
        return t;
    }
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0)
}

/// `YYYY-MM-DD HH:MM:SS UTC` for seconds since 1970 (proleptic Gregorian).
pub(crate) fn utc_string(secs: i64) -> String {
    let days = secs.div_euclid(86_400);
    let s = secs.rem_euclid(86_400);
    // Days → civil date (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02} UTC",
        s / 3600,
        s / 60 % 60,
        s % 60
    )
}

/// What localisation kept for plotting one located target.
#[derive(Debug, Clone, Copy, Default)]
pub struct Diagnostics<'a> {
    /// Role of each tight-crop point in the reference sample (plate 1, plate
    /// 2, outlier), in the order of the tight crop.
    pub labels: &'a [Label],
    /// Unit normals of the two fitted plate planes (map frame).
    pub plate_normals: Option<[[f64; 3]; 2]>,
    /// The estimated corner (map frame).
    pub corner: Option<Point>,
    /// Every accepted sample corner (map frame): the spread behind `corner`.
    pub samples: &'a [Point],
    /// A sphere's radius (m): its outline is drawn about `corner`, its centre.
    pub circle: Option<f64>,
    /// A board's face and print: drawn face on, its squares' colours and
    /// lines about `corner`, the crossing.
    pub board: Option<BoardView<'a>>,
}

/// What a board's face view draws.
#[derive(Debug, Clone, Copy)]
pub struct BoardView<'a> {
    /// The face's unit normal (map frame).
    pub normal: [f64; 3],
    /// The two boundary lines' directions (map frame).
    pub lines: [[f64; 3]; 2],
    /// Whether each tight-crop point reads as a bright square.
    pub bright: &'a [bool],
}

/// The crops and fits of one target, borrowed from an [`Evaluation`].
#[derive(Debug, Clone, Copy, Default)]
pub struct TargetView<'a> {
    /// Loose crop (map frame).
    pub loose: &'a [Point],
    /// Tight crop (map frame), empty when none was made.
    pub tight: &'a [Point],
    /// What localisation kept for plotting, when it located the target.
    pub diag: Option<Diagnostics<'a>>,
}

/// Everything a report shows.
#[derive(Debug, Clone)]
pub struct Report<'a> {
    /// The result (result.json).
    pub result: &'a ResultFile,
    /// The map → survey transform, to draw survey positions in the map frame.
    pub alignment: Alignment,
    /// Per target, in the order of `result.targets`.
    pub targets: Vec<TargetView<'a>>,
    /// Inputs, seed, date, parameters.
    pub provenance: Provenance,
    /// The map from above, drawn under the target positions (levelled map
    /// frame, as the targets' map positions).
    pub footprint: Option<&'a crate::frame::Footprint>,
    /// The sensor's route in the frame of the targets' map positions (see
    /// [`Report::with_trajectory`]).
    pub trajectory: Option<crate::trajectory::Trajectory>,
}

impl<'a> Report<'a> {
    /// A report of an evaluation; `result` is its result file.
    pub fn from_evaluation(
        ev: &'a Evaluation,
        result: &'a ResultFile,
        provenance: Provenance,
    ) -> Report<'a> {
        let targets = ev
            .targets
            .iter()
            .map(|t| TargetView {
                loose: &t.loose,
                tight: &t.tight,
                diag: t.outcome.as_ref().ok().map(|f| Diagnostics {
                    labels: &f.located.labels,
                    plate_normals: f
                        .is_l()
                        .then(|| [f.located.plates[0].normal, f.located.plates[1].normal]),
                    corner: Some(f.located.corner),
                    samples: &f.located.samples,
                    circle: f.sphere.as_ref().map(|s| s.radius),
                    board: f.board.as_ref().map(|b| BoardView {
                        normal: b.normal,
                        lines: b.lines,
                        bright: &b.bright,
                    }),
                }),
            })
            .collect();
        Report {
            result,
            alignment: ev.accuracy.fit.alignment.clone(),
            targets,
            provenance,
            footprint: Some(&ev.footprint),
            trajectory: None,
        }
    }
    /// A report of a result file alone (no crops: target panels say so).
    pub fn from_result(result: &'a ResultFile, provenance: Provenance) -> Report<'a> {
        Report {
            result,
            alignment: alignment_of(result),
            targets: Vec::new(),
            provenance,
            footprint: None,
            trajectory: None,
        }
    }
    /// This report with the sensor's route drawn on the overview and each
    /// target's error plotted against the distance along it. `route` is in
    /// the map's own frame, `levelling` the turn the evaluation gave the map
    /// (`Evaluation::frame.levelling`).
    pub fn with_trajectory(
        mut self,
        route: &crate::trajectory::Trajectory,
        levelling: &crate::cloud::RigidMotion,
    ) -> Self {
        self.trajectory = Some(route.moved(levelling));
        self
    }
    /// Every figure, in page order.
    pub(crate) fn figures(&self) -> Vec<figure::Figure> {
        plots::figures(self)
    }
    /// The whole page.
    pub fn html(&self) -> String {
        html::report_page(self, &self.figures())
    }
    /// Writes the page atomically.
    pub fn write_html(&self, path: &Path) -> Result<()> {
        write_atomic(path, self.html().as_bytes())
    }
    /// Writes every figure as `DIR/<name>.svg` and `DIR/<name>.png`; returns the paths.
    pub fn write_plots(&self, dir: &Path) -> Result<Vec<PathBuf>> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let mut out = Vec::new();
        for f in self.figures() {
            let svg_path = dir.join(format!("{}.svg", f.name));
            let mut text = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
            text.push_str(&svg::render(&f));
            text.push('\n');
            write_atomic(&svg_path, text.as_bytes())?;
            let png_path = dir.join(format!("{}.png", f.name));
            png::write(&f, &png_path)?;
            out.push(svg_path);
            out.push(png_path);
        }
        Ok(out)
    }
}

/// The transform a result file records (its full rotation matrix).
pub(crate) fn alignment_of(r: &ResultFile) -> Alignment {
    let m = r.alignment.rotation_matrix;
    Alignment {
        method: r.alignment.method.parse().unwrap_or_default(),
        rotation: nalgebra::Matrix3::new(
            m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2],
        ),
        translation: nalgebra::Vector3::from(r.alignment.translation),
        scale: r.alignment.scale,
        iterations: r.alignment.iterations,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A small XML well-formedness check: tags balance, attributes are quoted,
    /// no raw `<` or `&` in text. Enough to catch a broken builder.
    pub(crate) fn check_xmlish(s: &str) {
        let mut stack: Vec<String> = Vec::new();
        let mut i = 0;
        let b = s.as_bytes();
        while i < b.len() {
            match b[i] {
                b'<' => {
                    let end = s[i..].find('>').map(|e| i + e).expect("unclosed tag");
                    let tag = &s[i + 1..end];
                    assert!(!tag.contains('<'), "`<` inside a tag: {tag}");
                    if tag.starts_with('!') || tag.starts_with('?') {
                    } else if let Some(name) = tag.strip_prefix('/') {
                        let open = stack.pop().unwrap_or_default();
                        assert_eq!(open, name.trim(), "mismatched close");
                    } else {
                        let name: String = tag
                            .chars()
                            .take_while(|c| !c.is_whitespace() && *c != '/')
                            .collect();
                        assert_eq!(
                            tag.matches('"').count() % 2,
                            0,
                            "unbalanced quotes in {tag}"
                        );
                        let void = ["meta", "br", "hr", "img", "link", "input", "col", "wbr"];
                        if !tag.ends_with('/') && !void.contains(&name.as_str()) {
                            stack.push(name);
                        }
                    }
                    i = end + 1;
                }
                b'&' => {
                    let semi = s[i..].find(';').expect("bare &");
                    let ent = &s[i + 1..i + semi];
                    assert!(
                        ["amp", "lt", "gt", "quot", "#39"].contains(&ent),
                        "entity &{ent};"
                    );
                    i += semi + 1;
                }
                _ => i += 1,
            }
        }
        assert!(stack.is_empty(), "unclosed elements: {stack:?}");
    }

    #[test]
    fn dates() {
        assert_eq!(utc_string(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc_string(951_782_400), "2000-02-29 00:00:00 UTC");
        assert_eq!(utc_string(1_700_000_000), "2023-11-14 22:13:20 UTC");
    }

    #[test]
    fn hash_streams_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.txt");
        std::fs::write(&p, b"abc").unwrap();
        let f = InputFile::hash("map", &p).unwrap();
        assert_eq!(f.bytes, 3);
        assert_eq!(
            f.blake3,
            "6437b3ac38465133ffb63b75273a8db548c558465d79db03fd359c6cd5bd9d85"
        );
        assert!(InputFile::hash("map", &dir.path().join("missing")).is_err());
    }

    #[test]
    fn hash_is_the_whole_streams() {
        // Across the 1 MiB reads: the one-shot hash of the same bytes.
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.bin");
        let bytes: Vec<u8> = (0..2_621_447u32).map(|i| (i * 7 % 251) as u8).collect();
        std::fs::write(&p, &bytes).unwrap();
        let f = InputFile::hash("map", &p).unwrap();
        assert_eq!(f.bytes, bytes.len() as u64);
        assert_eq!(f.blake3, blake3::hash(&bytes).to_hex().to_string());
        // A tiled map: its metadata and tiles, in reading order, as one stream.
        let pts: Vec<Point> = (0..200)
            .map(|i| Point::new((i % 20) as f64 * 3.0, (i / 20) as f64 * 5.0, 0.1 * i as f64))
            .collect();
        let tiled = dir.path().join("tiles");
        let map =
            crate::cloud::write_tiles(&pts, &tiled, 20.0, crate::cloud::OutFormat::Pcd).unwrap();
        let files = map.files();
        assert!(files.len() > 2, "metadata and several tiles");
        let mut all = Vec::new();
        for f in &files {
            all.extend(std::fs::read(f).unwrap());
        }
        let f = InputFile::hash("map", &tiled).unwrap();
        assert_eq!(f.bytes, all.len() as u64);
        assert_eq!(f.blake3, blake3::hash(&all).to_hex().to_string());
    }
}
