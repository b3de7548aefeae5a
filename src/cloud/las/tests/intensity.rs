//! Intensity, for checkerboard boards: every LAS/LAZ path gives the values
//! the `las` crate reads, point for point, and the writer keeps them.

use super::*;
use crate::cloud::{CloudWriter, OutFormat};

use crate::cloud::read_with_intensity as with_intensity;

/// The `las` crate's own reading: every point's intensity, in file order.
fn crate_intensities(path: &Path) -> Vec<f32> {
    let mut r = las::Reader::from_path(path).unwrap();
    let data = r.read_all().unwrap();
    data.points()
        .map(|p| f32::from(p.unwrap().intensity))
        .collect()
}

/// LAZ of point formats 6-8 (decoded chunk by chunk, the intensity layer
/// only when asked for) and of format 3 (the crate's path): the same
/// intensities as the crate's full decoding, and the same points as the
/// coordinates-only read.
#[test]
fn laz_intensities_are_the_crates() {
    use rand::{Rng, SeedableRng};
    let dir = tempfile::tempdir().unwrap();
    for fmt in [6u8, 7, 8] {
        let path = dir.path().join(format!("f{fmt}.laz"));
        super::laz14::write_rich_laz(&path, fmt, 0, 80_000, u64::from(fmt) + 40);
        let (pts, inten, has) = with_intensity(&path);
        assert!(has, "format {fmt}");
        assert!(inten == crate_intensities(&path), "format {fmt}");
        assert!(
            inten.iter().any(|&v| v > 1000.0),
            "format {fmt}: varied intensities"
        );
        assert!(pts == read(&path).unwrap().0, "format {fmt}");
    }
    let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
    let path = dir.path().join("f3.laz");
    let mut b = las::Builder::from((1, 2));
    b.point_format = las::point::Format::new(3).unwrap();
    b.point_format.is_compressed = true;
    b.transforms = utm_mm();
    let mut w = las::Writer::from_path(&path, b.into_header().unwrap()).unwrap();
    for p in truth(70_000) {
        w.write_point(las::Point {
            x: p.x,
            y: p.y,
            z: p.z,
            intensity: rng.random(),
            return_number: 1,
            number_of_returns: 1,
            gps_time: Some(0.0),
            color: Some(las::Color::new(1, 2, 3)),
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
    let (pts, inten, has) = with_intensity(&path);
    assert!(has);
    assert!(inten == crate_intensities(&path));
    assert_eq!(pts.len(), 70_000);
}

/// LAS and LAZ written with intensities keep them as whole numbers of 16
/// bits (rounded, clamped; a broken one is 0), and read back so.
#[test]
fn las_and_laz_keep_intensity_written() {
    let dir = tempfile::tempdir().unwrap();
    let pts = truth(1000);
    let given: Vec<f32> = (0..1000)
        .map(|i| match i % 5 {
            0 => i as f32 * 1.3,
            1 => 70_000.0,
            2 => -3.0,
            3 => f32::NAN,
            _ => 12.6,
        })
        .collect();
    let want: Vec<f32> = given
        .iter()
        .map(|&v| {
            if v.is_finite() {
                v.round().clamp(0.0, 65535.0)
            } else {
                0.0
            }
        })
        .collect();
    for format in [OutFormat::Las, OutFormat::Laz] {
        let path = dir.path().join(format!("i.{}", format.extension()));
        let mut w = CloudWriter::create_with(&path, format, true).unwrap();
        w.write_intensity(&pts, &given).unwrap();
        w.finish().unwrap();
        let (back, inten, has) = with_intensity(&path);
        assert!(has);
        assert_eq!(back.len(), pts.len());
        assert!(inten == want, "{format:?}");
    }
}
