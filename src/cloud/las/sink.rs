//! The LAS/LAZ writer: LAS 1.2 point format 0 at millimetre scale, through
//! the `las` crate, under a temporary name until finished.

use super::las_err;
use crate::cloud::Sink;
use crate::{Error, Point, Result};
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A file that turns into a no-op once aborted, so the `las` writer's drop (which
/// rewrites the header) cannot fail or panic after we gave up on the file.
struct Abortable {
    inner: BufWriter<File>,
    abort: Arc<AtomicBool>,
}

impl Write for Abortable {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        if self.abort.load(Ordering::Relaxed) {
            Ok(b.len())
        } else {
            self.inner.write(b)
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        if self.abort.load(Ordering::Relaxed) {
            Ok(())
        } else {
            self.inner.flush()
        }
    }
}

impl Seek for Abortable {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        if self.abort.load(Ordering::Relaxed) {
            Ok(0)
        } else {
            self.inner.seek(pos)
        }
    }
}

/// Streaming LAS 1.2 point format 0 writer, millimetre scale, offset from the
/// first point (floored to 1 km) so projected coordinates keep full precision.
struct LasSink {
    path: PathBuf,
    tmp: PathBuf,
    file: Option<File>,
    writer: Option<las::Writer<Abortable>>,
    abort: Arc<AtomicBool>,
    pd: Option<las::PointData>,
    offset: [f64; 3],
    count: u64,
    finished: bool,
    /// Write LAZ.
    compressed: bool,
}

/// Scale of written coordinates (metres per unit).
const SCALE: f64 = 0.001;

/// Starts a LAS writer.
pub(in crate::cloud) fn las_sink(path: &Path, compressed: bool) -> Result<Box<dyn Sink>> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.partial"));
    let file = File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
    Ok(Box::new(LasSink {
        path: path.to_path_buf(),
        tmp,
        file: Some(file),
        writer: None,
        abort: Arc::new(AtomicBool::new(false)),
        pd: None,
        offset: [0.0; 3],
        count: 0,
        finished: false,
        compressed,
    }))
}

impl LasSink {
    fn start(&mut self, first: Option<&Point>) -> Result<()> {
        if let Some(p) = first {
            self.offset = [p.x, p.y, p.z].map(|c| (c / 1000.0).floor() * 1000.0);
        }
        let mut b = las::Builder::from((1, 2));
        b.point_format = las::point::Format::new(0).map_err(|e| las_err(&self.path, e))?;
        b.point_format.is_compressed = self.compressed;
        b.generating_software = format!("mapgauge {}", env!("CARGO_PKG_VERSION"));
        b.system_identifier = "mapgauge".into();
        b.date = None;
        let tr = |o: f64| las::Transform {
            scale: SCALE,
            offset: o,
        };
        b.transforms = las::Vector {
            x: tr(self.offset[0]),
            y: tr(self.offset[1]),
            z: tr(self.offset[2]),
        };
        let header = b.into_header().map_err(|e| las_err(&self.path, e))?;
        let file = self
            .file
            .take()
            .ok_or_else(|| Error::format(&self.path, "LAS writer reused"))?;
        let w = Abortable {
            inner: BufWriter::with_capacity(1 << 20, file),
            abort: self.abort.clone(),
        };
        let writer = las::Writer::new(w, header).map_err(|e| las_err(&self.tmp, e))?;
        self.pd = Some(
            las::PointDataBuilder::new()
                .for_header(writer.header())
                .build(),
        );
        self.writer = Some(writer);
        Ok(())
    }
}

impl Sink for LasSink {
    fn write(&mut self, points: &[Point], intensity: Option<&[f32]>) -> Result<()> {
        if points.is_empty() {
            return Ok(());
        }
        if self.writer.is_none() {
            self.start(
                points
                    .iter()
                    .find(|p| p.x.is_finite() && p.y.is_finite() && p.z.is_finite()),
            )?;
        }
        let (Some(writer), Some(pd)) = (self.writer.as_mut(), self.pd.as_mut()) else {
            return Err(Error::format(&self.path, "LAS writer not started"));
        };
        let bytes = pd.resize_for(points.len());
        for (k, (p, rec)) in points.iter().zip(bytes.chunks_exact_mut(20)).enumerate() {
            let mut q = [0i32; 3];
            for (c, v) in [p.x, p.y, p.z].into_iter().enumerate() {
                let u = ((v - self.offset[c]) / SCALE).round();
                if !(u >= i32::MIN as f64 && u <= i32::MAX as f64) {
                    return Err(Error::format(
                        &self.path,
                        format!(
                            "point {}: ({}, {}, {}) is not finite or lies over 2000 km from the first point; LAS millimetre coordinates cannot hold it",
                            self.count + k as u64,
                            p.x,
                            p.y,
                            p.z
                        ),
                    ));
                }
                q[c] = u as i32;
            }
            rec[0..4].copy_from_slice(&q[0].to_le_bytes());
            rec[4..8].copy_from_slice(&q[1].to_le_bytes());
            rec[8..12].copy_from_slice(&q[2].to_le_bytes());
            // LAS stores intensity as a whole number: rounded, and clamped
            // to its 16 bits (a missing or broken value is 0).
            let i = intensity.and_then(|v| v.get(k)).copied().unwrap_or(0.0);
            let i = if i.is_finite() {
                i.round().clamp(0.0, 65535.0) as u16
            } else {
                0
            };
            rec[12..14].copy_from_slice(&i.to_le_bytes());
            rec[14] = 0b0000_1001; // return 1 of 1
            rec[15] = 1; // classification: unclassified
            rec[16] = 0; // scan angle
            rec[17] = 0; // user data
            rec[18..20].copy_from_slice(&0u16.to_le_bytes()); // point source id
        }
        writer.write_points(pd).map_err(|e| las_err(&self.tmp, e))?;
        self.count += points.len() as u64;
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<u64> {
        if self.writer.is_none() {
            self.start(None)?;
        }
        let Some(writer) = self.writer.take() else {
            return Err(Error::format(&self.path, "LAS writer not started"));
        };
        let mut inner = writer.into_inner().map_err(|e| las_err(&self.tmp, e))?;
        inner.inner.flush().map_err(|e| Error::io(&self.tmp, e))?;
        drop(inner);
        std::fs::rename(&self.tmp, &self.path).map_err(|e| Error::io(&self.path, e))?;
        self.finished = true;
        Ok(self.count)
    }
}

impl Drop for LasSink {
    fn drop(&mut self) {
        if !self.finished {
            self.abort.store(true, Ordering::Relaxed);
            self.writer = None;
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}
