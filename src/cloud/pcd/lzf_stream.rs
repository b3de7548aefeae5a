//! binary_compressed PCD, streamed.
//!
//! PCL stores such a cloud as ONE LZF stream of the column-wise data: all
//! values of the first field, then all of the second, and so on. x, y and z of
//! a point are therefore far apart in the stream, and an LZF stream can only be
//! decoded from its start. What makes streaming possible is that an LZF
//! back-reference reaches at most 8 KiB back: decoding can resume at any token
//! boundary given the 8 KiB of output before it.
//!
//! So the reader works in two passes:
//! 1. at open, one sequential decode through the stream (up to the end of the
//!    last coordinate column) keeps only a sliding window and records, for
//!    every chunk of `P` points and every coordinate, a checkpoint: the input
//!    and output positions of the token boundary at or before the chunk's first
//!    value, plus the 8 KiB of output before it;
//! 2. each chunk is then decoded independently (in parallel) from its three
//!    checkpoints, producing x, y and z of its `P` points.
//!
//! Memory bound: at most 3 x 1025 checkpoints of 8 KiB (≈ 25 MiB; 4 x, ≈ 33
//! MiB, once the intensity is read: `P` grows
//! with the cloud beyond 64 Ki points per chunk x 1024 chunks) plus, per
//! thread, the three decoded columns of one chunk; never the decompressed
//! cloud. The price is a second decode of the coordinate columns (pass 1 is
//! sequential, pass 2 parallel). The intensity (for checkerboard boards) is a
//! fourth column whose checkpoints a pass 1 of its own records the first time
//! a read asks for it, so reads of the coordinates alone never decode it.

use crate::cloud::records::read_exact_at;
use crate::cloud::scalar::Scalar;
use crate::cloud::{Batch, CloudInfo, PointReader, ReadStats, Scratch};
use crate::{Error, Point, Result};
use rayon::prelude::*;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Farthest an LZF back-reference reaches.
const WINDOW: usize = 8192;
/// Fewest points per chunk.
const MIN_CHUNK: u64 = 1 << 16;
/// Most chunks (bounds the checkpoints' memory).
const MAX_CHUNKS: u64 = 1024;
/// Compressed bytes read per refill in pass 1.
const IN_BLOCK: usize = 1 << 20;
/// Output kept in pass 1's sliding buffer before it is shifted down.
const OUT_BLOCK: usize = 1 << 20;
/// Chunks per batch.
const BATCH_CHUNKS: usize = 16;
/// Longest LZF token in input bytes (a 32-byte literal run and its control byte).
const MAX_TOKEN_IN: u64 = 33;

/// One coordinate column: value `i` is at `base + i * stride` in the
/// decompressed stream.
#[derive(Debug, Clone, Copy)]
pub(super) struct Column {
    pub kind: Scalar,
    pub base: u64,
    pub stride: u64,
}

/// Where decoding can resume.
#[derive(Debug, Clone, Default)]
struct Checkpoint {
    /// Input offset (in the compressed stream) of a token boundary.
    input: u64,
    /// Output offset of that boundary.
    output: u64,
    /// The output bytes just before `output` (up to [`WINDOW`]).
    history: Vec<u8>,
}

/// The next token at `src[i..]`: (input bytes, output bytes), or why not.
#[inline(always)]
fn token(src: &[u8], i: usize) -> std::result::Result<(usize, usize), &'static str> {
    let ctrl = *src.get(i).ok_or("input ends inside a token")? as usize;
    if ctrl < 32 {
        Ok((1 + ctrl + 1, ctrl + 1))
    } else {
        let mut n = ctrl >> 5;
        let mut len = 2;
        if n == 7 {
            n += *src.get(i + 1).ok_or("input ends inside a back-reference")? as usize;
            len = 3;
        }
        Ok((len, n + 2))
    }
}

/// Applies the token at `src[i..]` (already measured by [`token`]) to `out`.
#[inline(always)]
fn apply(
    src: &[u8],
    i: usize,
    tin: usize,
    tout: usize,
    out: &mut Vec<u8>,
) -> std::result::Result<(), &'static str> {
    let ctrl = src[i] as usize;
    if ctrl < 32 {
        let lit = src
            .get(i + 1..i + tin)
            .ok_or("literal run past the end of the input")?;
        out.extend_from_slice(lit);
    } else {
        let lo = *src
            .get(i + tin - 1)
            .ok_or("back-reference past the end of the input")? as usize;
        let dist = ((ctrl & 0x1f) << 8) + lo + 1;
        let o = out.len();
        if dist > o {
            return Err("back-reference before the start of the output");
        }
        let start = o - dist;
        if dist >= tout {
            out.extend_from_within(start..start + tout);
        } else {
            out.reserve(tout);
            for k in 0..tout {
                let b = out[start + k];
                out.push(b);
            }
        }
    }
    Ok(())
}

/// A streamed binary_compressed PCD.
pub(super) struct LzfColumns {
    file: File,
    path: PathBuf,
    info: CloudInfo,
    /// File offset of the compressed stream.
    start: u64,
    /// Compressed bytes.
    comp: u64,
    /// Decompressed bytes.
    raw: u64,
    points: u64,
    /// x, y and z, then the intensity when the cloud has one.
    cols: Vec<Column>,
    /// Points per chunk.
    chunk: u64,
    /// `cps[c][j]`: resume point for column `c` at the start of chunk `j`
    /// (`j` up to and including the number of chunks: the last marks the
    /// end). x, y and z's from the open; the intensity's from the first
    /// read that asks for it (a pass through the stream that only the
    /// boards' pass pays for).
    cps: Vec<Vec<Checkpoint>>,
    next_chunk: u64,
    kept: AtomicU64,
    skipped: AtomicU64,
}

fn corrupt(path: &Path, at: u64, msg: &str) -> Error {
    Error::format(
        path,
        format!("binary_compressed data is corrupt at compressed byte {at}: {msg}"),
    )
}

impl LzfColumns {
    /// Runs pass 1 for the coordinates. `comp` and `raw` were checked
    /// against the file and the header by the caller; `intensity` is the
    /// intensity's column, when the cloud has one.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn open(
        file: File,
        path: &Path,
        info: CloudInfo,
        start: u64,
        comp: u64,
        raw: u64,
        points: u64,
        coords: [Column; 3],
        intensity: Option<Column>,
    ) -> Result<LzfColumns> {
        let chunk = points.div_ceil(MAX_CHUNKS).max(MIN_CHUNK);
        let mut r = LzfColumns {
            file,
            path: path.to_path_buf(),
            info,
            start,
            comp,
            raw,
            points,
            cols: coords.into_iter().chain(intensity).collect(),
            chunk,
            cps: Vec::new(),
            next_chunk: 0,
            kept: AtomicU64::new(0),
            skipped: AtomicU64::new(0),
        };
        r.cps = r.checkpoints(&coords)?;
        Ok(r)
    }

    /// Pass 1 over the stream, as far as the last of `cols` ends: for each
    /// column, the checkpoint of each chunk's first value (`[c][j]`).
    fn checkpoints(&self, cols: &[Column]) -> Result<Vec<Vec<Checkpoint>>> {
        let (path, comp, raw, points, chunk) =
            (&self.path, self.comp, self.raw, self.points, self.chunk);
        let nchunks = points.div_ceil(chunk);
        // Targets: the output offset of each chunk's first value, per column.
        let mut targets: Vec<(u64, usize, usize)> = Vec::new();
        for (c, col) in cols.iter().enumerate() {
            for j in 0..=nchunks {
                let at = col.base + (j * chunk).min(points) * col.stride;
                if at > raw {
                    return Err(Error::format(
                        path,
                        "binary_compressed column lies past the data",
                    ));
                }
                targets.push((at, j as usize, c));
            }
        }
        targets.sort_unstable();
        let mut cps = vec![vec![Checkpoint::default(); nchunks as usize + 1]; cols.len()];
        let end = targets.last().map_or(0, |t| t.0);
        // Decode sequentially into a sliding window.
        let mut input = vec![0u8; IN_BLOCK];
        let mut in_len = 0usize; // valid bytes in `input`
        let mut in_base = 0u64; // stream offset of input[0]
        let mut i = 0usize;
        let mut out: Vec<u8> = Vec::with_capacity(OUT_BLOCK + WINDOW + 300);
        let mut out_base = 0u64; // stream output offset of out[0]
        let mut t = 0usize;
        loop {
            // Keep at least one whole token in the input buffer.
            if in_len - i < MAX_TOKEN_IN as usize && in_base + (in_len as u64) < comp {
                input.copy_within(i..in_len, 0);
                in_len -= i;
                in_base += i as u64;
                i = 0;
                let want = ((comp - in_base) as usize).min(IN_BLOCK) - in_len;
                read_exact_at(
                    &self.file,
                    &mut input[in_len..in_len + want],
                    self.start + in_base + in_len as u64,
                )
                .map_err(|e| read_err(path, e))?;
                in_len += want;
            }
            let o = out_base + out.len() as u64;
            let at_end = in_base + i as u64 >= comp;
            let tok = if at_end {
                None
            } else {
                Some(token(&input[..in_len], i).map_err(|m| corrupt(path, in_base + i as u64, m))?)
            };
            // Record every target this token boundary is the last one before.
            while let Some(&(target, j, c)) = targets.get(t) {
                let covers = match tok {
                    Some((_, tout)) => o + tout as u64 > target,
                    None => true,
                };
                if !covers {
                    break;
                }
                if target > o && tok.is_none() {
                    return Err(Error::format(
                        path,
                        format!(
                            "binary_compressed data decompresses to {o} bytes, header declares {raw}"
                        ),
                    ));
                }
                let h = out.len().min(WINDOW);
                cps[c][j] = Checkpoint {
                    input: in_base + i as u64,
                    output: o,
                    history: out[out.len() - h..].to_vec(),
                };
                t += 1;
            }
            if t == targets.len() || o >= end && tok.is_none() {
                break;
            }
            let Some((tin, tout)) = tok else { break };
            apply(&input[..in_len], i, tin, tout, &mut out)
                .map_err(|m| corrupt(path, in_base + i as u64, m))?;
            i += tin;
            if out_base + out.len() as u64 > raw {
                return Err(corrupt(
                    path,
                    in_base + i as u64,
                    "output exceeds the declared size",
                ));
            }
            if out.len() > OUT_BLOCK + WINDOW {
                let drop = out.len() - WINDOW;
                out.drain(..drop);
                out_base += drop as u64;
            }
        }
        if t < targets.len() {
            return Err(Error::format(
                path,
                "binary_compressed data ends before the columns read",
            ));
        }
        Ok(cps)
    }

    fn nchunks(&self) -> u64 {
        self.points.div_ceil(self.chunk)
    }

    /// Decodes column `c` of chunk `j` into `out` (values only, `stride` bytes
    /// per point); `input` is scratch for the compressed bytes.
    fn column(&self, j: usize, c: usize, input: &mut Vec<u8>, out: &mut Vec<u8>) -> Result<usize> {
        let (cp, next) = (&self.cps[c][j], &self.cps[c][j + 1]);
        let col = self.cols[c];
        let first = j as u64 * self.chunk;
        let n = (self.points - first).min(self.chunk);
        let want_from = col.base + first * col.stride;
        let want_to = want_from + n * col.stride;
        let in_to = (next.input + MAX_TOKEN_IN).min(self.comp);
        let in_len = (in_to - cp.input) as usize;
        input.resize(in_len, 0);
        read_exact_at(&self.file, input, self.start + cp.input)
            .map_err(|e| read_err(&self.path, e))?;
        out.clear();
        out.extend_from_slice(&cp.history);
        let hist = cp.history.len();
        let mut i = 0usize;
        while cp.output + ((out.len() - hist) as u64) < want_to {
            let at = cp.input + i as u64;
            let (tin, tout) = token(input, i).map_err(|m| corrupt(&self.path, at, m))?;
            apply(input, i, tin, tout, out).map_err(|m| corrupt(&self.path, at, m))?;
            i += tin;
        }
        // Drop the history and anything before the chunk's first value.
        let skip = hist + (want_from - cp.output) as usize;
        out.drain(..skip);
        out.truncate((n * col.stride) as usize);
        Ok(n as usize)
    }

    /// Decodes chunk `j` into `points` (finite points only); returns how
    /// many. With `intensity`, each kept point's intensity goes there too
    /// (the intensity's checkpoints must be in place).
    fn chunk_points(
        &self,
        j: usize,
        s: &mut Scratch,
        intensity: Option<&mut Vec<f32>>,
    ) -> Result<usize> {
        let Scratch {
            bytes,
            points,
            cols,
            ..
        } = s;
        let ncols = if intensity.is_some() { 4 } else { 3 };
        cols.resize_with(ncols, Vec::new);
        let mut n = 0;
        for c in 0..ncols {
            n = self.column(j, c, bytes, &mut cols[c])?;
        }
        points.clear();
        points.reserve(n);
        let [k0, k1, k2] = [0, 1, 2].map(|c| self.cols[c].kind);
        let [s0, s1, s2] = [0, 1, 2].map(|c| self.cols[c].stride as usize);
        let (a, b, d) = (&cols[0], &cols[1], &cols[2]);
        let at = |i: usize| {
            let p = Point::new(
                k0.read_at(a, i * s0, false),
                k1.read_at(b, i * s1, false),
                k2.read_at(d, i * s2, false),
            );
            (p.x.is_finite() && p.y.is_finite() && p.z.is_finite()).then_some(p)
        };
        match intensity {
            None => points.extend((0..n).filter_map(at)),
            Some(inten) => {
                inten.clear();
                let (ki, si) = (self.cols[3].kind, self.cols[3].stride as usize);
                let e = &cols[3];
                for i in 0..n {
                    if let Some(p) = at(i) {
                        points.push(p);
                        inten.push(ki.read_at(e, i * si, false) as f32);
                    }
                }
            }
        }
        self.kept.fetch_add(points.len() as u64, Ordering::Relaxed);
        self.skipped
            .fetch_add((n - points.len()) as u64, Ordering::Relaxed);
        Ok(points.len())
    }

    /// The next batch of chunks, decoded in parallel, into `buf` (and their
    /// intensities into `inten` when given).
    fn fill(&mut self, buf: &mut Vec<Point>, mut inten: Option<&mut Vec<f32>>) -> Result<bool> {
        buf.clear();
        if let Some(v) = inten.as_deref_mut() {
            v.clear();
        }
        let with = inten.is_some();
        while buf.is_empty() && self.next_chunk < self.nchunks() {
            let first = self.next_chunk as usize;
            let n = (self.nchunks() - self.next_chunk).min(BATCH_CHUNKS as u64) as usize;
            let this = &*self;
            let parts: Vec<Result<(Vec<Point>, Vec<f32>)>> = (first..first + n)
                .into_par_iter()
                .map(|j| {
                    let mut s = Scratch::default();
                    let mut i = Vec::new();
                    this.chunk_points(j, &mut s, with.then_some(&mut i))?;
                    Ok((s.points, i))
                })
                .collect();
            for p in parts {
                let (pts, i) = p?;
                buf.extend_from_slice(&pts);
                if let Some(v) = inten.as_deref_mut() {
                    v.extend_from_slice(&i);
                }
            }
            self.next_chunk += n as u64;
        }
        Ok(!buf.is_empty())
    }
}

fn read_err(path: &Path, e: std::io::Error) -> Error {
    if e.kind() == std::io::ErrorKind::UnexpectedEof {
        Error::format(
            path,
            "truncated binary_compressed data (was the file shortened while being read?)",
        )
    } else {
        Error::io(path, e)
    }
}

struct LzfBatch<'a> {
    r: &'a LzfColumns,
    first: usize,
    n: usize,
}

impl Batch for LzfBatch<'_> {
    fn pieces(&self) -> usize {
        self.n
    }
    fn piece<'s>(&'s self, i: usize, s: &'s mut Scratch) -> Result<&'s [Point]> {
        if i >= self.n {
            return Ok(&[]);
        }
        let k = self.r.chunk_points(self.first + i, s, None)?;
        Ok(&s.points[..k])
    }
}

impl PointReader for LzfColumns {
    fn info(&self) -> &CloudInfo {
        &self.info
    }
    fn float32_coords(&self) -> bool {
        // x, y and z only: a float intensity beside double coordinates
        // says nothing of their precision.
        self.cols[..3].iter().any(|c| c.kind == Scalar::F32)
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        self.fill(buf, None)
    }

    fn has_intensity(&self) -> bool {
        self.cols.len() == 4
    }

    fn next_chunk_intensity(&mut self, buf: &mut Vec<Point>, inten: &mut Vec<f32>) -> Result<bool> {
        if self.cols.len() < 4 {
            inten.clear();
            return self.next_chunk(buf);
        }
        if self.cps.len() < 4 {
            let more = self.checkpoints(&self.cols[3..])?;
            self.cps.extend(more);
        }
        self.fill(buf, Some(inten))
    }

    fn next_batch<'a>(
        &'a mut self,
        _buf: &'a mut Vec<Point>,
    ) -> Result<Option<Box<dyn Batch + 'a>>> {
        if self.next_chunk >= self.nchunks() {
            return Ok(None);
        }
        let first = self.next_chunk as usize;
        let n = (self.nchunks() - self.next_chunk).min(BATCH_CHUNKS as u64) as usize;
        self.next_chunk += n as u64;
        Ok(Some(Box::new(LzfBatch { r: self, first, n })))
    }

    fn stats(&self) -> ReadStats {
        ReadStats {
            points: self.kept.load(Ordering::Relaxed),
            skipped_nonfinite: self.skipped.load(Ordering::Relaxed),
        }
    }

    fn bytes_read(&self) -> u64 {
        let n = self.nchunks().max(1);
        self.start + self.comp * self.next_chunk.min(n) / n
    }
}
