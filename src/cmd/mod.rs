//! One module per subcommand: flag definitions and printing only.

pub mod crop;
pub mod demo;
pub mod errors;
pub mod eval;
pub mod locate;
pub mod synth;
pub mod table;

use indicatif::{ProgressBar, ProgressStyle};
use mapgauge::{Error, Result};
use std::io::IsTerminal;

/// A byte progress bar on stderr, or `None` when stderr is not a terminal.
pub fn progress_bar(total: u64, what: &str) -> Option<ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let pb = ProgressBar::new(total);
    pb.set_style(
        ProgressStyle::with_template(
            "{msg} [{bar:40}] {bytes}/{total_bytes} {bytes_per_sec} eta {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    Some(pb)
}

/// Parses `a,b,c` into three numbers (used by `--init` and `--origin`).
pub fn parse_triple(s: &str, what: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| {
            Error::Param(format!(
                "{what}: expected three comma-separated numbers, got `{s}`"
            ))
        })?;
    match v.as_slice() {
        [a, b, c] if v.iter().all(|x| x.is_finite()) => Ok([*a, *b, *c]),
        [a, b] if v.iter().all(|x| x.is_finite()) => Ok([*a, *b, 0.0]),
        _ => Err(Error::Param(format!(
            "{what}: expected three comma-separated numbers, got `{s}`"
        ))),
    }
}

/// A target id made safe as a file name (ids are free text in the survey).
pub fn file_stem_for(id: &str) -> String {
    let s: String = id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.chars().all(|c| c == '.') {
        format!("_{s}")
    } else {
        s
    }
}

/// Refuses to write an output onto one of the inputs.
pub fn refuse_overwrite(out: &std::path::Path, inputs: &[&std::path::Path]) -> Result<()> {
    let canon = |p: &std::path::Path| std::fs::canonicalize(p).ok();
    if let Some(o) = canon(out) {
        for i in inputs {
            if canon(i).as_ref() == Some(&o) {
                return Err(Error::Param(format!(
                    "refusing to overwrite input {}",
                    i.display()
                )));
            }
        }
    }
    Ok(())
}
