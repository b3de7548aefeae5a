//! Fuzzes the PTS map reader.
#![no_main]

mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    common::read_map(data, "pts", mapgauge::cloud::Format::Pts);
});
