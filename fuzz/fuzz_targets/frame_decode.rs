//! CAN frame → sample decoder with the sensor map: arbitrary frames (identifier from
//! the map's channels, its DBC message or anywhere; classic or FD, data, remote or
//! error; any payload length; timestamps forwards, repeated or backwards) through the
//! gateway's [`Pipeline`]. The health counters must add up after every frame.
//!
//! Input: a sequence of records `[sel, dt, len, rep, payload…]`: `sel` picks the
//! identifier (bits 0–2), extended (3), FD (4) and kind (5–7); `dt` the time step
//! (× 100 µs), backwards when `len`'s top bit is set; `len & 0x7F` the payload
//! length (≤ 64); `rep` how many more times the frame is sent, each copy later by
//! one step and with its first byte (a sequence counter) one higher. The repeats let
//! a short input fill the 2048-sample windows, so the window path (features,
//! explanation, tracking) is fuzzed too, not only the decoder.
#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use pumptwin_edge::candump::{parse_line, Frame, FrameKind};
use pumptwin_edge::pipeline::Pipeline;
use pumptwin_edge::sensor_map::SensorMap;

/// The demo's map (three CAN FD channels, a sequence byte) plus a classic-CAN channel
/// without one, and a DBC message with the slow signals.
const MAP: &str = r#"
[machine]
rpm = 1797.0
bearing = "cwru-6205-de"
fs_hz = 12000.0

[dbc]
file = "pump.dbc"
rpm = "ShaftSpeed"
temperature = "BearingTemp"
pressure = "DischargePressure"

[[channel]]
name = "DE"
can_id = 0x101
samples_per_frame = 31
scale = 0.0005
sequence_byte = 0

[[channel]]
name = "FE"
can_id = 0x102
samples_per_frame = 31
scale = 0.0005
sequence_byte = 0

[[channel]]
name = "BA"
can_id = 0x18FF0103
extended = true
samples_per_frame = 4
scale = 0.001
"#;

const DBC: &str = include_str!("../seeds/pump.dbc");

fn map() -> &'static SensorMap {
    static MAP_ONCE: OnceLock<SensorMap> = OnceLock::new();
    MAP_ONCE.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("pumptwin-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        std::fs::write(dir.join("pump.dbc"), DBC).expect("write dbc");
        SensorMap::from_toml_str_in(MAP, &dir).expect("the fuzz map is valid")
    })
}

fn template() -> Frame {
    parse_line(b"(1700000000.000000) can0 101#00")
        .expect("valid line")
        .expect("a frame")
}

fuzz_target!(|data: &[u8]| {
    let mut pipeline = Pipeline::new(map().clone()).expect("pipeline");
    let mut frame = template();
    let mut rest = data;
    let mut pushed = 0u64;
    while let [sel, dt, len, rep, tail @ ..] = rest {
        let n = usize::from(*len & 0x7F).min(64).min(tail.len());
        let (payload, next) = tail.split_at(n);
        rest = next;
        frame.id = match sel & 0x07 {
            0 | 1 => 0x101,
            2 => 0x102,
            3 => 0x0FF0103,
            4 => 0x18FF0103,
            5 => 0x600, // the DBC message
            _ => u32::from(*dt) << 3 | u32::from(sel >> 5),
        };
        frame.extended = sel & 0x08 != 0 || frame.id > 0x7FF;
        frame.fd = sel & 0x10 != 0;
        frame.kind = match (sel >> 5) & 0x07 {
            6 => FrameKind::Remote { dlc: *dt & 0x0F },
            7 => FrameKind::Error,
            _ => FrameKind::Data,
        };
        frame.data.clear();
        if !matches!(frame.kind, FrameKind::Remote { .. }) {
            let _ = frame.data.extend_from_slice(payload);
        }
        // Time steps of 0..=255 × 100 µs forwards, or backwards when `len`'s top bit is set.
        let step = u64::from(*dt) * 100;
        for copy in 0..=u32::from(*rep) {
            if copy > 0 {
                if let Some(seq) = frame.data.first_mut() {
                    *seq = seq.wrapping_add(1);
                }
            }
            frame.ts_us = if len & 0x80 != 0 {
                frame.ts_us.saturating_sub(step)
            } else {
                frame.ts_us + step
            };
            let out = pipeline.push(&frame);
            pushed += 1;
            for w in &out.windows {
                let _ = w.is_degraded();
                for name in ["DE", "FE", "BA"] {
                    if let Some(f) = w.features(name) {
                        let _ = f.envelope_feature(0);
                    }
                }
            }
            // Not `track_pending()`: the RK4 tracker is no parser (it is in the
            // no-panic proof and the core's tests); here it would cut the rate 3.5×.
        }
        // A frame held after a silence is counted once it is decided.
        let _ = pipeline.finish();
        let h = pipeline.health();
        assert_eq!(h.frames_total, pushed);
        assert_eq!(
            h.frames_classified(),
            h.frames_total,
            "counters do not add up: {h}"
        );
    }
});
