//! The tests' reference for binary_compressed PCD: the whole block read,
//! decompressed at once and decoded in parallel, as the reader did before it
//! streamed. The streamed reader (`lzf_stream.rs`) must equal it bit for bit.

use super::compressed::compressed_sizes;
use super::header::Header;
use super::read_header;
use crate::cloud::ReadStats;
use crate::cloud::scalar::Scalar;
use crate::{Error, Point, Result};
use rayon::prelude::*;
use std::fs::File;
use std::io::Read;
use std::path::Path;

/// Points decoded per round (6 MiB of `Point`s).
pub(super) const CHUNK_POINTS: usize = 1 << 18;
/// Points decoded by one rayon task.
pub(super) const TASK_POINTS: usize = 1 << 16;

/// Reads a binary_compressed PCD whole: its finite points and the counters.
pub(super) fn read_whole(path: &Path) -> (Vec<[f64; 3]>, ReadStats) {
    let (mut file, file_bytes, h) = read_header(path).unwrap();
    let after = file_bytes.saturating_sub(h.data_offset as u64);
    let cols = read_compressed(path, &mut file, &h, after).unwrap();
    let f = |i: usize| &h.fields[h.xyz[i]];
    let lay = Layout {
        kind: [f(0).kind, f(1).kind, f(2).kind],
        // Column-wise: each field's values for all points lie together.
        base: [0, 1, 2].map(|i| h.points as usize * f(i).offset),
        stride: [0, 1, 2].map(|i| f(i).size * f(i).count),
    };
    let mut stats = ReadStats::default();
    let mut all = Vec::new();
    let mut buf = Vec::new();
    let mut next = 0usize;
    while next < h.points as usize {
        let n = (h.points as usize - next).min(CHUNK_POINTS);
        stats.skipped_nonfinite += decode_parallel(&cols, &lay, next, n, &mut buf);
        stats.points += buf.len() as u64;
        all.extend(buf.iter().map(|p| [p.x, p.y, p.z]));
        next += n;
    }
    (all, stats)
}

/// Reads and decompresses a PCL binary_compressed block, checking its sizes
/// against the header before allocating.
/// Only the tests use the whole-block path now (as the reference the streamed
/// reader must equal).
fn read_compressed(path: &Path, file: &mut File, h: &Header, after: u64) -> Result<Vec<u8>> {
    let (comp, raw) = compressed_sizes(path, file, h, after)?;
    if raw == 0 {
        return Ok(Vec::new());
    }
    let raw = usize::try_from(raw)
        .map_err(|_| Error::format(path, "binary_compressed block too large for this machine"))?;
    let mut packed = Vec::new();
    file.take(comp)
        .read_to_end(&mut packed)
        .map_err(|e| Error::io(path, e))?;
    let cols = lzf_decompress(&packed, raw)
        .map_err(|msg| Error::format(path, format!("binary_compressed data is corrupt: {msg}")))?;
    Ok(cols)
}

/// Where and how x, y, z of point `i` are stored: value `c` sits at
/// `base[c] + i * stride[c]` in the data slice.
#[derive(Debug, Clone, Copy)]
struct Layout {
    kind: [Scalar; 3],
    base: [usize; 3],
    stride: [usize; 3],
}

/// Decodes points `first..first + out.len()` into `out`, writing only finite
/// points, packed at the front; returns how many were written.
#[inline(always)]
fn decode_into<F: Fn(&[u8], usize) -> f64>(
    data: &[u8],
    lay: &Layout,
    first: usize,
    out: &mut [Point],
    rd: [F; 3],
) -> usize {
    let mut o = [
        lay.base[0] + first * lay.stride[0],
        lay.base[1] + first * lay.stride[1],
        lay.base[2] + first * lay.stride[2],
    ];
    let n = out.len();
    let mut w = 0;
    for _ in 0..n {
        let x = rd[0](data, o[0]);
        let y = rd[1](data, o[1]);
        let z = rd[2](data, o[2]);
        o[0] += lay.stride[0];
        o[1] += lay.stride[1];
        o[2] += lay.stride[2];
        if (x + y + z).is_finite() {
            out[w] = Point::new(x, y, z);
            w += 1;
        } else if x.is_finite() && y.is_finite() && z.is_finite() {
            // Sum overflowed; the coordinates themselves are fine.
            out[w] = Point::new(x, y, z);
            w += 1;
        }
    }
    w
}

fn decode_block(data: &[u8], lay: &Layout, first: usize, out: &mut [Point]) -> usize {
    let f32r = |b: &[u8], o: usize| Scalar::F32.read_at(b, o, false);
    let f64r = |b: &[u8], o: usize| Scalar::F64.read_at(b, o, false);
    match lay.kind {
        [Scalar::F32, Scalar::F32, Scalar::F32] => decode_into(data, lay, first, out, [f32r; 3]),
        [Scalar::F64, Scalar::F64, Scalar::F64] => decode_into(data, lay, first, out, [f64r; 3]),
        kinds => {
            let rd = |c: usize| move |b: &[u8], o: usize| kinds[c].read_at(b, o, false);
            decode_into(data, lay, first, out, [rd(0), rd(1), rd(2)])
        }
    }
}

/// Decodes points `first..first + n` in parallel into `buf` (its old contents
/// are overwritten, not cleared: zero-filling a reused buffer cost an eighth of
/// a binary read), keeping file order; returns the number of non-finite points
/// skipped.
fn decode_parallel(data: &[u8], lay: &Layout, first: usize, n: usize, buf: &mut Vec<Point>) -> u64 {
    buf.resize(n, Point::origin());
    let kept: Vec<usize> = buf
        .par_chunks_mut(TASK_POINTS)
        .enumerate()
        .map(|(t, out)| decode_block(data, lay, first + t * TASK_POINTS, out))
        .collect();
    // Close the gaps left by skipped points (only when there were any).
    let mut w = kept.first().copied().unwrap_or(0);
    for (t, &k) in kept.iter().enumerate().skip(1) {
        let src = t * TASK_POINTS;
        if src != w {
            buf.copy_within(src..src + k, w);
        }
        w += k;
    }
    buf.truncate(w);
    (n - w) as u64
}

/// LZF decoder writing into an exactly-sized buffer; refuses any stream whose
/// output would not be exactly `len` bytes.
pub(super) fn lzf_decompress(src: &[u8], len: usize) -> std::result::Result<Vec<u8>, String> {
    // Zeroed allocation is lazily backed by the OS; every byte is overwritten
    // (the final length check guarantees it).
    let mut out = vec![0u8; len];
    let too_long = || format!("output exceeds the declared {len} bytes");
    let mut i = 0usize;
    let mut o = 0usize;
    while i < src.len() {
        let ctrl = src[i] as usize;
        i += 1;
        if ctrl < 32 {
            let n = ctrl + 1;
            let lit = src
                .get(i..i + n)
                .ok_or("literal run past the end of the input")?;
            out.get_mut(o..o + n)
                .ok_or_else(too_long)?
                .copy_from_slice(lit);
            i += n;
            o += n;
        } else {
            let mut n = ctrl >> 5;
            if n == 7 {
                n += *src
                    .get(i)
                    .ok_or("back-reference past the end of the input")?
                    as usize;
                i += 1;
            }
            n += 2;
            let lo = *src
                .get(i)
                .ok_or("back-reference past the end of the input")? as usize;
            i += 1;
            let dist = ((ctrl & 0x1f) << 8) + lo + 1;
            if dist > o {
                return Err("back-reference before the start of the output".into());
            }
            if o + n > len {
                return Err(too_long());
            }
            let start = o - dist;
            if dist >= n {
                out.copy_within(start..start + n, o);
            } else {
                // Overlapping: a run that repeats the last `dist` bytes.
                for k in 0..n {
                    out[o + k] = out[start + k];
                }
            }
            o += n;
        }
    }
    if o != len {
        return Err(format!("decompressed to {o} bytes, header declares {len}"));
    }
    Ok(out)
}
