//! A synthetic scene on disk: the map, the survey (local and WGS84) and the
//! truth, including the errors a perfect locator would report.

use super::{PointLabel, SynthParams, Truth, generate, generate_labelled};
use crate::accuracy::{self, ScoreOptions};
use crate::cloud::{CloudWriter, OutFormat};
use crate::record::{ResultFile, write_atomic};
use crate::survey::{
    Estimate, Geodetic, Survey, SurveyFrame, SurveyOptions, SurveyTarget, read_survey,
};
use crate::{Error, Point, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Where [`write_scene`] put things.
#[derive(Debug, Clone)]
pub struct SceneFiles {
    /// The map.
    pub map: PathBuf,
    /// `id,x,y,z,antenna_height` in the local (survey) frame.
    pub survey: PathBuf,
    /// `id,lat,lon,alt,antenna_height` in WGS84.
    pub survey_llh: PathBuf,
    /// The truth (JSON).
    pub truth: PathBuf,
    /// The sensor's route in the map frame, TUM lines (`eval --trajectory`).
    pub trajectory: PathBuf,
    /// What each point of the map is a return from, when asked for
    /// ([`write_scene_labelled`]): little-endian u16 codes
    /// ([`PointLabel::code`]), one per point in the map's order.
    pub labels: Option<PathBuf>,
}

/// The truth plus what evaluating the true map positions gives: the errors a
/// perfect locator would report, which `eval` should reproduce.
#[derive(Debug, Clone, serde::Serialize)]
pub(crate) struct TruthFile<'a> {
    /// Scene truth.
    #[serde(flatten)]
    pub truth: &'a Truth,
    /// Result of aligning the true map positions to the survey (rigid2d, 2D).
    pub expected: &'a ResultFile,
}

/// Generates the scene into `dir` (created if missing). Returns the files and
/// the expected result.
pub fn write_scene(
    dir: &Path,
    params: &SynthParams,
    format: OutFormat,
) -> Result<(SceneFiles, Truth, ResultFile)> {
    scene(dir, params, format, false)
}

/// [`write_scene`], with `labels.u16` beside the map: what each point is a
/// return from ([`PointLabel::code`]), for testing a locator against the
/// plates' own points.
pub fn write_scene_labelled(
    dir: &Path,
    params: &SynthParams,
    format: OutFormat,
) -> Result<(SceneFiles, Truth, ResultFile)> {
    scene(dir, params, format, true)
}

fn scene(
    dir: &Path,
    params: &SynthParams,
    format: OutFormat,
    labelled: bool,
) -> Result<(SceneFiles, Truth, ResultFile)> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let files = SceneFiles {
        map: dir.join(format!("map.{}", format.extension())),
        survey: dir.join("survey.csv"),
        survey_llh: dir.join("survey_llh.csv"),
        truth: dir.join("truth.json"),
        trajectory: dir.join("trajectory.txt"),
        labels: labelled.then(|| dir.join("labels.u16")),
    };
    // Labels of an earlier scene in this folder would not be this map's.
    if !labelled {
        let stale = dir.join("labels.u16");
        if stale.exists() {
            std::fs::remove_file(&stale).map_err(|e| Error::io(&stale, e))?;
        }
    }
    let truth = write_map(&files.map, files.labels.as_deref(), params, format)?;

    // Model and size columns only for a survey of more than Ls: an L-only
    // survey is written as the paper's.
    let models = truth
        .targets
        .iter()
        .any(|t| t.model != crate::model::ModelKind::L);
    let extra = if models { ",model,size" } else { "" };
    let mut local = format!("id,x,y,z,antenna_height{extra}\n");
    let mut llh = format!("id,lat,lon,alt,antenna_height{extra}\n");
    let [lat, lon, alt] = params.origin_llh;
    let origin = Geodetic { lat, lon, alt };
    // `origin_llh` is the local frame's origin: the false origin comes off first.
    let [fx, fy, fz] = params.survey_false_origin_m;
    for t in &truth.targets {
        let s = &t.survey;
        let tail = if models {
            let size = t.size.map_or(String::new(), |v| format!("{v}"));
            format!(",{},{size}", t.model.name())
        } else {
            String::new()
        };
        let _ = writeln!(
            local,
            "{},{:.4},{:.4},{:.4},{:.4}{tail}",
            t.id, s.x, s.y, s.z, s.antenna_height
        );
        let g = origin.geodetic_of(&Point::new(s.x - fx, s.y - fy, s.z - fz));
        let _ = writeln!(
            llh,
            "{},{:.10},{:.10},{:.4},{:.4}{tail}",
            t.id, g.lat, g.lon, g.alt, s.antenna_height
        );
    }
    // Positions in the map frame, as SLAM software writes its poses; the
    // heading is the world's (only positions are read back).
    let mut route = String::from(
        "# mapgauge synth: sensor positions in the map frame (TUM: t x y z qx qy qz qw)\n",
    );
    for (i, (p, q)) in truth.path_in_map.iter().zip(&truth.path).enumerate() {
        let h = q.yaw_deg.to_radians() / 2.0;
        let _ = writeln!(
            route,
            "{:.3} {:.4} {:.4} {:.4} 0 0 {:.6} {:.6}",
            i as f64 / params.lidar.rate_hz,
            p[0],
            p[1],
            p[2],
            h.sin(),
            h.cos()
        );
    }
    write_atomic(&files.trajectory, route.as_bytes())?;
    write_atomic(&files.survey, local.as_bytes())?;
    write_atomic(&files.survey_llh, llh.as_bytes())?;

    let survey = read_survey(&files.survey, &SurveyOptions::default())?;
    let estimates: Vec<Estimate> = truth
        .targets
        .iter()
        .map(|t| Estimate::found(t.id.clone(), Point::from(t.map)))
        .collect();
    let expected = ResultFile::from_accuracy(
        &accuracy::score(&survey, &estimates, &ScoreOptions::default())?,
        &survey,
    );
    let json = serde_json::to_string_pretty(&TruthFile {
        truth: &truth,
        expected: &expected,
    })
    .map_err(|e| Error::Input(e.to_string()))?;
    write_atomic(&files.truth, (json + "\n").as_bytes())?;
    Ok((files, truth, expected))
}

/// Generates the scene's map into `path`. Formats with an intensity field
/// get [`synthetic_intensity`]; float32 formats hold the map's own
/// coordinates (a local frame within a few hundred metres of the origin, so
/// rounded by a few micrometres; see `OutFormat::PcdF32`).
fn write_map(
    path: &Path,
    labels: Option<&Path>,
    params: &SynthParams,
    format: OutFormat,
) -> Result<Truth> {
    // Boards print their squares in the intensity; the rest is a stand-in.
    let faces = super::print::board_faces(params);
    // LAS, LAZ, binary_compressed PCD and double PLY carry it only when
    // boards print in it: without, LAS holds 0, as SLAM software's LAS
    // exports do, and the compressed PCD and the PLY x, y, z alone (as
    // synth's always did).
    let only_boards = matches!(
        format,
        OutFormat::Las | OutFormat::Laz | OutFormat::PcdCompressed | OutFormat::Ply
    );
    let with = format.holds_intensity() && !(only_boards && faces.is_empty());
    let mut writer = CloudWriter::create_with(path, format, with)?;
    let mut inten = Vec::new();
    let mut put = |pts: &[Point]| {
        if with {
            inten.clear();
            inten.extend(pts.iter().map(|p| {
                let i = synthetic_intensity(p);
                if faces.is_empty() {
                    return i;
                }
                super::print::board_intensity(&faces, p, coordinate_hash(p)).unwrap_or(i)
            }));
            writer.write_intensity(pts, &inten)
        } else {
            writer.write(pts)
        }
    };
    // Labels only when asked for: they cost a word a point in every batch.
    let mut codes = labels.map(LabelWriter::create).transpose()?;
    let truth = match codes.as_mut() {
        Some(c) => generate_labelled(params, &mut |pts, l| {
            c.write(l)?;
            put(pts)
        })?,
        None => generate(params, &mut put)?,
    };
    // The labels first, then the map: a map whose labels failed is removed,
    // so a scene's map never stands beside labels of another (nor without
    // those asked for).
    if let Some(c) = codes {
        c.finish()?;
    }
    if let Err(e) = writer.finish() {
        if let Some(l) = labels {
            let _ = std::fs::remove_file(l);
        }
        return Err(e);
    }
    Ok(truth)
}

/// `labels.u16`, streamed to a temporary name and renamed when whole, as
/// the map is: memory stays at a buffer, and a crash leaves no half file.
struct LabelWriter {
    path: PathBuf,
    tmp: PathBuf,
    /// Taken by `finish`; a writer dropped with it (a failed scene) removes
    /// its temporary file.
    out: Option<std::io::BufWriter<std::fs::File>>,
}

impl Drop for LabelWriter {
    fn drop(&mut self) {
        if self.out.is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

impl LabelWriter {
    fn create(path: &Path) -> Result<Self> {
        let name = path
            .file_name()
            .map_or("labels".into(), |n| n.to_string_lossy());
        let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
        let f = std::fs::File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        Ok(LabelWriter {
            path: path.to_path_buf(),
            tmp,
            out: Some(std::io::BufWriter::with_capacity(1 << 20, f)),
        })
    }

    fn write(&mut self, labels: &[PointLabel]) -> Result<()> {
        use std::io::Write as _;
        let bytes: Vec<u8> = labels.iter().flat_map(|l| l.code().to_le_bytes()).collect();
        match self.out.as_mut() {
            Some(o) => o.write_all(&bytes).map_err(|e| Error::io(&self.path, e)),
            None => Ok(()),
        }
    }

    fn finish(mut self) -> Result<()> {
        let Some(out) = self.out.take() else {
            return Ok(());
        };
        let done = out
            .into_inner()
            .map_err(|e| e.into_error())
            .and_then(|f| f.sync_all())
            .and_then(|()| std::fs::rename(&self.tmp, &self.path));
        done.map_err(|e| {
            let _ = std::fs::remove_file(&self.tmp);
            Error::io(&self.path, e)
        })
    }
}

/// A stand-in for a return's intensity: an integer in 0..=255 (the range
/// LIO-SAM and FAST-LIO2 maps hold) from a hash of the point's coordinates,
/// so the same seed gives the same bytes in any thread count. Nothing reads
/// it back (but on boards, whose print `print::board_intensity` writes);
/// it is there so the files have the real layouts' bytes.
fn synthetic_intensity(p: &Point) -> f32 {
    let h = (p.x.to_bits() ^ p.y.to_bits().rotate_left(21) ^ p.z.to_bits().rotate_left(42))
        .wrapping_mul(0x9E37_79B9_7F4A_7C15);
    (h >> 56) as f32
}

/// A well-mixed hash of a point's coordinates (for a board's intensity
/// noise; [`synthetic_intensity`]'s is one multiply, kept for its bytes).
fn coordinate_hash(p: &Point) -> u64 {
    crate::crop::point_hash(p)
}

impl Truth {
    /// The scene's survey, exactly (the CSV that [`write_scene`] writes rounds
    /// to 0.1 mm): for evaluating a scene held in memory.
    pub fn survey(&self) -> Survey {
        Survey {
            targets: self
                .targets
                .iter()
                .enumerate()
                .map(|(i, t)| SurveyTarget {
                    id: t.id.clone(),
                    position: Point::new(t.survey.x, t.survey.y, t.survey.z),
                    has_z: true,
                    role: None,
                    antenna_height: t.survey.antenna_height,
                    model: t.model,
                    size: t.size,
                    line: i as u64 + 2,
                })
                .collect(),
            frame: SurveyFrame::Local,
            origin: None,
            exchanged: None,
        }
    }
}
