//! Many maps at once: methods × sequences from a manifest, evaluated in
//! parallel with a bound on the maps open at once, resumable, summarised as
//! the paper's tables per sequence, a leaderboard across sequences and a
//! comparison of every method with a baseline (`mapgauge batch`).
//!
//! Each run is `mapgauge eval --out <sequence>/<method>` with the run's
//! settings: the same `result.json`, tables and report. A run whose map,
//! survey, configuration and mapgauge version are those of its last
//! finished run is not evaluated again (its `batch-run.json` holds their
//! BLAKE3 hashes); a run that fails leaves `error.txt` and does not stop
//! the others.
//!
//! ```no_run
//! use mapgauge::batch::{Manifest, run_all, summarise, write_summary};
//! let m = Manifest::read("runs.toml".as_ref())?;
//! let out = std::path::Path::new("results");
//! let records = run_all(&m, out, 2, |_| {});
//! let summary = summarise(&m, &records);
//! write_summary(out, &summary, &records)?;
//! # Ok::<(), mapgauge::Error>(())
//! ```

mod manifest;
mod one;
mod summary;

pub use manifest::{Manifest, RawManifest, RawRun, Run};
pub use one::{RunRecord, Status, run_one};
pub use summary::{Leader, RunLine, Summary, Versus, leaderboard_grid, summarise, write_summary};

use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Evaluates every run of `m` into `out`, `jobs` at a time (so at most
/// `jobs` maps are open at once; each run's own passes use every core as
/// `eval` does). `done` is called as each run ends, from its worker. The
/// records come back in the manifest's order whatever the finishing order.
pub fn run_all(
    m: &Manifest,
    out: &Path,
    jobs: usize,
    done: impl Fn(&RunRecord) + Sync,
) -> Vec<RunRecord> {
    let next = AtomicUsize::new(0);
    let slots: Mutex<Vec<Option<RunRecord>>> = Mutex::new(vec![None; m.runs.len()]);
    std::thread::scope(|s| {
        for _ in 0..jobs.clamp(1, m.runs.len().max(1)) {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(run) = m.runs.get(i) else { break };
                    let rec = run_one(run, out);
                    done(&rec);
                    if let Ok(mut v) = slots.lock() {
                        v[i] = Some(rec);
                    }
                }
            });
        }
    });
    slots
        .into_inner()
        .unwrap_or_default()
        .into_iter()
        .flatten()
        .collect()
}

#[cfg(test)]
mod tests;
