//! Fuzzes the xyz map reader.
#![no_main]

mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    common::read_map(data, "xyz", mapgauge::cloud::Format::Xyz);
});
