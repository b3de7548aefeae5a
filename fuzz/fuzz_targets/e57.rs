//! Fuzzes the e57 map reader. Every 1024-byte page of an E57 file ends in a
//! CRC-32C of the page, which a mutated input almost never matches; the CRCs
//! are recomputed before reading so that mutations reach the XML and binary
//! sections instead of stopping at the checksum (tests/integration/hostile.rs covers bad
//! checksums).
#![no_main]

mod common;

const PAGE: usize = 1024;

fn crc32c(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0x82F6_3B78
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let mut v = data.to_vec();
    for page in v.chunks_exact_mut(PAGE) {
        let crc = crc32c(&page[..PAGE - 4]);
        page[PAGE - 4..].copy_from_slice(&crc.to_be_bytes());
    }
    common::read_map(&v, "e57", mapgauge::cloud::Format::E57);
});
