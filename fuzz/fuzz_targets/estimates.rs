//! Fuzzes the estimates CSV reader.
#![no_main]

mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let path = common::scratch(data, "csv");
    if let Ok(e) = mapgauge::survey::read_estimates(&path) {
        assert!(!e.is_empty());
    }
});
