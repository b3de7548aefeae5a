//! PCD reader (v0.5-v0.7; ascii, binary, binary_compressed).
//!
//! Hand-written because it is the hot path of every map read, and reads only
//! the x, y, z fields whatever else a point carries. binary data goes to the
//! `pread` record reader (`records.rs`), binary_compressed to the streamed
//! two-pass LZF decoder (`pcd_lzf.rs`); ascii data is read in blocks whose
//! lines are parsed in parallel pieces with the exact fast number parser
//! (`num.rs`). Memory stays bounded whatever the cloud's size.

use super::{CloudInfo, Format, PointReader, ReadStats, pcd_lzf, records};
use crate::{Error, Point, Result};
use rayon::prelude::*;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// Points handed out per `next_chunk` call (6 MiB of `Point`s).
#[cfg(test)]
const CHUNK_POINTS: usize = 1 << 18;
/// Points decoded by one rayon task.
#[cfg(test)]
const TASK_POINTS: usize = 1 << 16;
/// Longest header accepted before concluding it never ends.
const MAX_HEADER: usize = 1 << 20;
/// Largest point record accepted (bytes); real files use well under 1 KiB.
const MAX_POINT_SIZE: usize = 1 << 16;
/// An LZF back-reference turns 3 input bytes into at most 264 output bytes.
const LZF_MAX_RATIO: u64 = 88;

use super::scalar::Scalar;

impl Scalar {
    fn from_type_size(ty: &str, size: usize) -> Option<Scalar> {
        Some(match (ty, size) {
            ("F", 4) => Scalar::F32,
            ("F", 8) => Scalar::F64,
            ("I", 1) => Scalar::I8,
            ("I", 2) => Scalar::I16,
            ("I", 4) => Scalar::I32,
            ("I", 8) => Scalar::I64,
            ("U", 1) => Scalar::U8,
            ("U", 2) => Scalar::U16,
            ("U", 4) => Scalar::U32,
            ("U", 8) => Scalar::U64,
            _ => return None,
        })
    }
}

/// One entry of FIELDS with its SIZE, TYPE and COUNT.
#[derive(Debug, Clone)]
struct Field {
    name: String,
    size: usize,
    count: usize,
    kind: Scalar,
    /// Byte offset inside a binary point record.
    offset: usize,
    /// Index of its first value among the tokens of an ascii line.
    token: usize,
}

/// How the point data is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DataKind {
    Ascii,
    Binary,
    Compressed,
}

/// A parsed and validated PCD header.
#[derive(Debug)]
struct Header {
    fields: Vec<Field>,
    point_size: usize,
    tokens_per_line: usize,
    points: u64,
    data: DataKind,
    /// Byte offset of the first data byte.
    data_offset: usize,
    /// Number of header lines (data line numbers follow it).
    lines: u64,
    /// Indices into `fields` of x, y, z.
    xyz: [usize; 3],
}

fn parse_usize_list(
    path: &Path,
    key: &str,
    lineno: u64,
    vals: &[&str],
    min: usize,
) -> Result<Vec<usize>> {
    vals.iter()
        .map(|v| match v.parse::<usize>() {
            Ok(n) if n >= min => Ok(n),
            _ => Err(Error::table(
                path,
                lineno,
                format!("{key} value '{v}' is not an integer >= {min}"),
            )),
        })
        .collect()
}

fn parse_u64(path: &Path, key: &str, lineno: u64, vals: &[&str]) -> Result<u64> {
    match vals {
        [v] => v.parse::<u64>().map_err(|_| {
            Error::table(
                path,
                lineno,
                format!("{key} value '{v}' is not a non-negative integer"),
            )
        }),
        _ => Err(Error::table(
            path,
            lineno,
            format!("{key} needs exactly one value, found {}", vals.len()),
        )),
    }
}

/// Parses the header at the start of `bytes` (a prefix of the file).
fn parse_header(path: &Path, bytes: &[u8]) -> Result<Header> {
    let mut names: Option<(u64, Vec<String>)> = None;
    let mut sizes: Option<(u64, Vec<usize>)> = None;
    let mut types: Option<(u64, Vec<String>)> = None;
    let mut counts: Option<(u64, Vec<usize>)> = None;
    let mut width = None;
    let mut height = None;
    let mut points = None;
    let mut data = None;
    let mut pos = 0usize;
    let mut lineno = 0u64;
    while data.is_none() {
        if pos >= bytes.len() {
            let why = if bytes.len() >= MAX_HEADER {
                format!(
                    "header has no DATA line within its first {} bytes",
                    MAX_HEADER
                )
            } else {
                "header ends without a DATA line".to_string()
            };
            return Err(Error::format(path, why));
        }
        lineno += 1;
        let rest = &bytes[pos..];
        let (raw, next) = match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (&rest[..i], pos + i + 1),
            None => (rest, bytes.len()),
        };
        pos = next;
        let line = std::str::from_utf8(raw)
            .map_err(|_| Error::table(path, lineno, "header line is not UTF-8 text"))?;
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut it = line.split_ascii_whitespace();
        let key = it.next().unwrap_or_default();
        let vals: Vec<&str> = it.collect();
        match key.to_ascii_uppercase().as_str() {
            "VERSION" | "VIEWPOINT" => {}
            "FIELDS" | "COLUMNS" => {
                names = Some((lineno, vals.iter().map(|s| s.to_string()).collect()));
            }
            "SIZE" => sizes = Some((lineno, parse_usize_list(path, "SIZE", lineno, &vals, 1)?)),
            "TYPE" => {
                types = Some((
                    lineno,
                    vals.iter().map(|s| s.to_ascii_uppercase()).collect(),
                ))
            }
            "COUNT" => counts = Some((lineno, parse_usize_list(path, "COUNT", lineno, &vals, 1)?)),
            "WIDTH" => width = Some(parse_u64(path, "WIDTH", lineno, &vals)?),
            "HEIGHT" => height = Some(parse_u64(path, "HEIGHT", lineno, &vals)?),
            "POINTS" => points = Some(parse_u64(path, "POINTS", lineno, &vals)?),
            "DATA" => {
                let kind = match vals.first().map(|s| s.to_ascii_lowercase()).as_deref() {
                    Some("ascii") => DataKind::Ascii,
                    Some("binary") => DataKind::Binary,
                    Some("binary_compressed") => DataKind::Compressed,
                    other => {
                        return Err(Error::table(
                            path,
                            lineno,
                            format!(
                                "unknown DATA '{}' (expected ascii, binary or binary_compressed)",
                                other.unwrap_or("")
                            ),
                        ));
                    }
                };
                data = Some(kind);
            }
            // PCL ignores keywords it does not know; so do we.
            _ => {}
        }
    }
    let data = data.unwrap_or(DataKind::Ascii);
    let (names_line, names) = names
        .filter(|(_, n)| !n.is_empty())
        .ok_or_else(|| Error::format(path, "header has no FIELDS line"))?;
    let n = names.len();
    let check_len = |key: &str, line: u64, len: usize| -> Result<()> {
        if len != n {
            Err(Error::table(
                path,
                line,
                format!("{key} has {len} entries but FIELDS (line {names_line}) has {n}"),
            ))
        } else {
            Ok(())
        }
    };
    // v0.5 files may lack SIZE / TYPE / COUNT: PCL's defaults are 4, F and 1.
    let sizes = match sizes {
        Some((l, s)) => {
            check_len("SIZE", l, s.len())?;
            s
        }
        None => vec![4; n],
    };
    let (types_line, types) = match types {
        Some((l, t)) => {
            check_len("TYPE", l, t.len())?;
            (l, t)
        }
        None => (0, vec!["F".to_string(); n]),
    };
    let counts = match counts {
        Some((l, c)) => {
            check_len("COUNT", l, c.len())?;
            c
        }
        None => vec![1; n],
    };
    let mut fields = Vec::with_capacity(n);
    let mut offset = 0usize;
    let mut token = 0usize;
    for i in 0..n {
        let (name, size, ty, count) = (&names[i], sizes[i], types[i].as_str(), counts[i]);
        if !matches!(ty, "F" | "I" | "U") {
            return Err(Error::table(
                path,
                types_line,
                format!("unknown TYPE '{ty}' for field '{name}' (expected F, I or U)"),
            ));
        }
        let kind = Scalar::from_type_size(ty, size).ok_or_else(|| {
            let allowed = if ty == "F" { "4 or 8" } else { "1, 2, 4 or 8" };
            Error::format(
                path,
                format!(
                    "field '{name}' has TYPE {ty} with SIZE {size}; TYPE {ty} needs SIZE {allowed}"
                ),
            )
        })?;
        let bytes = size
            .checked_mul(count)
            .and_then(|b| b.checked_add(offset))
            .filter(|&b| b <= MAX_POINT_SIZE)
            .ok_or_else(|| {
                Error::format(path, format!("point records larger than {MAX_POINT_SIZE} bytes are not supported (field '{name}' COUNT {count})"))
            })?;
        fields.push(Field {
            name: name.clone(),
            size,
            count,
            kind,
            offset,
            token,
        });
        offset = bytes;
        token += count;
    }
    let find = |want: &str| -> Result<usize> {
        fields
            .iter()
            .position(|f| f.name == want)
            .or_else(|| {
                fields
                    .iter()
                    .position(|f| f.name.eq_ignore_ascii_case(want))
            })
            .ok_or_else(|| {
                Error::table(
                    path,
                    names_line,
                    format!("no field '{want}' in FIELDS {}", names.join(" ")),
                )
            })
    };
    let xyz = [find("x")?, find("y")?, find("z")?];
    let height = height.unwrap_or(1);
    let points = match (points, width) {
        (Some(p), Some(w)) => {
            if w.checked_mul(height) != Some(p) {
                return Err(Error::format(
                    path,
                    format!("header WIDTH {w} x HEIGHT {height} does not equal POINTS {p}"),
                ));
            }
            p
        }
        (Some(p), None) => p,
        (None, Some(w)) => w.checked_mul(height).ok_or_else(|| {
            Error::format(
                path,
                format!("header WIDTH {w} x HEIGHT {height} overflows"),
            )
        })?,
        (None, None) => return Err(Error::format(path, "header has neither POINTS nor WIDTH")),
    };
    Ok(Header {
        fields,
        point_size: offset,
        tokens_per_line: token,
        points,
        data,
        data_offset: pos,
        lines: lineno,
        xyz,
    })
}

/// Where and how x, y, z of point `i` are stored: value `c` sits at
/// `base[c] + i * stride[c]` in the data slice.
#[derive(Debug, Clone, Copy)]
#[cfg_attr(not(test), allow(dead_code))]
struct Layout {
    kind: [Scalar; 3],
    base: [usize; 3],
    stride: [usize; 3],
}

#[cfg(test)]
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

#[cfg(test)]
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

#[cfg(test)]
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

enum Source {
    /// binary_compressed: the decompressed column-wise block (tests only).
    #[cfg(test)]
    Columns(Vec<u8>),
    /// ascii: the file, read in blocks parsed in parallel.
    Text(Box<TextState>),
}

struct PcdReader {
    path: PathBuf,
    info: CloudInfo,
    stats: ReadStats,
    header: Header,
    layout: Layout,
    source: Source,
    /// Index of the next point to decode.
    next: u64,
    /// Bytes of the file that hold the point data (for progress).
    data_bytes: u64,
}

/// Opens a PCD file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    let (file, file_bytes, header) = read_header(path)?;
    if header.data == DataKind::Binary {
        let after = file_bytes.saturating_sub(header.data_offset as u64);
        let need = header.points.checked_mul(header.point_size as u64);
        if need.is_none_or(|need| need > after) {
            return Err(Error::format(
                path,
                format!(
                    "truncated binary data: header declares POINTS {} ({} bytes of {}-byte points) but only {} bytes ({} whole points) follow the header",
                    header.points,
                    need.map_or("too many".to_string(), |n| n.to_string()),
                    header.point_size,
                    after,
                    after / header.point_size as u64
                ),
            ));
        }
        if need.is_some_and(|need| after - need >= header.point_size as u64) {
            return Err(Error::format(
                path,
                format!(
                    "header declares POINTS {} but the data holds {} points ({} bytes of {}-byte points follow the header)",
                    header.points,
                    after / header.point_size as u64,
                    after,
                    header.point_size
                ),
            ));
        }
        let f = |i: usize| &header.fields[header.xyz[i]];
        let info = CloudInfo {
            format: Format::Pcd,
            declared_points: Some(header.points),
            file_bytes,
        };
        let lay = records::Layout {
            start: header.data_offset as u64,
            stride: header.point_size,
            count: header.points,
            coords: [0, 1, 2].map(|i| records::Coord {
                kind: f(i).kind,
                offset: f(i).offset,
            }),
            big_endian: false,
            transform: None,
        };
        return Ok(Box::new(records::Records::new(file, path, info, lay)?));
    }
    if header.data == DataKind::Compressed {
        let mut file = file;
        let after = file_bytes.saturating_sub(header.data_offset as u64);
        let (comp, raw) = compressed_sizes(path, &mut file, &header, after)?;
        let f = |i: usize| &header.fields[header.xyz[i]];
        let info = CloudInfo {
            format: Format::Pcd,
            declared_points: Some(header.points),
            file_bytes,
        };
        let cols = [0, 1, 2].map(|i| pcd_lzf::Column {
            kind: f(i).kind,
            // Column-wise: each field's values for all points lie together.
            base: header.points * f(i).offset as u64,
            stride: (f(i).size * f(i).count) as u64,
        });
        let start = header.data_offset as u64 + 8;
        return Ok(Box::new(pcd_lzf::LzfColumns::open(
            file,
            path,
            info,
            start,
            comp,
            raw,
            header.points,
            cols,
        )?));
    }
    Ok(Box::new(PcdReader::open_with(
        path, file, file_bytes, header,
    )?))
}

/// Opens `path` and parses its header; the file position is unspecified.
fn read_header(path: &Path) -> Result<(File, u64, Header)> {
    let mut file = File::open(path).map_err(|e| Error::io(path, e))?;
    let file_bytes = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let mut head = Vec::new();
    (&mut file)
        .take(MAX_HEADER as u64)
        .read_to_end(&mut head)
        .map_err(|e| Error::io(path, e))?;
    let header = parse_header(path, &head)?;
    Ok((file, file_bytes, header))
}

impl PcdReader {
    fn open_with(
        path: &Path,
        mut file: File,
        file_bytes: u64,
        header: Header,
    ) -> Result<PcdReader> {
        let info = CloudInfo {
            format: Format::Pcd,
            declared_points: Some(header.points),
            file_bytes,
        };
        let after = file_bytes.saturating_sub(header.data_offset as u64);
        let f = |i: usize| &header.fields[header.xyz[i]];
        let (source, layout, data_bytes) = match header.data {
            DataKind::Binary => {
                // `open` hands binary data to the `pread` record reader.
                return Err(Error::format(path, "internal: binary PCD opened as text"));
            }
            #[cfg(not(test))]
            DataKind::Compressed => {
                return Err(Error::format(
                    path,
                    "internal: binary_compressed PCD opened as text",
                ));
            }
            // The whole-block path, kept as the tests' reference.
            #[cfg(test)]
            DataKind::Compressed => {
                let cols = read_compressed(path, &mut file, &header, after)?;
                let layout = Layout {
                    kind: [f(0).kind, f(1).kind, f(2).kind],
                    // Column-wise: each field's values for all points lie together.
                    base: [0, 1, 2].map(|i| header.points as usize * f(i).offset),
                    stride: [0, 1, 2].map(|i| f(i).size * f(i).count),
                };
                (Source::Columns(cols), layout, after)
            }
            DataKind::Ascii => {
                file.seek(SeekFrom::Start(header.data_offset as u64))
                    .map_err(|e| Error::io(path, e))?;
                let layout = Layout {
                    kind: [f(0).kind, f(1).kind, f(2).kind],
                    base: [f(0).token, f(1).token, f(2).token],
                    stride: [0; 3],
                };
                let src = Source::Text(Box::new(TextState {
                    file,
                    block: Vec::new(),
                    eof: false,
                    lineno: header.lines,
                    consumed: 0,
                }));
                (src, layout, after)
            }
        };
        Ok(PcdReader {
            path: path.to_path_buf(),
            info,
            stats: ReadStats::default(),
            header,
            layout,
            source,
            next: 0,
            data_bytes,
        })
    }

    /// Reads the next block of ascii lines, parses it in parallel pieces and
    /// appends the finite points (at most the declared count) to `buf`.
    #[allow(irrefutable_let_patterns)]
    fn next_text(&mut self, buf: &mut Vec<Point>) -> Result<()> {
        let Source::Text(st) = &mut self.source else {
            return Ok(());
        };
        let path = &self.path;
        // Read on until the block holds at least one whole line (the carried
        // partial line never contains a newline).
        while !st.eof {
            let before = st.block.len();
            (&mut st.file)
                .take(TEXT_BLOCK as u64)
                .read_to_end(&mut st.block)
                .map_err(|e| Error::io(path, e))?;
            if st.block.len() == before {
                st.eof = true;
            } else if st.block[before..].contains(&b'\n') {
                break;
            } else if st.block.len() > MAX_LINE {
                return Err(Error::table(
                    path,
                    st.lineno + 1,
                    format!("line longer than {} bytes", MAX_LINE),
                ));
            }
        }
        let end = if st.eof {
            st.block.len()
        } else {
            st.block
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |i| i + 1)
        };
        if end == 0 && st.eof {
            return Err(Error::format(
                path,
                format!(
                    "truncated ascii data: header declares POINTS {} but the data ends after {} points (line {})",
                    self.header.points, self.next, st.lineno
                ),
            ));
        }
        let text = &st.block[..end];
        // Cut into pieces at line boundaries, parse them in parallel.
        let mut cuts = vec![0usize];
        while let Some(&last) = cuts.last() {
            if last >= end {
                break;
            }
            let at = (last + TEXT_PIECE).min(end);
            let next = match text[at..].iter().position(|&b| b == b'\n') {
                Some(i) if at < end => at + i + 1,
                _ => end,
            };
            cuts.push(next);
        }
        let cols = self.layout.base;
        let pieces: Vec<Piece> = cuts
            .par_windows(2)
            .map(|w| parse_piece(&text[w[0]..w[1]], cols))
            .collect();
        let ntok = self.header.tokens_per_line;
        let mut remaining = self.header.points - self.next;
        for piece in &pieces {
            for p in &piece.points {
                if remaining == 0 {
                    return Err(more_points_than_declared(path, self.header.points));
                }
                remaining -= 1;
                self.next += 1;
                if p.iter().all(|v| v.is_finite()) {
                    buf.push(Point::new(p[0], p[1], p[2]));
                } else {
                    self.stats.skipped_nonfinite += 1;
                }
            }
            if let Some((line, ref what)) = piece.error {
                let line = st.lineno + line;
                let msg = match what {
                    LineError::Short(found) => {
                        format!("expected {ntok} values, found {found}")
                    }
                    LineError::NotNumber(c, tok) => format!(
                        "field '{}' value '{tok}' is not a number",
                        self.header.fields[self.header.xyz[*c]].name
                    ),
                };
                return Err(Error::table(path, line, msg));
            }
            st.lineno += piece.lines;
        }
        st.consumed += end as u64;
        st.block.drain(..end);
        Ok(())
    }
}

fn more_points_than_declared(path: &Path, points: u64) -> Error {
    Error::format(
        path,
        format!("header declares POINTS {points} but the ascii data holds more points"),
    )
}

/// After the declared points only blank lines may follow; more data means the
/// header's POINTS is wrong (and part of the map would silently be dropped).
fn ascii_tail_is_blank(path: &Path, st: &mut TextState, points: u64) -> Result<()> {
    loop {
        if !st.block.iter().all(|b| b.is_ascii_whitespace()) {
            return Err(more_points_than_declared(path, points));
        }
        st.block.clear();
        if st.eof {
            return Ok(());
        }
        (&mut st.file)
            .take(TEXT_BLOCK as u64)
            .read_to_end(&mut st.block)
            .map_err(|e| Error::io(path, e))?;
        st.eof = st.block.is_empty();
    }
}

/// Bytes of ascii data read per block.
const TEXT_BLOCK: usize = 8 << 20;
/// Bytes of ascii data parsed by one rayon task.
const TEXT_PIECE: usize = 256 << 10;
/// Longest ascii data line accepted.
const MAX_LINE: usize = 64 << 20;

struct TextState {
    file: File,
    /// Unparsed bytes: a partial line carried over, then the next block.
    block: Vec<u8>,
    eof: bool,
    /// Physical lines consumed so far (header included), for messages.
    lineno: u64,
    consumed: u64,
}

enum LineError {
    /// Fewer tokens than needed to reach x, y and z.
    Short(usize),
    /// Coordinate `c` is not a number.
    NotNumber(usize, String),
}

/// The parsed lines of one piece of ascii data.
struct Piece {
    /// x, y, z of every data line, non-finite ones included (in order).
    points: Vec<[f64; 3]>,
    /// Physical lines in the piece.
    lines: u64,
    /// First bad line (1-based within the piece), after which parsing stopped.
    error: Option<(u64, LineError)>,
}

fn parse_piece(text: &[u8], cols: [usize; 3]) -> Piece {
    let last = cols.iter().copied().max().unwrap_or(0);
    let mut piece = Piece {
        points: Vec::with_capacity(text.len() / 24),
        lines: 0,
        error: None,
    };
    for line in text.split(|&b| b == b'\n') {
        piece.lines += 1;
        let mut vals = [0f64; 3];
        let mut toks = line
            .split(|b| matches!(b, b' ' | b'\t' | b'\r' | b','))
            .filter(|t| !t.is_empty());
        let mut t = 0usize;
        while t <= last {
            let Some(tok) = toks.next() else { break };
            for c in 0..3 {
                if cols[c] == t {
                    match parse_f64(tok) {
                        Some(v) => vals[c] = v,
                        None => {
                            let tok =
                                String::from_utf8_lossy(&tok[..tok.len().min(40)]).into_owned();
                            piece.error = Some((piece.lines, LineError::NotNumber(c, tok)));
                            return piece;
                        }
                    }
                }
            }
            t += 1;
        }
        if t == 0 {
            continue; // blank line
        }
        if t <= last {
            piece.error = Some((piece.lines, LineError::Short(t + toks.count())));
            return piece;
        }
        piece.points.push(vals);
    }
    // `split` yields an empty tail after a final newline: it is not a line.
    if text.last() == Some(&b'\n') {
        piece.lines -= 1;
    }
    piece
}

/// Parses an ascii number (PCL writes `nan` for missing points).
use super::num::parse_f64;

/// Reads and decompresses a PCL binary_compressed block, checking its sizes
/// against the header before allocating.
/// Only the tests use the whole-block path now (as the reference the streamed
/// reader must equal).
#[cfg(test)]
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

/// Reads the compressed and uncompressed sizes that follow a binary_compressed
/// header and checks them against the header and the file size.
fn compressed_sizes(path: &Path, file: &mut File, h: &Header, after: u64) -> Result<(u64, u64)> {
    let expect = h
        .points
        .checked_mul(h.point_size as u64)
        .ok_or_else(|| Error::format(path, format!("POINTS {} is absurdly large", h.points)))?;
    if after < 8 {
        return Err(Error::format(
            path,
            format!(
                "truncated binary_compressed data: {after} bytes after the header, need at least 8 for the size fields"
            ),
        ));
    }
    file.seek(SeekFrom::Start(h.data_offset as u64))
        .map_err(|e| Error::io(path, e))?;
    let mut sizes = [0u8; 8];
    file.read_exact(&mut sizes)
        .map_err(|e| Error::io(path, e))?;
    let comp = u32::from_le_bytes([sizes[0], sizes[1], sizes[2], sizes[3]]) as u64;
    let raw = u32::from_le_bytes([sizes[4], sizes[5], sizes[6], sizes[7]]) as u64;
    if raw != expect {
        return Err(Error::format(
            path,
            format!(
                "binary_compressed uncompressed size {raw} does not match POINTS {} x {}-byte points = {expect}",
                h.points, h.point_size
            ),
        ));
    }
    if comp > after - 8 {
        return Err(Error::format(
            path,
            format!(
                "truncated binary_compressed data: compressed size {comp} but only {} bytes follow",
                after - 8
            ),
        ));
    }
    if raw > comp.saturating_mul(LZF_MAX_RATIO) + 16 {
        return Err(Error::format(
            path,
            format!(
                "binary_compressed sizes are inconsistent: {comp} compressed bytes cannot hold {raw} bytes"
            ),
        ));
    }
    Ok((comp, raw))
}

/// LZF decoder writing into an exactly-sized buffer; refuses any stream whose
/// output would not be exactly `len` bytes.
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) fn lzf_decompress(src: &[u8], len: usize) -> std::result::Result<Vec<u8>, String> {
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

impl PointReader for PcdReader {
    fn info(&self) -> &CloudInfo {
        &self.info
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        loop {
            if self.next >= self.header.points {
                buf.clear();
                // Only `Text` outside tests: the whole-block variant is the tests' reference.
                #[allow(irrefutable_let_patterns)]
                if let Source::Text(st) = &mut self.source {
                    ascii_tail_is_blank(&self.path, st, self.header.points)?;
                }
                #[cfg(test)]
                if let Source::Columns(c) = &mut self.source {
                    *c = Vec::new(); // free the block as soon as it is consumed
                }
                return Ok(false);
            }
            match &mut self.source {
                Source::Text(_) => {
                    buf.clear();
                    self.next_text(buf)?
                }
                #[cfg(test)]
                Source::Columns(cols) => {
                    let first = self.next as usize;
                    let n = (self.header.points - self.next).min(CHUNK_POINTS as u64) as usize;
                    let skipped = decode_parallel(cols, &self.layout, first, n, buf);
                    self.stats.skipped_nonfinite += skipped;
                    self.next += n as u64;
                }
            }
            if !buf.is_empty() {
                self.stats.points += buf.len() as u64;
                return Ok(true);
            }
        }
    }

    fn stats(&self) -> ReadStats {
        self.stats
    }

    #[allow(unreachable_patterns)]
    fn bytes_read(&self) -> u64 {
        let head = self.header.data_offset as u64;
        match &self.source {
            Source::Text(st) => head + st.consumed,
            _ if self.header.points == 0 => self.info.file_bytes,
            _ => {
                let frac = self.next as f64 / self.header.points as f64;
                head + (self.data_bytes as f64 * frac) as u64
            }
        }
    }
}

#[cfg(test)]
#[path = "pcd_tests.rs"]
mod tests;
