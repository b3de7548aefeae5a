//! PTS reader: the text format of Leica Cyclone, CloudCompare and Open3D.
//!
//! A line with the point count, then one point per line:
//! `x y z [intensity [r g b]]` (3, 4, 6 or 7 values separated by blanks).
//! Leica exports several scans into one file as consecutive sections, each
//! led by its own count line, so after a section's last point either the file
//! ends or another count line follows. Every count is checked against the
//! points that follow it, in both directions. Blank lines are skipped.

use super::num::parse_f64;
use super::xyz::LineBlocks;
use super::{CloudInfo, Format, PointReader, ReadStats};
use crate::{Error, Point, Result};
use std::fs::File;
use std::path::{Path, PathBuf};

/// Points handed out per `next_chunk` call at most (a block of lines may
/// hold fewer).
const CHUNK: usize = 1 << 18;

/// Where the reader is in the file.
#[derive(Debug, Clone, Copy)]
enum State {
    /// Expecting a count line (at the start, or after a complete section).
    Count,
    /// Inside a section: `left` of `count` points (declared on `line`) to go.
    Points { count: u64, left: u64, line: u64 },
}

struct PtsReader {
    info: CloudInfo,
    /// The first point line holds an intensity (4 or 7 values).
    intensity: bool,
    lines: LineBlocks,
    /// Lines of the last block not parsed yet (a chunk filled up).
    pending: Vec<u8>,
    cur: Cursor,
    done: bool,
}

/// The parse position: what is expected next, and the counters.
struct Cursor {
    path: PathBuf,
    state: State,
    /// Lines consumed so far.
    line_no: u64,
    /// The last count line: (count, line number).
    last_count: Option<(u64, u64)>,
    stats: ReadStats,
}

/// Opens a PTS file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let file_bytes = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let intensity = first_has_intensity(&file);
    Ok(Box::new(PtsReader {
        intensity,
        info: CloudInfo {
            format: Format::Pts,
            // Unknown until every section is read.
            declared_points: None,
            file_bytes,
        },
        lines: LineBlocks::new(file, path),
        pending: Vec::new(),
        cur: Cursor {
            path: path.to_path_buf(),
            state: State::Count,
            line_no: 0,
            last_count: None,
            stats: ReadStats::default(),
        },
        done: false,
    }))
}

/// True when `head` (the file's first bytes; `whole` when that is the whole
/// file) starts like a PTS file: a count line, then a point line. With no
/// point line in `head` (an empty section), the `.pts` extension decides.
pub(super) fn sniff(head: &[u8], whole: bool, ext_pts: bool) -> bool {
    let mut lines: Vec<&[u8]> = head.split(|&b| b == b'\n').collect();
    if !whole {
        lines.pop(); // possibly cut short
    }
    let mut lines = lines
        .into_iter()
        .map(|l| l.trim_ascii())
        .filter(|l| !l.is_empty());
    if lines.next().and_then(count_of).is_none() {
        return false;
    }
    match lines.next() {
        Some(l) => point_of(l).is_ok(),
        None => ext_pts,
    }
}

/// Whether the file's first point line (in its first 64 KiB) holds an
/// intensity: 4 values (`x y z i`) or 7 (`x y z i r g b`); 3 or 6 (`x y z
/// r g b`, CloudCompare's) hold none.
fn first_has_intensity(file: &File) -> bool {
    use std::os::unix::fs::FileExt;
    let mut head = vec![0u8; 64 << 10];
    let n = file.read_at(&mut head, 0).unwrap_or(0);
    head.truncate(n);
    head.split(|&b| b == b'\n')
        .map(|l| l.trim_ascii())
        .filter(|l| !l.is_empty() && count_of(l).is_none())
        .map(|l| point_of(l).is_ok_and(|(_, i)| i.is_some()))
        .next()
        .unwrap_or(false)
}

/// The count of a count line: one non-negative integer.
fn count_of(line: &[u8]) -> Option<u64> {
    let mut toks = line
        .split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty());
    let tok = toks.next()?;
    if toks.next().is_some() || !tok.iter().all(u8::is_ascii_digit) {
        return None;
    }
    std::str::from_utf8(tok).ok()?.parse().ok()
}

/// x, y, z of a point line and its intensity's token (4 or 7 values; left
/// unparsed: only the boards' pass reads it), or what is wrong with it.
fn point_of(line: &[u8]) -> std::result::Result<([f64; 3], Option<&[u8]>), String> {
    let mut v = [0.0; 3];
    let mut i: &[u8] = &[];
    let mut n = 0usize;
    for tok in line
        .split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
    {
        if n < 3 {
            v[n] = parse_f64(tok).ok_or_else(|| {
                format!(
                    "{} value '{}' is not a number",
                    ["x", "y", "z"][n],
                    String::from_utf8_lossy(&tok[..tok.len().min(40)])
                )
            })?;
        } else if n == 3 {
            i = tok;
        }
        n += 1;
    }
    if matches!(n, 3 | 4 | 6 | 7) {
        Ok((v, matches!(n, 4 | 7).then_some(i)))
    } else {
        Err(format!(
            "expected x y z [intensity [r g b]] (3, 4, 6 or 7 values), found {n}"
        ))
    }
}

impl Cursor {
    /// Parses whole lines of `text` into `buf` (and each point's intensity
    /// into `inten` when given: NaN on a line without one) until it holds
    /// `CHUNK` points; returns the bytes consumed.
    fn parse(
        &mut self,
        text: &[u8],
        buf: &mut Vec<Point>,
        mut inten: Option<&mut Vec<f32>>,
    ) -> Result<usize> {
        let mut pos = 0;
        while pos < text.len() && buf.len() < CHUNK {
            let end = text[pos..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(text.len(), |i| pos + i + 1);
            let text_line = text[pos..end].trim_ascii();
            pos = end;
            self.line_no += 1;
            if text_line.is_empty() {
                continue;
            }
            let ln = self.line_no;
            match self.state {
                State::Count => {
                    let count = count_of(text_line).ok_or_else(|| {
                        Error::table(
                            &self.path,
                            ln,
                            match self.last_count {
                                None => "expected the point count (one integer) before the points"
                                    .to_string(),
                                Some((count, line)) => format!(
                                    "count line {line} declares {count} points but more follow"
                                ),
                            },
                        )
                    })?;
                    self.last_count = Some((count, ln));
                    if count > 0 {
                        self.state = State::Points {
                            count,
                            left: count,
                            line: ln,
                        };
                    }
                }
                State::Points { count, left, line } => {
                    if count_of(text_line).is_some() {
                        return Err(Error::table(
                            &self.path,
                            line,
                            format!(
                                "count line declares {count} points but line {ln} starts another section after {}",
                                count - left
                            ),
                        ));
                    }
                    let (v, i) =
                        point_of(text_line).map_err(|m| Error::table(&self.path, ln, m))?;
                    if v.iter().all(|c| c.is_finite()) {
                        buf.push(Point::new(v[0], v[1], v[2]));
                        if let Some(out) = inten.as_deref_mut() {
                            // NaN where none, or not a number.
                            out.push(i.and_then(parse_f64).unwrap_or(f64::NAN) as f32);
                        }
                    } else {
                        self.stats.skipped_nonfinite += 1;
                    }
                    self.state = if left == 1 {
                        State::Count
                    } else {
                        State::Points {
                            count,
                            left: left - 1,
                            line,
                        }
                    };
                }
            }
        }
        Ok(pos)
    }
}

impl PointReader for PtsReader {
    fn info(&self) -> &CloudInfo {
        &self.info
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        self.fill(buf, None)
    }

    fn has_intensity(&self) -> bool {
        self.intensity
    }

    fn next_chunk_intensity(&mut self, buf: &mut Vec<Point>, inten: &mut Vec<f32>) -> Result<bool> {
        inten.clear();
        if !self.intensity {
            return self.next_chunk(buf);
        }
        self.fill(buf, Some(inten))
    }

    fn stats(&self) -> ReadStats {
        self.cur.stats
    }

    fn bytes_read(&self) -> u64 {
        self.lines.bytes
    }
}

impl PtsReader {
    /// The next points, with their intensities into `inten` when given.
    fn fill(&mut self, buf: &mut Vec<Point>, mut inten: Option<&mut Vec<f32>>) -> Result<bool> {
        buf.clear();
        while !self.done && buf.len() < CHUNK {
            if !self.pending.is_empty() {
                let text = std::mem::take(&mut self.pending);
                let used = self.cur.parse(&text, buf, inten.as_deref_mut())?;
                self.pending = text[used..].to_vec();
                continue;
            }
            let Some(block) = self.lines.next_block()? else {
                self.done = true;
                let cur = &self.cur;
                match (cur.state, cur.last_count) {
                    (State::Points { count, left, line }, _) => {
                        return Err(Error::table(
                            &cur.path,
                            line,
                            format!(
                                "count line declares {count} points but the file ends after {}",
                                count - left
                            ),
                        ));
                    }
                    (State::Count, None) => {
                        return Err(Error::format(
                            &cur.path,
                            "no point count line: the file holds only blank lines",
                        ));
                    }
                    (State::Count, Some(_)) => break,
                }
            };
            let used = self.cur.parse(block, buf, inten.as_deref_mut())?;
            if used < block.len() {
                self.pending = block[used..].to_vec();
            }
        }
        self.cur.stats.points += buf.len() as u64;
        Ok(!buf.is_empty())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloud;

    fn file(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn read(path: &Path) -> Result<(Vec<[f64; 3]>, ReadStats)> {
        let mut r = cloud::open(path)?;
        let mut all = Vec::new();
        let mut buf = Vec::new();
        while r.next_chunk(&mut buf)? {
            all.extend(buf.iter().map(|p| [p.x, p.y, p.z]));
        }
        assert!(!r.next_chunk(&mut buf)?);
        Ok((all, r.stats()))
    }

    fn err(path: &Path) -> String {
        let e = read(path).unwrap_err().to_string();
        assert!(!e.contains('\n'), "{e}");
        e
    }

    #[test]
    fn writers_layouts_and_sections() {
        let dir = tempfile::tempdir().unwrap();
        let want = vec![[350123.4567891234, 4150234.5, 12.25], [-1.0, 2.0, -0.5]];
        for (name, text) in [
            // Open3D: %.10f coordinates, CRLF; with colours `x y z i r g b`.
            (
                "o3d.pts",
                "2\r\n350123.4567891234 4150234.5000000000 12.2500000000\r\n\
                 -1.0000000000 2.0000000000 -0.5000000000\r\n",
            ),
            (
                "o3d-rgb.pts",
                "2\r\n350123.4567891234 4150234.5 12.25 0 255 128 0\r\n-1 2 -0.5 0 1 2 3\r\n",
            ),
            // Leica Cyclone: intensity -2048..2047, tabs; CloudCompare: x y z r g b.
            (
                "leica.pts",
                "2\n350123.4567891234\t4150234.5\t12.25\t-1024\t10\t20\t30\n-1 2 -0.5 2047 0 0 0\n",
            ),
            (
                "cc.pts",
                "\n2\n350123.4567891234 4150234.5 12.25 10 20 30\n\n-1 2 -0.5 1 2 3\n\n",
            ),
            // Two scans in one file; an empty one between; no final newline.
            (
                "sections.txt",
                "1\n350123.4567891234 4150234.5 12.25 7\n0\n1\n-1 2 -0.5 7",
            ),
        ] {
            let p = file(&dir, name, text);
            assert_eq!(cloud::detect(&p).unwrap(), cloud::Format::Pts, "{name}");
            let (got, st) = read(&p).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(got, want, "{name}");
            assert_eq!(st.points, 2);
        }
        // An XYZ file without a count line stays XYZ; an empty .pts is PTS.
        let p = file(&dir, "plain.txt", "1 2 3\n4 5 6\n");
        assert_eq!(cloud::detect(&p).unwrap(), cloud::Format::Xyz);
        let p = file(&dir, "empty.pts", "0\n");
        assert_eq!(cloud::detect(&p).unwrap(), cloud::Format::Pts);
        assert_eq!(read(&p).unwrap().0, Vec::<[f64; 3]>::new());
    }

    /// Leica's `x y z i [r g b]` lines give their intensities with their
    /// points (a point line without one gives NaN; a non-finite point
    /// drops its intensity with it); CloudCompare's `x y z r g b` has none.
    #[test]
    fn intensity_of_leica_lines() {
        let dir = tempfile::tempdir().unwrap();
        let with_i = |p: &Path| {
            let (_, inten, has) = cloud::read_with_intensity(p);
            (has, inten)
        };
        let p = file(
            &dir,
            "leica.pts",
            "4\n1 2 3\t-1024\t10\t20\t30\n4 5 6 2047 0 0 0\nnan 1 1 5\n7 8 9\n1\n0 0 0 12\n",
        );
        let (has, i) = with_i(&p);
        assert!(has);
        assert_eq!(i.len(), 4);
        assert_eq!(&i[..2], &[-1024.0, 2047.0]);
        assert!(i[2].is_nan());
        assert_eq!(i[3], 12.0);
        let p = file(&dir, "cc.pts", "2\n1 2 3 10 20 30\n4 5 6 1 2 3\n");
        let (has, i) = with_i(&p);
        assert!(!has && i.is_empty());
    }

    #[test]
    fn counts_are_checked_and_errors_name_the_line() {
        let dir = tempfile::tempdir().unwrap();
        for (text, want) in [
            (
                "5\n1 2 3\n4 5 6\n7 8 9\n",
                "m.pts:1: count line declares 5 points but the file ends after 3",
            ),
            (
                "2\n1 2 3\n4 5 6\n7 8 9\n",
                "m.pts:4: count line 1 declares 2 points but more follow",
            ),
            (
                "4\n1 2 3\n4 5 6\n2\n7 8 9\n",
                "m.pts:1: count line declares 4 points but line 4 starts another section after 2",
            ),
            (
                "2\n1 2 3\n4 abc 6\n",
                "m.pts:3: y value 'abc' is not a number",
            ),
            (
                "2\n1 2 3\n4 5 6 7 8\n",
                "m.pts:3: expected x y z [intensity [r g b]] (3, 4, 6 or 7 values), found 5",
            ),
            ("2\n1 2\n", "m.pts:2: expected x y z"),
            (
                "two\n1 2 3\n",
                "m.pts:1: expected the point count (one integer) before the points",
            ),
            ("-3\n1 2 3\n", "m.pts:1: expected the point count"),
            ("\n \n\n", "m.pts: no point count line"),
        ] {
            let p = file(&dir, "m.pts", text);
            let e = err(&p);
            assert!(e.contains(want), "{text:?}: got `{e}`, want `{want}`");
        }
    }

    #[test]
    fn large_file_across_blocks_keeps_order_and_counts_nan() {
        let dir = tempfile::tempdir().unwrap();
        let n = 400_000; // > one chunk of points and > one 4 MiB block of text
        let mut text = format!("{n}\n");
        let mut want = Vec::new();
        for i in 0..n {
            if i % 100_003 == 5 {
                text.push_str("nan nan nan 0\n");
            } else {
                let p = [i as f64 * 0.001, -(i as f64), (i % 13) as f64 + 0.5];
                text.push_str(&format!("{} {} {} 17 1 2 3\n", p[0], p[1], p[2]));
                want.push(p);
            }
        }
        assert!(text.len() > 8 << 20);
        let p = file(&dir, "big.pts", &text);
        let (got, st) = read(&p).unwrap();
        assert_eq!(got, want);
        assert_eq!(st.points as usize, want.len());
        assert_eq!(st.skipped_nonfinite as usize, n - want.len());
    }

    #[test]
    fn mutated_files_give_points_or_one_line_errors() {
        let dir = tempfile::tempdir().unwrap();
        let seed = b"2\n1.5 2.5 3.5 0 1 2 3\n-1 -2 -3\n0\n1\n4 5 6 7\n";
        let alphabet = b"0123456789 \t\n\r.-+eEnaif#,x\x00\xff";
        let mut h = 1u64;
        let p = dir.path().join("m.pts");
        for _ in 0..800 {
            let mut b = seed.to_vec();
            for _ in 0..1 + (h >> 60) {
                h = h
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let at = (h >> 33) as usize % (b.len() + 1);
                let c = alphabet[(h >> 20) as usize % alphabet.len()];
                match (h >> 10) % 3 {
                    0 if at < b.len() => b[at] = c,
                    1 if at < b.len() => {
                        b.remove(at);
                    }
                    _ => b.insert(at, c),
                }
            }
            std::fs::write(&p, &b).unwrap();
            let mut r = cloud::open_as(&p, cloud::Format::Pts).unwrap();
            let mut buf = Vec::new();
            loop {
                match r.next_chunk(&mut buf) {
                    Ok(true) => assert!(buf.iter().all(|q| q.x.is_finite())),
                    Ok(false) => break,
                    Err(e) => {
                        assert!(!e.to_string().contains('\n'), "{e}");
                        break;
                    }
                }
            }
            let _ = cloud::detect(&p);
        }
    }
}
