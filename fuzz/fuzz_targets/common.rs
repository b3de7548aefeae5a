//! Shared by the fuzz targets: mapgauge's readers take paths (they map or
//! stream files), so each input is written to one file per process in a RAM
//! file system and read back from there.

#![allow(dead_code)] // each target uses a part

use std::path::PathBuf;

/// Writes `data` to this process's scratch file with extension `ext`.
pub fn scratch(data: &[u8], ext: &str) -> PathBuf {
    let dir = if std::path::Path::new("/dev/shm").is_dir() {
        PathBuf::from("/dev/shm")
    } else {
        std::env::temp_dir()
    };
    let path = dir.join(format!("mapgauge-fuzz-{}.{ext}", std::process::id()));
    std::fs::write(&path, data).expect("cannot write the scratch file");
    path
}

/// Opens `data` as a map of `format` and reads every point; errors are fine,
/// panics and unbounded allocations are the bugs being looked for.
pub fn read_map(data: &[u8], ext: &str, format: mapgauge::cloud::Format) {
    let path = scratch(data, ext);
    if let Ok(mut r) = mapgauge::cloud::open_as(&path, format) {
        let mut buf = Vec::new();
        let mut n = 0u64;
        while let Ok(true) = r.next_chunk(&mut buf) {
            n += buf.len() as u64;
            assert!(
                buf.iter()
                    .all(|p| p.x.is_finite() && p.y.is_finite() && p.z.is_finite())
            );
        }
        assert!(n <= r.stats().points);
    }
    // `convert`'s path: one intensity per point.
    if let Ok(mut r) = mapgauge::cloud::open_as(&path, format) {
        let (mut buf, mut inten) = (Vec::new(), Vec::new());
        let with = r.has_intensity();
        while let Ok(true) = r.next_chunk_intensity(&mut buf, &mut inten) {
            assert_eq!(inten.len(), if with { buf.len() } else { 0 });
        }
    }
    // The loose crop's path: pieces filtered by a region around the origin.
    if let Ok(mut r) = mapgauge::cloud::open_as(&path, format) {
        let reg = mapgauge::cloud::Region::discs(&[[0.0, 0.0], [1.0, -2.0]], 5.0)
            .expect("a valid region");
        let mut buf = Vec::new();
        let mut scratch = mapgauge::cloud::Scratch::default();
        while let Ok(Some(b)) = r.next_batch(&mut buf) {
            let mut failed = false;
            for i in 0..b.pieces() {
                match b.piece_within(i, &mut scratch, &reg) {
                    Ok(p) => assert!(
                        p.iter()
                            .all(|p| p.x.is_finite() && p.y.is_finite() && p.z.is_finite())
                    ),
                    Err(_) => failed = true,
                }
            }
            if failed {
                break;
            }
        }
    }
    let _ = mapgauge::cloud::detect(&path);
}
