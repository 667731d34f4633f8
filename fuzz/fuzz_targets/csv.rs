//! The data crate's CSV loader (`pumptwin_data::csv`), as the command line uses it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pumptwin_data::csv;

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
