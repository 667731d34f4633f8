//! The trainer's CSV loader, compiled from its own source file (no copy of its logic):
//! `trainer/src/data/csv.rs` is included as a module, beside a `record` module that
//! holds the two plain data types it builds (the trainer's `record.rs` pulls in the
//! `.mat` selection, manifests and preprocessing, which this target does not need).
#![no_main]
#![allow(dead_code)]

use libfuzzer_sys::fuzz_target;

/// The two types `csv.rs` builds, field for field as in `trainer/src/data/record.rs`.
mod record {
    /// One channel.
    #[derive(Debug, Clone, PartialEq)]
    pub struct Channel {
        pub name: String,
        pub samples: Vec<f32>,
    }

    /// Simultaneously sampled channels.
    #[derive(Debug, Clone, PartialEq)]
    pub struct Recording {
        pub name: String,
        pub fs_hz: f32,
        pub rpm: Option<f32>,
        pub channels: Vec<Channel>,
    }
}

#[path = "../../trainer/src/data/csv.rs"]
mod csv;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return; // the loader reads files with read_to_string: UTF-8 or an I/O error
    };
    if let Ok(rec) = csv::parse_csv(text, "fuzz", Some(12_000.0), Some(1797.0)) {
        let n = rec.channels.first().map_or(0, |c| c.samples.len());
        assert!(!rec.channels.is_empty());
        for c in &rec.channels {
            assert_eq!(c.samples.len(), n, "ragged channels accepted");
            assert!(c.samples.iter().all(|v| v.is_finite()), "non-finite sample");
        }
    }
});
