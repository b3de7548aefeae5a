//! Fuzzes the pcd map reader.
#![no_main]

mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    common::read_map(data, "pcd", mapgauge::cloud::Format::Pcd);
});
