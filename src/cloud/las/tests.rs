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

/// laz 0.13 indexes out of bounds on this chunk table inside its rayon
/// workers: the panic must happen on reader-named threads (whose panics the
/// quiet hook keeps from a hook that aborts, libFuzzer's: the `las` fuzz
/// target depends on it) and come back as the file's error.
#[test]
fn laz_decoder_panic_stays_on_reader_threads() {
    let seen = decoder_panics();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.las");
    std::fs::write(
        &path,
        include_bytes!("../../../fuzz/upstream/laz-decoders-index-out-of-bounds.las"),
    )
    .unwrap();
    let e = read(&path).unwrap_err().to_string();
    assert!(e.contains("the decoder failed on malformed data"), "{e}");
    let seen = seen.lock().unwrap_or_else(|e| e.into_inner()).clone();
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

/// [`COPC`] in a temporary directory (kept while the first is alive).
fn copc_file() -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.copc.laz");
    std::fs::write(&path, COPC).unwrap();
    (dir, path)
}

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
    let (_dir, path) = copc_file();
    let mut copc = super::open(&path).unwrap();
    let mut plain = open_with(&path, false, true).unwrap();
    assert!(plain.tile_stats().is_none(), "the plain path reads chunks");
    let (a, b) = (all(copc.as_mut()), all(plain.as_mut()));
    assert_eq!(a.len(), 20_000);
    assert_eq!(a, b, "same points in the same order");
    assert_eq!(copc.stats(), plain.stats());
    // Variable-size chunks: coordinate-only decoding equals the crate's.
    let (c, sc, _) = all_of(&path, false, false).unwrap();
    assert!(c == a && sc == copc.stats());
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
    let (_dir, path) = copc_file();
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
            by_level: false,
        };
        let mut copc = super::open(&path).unwrap();
        let mut plain = open_with(&path, false, true).unwrap();
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

/// A crop that keeps `max_points` reads near each centre only the levels
/// that hold more than that there: fewer nodes, a subset of the full crop's
/// points, each crop still more than it keeps (so thinned either way).
#[test]
fn copc_crop_by_level_reads_the_coarse_levels_it_needs() {
    use crate::crop::{LooseParams, Shape, loose_crop, loose_crop_by_level};
    let (_dir, path) = copc_file();
    let centres = [
        Point::new(350_100.5, 4_150_100.5, 10.0),
        Point::new(350_312.2, 4_150_250.7, 5.0),
    ];
    let params = LooseParams {
        radius: 60.0,
        shape: Shape::Cylinder,
        max_points: 60,
        by_level: false,
    };
    let mut every = super::open(&path).unwrap();
    let full = loose_crop(every.as_mut(), &centres, &params, |_| ()).unwrap();
    assert!(full.levels_cut.is_empty());
    let mut copc = super::open(&path).unwrap();
    let by_level = loose_crop_by_level(copc.as_mut(), &centres, &params, |_| ()).unwrap();
    let (a, b) = (copc.tile_stats().unwrap(), every.tile_stats().unwrap());
    assert!(
        by_level.levels_cut == [true, true] && a.opened < b.opened,
        "{a:?} against {b:?}"
    );
    assert!(a.bytes_opened < b.bytes_opened);
    for i in 0..centres.len() {
        assert!(
            full.offered[i] > 3 * by_level.offered[i],
            "{:?} {:?}",
            full.offered,
            by_level.offered
        );
        assert!(by_level.offered[i] > 60, "{:?}", by_level.offered);
    }
    // Uncapped, every level is read.
    let mut copc = super::open(&path).unwrap();
    let params = LooseParams {
        max_points: 0,
        ..params
    };
    let all = loose_crop_by_level(copc.as_mut(), &centres, &params, |_| ()).unwrap();
    assert!(all.levels_cut.is_empty());
    assert_eq!(all.offered, full.offered);
}

#[test]
fn copc_hint_after_reading_or_invalid_is_ignored() {
    let (_dir, path) = copc_file();
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
    let e = open_with(&path, false, true).err().unwrap().to_string();
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
    // Every chunk of a batch is decoded (the lying one refused before it
    // allocates); the first bad one in file order names the error, the same
    // one on every run (it once depended on which thread failed first).
    for copc in [true, false] {
        let err = || {
            open_with(&path, copc, true)
                .and_then(|mut r| {
                    let mut buf = Vec::new();
                    while r.next_chunk(&mut buf)? {}
                    Ok(())
                })
                .unwrap_err()
                .to_string()
        };
        let e = err();
        assert!(
            e.contains("declared in a chunk of") || e.contains("failed to fill whole buffer"),
            "{copc}: {e}"
        );
        for _ in 0..4 {
            assert_eq!(err(), e, "{copc}");
        }
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

/// Writes a LAS 1.4 LAZ file of point format `fmt` (with `extra` extra
/// bytes) of `n` points whose every field varies: returns, scanner channels,
/// classification and flags, intensity, scan angle, GPS time, colour, NIR.
fn write_rich_laz(path: &Path, fmt: u8, extra: u16, n: usize, seed: u64) {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut b = las::Builder::from((1, 4));
    b.point_format = las::point::Format::new(fmt).unwrap();
    b.point_format.extra_bytes = extra;
    b.point_format.is_compressed = true;
    b.transforms = utm_mm();
    let mut w = las::Writer::from_path(path, b.into_header().unwrap()).unwrap();
    let f = *w.header().point_format();
    let mut t = 1.0e8;
    for i in 0..n {
        let returns = rng.random_range(1..=5u8);
        t += rng.random_range(0.0..1e-4);
        let q = las::Point {
            x: 350_000.0 + (i % 5000) as f64 * 0.013 + rng.random_range(0.0..2.0),
            y: 4_150_000.0 + (i / 5000) as f64 * 0.7 + rng.random_range(0.0..2.0),
            z: 12.0 + rng.random_range(-5.0..30.0),
            intensity: rng.random(),
            return_number: rng.random_range(1..=returns),
            number_of_returns: returns,
            scan_direction: if rng.random() {
                las::point::ScanDirection::LeftToRight
            } else {
                las::point::ScanDirection::RightToLeft
            },
            is_edge_of_flight_line: rng.random_bool(0.01),
            classification: las::point::Classification::new(rng.random_range(1..10)).unwrap(),
            is_synthetic: rng.random_bool(0.1),
            is_key_point: rng.random_bool(0.1),
            is_withheld: rng.random_bool(0.05),
            is_overlap: rng.random_bool(0.05),
            scanner_channel: rng.random_range(0..4),
            scan_angle: rng.random_range(-30.0..30.0),
            user_data: rng.random(),
            point_source_id: rng.random_range(0..3),
            gps_time: f.has_gps_time.then_some(t),
            color: f
                .has_color
                .then(|| las::Color::new(rng.random(), rng.random(), rng.random())),
            nir: f.has_nir.then(|| rng.random()),
            extra_bytes: (0..extra).map(|_| rng.random()).collect(),
            ..Default::default()
        };
        w.write_point(q).unwrap();
    }
    w.close().unwrap();
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

/// Coordinate-only decoding gives the points of the `las` crate's full
/// decoding, in the same order, for formats 6, 7, 8 (and extra bytes) of
/// several fixed-size chunks.
#[test]
fn laz14_coordinates_only_equal_the_crate_path() {
    let dir = tempfile::tempdir().unwrap();
    for (fmt, extra) in [(6, 0), (7, 0), (8, 0), (6, 3)] {
        let path = dir.path().join(format!("f{fmt}-{extra}.laz"));
        let n = 123_457;
        write_rich_laz(&path, fmt, extra, n, u64::from(fmt));
        let (a, sa, ba) = all_of(&path, true, true).unwrap();
        let (b, sb, bb) = all_of(&path, true, false).unwrap();
        assert_eq!(open(&path).unwrap().info().format, Format::Laz);
        assert_eq!(a.len(), n, "format {fmt}");
        assert!(a == b, "format {fmt}: the paths differ");
        assert_eq!((sa, ba), (sb, bb));
        // The chunked reader itself takes these files.
        let file = File::open(&path).unwrap();
        let len = file.metadata().unwrap().len();
        let mut c = chunked::open_plain(&path, &file, len)
            .unwrap()
            .expect("formats 6-10 are read chunk by chunk");
        assert!(all(&mut c) == b, "format {fmt}");
        assert_eq!(c.bytes_read(), len);
    }
    // Formats 0-5 are not.
    let path = dir.path().join("f3.laz");
    write_with_crate(&path, 3, (1, 2), &truth(1000));
    let file = File::open(&path).unwrap();
    assert!(chunked::open_plain(&path, &file, 1).unwrap().is_none());
}

/// Points made non-finite by a huge scale are skipped and counted alike.
#[test]
fn laz14_nonfinite_points_skipped_as_by_the_crate_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("inf.laz");
    write_rich_laz(&path, 7, 0, 60_000, 9);
    let mut bytes = std::fs::read(&path).unwrap();
    // The X scale factor (LAS header byte 131): X * 1e305 overflows for |X| > 1797.
    bytes[131..139].copy_from_slice(&1e305_f64.to_le_bytes());
    bytes[155..163].copy_from_slice(&0.0_f64.to_le_bytes());
    std::fs::write(&path, &bytes).unwrap();
    let (a, sa, _) = all_of(&path, true, true).unwrap();
    let (b, sb, _) = all_of(&path, true, false).unwrap();
    assert!(a == b && sa == sb);
    assert!(sa.skipped_nonfinite > 1000 && sa.points > 0, "{sa:?}");
    assert_eq!(sa.points + sa.skipped_nonfinite, 60_000);
}

/// Every LAS/LAZ input of the fuzz corpus and the hostile-input corpus gives
/// points or an error on both LAZ paths, and a panic inside a decoder only
/// ever happens on reader-named threads (which libFuzzer's hook cannot see).
#[test]
fn fuzz_corpus_gives_errors_not_panics() {
    let seen_all = decoder_panics();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for d in ["fuzz/corpus/las", "fuzz/upstream", "tests/corpus"] {
        for e in std::fs::read_dir(root.join(d)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "las" || x == "laz") {
                files.push(p);
            }
        }
    }
    assert!(files.len() >= 12, "{files:?}");
    let (mut ok, mut failed) = (0, 0);
    for p in &files {
        for (copc, chunked) in [(true, true), (false, true), (false, false)] {
            match all_of(p, copc, chunked) {
                Ok(_) => ok += 1,
                Err(e) => {
                    failed += 1;
                    assert!(!e.to_string().contains('\n'), "{e}");
                }
            }
        }
    }
    assert!(ok > 0 && failed > 0, "{ok} {failed}");
    let seen = seen_all.lock().unwrap_or_else(|e| e.into_inner()).clone();
    let reader = Some(super::super::producer::READER_THREAD.to_string());
    assert!(seen.iter().all(|n| *n == reader), "{seen:?}");
}

/// A header that declares fewer points than the chunks hold is read to its
/// count as by the crate; one that declares more is an error.
#[test]
fn laz14_header_count_caps_or_refuses() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("n.laz");
    write_rich_laz(&path, 6, 0, 70_000, 3);
    let good = std::fs::read(&path).unwrap();
    let with_count = |n: u64| {
        let mut b = good.clone();
        // LAS 1.4's 64-bit point count (header byte 247), and the legacy one
        // (byte 107), which the las crate writes too.
        b[247..255].copy_from_slice(&n.to_le_bytes());
        b[107..111].copy_from_slice(&(n as u32).to_le_bytes());
        std::fs::write(&path, &b).unwrap();
    };
    with_count(60_001);
    let (a, sa, _) = all_of(&path, true, true).unwrap();
    let (b, sb, _) = all_of(&path, true, false).unwrap();
    assert_eq!((a.len(), b.len()), (60_001, 60_001));
    assert!(a == b && sa == sb);
    // A fixed-size table's last chunk may hold up to 50 000: its own count
    // (in its head) tells.
    with_count(70_001);
    let e = all_of(&path, true, true).unwrap_err().to_string();
    assert!(
        e.contains("n.laz")
            && e.contains("reading points 50000.. of 70001")
            && e.contains("says 20001 points, the chunk's data 20000"),
        "{e}"
    );
    with_count(100_001);
    let e = all_of(&path, true, true).unwrap_err().to_string();
    assert!(
        e.contains(
            "reading points 100000.. of 100001: the LAZ chunk table holds only 100000 points"
        ),
        "{e}"
    );
    // The crate path fails too (when reading).
    assert!(all_of(&path, true, false).is_err());
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
    assert_eq!(
        wkt_name("PROJCS[\"WGS 84 / UTM zone 33N\",GEOGCS"),
        "WGS 84 / UTM zone 33N"
    );
    assert_eq!(wkt_name("garbage"), "a WKT coordinate system");
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
