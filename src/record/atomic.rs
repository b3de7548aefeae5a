//! Files written so that a crash never leaves a half-written one.

use crate::{Error, Result};
use std::path::Path;

/// Writes `bytes` to `path` so readers never see a half-written file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    // Process and a per-process count: two threads writing the same name
    // (a batch's runs) never share a temporary.
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = path.with_file_name(format!(".{name}.tmp{}.{k}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(|e| {
        // A disk that filled up must not be left holding a partial temporary.
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

/// Refuses to write an output onto one of the inputs: the same file under any
/// spelling (`./`, `..`, symlinks, hard links), recognised by device and inode.
pub fn refuse_overwrite(out: &Path, inputs: &[&Path]) -> Result<()> {
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
fn same_file(a: &Path, b: &Path) -> bool {
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
