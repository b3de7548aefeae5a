//! Fuzzes the survey CSV reader (local and WGS84 surveys).
#![no_main]

mod common;

use mapgauge::survey::{SurveyOptions, read_survey};

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let path = common::scratch(data, "csv");
    if let Ok(s) = read_survey(&path, &SurveyOptions::default()) {
        assert!(!s.targets.is_empty());
        assert!(
            s.targets
                .iter()
                .all(|t| t.position.iter().all(|v| v.is_finite()))
        );
    }
});
