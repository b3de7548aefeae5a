//! The LAZ chunk table checked against the file before the `laz` crate
//! allocates from it.

use std::fs::File;
use std::io::{BufReader, Seek, SeekFrom};
use std::os::unix::fs::FileExt;

/// Checks a LAZ file's chunk table against the file size before the `laz`
/// crate sees it: the crate allocates the table from its declared chunk count
/// and reads each chunk into a buffer of its declared byte count, so a lying
/// table would make it allocate gigabytes (found by fuzzing). Not LAZ: Ok.
/// `heads`: also check the head of every layered chunk (one small read per
/// chunk; a COPC reader checks the nodes it reads instead).
pub(super) fn check_laz_chunks(
    file: &File,
    file_bytes: u64,
    heads: bool,
) -> std::result::Result<(), String> {
    use std::io::Read;
    let mut f = BufReader::new(file);
    // Read the header fields directly: the las crate is more lenient than a
    // strict header parser, and every file it would decompress must be checked.
    let mut head = [0u8; 227];
    if f.read_exact(&mut head).is_err() || &head[..4] != b"LASF" {
        return Ok(()); // not a LAS header: the las crate decides
    }
    check_evlr(file, file_bytes)?;
    if head[104] & 0x80 == 0 {
        return Ok(()); // not compressed
    }
    let start = u64::from(u32::from_le_bytes([head[96], head[97], head[98], head[99]]));
    let Some(vlr) = laszip_vlr(&mut f, start, file_bytes)? else {
        return Err(bad("compressed point format but no readable laszip VLR"));
    };
    let table = table_offset(&mut f, start, file_bytes)?;
    let mut word = [0u8; 4];
    f.seek(SeekFrom::Start(table + 4)).map_err(io)?;
    f.read_exact(&mut word).map_err(io)?;
    let chunks = u64::from(u32::from_le_bytes(word));
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
    check_totals(&vlr, entries.as_ref(), data, max_points)?;
    // Layered chunks (point formats 6-10) declare their layers' sizes up front.
    if heads {
        check_heads(file, &vlr, entries.as_ref(), start)?;
    }
    Ok(())
}

/// A LAZ error message.
fn bad(m: &str) -> String {
    format!("LAZ: {m}")
}

/// A read error, as a LAZ error message.
fn io(e: std::io::Error) -> String {
    format!("LAZ: {e}")
}

/// The laszip VLR among the bytes before the point data at `start`, found
/// by its user id rather than by walking VLR lengths the crate may read
/// otherwise; `None` when there is none it can parse.
fn laszip_vlr(
    f: &mut BufReader<&File>,
    start: u64,
    file_bytes: u64,
) -> std::result::Result<Option<laz::LazVlr>, String> {
    use std::io::Read;
    let mut vlrs = Vec::new();
    f.seek(SeekFrom::Start(0)).map_err(io)?;
    f.take(start.min(file_bytes))
        .read_to_end(&mut vlrs)
        .map_err(io)?;
    let id = laz::LazVlr::USER_ID.as_bytes();
    Ok((0..vlrs.len().saturating_sub(id.len()))
        .filter(|&p| p >= 2 && vlrs[p..].starts_with(id))
        .find_map(|p| {
            let rec = u16::from_le_bytes([*vlrs.get(p + 16)?, *vlrs.get(p + 17)?]);
            let len = u16::from_le_bytes([*vlrs.get(p + 18)?, *vlrs.get(p + 19)?]) as usize;
            let data = vlrs.get(p + 52..p + 52 + len)?;
            (rec == laz::LazVlr::RECORD_ID)
                .then(|| laz::LazVlr::from_buffer(data).ok())
                .flatten()
        }))
}

/// The chunk table's offset (the point data's first word, or the file's
/// last when a streaming compressor wrote -1), which must lie within the
/// point data.
fn table_offset(
    f: &mut BufReader<&File>,
    start: u64,
    file_bytes: u64,
) -> std::result::Result<u64, String> {
    use std::io::Read;
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
    Ok(table)
}

/// The table's totals against the `data` bytes of point data: the chunks'
/// bytes must fit, and variable chunks hold at most `max_points` points.
fn check_totals(
    vlr: &laz::LazVlr,
    entries: &[laz::laszip::ChunkTableEntry],
    data: u64,
    max_points: u64,
) -> std::result::Result<(), String> {
    let (mut bytes, mut points) = (0u64, 0u64);
    for e in entries {
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

/// The head of every layered chunk (point formats 6-10; none for others),
/// one small read per chunk from the point data at `start`.
fn check_heads(
    file: &File,
    vlr: &laz::LazVlr,
    entries: &[laz::laszip::ChunkTableEntry],
    start: u64,
) -> std::result::Result<(), String> {
    let Some(words) = layer_words(vlr.items()) else {
        return Ok(());
    };
    let first: usize = vlr.items().iter().map(|i| usize::from(i.size())).sum();
    let mut head = vec![0u8; first + 4 + 4 * words];
    let mut at = start + 8;
    for (k, e) in entries.iter().enumerate() {
        let n = (e.byte_count as usize).min(head.len());
        file.read_exact_at(&mut head[..n], at)
            .map_err(|_| bad(&format!("chunk {k} lies beyond the end of the file")))?;
        check_layers(&head[..n], first, words, e.byte_count)
            .map_err(|m| bad(&format!("chunk {k}: {m}")))?;
        at += e.byte_count;
    }
    Ok(())
}

/// The `las` crate sizes the first extended VLR's buffer (LAS 1.4) by its
/// declared length before reading it: a length beyond the file's end is
/// refused here (fuzz find: 8 GB asked for by a 22 KB file).
fn check_evlr(file: &File, file_bytes: u64) -> std::result::Result<(), String> {
    let mut head = [0u8; 247];
    if file.read_exact_at(&mut head, 0).is_err() || head[24] != 1 || head[25] < 4 {
        return Ok(());
    }
    let start = u64::from_le_bytes(head[235..243].try_into().unwrap_or_default());
    let count = u32::from_le_bytes(head[243..247].try_into().unwrap_or_default());
    let mut evlr = [0u8; 60];
    if start == 0 || count == 0 || file.read_exact_at(&mut evlr, start).is_err() {
        return Ok(()); // none, or the crate's read fails before allocating
    }
    let len = u64::from_le_bytes(evlr[20..28].try_into().unwrap_or_default());
    if len > file_bytes.saturating_sub(start + 60) {
        return Err(format!(
            "LAS: extended VLR at byte {start} declares {len} bytes, the file ends {} bytes after its header",
            file_bytes.saturating_sub(start + 60)
        ));
    }
    Ok(())
}

/// How many layer-size words follow a layered chunk's first point and point
/// count (LAS 1.4 point formats 6-10); `None` for point-wise items (formats
/// 0-5), whose chunks have no layers.
pub(super) fn layer_words(items: &[laz::LazItem]) -> Option<usize> {
    use laz::LazItemType as T;
    items
        .iter()
        .map(|i| match i.item_type() {
            T::Point14 => Some(9),
            T::RGB14 | T::WavePacket14 => Some(1),
            T::RGBNIR14 => Some(2),
            T::Byte14(n) => Some(usize::from(n)),
            _ => None,
        })
        .sum()
}

/// Checks the head of a layered chunk of `len` bytes: its first point
/// (`first` bytes), point count and `words` layer sizes, which must fit in
/// the chunk. The `laz` crate zero-fills a buffer of each declared size before
/// reading it, so a lying size would cost gigabytes (fuzz find: 2 GB per
/// 23 KB file). Returns the chunk's declared point count.
pub(super) fn check_layers(
    head: &[u8],
    first: usize,
    words: usize,
    len: u64,
) -> std::result::Result<u32, String> {
    let fixed = first + 4 + 4 * words;
    if head.len() < fixed || (len as usize) < fixed {
        return Err(format!(
            "{len} bytes cannot hold a chunk's first point and layer sizes"
        ));
    }
    let word = |o: usize| u32::from_le_bytes([head[o], head[o + 1], head[o + 2], head[o + 3]]);
    let count = word(first);
    let layers: u64 = (0..words).map(|w| u64::from(word(first + 4 + 4 * w))).sum();
    if layers > len - fixed as u64 {
        return Err(format!(
            "layers of {layers} bytes declared in a chunk of {len} bytes"
        ));
    }
    Ok(count)
}
