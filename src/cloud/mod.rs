//! Point clouds in and out: streaming readers for every common map format and
//! writers for crops.
//!
//! Readers are pull-based: [`open`] sniffs the format from the file's first
//! bytes (the extension is only a tie-breaker), and [`PointReader::next_chunk`]
//! fills a caller-owned buffer with the next block of points, so memory stays
//! bounded whatever the map's size. Non-finite points are skipped and counted.

use crate::{Error, Point, Result};
pub(crate) use fold::{fold_points, fold_points_until};
pub(crate) use motion::Moved;
pub use motion::RigidMotion;
pub use region::Region;
pub use source::{MapSource, MemoryReader};
use std::io::Read;
use std::path::Path;
pub(crate) use tiles::is_tiled;
pub use tiles::{Tile, TileStats};
pub use tiles::{TiledMap, read_metadata, write_tiles};

mod e57;
mod fold;
mod las;
mod motion;
mod num;
mod pcd;
mod ply;
mod producer;
mod pts;
mod records;
mod region;
mod scalar;
mod source;
pub(crate) mod tiles;
mod write;
mod xyz;

/// A map file format mapgauge can read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// Point Cloud Data (PCL), v0.5–v0.7, ascii / binary / binary_compressed.
    Pcd,
    /// Polygon File Format, ascii / binary little and big endian.
    Ply,
    /// ASPRS LAS 1.0–1.4.
    Las,
    /// LASzip-compressed LAS.
    Laz,
    /// ASTM E57.
    E57,
    /// Whitespace- or comma-separated x y z text.
    Xyz,
    /// PTS text (Leica, CloudCompare, Open3D): a count line, then
    /// `x y z [intensity [r g b]]` lines.
    Pts,
    /// Points handed over in memory ([`MapSource::Points`]): no file.
    Memory,
}

/// What a reader knows about a cloud before reading its points.
#[derive(Debug, Clone)]
pub struct CloudInfo {
    /// Detected format.
    pub format: Format,
    /// Point count declared by the header, when the format has one.
    pub declared_points: Option<u64>,
    /// Size of the file in bytes (for progress).
    pub file_bytes: u64,
}

/// What one pass of an evaluation read from the map: how many points, and
/// how many bytes of files (a whole plain file; only the tiles or COPC
/// nodes a region hint selected), so a user sees what each pass cost.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PassRead {
    /// The pass: `ground` (an even sample of a big map), `detect-ground`
    /// (the rest of the ground, when detection needs it), `detect-cells`,
    /// `detect-crops`, `crops`, `second-pass`; for a COPC map read by level
    /// (`crop.by_level`), `crops-again` (a crop whose coarse levels came out
    /// short, read again at every level), `crops-detail` (every level near
    /// the targets found in the coarse levels) and `crops-whole` (every
    /// level of the crops of targets the coarse levels did not show).
    pub pass: String,
    /// Finite points read.
    pub points: u64,
    /// Bytes of the files read.
    pub bytes: u64,
}

impl PassRead {
    /// What `reader` has read so far, as pass `pass`.
    pub fn of(pass: &str, reader: &dyn PointReader) -> PassRead {
        PassRead {
            pass: pass.into(),
            points: reader.stats().points,
            bytes: match reader.tile_stats() {
                Some(t) => t.bytes_opened,
                None => reader.sampled().unwrap_or(reader.info().file_bytes),
            },
        }
    }
}

/// Counters a reader keeps while streaming.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReadStats {
    /// Finite points read (handed to the caller, or dropped by a reader as
    /// outside the [`Region`] the caller gave).
    pub points: u64,
    /// Points skipped because a coordinate was NaN or infinite.
    pub skipped_nonfinite: u64,
}

/// A streaming source of points.
pub trait PointReader: Send {
    /// Header facts.
    fn info(&self) -> &CloudInfo;
    /// Clears `buf` and fills it with the next block of finite points (up to a
    /// reader-chosen block size). Returns `Ok(false)` once the cloud is exhausted.
    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool>;
    /// Counters so far.
    fn stats(&self) -> ReadStats;
    /// Bytes of the file consumed so far (for progress bars).
    fn bytes_read(&self) -> u64;
    /// Whether [`PointReader::next_chunk_intensity`] gives intensities: the
    /// cloud has an `intensity` field and the reader reads it (binary,
    /// binary_compressed and ASCII PCD, binary and ASCII PLY, LAS, LAZ and COPC, E57 whose every
    /// scan has one, PTS whose first point line has one, XYZ/CSV whose header
    /// names an intensity column).
    fn has_intensity(&self) -> bool {
        false
    }
    /// [`PointReader::next_chunk`], with the intensity of each point in
    /// `intensity` (cleared first; left empty when
    /// [`PointReader::has_intensity`] is false).
    fn next_chunk_intensity(
        &mut self,
        buf: &mut Vec<Point>,
        intensity: &mut Vec<f32>,
    ) -> Result<bool> {
        intensity.clear();
        self.next_chunk(buf)
    }
    /// The next stretch of the cloud as a [`Batch`] of pieces that threads can
    /// read, decode and consume independently (so each piece is used while it
    /// is in the cache), or `None` once the cloud is exhausted. `buf` is the
    /// storage readers without a parallel path decode into; the default
    /// implementation fills it with [`PointReader::next_chunk`].
    fn next_batch<'a>(
        &'a mut self,
        buf: &'a mut Vec<Point>,
    ) -> Result<Option<Box<dyn Batch + 'a>>> {
        if self.next_chunk(buf)? {
            Ok(Some(Box::new(Decoded(buf))))
        } else {
            Ok(None)
        }
    }
    /// Tells the reader, before its first read, that the consumer keeps only
    /// points within `radius` (horizontally) of one of `centres`: a reader
    /// that can skip whole parts of the map unread (a tiled map's far tiles)
    /// does. Later calls, and readers without such parts, ignore it; the
    /// consumer still applies its exact test.
    fn hint_discs(&mut self, centres: &[[f64; 2]], radius: f64) {
        let _ = (centres, radius);
    }
    /// Tells the reader, after [`PointReader::hint_discs`] and before its
    /// first read, that the consumer keeps an even sample of at most `points`
    /// points per disc and thins the rest away. A reader whose map is stored
    /// in levels of detail, each a spatially even sample of the map (a COPC
    /// octree; density-capped, not uniform: see `crop::loose_crop_by_level`),
    /// may then read near each disc only the coarser levels that hold more
    /// than that there by its estimate; [`PointReader::levels_cut`] says
    /// whether it left any unread. Others ignore it. The estimate may be
    /// wrong: a consumer that gets no more than `points` in a disc has no
    /// sample of it and reads that disc again without the hint.
    fn hint_enough(&mut self, points: u64) {
        let _ = points;
    }
    /// Per disc of the [`PointReader::hint_discs`], whether a
    /// [`PointReader::hint_enough`] left levels of detail unread near it;
    /// empty when it left nothing unread.
    fn levels_cut(&self) -> Vec<bool> {
        Vec::new()
    }
    /// What a tiled map's reader opened (`None` for a single file).
    fn tile_stats(&self) -> Option<TileStats> {
        None
    }
    /// Tells the reader, before its first read, that the consumer wants a
    /// spatially even sample of the map of at least `points` points, not
    /// every point (the levelling's ground estimate). A reader that can leave
    /// whole parts of the map unread reads an even selection of them: every
    /// k-th tile, the coarse levels of a COPC octree, every k-th LASzip chunk,
    /// every k-th block of fixed-size records. Others, and later calls, read
    /// everything; [`PointReader::sampled`] says which happened.
    fn hint_sample(&mut self, points: u64) {
        let _ = points;
    }
    /// The bytes of the map read so far when a [`PointReader::hint_sample`]
    /// made this reader skip parts of it (its counters are then the
    /// sample's, not the map's); `None` when it reads everything.
    fn sampled(&self) -> Option<u64> {
        None
    }
    /// Whether the file stores coordinates as float32 (binary PCD and PLY
    /// `float`): far from the origin those keep a coarse step (0.5 m at
    /// 5.4e6 m, UTM northings), which the pipeline warns of.
    fn float32_coords(&self) -> bool {
        false
    }
}

/// The step float32 keeps at coordinates up to `reach` (m): its spacing at
/// the largest power of two below `reach` (24-bit significand).
pub(crate) fn float32_step(reach: f64) -> f64 {
    if !(reach.is_finite() && reach > 0.0) {
        return 0.0;
    }
    2f64.powi(reach.log2().floor() as i32 - 23)
}

/// Bytes a point is taken to occupy when only a file's size is known (a
/// tile not yet opened): float32 x, y, z and intensity, the common PCD map.
pub(crate) const BYTES_PER_POINT_GUESS: u64 = 16;

/// Consecutive pieces of a cloud, in file order, each decodable on any thread.
pub trait Batch: Sync {
    /// Number of pieces.
    fn pieces(&self) -> usize;
    /// The finite points of piece `i` (`i < pieces()`), decoded into `scratch`
    /// where the reader needs storage. Counters in [`PointReader::stats`]
    /// include a piece once it has been decoded.
    fn piece<'s>(&'s self, i: usize, scratch: &'s mut Scratch) -> Result<&'s [Point]>;
    /// [`Batch::piece`] for a consumer that wants only points inside `region`:
    /// readers that can test raw coordinates drop the others before building
    /// them (the default returns every point). The result may still hold points
    /// outside the region; the counters in [`PointReader::stats`] count every
    /// finite point decoded, kept or not.
    fn piece_within<'s>(
        &'s self,
        i: usize,
        scratch: &'s mut Scratch,
        region: &Region,
    ) -> Result<&'s [Point]> {
        let _ = region;
        self.piece(i, scratch)
    }
}

/// Per-thread buffers a [`Batch`] decodes into; reuse one across pieces so its
/// memory is allocated (and faulted in) once.
#[derive(Debug, Default)]
pub struct Scratch {
    /// Raw bytes of a piece.
    bytes: Vec<u8>,
    /// Decoded points of a piece.
    points: Vec<Point>,
    /// Decompressed columns of a piece (binary_compressed PCD).
    cols: Vec<Vec<u8>>,
    /// Points moved by a [`RigidMotion`] reader.
    moved: Vec<Point>,
}

/// Points per piece of an already decoded block.
const DECODED_PIECE: usize = 1 << 16;

/// An already decoded block handed out in pieces.
struct Decoded<'a>(&'a mut Vec<Point>);

impl Batch for Decoded<'_> {
    fn pieces(&self) -> usize {
        self.0.len().div_ceil(DECODED_PIECE)
    }
    fn piece<'s>(&'s self, i: usize, _: &'s mut Scratch) -> Result<&'s [Point]> {
        let from = (i * DECODED_PIECE).min(self.0.len());
        let to = (from + DECODED_PIECE).min(self.0.len());
        Ok(&self.0[from..to])
    }
}

/// Opens a map of any supported format, recognised from its content; a
/// folder or a `*metadata*.yaml` is a tiled map ([`TiledMap`]).
pub fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    if is_tiled(path) {
        return tiles::open(path);
    }
    open_as(path, detect(path)?)
}

/// The projection file of the map at `path`: a tiled map's
/// `map_projector_info.yaml`, if it has one.
pub fn map_projector(path: &Path) -> Result<Option<std::path::PathBuf>> {
    if is_tiled(path) {
        Ok(TiledMap::discover(path)?.projector)
    } else {
        Ok(None)
    }
}

/// The coordinate reference system the map's header declares (LAS, LAZ,
/// COPC), when it declares one: such a map is georeferenced, its z vertical
/// by construction.
pub fn declared_crs(path: &Path) -> Option<String> {
    if is_tiled(path) {
        return None;
    }
    match detect(path).ok()? {
        Format::Las | Format::Laz => las::declared_crs(path),
        _ => None,
    }
}

/// Refuses a map whose header declares a CRS in another unit than the
/// metre: longitude and latitude in degrees (read as metres, the whole site
/// fits in a few centimetres), feet (a State Plane map; read as metres, a
/// 0.6 m plate is looked for at 0.6 ft), or heights in feet. Every measure
/// here (plate sizes, distances, the ground's slope) is in metres. The
/// error names the remedy: the UTM zone to reproject to, or the scales to
/// convert by.
pub fn refuse_non_metric(path: &Path) -> Result<()> {
    if is_tiled(path) || !matches!(detect(path), Ok(Format::Las | Format::Laz)) {
        return Ok(());
    }
    let Some(crs) = las::crs_of(path) else {
        return Ok(());
    };
    let las::Crs {
        name,
        degrees,
        middle: [lon, lat],
        horizontal_unit,
        vertical_unit,
    } = crs;
    let at = path.display();
    if degrees {
        let epsg = (lat.abs() <= 84.0).then(|| {
            let zone = (((lon + 180.0) / 6.0).floor() as i64).clamp(0, 59) + 1;
            (if lat >= 0.0 { 32600 } else { 32700 }) + zone
        });
        let target = match epsg {
            Some(e) => format!(
                "its UTM zone, EPSG:{e} (from the middle of its bounds: lon {lon:.4}°, lat {lat:.4}°)"
            ),
            None => "a projected CRS in metres".into(),
        };
        let code = epsg.map_or("<code>".to_string(), |e| e.to_string());
        return Err(Error::Input(format!(
            "{at}: its header declares a geographic coordinate reference system ({name}): its x and y are longitude and latitude in degrees, and mapgauge measures in metres. Reproject the map to {target}, for example `pdal translate {at} map_utm.las reprojection --filters.reprojection.out_srs=EPSG:{code}`, and give the survey in the same CRS"
        )));
    }
    let said = |(u, m): &(String, f64)| format!("the {u} ({m} m)");
    // Heights are in the projected CRS's unit unless a vertical CRS says
    // otherwise (Autzen's elevations are in feet; Texas State Plane feet
    // over NAVD88 metres is common).
    let vertical = vertical_unit.filter(|v| Some(v.1) != horizontal_unit.as_ref().map(|h| h.1));
    let (what, flags) = match (&horizontal_unit, &vertical) {
        (None, None) => return Ok(()),
        (None, Some(v)) if v.1 == 1.0 => return Ok(()),
        (Some(h), None) => (
            format!("whose unit is {}", said(h)),
            format!("--scale {}", h.1),
        ),
        (Some(h), Some(v)) => (
            format!(
                "whose x and y are in {} and heights in {}",
                said(h),
                said(v)
            ),
            format!("--scale {} --scale-z {}", h.1, v.1),
        ),
        (None, Some(v)) => (
            format!("whose heights are in {}", said(v)),
            format!("--scale-z {}", v.1),
        ),
    };
    Err(Error::Input(format!(
        "{at}: its header declares a coordinate reference system ({name}) {what}, and mapgauge measures in metres. Convert the map: `mapgauge convert --map {at} --out map_m.las {flags}`, and give the survey in metres"
    )))
}

/// Size of the map at `path` in bytes (a tiled map's tiles together), for
/// progress; 0 when it cannot be told.
pub fn map_bytes(path: &Path) -> u64 {
    if is_tiled(path) {
        TiledMap::discover(path).map_or(0, |m| m.bytes())
    } else {
        std::fs::metadata(path).map_or(0, |m| m.len())
    }
}

/// Opens a map as `format` whatever its content says (for callers that know
/// better than the sniffer, and for fuzzing one reader at a time).
pub fn open_as(path: &Path, format: Format) -> Result<Box<dyn PointReader>> {
    match format {
        Format::Pcd => pcd::open(path),
        Format::Ply => ply::open(path),
        Format::Las | Format::Laz => las::open(path),
        Format::E57 => e57::open(path),
        Format::Xyz => xyz::open(path),
        Format::Pts => pts::open(path),
        Format::Memory => Err(Error::Param(format!(
            "{}: `memory` is not a file format",
            path.display()
        ))),
    }
}

/// The message for a Git LFS pointer file (a map repository cloned without
/// its large files): a few lines naming the object, not the map.
fn lfs_pointer(head: &[u8]) -> Option<String> {
    let text = std::str::from_utf8(head).ok()?;
    if !text.starts_with("version https://git-lfs.github.com/spec/") {
        return None;
    }
    let size = text
        .lines()
        .find_map(|l| l.strip_prefix("size "))
        .and_then(|v| v.trim().parse::<u64>().ok());
    Some(format!(
        "this is a Git LFS pointer, not the map itself{}: the repository was cloned without its large files; run `git lfs pull` in it (or download the file) and try again",
        size.map_or(String::new(), |b| format!(" (the map is {b} bytes)"))
    ))
}

/// Recognises a cloud's format from its first bytes; the extension only breaks
/// ties (LAS vs LAZ share a signature).
pub fn detect(path: &Path) -> Result<Format> {
    let mut head = [0u8; 512];
    let n = {
        let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let mut n = 0;
        loop {
            match f.read(&mut head[n..]) {
                Ok(0) => break,
                Ok(k) => {
                    n += k;
                    if n == head.len() {
                        break;
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(Error::io(path, e)),
            }
        }
        n
    };
    let head = &head[..n];
    if n == 0 {
        return Err(Error::format(path, "empty file"));
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    if let Some(msg) = lfs_pointer(head) {
        return Err(Error::format(path, msg));
    }
    if head.starts_with(b"LASF") {
        // Point data format id at byte 104; LAZ sets bit 7 (and 6).
        let compressed = head.get(104).is_some_and(|b| b & 0x80 != 0);
        return Ok(if compressed || ext == "laz" {
            Format::Laz
        } else {
            Format::Las
        });
    }
    if head.starts_with(b"ASTM-E57") {
        return Ok(Format::E57);
    }
    if head.starts_with(b"ply\n") || head.starts_with(b"ply\r\n") {
        return Ok(Format::Ply);
    }
    // PCD: comment lines, then VERSION / FIELDS keywords.
    for line in head.split(|&b| b == b'\n') {
        let line = line.trim_ascii_start();
        if line.is_empty() || line.starts_with(b"#") {
            continue;
        }
        if line.starts_with(b"VERSION") || line.starts_with(b"FIELDS") {
            return Ok(Format::Pcd);
        }
        break;
    }
    if pts::sniff(head, n < 512, ext == "pts") {
        return Ok(Format::Pts);
    }
    match ext.as_str() {
        "pcd" => Ok(Format::Pcd),
        "ply" => Ok(Format::Ply),
        "e57" => Ok(Format::E57),
        "pts" => Ok(Format::Pts),
        _ => Ok(Format::Xyz),
    }
}

/// Reads a whole (small) cloud into memory, e.g. a tight crop.
pub fn read_all(path: &Path) -> Result<Vec<Point>> {
    let mut reader = open(path)?;
    let mut all = Vec::new();
    let mut buf = Vec::new();
    while reader.next_chunk(&mut buf)? {
        all.extend_from_slice(&buf);
    }
    Ok(all)
}

/// An output format for crops and synthetic maps.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum OutFormat {
    /// Binary little-endian PLY with double x, y, z, and a float intensity
    /// when the source has one (synth: with boards).
    Ply,
    /// Binary PCD v0.7 with double x, y, z.
    Pcd,
    /// LAS 1.2, point format 0 (millimetre scale).
    Las,
    /// ascii PCD with double x, y, z written to the micrometre (6 decimals).
    #[serde(rename = "pcd-ascii")]
    PcdAscii,
    /// binary_compressed PCD (PCL's LZF, column-wise) with double x, y, z, and
    /// a float intensity when the source has one (synth: with boards); the
    /// format's 32-bit sizes limit it to 178 956 970 points (153 391 689 with
    /// intensity).
    #[serde(rename = "pcd-compressed")]
    PcdCompressed,
    /// LAZ (LASzip-compressed LAS 1.2, point format 0, millimetre scale).
    Laz,
    /// Binary PCD v0.7 with float32 x, y, z, for readers that misread double
    /// PCD (Open3D 0.20's legacy reader returns zeros). Coordinates are
    /// written as they are, with no offset (as SLAM tools write their maps):
    /// f32 keeps 24 bits, so they round by at most 4 µm within 128 m of the
    /// origin, 0.03 mm within 1 024 m, 0.25 mm within 8 192 m, under 1 mm
    /// within 32 768 m; beyond that they would round by 1 mm or more and are
    /// refused (UTM-size maps: keep `pcd`).
    #[serde(rename = "pcd-f32")]
    PcdF32,
    /// Binary PCD of float x y z intensity, 16 bytes a point: LIO-SAM's
    /// `PointXYZI` maps. Float32 limits as for `pcd-f32`.
    #[serde(rename = "pcd-xyzi")]
    PcdXyzi,
    /// Binary PCD of FAST-LIO2's `PointXYZINormal`: float x y z intensity
    /// normal_x normal_y normal_z curvature, 32 bytes a point (normals and
    /// curvature 0, as FAST-LIO2 saves them). Float32 limits as for `pcd-f32`.
    #[serde(rename = "pcd-fastlio")]
    PcdFastlio,
    /// Binary little-endian PLY of float x y z, plus float intensity when
    /// the source has it (GLIM's maps). Float32 limits as for `pcd-f32`.
    #[serde(rename = "ply-f32")]
    PlyF32,
    /// XYZ text: `x y z` lines to the micrometre (6 decimals), no header;
    /// with the source's intensity, `x y z intensity` lines under that
    /// header line.
    Xyz,
}

impl OutFormat {
    /// Whether the format has an intensity field (LAS and LAZ store it as a
    /// whole number 0–65535: values are rounded and clamped, so intensities
    /// scaled to 0–1 do not survive).
    pub fn holds_intensity(self) -> bool {
        matches!(
            self,
            OutFormat::Ply
                | OutFormat::PcdXyzi
                | OutFormat::PcdFastlio
                | OutFormat::PcdCompressed
                | OutFormat::PlyF32
                | OutFormat::Xyz
                | OutFormat::Las
                | OutFormat::Laz
        )
    }

    /// File extension without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            OutFormat::Ply | OutFormat::PlyF32 => "ply",
            OutFormat::Pcd
            | OutFormat::PcdAscii
            | OutFormat::PcdCompressed
            | OutFormat::PcdF32
            | OutFormat::PcdXyzi
            | OutFormat::PcdFastlio => "pcd",
            OutFormat::Las => "las",
            OutFormat::Laz => "laz",
            OutFormat::Xyz => "xyz",
        }
    }
}

/// A streaming writer: points are appended in blocks, the header's point count is
/// fixed up in [`CloudWriter::finish`], and the file appears under its final name
/// only then (written to a temporary sibling and renamed), so a crash never leaves
/// a half-written file.
pub struct CloudWriter {
    sink: Box<dyn Sink>,
}

/// One output format's encoder (implemented in `write.rs` and `las/sink.rs`).
trait Sink: Send {
    /// Appends points, with one intensity each when given (formats without
    /// an intensity field ignore it; those with one write 0 without it).
    fn write(&mut self, points: &[Point], intensity: Option<&[f32]>) -> Result<()>;
    fn finish(self: Box<Self>) -> Result<u64>;
}

impl CloudWriter {
    /// Starts writing `path` in `format`.
    pub fn create(path: &Path, format: OutFormat) -> Result<Self> {
        Self::create_with(path, format, false)
    }

    /// Starts writing `path` in `format`, with an intensity field where the
    /// format has an optional one (`ply`, `ply-f32`, `xyz`) when `intensity`; give
    /// the values with [`CloudWriter::write_intensity`].
    pub fn create_with(path: &Path, format: OutFormat, intensity: bool) -> Result<Self> {
        let sink: Box<dyn Sink> = match format {
            OutFormat::Ply => write::ply_sink(path, intensity)?,
            OutFormat::Pcd => write::pcd_sink(path)?,
            OutFormat::Las => las::las_sink(path, false)?,
            OutFormat::Laz => las::las_sink(path, true)?,
            OutFormat::PcdAscii => write::pcd_ascii_sink(path)?,
            OutFormat::PcdCompressed => write::pcd_compressed_sink(path, intensity)?,
            OutFormat::PcdF32 => write::pcd_f32_sink(path)?,
            OutFormat::PcdXyzi => write::pcd_xyzi_sink(path)?,
            OutFormat::PcdFastlio => write::pcd_fastlio_sink(path)?,
            OutFormat::PlyF32 => write::ply_f32_sink(path, intensity)?,
            OutFormat::Xyz => write::xyz_sink(path, intensity)?,
        };
        Ok(CloudWriter { sink })
    }
    /// Appends points.
    pub fn write(&mut self, points: &[Point]) -> Result<()> {
        self.sink.write(points, None)
    }
    /// Appends points with one intensity each (`intensity.len() ==
    /// points.len()`), kept by the formats that have an intensity field.
    pub fn write_intensity(&mut self, points: &[Point], intensity: &[f32]) -> Result<()> {
        self.sink.write(points, Some(intensity))
    }
    /// Completes the header and moves the file into place. Returns the point count.
    pub fn finish(self) -> Result<u64> {
        self.sink.finish()
    }
}

/// Writes a whole cloud in one call.
pub fn write(path: &Path, format: OutFormat, points: &[Point]) -> Result<()> {
    let mut w = CloudWriter::create(path, format)?;
    w.write(points)?;
    w.finish()?;
    Ok(())
}

/// Every point and intensity a file's reader gives through
/// [`PointReader::next_chunk_intensity`], and whether it has intensities
/// (the readers' tests share it). Each block's intensities are one a point,
/// or none.
#[cfg(test)]
pub(crate) fn read_with_intensity(path: &Path) -> (Vec<Point>, Vec<f32>, bool) {
    let mut r = open(path).unwrap();
    let has = r.has_intensity();
    let (mut pts, mut inten) = (Vec::new(), Vec::new());
    let (mut b, mut i) = (Vec::new(), Vec::new());
    while r.next_chunk_intensity(&mut b, &mut i).unwrap() {
        assert!(i.len() == b.len() || (!has && i.is_empty()));
        pts.extend_from_slice(&b);
        inten.extend_from_slice(&i);
    }
    (pts, inten, has)
}
