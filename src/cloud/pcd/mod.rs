//! PCD reader (v0.5-v0.7; ascii, binary, binary_compressed).
//!
//! Hand-written because it is the hot path of every map read, and reads only
//! the x, y, z fields whatever else a point carries. The header is parsed
//! first (`header.rs`); binary data goes to the `pread` record reader
//! (`binary.rs`), binary_compressed to the streamed two-pass LZF decoder
//! (`compressed.rs`, `lzf_stream.rs`); ascii data is read in blocks whose
//! lines are parsed in parallel pieces (`ascii.rs`). Memory stays bounded
//! whatever the cloud's size.

use super::PointReader;
use crate::{Error, Result};
use header::{DataKind, Header};
use std::fs::File;
use std::io::Read;
use std::path::Path;

mod ascii;
mod binary;
mod compressed;
mod header;
mod lzf_stream;
#[cfg(test)]
mod reference;
#[cfg(test)]
mod tests;

/// Longest header accepted before concluding it never ends.
const MAX_HEADER: usize = 1 << 20;

/// Opens a PCD file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    let (file, file_bytes, header) = read_header(path)?;
    match header.data {
        DataKind::Binary => binary::open(path, file, file_bytes, header),
        DataKind::Compressed => compressed::open(path, file, file_bytes, header),
        DataKind::Ascii => Ok(Box::new(ascii::AsciiReader::open(
            path, file, file_bytes, header,
        )?)),
    }
}

/// Opens `path` and parses its header; the file position is unspecified.
fn read_header(path: &Path) -> Result<(File, u64, Header)> {
    let mut file = File::open(path).map_err(|e| Error::io(path, e))?;
    let file_bytes = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let mut head = Vec::new();
    (&mut file)
        .take(MAX_HEADER as u64)
        .read_to_end(&mut head)
        .map_err(|e| Error::io(path, e))?;
    let header = header::parse_header(path, &head)?;
    Ok((file, file_bytes, header))
}
