//! Where a map comes from: a file, or points already in memory (a caller that
//! built or loaded them itself, e.g. from numpy). Both stream through the same
//! [`PointReader`] interface, so the loose crop never knows the difference.

use super::{CloudInfo, Format, PointReader, ReadStats};
use crate::{Point, Result};
use std::path::Path;

/// A map to evaluate.
#[derive(Debug, Clone, Copy)]
pub enum MapSource<'a> {
    /// A map file of any supported format, recognised from its content.
    File(&'a Path),
    /// Points in the map frame, already in memory.
    Points(&'a [Point]),
}

impl<'a> MapSource<'a> {
    /// A streaming reader over the source (a file is opened again each time).
    pub fn open(&self) -> Result<Box<dyn PointReader + 'a>> {
        match *self {
            MapSource::File(p) => super::open(p),
            MapSource::Points(pts) => Ok(Box::new(MemoryReader::new(pts))),
        }
    }

    /// [`MapSource::open`] with every point moved by `motion` (none: as stored).
    pub fn open_moved(
        &self,
        motion: Option<&super::RigidMotion>,
    ) -> Result<Box<dyn PointReader + 'a>> {
        self.open_moved_within(motion, None)
    }

    /// [`MapSource::open_moved`] of a map whose z range (its own frame) is
    /// known: a consumer's region hint then reaches the file's reader even
    /// when the map is turned, so a tilted tiled map or COPC file is read
    /// only near the targets.
    pub(crate) fn open_moved_within(
        &self,
        motion: Option<&super::RigidMotion>,
        z_range: Option<[f64; 2]>,
    ) -> Result<Box<dyn PointReader + 'a>> {
        let inner = self.open()?;
        Ok(match motion {
            Some(m) if !m.is_identity() => Box::new(super::Moved {
                inner,
                motion: *m,
                z_range,
            }),
            _ => inner,
        })
    }

    /// How the source is named in results: the path as given, or `<memory>`.
    pub fn name(&self) -> String {
        match self {
            MapSource::File(p) => p.display().to_string(),
            MapSource::Points(_) => "<memory>".into(),
        }
    }
}

/// Points per block handed out by [`MemoryReader`]: the size file readers
/// use, so the crop's batching behaves alike.
const BLOCK: usize = 1 << 16;

/// A [`PointReader`] over a slice: non-finite points are skipped and counted
/// as a file reader would.
pub struct MemoryReader<'a> {
    pts: &'a [Point],
    pos: usize,
    info: CloudInfo,
    stats: ReadStats,
}

impl<'a> MemoryReader<'a> {
    /// A reader over `pts`.
    pub fn new(pts: &'a [Point]) -> Self {
        MemoryReader {
            pts,
            pos: 0,
            info: CloudInfo {
                format: Format::Memory,
                declared_points: Some(pts.len() as u64),
                file_bytes: 0,
            },
            stats: ReadStats::default(),
        }
    }
}

impl PointReader for MemoryReader<'_> {
    fn info(&self) -> &CloudInfo {
        &self.info
    }
    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        buf.clear();
        if self.pos >= self.pts.len() {
            return Ok(false);
        }
        let end = (self.pos + BLOCK).min(self.pts.len());
        for p in &self.pts[self.pos..end] {
            if p.coords.iter().all(|v| v.is_finite()) {
                buf.push(*p);
            } else {
                self.stats.skipped_nonfinite += 1;
            }
        }
        self.stats.points += buf.len() as u64;
        self.pos = end;
        Ok(true)
    }
    fn stats(&self) -> ReadStats {
        self.stats
    }
    fn bytes_read(&self) -> u64 {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_reader_skips_and_counts_non_finite() {
        let mut pts: Vec<Point> = (0..200_000)
            .map(|i| Point::new(i as f64, 0.0, 1.0))
            .collect();
        pts[7].y = f64::NAN;
        pts[150_000].z = f64::INFINITY;
        let mut r = MapSource::Points(&pts).open().unwrap();
        let (mut buf, mut n) = (Vec::new(), 0);
        while r.next_chunk(&mut buf).unwrap() {
            n += buf.len();
        }
        assert_eq!(n, 199_998);
        assert_eq!(r.stats().points, 199_998);
        assert_eq!(r.stats().skipped_nonfinite, 2);
    }
}
