//! LAS/LAZ written by the `las` crate read back to the millimetre; the writer
//! round-trips and never leaves a partial file.

use super::*;
use crate::cloud::ReadStats;

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

/// laz 0.13 indexes out of bounds on this chunk table inside its rayon
/// workers: the panic must happen on reader-named threads (whose panics the
/// quiet hook keeps from a hook that aborts, libFuzzer's: the `las` fuzz
/// target depends on it) and come back as the file's error.
#[test]
fn laz_decoder_panic_stays_on_reader_threads() {
    use std::sync::Mutex;
    static SEEN: Mutex<Vec<Option<String>>> = Mutex::new(Vec::new());
    // Ours runs first, then the quiet hook (installed now, so it is under ours).
    super::super::producer::quiet_reader_panics();
    let prev = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if info.location().is_some_and(|l| l.file().contains("laz-0.")) {
            let name = std::thread::current().name().map(str::to_string);
            SEEN.lock().unwrap_or_else(|e| e.into_inner()).push(name);
        }
        prev(info);
    }));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.las");
    std::fs::write(
        &path,
        include_bytes!("../../../fuzz/upstream/laz-decoders-index-out-of-bounds.las"),
    )
    .unwrap();
    let e = read(&path).unwrap_err().to_string();
    assert!(e.contains("the decoder failed on malformed data"), "{e}");
    let seen = SEEN.lock().unwrap().clone();
    assert!(
        !seen.is_empty(),
        "the laz crate no longer panics on this file"
    );
    let reader = Some(super::super::producer::READER_THREAD.to_string());
    assert!(seen.iter().all(|n| *n == reader), "{seen:?}");
}

/// A COPC file written by copclib 2.6.3 (`bench/copc_write.py --random 20000
/// 21`, leaves of about 200 points): 20 000 points in 400 m x 400 m x 20 m,
/// 169 nodes on levels 0-3.
const COPC: &[u8] = include_bytes!("../../../tests/corpus/random-20k.copc.laz");

fn all(r: &mut dyn PointReader) -> Vec<Point> {
    let mut all = Vec::new();
    let mut buf = Vec::new();
    while r.next_chunk(&mut buf).unwrap() {
        all.extend_from_slice(&buf);
    }
    all
}

#[test]
fn copc_whole_read_equals_plain_laz() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.copc.laz");
    std::fs::write(&path, COPC).unwrap();
    let mut copc = super::open(&path).unwrap();
    let mut plain = open_with(&path, false).unwrap();
    assert!(plain.tile_stats().is_none(), "the plain path reads chunks");
    let (a, b) = (all(copc.as_mut()), all(plain.as_mut()));
    assert_eq!(a.len(), 20_000);
    assert_eq!(a, b, "same points in the same order");
    assert_eq!(copc.stats(), plain.stats());
    assert_eq!(copc.info().format, Format::Laz);
    assert_eq!(copc.info().declared_points, Some(20_000));
    let t = copc.tile_stats().unwrap();
    assert!(
        t.copc && t.tiles == 169 && t.selected == 169 && t.opened == 169,
        "{t:?}"
    );
    assert_eq!(t.bytes_opened, t.bytes);
    assert!(t.bytes > 0 && t.bytes < COPC.len() as u64);
}

#[test]
fn copc_crop_reads_near_nodes_only_and_equals_plain_laz() {
    use crate::crop::{LooseParams, Shape, loose_crop};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.copc.laz");
    std::fs::write(&path, COPC).unwrap();
    let centres = [
        Point::new(350_100.5, 4_150_100.5, 10.0),
        Point::new(350_312.2, 4_150_250.7, 5.0),
        // On the octree's corner, and off the map.
        Point::new(350_000.0, 4_150_000.0, 0.0),
        Point::new(349_000.0, 4_150_000.0, 0.0),
    ];
    for (radius, shape) in [
        (10.0, Shape::Cylinder),
        (10.0, Shape::Sphere),
        (60.0, Shape::Cylinder),
    ] {
        let params = LooseParams {
            radius,
            shape,
            max_points: 0,
        };
        let mut copc = super::open(&path).unwrap();
        let mut plain = open_with(&path, false).unwrap();
        let a = loose_crop(copc.as_mut(), &centres, &params, |_| ()).unwrap();
        let b = loose_crop(plain.as_mut(), &centres, &params, |_| ()).unwrap();
        assert_eq!(a.points, b.points, "radius {radius} {shape:?}");
        assert_eq!(a.offered, b.offered);
        assert!(a.points[0].len() > 5 && a.points[1].len() > 5 && a.points[3].is_empty());
        let t = copc.tile_stats().unwrap();
        assert!(t.selected < t.tiles && t.opened == t.selected, "{t:?}");
        assert!(t.bytes_opened < t.bytes / 2, "{t:?}");
        // Only the points of the nodes read were decoded.
        assert!(a.map_points < b.map_points && b.map_points == 20_000);
    }
}

#[test]
fn copc_hint_after_reading_or_invalid_is_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.copc.laz");
    std::fs::write(&path, COPC).unwrap();
    let mut r = super::open(&path).unwrap();
    r.hint_discs(&[[f64::NAN, 0.0]], 5.0);
    r.hint_discs(&[[350_100.0, 4_150_100.0]], -1.0);
    let mut buf = Vec::new();
    assert!(r.next_chunk(&mut buf).unwrap());
    r.hint_discs(&[[350_100.0, 4_150_100.0]], 1.0);
    let t = r.tile_stats().unwrap();
    assert_eq!(t.selected, t.tiles);
    let n = buf.len() + all(r.as_mut()).len();
    assert_eq!(n, 20_000);
}

#[test]
fn copc_truncated_or_corrupt_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.copc.laz");
    // Without its hierarchy (the EVLR at the end) it is read as plain LAZ,
    // whose chunk table is gone too.
    std::fs::write(&path, &COPC[..COPC.len() / 2]).unwrap();
    assert!(read(&path).is_err());
    // Node data overwritten: the decoder's error (or caught panic) names the file.
    let mut bad = COPC.to_vec();
    for b in &mut bad[2000..60_000] {
        *b = b.wrapping_mul(31).wrapping_add(7);
    }
    std::fs::write(&path, &bad).unwrap();
    let mut r = super::open(&path).unwrap();
    r.hint_discs(&[[350_100.0, 4_150_100.0]], 100.0);
    let mut buf = Vec::new();
    let mut res = Ok(true);
    while let Ok(true) = res {
        res = r.next_chunk(&mut buf);
    }
    let e = res.unwrap_err().to_string();
    assert!(e.contains("m.copc.laz") && e.contains("COPC node"), "{e}");
    // The plain LAZ path checks every chunk's head when opening.
    let e = open_with(&path, false).err().unwrap().to_string();
    assert!(
        e.contains("layers of") && e.contains("declared in a chunk"),
        "{e}"
    );
}

#[test]
fn lying_layer_sizes_are_refused_before_allocating() {
    // Fuzz find: a COPC node (and its LASzip chunk) declaring layers of
    // gigabytes in 23 KB; the laz crate zero-filled 2 GB before reading.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.copc.laz");
    std::fs::write(
        &path,
        include_bytes!("../../../tests/corpus/fuzz-copc-layer-sizes.copc.laz"),
    )
    .unwrap();
    for copc in [true, false] {
        let e = open_with(&path, copc)
            .and_then(|mut r| {
                let mut buf = Vec::new();
                while r.next_chunk(&mut buf)? {}
                Ok(())
            })
            .unwrap_err()
            .to_string();
        assert!(e.contains("declared in a chunk of"), "{copc}: {e}");
    }
}

#[test]
fn lying_evlr_length_is_refused_before_allocating() {
    // Fuzz find: an extended VLR declaring 8 GB in a 22 KB file; the las
    // crate allocated it before reading.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.laz");
    std::fs::write(
        &path,
        include_bytes!("../../../tests/corpus/fuzz-las-evlr-length.copc.laz"),
    )
    .unwrap();
    let e = read(&path).unwrap_err().to_string();
    assert!(
        e.contains("extended VLR at byte") && e.contains("declares"),
        "{e}"
    );
}
