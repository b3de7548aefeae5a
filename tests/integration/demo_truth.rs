//! `mapgauge demo` against its own truth, held to the limits README.md claims
//! ([`crate::truth::README`]). `.ci/run` runs this on the demo it has just run:
//!
//! ```sh
//! MAPGAUGE_DEMO_DIR=path/to/demo cargo test --release --test integration demo_truth::
//! ```
//!
//! Without `MAPGAUGE_DEMO_DIR` the test runs the demo itself (about 3 s).

use crate::truth::{README, Run};
use crate::util::{bin, stderr, tempdir};
use std::path::PathBuf;
use std::sync::OnceLock;

/// The demo's output directory (holding `scene/` and `eval/`).
fn demo_dir() -> &'static PathBuf {
    static CELL: OnceLock<(Option<tempfile::TempDir>, PathBuf)> = OnceLock::new();
    &CELL
        .get_or_init(|| {
            if let Some(d) = std::env::var_os("MAPGAUGE_DEMO_DIR") {
                return (None, PathBuf::from(d));
            }
            let tmp = tempdir();
            let out = tmp.path().join("demo");
            let o = bin().arg("demo").arg("--out").arg(&out).output().unwrap();
            assert!(o.status.success(), "demo: {}", stderr(&o));
            (Some(tmp), out)
        })
        .1
}

#[test]
fn demo_is_within_the_readme_limits() {
    let d = demo_dir();
    let run = Run::read(
        &d.join("eval").join("result.json"),
        &d.join("scene").join("truth.json"),
    );
    eprintln!("demo {}:\n{}", d.display(), run.describe());
    if let Err(e) = run.check(&README) {
        panic!(
            "the demo misses README.md's claims: {e}\n{}",
            run.describe()
        );
    }
}

/// The check is not vacuous on the demo: one corner 12 mm off, or every corner
/// 10 mm off the same way, fails it.
#[test]
fn demo_check_catches_a_moved_corner() {
    let d = demo_dir();
    let run = Run::read(
        &d.join("eval").join("result.json"),
        &d.join("scene").join("truth.json"),
    );
    let mut one = run.shifted(0.0, 0.0);
    let y = &mut one.result["targets"][2]["map"]["y"];
    *y = serde_json::Value::from(y.as_f64().unwrap() - 0.012);
    assert!(
        one.check(&README).is_err(),
        "one corner moved by 12 mm passed"
    );
    for (dx, dy) in [(0.010, 0.0), (0.0, -0.010), (-0.007, 0.007)] {
        assert!(
            run.shifted(dx, dy).check(&README).is_err(),
            "every corner moved by ({dx}, {dy}) m passed"
        );
    }
}
