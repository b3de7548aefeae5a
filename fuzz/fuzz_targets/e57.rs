//! Fuzzes the e57 map reader.
#![no_main]

mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    common::read_map(data, "e57", mapgauge::cloud::Format::E57);
});
