//! Fuzzes the Autoware tiled-map readers: the metadata YAML
//! (`x_resolution`, `y_resolution`, `<file>.pcd: [min_x, min_y]`) and
//! `map_projector_info.yaml`. Whatever they accept must be usable: positive
//! finite cell sizes, finite corners, and a projection that places a point
//! near its origin at finite coordinates.
#![no_main]

mod common;

use mapgauge::cloud::read_metadata;
use mapgauge::survey::{Geodetic, Projector};

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let path = common::scratch(data, "yaml");
    if let Ok((res, tiles)) = read_metadata(&path) {
        assert!(res.iter().all(|r| r.is_finite() && *r > 0.0));
        assert!(!tiles.is_empty());
        for (name, min) in &tiles {
            assert!(name.to_ascii_lowercase().ends_with(".pcd"));
            assert!(min.iter().all(|v| v.is_finite()));
        }
    }
    for heights in [false, true] {
        if let Ok(p) = Projector::read(&path, heights) {
            let o = match &p {
                Projector::LocalCartesianUtm { origin }
                | Projector::LocalCartesian { origin }
                | Projector::TransverseMercator { origin } => *origin,
                Projector::Mgrs { .. } => Geodetic {
                    lat: 35.0,
                    lon: 139.0,
                    alt: 0.0,
                },
            };
            let q = p.forward(&o);
            assert!(q.iter().all(|v| v.is_finite()), "{p:?} {q}");
            let _ = p.describe();
        }
    }
});
