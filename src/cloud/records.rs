//! Fixed-size binary point records (binary PCD, fixed-stride binary PLY,
//! uncompressed LAS), read with positioned reads (`pread`) into small reused
//! buffers.
//!
//! Why not a memory map: on a page-cached file, mapping costs a page fault per
//! few pages and an `madvise` per block to give consumed pages back, about a
//! third of the whole read in the kernel; `pread` is the same single copy out of
//! the page cache that `cat` does. Each piece (~128 KiB of file) is read and
//! decoded by one thread into a buffer that stays in its cache, so a consumer
//! that works piece by piece (the loose crop) touches every byte once. A file
//! truncated while it is read gives a clear error instead of a `SIGBUS`.

use super::scalar::Scalar;
use super::{Batch, CloudInfo, PointReader, ReadStats, Region, Scratch};
use crate::{Error, Point, Result};
use rayon::prelude::*;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

mod decode;
use decode::decode;
#[cfg(test)]
use decode::f32_front_finite;

/// Bytes of file per piece (one thread's unit of work).
const PIECE_BYTES: usize = 128 << 10;
/// Pieces per batch (4 MiB of file): enough to keep every core busy between
/// two batches, and few, because the crop holds a batch's hits until the
/// next batch is written: on this 2-core VM a fresh page costs more than its
/// share of the read (128 pieces held 40 % more pages, for no speed).
const BATCH_PIECES: usize = 32;

/// Where one coordinate sits in a record and how it is stored.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Coord {
    /// Stored type.
    pub kind: Scalar,
    /// Byte offset inside the record.
    pub offset: usize,
}

/// The layout of a fixed-size record file.
#[derive(Debug, Clone)]
pub(super) struct Layout {
    /// Byte offset of the first record in the file.
    pub start: u64,
    /// Bytes per record.
    pub stride: usize,
    /// Records in the file (already checked against the file size).
    pub count: u64,
    /// x, y, z.
    pub coords: [Coord; 3],
    /// Values are big-endian (binary_big_endian PLY).
    pub big_endian: bool,
    /// LAS: `value = scale * raw + offset` per coordinate.
    pub transform: Option<[(f64, f64); 3]>,
    /// Where the point's intensity is, when it has one (for `convert`).
    pub intensity: Option<Coord>,
}

/// A streaming reader of fixed-size records.
pub(super) struct Records {
    file: File,
    path: PathBuf,
    info: CloudInfo,
    lay: Layout,
    /// Records per piece.
    piece: u64,
    /// One piece in `every` is read (1: all of them; more after a
    /// [`PointReader::hint_sample`]).
    every: u64,
    /// Bytes of records read (what a sample cost).
    fetched: AtomicU64,
    next: u64,
    points: AtomicU64,
    skipped: AtomicU64,
    /// Byte buffers for `next_chunk`'s parallel pieces.
    pool: Mutex<Vec<Vec<u8>>>,
}

impl Records {
    /// Checks `lay` against the record size and the file size (so nothing is
    /// allocated or read from an untrusted count that the file cannot hold).
    pub(super) fn new(file: File, path: &Path, info: CloudInfo, lay: Layout) -> Result<Records> {
        if lay.stride == 0 {
            return Err(Error::format(path, "point records have zero size"));
        }
        for c in lay.coords.iter().chain(&lay.intensity) {
            if c.offset
                .checked_add(c.kind.size())
                .is_none_or(|e| e > lay.stride)
            {
                return Err(Error::format(
                    path,
                    format!(
                        "a field at byte {} does not fit in a {}-byte record",
                        c.offset, lay.stride
                    ),
                ));
            }
        }
        let need = lay
            .count
            .checked_mul(lay.stride as u64)
            .and_then(|b| b.checked_add(lay.start));
        if need.is_none_or(|n| n > info.file_bytes) {
            return Err(Error::format(
                path,
                format!(
                    "truncated point data: the header declares {} points of {} bytes, the file holds {}",
                    lay.count,
                    lay.stride,
                    info.file_bytes.saturating_sub(lay.start) / lay.stride as u64
                ),
            ));
        }
        let piece = (PIECE_BYTES / lay.stride).max(1) as u64;
        Ok(Records {
            file,
            path: path.to_path_buf(),
            info,
            lay,
            piece,
            every: 1,
            fetched: AtomicU64::new(0),
            next: 0,
            points: AtomicU64::new(0),
            skipped: AtomicU64::new(0),
            pool: Mutex::new(Vec::new()),
        })
    }

    /// Reads records `first..first + n` into `bytes` (resized; never shrunk, so
    /// a reused buffer is not zero-filled again).
    fn read(&self, first: u64, n: usize, bytes: &mut Vec<u8>) -> Result<()> {
        let len = n * self.lay.stride;
        if bytes.len() < len {
            bytes.resize(len, 0);
        }
        let off = self.lay.start + first * self.lay.stride as u64;
        self.fetched.fetch_add(len as u64, Ordering::Relaxed);
        read_exact_at(&self.file, &mut bytes[..len], off).map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                Error::format(
                    &self.path,
                    format!(
                        "truncated point data: the file ends inside points {first}..{} (was it shortened while being read?)",
                        first + n as u64
                    ),
                )
            } else {
                Error::io(&self.path, e)
            }
        })
    }

    /// Decodes `n` records from `bytes` into `out` (finite points inside
    /// `region`, or all finite ones) and updates the counters; returns the
    /// number kept.
    fn decode(&self, bytes: &[u8], n: usize, out: &mut [Point], region: Option<&Region>) -> usize {
        let bytes = &bytes[..n * self.lay.stride];
        let (kept, finite) = match region {
            Some(reg) => decode(&self.lay, bytes, out, |x, y| reg.contains(x, y)),
            None => decode(&self.lay, bytes, out, |_, _| true),
        };
        self.points.fetch_add(finite as u64, Ordering::Relaxed);
        self.skipped
            .fetch_add((n - finite) as u64, Ordering::Relaxed);
        kept
    }
}

/// Positioned read of exactly `buf.len()` bytes.
#[cfg(unix)]
pub(super) fn read_exact_at(file: &File, buf: &mut [u8], off: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, buf, off)
}

/// Positioned read of exactly `buf.len()` bytes.
#[cfg(windows)]
pub(super) fn read_exact_at(file: &File, mut buf: &mut [u8], mut off: u64) -> std::io::Result<()> {
    while !buf.is_empty() {
        match std::os::windows::fs::FileExt::seek_read(file, buf, off) {
            Ok(0) => return Err(std::io::ErrorKind::UnexpectedEof.into()),
            Ok(k) => {
                buf = &mut buf[k..];
                off += k as u64;
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// One batch of pieces of a [`Records`] reader: records `first..first + n`,
/// of which the first piece in every `r.every` is read.
struct RecBatch<'a> {
    r: &'a Records,
    first: u64,
    n: u64,
}

impl Batch for RecBatch<'_> {
    fn pieces(&self) -> usize {
        self.n.div_ceil(self.r.piece * self.r.every) as usize
    }

    fn piece<'s>(&'s self, i: usize, scratch: &'s mut Scratch) -> Result<&'s [Point]> {
        self.decode_piece(i, scratch, None)
    }

    fn piece_within<'s>(
        &'s self,
        i: usize,
        scratch: &'s mut Scratch,
        region: &Region,
    ) -> Result<&'s [Point]> {
        self.decode_piece(i, scratch, Some(region))
    }
}

impl RecBatch<'_> {
    fn decode_piece<'s>(
        &self,
        i: usize,
        scratch: &'s mut Scratch,
        region: Option<&Region>,
    ) -> Result<&'s [Point]> {
        let from = i as u64 * self.r.piece * self.r.every;
        if from >= self.n {
            return Ok(&[]);
        }
        let n = (self.n - from).min(self.r.piece) as usize;
        self.r.read(self.first + from, n, &mut scratch.bytes)?;
        if scratch.points.len() < n {
            scratch.points.resize(n, Point::origin());
        }
        let kept = self
            .r
            .decode(&scratch.bytes, n, &mut scratch.points, region);
        Ok(&scratch.points[..kept])
    }
}

impl PointReader for Records {
    fn info(&self) -> &CloudInfo {
        &self.info
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        buf.clear();
        if self.every > 1 {
            // A sample: one piece at a time, the others skipped unread.
            let mut bytes = Vec::new();
            while buf.is_empty() && self.next < self.lay.count {
                let n = (self.lay.count - self.next).min(self.piece) as usize;
                self.read(self.next, n, &mut bytes)?;
                buf.resize(n, Point::origin());
                let kept = self.decode(&bytes, n, buf, None);
                buf.truncate(kept);
                self.next = (self.next + self.piece * self.every).min(self.lay.count);
            }
            return Ok(!buf.is_empty());
        }
        while buf.is_empty() && self.next < self.lay.count {
            let n = (self.lay.count - self.next).min(self.piece * BATCH_PIECES as u64);
            buf.resize(n as usize, Point::origin());
            let piece = self.piece as usize;
            let first = self.next;
            let this = &*self;
            let kept: Vec<Result<usize>> = buf
                .par_chunks_mut(piece)
                .enumerate()
                .map(|(t, out)| {
                    let mut bytes = this.pool.lock().map(|mut p| p.pop()).ok().flatten();
                    let mut b = bytes.take().unwrap_or_default();
                    let res = this
                        .read(first + (t * piece) as u64, out.len(), &mut b)
                        .map(|()| this.decode(&b, out.len(), out, None));
                    if let Ok(mut p) = this.pool.lock() {
                        p.push(b);
                    }
                    res
                })
                .collect();
            let mut w = 0;
            for (t, k) in kept.into_iter().enumerate() {
                let k = k?;
                let src = t * piece;
                if src != w {
                    buf.copy_within(src..src + k, w);
                }
                w += k;
            }
            buf.truncate(w);
            self.next += n;
        }
        Ok(!buf.is_empty())
    }

    fn has_intensity(&self) -> bool {
        self.lay.intensity.is_some()
    }

    /// One thread, a record at a time: the path of `convert`, not of the
    /// crop, so kept simple.
    fn next_chunk_intensity(&mut self, buf: &mut Vec<Point>, inten: &mut Vec<f32>) -> Result<bool> {
        let Some(ic) = self.lay.intensity.filter(|_| self.every == 1) else {
            inten.clear();
            return self.next_chunk(buf);
        };
        buf.clear();
        inten.clear();
        let lay = self.lay.clone();
        let mut bytes = self
            .pool
            .lock()
            .ok()
            .and_then(|mut p| p.pop())
            .unwrap_or_default();
        while buf.is_empty() && self.next < lay.count {
            let n = (lay.count - self.next).min(self.piece * 8) as usize;
            self.read(self.next, n, &mut bytes)?;
            let mut finite = 0u64;
            for r in bytes[..n * lay.stride].chunks_exact(lay.stride) {
                let v = [0, 1, 2].map(|i| {
                    let c = lay.coords[i];
                    let v = c.kind.read_at(r, c.offset, lay.big_endian);
                    lay.transform.map_or(v, |t| t[i].0 * v + t[i].1)
                });
                if v.iter().all(|c| c.is_finite()) {
                    finite += 1;
                    buf.push(Point::new(v[0], v[1], v[2]));
                    inten.push(ic.kind.read_at(r, ic.offset, lay.big_endian) as f32);
                }
            }
            self.points.fetch_add(finite, Ordering::Relaxed);
            self.skipped.fetch_add(n as u64 - finite, Ordering::Relaxed);
            self.next += n as u64;
        }
        if let Ok(mut p) = self.pool.lock() {
            p.push(bytes);
        }
        Ok(!buf.is_empty())
    }

    fn next_batch<'a>(
        &'a mut self,
        _buf: &'a mut Vec<Point>,
    ) -> Result<Option<Box<dyn Batch + 'a>>> {
        if self.next >= self.lay.count {
            return Ok(None);
        }
        let n = (self.lay.count - self.next).min(self.piece * BATCH_PIECES as u64 * self.every);
        let first = self.next;
        self.next += n;
        Ok(Some(Box::new(RecBatch { r: self, first, n })))
    }

    /// Every k-th piece (128 KiB of records): each piece holds points that
    /// are near one another in a map's file (a scan's stretch, a voxel's
    /// run), so the ground under them is seen whole, and the pieces come
    /// from the whole file.
    fn hint_sample(&mut self, points: u64) {
        if self.next > 0 || points == 0 {
            return;
        }
        self.every = (self.lay.count / points).max(1);
    }

    fn sampled(&self) -> Option<u64> {
        (self.every > 1).then(|| self.lay.start + self.fetched.load(Ordering::Relaxed))
    }

    fn float32_coords(&self) -> bool {
        self.lay.transform.is_none() && self.lay.coords.iter().any(|c| c.kind == Scalar::F32)
    }

    fn stats(&self) -> ReadStats {
        ReadStats {
            points: self.points.load(Ordering::Relaxed),
            skipped_nonfinite: self.skipped.load(Ordering::Relaxed),
        }
    }

    fn bytes_read(&self) -> u64 {
        if self.next >= self.lay.count {
            self.info.file_bytes
        } else {
            self.lay.start + self.next * self.lay.stride as u64
        }
    }
}

#[cfg(test)]
mod tests;
