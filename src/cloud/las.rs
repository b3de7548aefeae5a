//! LAS/LAZ reader and LAS writer, on the `las` crate.
//!
//! The crate's reader is not `Send`, so it runs on its own thread and hands
//! blocks of points over a bounded channel ([`Producer`]); that also overlaps
//! decoding (and LAZ decompression, itself parallel) with the caller's work.
//! Memory stays at a few blocks whatever the file size.

use super::{CloudInfo, Format, PointReader, ReadStats, Sink};
use crate::{Error, Point, Result};
use std::fs::File;
use std::io::{BufReader, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

/// Points per block.
const CHUNK: u64 = 1 << 18;
/// Points per block of a LAZ file (about 20 LASzip chunks).
const LAZ_CHUNK: u64 = 1 << 20;
/// Most raw record bytes decoded per block.
const MAX_BLOCK_BYTES: u64 = 16 << 20;

/// A message from a reader thread.
pub(super) enum Msg {
    /// Header facts, sent first.
    Info(CloudInfo),
    /// A block of finite points, the non-finite/invalid points skipped while
    /// producing it, and the bytes of the file consumed so far.
    Chunk(Vec<Point>, u64, u64),
    /// The cloud is exhausted; skipped points since the last chunk.
    Done(u64),
    /// Reading failed.
    Err(Error),
}

/// The sending side given to a reader thread's body.
pub(super) struct Tx {
    tx: SyncSender<Msg>,
    recycle: Receiver<Vec<Point>>,
}

impl Tx {
    /// Sends a message; false when the consumer has gone away (stop reading).
    pub(super) fn send(&self, m: Msg) -> bool {
        self.tx.send(m).is_ok()
    }
    /// An empty buffer to fill, reusing one the consumer handed back.
    pub(super) fn buffer(&self) -> Vec<Point> {
        let mut v = self.recycle.try_recv().unwrap_or_default();
        v.clear();
        v
    }
}

/// A [`PointReader`] fed by a background thread (for crates whose readers are not
/// `Send` or borrow themselves). A panic in the thread becomes an error.
pub(super) struct Producer {
    path: PathBuf,
    info: CloudInfo,
    rx: Receiver<Msg>,
    recycle: SyncSender<Vec<Point>>,
    stats: ReadStats,
    bytes: u64,
    done: bool,
}

/// Name of the threads that run third-party decoders.
const READER_THREAD: &str = "mapgauge-reader";

/// Runs `f` on a reader thread and waits for it: a panic inside a third-party
/// parser becomes `path`'s one-line error instead of ending the process.
fn on_reader_thread<T: Send>(path: &Path, f: impl FnOnce() -> Result<T> + Send) -> Result<T> {
    quiet_reader_panics();
    std::thread::scope(|s| {
        let handle = std::thread::Builder::new()
            .name(READER_THREAD.into())
            .spawn_scoped(s, f)
            .map_err(|e| Error::io(path, e))?;
        handle.join().unwrap_or_else(|panic| {
            Err(Error::format(
                path,
                format!(
                    "the decoder failed on malformed data ({})",
                    panic_text(&*panic)
                ),
            ))
        })
    })
}

/// The message of a caught panic.
fn panic_text(panic: &(dyn std::any::Any + Send)) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown cause".into())
}

/// Installs (once) a panic hook that stays silent for reader threads, whose
/// panics are caught and reported as one-line errors; every other panic is
/// reported by the previous hook as usual.
fn quiet_reader_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let prev = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if std::thread::current().name() != Some(READER_THREAD) {
                prev(info);
            }
        }));
    });
}

impl Producer {
    /// Runs `body` on a new thread; it must send `Msg::Info` first, then chunks,
    /// then `Msg::Done` (or `Msg::Err`). Waits for the header.
    pub(super) fn spawn(path: &Path, body: impl FnOnce(Tx) + Send + 'static) -> Result<Self> {
        let (tx, rx) = sync_channel(1);
        let (recycle, back) = sync_channel(2);
        let p = path.to_path_buf();
        quiet_reader_panics();
        std::thread::Builder::new()
            .name(READER_THREAD.into())
            .spawn(move || {
                let err = tx.clone();
                // A decoder crate that panics on a malformed file (the `laz`
                // crate asserts on some lying headers) must not take the process
                // down: its panic becomes this file's error.
                let run = std::panic::AssertUnwindSafe(move || body(Tx { tx, recycle: back }));
                if let Err(panic) = std::panic::catch_unwind(run) {
                    let _ = err.send(Msg::Err(Error::format(
                        &p,
                        format!(
                            "the decoder failed on malformed data ({})",
                            panic_text(&*panic)
                        ),
                    )));
                }
            })
            .map_err(|e| Error::io(path, e))?;
        let mut p = Producer {
            path: path.to_path_buf(),
            info: CloudInfo {
                format: Format::Las,
                declared_points: None,
                file_bytes: 0,
            },
            rx,
            recycle,
            stats: ReadStats::default(),
            bytes: 0,
            done: false,
        };
        match p.rx.recv() {
            Ok(Msg::Info(info)) => p.info = info,
            Ok(Msg::Err(e)) => return Err(e),
            _ => return Err(p.died()),
        }
        Ok(p)
    }

    fn died(&self) -> Error {
        Error::format(
            &self.path,
            "the reader stopped unexpectedly (malformed file?)",
        )
    }
}

impl PointReader for Producer {
    fn info(&self) -> &CloudInfo {
        &self.info
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        buf.clear();
        if self.done {
            return Ok(false);
        }
        match self.rx.recv() {
            Ok(Msg::Chunk(mut v, skipped, bytes)) => {
                std::mem::swap(buf, &mut v);
                let _ = self.recycle.try_send(v);
                self.stats.points += buf.len() as u64;
                self.stats.skipped_nonfinite += skipped;
                self.bytes = bytes;
                Ok(true)
            }
            Ok(Msg::Done(skipped)) => {
                self.stats.skipped_nonfinite += skipped;
                self.bytes = self.info.file_bytes;
                self.done = true;
                Ok(false)
            }
            Ok(Msg::Err(e)) => {
                self.done = true;
                Err(e)
            }
            Ok(Msg::Info(_)) | Err(_) => {
                self.done = true;
                Err(self.died())
            }
        }
    }

    fn stats(&self) -> ReadStats {
        self.stats
    }

    fn bytes_read(&self) -> u64 {
        self.bytes
    }
}

fn las_err(path: &Path, e: las::Error) -> Error {
    Error::format(path, format!("LAS: {e}"))
}

/// Opens a LAS file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let file_bytes = file.metadata().map_err(|e| Error::io(path, e))?.len();
    // Before any `las::Reader`: opening a LAZ file already reads its chunk table.
    // On a reader thread: the laz crate's chunk-table decoder can panic on
    // malformed data (index out of bounds: fuzz find).
    on_reader_thread(path, || {
        check_laz_chunks(&file, file_bytes)
            .and_then(|()| {
                (&file)
                    .seek(SeekFrom::Start(0))
                    .map(drop)
                    .map_err(|e| e.to_string())
            })
            .map_err(|msg| Error::format(path, msg))
    })?;
    if let Some(r) = open_records(path, &file, file_bytes)? {
        return Ok(r);
    }
    let p = path.to_path_buf();
    let producer = Producer::spawn(path, move |tx| {
        let mut reader = match las::Reader::new(BufReader::with_capacity(1 << 20, file)) {
            Ok(r) => r,
            Err(e) => {
                tx.send(Msg::Err(las_err(&p, e)));
                return;
            }
        };
        let header = reader.header();
        let total = header.number_of_points();
        let fmt = *header.point_format();
        let rec = fmt.len() as u64;
        let t = *header.transforms();
        let compressed = fmt.is_compressed;
        if !compressed {
            // A declared count larger than the data is an error up front.
            let raw = header.clone().into_raw().ok();
            let start = raw.as_ref().map_or(0, |r| r.offset_to_point_data as u64);
            // Point data ends where the extended VLRs (LAS 1.4) start, or at the end.
            let data_end = raw
                .as_ref()
                .and_then(|r| r.evlr)
                .map(|e| e.start_of_first_evlr)
                .filter(|&e| e > start && e <= file_bytes)
                .unwrap_or(file_bytes);
            let need = total.checked_mul(rec).and_then(|b| b.checked_add(start));
            if need.is_some_and(|n| rec > 0 && n <= data_end && data_end - n >= rec) {
                tx.send(Msg::Err(Error::format(
                    &p,
                    format!(
                        "LAS header declares {total} points but the point data holds {} ({} bytes of {rec}-byte records)",
                        (data_end - start) / rec,
                        data_end - start
                    ),
                )));
                return;
            }
            if need.is_none_or(|n| n > file_bytes) {
                tx.send(Msg::Err(Error::format(
                    &p,
                    format!(
                        "LAS point data truncated: header declares {total} points of {rec} bytes, the file holds {}",
                        file_bytes.saturating_sub(start) / rec.max(1)
                    ),
                )));
                return;
            }
        }
        let format = if compressed { Format::Laz } else { Format::Las };
        if !tx.send(Msg::Info(CloudInfo {
            format,
            declared_points: Some(total),
            file_bytes,
        })) {
            return;
        }
        let mut pd = las::PointDataBuilder::new()
            .for_header(reader.header())
            .build();
        let mut done = 0u64;
        // LAZ is decompressed in parallel one LASzip chunk (typically 50 000
        // points) per task: ask for many chunks at a time so every core has one.
        let block = if compressed { LAZ_CHUNK } else { CHUNK };
        // The crate's buffer is points x record length, and a header may claim
        // 64 KiB records: keep a block's raw bytes within 16 MiB (no change
        // for real records, at most 64 bytes; fuzz find: 17 GB block).
        let per_fill = block.min((MAX_BLOCK_BYTES / rec.max(1)).max(1));
        loop {
            let n = match reader.fill_points(per_fill, &mut pd) {
                Ok(n) => n,
                Err(e) => {
                    tx.send(Msg::Err(Error::format(
                        &p,
                        format!("LAS: reading points {done}.. of {total}: {e}"),
                    )));
                    return;
                }
            };
            if n == 0 {
                break;
            }
            done += n;
            let mut out = tx.buffer();
            out.reserve(n as usize);
            let mut skipped = 0;
            for r in pd.raw_bytes().chunks_exact(pd.record_len()) {
                let i = |o: usize| i32::from_le_bytes([r[o], r[o + 1], r[o + 2], r[o + 3]]);
                let q = Point::new(t.x.direct(i(0)), t.y.direct(i(4)), t.z.direct(i(8)));
                if q.x.is_finite() && q.y.is_finite() && q.z.is_finite() {
                    out.push(q);
                } else {
                    skipped += 1;
                }
            }
            let bytes = if total > 0 {
                file_bytes.saturating_mul(done) / total
            } else {
                file_bytes
            };
            if !tx.send(Msg::Chunk(out, skipped, bytes)) {
                return;
            }
        }
        tx.send(Msg::Done(0));
    })?;
    Ok(Box::new(producer))
}

/// Uncompressed LAS: every point format stores X, Y, Z as little-endian i32 at
/// the start of a fixed-size record, so the points go through the `pread`
/// record reader (the `las` crate's reader copies each record twice). `None`
/// for LAZ.
fn open_records(path: &Path, file: &File, file_bytes: u64) -> Result<Option<Box<dyn PointReader>>> {
    let own = || File::open(path).map_err(|e| Error::io(path, e));
    // The `las` crate can panic on a malformed header (an overflow in its size
    // arithmetic: fuzz find), so it parses on a reader thread, like the decoders.
    let parsed = on_reader_thread(path, || {
        let reader = las::Reader::new(BufReader::new(own()?)).map_err(|e| las_err(path, e))?;
        let header = reader.header();
        if header.point_format().is_compressed {
            return Ok(None);
        }
        let count = header.number_of_points();
        let t = *header.transforms();
        drop(reader);
        let mut head = BufReader::new(own()?);
        let raw = las::raw::Header::read_from(&mut head).map_err(|e| las_err(path, e))?;
        Ok(Some((count, t, raw)))
    })?;
    let Some((count, t, raw)) = parsed else {
        return Ok(None);
    };
    let stride = raw.point_data_record_length as usize;
    if stride < 12 {
        return Err(Error::format(
            path,
            format!("LAS point records of {stride} bytes cannot hold X, Y, Z"),
        ));
    }
    let start = u64::from(raw.offset_to_point_data);
    // Point data ends where the extended VLRs (LAS 1.4) start, or at the end.
    let data_end = raw
        .evlr
        .map(|e| e.start_of_first_evlr)
        .filter(|&e| e > start && e <= file_bytes)
        .unwrap_or(file_bytes);
    let need = count
        .checked_mul(stride as u64)
        .and_then(|b| b.checked_add(start));
    if need.is_some_and(|n| n <= data_end && data_end - n >= stride as u64) {
        return Err(Error::format(
            path,
            format!(
                "LAS header declares {count} points but the point data holds {} ({} bytes of {stride}-byte records)",
                (data_end - start) / stride as u64,
                data_end - start
            ),
        ));
    }
    if count
        .checked_mul(stride as u64)
        .and_then(|b| b.checked_add(start))
        .is_none_or(|n| n > file_bytes)
    {
        return Err(Error::format(
            path,
            format!(
                "LAS point data truncated: header declares {count} points of {stride} bytes, the file holds {}",
                file_bytes.saturating_sub(start) / stride as u64
            ),
        ));
    }
    let file = file.try_clone().map_err(|e| Error::io(path, e))?;
    let info = CloudInfo {
        format: Format::Las,
        declared_points: Some(count),
        file_bytes,
    };
    let coord = |offset| super::records::Coord {
        kind: super::scalar::Scalar::I32,
        offset,
    };
    let lay = super::records::Layout {
        start,
        stride,
        count,
        coords: [coord(0), coord(4), coord(8)],
        big_endian: false,
        transform: Some([
            (t.x.scale, t.x.offset),
            (t.y.scale, t.y.offset),
            (t.z.scale, t.z.offset),
        ]),
    };
    Ok(Some(Box::new(super::records::Records::new(
        file, path, info, lay,
    )?)))
}

/// Checks a LAZ file's chunk table against the file size before the `laz`
/// crate sees it: the crate allocates the table from its declared chunk count
/// and reads each chunk into a buffer of its declared byte count, so a lying
/// table would make it allocate gigabytes (found by fuzzing). Not LAZ: Ok.
fn check_laz_chunks(file: &File, file_bytes: u64) -> std::result::Result<(), String> {
    use std::io::Read;
    let mut f = BufReader::new(file);
    let bad = |m: &str| format!("LAZ: {m}");
    let io = |e: std::io::Error| format!("LAZ: {e}");
    // Read the header fields directly: the las crate is more lenient than a
    // strict header parser, and every file it would decompress must be checked.
    let mut head = [0u8; 227];
    if f.read_exact(&mut head).is_err() || &head[..4] != b"LASF" || head[104] & 0x80 == 0 {
        return Ok(()); // not a compressed LAS header: the las crate decides
    }
    let start = u64::from(u32::from_le_bytes([head[96], head[97], head[98], head[99]]));
    // The laszip VLR lies between the header and the point data; find it by
    // its user id rather than by walking VLR lengths the crate may read otherwise.
    let mut vlrs = Vec::new();
    f.seek(SeekFrom::Start(0)).map_err(io)?;
    (&mut f)
        .take(start.min(file_bytes))
        .read_to_end(&mut vlrs)
        .map_err(io)?;
    let id = laz::LazVlr::USER_ID.as_bytes();
    let vlr = (0..vlrs.len().saturating_sub(id.len()))
        .filter(|&p| p >= 2 && vlrs[p..].starts_with(id))
        .find_map(|p| {
            let rec = u16::from_le_bytes([*vlrs.get(p + 16)?, *vlrs.get(p + 17)?]);
            let len = u16::from_le_bytes([*vlrs.get(p + 18)?, *vlrs.get(p + 19)?]) as usize;
            let data = vlrs.get(p + 52..p + 52 + len)?;
            (rec == laz::LazVlr::RECORD_ID)
                .then(|| laz::LazVlr::from_buffer(data).ok())
                .flatten()
        });
    let Some(vlr) = vlr else {
        return Err(bad("compressed point format but no readable laszip VLR"));
    };
    let mut word = [0u8; 8];
    f.seek(SeekFrom::Start(start)).map_err(io)?;
    f.read_exact(&mut word)
        .map_err(|_| bad("point data ends before the chunk table offset"))?;
    let mut table = i64::from_le_bytes(word);
    if table == -1 {
        // Written by a streaming compressor: the offset is the file's last 8 bytes.
        f.seek(SeekFrom::End(-8)).map_err(io)?;
        f.read_exact(&mut word).map_err(io)?;
        table = i64::from_le_bytes(word);
    }
    let table = u64::try_from(table).unwrap_or(u64::MAX);
    if table < start + 8 || table.saturating_add(8) > file_bytes {
        return Err(bad(&format!(
            "chunk table offset {table} lies outside the point data ({}..{file_bytes})",
            start + 8
        )));
    }
    f.seek(SeekFrom::Start(table + 4)).map_err(io)?;
    f.read_exact(&mut word[..4]).map_err(io)?;
    let chunks = u64::from(u32::from_le_bytes([word[0], word[1], word[2], word[3]]));
    // Every chunk holds at least one byte of point data.
    if chunks > table - start {
        return Err(bad(&format!(
            "chunk table declares {chunks} chunks in {} bytes of point data",
            table - start
        )));
    }
    // The crate sizes a chunk's output buffer by its point count (the VLR's
    // chunk size when chunks are fixed): no real file packs more than a few
    // dozen points into a compressed byte, so allow 64 per byte (and the
    // LASzip default chunk of 50 000 whatever the size).
    let data = table - start;
    let max_points = data.saturating_mul(64).max(50_000);
    if !vlr.uses_variable_size_chunks() && u64::from(vlr.chunk_size()) > max_points {
        return Err(bad(&format!(
            "chunk size {} points is absurd for {data} bytes of point data",
            vlr.chunk_size()
        )));
    }
    f.seek(SeekFrom::Start(start)).map_err(io)?;
    let entries =
        laz::laszip::ChunkTable::read_from(&mut f, &vlr).map_err(|e| bad(&e.to_string()))?;
    let (mut bytes, mut points) = (0u64, 0u64);
    for e in entries.as_ref() {
        bytes = bytes.saturating_add(e.byte_count);
        points = points.saturating_add(e.point_count);
    }
    if bytes > data {
        return Err(bad(&format!(
            "chunk table declares {bytes} compressed bytes, the point data holds {data}"
        )));
    }
    if vlr.uses_variable_size_chunks() && points > max_points {
        return Err(bad(&format!(
            "chunk table declares {points} points in {data} bytes of point data"
        )));
    }
    Ok(())
}

/// A file that turns into a no-op once aborted, so the `las` writer's drop (which
/// rewrites the header) cannot fail or panic after we gave up on the file.
struct Abortable {
    inner: BufWriter<File>,
    abort: Arc<AtomicBool>,
}

impl Write for Abortable {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        if self.abort.load(Ordering::Relaxed) {
            Ok(b.len())
        } else {
            self.inner.write(b)
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        if self.abort.load(Ordering::Relaxed) {
            Ok(())
        } else {
            self.inner.flush()
        }
    }
}

impl Seek for Abortable {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        if self.abort.load(Ordering::Relaxed) {
            Ok(0)
        } else {
            self.inner.seek(pos)
        }
    }
}

/// Streaming LAS 1.2 point format 0 writer, millimetre scale, offset from the
/// first point (floored to 1 km) so projected coordinates keep full precision.
struct LasSink {
    path: PathBuf,
    tmp: PathBuf,
    file: Option<File>,
    writer: Option<las::Writer<Abortable>>,
    abort: Arc<AtomicBool>,
    pd: Option<las::PointData>,
    offset: [f64; 3],
    count: u64,
    finished: bool,
    /// Write LAZ.
    compressed: bool,
}

/// Scale of written coordinates (metres per unit).
const SCALE: f64 = 0.001;

/// Starts a LAS writer.
pub(super) fn las_sink(path: &Path, compressed: bool) -> Result<Box<dyn Sink>> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.partial"));
    let file = File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
    Ok(Box::new(LasSink {
        path: path.to_path_buf(),
        tmp,
        file: Some(file),
        writer: None,
        abort: Arc::new(AtomicBool::new(false)),
        pd: None,
        offset: [0.0; 3],
        count: 0,
        finished: false,
        compressed,
    }))
}

impl LasSink {
    fn start(&mut self, first: Option<&Point>) -> Result<()> {
        if let Some(p) = first {
            self.offset = [p.x, p.y, p.z].map(|c| (c / 1000.0).floor() * 1000.0);
        }
        let mut b = las::Builder::from((1, 2));
        b.point_format = las::point::Format::new(0).map_err(|e| las_err(&self.path, e))?;
        b.point_format.is_compressed = self.compressed;
        b.generating_software = format!("mapgauge {}", env!("CARGO_PKG_VERSION"));
        b.system_identifier = "mapgauge".into();
        b.date = None;
        let tr = |o: f64| las::Transform {
            scale: SCALE,
            offset: o,
        };
        b.transforms = las::Vector {
            x: tr(self.offset[0]),
            y: tr(self.offset[1]),
            z: tr(self.offset[2]),
        };
        let header = b.into_header().map_err(|e| las_err(&self.path, e))?;
        let file = self
            .file
            .take()
            .ok_or_else(|| Error::format(&self.path, "LAS writer reused"))?;
        let w = Abortable {
            inner: BufWriter::with_capacity(1 << 20, file),
            abort: self.abort.clone(),
        };
        let writer = las::Writer::new(w, header).map_err(|e| las_err(&self.tmp, e))?;
        self.pd = Some(
            las::PointDataBuilder::new()
                .for_header(writer.header())
                .build(),
        );
        self.writer = Some(writer);
        Ok(())
    }
}

impl Sink for LasSink {
    fn write(&mut self, points: &[Point]) -> Result<()> {
        if points.is_empty() {
            return Ok(());
        }
        if self.writer.is_none() {
            self.start(
                points
                    .iter()
                    .find(|p| p.x.is_finite() && p.y.is_finite() && p.z.is_finite()),
            )?;
        }
        let (Some(writer), Some(pd)) = (self.writer.as_mut(), self.pd.as_mut()) else {
            return Err(Error::format(&self.path, "LAS writer not started"));
        };
        let bytes = pd.resize_for(points.len());
        for (k, (p, rec)) in points.iter().zip(bytes.chunks_exact_mut(20)).enumerate() {
            let mut q = [0i32; 3];
            for (c, v) in [p.x, p.y, p.z].into_iter().enumerate() {
                let u = ((v - self.offset[c]) / SCALE).round();
                if !(u >= i32::MIN as f64 && u <= i32::MAX as f64) {
                    return Err(Error::format(
                        &self.path,
                        format!(
                            "point {}: ({}, {}, {}) is not finite or lies over 2000 km from the first point; LAS millimetre coordinates cannot hold it",
                            self.count + k as u64,
                            p.x,
                            p.y,
                            p.z
                        ),
                    ));
                }
                q[c] = u as i32;
            }
            rec[0..4].copy_from_slice(&q[0].to_le_bytes());
            rec[4..8].copy_from_slice(&q[1].to_le_bytes());
            rec[8..12].copy_from_slice(&q[2].to_le_bytes());
            rec[12..14].copy_from_slice(&0u16.to_le_bytes()); // intensity
            rec[14] = 0b0000_1001; // return 1 of 1
            rec[15] = 1; // classification: unclassified
            rec[16] = 0; // scan angle
            rec[17] = 0; // user data
            rec[18..20].copy_from_slice(&0u16.to_le_bytes()); // point source id
        }
        writer.write_points(pd).map_err(|e| las_err(&self.tmp, e))?;
        self.count += points.len() as u64;
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<u64> {
        if self.writer.is_none() {
            self.start(None)?;
        }
        let Some(writer) = self.writer.take() else {
            return Err(Error::format(&self.path, "LAS writer not started"));
        };
        let mut inner = writer.into_inner().map_err(|e| las_err(&self.tmp, e))?;
        inner.inner.flush().map_err(|e| Error::io(&self.tmp, e))?;
        drop(inner);
        std::fs::rename(&self.tmp, &self.path).map_err(|e| Error::io(&self.path, e))?;
        self.finished = true;
        Ok(self.count)
    }
}

impl Drop for LasSink {
    fn drop(&mut self) {
        if !self.finished {
            self.abort.store(true, Ordering::Relaxed);
            self.writer = None;
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(path: &Path) -> Result<(Vec<Point>, ReadStats, CloudInfo)> {
        let mut r = super::super::open(path)?;
        let mut all = Vec::new();
        let mut buf = Vec::new();
        while r.next_chunk(&mut buf)? {
            all.extend_from_slice(&buf);
        }
        Ok((all, r.stats(), r.info().clone()))
    }

    fn truth(n: usize) -> Vec<Point> {
        (0..n)
            .map(|i| {
                Point::new(
                    350123.456 + i as f64 * 0.01,
                    4150234.567 - i as f64 * 0.002,
                    12.5 + i as f64 * 0.001,
                )
            })
            .collect()
    }

    /// Writes `pts` with the las crate itself in point format `fmt`.
    fn write_with_crate(path: &Path, fmt: u8, version: (u8, u8), pts: &[Point]) {
        let mut b = las::Builder::from(version);
        b.point_format = las::point::Format::new(fmt).unwrap();
        let tr = |o| las::Transform {
            scale: 0.001,
            offset: o,
        };
        b.transforms = las::Vector {
            x: tr(350000.0),
            y: tr(4150000.0),
            z: tr(0.0),
        };
        let mut w = las::Writer::from_path(path, b.into_header().unwrap()).unwrap();
        for p in pts {
            let mut q = las::Point {
                x: p.x,
                y: p.y,
                z: p.z,
                intensity: 7,
                return_number: 1,
                number_of_returns: 1,
                ..Default::default()
            };
            let f = w.header().point_format();
            if f.has_gps_time {
                q.gps_time = Some(1234.5);
            }
            if f.has_color {
                q.color = Some(las::Color::new(1, 2, 3));
            }
            w.write_point(q).unwrap();
        }
        w.close().unwrap();
    }

    fn assert_mm(got: &[Point], want: &[Point]) {
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs().max() < 0.0005 + 1e-9, "{g} vs {w}");
        }
    }

    #[test]
    fn reads_formats_0_1_3_6_and_laz() {
        let dir = tempfile::tempdir().unwrap();
        let pts = truth(CHUNK as usize + 1000);
        for (fmt, ver, ext) in [
            (0, (1, 2), "las"),
            (1, (1, 2), "las"),
            (3, (1, 2), "las"),
            (6, (1, 4), "las"),
            (3, (1, 2), "laz"),
            (6, (1, 4), "laz"),
        ] {
            let path = dir.path().join(format!("f{fmt}.{ext}"));
            write_with_crate(&path, fmt, ver, &pts);
            let (got, st, info) = read(&path).unwrap();
            assert_eq!(
                info.format,
                if ext == "laz" {
                    Format::Laz
                } else {
                    Format::Las
                },
                "{fmt} {ext}"
            );
            assert_eq!(info.declared_points, Some(pts.len() as u64));
            assert_eq!(st.points, pts.len() as u64);
            assert_mm(&got, &pts);
        }
    }

    #[test]
    fn truncated_las_is_a_clear_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.las");
        write_with_crate(&path, 0, (1, 2), &truth(100));
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 30]).unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(
            e.contains("t.las") && e.contains("declares 100 points") && e.contains("holds 98"),
            "{e}"
        );
        std::fs::write(&path, &bytes[..50]).unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(e.contains("t.las") && e.contains("LAS"), "{e}");
    }

    #[test]
    fn sink_roundtrip_keeps_millimetres_at_utm() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.las");
        let pts = truth(5000);
        let mut w = super::super::CloudWriter::create(&path, super::super::OutFormat::Las).unwrap();
        for c in pts.chunks(777) {
            w.write(c).unwrap();
        }
        assert!(!path.exists(), "final name appears only on finish");
        assert_eq!(w.finish().unwrap(), pts.len() as u64);
        let (got, _, _) = read(&path).unwrap();
        assert_mm(&got, &pts);
        // exact to the millimetre grid
        assert_eq!(got[0], Point::new(350123.456, 4150234.567, 12.5));
        // header bounds computed by the crate
        let r = las::Reader::from_path(&path).unwrap();
        let b = r.header().bounds();
        assert!((b.min.x - 350123.456).abs() < 1e-6 && (b.max.z - (12.5 + 4.999)).abs() < 1e-6);
        // deterministic bytes
        let path2 = dir.path().join("out2.las");
        super::super::write(&path2, super::super::OutFormat::Las, &pts).unwrap();
        assert_eq!(
            std::fs::read(&path).unwrap(),
            std::fs::read(&path2).unwrap()
        );
    }

    #[test]
    fn sink_dropped_without_finish_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("gone.las");
        let mut w = super::super::CloudWriter::create(&path, super::super::OutFormat::Las).unwrap();
        w.write(&truth(10)).unwrap();
        drop(w);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        // empty cloud is a valid file
        super::super::write(&path, super::super::OutFormat::Las, &[]).unwrap();
        assert_eq!(read(&path).unwrap().0.len(), 0);
        // a point too far away is an error, not garbage
        let e = super::super::write(
            &path,
            super::super::OutFormat::Las,
            &[Point::origin(), Point::new(3e6, 0., 0.)],
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("point 1"), "{e}");
    }
}
