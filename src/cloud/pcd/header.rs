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
