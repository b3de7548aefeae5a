//! Fuzzes the result.json reader used by `mapgauge table`, and the tables
//! rendered from whatever it accepts.
#![no_main]

mod common;

use mapgauge::record::ResultFile as RunResult;
use mapgauge::render::{TableFormat, absolute_grid, relative_grid, render_report};

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let path = common::scratch(data, "json");
    if let Ok(r) = RunResult::from_json_file(&path) {
        let runs = [("run".to_string(), &r)];
        for f in [
            TableFormat::Markdown,
            TableFormat::Latex,
            TableFormat::Csv,
            TableFormat::Text,
        ] {
            let _ = relative_grid(&runs).render(f);
            let _ = absolute_grid(&runs).render(f);
            let _ = render_report(&r, f);
        }
        let _ = r.to_json();
    }
});
