//! Checkpoints out (issue 35, item 4) from the CLI: what `--checkpoints`
//! refuses costs nothing (before the run, nothing written), and `errors`
//! writes the same file as `eval` from the same positions.

use crate::util::{bin, stderr, tempdir};

fn run(args: &[&str]) -> std::process::Output {
    bin().args(args).output().expect("mapgauge")
}

#[test]
fn refusals_come_before_the_work_and_write_nothing() {
    let dir = tempdir();
    let d = dir.path().to_str().expect("utf-8");
    let survey = format!("{d}/survey.csv");
    std::fs::write(&survey, "id,x,y\n1,0,0\n2,30,0\n3,0,40\n").expect("survey");
    // The map does not exist: a refusal must come before reading it.
    let map = format!("{d}/no-map.pcd");
    let gj = format!("{d}/cp.geojson");
    let o = run(&[
        "eval",
        "--map",
        &map,
        "--survey",
        &survey,
        "--checkpoints",
        &gj,
    ]);
    // Refused by mapgauge: could not evaluate (4); by the flags' parser: usage (2).
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(stderr(&o).contains("RFC 7946"), "{}", stderr(&o));
    let shp = format!("{d}/cp.shp");
    let o = run(&[
        "eval",
        "--map",
        &map,
        "--survey",
        &survey,
        "--checkpoints",
        &shp,
    ]);
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(".gpkg, .geojson or .csv"),
        "{}",
        stderr(&o)
    );
    // The survey itself, as a CSV of checkpoints: refused, kept.
    let o = run(&[
        "eval",
        "--map",
        &map,
        "--survey",
        &survey,
        "--checkpoints",
        &survey,
    ]);
    assert_ne!(o.status.code(), Some(0));
    assert!(
        stderr(&o).contains("refusing to overwrite"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        std::fs::read_to_string(&survey).expect("kept"),
        "id,x,y\n1,0,0\n2,30,0\n3,0,40\n"
    );
    // Over a file --out writes: refused.
    let out = format!("{d}/out");
    let o = run(&[
        "eval",
        "--map",
        &map,
        "--survey",
        &survey,
        "--out",
        &out,
        "--checkpoints",
        &format!("{out}/targets.csv"),
    ]);
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("another output of this run"),
        "{}",
        stderr(&o)
    );
    // A CRS without a file to write it in is a usage error.
    let o = run(&[
        "eval",
        "--map",
        &map,
        "--survey",
        &survey,
        "--checkpoints-crs",
        "EPSG:32633",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = run(&[
        "eval",
        "--map",
        &map,
        "--survey",
        &survey,
        "--checkpoints",
        &format!("{d}/cp.gpkg"),
        "--checkpoints-crs",
        "UTM33",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("not an EPSG code"), "{}", stderr(&o));
    let left: Vec<_> = std::fs::read_dir(d)
        .expect("dir")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(left, ["survey.csv"], "something was written");
}

#[test]
fn errors_writes_the_checkpoints_of_the_positions_it_scores() {
    let dir = tempdir();
    let d = dir.path().to_str().expect("utf-8");
    let survey = format!("{d}/survey.csv");
    std::fs::write(
        &survey,
        "id,x,y,z\na,0,0,1\nb,30,0,1\nc,0,40,1\nd,30,40,1\n",
    )
    .expect("survey");
    // The map turned by 90° and shifted; d not found.
    let est = format!("{d}/est.csv");
    std::fs::write(
        &est,
        "id,x,y,z,status\na,5.003,7,1,ok\nb,5,37.002,1,ok\nc,-34.998,7,1,ok\nd,,,,not_found\n",
    )
    .expect("estimates");
    let csv = format!("{d}/cp.csv");
    let o = run(&[
        "errors",
        "--survey",
        &survey,
        "--estimates",
        &est,
        "--checkpoints",
        &csv,
        "--checkpoints-crs",
        "EPSG:25832",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).expect("checkpoints");
    let rows: Vec<Vec<&str>> = text.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 5, "{text}");
    assert_eq!(
        rows[0][..8],
        [
            "id",
            "role",
            "status",
            "reason",
            "crs",
            "surveyed_x",
            "surveyed_y",
            "surveyed_z"
        ]
    );
    assert_eq!(rows[1][4], "EPSG:25832");
    assert_eq!((rows[1][5], rows[1][6]), ("0.000000", "0.000000"));
    assert_eq!(rows[4][2], "not_found");
    // A 2D fit leaves the map's z as it is: no measured height, no dz.
    assert_eq!((rows[1][10], rows[1][13]), ("", ""), "{text}");
    // The located ones are within a few mm of their surveyed points.
    for r in &rows[1..4] {
        let dx: f64 = r[11].parse().expect("dx");
        let dy: f64 = r[12].parse().expect("dy");
        assert!(dx.hypot(dy) < 0.01, "{r:?}");
    }
}
