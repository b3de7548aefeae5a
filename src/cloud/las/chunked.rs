//! LAZ of LAS 1.4 point formats 6-10 decoded chunk by chunk, coordinates only
//! (and intensity, for the passes that read it).
//!
//! Why: these formats compress each field in its own layer, so a reader that
//! wants X, Y and Z can skip the layers of intensity, GPS time, colour,
//! classification and the rest unread (`laz::DecompressionSelection`), and
//! mapgauge needs nothing else but, for checkerboard boards, the intensity. The LASzip chunks (from the chunk table of a
//! plain LAZ file, or the octree nodes of a COPC file) are read with `pread`
//! and decoded in parallel on the reader pool, in file order, one block of
//! chunks at a time, so memory stays at a few blocks. Point formats 0-5 are
//! compressed point by point (nothing to skip) and stay on the `las` crate.
//!
//! COPC ([`Octree`]) is the hinted case: given a region hint, only the nodes
//! near the targets are decoded.

use super::super::producer::{on_reader_thread, panic_text, reader_pool};
use super::super::{CloudInfo, Format, PointReader, ReadStats, TileStats};
use super::Chunk;
use super::laz_check::{check_layers, layer_words};
use super::octree::Octree;
use crate::{Error, Point, Result};
use laz::record::{LayeredPointRecordDecompressor, RecordDecompressor};
use rayon::prelude::*;
use std::fs::File;
use std::io::{BufReader, Seek, SeekFrom};
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

/// Points decoded per block (about 20 LASzip chunks, so every core has one).
const BLOCK_POINTS: u64 = 1 << 20;

/// Set (to anything) to read plain LAZ of formats 6-10 through the `las`
/// crate (every layer decompressed), as before coordinate-only decoding:
/// the benchmark's "before".
pub(super) const CRATE_PATH_ENV: &str = "MAPGAUGE_LAZ_CRATE";

/// What a chunked reader is built from (see [`ChunkedLaz::new`]).
pub(super) struct Layout {
    pub(super) info: CloudInfo,
    /// Every chunk with points, in file order.
    pub(super) chunks: Vec<Chunk>,
    pub(super) items: Vec<laz::LazItem>,
    pub(super) transforms: las::Vector<las::Transform>,
    /// Bytes counted as read before any chunk (header, VLRs, and for COPC
    /// the hierarchy).
    pub(super) head_bytes: u64,
}

/// A LAZ file of layered chunks read chunk by chunk, X, Y, Z only.
pub(super) struct ChunkedLaz {
    path: PathBuf,
    file: File,
    info: CloudInfo,
    chunks: Vec<Chunk>,
    /// Indices of the chunks to read, in file order.
    order: Vec<usize>,
    next: usize,
    items: Vec<laz::LazItem>,
    /// Bytes of a record (a chunk's first point), and its layer-size words.
    first: usize,
    words: usize,
    transforms: las::Vector<las::Transform>,
    stats: ReadStats,
    bytes: u64,
    /// Points in the chunks before each one (for a plain file's errors).
    before: Vec<u64>,
    octree: Option<Octree>,
    started: bool,
    /// A [`PointReader::hint_sample`] left chunks unread.
    sampled: bool,
    pool: Option<rayon::ThreadPool>,
    /// The intensity layer is decoded too ([`PointReader::next_chunk_intensity`]).
    intensity: bool,
}

/// The layers read: X, Y (with returns and channel, which predict them) and Z,
/// and the intensity when asked for.
fn selection(intensity: bool) -> laz::DecompressionSelection {
    let s = laz::DecompressionSelection::xy_returns_channel().decompress_z();
    if intensity {
        s.decompress_intensity()
    } else {
        s
    }
}

/// A chunk decoded: its finite points, their intensities (when read), and
/// the count of non-finite points skipped.
type Decoded = (Vec<Point>, Vec<f32>, u64);

/// Whether the `laz` items are layered (item versions 3 and 4: the crate
/// picks its layered decompressor by the first item's version) with X, Y, Z
/// at the start of a record (point formats 6-10): the layer-size words of a
/// chunk's head.
fn layered(items: &[laz::LazItem]) -> Option<usize> {
    let first = items.first()?;
    (first.item_type() == laz::LazItemType::Point14 && matches!(first.version(), 3 | 4))
        .then(|| layer_words(items))
        .flatten()
}

impl ChunkedLaz {
    /// `None` when the items are not layered with X, Y, Z first (point
    /// formats 0-5): those stay on the `las` crate.
    pub(super) fn new(
        path: &Path,
        file: &File,
        lay: Layout,
        octree: Option<Octree>,
    ) -> Result<Option<Self>> {
        let Some(words) = layered(&lay.items) else {
            return Ok(None);
        };
        let file = file.try_clone().map_err(|e| Error::io(path, e))?;
        let before = lay
            .chunks
            .iter()
            .scan(0u64, |s, c| {
                let b = *s;
                *s = s.saturating_add(c.points);
                Some(b)
            })
            .collect();
        Ok(Some(ChunkedLaz {
            path: path.to_path_buf(),
            file,
            info: lay.info,
            order: (0..lay.chunks.len()).collect(),
            chunks: lay.chunks,
            next: 0,
            first: lay.items.iter().map(|i| usize::from(i.size())).sum(),
            words,
            items: lay.items,
            transforms: lay.transforms,
            stats: ReadStats::default(),
            bytes: lay.head_bytes,
            before,
            octree,
            started: false,
            sampled: false,
            pool: reader_pool(),
            intensity: false,
        }))
    }

    /// Decodes chunk `i`: its finite points (with their intensities when
    /// reading them) and the count of non-finite ones.
    fn decode(&self, i: usize) -> std::result::Result<Decoded, String> {
        let c = &self.chunks[i];
        let mut raw = vec![0u8; c.bytes as usize];
        self.file
            .read_exact_at(&mut raw, c.offset)
            .map_err(|e| e.to_string())?;
        // The chunk's own head: its layers fit in it, and it holds the points
        // the hierarchy (the chunk table) says.
        let count = u64::from(check_layers(&raw, self.first, self.words, c.bytes)?);
        if self.octree.is_some() && count != c.points {
            return Err(format!(
                "the hierarchy says {} points, the node's data {count}",
                c.points
            ));
        }
        if count < c.points {
            return Err(format!(
                "the chunk table says {} points, the chunk's data {count}",
                c.points
            ));
        }
        let mut d = LayeredPointRecordDecompressor::new(std::io::Cursor::new(&raw[..]));
        d.set_fields_from(&self.items).map_err(|e| e.to_string())?;
        d.set_selection(selection(self.intensity));
        // One record at a time: the skipped fields are never copied out, and
        // a header claiming huge records costs one record, not a block of them.
        let mut rec = vec![0u8; self.first];
        let t = &self.transforms;
        let mut pts = Vec::with_capacity(c.points.min(1 << 16) as usize);
        let mut inten = Vec::new();
        let mut skipped = 0;
        for _ in 0..c.points {
            d.decompress_next(&mut rec).map_err(|e| e.to_string())?;
            if !super::push_record(&rec, t, &mut pts) {
                skipped += 1;
            } else if self.intensity {
                inten.push(super::record_intensity(&rec));
            }
        }
        Ok((pts, inten, skipped))
    }

    /// Decodes `batch` (chunk indices) on the reader pool, in order. Of
    /// several bad chunks the first in file order names the error, whichever
    /// thread failed first: the message is part of the output.
    fn decode_all(&self, batch: &[usize]) -> Result<Vec<Decoded>> {
        // A panic in the laz crate on malformed data becomes that chunk's
        // error (on reader-named threads, no panic hook reports it).
        let one = |i: usize| {
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.decode(i)))
                .map_err(|panic| (i, Err(panic_text(&*panic))))?
                .map_err(|m| (i, Ok(m)))
        };
        let run = || batch.par_iter().map(|&i| one(i)).collect::<Vec<_>>();
        let out = match &self.pool {
            Some(pool) => pool.install(run),
            None => run(),
        };
        let (i, fail) = match out.into_iter().collect::<std::result::Result<Vec<_>, _>>() {
            Ok(v) => return Ok(v),
            Err(e) => e,
        };
        let msg = match (fail, &self.octree) {
            (Ok(m), Some(o)) => format!("COPC node {}: {m}", key_text(&o.keys[i])),
            (Ok(m), None) => format!(
                "LAS: reading points {}.. of {}: LAZ chunk {i}: {m}",
                self.before[i],
                self.info.declared_points.unwrap_or(0)
            ),
            (Err(_), Some(_)) => "the decoder failed on malformed data (a COPC node)".into(),
            (Err(panic), None) => format!("the decoder failed on malformed data ({panic})"),
        };
        Err(Error::format(&self.path, msg))
    }

    /// The next block of chunks' points, and their intensities into `inten`
    /// (cleared first) when given.
    fn fill(&mut self, buf: &mut Vec<Point>, mut inten: Option<&mut Vec<f32>>) -> Result<bool> {
        self.started = true;
        buf.clear();
        if let Some(v) = inten.as_deref_mut() {
            v.clear();
        }
        while self.next < self.order.len() {
            let mut end = self.next;
            let mut pts = 0;
            while end < self.order.len()
                && (end == self.next || pts + self.chunks[self.order[end]].points <= BLOCK_POINTS)
            {
                pts += self.chunks[self.order[end]].points;
                end += 1;
            }
            let batch = self.order[self.next..end].to_vec();
            let decoded = self.decode_all(&batch)?;
            for (&i, (pts, chunk_inten, skipped)) in batch.iter().zip(decoded) {
                self.check_cube(i, &pts)?;
                self.stats.points += pts.len() as u64;
                self.stats.skipped_nonfinite += skipped;
                self.bytes += self.chunks[i].bytes;
                if let Some(o) = &mut self.octree {
                    o.counts.opened += 1;
                    o.counts.bytes_opened += self.chunks[i].bytes;
                }
                buf.extend_from_slice(&pts);
                if let Some(inten) = inten.as_deref_mut() {
                    inten.extend_from_slice(&chunk_inten);
                }
            }
            self.next = end;
            if !buf.is_empty() {
                return Ok(true);
            }
        }
        // A plain file has been read to its end (the chunk table after the chunks).
        if self.octree.is_none() && !self.sampled {
            self.bytes = self.info.file_bytes;
        }
        Ok(false)
    }

    /// Some nodes were left unread: every point read must lie in its cube.
    fn check_cube(&self, i: usize, pts: &[Point]) -> Result<()> {
        let Some(o) = &self.octree else {
            return Ok(());
        };
        if o.counts.selected == o.counts.tiles {
            return Ok(());
        }
        let (c, s) = (&o.cubes[i], o.slack);
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
                    key_text(&o.keys[i]),
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

impl PointReader for ChunkedLaz {
    fn info(&self) -> &CloudInfo {
        &self.info
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        self.fill(buf, None)
    }

    /// Every point format stores an intensity (0 where the writer had none).
    fn has_intensity(&self) -> bool {
        true
    }

    fn next_chunk_intensity(&mut self, buf: &mut Vec<Point>, inten: &mut Vec<f32>) -> Result<bool> {
        self.intensity = true;
        self.fill(buf, Some(inten))
    }

    fn stats(&self) -> ReadStats {
        self.stats
    }

    fn bytes_read(&self) -> u64 {
        self.bytes
    }

    fn hint_discs(&mut self, centres: &[[f64; 2]], radius: f64) {
        let Some(o) = &mut self.octree else {
            return;
        };
        if self.started
            || !(radius.is_finite() && radius >= 0.0)
            || centres.iter().flatten().any(|v| !v.is_finite())
        {
            return;
        }
        let o: &Octree = o;
        self.order
            .retain(|&i| centres.iter().any(|p| o.near(&o.cubes[i], p, radius)));
        if let Some(o) = &mut self.octree {
            o.counts.selected = self.order.len() as u64;
            o.discs = Some((centres.to_vec(), radius));
        }
    }

    fn hint_enough(&mut self, points: u64) {
        let Some(o) = &mut self.octree else {
            return;
        };
        if self.started || points == 0 {
            return;
        }
        let (keep, cut) = o.enough_levels(&self.order, &self.chunks, points);
        if keep.len() < self.order.len() {
            self.order = keep;
            o.levels_cut = cut;
            o.counts.selected = self.order.len() as u64;
        }
    }

    fn levels_cut(&self) -> Vec<bool> {
        self.octree
            .as_ref()
            .map_or_else(Vec::new, |o| o.levels_cut.clone())
    }

    fn tile_stats(&self) -> Option<TileStats> {
        self.octree.as_ref().map(|o| o.counts)
    }

    /// Every k-th chunk: for plain LAZ in file order (a chunk is a run of
    /// consecutive points, near one another in a map's file); for COPC in
    /// the order of the nodes' keys (level, then x, y, z), so the sample is
    /// nodes from all over the map, most of them small deep cubes, each
    /// holding most of the points of its patch of ground. (An octree's
    /// coarse levels are an even sample too, but a thin one: at 4 M points
    /// of a square kilometre no 0.5 m ground cell would have a point.)
    fn hint_sample(&mut self, points: u64) {
        let total: u64 = self.order.iter().map(|&i| self.chunks[i].points).sum();
        if self.started || points == 0 || points >= total {
            return;
        }
        let every = (total / points).max(1) as usize;
        let before = self.order.len();
        match &mut self.octree {
            Some(o) => {
                let keys = &o.keys;
                let mut by_key = self.order.clone();
                by_key.sort_unstable_by_key(|&i| keys[i]);
                let mut keep: Vec<usize> = by_key.into_iter().step_by(every).collect();
                // Read in file order, as every other read of the file is.
                keep.sort_unstable();
                self.order = keep;
                o.counts.selected = self.order.len() as u64;
            }
            None => self.order = self.order.iter().copied().step_by(every).collect(),
        }
        self.sampled = self.order.len() < before;
    }

    fn sampled(&self) -> Option<u64> {
        self.sampled.then_some(self.bytes)
    }
}

/// Opens a plain LAZ file of point format 6-10 for coordinate-only decoding
/// (its chunk table already checked by `laz_check`). `None` sends it to the
/// `las` crate: formats 0-5, and a file the crate cannot parse (it then
/// reports why).
pub(super) fn open_plain(path: &Path, file: &File, file_bytes: u64) -> Result<Option<ChunkedLaz>> {
    // The las and laz crates parse the header and chunk table; they can panic
    // on malformed data, so on a reader thread (the panic becomes an error).
    let parsed = on_reader_thread(path, || {
        let own = || File::open(path).map_err(|e| Error::io(path, e));
        let Ok(r) = las::Reader::new(BufReader::new(own()?)) else {
            return Ok(None);
        };
        let h = r.header();
        let fmt = *h.point_format();
        if !fmt.is_compressed || fmt.to_u8().is_ok_and(|f| f < 6) {
            return Ok(None);
        }
        let (Ok(vlr), Ok(raw)) = (h.laz_vlr(), h.clone().into_raw()) else {
            return Ok(None);
        };
        let (total, transforms) = (h.number_of_points(), *h.transforms());
        drop(r);
        if vlr.items_size() != u64::from(fmt.len()) {
            return Ok(None);
        }
        let start = u64::from(raw.offset_to_point_data);
        let mut f = BufReader::new(own()?);
        f.seek(SeekFrom::Start(start))
            .map_err(|e| Error::io(path, e))?;
        let Ok(table) = laz::laszip::ChunkTable::read_from(&mut f, &vlr) else {
            return Ok(None);
        };
        let fixed = (!vlr.uses_variable_size_chunks()).then(|| u64::from(vlr.chunk_size()));
        Ok(Some((vlr, total, transforms, start, table, fixed)))
    })?;
    let Some((vlr, total, transforms, start, table, fixed)) = parsed else {
        return Ok(None);
    };
    // The chunks follow the 8-byte chunk table offset. Decode as many points
    // as the header declares: every chunk's (a fixed-size table's last chunk
    // holds the rest), and none after the header's count is reached.
    let mut chunks = Vec::with_capacity(table.len());
    let (mut at, mut sum) = (start + 8, 0u64);
    for e in table.as_ref() {
        if sum == total {
            break;
        }
        let points = fixed.unwrap_or(e.point_count).min(total - sum);
        let end = at.checked_add(e.byte_count).filter(|&b| b <= file_bytes);
        let Some(end) = end else {
            return Ok(None); // refused by `laz_check` already
        };
        if points > 0 {
            chunks.push(Chunk {
                offset: at,
                bytes: e.byte_count,
                points,
            });
        }
        (at, sum) = (end, sum + points);
    }
    if sum < total {
        return Err(Error::format(
            path,
            format!(
                "LAS: reading points {sum}.. of {total}: the LAZ chunk table holds only {sum} points"
            ),
        ));
    }
    let lay = Layout {
        info: CloudInfo {
            format: Format::Laz,
            declared_points: Some(total),
            file_bytes,
        },
        chunks,
        items: vlr.items().clone(),
        transforms,
        head_bytes: start,
    };
    ChunkedLaz::new(path, file, lay, None)
}
