//! LAS/LAZ reader and LAS writer, on the `las` and `laz` crates.
//!
//! The `las` crate's reader is not `Send`, so it runs on its own thread and hands
//! blocks of points over a bounded channel (`producer.rs`); that also overlaps
//! decoding (and LAZ decompression, itself parallel) with the caller's work.
//! Memory stays at a few blocks whatever the file size.

//!
//! LAS data goes to the `pread` record reader. LAZ has its chunk table
//! checked first (`laz_check.rs`); then LAS 1.4 point formats 6-10 (layered
//! chunks) are decoded chunk by chunk, X, Y, Z only (`chunked.rs`, of which
//! COPC, `copc.rs`, is the case that can skip nodes), and formats 0-5 go
//! through the crate. The writer is `sink.rs`.

use super::producer::{Msg, Producer, Tx, on_reader_thread};
use super::{CloudInfo, Format, PointReader};
use crate::{Error, Point, Result};
use std::fs::File;
use std::io::{BufReader, Seek, SeekFrom};
use std::path::Path;

mod chunked;
mod copc;
mod crs;
mod laz_check;
mod octree;
mod sink;
#[cfg(test)]
mod tests;

pub(super) use crs::{Crs, crs_of, declared_crs};
pub(super) use sink::las_sink;

/// One LASzip chunk: where its bytes are and how many points to decode.
#[derive(Debug, Clone, Copy)]
pub(super) struct Chunk {
    pub(super) offset: u64,
    pub(super) bytes: u64,
    pub(super) points: u64,
}

/// Points per block.
const CHUNK: u64 = 1 << 18;
/// Points per block of a LAZ file (about 20 LASzip chunks).
const LAZ_CHUNK: u64 = 1 << 20;
/// Most raw record bytes decoded per block.
const MAX_BLOCK_BYTES: u64 = 16 << 20;

pub(super) fn las_err(path: &Path, e: las::Error) -> Error {
    Error::format(path, format!("LAS: {e}"))
}

/// Appends a LAS record's point (every point format starts with X, Y, Z as
/// little-endian i32), scaled and offset; `false` (and nothing appended)
/// when a coordinate is not finite.
#[inline]
fn push_record(r: &[u8], t: &las::Vector<las::Transform>, out: &mut Vec<Point>) -> bool {
    let i = |o: usize| i32::from_le_bytes([r[o], r[o + 1], r[o + 2], r[o + 3]]);
    let q = Point::new(t.x.direct(i(0)), t.y.direct(i(4)), t.z.direct(i(8)));
    let finite = q.x.is_finite() && q.y.is_finite() && q.z.is_finite();
    if finite {
        out.push(q);
    }
    finite
}

/// A LAS record's intensity (every point format stores it as a
/// little-endian u16 after X, Y, Z).
#[inline]
fn record_intensity(r: &[u8]) -> f32 {
    f32::from(u16::from_le_bytes([r[12], r[13]]))
}

/// Opens a LAS file for streaming (a COPC file reads its octree's nodes).
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    let chunked = std::env::var_os(chunked::CRATE_PATH_ENV).is_none();
    open_with(path, true, chunked)
}

/// [`open`]; `copc: false` reads a COPC file as plain LAZ, `chunked: false`
/// reads plain LAZ of every point format through the `las` crate (tests
/// compare the paths).
fn open_with(path: &Path, copc: bool, chunked: bool) -> Result<Box<dyn PointReader>> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let file_bytes = file.metadata().map_err(|e| Error::io(path, e))?.len();
    // Before any `las::Reader`: opening a LAZ file already reads its chunk table.
    // On a reader thread: the laz crate's chunk-table decoder can panic on
    // malformed data (index out of bounds: fuzz find).
    let check = |heads: bool| {
        on_reader_thread(path, || {
            laz_check::check_laz_chunks(&file, file_bytes, heads)
                .and_then(|()| {
                    (&file)
                        .seek(SeekFrom::Start(0))
                        .map(drop)
                        .map_err(|e| e.to_string())
                })
                .map_err(|msg| Error::format(path, msg))
        })
    };
    // A COPC reader checks the head of each node it reads, not of every chunk
    // up front (that would touch the whole file).
    let is_copc = copc && copc::has_copc_vlr(&file);
    check(!is_copc)?;
    if let Some(r) = open_records(path, &file, file_bytes)? {
        return Ok(r);
    }
    if is_copc {
        if let Some(r) = copc::open(path, &file, file_bytes)? {
            return Ok(Box::new(r));
        }
        // Read as plain LAZ after all: every chunk's head checked first.
        check(true)?;
    }
    if chunked && let Some(r) = chunked::open_plain(path, &file, file_bytes)? {
        return Ok(Box::new(r));
    }
    let p = path.to_path_buf();
    // Sized here, on the caller's thread, so a caller's own pool size holds.
    let pool = super::producer::reader_pool();
    let producer = Producer::spawn(path, move |tx| match pool {
        Some(pool) => pool.install(move || read_laz(tx, file, file_bytes, p)),
        None => read_laz(tx, file, file_bytes, p),
    })?;
    Ok(Box::new(producer))
}

/// Where the point records end: at the waveform data packets stored inside
/// the file (LAS 1.3+) or the extended VLRs (LAS 1.4), whichever comes first
/// after the points; else at the end of the file.
fn point_data_end(raw: &las::raw::Header, start: u64, file_bytes: u64) -> u64 {
    [
        raw.evlr.map(|e| e.start_of_first_evlr),
        raw.start_of_waveform_data_packet_record,
    ]
    .into_iter()
    .flatten()
    .filter(|&e| e > start && e <= file_bytes)
    .min()
    .unwrap_or(file_bytes)
}

/// The body of the LAZ reader thread: decodes blocks through the `las` crate
/// and sends them.
fn read_laz(tx: Tx, file: File, file_bytes: u64, p: std::path::PathBuf) {
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
        let data_end = raw
            .as_ref()
            .map_or(file_bytes, |r| point_data_end(r, start, file_bytes));
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
    // Every point format stores an intensity.
    if !tx.send(Msg::Info(
        CloudInfo {
            format,
            declared_points: Some(total),
            file_bytes,
        },
        true,
    )) {
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
        let mut inten = Vec::with_capacity(n as usize);
        let mut skipped = 0;
        for r in pd.raw_bytes().chunks_exact(pd.record_len()) {
            if push_record(r, &t, &mut out) {
                inten.push(record_intensity(r));
            } else {
                skipped += 1;
            }
        }
        let bytes = if total > 0 {
            file_bytes.saturating_mul(done) / total
        } else {
            file_bytes
        };
        if !tx.send(Msg::Chunk(out, inten, skipped, bytes)) {
            return;
        }
    }
    tx.send(Msg::Done(0));
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
    let data_end = point_data_end(&raw, start, file_bytes);
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
        // Intensity follows X, Y, Z in every point format.
        intensity: Some(super::records::Coord {
            kind: super::scalar::Scalar::U16,
            offset: 12,
        }),
    };
    Ok(Some(Box::new(super::records::Records::new(
        file, path, info, lay,
    )?)))
}
