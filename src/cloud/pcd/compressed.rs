//! binary_compressed PCD: the two size words after the header, checked
//! against the header and the file before the streamed LZF decoder
//! (`lzf_stream.rs`) sees the data.

use super::header::Header;
use super::lzf_stream::{Column, LzfColumns};
use crate::cloud::{CloudInfo, Format, PointReader};
use crate::{Error, Result};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// An LZF back-reference turns 3 input bytes into at most 264 output bytes.
const LZF_MAX_RATIO: u64 = 88;

/// Opens the binary_compressed data of `header` for streaming.
pub(super) fn open(
    path: &Path,
    mut file: File,
    file_bytes: u64,
    header: Header,
) -> Result<Box<dyn PointReader>> {
    let after = file_bytes.saturating_sub(header.data_offset as u64);
    let (comp, raw) = compressed_sizes(path, &mut file, &header, after)?;
    let f = |i: usize| &header.fields[header.xyz[i]];
    let info = CloudInfo {
        format: Format::Pcd,
        declared_points: Some(header.points),
        file_bytes,
    };
    let cols = [0, 1, 2].map(|i| Column {
        kind: f(i).kind,
        // Column-wise: each field's values for all points lie together.
        base: header.points * f(i).offset as u64,
        stride: (f(i).size * f(i).count) as u64,
    });
    // The intensity, for the boards' pass: a column like the others.
    let intensity = header.intensity_field().map(|i| {
        let f = &header.fields[i];
        Column {
            kind: f.kind,
            base: header.points * f.offset as u64,
            stride: (f.size * f.count) as u64,
        }
    });
    let start = header.data_offset as u64 + 8;
    Ok(Box::new(LzfColumns::open(
        file,
        path,
        info,
        start,
        comp,
        raw,
        header.points,
        cols,
        intensity,
    )?))
}

/// Reads the compressed and uncompressed sizes that follow a binary_compressed
/// header and checks them against the header and the file size.
pub(super) fn compressed_sizes(
    path: &Path,
    file: &mut File,
    h: &Header,
    after: u64,
) -> Result<(u64, u64)> {
    let expect = h
        .points
        .checked_mul(h.point_size as u64)
        .ok_or_else(|| Error::format(path, format!("POINTS {} is absurdly large", h.points)))?;
    if after < 8 {
        return Err(Error::format(
            path,
            format!(
                "truncated binary_compressed data: {after} bytes after the header, need at least 8 for the size fields"
            ),
        ));
    }
    file.seek(SeekFrom::Start(h.data_offset as u64))
        .map_err(|e| Error::io(path, e))?;
    let mut sizes = [0u8; 8];
    file.read_exact(&mut sizes)
        .map_err(|e| Error::io(path, e))?;
    let comp = u32::from_le_bytes([sizes[0], sizes[1], sizes[2], sizes[3]]) as u64;
    let raw = u32::from_le_bytes([sizes[4], sizes[5], sizes[6], sizes[7]]) as u64;
    if raw != expect {
        return Err(Error::format(
            path,
            format!(
                "binary_compressed uncompressed size {raw} does not match POINTS {} x {}-byte points = {expect}",
                h.points, h.point_size
            ),
        ));
    }
    if comp > after - 8 {
        return Err(Error::format(
            path,
            format!(
                "truncated binary_compressed data: compressed size {comp} but only {} bytes follow",
                after - 8
            ),
        ));
    }
    if raw > comp.saturating_mul(LZF_MAX_RATIO) + 16 {
        return Err(Error::format(
            path,
            format!(
                "binary_compressed sizes are inconsistent: {comp} compressed bytes cannot hold {raw} bytes"
            ),
        ));
    }
    Ok((comp, raw))
}
