//! LAS/LAZ written by the `las` crate read back to the millimetre; the writer
//! round-trips and never leaves a partial file; the declared CRS. COPC,
//! hostile files and coordinate-only LAZ 1.4 have their own files; the
//! helpers here serve them all.

use super::*;
use crate::cloud::ReadStats;

mod copc;
mod hostile;
mod intensity;
mod laz14;

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

/// Millimetre scale, offsets of a UTM-sized site.
fn utm_mm() -> las::Vector<las::Transform> {
    let tr = |o| las::Transform {
        scale: 0.001,
        offset: o,
    };
    las::Vector {
        x: tr(350000.0),
        y: tr(4150000.0),
        z: tr(0.0),
    }
}

/// Writes `pts` with the las crate itself in point format `fmt`.
fn write_with_crate(path: &Path, fmt: u8, version: (u8, u8), pts: &[Point]) {
    let mut b = las::Builder::from(version);
    b.point_format = las::point::Format::new(fmt).unwrap();
    b.transforms = utm_mm();
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

/// Issue 31: LAS 1.3 with its waveform data packets inside the file, after
/// the points (`start_of_waveform_data_packet_record`): the point data ends
/// there. It was refused as holding more points than declared.
#[test]
fn las13_internal_waveform_data_ends_the_points() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("w.las");
    let pts = truth(100);
    write_with_crate(&path, 1, (1, 3), &pts);
    let mut bytes = std::fs::read(&path).unwrap();
    let end = bytes.len() as u64;
    // Global encoding bit 1: waveform data packets internal; their start at
    // byte 227 of a 1.3 header; then a 60-byte record header and 40 bytes of
    // samples (two records' worth of format 1 points and more).
    bytes[6] |= 0b10;
    bytes[227..235].copy_from_slice(&end.to_le_bytes());
    bytes.extend_from_slice(&[0u8; 100]);
    std::fs::write(&path, &bytes).unwrap();
    let (got, stats, _) = read(&path).unwrap();
    assert_eq!(stats.points, 100);
    assert_mm(&got, &pts);
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

/// The names of the threads the decoder crates (`laz`, `las`) panicked on,
/// recorded by one hook installed once for every test: tests that each took
/// and set the process-wide hook raced (one's hook replaced the other's, and
/// it then saw no panic at all).
fn decoder_panics() -> &'static std::sync::Mutex<Vec<Option<String>>> {
    use std::sync::{Mutex, OnceLock};
    static SEEN: OnceLock<Mutex<Vec<Option<String>>>> = OnceLock::new();
    SEEN.get_or_init(|| {
        // Ours runs first, then the quiet hook (installed now, so it is under ours).
        super::super::producer::quiet_reader_panics();
        let prev = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if info
                .location()
                .is_some_and(|l| l.file().contains("laz-0.") || l.file().contains("las-0."))
            {
                let name = std::thread::current().name().map(str::to_string);
                if let Some(seen) = SEEN.get() {
                    seen.lock().unwrap_or_else(|e| e.into_inner()).push(name);
                }
            }
            prev(info);
        }));
        Mutex::new(Vec::new())
    })
}

fn all(r: &mut dyn PointReader) -> Vec<Point> {
    let mut all = Vec::new();
    let mut buf = Vec::new();
    while r.next_chunk(&mut buf).unwrap() {
        all.extend_from_slice(&buf);
    }
    all
}

fn all_of(path: &Path, copc: bool, chunked: bool) -> Result<(Vec<Point>, ReadStats, u64)> {
    let mut r = open_with(path, copc, chunked)?;
    let mut all = Vec::new();
    let mut buf = Vec::new();
    while r.next_chunk(&mut buf)? {
        all.extend_from_slice(&buf);
    }
    Ok((all, r.stats(), r.bytes_read()))
}

/// A real file's GeoTIFF keys: Autzen is in feet (EPSG:2994, unit 9002).
#[test]
fn a_geotiff_header_names_its_length_unit() {
    let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real/autzen.las");
    let c = crs_of(&real).unwrap();
    assert_eq!(c.name, "EPSG:2994");
    assert!(!c.degrees);
    assert_eq!(c.horizontal_unit, Some(("foot".to_string(), 0.3048)));
    assert_eq!(c.vertical_unit, None);
}

/// A real airborne LAS declares its CRS by GeoTIFF keys (Autzen: EPSG:2994,
/// tests/data/real/README.md); a LAS written without one declares none.
#[test]
fn the_declared_crs_is_read_from_geotiff_keys() {
    let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real/autzen.las");
    assert_eq!(declared_crs(&real).as_deref(), Some("EPSG:2994"));
    assert_eq!(
        crate::cloud::declared_crs(&real).as_deref(),
        Some("EPSG:2994")
    );
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain.las");
    write_with_crate(&plain, 0, (1, 2), &truth(10));
    assert_eq!(declared_crs(&plain), None);
    // A local frame written with a WKT record is no georeference.
    let mut b = las::Builder::from((1, 4));
    b.point_format = las::point::Format::new(0).unwrap();
    for (name, wkt, want) in [
        (
            "local.las",
            &br#"LOCAL_CS["SLAM map",UNIT["metre",1]]"#[..],
            None,
        ),
        (
            "utm.las",
            &br#"PROJCRS["WGS 84 / UTM zone 33N",BASEGEOGCRS["WGS 84"]]"#[..],
            Some("WGS 84 / UTM zone 33N"),
        ),
    ] {
        let mut h = b.clone().into_header().unwrap();
        h.set_wkt_crs(wkt.to_vec()).unwrap();
        let p = dir.path().join(name);
        las::Writer::from_path(&p, h).unwrap().close().unwrap();
        assert_eq!(declared_crs(&p).as_deref(), want, "{name}");
    }
}
