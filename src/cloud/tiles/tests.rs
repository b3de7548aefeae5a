use super::*;
use crate::cloud::{self, OutFormat};
use crate::crop::{LooseParams, loose_crop};

/// `n` points over a 200 m × 120 m area (negative coordinates too), on a
/// 1/64 m grid so every format writes them exactly.
fn scene(n: usize) -> Vec<Point> {
    (0..n)
        .map(|i| {
            let a = i as f64 * 0.618_033_988_75;
            Point::new(
                ((a.fract() * 200.0 - 60.0) * 64.0).round() / 64.0,
                (((a * 0.37).fract() * 120.0 - 30.0) * 64.0).round() / 64.0,
                (i % 17) as f64 * 0.125,
            )
        })
        .collect()
}

/// `pts` as 20 m tiles in `dir/t` and whole (in tile order) in
/// `dir/whole.pcd`.
fn tiled_and_whole(dir: &Path, pts: &[Point]) -> (PathBuf, PathBuf) {
    let tiled = dir.join("t");
    write_tiles(pts, &tiled, 20.0, OutFormat::Pcd).unwrap();
    let whole = dir.join("whole.pcd");
    cloud::write(
        &whole,
        OutFormat::Pcd,
        &TiledMap::order_points(pts, 20.0).unwrap(),
    )
    .unwrap();
    (tiled, whole)
}

fn read(path: &Path) -> (Vec<Point>, Option<TileStats>) {
    let mut r = cloud::open(path).unwrap();
    let mut all = Vec::new();
    let mut buf = Vec::new();
    while r.next_chunk(&mut buf).unwrap() {
        all.extend_from_slice(&buf);
    }
    (all, r.tile_stats())
}

fn err(path: &Path) -> String {
    match cloud::open(path) {
        Err(e) => e.to_string(),
        Ok(mut r) => {
            let mut buf = Vec::new();
            loop {
                match r.next_chunk(&mut buf) {
                    Ok(true) => {}
                    Ok(false) => panic!("{} read without error", path.display()),
                    Err(e) => return e.to_string(),
                }
            }
        }
    }
}

#[test]
fn tiles_read_as_the_whole_map_in_tile_order() {
    let dir = tempfile::tempdir().unwrap();
    let pts = scene(120_000);
    let m = write_tiles(&pts, &dir.path().join("t"), 20.0, OutFormat::Pcd).unwrap();
    // x from -60 to 140, y from -30 to 90 (both ends included after rounding).
    assert_eq!(m.tiles.len(), 11 * 7 - 5, "occupied cells");
    assert_eq!(m.resolution, Some([20.0, 20.0]));
    let want = TiledMap::order_points(&pts, 20.0).unwrap();
    assert_eq!(want.len(), pts.len());
    // The folder, and the metadata file itself.
    for p in [
        dir.path().join("t"),
        dir.path().join("t/pointcloud_map_metadata.yaml"),
    ] {
        let (got, st) = read(&p);
        assert!(got == want, "{}", p.display());
        let st = st.unwrap();
        assert_eq!((st.tiles, st.selected, st.opened), (72, 72, 72));
        assert_eq!(st.bytes, st.bytes_opened);
        assert_eq!(st.bytes, m.bytes());
    }
    // The batch path, as the crop and the whole-map passes read.
    let mut r = cloud::open(&dir.path().join("t")).unwrap();
    let mut buf = Vec::new();
    let mut s = Scratch::default();
    let mut got = Vec::new();
    while let Some(b) = r.next_batch(&mut buf).unwrap() {
        for i in 0..b.pieces() {
            got.extend_from_slice(b.piece(i, &mut s).unwrap());
        }
    }
    assert!(got == want);
    assert_eq!(r.stats().points, pts.len() as u64);
    assert_eq!(r.bytes_read(), r.info().file_bytes);
    assert_eq!(cloud::map_bytes(&dir.path().join("t")), m.bytes());
}

#[test]
fn a_region_hint_opens_only_the_tiles_within_reach() {
    let dir = tempfile::tempdir().unwrap();
    let pts = scene(120_000);
    let (tiled, whole) = tiled_and_whole(dir.path(), &pts);
    // Two targets: one well inside cell (1, 1) = [20, 40) × [20, 40), one on
    // the corner of four cells.
    let centres = [Point::new(30.0, 30.0, 0.0), Point::new(80.0, 40.0, 0.0)];
    let params = LooseParams {
        radius: 5.0,
        ..LooseParams::default()
    };
    let mut r = cloud::open(&tiled).unwrap();
    let a = loose_crop(r.as_mut(), &centres, &params, |_| {}).unwrap();
    let st = r.tile_stats().unwrap();
    assert_eq!((st.tiles, st.selected, st.opened), (72, 5, 5), "{st:?}");
    assert_eq!(r.bytes_read(), st.bytes_opened);
    let mut w = cloud::open(&whole).unwrap();
    let b = loose_crop(w.as_mut(), &centres, &params, |_| {}).unwrap();
    assert!(a.points == b.points);
    assert!(a.points.iter().all(|p| p.len() > 300), "{:?}", a.offered);
    // A radius reaching a cell's edge exactly takes the cell (the four
    // neighbours, not the diagonal ones 14.1 m away).
    let mut r = cloud::open(&tiled).unwrap();
    r.hint_discs(&[[30.0, 30.0]], 10.0);
    assert_eq!(r.tile_stats().unwrap().selected, 5);
    r.hint_discs(&[[30.0, 30.0]], 14.2);
    assert_eq!(
        r.tile_stats().unwrap().selected,
        5,
        "later hints only narrow"
    );
    // A hint after reading began changes nothing.
    let mut r = cloud::open(&tiled).unwrap();
    let mut buf = Vec::new();
    assert!(r.next_chunk(&mut buf).unwrap());
    r.hint_discs(&[[30.0, 30.0]], 1.0);
    assert_eq!(r.tile_stats().unwrap().selected, 72);
    // No metadata: no cells, so every tile is read.
    std::fs::remove_file(tiled.join("pointcloud_map_metadata.yaml")).unwrap();
    let mut r = cloud::open(&tiled).unwrap();
    r.hint_discs(&[[30.0, 30.0]], 1.0);
    assert_eq!(r.tile_stats().unwrap().selected, 72);
}

#[test]
fn a_tilted_maps_hint_is_turned_back_into_the_tiles_frame() {
    use crate::cloud::{MapSource, RigidMotion};
    let dir = tempfile::tempdir().unwrap();
    // Heights over 24 m, so that the tilt moves points sideways by up to
    // 2.5 m along x.
    let pts: Vec<Point> = scene(120_000)
        .into_iter()
        .enumerate()
        .map(|(i, p)| Point::new(p.x, p.y, (i % 97) as f64 * 0.25))
        .collect();
    let (tiled, whole) = tiled_and_whole(dir.path(), &pts);
    let t = 10f64.to_radians();
    let up = nalgebra::Vector3::new(t.sin() * 0.6, t.sin() * 0.8, t.cos());
    let m = RigidMotion::levelling(Point::new(40.0, 30.0, 0.0), &up);
    // Targets where the levelled map has them: one whose crop reaches the
    // next tile (x >= 40) only through the tilt, one on a tile corner.
    let centres = [
        m.apply(&Point::new(34.6, 30.0, 1.0)),
        m.apply(&Point::new(80.0, 40.0, 1.0)),
    ];
    let params = LooseParams {
        radius: 5.0,
        ..LooseParams::default()
    };
    let z = [0.0, 96.0 * 0.25];
    let crop = |map: &Path, z: Option<[f64; 2]>| {
        let mut r = MapSource::File(map).open_moved_within(Some(&m), z).unwrap();
        let c = loose_crop(r.as_mut(), &centres, &params, |_| {}).unwrap();
        (c.points, r.tile_stats())
    };
    let (want, _) = crop(&whole, Some(z));
    assert!(
        want.iter().all(|p| p.len() > 300),
        "{:?}",
        want.iter().map(Vec::len).collect::<Vec<_>>()
    );
    let (got, st) = crop(&tiled, Some(z));
    let st = st.unwrap();
    assert!(
        got == want,
        "the tiles opened hold every point of the crops"
    );
    assert!(st.selected >= 5 && st.selected <= 12, "{st:?}");
    // Without the height range nothing bounds the sideways move: every tile.
    let (all, st) = crop(&tiled, None);
    assert!(all == want);
    assert_eq!(st.unwrap().selected, 72);
    // The discs as the levelled frame has them, handed to the tiles as they
    // are, lose the points the tilt carried over the tile's edge.
    let mut inner = cloud::open(&tiled).unwrap();
    let flat: Vec<[f64; 2]> = centres.iter().map(|c| [c.x, c.y]).collect();
    inner.hint_discs(&flat, params.radius);
    let mut r = crate::cloud::Moved {
        inner,
        motion: m,
        z_range: None,
    };
    let lost = loose_crop(&mut r, &centres, &params, |_| {}).unwrap();
    assert!(
        lost.points[0].len() < want[0].len(),
        "the scene tests the turn"
    );
}

#[test]
fn without_metadata_every_pcd_is_read_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = vec![Point::new(1.0, 2.0, 3.0); 10];
    let b = vec![Point::new(4.0, 5.0, 6.0); 20];
    cloud::write(&d.join("b.pcd"), OutFormat::Pcd, &b).unwrap();
    cloud::write(&d.join("a.PCD"), OutFormat::PcdAscii, &a).unwrap();
    cloud::write(&d.join("c.ply"), OutFormat::Ply, &a).unwrap();
    std::fs::write(d.join("notes.yaml"), "not: metadata\n").unwrap();
    let (got, st) = read(d);
    assert_eq!(got, [a, b].concat());
    assert_eq!(st.unwrap().tiles, 2);
    let empty = tempfile::tempdir().unwrap();
    assert!(
        err(empty.path()).contains("no .pcd files"),
        "{}",
        err(empty.path())
    );
}

#[test]
fn autoware_layout_metadata_beside_the_tile_folder() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("pointcloud_map.pcd")).unwrap();
    let a = vec![Point::new(1.0, 2.0, 3.0); 10];
    let b = vec![Point::new(25.0, 5.0, 6.0); 20];
    cloud::write(&d.join("pointcloud_map.pcd/A.pcd"), OutFormat::Pcd, &a).unwrap();
    cloud::write(&d.join("pointcloud_map.pcd/B.pcd"), OutFormat::Pcd, &b).unwrap();
    std::fs::write(
        d.join("pointcloud_map_metadata.yaml"),
        "x_resolution: 20.0\ny_resolution: 20.0\nB.pcd: [20, 0]\nA.pcd: [0, 0]\n",
    )
    .unwrap();
    std::fs::write(d.join("lanelet2_map.osm"), "<osm/>").unwrap();
    std::fs::write(d.join(PROJECTOR_FILE), "projector_type: Local\n").unwrap();
    let m = TiledMap::discover(d).unwrap();
    assert_eq!(m.files()[0], d.join("pointcloud_map_metadata.yaml"));
    assert_eq!(m.projector, Some(d.join(PROJECTOR_FILE)));
    assert_eq!(m.tiles[0].cell, Some([20.0, 0.0, 40.0, 20.0]));
    assert_eq!(m.tiles[0].line, 3);
    let (got, _) = read(d);
    assert_eq!(got, [b.clone(), a.clone()].concat(), "metadata order");
    // Given the tile folder, the metadata beside it is found.
    let from_tiles = TiledMap::discover(&d.join("pointcloud_map.pcd")).unwrap();
    assert_eq!(
        from_tiles.metadata,
        m.metadata.as_ref().map(|p| p.canonicalize().unwrap())
    );
    assert_eq!(from_tiles.tiles.len(), 2);
    assert!(from_tiles.projector.is_some());
    let (got, _) = read(&d.join("pointcloud_map.pcd"));
    assert_eq!(got, [b.clone(), a.clone()].concat());
    // Not when the metadata lists a tile elsewhere: every .pcd of the folder.
    cloud::write(&d.join("C.pcd"), OutFormat::Pcd, &a).unwrap();
    std::fs::write(
        d.join("pointcloud_map_metadata.yaml"),
        "x_resolution: 20.0\ny_resolution: 20.0\nB.pcd: [20, 0]\nA.pcd: [0, 0]\nC.pcd: [0, 0]\n",
    )
    .unwrap();
    let (got, st) = read(&d.join("pointcloud_map.pcd"));
    assert_eq!(got, [a, b].concat(), "by name");
    assert_eq!(st.unwrap().tiles, 2);
}

#[test]
fn bad_maps_are_refused_naming_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = vec![Point::new(1.0, 2.0, 3.0); 10];
    cloud::write(&d.join("A.pcd"), OutFormat::Pcd, &a).unwrap();
    let meta = d.join("metadata.yaml");
    let case = |yaml: &str| {
        std::fs::write(&meta, yaml).unwrap();
        err(&meta)
    };
    let m = meta.display().to_string();
    let e = case("x_resolution: 20\ny_resolution: 20\nA.pcd: [0, 0]\nB.pcd: [20, 0]\n");
    assert!(
        e.starts_with(&format!("{m}:4: tile B.pcd is missing")),
        "{e}"
    );
    let e = case("x_resolution: 20\ny_resolution: 20\nA.pcd: [0, 0]\nA.pcd: [20, 0]\n");
    assert!(
        e.starts_with(&format!("{m}:4: `A.pcd` is listed twice (lines 3 and 4)")),
        "{e}"
    );
    let e = case("x_resolution: 20\ny_resolution: 20\nA.pcd: [0, 0\n");
    assert!(e.starts_with(&format!("{m}:3: ")), "{e}");
    let e = case("x_resolution: -1\ny_resolution: 20\nA.pcd: [0, 0]\n");
    assert!(
        e.starts_with(&format!("{m}:1: `x_resolution` must be positive")),
        "{e}"
    );
    let e = case("y_resolution: 20\nA.pcd: [0, 0]\n");
    assert!(e.contains("no `x_resolution`"), "{e}");
    let e = case("x_resolution: 20\ny_resolution: 20\nA.pcd: [0, nan]\n");
    assert!(
        e.starts_with(&format!("{m}:3: `A.pcd`: `nan` is not a finite number")),
        "{e}"
    );
    let e = case("x_resolution: 20\ny_resolution: 20\nA.pcd: [0]\n");
    assert!(e.contains("must be `[min_x, min_y]`"), "{e}");
    let e = case("x_resolution: 20\ny_resolution: 20\nfoo: 1\nA.pcd: [0, 0]\n");
    assert!(
        e.starts_with(&format!("{m}:3: unexpected key `foo`")),
        "{e}"
    );
    // A key naming a folder (found by the fuzzer) is no tile.
    let e = case("x_resolution: 20\ny_resolution: 20\nA.pcd/: [0, 0]\n");
    assert!(
        e.starts_with(&format!("{m}:3: unexpected key `A.pcd/`")),
        "{e}"
    );
    // Points outside the declared cell (x = 1 in a cell from 20).
    let e = case("x_resolution: 20\ny_resolution: 20\nA.pcd: [20, 0]\n");
    let a_path = d.join("A.pcd").display().to_string();
    assert!(
        e.starts_with(&format!("{a_path}: point (1, 2) lies outside"))
            && e.contains(&format!("{m}:3")),
        "{e}"
    );
    // A tile that is not a cloud.
    std::fs::write(d.join("A.pcd"), "garbage").unwrap();
    let e = case("x_resolution: 20\ny_resolution: 20\nA.pcd: [0, 0]\n");
    assert!(e.starts_with(&a_path), "{e}");
    // Two metadata files in one folder.
    std::fs::write(d.join("other_metadata.yml"), "x").unwrap();
    let e = err(d);
    assert!(e.contains("several metadata files"), "{e}");
}

#[test]
fn float32_tiles_at_the_cell_edge_are_inside() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 1019.99999 rounds to 1020.0 in float32: on the far edge.
    let pts = vec![
        Point::new(1_019.999_99, 5.0, 0.0),
        Point::new(1000.0, 19.999_999, 0.0),
    ];
    cloud::write(&d.join("A.pcd"), OutFormat::PcdF32, &pts).unwrap();
    std::fs::write(
        d.join("metadata.yaml"),
        "x_resolution: 20\ny_resolution: 20\nA.pcd: [1000, 0]\n",
    )
    .unwrap();
    let (got, _) = read(d);
    assert_eq!(got.len(), 2);
    assert_eq!(got[0].x, 1020.0);
}

#[test]
fn intensity_goes_through_when_every_tile_has_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = vec![Point::new(1.0, 2.0, 3.0); 10];
    let b = vec![Point::new(25.0, 5.0, 6.0); 20];
    let ia: Vec<f32> = (0..10).map(|i| i as f32).collect();
    let ib: Vec<f32> = (0..20).map(|i| 100.0 + i as f32).collect();
    for (name, pts, inten) in [("A.pcd", &a, &ia), ("B.pcd", &b, &ib)] {
        let mut w = cloud::CloudWriter::create(&d.join(name), OutFormat::PcdXyzi).unwrap();
        w.write_intensity(pts, inten).unwrap();
        w.finish().unwrap();
    }
    let read_i = |d: &Path| {
        let mut r = cloud::open(d).unwrap();
        let has = r.has_intensity();
        let (mut buf, mut inten, mut all) = (Vec::new(), Vec::new(), Vec::new());
        while r.next_chunk_intensity(&mut buf, &mut inten).unwrap() {
            assert_eq!(inten.len(), if has { buf.len() } else { 0 });
            all.extend_from_slice(&inten);
        }
        (has, all)
    };
    assert_eq!(read_i(d), (true, [ia.clone(), ib].concat()));
    // One tile without intensity: none is given.
    cloud::write(&d.join("B.pcd"), OutFormat::Pcd, &b).unwrap();
    assert_eq!(read_i(d), (false, Vec::new()));
}
