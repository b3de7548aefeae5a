//! COPC (Cloud Optimized Point Cloud): a LAZ file whose LASzip chunks are the
//! nodes of an octree, each listed with its cube in a hierarchy EVLR.
//!
//! Why: aerial and mobile-mapping maps of billions of points are kept as
//! COPC, and a crop needs only the nodes near the targets. Given a region
//! hint ([`PointReader::hint_discs`]) this reader decodes only the nodes whose
//! cubes come within the crop radius of a target, in file order, so a crop
//! holds the same points in the same order as decoding the whole file (the
//! plain LAZ path reads the same chunks in file order). Without a hint every
//! node is read. The `las` crate parses the header and the hierarchy; the
//! nodes are decoded by the chunked LAZ reader (`chunked.rs`: `pread`, in
//! parallel, X, Y, Z only), of which this is the case with an octree.
//!
//! A file whose hierarchy is unreadable or does not account for every point
//! of the header is read by the plain LAZ path instead (same points, no
//! skipping). A point outside its node's cube, found in a node read for a
//! hint, is an error: the nodes skipped could then hold points near a target.

use super::super::producer::on_reader_thread;
use super::super::{CloudInfo, Format, TileStats};
use super::Chunk;
use super::chunked::{ChunkedLaz, Layout};
use super::octree::Octree;
use crate::{Error, Result};
use std::fs::File;
use std::io::BufReader;
use std::os::unix::fs::FileExt;
use std::path::Path;

/// Deepest octree level accepted (a node's cube is 2^-level of the root's).
const MAX_LEVEL: i32 = 40;

/// One octree node with points.
#[derive(Debug, Clone)]
struct Node {
    /// Level, x, y, z of its voxel key.
    key: [i32; 4],
    offset: u64,
    bytes: u64,
    points: u64,
    /// Its cube: min x, min y, min z, max x, max y, max z.
    cube: [f64; 6],
}

/// Whether the file's first VLR is the COPC info VLR (at byte 375, as the
/// COPC specification requires).
pub(super) fn has_copc_vlr(file: &File) -> bool {
    let mut head = [0u8; 375 + 54];
    let n = file.read_at(&mut head, 0).unwrap_or(0);
    n == head.len()
        && &head[..4] == b"LASF"
        && &head[377..382] == b"copc\0"
        && u16::from_le_bytes([head[393], head[394]]) == 1
}

/// What the `las` crate tells of a COPC file.
struct Parsed {
    entries: Vec<las::copc::Entry>,
    centre: [f64; 3],
    halfsize: f64,
    items: Vec<laz::LazItem>,
    format: las::point::Format,
    transforms: las::Vector<las::Transform>,
    total: u64,
    /// Where the point data starts (header and VLRs before it).
    point_start: u64,
    evlr_bytes: u64,
}

/// Opens `path` (a file with the COPC VLR) as COPC when its hierarchy is
/// usable; `None` sends it to the plain LAZ path.
pub(super) fn open(path: &Path, file: &File, file_bytes: u64) -> Result<Option<ChunkedLaz>> {
    // The las crate parses headers and hierarchy pages; it can panic on
    // malformed data, so on a reader thread (the panic becomes an error).
    let parsed = on_reader_thread(path, || {
        let f = File::open(path).map_err(|e| Error::io(path, e))?;
        let Ok(r) = las::CopcReader::new(BufReader::new(f)) else {
            return Ok(None);
        };
        let h = r.header();
        let (Some(info), Ok(laz)) = (h.copc_info_vlr(), h.laz_vlr()) else {
            return Ok(None);
        };
        let raw = h.clone().into_raw().ok();
        Ok(Some(Parsed {
            entries: r.hierarchy_entries().collect(),
            centre: [info.center_x, info.center_y, info.center_z],
            halfsize: info.halfsize,
            items: laz.items().clone(),
            format: *h.point_format(),
            transforms: *h.transforms(),
            total: h.number_of_points(),
            point_start: raw
                .as_ref()
                .map_or(0, |r| u64::from(r.offset_to_point_data)),
            evlr_bytes: raw
                .as_ref()
                .and_then(|r| r.evlr)
                .map_or(0, |e| file_bytes.saturating_sub(e.start_of_first_evlr)),
        }))
    })?;
    let Some(p) = parsed else {
        return Ok(None);
    };
    let Some(nodes) = nodes(&p, file_bytes) else {
        return Ok(None);
    };
    // Records as the compressed items lay them out (else the crate decides).
    if p.items.iter().map(|i| u64::from(i.size())).sum::<u64>() != u64::from(p.format.len()) {
        return Ok(None);
    }
    let t = p.transforms;
    let scale = [t.x.scale, t.y.scale, t.z.scale]
        .into_iter()
        .fold(0.0_f64, |m, s| m.max(s.abs()));
    let size = p
        .centre
        .iter()
        .fold(p.halfsize.abs(), |m, c| m.max(c.abs()));
    let bytes: u64 = nodes.iter().map(|n| n.bytes).sum();
    let n = nodes.len() as u64;
    let octree = Octree {
        keys: nodes.iter().map(|n| n.key).collect(),
        cubes: nodes.iter().map(|n| n.cube).collect(),
        // A writer assigns a point to a node from its scaled coordinate; the
        // stored integer may round to a unit beyond the cube's face.
        slack: 2.0 * scale + 1e-9 * size,
        counts: TileStats {
            tiles: n,
            selected: n,
            bytes,
            copc: true,
            ..TileStats::default()
        },
        discs: None,
        levels_cut: Vec::new(),
    };
    let lay = Layout {
        info: CloudInfo {
            format: Format::Laz,
            declared_points: Some(p.total),
            file_bytes,
        },
        chunks: nodes
            .iter()
            .map(|n| Chunk {
                offset: n.offset,
                bytes: n.bytes,
                points: n.points,
            })
            .collect(),
        items: p.items,
        transforms: t,
        head_bytes: p.point_start + p.evlr_bytes,
    };
    ChunkedLaz::new(path, file, lay, Some(octree))
}

/// The nodes with points in file order, with their cubes; `None` when the
/// hierarchy cannot be trusted to hold every point once (then the plain LAZ
/// path reads the file).
fn nodes(p: &Parsed, file_bytes: u64) -> Option<Vec<Node>> {
    // Only layered point formats (6-10) are COPC; node data must be point
    // data (after the header) within the file.
    if !p.format.is_compressed || p.format.to_u8().ok()? < 6 {
        return None;
    }
    if !(p.halfsize.is_finite() && p.halfsize > 0.0 && p.centre.iter().all(|c| c.is_finite())) {
        return None;
    }
    let mut nodes = Vec::new();
    let mut sum = 0u64;
    for e in &p.entries {
        if e.point_count == 0 {
            continue;
        }
        let points = u64::try_from(e.point_count).ok()?;
        let bytes = u64::try_from(e.byte_size).ok()?;
        let k = e.key;
        let cells = 2f64.powi(k.l);
        let inside = |v: i32| v >= 0 && f64::from(v) < cells;
        if !(0..=MAX_LEVEL).contains(&k.l) || !inside(k.x) || !inside(k.y) || !inside(k.z) {
            return None;
        }
        // As the chunk-table check: data within the file, and no more than
        // 64 points per compressed byte (a lying count would size buffers).
        if bytes == 0
            || e.offset < p.point_start
            || e.offset.checked_add(bytes)? > file_bytes
            || points > bytes.saturating_mul(64)
        {
            return None;
        }
        let side = 2.0 * p.halfsize / cells;
        let lo = |c: usize, v: i32| p.centre[c] - p.halfsize + side * f64::from(v);
        let (x0, y0, z0) = (lo(0, k.x), lo(1, k.y), lo(2, k.z));
        nodes.push(Node {
            key: [k.l, k.x, k.y, k.z],
            offset: e.offset,
            bytes,
            points,
            cube: [x0, y0, z0, x0 + side, y0 + side, z0 + side],
        });
        sum = sum.checked_add(points)?;
    }
    if sum != p.total {
        return None;
    }
    nodes.sort_by_key(|n| n.offset);
    // Nodes must not share bytes: each is one LASzip chunk.
    if nodes
        .windows(2)
        .any(|w| w[0].offset + w[0].bytes > w[1].offset)
    {
        return None;
    }
    Some(nodes)
}
