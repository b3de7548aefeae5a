//! Fuzzes the eval TOML configuration reader; an accepted configuration must
//! pass its own validation and print back as TOML that reads the same.
#![no_main]

mod common;

use mapgauge::pipeline::Config as EvalConfig;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let path = common::scratch(data, "toml");
    if let Ok(cfg) = EvalConfig::from_toml_file(&path) {
        cfg.validate().expect("an accepted configuration validates");
        let text = cfg.to_toml();
        let again = common::scratch(text.as_bytes(), "toml");
        EvalConfig::from_toml_file(&again).expect("a printed configuration reads back");
    }
});
