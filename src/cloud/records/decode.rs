//! Decoding fixed-size records into points: the per-point hot loop of every
//! `pread` reader (binary PCD, fixed-stride binary PLY, uncompressed LAS).
//!
//! Why its own file: the loops are tuned by instruction count (the common
//! layouts each get a monomorphic loop and a vectorised finiteness scan),
//! apart from how the reader batches and reads its pieces (`records.rs`).

use super::Layout;
use crate::Point;
use crate::cloud::scalar::Scalar;

#[inline(always)]
fn get<const N: usize>(r: &[u8], o: usize) -> [u8; N] {
    let mut a = [0u8; N];
    a.copy_from_slice(&r[o..o + N]);
    a
}

/// Decodes every record of `bytes` (a whole number of records) into `out`,
/// keeping the finite points whose `keep(x, y)` holds, packed at the front in
/// file order; returns how many were written and how many were finite. The
/// common layouts get their own monomorphic loop, and `keep` is tested on the
/// coordinates before a point is built (the loose crop drops ~95 % there).
#[inline(always)]
pub(super) fn decode(
    lay: &Layout,
    bytes: &[u8],
    out: &mut [Point],
    keep: impl Fn(f64, f64) -> bool,
) -> (usize, usize) {
    let o = lay.coords.map(|c| c.offset);
    let kinds = lay.coords.map(|c| c.kind);
    let stride = lay.stride;
    let n = (bytes.len() / stride.max(1)).min(out.len());
    let bytes = &bytes[..n * stride];
    match (lay.transform, lay.big_endian, kinds) {
        (None, false, [Scalar::F64, Scalar::F64, Scalar::F64])
            if stride == 24 && o == [0, 8, 16] =>
        {
            // x, y, z and nothing else (what mapgauge, PCL and most SLAM
            // tools write): constant offsets, no bounds checks, and the
            // non-finite scan runs over a flat array of words.
            let clean = words_finite(bytes);
            pack(out, bytes, 24, keep, clean, |r, i| {
                f64::from_le_bytes(get::<8>(r, 8 * i))
            })
        }
        (None, false, [Scalar::F64, Scalar::F64, Scalar::F64]) => {
            let read = |r: &[u8], i: usize| f64::from_le_bytes(get::<8>(r, o[i]));
            let clean = all_finite(bytes, stride, read);
            pack(out, bytes, stride, keep, clean, read)
        }
        (None, false, [Scalar::F32, Scalar::F32, Scalar::F32]) if o == [0, 4, 8] => {
            // Float x, y, z first (every SLAM layout: LIO-SAM's 16 bytes,
            // FAST-LIO2's 32, PointXYZ and float PLY's 12, PointXYZRGB's
            // 16): the common strides get a loop of their own with constant
            // offsets and a vectorised non-finite scan, like the f64 path.
            match stride {
                12 => f32_front::<12>(bytes, out, keep),
                16 => f32_front::<16>(bytes, out, keep),
                32 => f32_front::<32>(bytes, out, keep),
                _ => {
                    let read = |r: &[u8], i: usize| f32::from_le_bytes(get::<4>(r, 4 * i)) as f64;
                    let clean = all_finite(bytes, stride, read);
                    pack(out, bytes, stride, keep, clean, read)
                }
            }
        }
        (None, false, [Scalar::F32, Scalar::F32, Scalar::F32]) => {
            let read = |r: &[u8], i: usize| f32::from_le_bytes(get::<4>(r, o[i])) as f64;
            let clean = all_finite(bytes, stride, read);
            pack(out, bytes, stride, keep, clean, read)
        }
        (Some(t), false, [Scalar::I32, Scalar::I32, Scalar::I32]) if o == [0, 4, 8] => {
            // LAS: X, Y, Z lead every point format, so constant offsets.
            let read = |r: &[u8], i: usize| {
                t[i].0 * f64::from(i32::from_le_bytes(get::<4>(r, 4 * i))) + t[i].1
            };
            let clean = t
                .iter()
                .all(|(s, o)| (s.abs() * 2_147_483_648.0 + o.abs()).is_finite());
            pack(out, bytes, stride, keep, clean, read)
        }
        (Some(t), false, [Scalar::I32, Scalar::I32, Scalar::I32]) => {
            // Integers scaled by finite factors are finite, whatever the
            // record holds, unless the header's scale or offset is huge.
            let read = |r: &[u8], i: usize| {
                t[i].0 * f64::from(i32::from_le_bytes(get::<4>(r, o[i]))) + t[i].1
            };
            let clean = t
                .iter()
                .all(|(s, o)| (s.abs() * 2_147_483_648.0 + o.abs()).is_finite());
            pack(out, bytes, stride, keep, clean, read)
        }
        (t, be, _) => pack(out, bytes, stride, keep, false, |r, i| {
            let v = kinds[i].read_at(r, o[i], be);
            match t {
                Some(t) => t[i].0 * v + t[i].1,
                None => v,
            }
        }),
    }
}

/// [`decode`] of `S`-byte records that start with float x, y, z.
#[inline(always)]
fn f32_front<const S: usize>(
    bytes: &[u8],
    out: &mut [Point],
    keep: impl Fn(f64, f64) -> bool,
) -> (usize, usize) {
    let clean = f32_front_finite::<S>(bytes);
    pack(out, bytes, S, keep, clean, |r, i| {
        f64::from(f32::from_le_bytes(get::<4>(r, 4 * i)))
    })
}

/// Whether the first three f32 words (x, y, z) of every `S`-byte record are
/// finite, whatever the other fields hold (a packed `rgb` with alpha 255 is a
/// NaN as a float, and must not count). One accumulator per word of the
/// record's first 16 bytes and no branch: a loop the compiler vectorises
/// (~6 instructions a record against ~20 for the per-record fold).
#[allow(
    clippy::eq_op,
    reason = "`v - v` is 0 for a finite v and NaN otherwise: a finiteness test without a branch"
)]
#[inline(never)]
pub(super) fn f32_front_finite<const S: usize>(bytes: &[u8]) -> bool {
    const { assert!(S % 4 == 0 && S >= 12) };
    if S == 12 {
        // Nothing but coordinates: one flat scan.
        let mut acc = 0u32;
        for w in bytes.chunks_exact(4) {
            let v = f32::from_le_bytes(get::<4>(w, 0));
            acc |= (v - v).to_bits();
        }
        return acc == 0;
    }
    // x, y, z and the word after them; that lane is dropped at the end.
    let mut acc = [0u32; 4];
    let head = |acc: &mut [u32; 4], r: &[u8]| {
        let head = get::<16>(r, 0);
        for (j, a) in acc.iter_mut().enumerate() {
            let v = f32::from_le_bytes(get::<4>(&head, 4 * j));
            *a |= (v - v).to_bits();
        }
    };
    // Four records a turn: the loop's own count and branch were a third of
    // its instructions.
    let mut quads = bytes.chunks_exact(4 * S);
    for q in &mut quads {
        for k in 0..4 {
            head(&mut acc, &q[k * S..]);
        }
    }
    for r in quads.remainder().chunks_exact(S) {
        head(&mut acc, r);
    }
    acc[0] | acc[1] | acc[2] == 0
}

/// Whether every 8-byte word of `bytes` is a finite f64: a loop the compiler
/// vectorises (a tenth of the time of a test per point).
#[allow(
    clippy::eq_op,
    reason = "`v - v` is 0 for a finite v and NaN otherwise: a finiteness test without a branch"
)]
#[inline(never)]
fn words_finite(bytes: &[u8]) -> bool {
    let mut acc = 0u64;
    for w in bytes.chunks_exact(8) {
        let v = f64::from_le_bytes(w.try_into().unwrap_or_default());
        acc |= (v - v).to_bits();
    }
    acc == 0
}

/// Whether every coordinate of every record is finite, without a branch per
/// record (`v - v` is 0 for finite `v` and NaN otherwise).
#[allow(
    clippy::eq_op,
    reason = "`v - v` is 0 for a finite v and NaN otherwise: a finiteness test without a branch"
)]
#[inline(always)]
fn all_finite(bytes: &[u8], stride: usize, read: impl Fn(&[u8], usize) -> f64) -> bool {
    bytes.chunks_exact(stride).fold(0u64, |acc, r| {
        let (x, y, z) = (read(r, 0), read(r, 1), read(r, 2));
        acc | ((x - x) + (y - y) + (z - z)).to_bits()
    }) == 0
}

/// Decodes records with `read(record, coordinate)`, writing the finite points
/// that `keep` accepts packed at the front of `out`; returns (written, finite).
/// `clean` says every coordinate is known to be finite, which takes the
/// finiteness test off the per-point path (z is then not even read for the
/// points `keep` rejects).
#[inline(always)]
fn pack(
    out: &mut [Point],
    bytes: &[u8],
    stride: usize,
    keep: impl Fn(f64, f64) -> bool,
    clean: bool,
    read: impl Fn(&[u8], usize) -> f64,
) -> (usize, usize) {
    let mut k = 0;
    if clean {
        for r in bytes.chunks_exact(stride) {
            let (x, y) = (read(r, 0), read(r, 1));
            if keep(x, y) {
                out[k] = Point::new(x, y, read(r, 2));
                k += 1;
            }
        }
        return (k, bytes.len() / stride);
    }
    let mut finite = 0;
    for r in bytes.chunks_exact(stride) {
        let (x, y, z) = (read(r, 0), read(r, 1), read(r, 2));
        // One sum is finite for almost every point; the three tests are only
        // needed when it is not (it can overflow).
        if !((x + y + z).is_finite() || (x.is_finite() && y.is_finite() && z.is_finite())) {
            continue;
        }
        finite += 1;
        if keep(x, y) {
            out[k] = Point::new(x, y, z);
            k += 1;
        }
    }
    (k, finite)
}
