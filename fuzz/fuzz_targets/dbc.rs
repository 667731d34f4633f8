//! The DBC reader of the sensor map's `[dbc]` section: any text through
//! `SlowSignals::parse`, asking for signals the text itself names (so that parsed
//! files reach the signal checks), then every accepted signal decoded from payloads
//! of every length.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use pumptwin_edge::dbc::{SlowSignals, ROLES};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return; // read with read_to_string: UTF-8 or an I/O error
    };
    // The names to ask for: the first three signals the parser finds, else fixed ones.
    let mut names: Vec<(&'static str, String)> = match can_dbc::Dbc::try_from(text) {
        Ok(dbc) => dbc
            .messages
            .iter()
            .flat_map(|m| m.signals.iter())
            .zip(ROLES)
            .map(|(s, role)| (role, s.name.clone()))
            .collect(),
        Err(_) => Vec::new(),
    };
    if names.is_empty() {
        names.push(("rpm", "ShaftSpeed".to_string()));
    }
    let Ok(mut slow) = SlowSignals::parse(text, Path::new("fuzz.dbc"), &names) else {
        return;
    };
    let payload: Vec<u8> = (0..64u8)
        .map(|b| b.wrapping_mul(37) ^ data.len() as u8)
        .collect();
    for s in slow.signals.clone() {
        for len in 0..=64 {
            if let Some(v) = s.decode(&payload[..len]) {
                let _ = v.is_finite();
            }
        }
        let mut frame = pumptwin_edge::candump::parse_line(b"(1.000000) can0 600#00")
            .expect("valid line")
            .expect("a frame");
        frame.id = s.id();
        frame.extended = s.extended();
        frame.data.clear();
        frame
            .data
            .extend_from_slice(&payload[..8])
            .expect("8 bytes");
        slow.update(&frame);
    }
});
