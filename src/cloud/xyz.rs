//! XYZ / CSV text reader.
//!
//! `x y z [more columns]`, separated by spaces/tabs, commas or semicolons (chosen
//! from the first data line). An optional header line names the columns; `x`,
//! `y`, `z` are then found by name (case-insensitive), and an intensity column
//! (`intensity`, `i`, `scalar_intensity`) when named. CloudCompare writes its
//! header as a comment (`//X,Y,Z,Intensity`): a `//` line naming x, y and z
//! before the first data line is the header. Other `#` and `//` lines and
//! blank lines are skipped. Without a header a fourth column is not taken for
//! intensity: it may as well be a time, a label or a colour. The file is read in blocks of whole lines and each
//! block is parsed in parallel (order kept), without per-line allocation.

use super::{CloudInfo, Format, PointReader, ReadStats};
use crate::{Error, Point, Result};
use rayon::prelude::*;
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Bytes read per block of lines.
const BLOCK_BYTES: usize = 4 << 20;
/// A single line longer than this is rejected (guards memory on hostile input).
const MAX_LINE: usize = 16 << 20;
/// Lines per parallel parse task.
const TASK_BYTES: usize = 256 << 10;

/// Reads a text file in blocks that always end on a line boundary, so memory stays
/// bounded and blocks can be parsed independently.
pub(super) struct LineBlocks {
    file: File,
    path: PathBuf,
    buf: Vec<u8>,
    /// Bytes at the start of `buf` that belong to the next block (a partial line).
    carry: usize,
    /// Length of the block handed out last (drained on the next call).
    last: usize,
    eof: bool,
    /// Bytes consumed from the file so far.
    pub(super) bytes: u64,
}

impl LineBlocks {
    /// Starts reading `file` at its current position.
    pub(super) fn new(file: File, path: &Path) -> Self {
        LineBlocks {
            file,
            path: path.to_path_buf(),
            buf: Vec::with_capacity(BLOCK_BYTES),
            carry: 0,
            last: 0,
            eof: false,
            bytes: 0,
        }
    }

    /// The next block of whole lines (the final line may lack its newline), or
    /// `None` at the end of the file.
    pub(super) fn next_block(&mut self) -> Result<Option<&[u8]>> {
        // Drop the previous block, keep the carried partial line.
        self.buf.drain(..self.last);
        self.last = 0;
        let mut want = BLOCK_BYTES;
        loop {
            if !self.eof && self.buf.len() < want {
                let start = self.buf.len();
                self.buf.resize(want, 0);
                let mut filled = start;
                while filled < want {
                    match self.file.read(&mut self.buf[filled..]) {
                        Ok(0) => {
                            self.eof = true;
                            break;
                        }
                        Ok(k) => filled += k,
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                        Err(e) => return Err(Error::io(&self.path, e)),
                    }
                }
                self.bytes += (filled - start) as u64;
                self.buf.truncate(filled);
            }
            if self.buf.is_empty() {
                return Ok(None);
            }
            if self.eof {
                self.last = self.buf.len();
                self.carry = 0;
                return Ok(Some(&self.buf[..self.last]));
            }
            if let Some(nl) = self.buf.iter().rposition(|&b| b == b'\n') {
                self.last = nl + 1;
                self.carry = self.buf.len() - self.last;
                return Ok(Some(&self.buf[..self.last]));
            }
            // One line longer than the block: grow, within reason.
            if want >= MAX_LINE {
                return Err(Error::format(
                    &self.path,
                    format!("a line is longer than {} MiB", MAX_LINE >> 20),
                ));
            }
            want *= 2;
        }
    }
}

/// How fields are separated on a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sep {
    /// Runs of spaces and tabs.
    Space,
    /// A single character (comma or semicolon); spaces around fields are trimmed.
    Char(u8),
}

/// Column layout found from the first data line.
#[derive(Debug, Clone, Copy)]
struct Layout {
    sep: Sep,
    cols: [usize; 3],
    /// The intensity's column, when a header names one.
    icol: Option<usize>,
}

/// Header names of an intensity column (lower case).
const INTENSITY_NAMES: [&str; 4] = ["intensity", "i", "scalar_intensity", "intensities"];

/// Splits a line into fields per `sep` and calls `f(index, field)` until it
/// returns false.
#[inline]
fn for_fields<'a>(line: &'a [u8], sep: Sep, mut f: impl FnMut(usize, &'a [u8]) -> bool) {
    match sep {
        Sep::Space => {
            let mut i = 0;
            let mut idx = 0;
            let n = line.len();
            while i < n {
                while i < n && (line[i] == b' ' || line[i] == b'\t') {
                    i += 1;
                }
                if i >= n {
                    break;
                }
                let s = i;
                while i < n && line[i] != b' ' && line[i] != b'\t' {
                    i += 1;
                }
                if !f(idx, &line[s..i]) {
                    return;
                }
                idx += 1;
            }
        }
        Sep::Char(c) => {
            for (idx, field) in line.split(|&b| b == c).enumerate() {
                if !f(idx, field.trim_ascii()) {
                    return;
                }
            }
        }
    }
}

/// Strips a trailing `\r` and surrounding blanks.
#[inline]
fn clean(line: &[u8]) -> &[u8] {
    line.trim_ascii()
}

/// True for lines that carry no data.
#[inline]
fn is_skip(line: &[u8]) -> bool {
    line.is_empty() || line[0] == b'#' || line.starts_with(b"//")
}

pub(super) use super::num::parse_f64;

/// Parses a block of whole lines; `first_line` is the 1-based number of its first
/// line. Appends finite points to `out`; returns the number of non-finite rows.
/// With `inten`, each kept point's intensity is appended to it (the layout's
/// intensity column; coordinate passes leave that column unparsed).
fn parse_block(
    path: &Path,
    block: &[u8],
    first_line: u64,
    layout: Layout,
    out: &mut Vec<Point>,
    mut inten: Option<&mut Vec<f32>>,
) -> Result<u64> {
    let mut skipped = 0;
    let icol = layout.icol.filter(|_| inten.is_some());
    let need = layout.cols.iter().copied().chain(icol).max().unwrap_or(0);
    for (k, raw) in block.split(|&b| b == b'\n').enumerate() {
        let line = clean(raw);
        if is_skip(line) {
            continue;
        }
        let mut v = [f64::NAN; 3];
        let mut value = f64::NAN;
        let mut seen = 0usize;
        let mut bad: Option<usize> = None;
        for_fields(line, layout.sep, |i, field| {
            if icol == Some(i) {
                match parse_f64(field) {
                    Some(x) => value = x,
                    None => {
                        bad = Some(i);
                        return false;
                    }
                }
            }
            for c in 0..3 {
                if layout.cols[c] == i {
                    match parse_f64(field) {
                        Some(x) => v[c] = x,
                        None => {
                            bad = Some(i);
                            return false;
                        }
                    }
                }
            }
            seen = i + 1;
            i < need
        });
        let line_no = first_line + k as u64;
        if let Some(i) = bad {
            return Err(Error::table(
                path,
                line_no,
                format!(
                    "column {} is not a number: {:?}",
                    i + 1,
                    String::from_utf8_lossy(field_at(line, layout.sep, i))
                ),
            ));
        }
        if seen <= need {
            return Err(Error::table(
                path,
                line_no,
                format!("expected at least {} columns, found {seen}", need + 1),
            ));
        }
        if v.iter().all(|c| c.is_finite()) {
            out.push(Point::new(v[0], v[1], v[2]));
            if let Some(inten) = inten.as_deref_mut() {
                inten.push(value as f32);
            }
        } else {
            skipped += 1;
        }
    }
    Ok(skipped)
}

/// The `i`-th field of a line (for error messages).
fn field_at(line: &[u8], sep: Sep, i: usize) -> &[u8] {
    let mut r: &[u8] = &[];
    for_fields(line, sep, |j, f| {
        if j == i {
            r = f;
            return false;
        }
        true
    });
    r
}

/// One task's points, their intensities (when asked for) and non-finite rows.
type Parsed = (Vec<Point>, Vec<f32>, u64);

/// Streaming XYZ reader.
struct XyzReader {
    info: CloudInfo,
    path: PathBuf,
    lines: LineBlocks,
    /// Layout, once the first data line was seen.
    layout: Option<Layout>,
    /// A header names an intensity column (read at open).
    intensity: bool,
    /// 1-based number of the first line of the next block.
    line_no: u64,
    stats: ReadStats,
    done: bool,
}

/// Opens a XYZ file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let file_bytes = file.metadata().map_err(|e| Error::io(path, e))?.len();
    Ok(Box::new(XyzReader {
        info: CloudInfo {
            format: Format::Xyz,
            declared_points: None,
            file_bytes,
        },
        path: path.to_path_buf(),
        lines: LineBlocks::new(file, path),
        layout: None,
        intensity: peek_layout(path).is_some_and(|l| l.icol.is_some()),
        line_no: 1,
        stats: ReadStats::default(),
        done: false,
    }))
}

/// A line's separator: a comma if it has one, else a semicolon, else
/// spaces and tabs.
fn sep_of(line: &[u8]) -> Sep {
    if line.contains(&b',') {
        Sep::Char(b',')
    } else if line.contains(&b';') {
        Sep::Char(b';')
    } else {
        Sep::Space
    }
}

/// Finds the layout from the first non-comment line. Returns the layout and
/// whether that line is a header (to be skipped).
fn detect_layout(path: &Path, line: &[u8], line_no: u64) -> Result<(Layout, bool)> {
    let sep = sep_of(line);
    let mut fields: Vec<String> = Vec::new();
    let mut numeric = true;
    for_fields(line, sep, |_, f| {
        if parse_f64(f).is_none() {
            numeric = false;
        }
        fields.push(String::from_utf8_lossy(f).into_owned());
        true
    });
    if numeric {
        if fields.len() < 3 {
            return Err(Error::table(
                path,
                line_no,
                format!(
                    "expected at least 3 columns (x y z), found {}",
                    fields.len()
                ),
            ));
        }
        return Ok((
            Layout {
                sep,
                cols: [0, 1, 2],
                icol: None,
            },
            false,
        ));
    }
    let mut cols = [usize::MAX; 3];
    let mut icol = None;
    for (i, name) in fields.iter().enumerate() {
        let n = name
            .trim_matches(|c| c == '"' || c == '\'')
            .trim()
            .to_ascii_lowercase();
        for (c, want) in ["x", "y", "z"].iter().enumerate() {
            if n == *want && cols[c] == usize::MAX {
                cols[c] = i;
            }
        }
        if icol.is_none() && INTENSITY_NAMES.contains(&n.as_str()) {
            icol = Some(i);
        }
    }
    for (c, want) in ["x", "y", "z"].iter().enumerate() {
        if cols[c] == usize::MAX {
            return Err(Error::table(
                path,
                line_no,
                format!(
                    "header line has no column named {want} (columns: {})",
                    fields.join(", ")
                ),
            ));
        }
    }
    Ok((Layout { sep, cols, icol }, true))
}

/// A CloudCompare header: a `//` comment line whose fields name x, y and z
/// (`//X,Y,Z,Intensity`); the line without its `//`.
fn comment_header(line: &[u8]) -> Option<&[u8]> {
    let rest = line.strip_prefix(b"//")?.trim_ascii();
    let sep = sep_of(rest);
    let mut named = [false; 3];
    for_fields(rest, sep, |_, f| {
        let n = String::from_utf8_lossy(f).trim().to_ascii_lowercase();
        for (c, want) in ["x", "y", "z"].iter().enumerate() {
            named[c] |= n == *want;
        }
        true
    });
    named.iter().all(|&b| b).then_some(rest)
}

/// The first data line of `lines` (a header, a comment header, or data),
/// its layout and whether it is a header; `None` when none is there yet.
/// `first` is the 1-based number of the first line; returns how many bytes
/// the lines up to and including a header take (0 up to the data line).
fn layout_of(path: &Path, lines: &[u8], first: u64) -> Result<Option<(Layout, usize)>> {
    let mut at = 0;
    let mut line_no = first;
    // The first comment that reads as a header, and its line.
    let mut comment: Option<(&[u8], u64)> = None;
    while at < lines.len() {
        let end = lines[at..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(lines.len(), |p| at + p + 1);
        let line = clean(&lines[at..end]);
        if is_skip(line) {
            if comment.is_none() {
                comment = comment_header(line).map(|h| (h, line_no));
            }
            at = end;
            line_no += 1;
            continue;
        }
        let (layout, header) = detect_layout(path, line, line_no)?;
        if header {
            return Ok(Some((layout, end)));
        }
        // A comment names the columns only when it reads as the data's: the
        // same separator and as many fields (review: "// fields: x y z i t"
        // above five numbers would have moved every column by one, and
        // "// x y z" above CSV split nothing).
        if let Some((h, n)) = comment
            && shape(h) == shape(line)
        {
            let (named, _) = detect_layout(path, h, n)?;
            return Ok(Some((named, at)));
        }
        return Ok(Some((layout, at)));
    }
    Ok(None)
}

/// A line's separator ([`sep_of`]) and field count.
fn shape(line: &[u8]) -> (Sep, usize) {
    let sep = sep_of(line);
    let mut n = 0;
    for_fields(line, sep, |_, _| {
        n += 1;
        true
    });
    (sep, n)
}

/// The layout from the file's first 1 MiB, to say at open whether it has
/// an intensity; `None` when it cannot tell (the read then says why).
fn peek_layout(path: &Path) -> Option<Layout> {
    let mut head = Vec::with_capacity(1 << 20);
    File::open(path)
        .ok()?
        .take(1 << 20)
        .read_to_end(&mut head)
        .ok()?;
    layout_of(path, &head, 1).ok().flatten().map(|l| l.0)
}

impl PointReader for XyzReader {
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
            return self.fill(buf, None);
        }
        self.fill(buf, Some(inten))
    }

    fn stats(&self) -> ReadStats {
        self.stats
    }

    fn bytes_read(&self) -> u64 {
        self.lines.bytes
    }
}

impl XyzReader {
    /// The next points, with their intensities into `inten` when given.
    fn fill(&mut self, buf: &mut Vec<Point>, mut inten: Option<&mut Vec<f32>>) -> Result<bool> {
        buf.clear();
        while !self.done {
            let Some(block) = self.lines.next_block()? else {
                self.done = true;
                break;
            };
            let mut block = block;
            let mut first = self.line_no;
            let lines_in_block = block.iter().filter(|&&b| b == b'\n').count() as u64;
            self.line_no += lines_in_block;
            if self.layout.is_none() {
                // Skip comment lines up to the first data line and detect the
                // layout; a header (or comment header) is skipped too.
                if let Some((layout, skip)) = layout_of(&self.path, block, first)? {
                    self.layout = Some(layout);
                    first += block[..skip].iter().filter(|&&b| b == b'\n').count() as u64;
                    block = &block[skip..];
                } else {
                    block = &[];
                }
            }
            let Some(layout) = self.layout else { continue };
            // Split the block into tasks on line boundaries, parse in parallel.
            let mut tasks: Vec<(&[u8], u64)> = Vec::new();
            let mut rest = block;
            let mut line = first;
            while !rest.is_empty() {
                let cut = if rest.len() <= TASK_BYTES {
                    rest.len()
                } else {
                    rest[TASK_BYTES..]
                        .iter()
                        .position(|&b| b == b'\n')
                        .map_or(rest.len(), |p| TASK_BYTES + p + 1)
                };
                let (a, b) = rest.split_at(cut);
                tasks.push((a, line));
                line += a.iter().filter(|&&b| b == b'\n').count() as u64;
                rest = b;
            }
            let path = &self.path;
            let want = inten.is_some();
            let parts: Vec<Result<Parsed>> = tasks
                .par_iter()
                .map(|&(t, l)| {
                    let mut out = Vec::with_capacity(t.len() / 24);
                    let mut values = Vec::new();
                    let skipped =
                        parse_block(path, t, l, layout, &mut out, want.then_some(&mut values))?;
                    Ok((out, values, skipped))
                })
                .collect();
            for part in parts {
                let (pts, values, skipped) = part?;
                buf.extend_from_slice(&pts);
                if let Some(inten) = inten.as_deref_mut() {
                    inten.extend_from_slice(&values);
                }
                self.stats.skipped_nonfinite += skipped;
            }
            if !buf.is_empty() {
                break;
            }
        }
        self.stats.points += buf.len() as u64;
        Ok(!buf.is_empty())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn file(text: &str) -> tempfile::NamedTempFile {
        let mut f = tempfile::Builder::new().suffix(".xyz").tempfile().unwrap();
        f.write_all(text.as_bytes()).unwrap();
        f.flush().unwrap();
        f
    }

    fn read(text: &str) -> Result<(Vec<Point>, ReadStats)> {
        let f = file(text);
        let mut r = open(f.path())?;
        let mut all = Vec::new();
        let mut buf = Vec::new();
        while r.next_chunk(&mut buf)? {
            all.extend_from_slice(&buf);
        }
        Ok((all, r.stats()))
    }

    #[test]
    fn fast_number_parser_matches_std() {
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let mut cases: Vec<String> = [
            "0",
            "-0",
            "1",
            "+2.5",
            "350123.456",
            "4150234.567",
            ".5",
            "5.",
            "-.25",
            "1e3",
            "1.5E-3",
            "nan",
            "inf",
            "-inf",
            "123456789012345678",
            "0.1",
            "9007199254740993",
            "1234567890.1234567891",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        for _ in 0..20000 {
            let int = next() % 10_000_000;
            let dec = next() % 1_000_000;
            let w = (next() % 7) as usize;
            cases.push(format!(
                "{}{int}.{dec:0w$}",
                if next() % 2 == 0 { "-" } else { "" }
            ));
        }
        for c in &cases {
            let want = c.parse::<f64>().ok();
            let got = parse_f64(c.as_bytes());
            assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "{c}");
        }
        for bad in ["", "-", ".", "1.2.3", "abc", "1,5", "--1"] {
            assert_eq!(parse_f64(bad.as_bytes()), None, "{bad}");
        }
    }

    #[test]
    fn plain_space_separated_with_comments() {
        let (p, s) =
            read("# a comment\n// another\n\n1 2 3\n4\t5  6 7 8\r\n350123.456 4150234.567 12.5")
                .unwrap();
        assert_eq!(
            p,
            vec![
                Point::new(1., 2., 3.),
                Point::new(4., 5., 6.),
                Point::new(350123.456, 4150234.567, 12.5)
            ]
        );
        assert_eq!(s.points, 3);
    }

    #[test]
    fn header_names_columns() {
        let (p, _) = read("intensity,Z,y,X\n9,3,2,1\n9, 6 ,5,4\n").unwrap();
        assert_eq!(p, vec![Point::new(1., 2., 3.), Point::new(4., 5., 6.)]);
        let (p, _) = read("X\tY\tZ\tr\n1\t2\t3\t4\n").unwrap();
        assert_eq!(p, vec![Point::new(1., 2., 3.)]);
    }

    #[test]
    fn comma_and_nan() {
        let (p, s) = read("1,2,3\nnan,1,1\n4,5,inf\n7,8,9\n").unwrap();
        assert_eq!(p, vec![Point::new(1., 2., 3.), Point::new(7., 8., 9.)]);
        assert_eq!(s.skipped_nonfinite, 2);
    }

    #[test]
    fn bad_rows_name_the_line() {
        let e = read("1 2 3\n4 5\n").unwrap_err().to_string();
        assert!(e.contains(":2:") && e.contains("at least 3 columns"), "{e}");
        let e = read("# c\n1 2 3\n4 5 abc\n").unwrap_err().to_string();
        assert!(
            e.contains(":3:") && e.contains("column 3") && e.contains("abc"),
            "{e}"
        );
        let e = read("a,b,c\n1,2,3\n").unwrap_err().to_string();
        assert!(e.contains(":1:") && e.contains("no column named x"), "{e}");
    }

    #[test]
    fn many_lines_across_blocks_keep_order_and_line_numbers() {
        let mut s = String::new();
        let n = 300_000;
        for i in 0..n {
            s.push_str(&format!("{i} {}.5 -{i}\n", i * 2));
        }
        let (p, st) = read(&s).unwrap();
        assert_eq!(p.len(), n);
        assert_eq!(st.points, n as u64);
        for (i, q) in p.iter().enumerate().step_by(9973) {
            assert_eq!(*q, Point::new(i as f64, i as f64 * 2. + 0.5, -(i as f64)));
        }
        s.push_str("1 2 x\n");
        let e = read(&s).unwrap_err().to_string();
        assert!(e.contains(&format!(":{}:", n + 1)), "{e}");
    }

    /// Points and intensities of a text file (`None` without an intensity).
    fn read_intensity(text: &str) -> Result<(Vec<Point>, Option<Vec<f32>>)> {
        let f = file(text);
        let mut r = open(f.path())?;
        let has = r.has_intensity();
        let (mut all, mut values) = (Vec::new(), Vec::new());
        let (mut buf, mut inten) = (Vec::new(), Vec::new());
        while r.next_chunk_intensity(&mut buf, &mut inten)? {
            assert_eq!(inten.len(), if has { buf.len() } else { 0 });
            all.extend_from_slice(&buf);
            values.extend_from_slice(&inten);
        }
        Ok((all, has.then_some(values)))
    }

    /// Issue 33: a header naming an intensity column gives the boards'
    /// intensity, in any column and with any separator, CloudCompare's
    /// `//X,Y,Z,Intensity` header too; without a header a fourth column is
    /// not taken for one. Coordinates read alike either way, a bad
    /// intensity token is said with its line, and non-finite rows drop
    /// their intensity with them.
    #[test]
    fn intensity_from_a_header_naming_it() {
        let (p, i) = read_intensity("x y z intensity\n1 2 3 0.5\n4 5 6 7\n").unwrap();
        assert_eq!(p, vec![Point::new(1., 2., 3.), Point::new(4., 5., 6.)]);
        assert_eq!(i, Some(vec![0.5, 7.0]));
        let (p, i) =
            read_intensity("# scan\nIntensity;Z;Y;X\n9;3;2;1\n8;nan;5;4\n7;6;5;4\n").unwrap();
        assert_eq!(p, vec![Point::new(1., 2., 3.), Point::new(4., 5., 6.)]);
        assert_eq!(i, Some(vec![9.0, 7.0]));
        let (p, i) =
            read_intensity("//X,Y,Z,R,G,B,Intensity\n1,2,3,0,0,0,120\n4,5,6,0,0,0,30\n").unwrap();
        assert_eq!(p, vec![Point::new(1., 2., 3.), Point::new(4., 5., 6.)]);
        assert_eq!(i, Some(vec![120.0, 30.0]));
        let (p, i) = read_intensity("\"x\",\"y\",\"z\",\"scalar_intensity\"\n1,2,3,4\n").unwrap();
        assert_eq!((p.len(), i), (1, Some(vec![4.0])));
        // No header, or a header without one: no intensity.
        assert_eq!(read_intensity("1 2 3 0.5\n4 5 6 7\n").unwrap().1, None);
        assert_eq!(read_intensity("x,y,z,time\n1,2,3,4\n").unwrap().1, None);
        // A plain comment is not a header, nor one that does not read as
        // the data's columns (another count, another separator).
        let (p, i) = read_intensity("// exported by a tool\n1 2 3 4\n").unwrap();
        assert_eq!((p.len(), i), (1, None));
        let (p, i) = read_intensity("// fields: x y z intensity time\n1 2 3 40 9.5\n").unwrap();
        assert_eq!((p, i), (vec![Point::new(1., 2., 3.)], None));
        let (p, i) = read_intensity("// x y z\n1,2,3\n").unwrap();
        assert_eq!((p, i), (vec![Point::new(1., 2., 3.)], None));
        // Coordinates never parse the intensity; the intensity pass does.
        let bad = "x y z i\n1 2 3 0.5\n4 5 6 bright\n";
        assert_eq!(read(bad).unwrap().0.len(), 2);
        let e = read_intensity(bad).unwrap_err().to_string();
        assert!(
            e.contains(":3:") && e.contains("column 4") && e.contains("bright"),
            "{e}"
        );
    }
}
