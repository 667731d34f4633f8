//! The data crate's WAV reader (`pumptwin_data::wav`), as the command line uses it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pumptwin_data::wav;

fuzz_target!(|data: &[u8]| {
    if let Ok(rec) = wav::parse_wav(data, "fuzz", Some(1797.0)) {
        let n = rec.channels.first().map_or(0, |c| c.samples.len());
        assert!(n > 0 && rec.fs_hz > 0.0);
        for c in &rec.channels {
            assert_eq!(c.samples.len(), n, "ragged channels accepted");
            assert!(c.samples.iter().all(|v| v.is_finite()), "non-finite sample");
        }
    }
});
