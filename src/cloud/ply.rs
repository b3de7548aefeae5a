//! PLY reader (ascii, binary little and big endian).
//!
//! Hand-written: the header is parsed line by line; binary vertex data with a
//! fixed stride goes to the `pread` record reader (`records.rs`); vertex elements
//! with list properties (variable stride) are walked sequentially; ascii data is
//! streamed in blocks of lines. Elements before `vertex` are skipped, elements
//! after it are ignored.

use super::xyz::{LineBlocks, parse_f64};
use super::{CloudInfo, Format, PointReader, ReadStats, records};
use crate::{Error, Point, Result};
use memmap2::Mmap;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// Points per `next_chunk` call.
const CHUNK: usize = 1 << 19;
/// Headers longer than this are rejected.
const MAX_HEADER: usize = 1 << 20;

use super::scalar::Scalar as Ty;

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
enum Prop {
    Scalar(Ty),
    /// A list: count type, item type.
    List(Ty, Ty),
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<(String, Prop)>,
}

impl Element {
    /// Byte size of one instance when it has no list property.
    fn fixed_size(&self) -> Option<usize> {
        self.props.iter().try_fold(0usize, |acc, (_, p)| match p {
            Prop::Scalar(t) => Some(acc + t.size()),
            Prop::List(..) => None,
        })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    BinLe,
    BinBe,
}

/// A parsed header.
#[derive(Debug)]
struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Byte offset of the first data byte.
    data_offset: usize,
    /// Number of header lines (data line numbers follow).
    lines: u64,
}

fn parse_header(path: &Path, file: &mut File) -> Result<Header> {
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
struct Xyz {
    /// Property index of x, y, z.
    idx: [usize; 3],
    ty: [Ty; 3],
}

fn find_xyz(path: &Path, v: &Element) -> Result<Xyz> {
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

/// How the vertex data is read.
enum Body {
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

struct PlyReader {
    path: PathBuf,
    info: CloudInfo,
    be: bool,
    xyz: Xyz,
    total: u64,
    next: u64,
    body: Body,
    stats: ReadStats,
    bytes: u64,
    /// The vertex element is the last one: nothing but blanks may follow it.
    vertex_last: bool,
}

/// Walks one binary element instance with list properties starting at `pos`;
/// returns its end, or `None` if the data ends first.
#[inline]
fn walk(map: &[u8], pos: usize, props: &[Prop], be: bool) -> Option<usize> {
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

/// Opens a PLY file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    let mut file = File::open(path).map_err(|e| Error::io(path, e))?;
    let file_bytes = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let header = parse_header(path, &mut file)?;
    let Some(vi) = header.elements.iter().position(|e| e.name == "vertex") else {
        return Err(Error::format(path, "PLY header has no 'vertex' element"));
    };
    let vertex = &header.elements[vi];
    let xyz = find_xyz(path, vertex)?;
    let total = vertex.count;
    // Only then can data after the vertices be told apart from other elements.
    let vertex_last = vi + 1 == header.elements.len();
    let be = header.encoding == Encoding::BinBe;
    let props: Vec<Prop> = vertex.props.iter().map(|(_, p)| p.clone()).collect();
    let body = if header.encoding == Encoding::Ascii {
        file.seek(SeekFrom::Start(header.data_offset as u64))
            .map_err(|e| Error::io(path, e))?;
        let mut lines = LineBlocks::new(file, path);
        let mut line_no = header.lines + 1;
        // Skip the lines of the elements before the vertex element.
        let mut skip: u64 = header.elements[..vi]
            .iter()
            .fold(0u64, |a, e| a.saturating_add(e.count));
        let mut pending = Vec::new();
        while skip > 0 {
            let Some(block) = lines.next_block()? else {
                return Err(Error::format(
                    path,
                    "PLY data ends before the vertex element starts",
                ));
            };
            let mut rest = block;
            while skip > 0 && !rest.is_empty() {
                let end = rest
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(rest.len(), |p| p + 1);
                if !rest[..end].trim_ascii().is_empty() {
                    skip -= 1;
                }
                line_no += 1;
                rest = &rest[end..];
            }
            pending = rest.to_vec();
        }
        Body::Ascii {
            lines,
            line_no,
            props,
            pending,
        }
    } else {
        // SAFETY: the map is only read; a file truncated by another process while
        // mapped is the usual mmap caveat (SIGBUS), accepted for map files.
        let map = unsafe { Mmap::map(&file) }.map_err(|e| Error::io(path, e))?;
        let _ = map.advise(memmap2::Advice::Sequential);
        let mut pos = header.data_offset;
        for e in &header.elements[..vi] {
            match e.fixed_size() {
                Some(sz) => {
                    let len = (sz as u64).checked_mul(e.count);
                    match len.and_then(|l| (pos as u64).checked_add(l)) {
                        Some(end) if end <= map.len() as u64 => pos = end as usize,
                        _ => {
                            return Err(Error::format(
                                path,
                                format!(
                                    "PLY data truncated: element '{}' declares {} items that do not fit in the file",
                                    e.name, e.count
                                ),
                            ));
                        }
                    }
                }
                None => {
                    let eprops: Vec<Prop> = e.props.iter().map(|(_, p)| p.clone()).collect();
                    for k in 0..e.count {
                        pos = walk(&map, pos, &eprops, be).ok_or_else(|| {
                            Error::format(
                                path,
                                format!(
                                    "PLY data truncated in element '{}' at item {k} of {}",
                                    e.name, e.count
                                ),
                            )
                        })?;
                    }
                }
            }
        }
        match vertex.fixed_size() {
            Some(stride) => {
                let have = (map.len() - pos) as u64 / stride.max(1) as u64;
                if vertex_last && have > total {
                    return Err(Error::format(
                        path,
                        format!("PLY header declares {total} vertices but the data holds {have}"),
                    ));
                }
                if stride == 0 || have < total {
                    return Err(Error::format(
                        path,
                        format!(
                            "PLY data truncated: header declares {total} vertices, the file holds {have}"
                        ),
                    ));
                }
                let mut offs = [0usize; 3];
                for c in 0..3 {
                    offs[c] = vertex.props[..xyz.idx[c]]
                        .iter()
                        .map(|(_, p)| match p {
                            Prop::Scalar(t) => t.size(),
                            Prop::List(..) => 0,
                        })
                        .sum();
                }
                drop(map);
                let lay = records::Layout {
                    start: pos as u64,
                    stride,
                    count: total,
                    coords: [0, 1, 2].map(|c| records::Coord {
                        kind: xyz.ty[c],
                        offset: offs[c],
                    }),
                    big_endian: be,
                    transform: None,
                };
                let info = CloudInfo {
                    format: Format::Ply,
                    declared_points: Some(total),
                    file_bytes,
                };
                return Ok(Box::new(records::Records::new(file, path, info, lay)?));
            }
            None => Body::Variable { map, pos, props },
        }
    };
    Ok(Box::new(PlyReader {
        path: path.to_path_buf(),
        info: CloudInfo {
            format: Format::Ply,
            declared_points: Some(total),
            file_bytes,
        },
        be,
        xyz,
        total,
        next: 0,
        body,
        stats: ReadStats::default(),
        bytes: header.data_offset as u64,
        vertex_last,
    }))
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

impl PointReader for PlyReader {
    fn info(&self) -> &CloudInfo {
        &self.info
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        buf.clear();
        let be = self.be;
        let xyz = self.xyz;
        while buf.is_empty() && self.next < self.total {
            let n = (self.total - self.next).min(CHUNK as u64) as usize;
            match &mut self.body {
                Body::Variable { map, pos, props } => {
                    buf.reserve(n);
                    for _ in 0..n {
                        let Some(end) = walk(map, *pos, props, be) else {
                            return Err(self.truncated(self.next));
                        };
                        let mut v = [0.0; 3];
                        let mut p = *pos;
                        for (i, prop) in props.iter().enumerate() {
                            match prop {
                                Prop::Scalar(t) => {
                                    for c in 0..3 {
                                        if xyz.idx[c] == i {
                                            v[c] = t.read(&map[p..], be);
                                        }
                                    }
                                    p += t.size();
                                }
                                Prop::List(ct, it) => {
                                    let k = ct.read(&map[p..], be) as usize;
                                    p += ct.size() + k * it.size();
                                }
                            }
                        }
                        *pos = end;
                        self.next += 1;
                        if v.iter().all(|c| c.is_finite()) {
                            buf.push(Point::new(v[0], v[1], v[2]));
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
                        let mut v = [f64::NAN; 3];
                        let mut it = line
                            .split(|b| b.is_ascii_whitespace())
                            .filter(|t| !t.is_empty());
                        let bad = |msg: String| Error::table(&self.path, ln, msg);
                        let need = xyz.idx.iter().copied().max().unwrap_or(0);
                        for (i, prop) in props.iter().enumerate().take(need + 1) {
                            let count = match prop {
                                Prop::Scalar(_) => 1,
                                Prop::List(..) => {
                                    let t =
                                        it.next().ok_or_else(|| bad("too few values".into()))?;
                                    parse_f64(t)
                                        .filter(|c| *c >= 0.0 && *c <= 1e9)
                                        .ok_or_else(|| bad("bad list count".into()))?
                                        as usize
                                }
                            };
                            for _ in 0..count {
                                let t = it.next().ok_or_else(|| {
                                    bad(format!("too few values for vertex {}", self.next))
                                })?;
                                for c in 0..3 {
                                    if xyz.idx[c] == i {
                                        v[c] = parse_f64(t).ok_or_else(|| {
                                            bad(format!(
                                                "{:?} is not a number",
                                                String::from_utf8_lossy(t)
                                            ))
                                        })?;
                                    }
                                }
                            }
                        }
                        self.next += 1;
                        if v.iter().all(|c| c.is_finite()) {
                            buf.push(Point::new(v[0], v[1], v[2]));
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

    fn stats(&self) -> ReadStats {
        self.stats
    }

    fn bytes_read(&self) -> u64 {
        self.bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn tmp(bytes: &[u8]) -> tempfile::NamedTempFile {
        let mut f = tempfile::Builder::new().suffix(".ply").tempfile().unwrap();
        f.write_all(bytes).unwrap();
        f.flush().unwrap();
        f
    }

    fn read_bytes(bytes: &[u8]) -> Result<(Vec<Point>, ReadStats)> {
        let f = tmp(bytes);
        let mut r = open(f.path())?;
        let mut all = Vec::new();
        let mut buf = Vec::new();
        while r.next_chunk(&mut buf)? {
            all.extend_from_slice(&buf);
        }
        assert_eq!(r.stats().points, all.len() as u64);
        Ok((all, r.stats()))
    }

    fn pts() -> Vec<Point> {
        vec![
            Point::new(1.5, -2.25, 3.0),
            Point::new(350123.456, 4150234.567, 12.5),
            Point::new(f64::NAN, 0.0, 0.0),
            Point::new(-7.0, 8.0, 0.125),
        ]
    }

    /// A PLY with a vertex element (float or double x, y; float z; uchar rgb;
    /// float intensity) and a face element after it.
    fn ply(enc: &str, double: bool) -> Vec<u8> {
        let t = if double { "double" } else { "float" };
        let p = pts();
        let mut out = format!(
            "ply\nformat {enc} 1.0\ncomment made by hand\nobj_info test\nelement vertex {}\n\
             property {t} x\nproperty uchar red\nproperty {t} y\nproperty uint8 green\n\
             property float32 z\nproperty uchar blue\nproperty float intensity\n\
             element face 2\nproperty list uchar int vertex_indices\nend_header\n",
            p.len()
        )
        .into_bytes();
        if enc == "ascii" {
            for q in &p {
                out.extend_from_slice(
                    format!("{} 200 {} 100 {} 50 0.75\n", q.x, q.y, q.z).as_bytes(),
                );
            }
            out.extend_from_slice(b"3 0 1 2\n3 1 2 3\n");
            return out;
        }
        let be = enc == "binary_big_endian";
        let w = |v: f64, dbl: bool| -> Vec<u8> {
            match (dbl, be) {
                (true, true) => v.to_be_bytes().to_vec(),
                (true, false) => v.to_le_bytes().to_vec(),
                (false, true) => (v as f32).to_be_bytes().to_vec(),
                (false, false) => (v as f32).to_le_bytes().to_vec(),
            }
        };
        for q in &p {
            out.extend(w(q.x, double));
            out.push(200);
            out.extend(w(q.y, double));
            out.push(100);
            out.extend(w(q.z, false));
            out.push(50);
            out.extend(w(0.75, false));
        }
        for _ in 0..2 {
            out.push(3);
            for i in 0..3i32 {
                out.extend_from_slice(&if be { i.to_be_bytes() } else { i.to_le_bytes() });
            }
        }
        out
    }

    fn expect(double: bool) -> Vec<Point> {
        pts()
            .into_iter()
            .filter(|p| p.x.is_finite())
            .map(|p| {
                if double {
                    p
                } else {
                    Point::new(p.x as f32 as f64, p.y as f32 as f64, p.z as f32 as f64)
                }
            })
            .map(|p| Point::new(p.x, p.y, p.z as f32 as f64))
            .collect()
    }

    #[test]
    fn ascii_le_be_with_extra_properties_and_faces() {
        for enc in ["ascii", "binary_little_endian", "binary_big_endian"] {
            for double in [false, true] {
                let (got, st) = read_bytes(&ply(enc, double)).unwrap();
                let want = if enc == "ascii" {
                    // ascii keeps full precision for x, y; z parsed as written.
                    pts().into_iter().filter(|p| p.x.is_finite()).collect()
                } else {
                    expect(double)
                };
                assert_eq!(got, want, "{enc} double={double}");
                assert_eq!(st.skipped_nonfinite, 1, "{enc}");
            }
        }
    }

    #[test]
    fn vertex_not_first_and_list_in_vertex() {
        // binary: a fixed-size element and a list element before the vertices,
        // and a list property inside the vertex element (variable stride).
        let mut b = b"ply\r\nformat binary_little_endian 1.0\r\nelement camera 2\r\nproperty float a\r\n\
property double b\r\nelement face 2\r\nproperty list uchar uint idx\r\nelement vertex 2\r\n\
property list uint8 float extra\r\nproperty double x\r\nproperty double y\r\nproperty double z\r\nend_header\r\n"
            .to_vec();
        b.extend_from_slice(&[0u8; 24]);
        b.push(2);
        b.extend_from_slice(&[0u8; 8]);
        b.push(0);
        for (i, k) in [(1.0f64, 3u8), (2.0, 0)] {
            b.push(k);
            b.extend(std::iter::repeat_n(0u8, 4 * k as usize));
            for v in [i, i + 0.5, -i] {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
        let (got, _) = read_bytes(&b).unwrap();
        assert_eq!(
            got,
            vec![Point::new(1., 1.5, -1.), Point::new(2., 2.5, -2.)]
        );
        // truncated variable-stride data
        let e = read_bytes(&b[..b.len() - 3]).unwrap_err().to_string();
        assert!(e.contains("declares 2 vertices, found 1"), "{e}");

        let a = b"ply\nformat ascii 1.0\nelement face 2\nproperty list uchar int vertex_indices\n\
element vertex 2\nproperty list uchar float n\nproperty float x\nproperty float y\nproperty float z\n\
end_header\n3 0 1 2\n3 1 2 0\n2 9 9 1 2 3\n0 4 5 6\n";
        let (got, _) = read_bytes(a).unwrap();
        assert_eq!(got, vec![Point::new(1., 2., 3.), Point::new(4., 5., 6.)]);
    }

    #[test]
    fn many_points_keep_order_and_count_nan() {
        let n = CHUNK + 3 * (1 << 15) + 17;
        let mut b = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\n\
             property float y\nproperty float z\nproperty uchar r\nend_header\n"
        )
        .into_bytes();
        for i in 0..n {
            let x = if i % 1000 == 7 { f32::NAN } else { i as f32 };
            for v in [x, 1.0, -(i as f32)] {
                b.extend_from_slice(&v.to_le_bytes());
            }
            b.push(0);
        }
        let (got, st) = read_bytes(&b).unwrap();
        let want: Vec<Point> = (0..n)
            .filter(|i| i % 1000 != 7)
            .map(|i| Point::new(i as f32 as f64, 1.0, -(i as f32) as f64))
            .collect();
        assert_eq!(st.skipped_nonfinite, (n - want.len()) as u64);
        assert_eq!(got, want);
    }

    #[test]
    fn ascii_across_blocks_stops_at_vertex_count() {
        let n = 300_000;
        let mut s = format!(
            "ply\nformat ascii 1.0\nelement edge {n}\nproperty int a\nproperty int b\n\
             element vertex {n}\nproperty double x\nproperty double y\nproperty double z\n\
             element face {n}\nproperty list uchar int vertex_indices\nend_header\n"
        );
        for i in 0..n {
            s.push_str(&format!("{i} {}\n", i + 1));
        }
        for i in 0..n {
            s.push_str(&format!("{i}.25 {} -{i}\n", 350000 + i));
        }
        for _ in 0..n {
            s.push_str("3 0 1 2\n");
        }
        let (got, st) = read_bytes(s.as_bytes()).unwrap();
        assert_eq!(st.points, n as u64);
        for (i, p) in got.iter().enumerate() {
            assert_eq!(
                *p,
                Point::new(i as f64 + 0.25, (350000 + i) as f64, -(i as f64))
            );
        }
    }

    fn err(bytes: &[u8]) -> String {
        read_bytes(bytes).unwrap_err().to_string()
    }

    #[test]
    fn clear_errors() {
        let head = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                    property float y\nproperty float z\nend_header\n";
        let mut b = head.as_bytes().to_vec();
        b.extend_from_slice(&[0u8; 12 * 2 + 5]);
        let e = err(&b);
        assert!(e.contains("declares 3 vertices, the file holds 2"), "{e}");
        let e = err(
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
property float z\nend_header\n1 2 3\n",
        );
        assert!(e.contains("declares 3 vertices, found 1"), "{e}");
        let e = err(
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
property float z\nend_header\n1 2\n",
        );
        assert!(
            e.contains(".ply:8: ") && e.contains("too few values"),
            "{e}"
        );
        let e = err(
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
property float z\nend_header\n1 2 q\n",
        );
        assert!(
            e.contains(".ply:8: ") && e.contains("\"q\" is not a number"),
            "{e}"
        );
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float16 x\nend_header\n");
        assert!(
            e.contains(".ply:4: PLY header: unknown property type \"float16\""),
            "{e}"
        );
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\nend_header\n");
        assert!(e.contains("no 'y' property"), "{e}");
        let e = err(b"ply\nformat ascii 1.0\ncomment \xff\xfe\nend_header\n");
        assert!(
            e.contains(".ply:3: PLY header") && e.contains("UTF-8"),
            "{e}"
        );
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
        assert!(e.contains("never ends"), "{e}");
        let e =
            err(b"ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int v\nend_header\n");
        assert!(e.contains("no 'vertex' element"), "{e}");
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty float y\nproperty float z\nend_header\n1 2 3\n");
        assert!(e.contains("'x' must be float or double"), "{e}");
        // Every message names the file.
        assert!(e.contains(".ply"), "{e}");
    }
}
