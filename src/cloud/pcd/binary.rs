//! binary PCD data: fixed-size little-endian records, handed to the `pread`
//! record reader (`records.rs`) once their count is checked against the file.

use super::header::Header;
use crate::cloud::{CloudInfo, Format, PointReader, records};
use crate::{Error, Result};
use std::fs::File;
use std::path::Path;

/// Opens the binary data of `header` after checking the file holds exactly
/// the declared points.
pub(super) fn open(
    path: &Path,
    file: File,
    file_bytes: u64,
    header: Header,
) -> Result<Box<dyn PointReader>> {
    let after = file_bytes.saturating_sub(header.data_offset as u64);
    let need = header.points.checked_mul(header.point_size as u64);
    if need.is_none_or(|need| need > after) {
        return Err(Error::format(
            path,
            format!(
                "truncated binary data: header declares POINTS {} ({} bytes of {}-byte points) but only {} bytes ({} whole points) follow the header",
                header.points,
                need.map_or("too many".to_string(), |n| n.to_string()),
                header.point_size,
                after,
                after / header.point_size as u64
            ),
        ));
    }
    if need.is_some_and(|need| after - need >= header.point_size as u64) {
        return Err(Error::format(
            path,
            format!(
                "header declares POINTS {} but the data holds {} points ({} bytes of {}-byte points follow the header)",
                header.points,
                after / header.point_size as u64,
                after,
                header.point_size
            ),
        ));
    }
    let f = |i: usize| &header.fields[header.xyz[i]];
    let info = CloudInfo {
        format: Format::Pcd,
        declared_points: Some(header.points),
        file_bytes,
    };
    let lay = records::Layout {
        start: header.data_offset as u64,
        stride: header.point_size,
        count: header.points,
        coords: [0, 1, 2].map(|i| records::Coord {
            kind: f(i).kind,
            offset: f(i).offset,
        }),
        big_endian: false,
        transform: None,
    };
    Ok(Box::new(records::Records::new(file, path, info, lay)?))
}
