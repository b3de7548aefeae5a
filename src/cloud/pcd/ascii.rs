//! ascii PCD data: read in blocks whose lines are parsed in parallel pieces
//! with the exact fast number parser (`num.rs`), at most the declared count.
//!
//! A coordinate declared `TYPE F` with `SIZE 4` is rounded to the nearest f32,
//! as PCL (`istream >> float`) and pypcd4 (numpy float32) read it, so an ascii
//! map gives the same points as the same map in binary; `SIZE 8` stays f64.

use super::header::Header;
use crate::cloud::num::{parse_f64, round_f32};
use crate::cloud::scalar::Scalar;
use crate::cloud::{CloudInfo, Format, PointReader, ReadStats};
use crate::{Error, Point, Result};
use rayon::prelude::*;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// Streams the points of an ascii PCD.
pub(super) struct AsciiReader {
    path: PathBuf,
    info: CloudInfo,
    stats: ReadStats,
    header: Header,
    /// Token index of x, y, z on a data line.
    cols: [usize; 3],
    /// x, y, z declared `TYPE F` `SIZE 4`: read as PCL does, to the nearest f32.
    f32s: [bool; 3],
    /// Token index of the intensity, when the cloud has one.
    icol: Option<usize>,
    st: TextState,
    /// Index of the next point to decode.
    next: u64,
}

impl AsciiReader {
    /// Starts reading the data of `header` (an ascii one) from `file`.
    pub(super) fn open(
        path: &Path,
        mut file: File,
        file_bytes: u64,
        header: Header,
    ) -> Result<AsciiReader> {
        let info = CloudInfo {
            format: Format::Pcd,
            declared_points: Some(header.points),
            file_bytes,
        };
        file.seek(SeekFrom::Start(header.data_offset as u64))
            .map_err(|e| Error::io(path, e))?;
        let cols = header.xyz.map(|i| header.fields[i].token);
        let f32s = header.xyz.map(|i| header.fields[i].kind == Scalar::F32);
        let icol = header.intensity_field().map(|i| header.fields[i].token);
        let st = TextState {
            file,
            block: Vec::new(),
            eof: false,
            lineno: header.lines,
            consumed: 0,
        };
        Ok(AsciiReader {
            path: path.to_path_buf(),
            info,
            stats: ReadStats::default(),
            header,
            cols,
            f32s,
            icol,
            st,
            next: 0,
        })
    }

    /// Reads the next block of ascii lines, parses it in parallel pieces and
    /// appends the finite points (at most the declared count) to `buf`, and
    /// their intensities to `inten` when given.
    fn next_text(&mut self, buf: &mut Vec<Point>, mut inten: Option<&mut Vec<f32>>) -> Result<()> {
        let st = &mut self.st;
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
        let (cols, f32s) = (self.cols, self.f32s);
        // The intensity is parsed only by the passes that read it.
        let icol = self.icol.filter(|_| inten.is_some());
        let pieces: Vec<Piece> = cuts
            .par_windows(2)
            .map(|w| parse_piece(&text[w[0]..w[1]], cols, f32s, icol))
            .collect();
        let ntok = self.header.tokens_per_line;
        let mut remaining = self.header.points - self.next;
        for piece in &pieces {
            for (k, p) in piece.points.iter().enumerate() {
                if remaining == 0 {
                    return Err(more_points_than_declared(path, self.header.points));
                }
                remaining -= 1;
                self.next += 1;
                if p.iter().all(|v| v.is_finite()) {
                    buf.push(Point::new(p[0], p[1], p[2]));
                    if let Some(out) = inten.as_deref_mut() {
                        out.push(piece.inten.get(k).copied().unwrap_or(f32::NAN));
                    }
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
pub(super) const TEXT_BLOCK: usize = 8 << 20;
/// Bytes of ascii data parsed by one rayon task.
pub(super) const TEXT_PIECE: usize = 256 << 10;
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
    /// Each line's intensity when asked for (NaN where missing or not a
    /// number), else empty.
    inten: Vec<f32>,
    /// Physical lines in the piece.
    lines: u64,
    /// First bad line (1-based within the piece), after which parsing stopped.
    error: Option<(u64, LineError)>,
}

/// Parses the lines of `text`: x, y, z are tokens `cols`, rounded to f32
/// where `f32s` says so, and the intensity token `icol` when given.
fn parse_piece(text: &[u8], cols: [usize; 3], f32s: [bool; 3], icol: Option<usize>) -> Piece {
    let last = cols.iter().copied().max().unwrap_or(0);
    let reach = last.max(icol.unwrap_or(0));
    let mut piece = Piece {
        points: Vec::with_capacity(text.len() / 24),
        inten: Vec::new(),
        lines: 0,
        error: None,
    };
    for line in text.split(|&b| b == b'\n') {
        piece.lines += 1;
        let mut vals = [0f64; 3];
        let mut i = f32::NAN;
        let mut toks = line
            .split(|b| matches!(b, b' ' | b'\t' | b'\r' | b','))
            .filter(|t| !t.is_empty());
        let mut t = 0usize;
        while t <= reach {
            let Some(tok) = toks.next() else { break };
            if icol == Some(t) {
                i = parse_f64(tok).map_or(f32::NAN, |v| v as f32);
            }
            for c in 0..3 {
                if cols[c] == t {
                    match parse_f64(tok) {
                        Some(v) if f32s[c] => vals[c] = round_f32(tok, v),
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
        if icol.is_some() {
            piece.inten.push(i);
        }
    }
    // `split` yields an empty tail after a final newline: it is not a line.
    if text.last() == Some(&b'\n') {
        piece.lines -= 1;
    }
    piece
}

impl PointReader for AsciiReader {
    fn info(&self) -> &CloudInfo {
        &self.info
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        self.fill(buf, None)
    }

    fn has_intensity(&self) -> bool {
        self.icol.is_some()
    }

    fn next_chunk_intensity(&mut self, buf: &mut Vec<Point>, inten: &mut Vec<f32>) -> Result<bool> {
        inten.clear();
        if self.icol.is_none() {
            return self.next_chunk(buf);
        }
        self.fill(buf, Some(inten))
    }

    fn stats(&self) -> ReadStats {
        self.stats
    }

    fn bytes_read(&self) -> u64 {
        self.header.data_offset as u64 + self.st.consumed
    }
}

impl AsciiReader {
    /// The next points, with their intensities into `inten` when given.
    fn fill(&mut self, buf: &mut Vec<Point>, mut inten: Option<&mut Vec<f32>>) -> Result<bool> {
        loop {
            buf.clear();
            if let Some(v) = inten.as_deref_mut() {
                v.clear();
            }
            if self.next >= self.header.points {
                ascii_tail_is_blank(&self.path, &mut self.st, self.header.points)?;
                return Ok(false);
            }
            self.next_text(buf, inten.as_deref_mut())?;
            if !buf.is_empty() {
                self.stats.points += buf.len() as u64;
                return Ok(true);
            }
        }
    }
}
