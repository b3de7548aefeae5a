//! The PLY header: format, elements and their properties, and where x, y, z
//! sit in the vertex element.

use crate::cloud::scalar::Scalar as Ty;
use crate::{Error, Result};
use std::fs::File;
use std::io::Read;
use std::path::Path;

/// Headers longer than this are rejected.
const MAX_HEADER: usize = 1 << 20;

impl Ty {
    fn parse(s: &str) -> Option<Ty> {
        Some(match s {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }
}

/// One property of an element.
#[derive(Debug, Clone)]
pub(super) enum Prop {
    Scalar(Ty),
    /// A list: count type, item type.
    List(Ty, Ty),
}

#[derive(Debug, Clone)]
pub(super) struct Element {
    pub(super) name: String,
    pub(super) count: u64,
    pub(super) props: Vec<(String, Prop)>,
}

impl Element {
    /// Byte size of one instance when it has no list property.
    pub(super) fn fixed_size(&self) -> Option<usize> {
        self.props.iter().try_fold(0usize, |acc, (_, p)| match p {
            Prop::Scalar(t) => Some(acc + t.size()),
            Prop::List(..) => None,
        })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Encoding {
    Ascii,
    BinLe,
    BinBe,
}

/// A parsed header.
#[derive(Debug)]
pub(super) struct Header {
    pub(super) encoding: Encoding,
    pub(super) elements: Vec<Element>,
    /// Byte offset of the first data byte.
    pub(super) data_offset: usize,
    /// Number of header lines (data line numbers follow).
    pub(super) lines: u64,
}

pub(super) fn parse_header(path: &Path, file: &mut File) -> Result<Header> {
    let mut head = Vec::with_capacity(4096);
    file.by_ref()
        .take(MAX_HEADER as u64)
        .read_to_end(&mut head)
        .map_err(|e| Error::io(path, e))?;
    let mut pos = 0usize;
    let mut line_no = 0u64;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(nl) = head[pos..].iter().position(|&b| b == b'\n') else {
            return Err(Error::format(
                path,
                format!(
                    "PLY header never ends: no end_header line {}",
                    if head.len() >= MAX_HEADER {
                        format!("within the first {} KiB", MAX_HEADER >> 10)
                    } else {
                        "before the end of the file".to_string()
                    }
                ),
            ));
        };
        let raw = &head[pos..pos + nl];
        pos += nl + 1;
        line_no += 1;
        let bad = |msg: String| Error::table(path, line_no, format!("PLY header: {msg}"));
        let line = std::str::from_utf8(raw)
            .map_err(|_| bad("not valid UTF-8 text".into()))?
            .trim();
        let mut words = line.split_ascii_whitespace();
        let Some(key) = words.next() else { continue };
        if line_no == 1 {
            if key != "ply" {
                return Err(bad(format!("expected 'ply', found {line:?}")));
            }
            continue;
        }
        match key {
            "comment" | "obj_info" => {}
            "format" => {
                encoding = Some(match words.next() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::BinLe,
                    Some("binary_big_endian") => Encoding::BinBe,
                    other => return Err(bad(format!("unknown format {:?}", other.unwrap_or("")))),
                });
            }
            "element" => {
                let (Some(name), Some(count)) = (words.next(), words.next()) else {
                    return Err(bad("expected 'element NAME COUNT'".into()));
                };
                let count = count
                    .parse::<u64>()
                    .map_err(|_| bad(format!("element count {count:?} is not a number")))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            "property" => {
                let Some(el) = elements.last_mut() else {
                    return Err(bad("property before any element".into()));
                };
                let w: Vec<&str> = words.collect();
                let ty = |s: &str| {
                    Ty::parse(s).ok_or_else(|| bad(format!("unknown property type {s:?}")))
                };
                let (name, prop) = match w.as_slice() {
                    ["list", ct, it, name] => {
                        let ct = ty(ct)?;
                        if matches!(ct, Ty::F32 | Ty::F64) {
                            return Err(bad("list count type must be an integer".into()));
                        }
                        (*name, Prop::List(ct, ty(it)?))
                    }
                    [t, name] => (*name, Prop::Scalar(ty(t)?)),
                    _ => return Err(bad(format!("malformed property line {line:?}"))),
                };
                el.props.push((name.to_string(), prop));
            }
            "end_header" => break,
            other => return Err(bad(format!("unknown keyword {other:?}"))),
        }
    }
    let Some(encoding) = encoding else {
        return Err(Error::format(path, "PLY header has no format line"));
    };
    Ok(Header {
        encoding,
        elements,
        data_offset: pos,
        lines: line_no,
    })
}

/// Where x, y, z live in a vertex.
#[derive(Debug, Clone, Copy)]
pub(super) struct Xyz {
    /// Property index of x, y, z.
    pub(super) idx: [usize; 3],
    pub(super) ty: [Ty; 3],
}

pub(super) fn find_xyz(path: &Path, v: &Element) -> Result<Xyz> {
    let mut idx = [0usize; 3];
    let mut ty = [Ty::F32; 3];
    for (c, want) in ["x", "y", "z"].iter().enumerate() {
        let Some(i) = v.props.iter().position(|(n, _)| n == want) else {
            return Err(Error::format(
                path,
                format!("PLY vertex element has no '{want}' property"),
            ));
        };
        match v.props[i].1 {
            Prop::Scalar(t @ (Ty::F32 | Ty::F64)) => ty[c] = t,
            _ => {
                return Err(Error::format(
                    path,
                    format!("PLY vertex property '{want}' must be float or double"),
                ));
            }
        }
        idx[c] = i;
    }
    Ok(Xyz { idx, ty })
}
