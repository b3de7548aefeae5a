//! The CSV tables survey and estimate files are: delimiter sniffing,
//! header matching (with a misspelt column named), rows with their line.

use crate::{Error, Result};
use std::collections::HashSet;
use std::path::Path;

/// A header-indexed CSV reader with file/line error reporting.
pub(super) struct Table {
    pub(super) path: std::path::PathBuf,
    pub(super) headers: Vec<String>,
    /// The header's line in the file (comments may come first).
    pub(super) header_line: u64,
    pub(super) rows: Vec<(u64, csv::StringRecord)>,
}

/// The field separator of a survey or estimates table, from its first line
/// that is neither blank nor a comment: `;` or a tab when that line has no
/// comma but has those (spreadsheet exports in many locales), else `,`.
pub(super) fn sniff_delimiter(bytes: &[u8]) -> u8 {
    let first = bytes
        .split(|b| *b == b'\n')
        .map(|l| l.trim_ascii())
        .find(|l| !l.is_empty() && *l != b",")
        .unwrap_or(b"");
    if first.contains(&b',') {
        b','
    } else if first.contains(&b';') {
        b';'
    } else if first.contains(&b'\t') {
        b'\t'
    } else {
        b','
    }
}

impl Table {
    pub(super) fn read(path: &Path) -> Result<Table> {
        let raw = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        // Blank out comment lines but keep their newlines, so csv's line numbers
        // stay those of the file (csv counts neither its comments nor blank lines;
        // a lone comma is a record of empty fields, skipped below).
        let mut bytes = Vec::with_capacity(raw.len());
        for l in raw.split_inclusive(|b| *b == b'\n') {
            let t = l.trim_ascii_start();
            if t.is_empty() && l.ends_with(b"\n") || t.starts_with(b"#") {
                bytes.extend_from_slice(b",\n");
            } else {
                bytes.extend_from_slice(l);
            }
        }
        let delimiter = sniff_delimiter(&bytes);
        // A blanked comment line is a lone separator: keep it one for `;`/tab files.
        if delimiter != b',' {
            for l in bytes.split_mut(|b| *b == b'\n') {
                if l == b"," {
                    l[0] = delimiter;
                }
            }
        }
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .delimiter(delimiter)
            .trim(csv::Trim::All)
            .from_reader(bytes.as_slice());
        let mut headers = None;
        let mut header_line = 1;
        let mut rows = Vec::new();
        // Lines counted from the record's byte offset: on CRLF files (survey
        // software and spreadsheets on Windows write them) csv ends a record
        // at its `\r` and starts the next at the `\n`, so its own line count
        // named the line above in every message. A `\n` at the record's
        // offset ends the line before it.
        // (A lone `\r`, an old Mac's line end, ends a line too.)
        let breaks: Vec<usize> = (0..bytes.len())
            .filter(|&i| bytes[i] == b'\n' || bytes[i] == b'\r' && bytes.get(i + 1) != Some(&b'\n'))
            .collect();
        let line_at = |p: Option<&csv::Position>| {
            p.map_or(0, |p| {
                let at = p.byte() as usize;
                breaks.partition_point(|&b| b <= at) as u64 + 1
            })
        };
        for rec in rdr.records() {
            let rec = rec.map_err(|e| {
                let line = line_at(e.position());
                // csv's own text carries its line count and an offset into
                // the comment-blanked copy: the kind alone.
                let what = match e.kind() {
                    csv::ErrorKind::Utf8 { err, .. } => {
                        format!("not UTF-8 text ({err}): save the file as UTF-8")
                    }
                    csv::ErrorKind::Io(err) => err.to_string(),
                    _ => e.to_string(),
                };
                Error::table(path, line, format!("not valid CSV: {what}"))
            })?;
            let line = line_at(rec.position());
            if rec.iter().all(|f| f.is_empty()) {
                continue;
            }
            if headers.is_none() {
                // A first row of numbers is data, not names: say so rather than
                // guess which columns they are.
                if rec.len() >= 3 && rec.iter().skip(1).all(|f| f.parse::<f64>().is_ok()) {
                    return Err(Error::table(
                        path,
                        line,
                        format!(
                            "no header line (this row holds numbers: `{}`); the first line must name the columns, e.g. `id,x,y,z` (local metres) or `id,lat,lon,alt` (WGS84)",
                            rec.iter().collect::<Vec<_>>().join(",")
                        ),
                    ));
                }
                let h: Vec<String> = rec.iter().map(|f| f.to_ascii_lowercase()).collect();
                let mut seen = HashSet::new();
                for name in &h {
                    if !name.is_empty() && !seen.insert(name.clone()) {
                        return Err(Error::table(
                            path,
                            line,
                            format!("column `{name}` appears twice"),
                        ));
                    }
                }
                headers = Some(h);
                header_line = line;
            } else {
                rows.push((line, rec));
            }
        }
        let headers = headers.ok_or_else(|| Error::table(path, 0, "empty file: no header line"))?;
        Ok(Table {
            path: path.to_path_buf(),
            headers,
            header_line,
            rows,
        })
    }

    pub(super) fn col(&self, names: &[&str]) -> Option<usize> {
        self.headers
            .iter()
            .position(|h| names.contains(&h.as_str()))
    }

    /// The row's target id, refused when an earlier row had it (`seen`).
    pub(super) fn unique_id(
        &self,
        line: u64,
        rec: &csv::StringRecord,
        col: usize,
        seen: &mut HashSet<String>,
    ) -> Result<String> {
        let id = self.field(line, rec, col, "id")?.to_string();
        if !seen.insert(id.clone()) {
            return Err(Error::table(
                &self.path,
                line,
                format!("duplicate target id `{id}`"),
            ));
        }
        Ok(id)
    }

    pub(super) fn field<'a>(
        &self,
        line: u64,
        rec: &'a csv::StringRecord,
        col: usize,
        name: &str,
    ) -> Result<&'a str> {
        match rec.get(col) {
            Some(s) if !s.is_empty() => Ok(s),
            _ => Err(Error::table(
                &self.path,
                line,
                format!("missing value in column `{name}`"),
            )),
        }
    }

    pub(super) fn number(
        &self,
        line: u64,
        rec: &csv::StringRecord,
        col: usize,
        name: &str,
    ) -> Result<f64> {
        let s = self.field(line, rec, col, name)?;
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => {
                // A spreadsheet's decimal comma (`-0,2125`): say so.
                let comma = s.contains(',') && s.replace(',', ".").parse::<f64>().is_ok();
                let hint = if comma {
                    format!(
                        " (a decimal comma? numbers are read with a decimal point: `{}`)",
                        s.replace(',', ".")
                    )
                } else {
                    String::new()
                };
                Err(Error::table(
                    &self.path,
                    line,
                    format!("column `{name}`: `{s}` is not a finite number{hint}"),
                ))
            }
        }
    }

    pub(super) fn opt_number(
        &self,
        line: u64,
        rec: &csv::StringRecord,
        col: Option<usize>,
        name: &str,
    ) -> Result<Option<f64>> {
        match col {
            Some(c) if rec.get(c).is_some_and(|s| !s.is_empty()) => {
                self.number(line, rec, c, name).map(Some)
            }
            _ => Ok(None),
        }
    }

    pub(super) fn require(&self, names: &[&str]) -> Result<usize> {
        self.col(names).ok_or_else(|| {
            Error::table(
                &self.path,
                self.header_line,
                format!(
                    "missing column `{}` (header has: {})",
                    names[0],
                    self.headers.join(",")
                ),
            )
        })
    }
}

/// `point`: how survey controllers export a point's name (`Point,Easting,
/// Northing,Elevation`). Not `station`: a total station's export names the
/// instrument's station beside each point.
pub(super) const ID: &[&str] = &["id", "name", "target", "point", "pt"];
pub(super) const X: &[&str] = &["x", "east", "easting", "e"];
pub(super) const Y: &[&str] = &["y", "north", "northing", "n"];
pub(super) const Z: &[&str] = &["z", "up", "u", "height"];
pub(super) const LAT: &[&str] = &["lat", "latitude"];
pub(super) const LON: &[&str] = &["lon", "lng", "long", "longitude"];
pub(super) const ALT: &[&str] = &["alt", "altitude", "h", "ellipsoidal_height"];
pub(super) const ROLE: &[&str] = &["role"];
pub(super) const ANTENNA: &[&str] = &["antenna_height", "antenna"];
pub(super) const MODEL: &[&str] = &["model"];
pub(super) const SIZE: &[&str] = &["size", "size_m"];

/// Height columns under names mapgauge does not read.
pub(super) const ELEVATION: &[&str] = &[
    "elevation",
    "elev",
    "orthometric_height",
    "ortho_height",
    "hgt",
];

/// The survey column that header `h` (lowercase) most likely meant, when it
/// is not itself one: the same letters but for separators (`antenna height`),
/// a name with a unit after it (`alt_m`, `lat (deg)`), or one of the long
/// names (seven letters or more: `antenna_height`, `latitude`, `easting`...)
/// with up to two typos and at most one letter more or less. Other extra
/// columns (`description`, `note`, `weight`, `easting_sd`) are ignored.
pub(super) fn misspelt_column(h: &str) -> Option<&'static str> {
    let known = || {
        [ID, X, Y, Z, LAT, LON, ALT, ROLE, ANTENNA, MODEL, SIZE]
            .into_iter()
            .flatten()
            .copied()
    };
    if h.is_empty() || known().any(|k| k == h) {
        return None;
    }
    let norm = |s: &str| -> String { s.chars().filter(|c| c.is_ascii_alphanumeric()).collect() };
    // A unit after a separator: `alt_m`, `z [m]`, `lat(deg)`.
    let stem = ["metres", "meters", "degrees", "deg", "m"]
        .iter()
        .find_map(|u| {
            let t = h.trim_end_matches([')', ']', ' ']);
            let head = t.strip_suffix(u)?;
            let head2 = head.trim_end_matches(['_', '-', ' ', '(', '[']);
            (head2.len() < head.len()).then_some(head2)
        });
    let n = norm(h);
    known().find(|k| {
        let nk = norm(k);
        nk == n
            || stem.is_some_and(|s| norm(s) == nk)
            || (nk.len() >= 7 && n.len().abs_diff(nk.len()) <= 1 && levenshtein(&n, &nk) <= 2)
    })
}

/// Edit distance between two short ASCII strings.
pub(super) fn levenshtein(a: &str, b: &str) -> usize {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, &ca) in a.iter().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}
