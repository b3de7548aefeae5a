//! E57 reader, on the `e57` crate.
//!
//! Every point cloud (scan) in the file is read in turn with the crate's simple
//! iterator: spherical coordinates are converted to cartesian and each scan's
//! pose is applied, so all scans come out in the file's common frame. Points
//! without a valid cartesian position (direction-only or invalid) and
//! non-finite points are skipped and counted. The crate's iterator borrows its
//! reader, so it runs on a background thread (see `producer.rs`).

use super::producer::{Msg, Producer};
use super::{CloudInfo, Format, PointReader};
use crate::{Error, Point, Result};
use std::path::Path;

/// Points per block.
const CHUNK: usize = 1 << 18;

/// Opens a E57 file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    let file_bytes = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    let p = path.to_path_buf();
    let producer = Producer::spawn(path, move |tx| {
        let err = |e: e57::Error| Msg::Err(Error::format(&p, format!("E57: {e}")));
        let mut reader = match e57::E57Reader::from_file(&p) {
            Ok(r) => r,
            Err(e) => {
                tx.send(err(e));
                return;
            }
        };
        let clouds = reader.pointclouds();
        let total: u64 = clouds.iter().map(|c| c.records).sum();
        // Intensity when every scan has it (raw values: each scan's own
        // scale, as its sensor gave it).
        let intensity = !clouds.is_empty() && clouds.iter().all(|c| c.has_intensity());
        if !tx.send(Msg::Info(
            CloudInfo {
                format: Format::E57,
                declared_points: Some(total),
                file_bytes,
            },
            intensity,
        )) {
            return;
        }
        let mut done = 0u64;
        let mut skipped = 0u64;
        for pc in &clouds {
            let mut it = match reader.pointcloud_simple(pc) {
                Ok(it) => it,
                Err(e) => {
                    tx.send(err(e));
                    return;
                }
            };
            it.spherical_to_cartesian(true);
            it.apply_pose(true);
            it.intensity_to_color(false);
            it.normalize_color(false);
            it.normalize_intensity(false);
            let mut out = tx.buffer();
            let mut inten = Vec::new();
            for q in it.by_ref() {
                let q = match q {
                    Ok(q) => q,
                    Err(e) => {
                        tx.send(err(e));
                        return;
                    }
                };
                done += 1;
                match q.cartesian {
                    e57::CartesianCoordinate::Valid { x, y, z }
                        if x.is_finite() && y.is_finite() && z.is_finite() =>
                    {
                        out.push(Point::new(x, y, z));
                        if intensity {
                            // A point without one says nothing of a print.
                            inten.push(q.intensity.unwrap_or(f32::NAN));
                        }
                    }
                    _ => skipped += 1,
                }
                if out.len() == CHUNK {
                    let bytes = file_bytes.saturating_mul(done) / total.max(1);
                    let iv = std::mem::take(&mut inten);
                    if !tx.send(Msg::Chunk(std::mem::take(&mut out), iv, skipped, bytes)) {
                        return;
                    }
                    skipped = 0;
                    out = tx.buffer();
                }
            }
            if !out.is_empty() {
                let bytes = file_bytes.saturating_mul(done) / total.max(1);
                if !tx.send(Msg::Chunk(out, inten, skipped, bytes)) {
                    return;
                }
                skipped = 0;
            }
        }
        tx.send(Msg::Done(skipped));
    })?;
    Ok(Box::new(producer))
}

#[cfg(test)]
mod tests {
    use super::*;
    use e57::{Quaternion, Record, RecordValue, Transform, Translation};

    fn read(path: &Path) -> Result<(Vec<Point>, super::super::ReadStats)> {
        let mut r = super::super::open(path)?;
        assert_eq!(r.info().format, Format::E57);
        let mut all = Vec::new();
        let mut buf = Vec::new();
        while r.next_chunk(&mut buf)? {
            all.extend_from_slice(&buf);
        }
        Ok((all, r.stats()))
    }

    #[test]
    fn two_scans_cartesian_and_spherical_with_poses() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scan.e57");
        {
            let mut w = e57::E57Writer::from_file(&path, "guid-file").unwrap();
            // Scan 1: cartesian with an invalid-state column, translated pose. (The
            // crate fails to read a 3-point scan with a bit-packed column, so 13.)
            let proto = vec![
                Record::CARTESIAN_X_F64,
                Record::CARTESIAN_Y_F64,
                Record::CARTESIAN_Z_F64,
                Record::CARTESIAN_INVALID_STATE,
            ];
            let mut pc = w.add_pointcloud("guid-1", proto).unwrap();
            pc.set_transform(Some(Transform {
                rotation: Quaternion {
                    w: 1.0,
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                },
                translation: Translation {
                    x: 350000.0,
                    y: 4150000.0,
                    z: 10.0,
                },
            }));
            for (x, y, z, inv) in [(1.0, 2.0, 3.0, 0), (9.0, 9.0, 9.0, 2), (4.0, 5.0, 6.0, 0)]
                .into_iter()
                .chain(std::iter::repeat_n((7.0, 7.0, 7.0, 0), 10))
            {
                pc.add_point(vec![
                    RecordValue::Double(x),
                    RecordValue::Double(y),
                    RecordValue::Double(z),
                    RecordValue::Integer(inv),
                ])
                .unwrap();
            }
            pc.finalize().unwrap();
            // Scan 2: spherical, rotated 90 degrees about z.
            let proto = vec![
                Record::SPHERICAL_RANGE_F64,
                Record::SPHERICAL_AZIMUTH_F64,
                Record::SPHERICAL_ELEVATION_F64,
            ];
            let mut pc = w.add_pointcloud("guid-2", proto).unwrap();
            let h = std::f64::consts::FRAC_1_SQRT_2;
            pc.set_transform(Some(Transform {
                rotation: Quaternion {
                    w: h,
                    x: 0.0,
                    y: 0.0,
                    z: h,
                },
                translation: Translation {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                },
            }));
            pc.add_point(vec![
                RecordValue::Double(2.0),
                RecordValue::Double(0.0),
                RecordValue::Double(0.0),
            ])
            .unwrap();
            pc.finalize().unwrap();
            w.finalize().unwrap();
        }
        let (got, st) = read(&path).unwrap();
        assert_eq!(st.skipped_nonfinite, 1);
        assert_eq!(got.len(), 13);
        assert_eq!(got[0], Point::new(350001.0, 4150002.0, 13.0));
        assert_eq!(got[1], Point::new(350004.0, 4150005.0, 16.0));
        // (2, 0, 0) rotated +90 degrees about z is (0, 2, 0).
        assert!(
            (got[12] - Point::new(0.0, 2.0, 0.0)).norm() < 1e-12,
            "{}",
            got[12]
        );
    }

    /// A scan's intensities come with its points, as stored (not
    /// normalised); a file with a scan without them has none to give.
    #[test]
    fn intensity_is_read_when_every_scan_has_it() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, with: bool| {
            let path = dir.path().join(name);
            let mut w = e57::E57Writer::from_file(&path, "guid-file").unwrap();
            let mut proto = vec![
                Record::CARTESIAN_X_F64,
                Record::CARTESIAN_Y_F64,
                Record::CARTESIAN_Z_F64,
            ];
            if with {
                proto.push(Record::INTENSITY_U16);
            }
            let mut pc = w.add_pointcloud("guid-1", proto).unwrap();
            for i in 0..40 {
                let mut v = vec![
                    RecordValue::Double(i as f64),
                    RecordValue::Double(2.0 * i as f64),
                    RecordValue::Double(1.0),
                ];
                if with {
                    v.push(RecordValue::Integer(1000 + 37 * i));
                }
                pc.add_point(v).unwrap();
            }
            pc.finalize().unwrap();
            w.finalize().unwrap();
            path
        };
        let read_i = |path: &Path| {
            let (_, inten, has) = crate::cloud::read_with_intensity(path);
            (has, inten)
        };
        let (has, inten) = read_i(&write("i.e57", true));
        assert!(has);
        let want: Vec<f32> = (0..40).map(|i| (1000 + 37 * i) as f32).collect();
        assert_eq!(inten, want);
        let (has, inten) = read_i(&write("plain.e57", false));
        assert!(!has && inten.is_empty());
    }

    #[test]
    fn corrupt_file_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.e57");
        std::fs::write(&path, b"ASTM-E57 this is not really an e57 file at all").unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(e.contains("bad.e57") && e.contains("E57"), "{e}");
    }
}
