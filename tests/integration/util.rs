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

/// A fresh temporary directory, removed when dropped.
pub fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("create a temporary directory")
}
