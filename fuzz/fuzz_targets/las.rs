//! Fuzzes the las map reader.
#![no_main]

mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    common::read_map(data, "las", mapgauge::cloud::Format::Las);
});
