//! The sensor-map TOML reader: any text through `SensorMap::from_toml_str_in` (with
//! `pump.dbc` readable beside it, so a `[dbc]` section reaches the DBC reader). A map
//! that validates must build a pipeline that takes a frame on each of its channels.
#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use pumptwin_edge::candump::parse_line;
use pumptwin_edge::pipeline::Pipeline;
use pumptwin_edge::sensor_map::SensorMap;

const DBC: &str = include_str!("../seeds/pump.dbc");

fn base() -> &'static PathBuf {
    static BASE: OnceLock<PathBuf> = OnceLock::new();
    BASE.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("pumptwin-fuzz-map-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        std::fs::write(dir.join("pump.dbc"), DBC).expect("write dbc");
        dir
    })
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return; // the map is read with read_to_string: UTF-8 or an I/O error
    };
    let Ok(map) = SensorMap::from_toml_str_in(text, base()) else {
        return;
    };
    let channels = map.channels.clone();
    let mut pipeline = Pipeline::new(map).expect("a validated map builds a pipeline");
    let mut frame = parse_line(b"(1700000000.000000) can0 101#00")
        .expect("valid line")
        .expect("a frame");
    for (i, ch) in channels.iter().enumerate() {
        let samples: Vec<f32> = (0..ch.samples_per_frame).map(|k| k as f32 * 0.01).collect();
        let payload = ch.encode(&samples, i as u8);
        frame.id = ch.can_id;
        frame.extended = ch.extended;
        frame.fd = ch.needs_fd();
        frame.data.clear();
        frame.data.extend_from_slice(&payload).expect("≤ 64 bytes");
        frame.ts_us += 1000;
        pipeline.push(&frame);
    }
    let h = pipeline.health();
    assert_eq!(h.frames_classified(), h.frames_total, "{h}");
    assert_eq!(
        h.used + h.duplicate + h.out_of_sequence,
        channels.len() as u64,
        "{h}"
    );
});
