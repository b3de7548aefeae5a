//! PLY reader (ascii, binary little and big endian).
//!
//! Hand-written: the header is parsed line by line; binary vertex data with a
//! fixed stride goes to the `pread` record reader (`records.rs`); vertex elements
//! with list properties (variable stride) are walked sequentially; ascii data is
//! streamed in blocks of lines. Elements before `vertex` are skipped, elements
//! after it are ignored.
//!
//! The header is `header.rs`, the sequential readers `body.rs`.

use super::xyz::LineBlocks;
use super::{CloudInfo, Format, PointReader, ReadStats, records};
use crate::{Error, Result};
use body::{Body, PlyReader, walk};
use header::{Element, Encoding, Header, Prop, Xyz, find_xyz, parse_header};
use memmap2::Mmap;
use std::fs::File;
use std::io::{Seek, SeekFrom};
use std::path::Path;

mod body;
mod header;
#[cfg(test)]
mod tests;

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
    let info = CloudInfo {
        format: Format::Ply,
        declared_points: Some(total),
        file_bytes,
    };
    let body = if header.encoding == Encoding::Ascii {
        ascii_body(path, file, &header, vi, props)?
    } else {
        // SAFETY: the map is only read; a file truncated by another process while
        // mapped is the usual mmap caveat (SIGBUS), accepted for map files.
        let map = unsafe { Mmap::map(&file) }.map_err(|e| Error::io(path, e))?;
        let _ = map.advise(memmap2::Advice::Sequential);
        let pos = skip_binary(path, &map, &header.elements[..vi], header.data_offset, be)?;
        match vertex.fixed_size() {
            Some(stride) => {
                let have = (map.len() - pos) as u64 / stride.max(1) as u64;
                check_vertex_count(path, (have, total), stride, vertex_last)?;
                let lay = fixed_layout(vertex, &xyz, pos, stride, be);
                drop(map);
                return Ok(Box::new(records::Records::new(file, path, info, lay)?));
            }
            None => Body::Variable { map, pos, props },
        }
    };
    Ok(Box::new(PlyReader {
        path: path.to_path_buf(),
        info,
        be,
        xyz,
        total,
        next: 0,
        body,
        stats: ReadStats::default(),
        bytes: header.data_offset as u64,
        vertex_last,
        intensity: intensity_prop(vertex),
    }))
}

/// The ascii body, positioned at the first vertex line: the lines of the
/// elements before the vertex element (blank lines aside) are skipped.
fn ascii_body(
    path: &Path,
    mut file: File,
    header: &Header,
    vi: usize,
    props: Vec<Prop>,
) -> Result<Body> {
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
    Ok(Body::Ascii {
        lines,
        line_no,
        props,
        pending,
    })
}

/// Skips the binary elements before the vertex element from `pos`: by their
/// size when fixed, item by item when they hold lists. Returns where the
/// vertices start; elements that do not fit in the file are an error.
fn skip_binary(
    path: &Path,
    map: &[u8],
    before: &[Element],
    mut pos: usize,
    be: bool,
) -> Result<usize> {
    for e in before {
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
                    pos = walk(map, pos, &eprops, be).ok_or_else(|| {
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
    Ok(pos)
}

/// Fixed-stride vertices: the file must hold the `total` declared (`have`
/// fit), and no more when the vertex element is the last.
fn check_vertex_count(
    path: &Path,
    (have, total): (u64, u64),
    stride: usize,
    vertex_last: bool,
) -> Result<()> {
    if vertex_last && have > total {
        return Err(Error::format(
            path,
            format!("PLY header declares {total} vertices but the data holds {have}"),
        ));
    }
    if stride == 0 || have < total {
        return Err(Error::format(
            path,
            format!("PLY data truncated: header declares {total} vertices, the file holds {have}"),
        ));
    }
    Ok(())
}

/// The record layout of fixed-stride vertices starting at byte `pos`, for
/// the `pread` record reader.
fn fixed_layout(
    vertex: &Element,
    xyz: &Xyz,
    pos: usize,
    stride: usize,
    be: bool,
) -> records::Layout {
    let offs = xyz.idx.map(|i| prop_offset(vertex, i));
    let intensity = intensity_prop(vertex).and_then(|i| match vertex.props[i].1 {
        Prop::Scalar(t) => Some(records::Coord {
            kind: t,
            offset: prop_offset(vertex, i),
        }),
        Prop::List(..) => None,
    });
    records::Layout {
        start: pos as u64,
        stride,
        count: vertex.count,
        coords: [0, 1, 2].map(|c| records::Coord {
            kind: xyz.ty[c],
            offset: offs[c],
        }),
        big_endian: be,
        transform: None,
        intensity,
    }
}

/// The vertex property that holds the intensity: a scalar `intensity` (any
/// case), or CloudCompare's `scalar_intensity`, for boards and `convert`.
fn intensity_prop(vertex: &Element) -> Option<usize> {
    let named = |want: &str| {
        let props = &vertex.props;
        props
            .iter()
            .position(|(n, _)| n == want)
            .or_else(|| props.iter().position(|(n, _)| n.eq_ignore_ascii_case(want)))
    };
    named("intensity")
        .or_else(|| named("scalar_intensity"))
        .filter(|&i| matches!(vertex.props[i].1, Prop::Scalar(_)))
}

/// Byte offset of property `i` in a fixed-stride vertex record.
fn prop_offset(vertex: &Element, i: usize) -> usize {
    vertex.props[..i]
        .iter()
        .map(|(_, p)| match p {
            Prop::Scalar(t) => t.size(),
            Prop::List(..) => 0,
        })
        .sum()
}
