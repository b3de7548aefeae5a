//! Helpers shared by every module of the integration-test binary.

use std::process::{Command, Output};

/// The mapgauge binary Cargo built for these tests.
pub const BIN: &str = env!("CARGO_BIN_EXE_mapgauge");

/// A command running the mapgauge binary.
pub fn bin() -> Command {
    Command::new(BIN)
}

/// A run's stderr as text (lossy: a test must still show bytes that are not UTF-8).
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `cmd`, which must succeed (its stderr is the failure message); returns stdout.
pub fn stdout_ok(cmd: &mut Command) -> String {
    let out = cmd.output().expect("spawn mapgauge");
    assert!(out.status.success(), "{cmd:?}: {}", stderr(&out));
    String::from_utf8(out.stdout).expect("stdout is UTF-8")
}

/// Writes `to`: the survey CSV `from` with `edit` applied to each data row's
/// fields (the header kept), e.g. a survey moved or with columns swapped.
pub fn edit_survey(from: &std::path::Path, to: &std::path::Path, edit: impl Fn(&mut Vec<String>)) {
    let text = std::fs::read_to_string(from).expect("read the survey");
    let mut lines = text.lines();
    let mut out = format!("{}\n", lines.next().expect("a header"));
    for l in lines {
        let mut f: Vec<String> = l.split(',').map(String::from).collect();
        edit(&mut f);
        out += &(f.join(",") + "\n");
    }
    std::fs::write(to, out).expect("write the survey");
}

/// Adds `d` to a CSV field holding a number (4 decimals, as surveys are).
pub fn add_to(field: &mut String, d: f64) {
    *field = format!("{:.4}", field.parse::<f64>().expect("a number") + d);
}

/// A fresh temporary directory, removed when dropped.
pub fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("create a temporary directory")
}
