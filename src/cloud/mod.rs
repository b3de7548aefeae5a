//! Point clouds in and out: streaming readers for every common map format and
//! writers for crops.
//!
//! Readers are pull-based: [`open`] sniffs the format from the file's first
//! bytes (the extension is only a tie-breaker), and [`PointReader::next_chunk`]
//! fills a caller-owned buffer with the next block of points, so memory stays
//! bounded whatever the map's size. Non-finite points are skipped and counted.

use crate::{Error, Point, Result};
use std::path::Path;

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

/// Counters a reader keeps while streaming.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReadStats {
    /// Points handed to the caller.
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
}

/// Opens a map of any supported format, recognised from its content.
pub fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    let _ = path;
    Err(Error::Input("cloud::open: not yet implemented".into()))
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
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum OutFormat {
    /// Binary little-endian PLY with double x, y, z.
    Ply,
    /// Binary PCD v0.7 with double x, y, z.
    Pcd,
    /// LAS 1.2, point format 0 (millimetre scale).
    Las,
}

impl OutFormat {
    /// File extension without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            OutFormat::Ply => "ply",
            OutFormat::Pcd => "pcd",
            OutFormat::Las => "las",
        }
    }
}

/// A streaming writer: points are appended in blocks, the header's point count is
/// fixed up in [`CloudWriter::finish`], and the file appears under its final name
/// only then (written to a temporary sibling and renamed), so a crash never leaves
/// a half-written file.
pub struct CloudWriter {
    _private: (),
}

impl CloudWriter {
    /// Starts writing `path` in `format`.
    pub fn create(path: &Path, format: OutFormat) -> Result<Self> {
        let _ = (path, format);
        Err(Error::Input("CloudWriter: not yet implemented".into()))
    }
    /// Appends points.
    pub fn write(&mut self, points: &[Point]) -> Result<()> {
        let _ = points;
        Ok(())
    }
    /// Completes the header and moves the file into place. Returns the point count.
    pub fn finish(self) -> Result<u64> {
        Ok(0)
    }
}

/// Writes a whole cloud in one call.
pub fn write(path: &Path, format: OutFormat, points: &[Point]) -> Result<()> {
    let mut w = CloudWriter::create(path, format)?;
    w.write(points)?;
    w.finish()?;
    Ok(())
}
