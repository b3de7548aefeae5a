//! The PCD header: FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, POINTS and DATA,
//! parsed and checked before any data is read.

use super::MAX_HEADER;
use crate::cloud::scalar::Scalar;
use crate::{Error, Result};
use std::path::Path;

/// Largest point record accepted (bytes); real files use well under 1 KiB.
const MAX_POINT_SIZE: usize = 1 << 16;

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
pub(super) struct Field {
    pub(super) name: String,
    pub(super) size: usize,
    pub(super) count: usize,
    pub(super) kind: Scalar,
    /// Byte offset inside a binary point record.
    pub(super) offset: usize,
    /// Index of its first value among the tokens of an ascii line.
    pub(super) token: usize,
}

/// How the point data is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum DataKind {
    Ascii,
    Binary,
    Compressed,
}

/// A parsed and validated PCD header.
#[derive(Debug)]
pub(super) struct Header {
    pub(super) fields: Vec<Field>,
    pub(super) point_size: usize,
    pub(super) tokens_per_line: usize,
    pub(super) points: u64,
    pub(super) data: DataKind,
    /// Byte offset of the first data byte.
    pub(super) data_offset: usize,
    /// Number of header lines (data line numbers follow it).
    pub(super) lines: u64,
    /// Indices into `fields` of x, y, z.
    pub(super) xyz: [usize; 3],
}

impl Header {
    /// The index of the `intensity` field (exact name first, then any case,
    /// then the short `i` some writers use), when it holds one value.
    pub(super) fn intensity_field(&self) -> Option<usize> {
        let named = |want: &str, exact: bool| {
            self.fields.iter().position(|f| {
                if exact {
                    f.name == want
                } else {
                    f.name.eq_ignore_ascii_case(want)
                }
            })
        };
        let i = named("intensity", true)
            .or_else(|| named("intensity", false))
            .or_else(|| named("i", false))?;
        (self.fields[i].count == 1).then_some(i)
    }
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
pub(super) fn parse_header(path: &Path, bytes: &[u8]) -> Result<Header> {
    let raw = Keywords::read(path, bytes)?;
    let (names_line, names) = raw
        .names
        .filter(|(_, n)| !n.is_empty())
        .ok_or_else(|| Error::format(path, "header has no FIELDS line"))?;
    let columns = Columns::check(
        path,
        (names_line, names.len()),
        raw.sizes,
        raw.types,
        raw.counts,
    )?;
    let (fields, point_size, tokens_per_line) = lay_out_fields(path, &names, &columns)?;
    let find = |want: &str| find_field(path, &fields, (names_line, &names), want);
    let xyz = [find("x")?, find("y")?, find("z")?];
    let points = point_count(path, raw.points, raw.width, raw.height.unwrap_or(1))?;
    Ok(Header {
        fields,
        point_size,
        tokens_per_line,
        points,
        data: raw.data,
        data_offset: raw.pos,
        lines: raw.lineno,
        xyz,
    })
}

/// The header's keyword lines as written (each list with its line number,
/// for errors), up to and including DATA.
struct Keywords {
    names: Option<(u64, Vec<String>)>,
    sizes: Option<(u64, Vec<usize>)>,
    types: Option<(u64, Vec<String>)>,
    counts: Option<(u64, Vec<usize>)>,
    width: Option<u64>,
    height: Option<u64>,
    points: Option<u64>,
    data: DataKind,
    /// Byte offset just after the DATA line.
    pos: usize,
    /// Line number of the DATA line.
    lineno: u64,
}

impl Keywords {
    /// Reads lines until DATA; a header cut short (or too long) is an error.
    fn read(path: &Path, bytes: &[u8]) -> Result<Keywords> {
        let mut l = Keywords {
            names: None,
            sizes: None,
            types: None,
            counts: None,
            width: None,
            height: None,
            points: None,
            data: DataKind::Ascii,
            pos: 0,
            lineno: 0,
        };
        let mut data = None;
        while data.is_none() {
            if l.pos >= bytes.len() {
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
            l.lineno += 1;
            let rest = &bytes[l.pos..];
            let (raw, next) = match rest.iter().position(|&b| b == b'\n') {
                Some(i) => (&rest[..i], l.pos + i + 1),
                None => (rest, bytes.len()),
            };
            l.pos = next;
            let line = std::str::from_utf8(raw)
                .map_err(|_| Error::table(path, l.lineno, "header line is not UTF-8 text"))?;
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            data = l.take(path, line)?;
        }
        l.data = data.unwrap_or(DataKind::Ascii);
        Ok(l)
    }

    /// Takes one keyword line; returns the data kind when it is DATA's.
    fn take(&mut self, path: &Path, line: &str) -> Result<Option<DataKind>> {
        let lineno = self.lineno;
        let mut it = line.split_ascii_whitespace();
        let key = it.next().unwrap_or_default();
        let vals: Vec<&str> = it.collect();
        match key.to_ascii_uppercase().as_str() {
            "VERSION" | "VIEWPOINT" => {}
            "FIELDS" | "COLUMNS" => {
                self.names = Some((lineno, vals.iter().map(|s| s.to_string()).collect()));
            }
            "SIZE" => {
                self.sizes = Some((lineno, parse_usize_list(path, "SIZE", lineno, &vals, 1)?))
            }
            "TYPE" => {
                self.types = Some((
                    lineno,
                    vals.iter().map(|s| s.to_ascii_uppercase()).collect(),
                ))
            }
            "COUNT" => {
                self.counts = Some((lineno, parse_usize_list(path, "COUNT", lineno, &vals, 1)?))
            }
            "WIDTH" => self.width = Some(parse_u64(path, "WIDTH", lineno, &vals)?),
            "HEIGHT" => self.height = Some(parse_u64(path, "HEIGHT", lineno, &vals)?),
            "POINTS" => self.points = Some(parse_u64(path, "POINTS", lineno, &vals)?),
            "DATA" => return data_kind(path, lineno, &vals).map(Some),
            // PCL ignores keywords it does not know; so do we.
            _ => {}
        }
        Ok(None)
    }
}

/// The DATA line's storage kind.
fn data_kind(path: &Path, lineno: u64, vals: &[&str]) -> Result<DataKind> {
    match vals.first().map(|s| s.to_ascii_lowercase()).as_deref() {
        Some("ascii") => Ok(DataKind::Ascii),
        Some("binary") => Ok(DataKind::Binary),
        Some("binary_compressed") => Ok(DataKind::Compressed),
        other => Err(Error::table(
            path,
            lineno,
            format!(
                "unknown DATA '{}' (expected ascii, binary or binary_compressed)",
                other.unwrap_or("")
            ),
        )),
    }
}

/// SIZE, TYPE and COUNT, one entry per field, PCL's defaults filled in.
struct Columns {
    sizes: Vec<usize>,
    /// The TYPE line (0 when absent), for errors.
    types_line: u64,
    types: Vec<String>,
    counts: Vec<usize>,
}

impl Columns {
    /// Checks that each list has one entry per field (`n` FIELDS at line
    /// `names_line`); v0.5 files may lack SIZE / TYPE / COUNT: PCL's
    /// defaults are 4, F and 1.
    fn check(
        path: &Path,
        (names_line, n): (u64, usize),
        sizes: Option<(u64, Vec<usize>)>,
        types: Option<(u64, Vec<String>)>,
        counts: Option<(u64, Vec<usize>)>,
    ) -> Result<Columns> {
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
        Ok(Columns {
            sizes,
            types_line,
            types,
            counts,
        })
    }
}

/// The fields with their scalar kinds and where each sits in a binary record
/// and an ascii line; returns them with the record's size and the tokens of
/// a line. A TYPE/SIZE pair the format has no scalar for, or a record too
/// large, is refused.
fn lay_out_fields(
    path: &Path,
    names: &[String],
    c: &Columns,
) -> Result<(Vec<Field>, usize, usize)> {
    let mut fields = Vec::with_capacity(names.len());
    let mut offset = 0usize;
    let mut token = 0usize;
    for (i, name) in names.iter().enumerate() {
        let (size, ty, count) = (c.sizes[i], c.types[i].as_str(), c.counts[i]);
        if !matches!(ty, "F" | "I" | "U") {
            return Err(Error::table(
                path,
                c.types_line,
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
    Ok((fields, offset, token))
}

/// The index of field `want`: an exact name first, else one differing only
/// in case.
fn find_field(
    path: &Path,
    fields: &[Field],
    (names_line, names): (u64, &[String]),
    want: &str,
) -> Result<usize> {
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
}

/// The point count: POINTS, which must agree with WIDTH x HEIGHT when both
/// are given, else WIDTH x HEIGHT.
fn point_count(path: &Path, points: Option<u64>, width: Option<u64>, height: u64) -> Result<u64> {
    Ok(match (points, width) {
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
    })
}
