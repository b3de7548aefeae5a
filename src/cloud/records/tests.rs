use super::*;

fn lcg(s: &mut u64) -> u64 {
    *s = s
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    *s >> 11
}

/// Float x, y, z at `offs` in `stride`-byte records.
fn f32_layout(stride: usize, offs: [usize; 3]) -> Layout {
    Layout {
        start: 0,
        stride,
        count: 0,
        coords: offs.map(|offset| Coord {
            kind: Scalar::F32,
            offset,
        }),
        big_endian: false,
        transform: None,
        intensity: None,
    }
}

/// What [`decode`] must return, one record at a time through
/// `Scalar::read_at`.
fn naive(lay: &Layout, bytes: &[u8], keep: impl Fn(f64, f64) -> bool) -> (Vec<Point>, usize) {
    let mut kept = Vec::new();
    let mut finite = 0;
    for r in bytes.chunks_exact(lay.stride) {
        let v = lay.coords.map(|c| c.kind.read_at(r, c.offset, false));
        if v.iter().all(|c| c.is_finite()) {
            finite += 1;
            if keep(v[0], v[1]) {
                kept.push(Point::new(v[0], v[1], v[2]));
            }
        }
    }
    (kept, finite)
}

/// `n` records: coordinates in ±60 m, every other byte junk that is not
/// finite as a float (packed `rgb` with alpha 255, NaN or infinite
/// intensity, `_` padding of 0xff); with `dirty`, some coordinates NaN or
/// infinite.
fn records(lay: &Layout, n: usize, dirty: bool, seed: u64) -> Vec<u8> {
    let mut s = seed;
    let mut bytes = vec![0u8; n * lay.stride];
    for (i, r) in bytes.chunks_exact_mut(lay.stride).enumerate() {
        for (k, w) in r.chunks_exact_mut(4).enumerate() {
            let junk: u32 = match (i + k) % 3 {
                0 => 0xff00_0000 | (lcg(&mut s) as u32 & 0xff_ffff),
                1 => f32::NAN.to_bits(),
                _ => f32::INFINITY.to_bits(),
            };
            w.copy_from_slice(&junk.to_le_bytes());
        }
        for c in lay.coords {
            let v = (lcg(&mut s) % 120_000) as f32 / 1000.0 - 60.0;
            r[c.offset..c.offset + 4].copy_from_slice(&v.to_le_bytes());
        }
        if dirty && i % 97 == 13 {
            let c = lay.coords[i % 3];
            let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][i % 3];
            r[c.offset..c.offset + 4].copy_from_slice(&bad.to_le_bytes());
        }
    }
    bytes
}

#[test]
fn float_records_decode_like_a_record_at_a_time_reader() {
    let reg = Region::discs(&[[10.0, -5.0], [-30.0, 20.0], [50.0, 55.0]], 8.0).unwrap();
    // The strides with loops of their own (12, 16, 32), others with x, y,
    // z first, and x, y, z elsewhere or out of order.
    let layouts = [
        f32_layout(12, [0, 4, 8]),
        f32_layout(16, [0, 4, 8]),
        f32_layout(32, [0, 4, 8]),
        f32_layout(20, [0, 4, 8]),
        f32_layout(48, [0, 4, 8]),
        f32_layout(16, [4, 8, 12]),
        f32_layout(24, [8, 0, 16]),
    ];
    for lay in &layouts {
        for dirty in [false, true] {
            let n = 3000;
            let bytes = records(lay, n, dirty, lay.stride as u64);
            let mut out = vec![Point::origin(); n];
            for region in [None, Some(&reg)] {
                let keep = |x: f64, y: f64| region.is_none_or(|r| r.contains(x, y));
                let (want, want_finite) = naive(lay, &bytes, keep);
                let (k, finite) = decode(lay, &bytes, &mut out, keep);
                let tag = format!("stride {} {:?} dirty {dirty}", lay.stride, lay.coords);
                assert_eq!(finite, want_finite, "{tag}");
                assert_eq!(&out[..k], &want[..], "{tag}");
                if dirty {
                    assert!(finite < n, "{tag}");
                } else {
                    assert_eq!(finite, n, "{tag}");
                }
                if region.is_some() {
                    assert!(k > 0 && k < n / 4, "{tag}: {k} kept");
                }
            }
        }
    }
}

#[test]
fn front_scan_sees_a_bad_coordinate_anywhere() {
    // One non-finite coordinate in an otherwise finite buffer, at every
    // record and coordinate of a short buffer: the scan must see it, and
    // never take a non-finite non-coordinate field for one.
    for stride in [12usize, 16, 32] {
        let lay = f32_layout(stride, [0, 4, 8]);
        let clean = records(&lay, 37, false, 5);
        assert!(
            if stride == 12 {
                f32_front_finite::<12>(&clean)
            } else if stride == 16 {
                f32_front_finite::<16>(&clean)
            } else {
                f32_front_finite::<32>(&clean)
            },
            "stride {stride}"
        );
        for i in 0..37 {
            for c in 0..3 {
                let mut b = clean.clone();
                let o = i * stride + 4 * c;
                b[o..o + 4].copy_from_slice(&f32::NAN.to_le_bytes());
                let ok = match stride {
                    12 => f32_front_finite::<12>(&b),
                    16 => f32_front_finite::<16>(&b),
                    _ => f32_front_finite::<32>(&b),
                };
                assert!(!ok, "stride {stride} record {i} coordinate {c}");
            }
        }
    }
}
