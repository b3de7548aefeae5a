//! Every integration test of mapgauge, as one test binary (one link, one run):
//! each module is one area, `util` holds what they share (the binary, stderr,
//! temporary directories). Run one area with its module path, e.g.
//!
//! ```sh
//! cargo test --release --test integration golden::
//! ```

mod truth;
mod util;

mod any_frame;
mod batch;
mod checkpoints;
mod cli_crop;
mod cli_formats;
mod cli_locate;
mod clutter;
mod copc;
mod demo_truth;
mod doubled;
mod errors_cli;
mod eval_scenes;
mod first_use;
mod gates;
mod golden;
mod hostile;
mod locate_acceptance;
mod models;
mod pipeline;
mod real_corpus;
mod report_cli;
mod synth_cli;
mod tiled;
mod uncertainty;
mod unfitted;
