//! binary PCD data: fixed-size little-endian records, handed to the `pread`
//! record reader (`records.rs`) once their count is checked against the file
//! (PCL's own page padding after the points is accepted: see [`pcl_padding`]).

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
    // `need` is Some and at most `after` here (checked above).
    let tail = need.map_or(0, |need| after - need);
    if tail >= header.point_size as u64 {
        let need = after - tail;
        let why = match pcl_padding(&file, header.data_offset as u64, need, tail) {
            Ok(Padding::Pcl) => None,
            Ok(Padding::NotZero) => Some("are not zero, so not PCL's page padding"),
            Ok(Padding::NotPage) => Some(
                "are zeros but not PCL's page padding, which makes the file one 4-64 KiB page longer than the data",
            ),
            Ok(Padding::TooLong) => Some("are more than PCL's largest page padding (64 KiB)"),
            Err(e) => return Err(Error::io(path, e)),
        };
        if let Some(why) = why {
            return Err(Error::format(
                path,
                format!(
                    "header declares POINTS {} but the data holds {} points ({} bytes of {}-byte points follow the header; the {tail} bytes after the declared points {why})",
                    header.points,
                    after / header.point_size as u64,
                    after,
                    header.point_size
                ),
            ));
        }
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
        intensity: intensity_field(&header),
    };
    Ok(Box::new(records::Records::new(file, path, info, lay)?))
}

/// The `intensity` field (exact name first, then any case, then the short
/// `i` some writers use), when it holds one value.
fn intensity_field(header: &Header) -> Option<records::Coord> {
    let f = &header.fields[header.intensity_field()?];
    Some(records::Coord {
        kind: f.kind,
        offset: f.offset,
    })
}

/// PCL's page sizes: 4 KiB (x86-64), 16 KiB (Apple silicon), 64 KiB (some
/// arm64 and ppc64 kernels).
const PAGE_MIN: u64 = 4 << 10;
const PAGE_MAX: u64 = 64 << 10;

/// What the bytes after the declared points are.
#[derive(Debug, PartialEq, Eq)]
enum Padding {
    /// PCL's writer padding: accept.
    Pcl,
    /// Non-zero bytes: they could be points the header does not count.
    NotZero,
    /// Zeros, but not where PCL puts them.
    NotPage,
    /// A page or more: more than PCL ever pads.
    TooLong,
}

/// Tells PCL's padding from points the header does not count.
///
/// PCL's `PCDWriter::writeBinary` for `PCLPointCloud2` (pcl/io/src/pcd_io.cpp,
/// the path of every PCL converter and of ROS `pointcloud_to_pcd`) stretches
/// the file with `lseek(fd, getpagesize() + data_size - 1)` and a one-byte
/// write, then maps and fills only `header + data`: the file is one page plus
/// the data long, and ends with `page - header` zero bytes. Accepted: exactly
/// that layout (header + tail a power-of-two page of 4-64 KiB, all zeros).
fn pcl_padding(file: &File, data_offset: u64, need: u64, tail: u64) -> std::io::Result<Padding> {
    let page = data_offset.saturating_add(tail);
    let zeros_only = |file: &File| -> std::io::Result<bool> {
        let mut buf = vec![0u8; tail.min(PAGE_MAX) as usize];
        records::read_exact_at(file, &mut buf, data_offset + need)?;
        Ok(buf.iter().all(|&b| b == 0))
    };
    if tail >= PAGE_MAX {
        return Ok(Padding::TooLong);
    }
    if !zeros_only(file)? {
        return Ok(Padding::NotZero);
    }
    if page.is_power_of_two() && (PAGE_MIN..=PAGE_MAX).contains(&page) {
        Ok(Padding::Pcl)
    } else {
        Ok(Padding::NotPage)
    }
}
