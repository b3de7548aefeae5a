//! LAZ of LAS 1.4 point formats 6-10 decoded coordinates only: the same
//! points, skips and counts as the `las` crate's full decoding.

use super::*;

/// Writes a LAS 1.4 LAZ file of point format `fmt` (with `extra` extra
/// bytes) of `n` points whose every field varies: returns, scanner channels,
/// classification and flags, intensity, scan angle, GPS time, colour, NIR.
pub(super) fn write_rich_laz(path: &Path, fmt: u8, extra: u16, n: usize, seed: u64) {
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
