//! One module per subcommand: flag definitions and printing only.

pub mod convert;
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

/// Parses a comma-separated list of `min..=max` finite numbers given to `--flag`.
pub fn numbers(flag: &str, s: &str, min: usize, max: usize) -> Result<Vec<f64>> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| Error::Param(format!("--{flag} `{s}`: not a list of numbers")))?;
    if v.len() < min || v.len() > max {
        return Err(Error::Param(format!(
            "--{flag} `{s}`: expected {min} to {max} comma-separated numbers"
        )));
    }
    Ok(v)
}

/// Parses `a,b[,c]` (c = 0 when absent), e.g. `--init x,y,yaw`.
pub fn parse_triple(s: &str, flag: &str) -> Result<[f64; 3]> {
    let v = numbers(flag, s, 2, 3)?;
    Ok([v[0], v[1], v.get(2).copied().unwrap_or(0.0)])
}

/// Parses `--origin lat,lon[,alt]` in WGS84 degrees and metres.
pub fn parse_origin(s: &str) -> Result<mapgauge::survey::Geodetic> {
    let [lat, lon, alt] = parse_triple(s, "origin")?;
    if !(-90.0..=90.0).contains(&lat) || !(-180.0..=360.0).contains(&lon) {
        return Err(Error::Param(format!(
            "--origin `{s}`: latitude must be within ±90° and longitude within ±180°"
        )));
    }
    Ok(mapgauge::survey::Geodetic { lat, lon, alt })
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

/// Refuses to write an output onto one of the inputs: the same file under any
/// spelling (`./`, `..`, symlinks, hard links), recognised by device and inode.
pub fn refuse_overwrite(out: &std::path::Path, inputs: &[&std::path::Path]) -> Result<()> {
    for i in inputs {
        if same_file(out, i) {
            return Err(Error::Input(format!(
                "{}: is the input {}; refusing to overwrite it",
                out.display(),
                i.display()
            )));
        }
    }
    Ok(())
}

/// True when both paths exist and name the same file.
fn same_file(a: &std::path::Path, b: &std::path::Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(a), std::fs::metadata(b)) {
            (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
            (Ok(x), Ok(y)) => x == y,
            _ => false,
        }
    }
}
