//! The data crate's universal file reader (`pumptwin_data::uff`, data set 58 and 58b)
//! and the channel assembly, as the command line uses them.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pumptwin_data::{channels, uff};

fuzz_target!(|data: &[u8]| {
    if let Ok(chans) = uff::parse_uff(data) {
        assert!(!chans.is_empty(), "no channel but no error");
        for c in &chans {
            assert!(
                c.fs_hz.is_some_and(|fs| fs > 0.0),
                "a time record without a rate"
            );
        }
        if let Ok(rec) = channels::assemble("fuzz", chans, &[], None, None) {
            let n = rec.len();
            for c in &rec.channels {
                assert_eq!(c.samples.len(), n, "ragged channels accepted");
                assert!(c.samples.iter().all(|v| v.is_finite()), "non-finite sample");
            }
        }
    }
});
