//! PLY vertex data that the `pread` record reader cannot take: binary with
//! list properties (variable stride, walked sequentially) and ascii lines.

use super::header::{Prop, Xyz};
use crate::cloud::xyz::{LineBlocks, parse_f64};
use crate::cloud::{CloudInfo, PointReader, ReadStats};
use crate::{Error, Point, Result};
use memmap2::Mmap;
use std::path::{Path, PathBuf};

/// Points per `next_chunk` call.
pub(super) const CHUNK: usize = 1 << 19;

/// How the vertex data is read.
pub(super) enum Body {
    /// Binary with list properties: walked sequentially.
    Variable {
        map: Mmap,
        pos: usize,
        props: Vec<Prop>,
    },
    /// Ascii lines.
    Ascii {
        lines: LineBlocks,
        line_no: u64,
        props: Vec<Prop>,
        pending: Vec<u8>,
    },
}

pub(super) struct PlyReader {
    pub(super) path: PathBuf,
    pub(super) info: CloudInfo,
    pub(super) be: bool,
    pub(super) xyz: Xyz,
    pub(super) total: u64,
    pub(super) next: u64,
    pub(super) body: Body,
    pub(super) stats: ReadStats,
    pub(super) bytes: u64,
    /// The vertex element is the last one: nothing but blanks may follow it.
    pub(super) vertex_last: bool,
    /// The vertex property that is the intensity ([`super::intensity_prop`]),
    /// read only when asked for (the boards' pass).
    pub(super) intensity: Option<usize>,
}

/// Walks one binary element instance with list properties starting at `pos`;
/// returns its end, or `None` if the data ends first.
#[inline]
pub(super) fn walk(map: &[u8], pos: usize, props: &[Prop], be: bool) -> Option<usize> {
    let mut p = pos;
    for prop in props {
        match prop {
            Prop::Scalar(t) => p = p.checked_add(t.size())?,
            Prop::List(ct, it) => {
                let n = ct.read(map.get(p..p + ct.size())?, be);
                if !(n >= 0.0) {
                    return None;
                }
                p = p
                    .checked_add(ct.size())?
                    .checked_add((n as usize).checked_mul(it.size())?)?;
            }
        }
    }
    (p <= map.len()).then_some(p)
}

impl PlyReader {
    fn truncated(&self, found: u64) -> Error {
        Error::format(
            &self.path,
            format!(
                "PLY data truncated: header declares {} vertices, found {found}",
                self.total
            ),
        )
    }
}

/// After the last vertex of an ascii file whose last element is `vertex`, only
/// blank lines may follow: more data means the declared count is wrong.
fn ascii_tail_is_blank(
    path: &Path,
    lines: &mut LineBlocks,
    pending: &mut Vec<u8>,
    line_no: u64,
    total: u64,
) -> Result<()> {
    let mut blank = pending.iter().all(|b| b.is_ascii_whitespace());
    pending.clear();
    while blank {
        match lines.next_block()? {
            Some(b) => blank = b.iter().all(|b| b.is_ascii_whitespace()),
            None => return Ok(()),
        }
    }
    Err(Error::table(
        path,
        line_no,
        format!("PLY header declares {total} vertices but more data follows"),
    ))
}

/// x, y, z of the binary vertex with list properties at `pos` (already
/// walked, so every read is within the map), and property `inten`'s value
/// when given (NaN otherwise).
#[inline]
fn variable_vertex(
    map: &[u8],
    pos: usize,
    props: &[Prop],
    xyz: Xyz,
    inten: Option<usize>,
    be: bool,
) -> ([f64; 3], f32) {
    let mut v = [0.0; 3];
    let mut w = f32::NAN;
    let mut p = pos;
    for (i, prop) in props.iter().enumerate() {
        match prop {
            Prop::Scalar(t) => {
                for c in 0..3 {
                    if xyz.idx[c] == i {
                        v[c] = t.read(&map[p..], be);
                    }
                }
                if inten == Some(i) {
                    w = t.read(&map[p..], be) as f32;
                }
                p += t.size();
            }
            Prop::List(ct, it) => {
                let k = ct.read(&map[p..], be) as usize;
                p += ct.size() + k * it.size();
            }
        }
    }
    (v, w)
}

/// x, y, z of the ascii vertex `line` (line number and vertex index in `at`,
/// for errors), and property `inten`'s value when given (NaN otherwise): the
/// values up to the last of those wanted are read, lists by their count; a
/// missing or unreadable value is an error.
#[inline]
fn ascii_vertex(
    path: &Path,
    (ln, vertex): (u64, u64),
    line: &[u8],
    props: &[Prop],
    xyz: Xyz,
    inten: Option<usize>,
) -> Result<([f64; 3], f32)> {
    let mut v = [f64::NAN; 3];
    let mut w = f32::NAN;
    let mut it = line
        .split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty());
    let bad = |msg: String| Error::table(path, ln, msg);
    let need = xyz.idx.iter().copied().chain(inten).max().unwrap_or(0);
    let number = |t: &[u8]| {
        parse_f64(t).ok_or_else(|| bad(format!("{:?} is not a number", String::from_utf8_lossy(t))))
    };
    for (i, prop) in props.iter().enumerate().take(need + 1) {
        let count = match prop {
            Prop::Scalar(_) => 1,
            Prop::List(..) => {
                let t = it.next().ok_or_else(|| bad("too few values".into()))?;
                parse_f64(t)
                    .filter(|c| *c >= 0.0 && *c <= 1e9)
                    .ok_or_else(|| bad("bad list count".into()))? as usize
            }
        };
        for _ in 0..count {
            let t = it
                .next()
                .ok_or_else(|| bad(format!("too few values for vertex {vertex}")))?;
            for c in 0..3 {
                if xyz.idx[c] == i {
                    v[c] = number(t)?;
                }
            }
            if inten == Some(i) {
                w = number(t)? as f32;
            }
        }
    }
    Ok((v, w))
}

impl PointReader for PlyReader {
    fn info(&self) -> &CloudInfo {
        &self.info
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        self.fill(buf, None)
    }

    fn has_intensity(&self) -> bool {
        self.intensity.is_some()
    }

    fn next_chunk_intensity(&mut self, buf: &mut Vec<Point>, inten: &mut Vec<f32>) -> Result<bool> {
        inten.clear();
        if self.intensity.is_none() {
            return self.next_chunk(buf);
        }
        self.fill(buf, Some(inten))
    }

    fn stats(&self) -> ReadStats {
        self.stats
    }

    fn bytes_read(&self) -> u64 {
        self.bytes
    }
}

impl PlyReader {
    /// The next points, with their intensities into `inten` when given.
    fn fill(&mut self, buf: &mut Vec<Point>, mut inten: Option<&mut Vec<f32>>) -> Result<bool> {
        buf.clear();
        let be = self.be;
        let xyz = self.xyz;
        let want = inten.is_some().then_some(self.intensity).flatten();
        while buf.is_empty() && self.next < self.total {
            let n = (self.total - self.next).min(CHUNK as u64) as usize;
            match &mut self.body {
                Body::Variable { map, pos, props } => {
                    buf.reserve(n);
                    for _ in 0..n {
                        let Some(end) = walk(map, *pos, props, be) else {
                            return Err(self.truncated(self.next));
                        };
                        let (v, w) = variable_vertex(map, *pos, props, xyz, want, be);
                        *pos = end;
                        self.next += 1;
                        if v.iter().all(|c| c.is_finite()) {
                            buf.push(Point::new(v[0], v[1], v[2]));
                            if let Some(out) = inten.as_deref_mut() {
                                out.push(w);
                            }
                        } else {
                            self.stats.skipped_nonfinite += 1;
                        }
                    }
                    self.bytes = *pos as u64;
                }
                Body::Ascii {
                    lines,
                    line_no,
                    props,
                    pending,
                } => {
                    let owned;
                    let block: &[u8] = if !pending.is_empty() {
                        owned = std::mem::take(pending);
                        &owned
                    } else {
                        match lines.next_block()? {
                            Some(b) => b,
                            None => {
                                let found = self.next;
                                return Err(self.truncated(found));
                            }
                        }
                    };
                    let mut rest = block;
                    while !rest.is_empty() && self.next < self.total {
                        let end = rest
                            .iter()
                            .position(|&b| b == b'\n')
                            .map_or(rest.len(), |p| p + 1);
                        let line = rest[..end].trim_ascii();
                        rest = &rest[end..];
                        let ln = *line_no;
                        *line_no += 1;
                        if line.is_empty() {
                            continue;
                        }
                        let at = (ln, self.next);
                        let (v, w) = ascii_vertex(&self.path, at, line, props, xyz, want)?;
                        self.next += 1;
                        if v.iter().all(|c| c.is_finite()) {
                            buf.push(Point::new(v[0], v[1], v[2]));
                            if let Some(out) = inten.as_deref_mut() {
                                out.push(w);
                            }
                        } else {
                            self.stats.skipped_nonfinite += 1;
                        }
                    }
                    if !rest.is_empty() {
                        *pending = rest.to_vec();
                    }
                    self.bytes = lines.bytes;
                }
            }
        }
        if self.next == self.total && self.vertex_last {
            if let Body::Ascii {
                lines,
                line_no,
                pending,
                ..
            } = &mut self.body
            {
                ascii_tail_is_blank(&self.path, lines, pending, *line_no, self.total)?;
            }
        }
        self.stats.points += buf.len() as u64;
        Ok(!buf.is_empty())
    }
}
