//! COPC (Cloud Optimized Point Cloud): a LAZ file whose LASzip chunks are the
//! nodes of an octree, each listed with its cube in a hierarchy EVLR.
//!
//! Why: aerial and mobile-mapping maps of billions of points are kept as
//! COPC, and a crop needs only the nodes near the targets. Given a region
//! hint ([`PointReader::hint_discs`]) this reader decodes only the nodes whose
//! cubes come within the crop radius of a target, in file order, so a crop
//! holds the same points in the same order as decoding the whole file (the
//! plain LAZ path reads the same chunks in file order). Without a hint every
//! node is read. The `las` crate parses the header and the hierarchy; nodes
//! are read with `pread` and decompressed in parallel with the `laz` crate.
//!
//! A file whose hierarchy is unreadable or does not account for every point
//! of the header is read by the plain LAZ path instead (same points, no
//! skipping). A point outside its node's cube, found in a node read for a
//! hint, is an error: the nodes skipped could then hold points near a target.

use super::super::producer::{on_reader_thread, reader_pool};
use super::super::{CloudInfo, Format, PointReader, ReadStats, TileStats};
use super::laz_check::{check_layers, layer_words};
use crate::{Error, Point, Result};
use laz::record::{LayeredPointRecordDecompressor, RecordDecompressor};
use rayon::prelude::*;
use std::fs::File;
use std::io::BufReader;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

/// Points decoded per block (many nodes, so every core has one).
const BLOCK_POINTS: u64 = 1 << 20;
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

/// A COPC file read node by node.
pub(super) struct CopcReader {
    path: PathBuf,
    file: File,
    info: CloudInfo,
    /// Every node with points, in file order.
    nodes: Vec<Node>,
    /// Indices of the nodes to read, in file order.
    order: Vec<usize>,
    next: usize,
    items: Vec<laz::LazItem>,
    /// Bytes of a chunk's first point, and its layer-size words.
    first: usize,
    words: usize,
    record_len: usize,
    transforms: las::Vector<las::Transform>,
    /// How far outside its cube a point may lie (coordinate rounding).
    slack: f64,
    stats: ReadStats,
    /// Bytes of the header, VLRs and hierarchy, then of every node read.
    bytes: u64,
    counts: TileStats,
    started: bool,
    pool: Option<rayon::ThreadPool>,
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
pub(super) fn open(path: &Path, file: &File, file_bytes: u64) -> Result<Option<CopcReader>> {
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
    let Some(words) = layer_words(&p.items) else {
        return Ok(None);
    };
    let file = file.try_clone().map_err(|e| Error::io(path, e))?;
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
    Ok(Some(CopcReader {
        path: path.to_path_buf(),
        file,
        info: CloudInfo {
            format: Format::Laz,
            declared_points: Some(p.total),
            file_bytes,
        },
        order: (0..nodes.len()).collect(),
        nodes,
        next: 0,
        first: p.items.iter().map(|i| usize::from(i.size())).sum(),
        words,
        items: p.items,
        record_len: usize::from(p.format.len()),
        transforms: t,
        // A writer assigns a point to a node from its scaled coordinate; the
        // stored integer may round to a unit beyond the cube's face.
        slack: 2.0 * scale + 1e-9 * size,
        stats: ReadStats::default(),
        bytes: p.point_start + p.evlr_bytes,
        counts: TileStats {
            tiles: n,
            selected: n,
            bytes,
            copc: true,
            ..TileStats::default()
        },
        started: false,
        pool: reader_pool(),
    }))
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

impl CopcReader {
    /// Decodes node `i`: its finite points and the count of non-finite ones.
    fn decode(&self, i: usize) -> std::result::Result<(Vec<Point>, u64), String> {
        let n = &self.nodes[i];
        let mut raw = vec![0u8; n.bytes as usize];
        self.file
            .read_exact_at(&mut raw, n.offset)
            .map_err(|e| e.to_string())?;
        // The chunk's own head: its layers fit in it, and it holds the points
        // the hierarchy says.
        let count = check_layers(&raw, self.first, self.words, n.bytes)?;
        if u64::from(count) != n.points {
            return Err(format!(
                "the hierarchy says {} points, the node's data {count}",
                n.points
            ));
        }
        let mut out = vec![0u8; n.points as usize * self.record_len];
        let mut d = LayeredPointRecordDecompressor::new(std::io::Cursor::new(&raw[..]));
        d.set_fields_from(&self.items).map_err(|e| e.to_string())?;
        d.decompress_many(&mut out).map_err(|e| e.to_string())?;
        let t = &self.transforms;
        let mut pts = Vec::with_capacity(n.points as usize);
        let mut skipped = 0;
        for r in out.chunks_exact(self.record_len) {
            let c = |o: usize| i32::from_le_bytes([r[o], r[o + 1], r[o + 2], r[o + 3]]);
            let q = Point::new(t.x.direct(c(0)), t.y.direct(c(4)), t.z.direct(c(8)));
            if q.x.is_finite() && q.y.is_finite() && q.z.is_finite() {
                pts.push(q);
            } else {
                skipped += 1;
            }
        }
        Ok((pts, skipped))
    }

    /// Decodes `batch` (node indices) on the reader pool, in order.
    fn decode_all(&self, batch: &[usize]) -> Result<Vec<(Vec<Point>, u64)>> {
        let run = || {
            batch
                .par_iter()
                .map(|&i| self.decode(i).map_err(|m| (i, m)))
                .collect::<std::result::Result<Vec<_>, _>>()
        };
        // A panic in the laz crate on malformed data becomes this file's
        // error (on reader-named threads, no panic hook reports it).
        let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match &self.pool {
            Some(pool) => pool.install(run),
            None => run(),
        }));
        match out {
            Ok(Ok(v)) => Ok(v),
            Ok(Err((i, m))) => Err(Error::format(
                &self.path,
                format!("COPC node {}: {m}", key_text(&self.nodes[i].key)),
            )),
            Err(_) => Err(Error::format(
                &self.path,
                "the decoder failed on malformed data (a COPC node)",
            )),
        }
    }

    /// Some nodes were left unread: every point read must lie in its cube.
    fn check_cube(&self, i: usize, pts: &[Point]) -> Result<()> {
        if self.counts.selected == self.counts.tiles {
            return Ok(());
        }
        let (c, s) = (&self.nodes[i].cube, self.slack);
        if let Some(p) = pts.iter().find(|p| {
            !(p.x >= c[0] - s
                && p.x <= c[3] + s
                && p.y >= c[1] - s
                && p.y <= c[4] + s
                && p.z >= c[2] - s
                && p.z <= c[5] + s)
        }) {
            return Err(Error::format(
                &self.path,
                format!(
                    "COPC node {} holds point ({}, {}, {}) outside its cube x [{}, {}], y [{}, {}], z [{}, {}]: the octree cannot tell which nodes to skip (convert the file to plain LAZ with `mapgauge convert`, which reads every node)",
                    key_text(&self.nodes[i].key),
                    p.x,
                    p.y,
                    p.z,
                    c[0],
                    c[3],
                    c[1],
                    c[4],
                    c[2],
                    c[5]
                ),
            ));
        }
        Ok(())
    }
}

fn key_text(k: &[i32; 4]) -> String {
    format!("{}-{}-{}-{}", k[0], k[1], k[2], k[3])
}

impl PointReader for CopcReader {
    fn info(&self) -> &CloudInfo {
        &self.info
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        self.started = true;
        buf.clear();
        while self.next < self.order.len() {
            let mut end = self.next;
            let mut pts = 0;
            while end < self.order.len()
                && (end == self.next || pts + self.nodes[self.order[end]].points <= BLOCK_POINTS)
            {
                pts += self.nodes[self.order[end]].points;
                end += 1;
            }
            let batch = self.order[self.next..end].to_vec();
            let decoded = self.decode_all(&batch)?;
            for (&i, (pts, skipped)) in batch.iter().zip(decoded) {
                self.check_cube(i, &pts)?;
                self.stats.points += pts.len() as u64;
                self.stats.skipped_nonfinite += skipped;
                self.bytes += self.nodes[i].bytes;
                self.counts.opened += 1;
                self.counts.bytes_opened += self.nodes[i].bytes;
                buf.extend_from_slice(&pts);
            }
            self.next = end;
            if !buf.is_empty() {
                return Ok(true);
            }
        }
        Ok(false)
    }

    fn stats(&self) -> ReadStats {
        self.stats
    }

    fn bytes_read(&self) -> u64 {
        self.bytes
    }

    fn hint_discs(&mut self, centres: &[[f64; 2]], radius: f64) {
        if self.started
            || !(radius.is_finite() && radius >= 0.0)
            || centres.iter().flatten().any(|v| !v.is_finite())
        {
            return;
        }
        let s = self.slack;
        let near = |c: &[f64; 6]| {
            centres.iter().any(|p| {
                let dx = (c[0] - s - p[0]).max(p[0] - c[3] - s).max(0.0);
                let dy = (c[1] - s - p[1]).max(p[1] - c[4] - s).max(0.0);
                dx * dx + dy * dy <= radius * radius
            })
        };
        let nodes = &self.nodes;
        self.order.retain(|&i| near(&nodes[i].cube));
        self.counts.selected = self.order.len() as u64;
    }

    fn tile_stats(&self) -> Option<TileStats> {
        Some(self.counts)
    }
}
