//! The data crate's TDMS reader (`pumptwin_data::tdms`) and the channel assembly every
//! self-describing file goes through, as the command line uses them.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pumptwin_data::{channels, tdms};

fuzz_target!(|data: &[u8]| {
    if let Ok(chans) = tdms::parse_tdms(data) {
        for c in &chans {
            assert!(c.fs_hz.is_none_or(|fs| fs.is_finite() && fs > 0.0));
        }
        if let Ok(rec) = channels::assemble("fuzz", chans, &[], Some(1000.0), None) {
            let n = rec.len();
            for c in &rec.channels {
                assert_eq!(c.samples.len(), n, "ragged channels accepted");
                assert!(c.samples.iter().all(|v| v.is_finite()), "non-finite sample");
            }
        }
    }
});
