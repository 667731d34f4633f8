//! Test kit: a tiny seeded PRNG, synthetic bearing signals, and the encoder that turns
//! multi-channel signals into candump frames per a sensor map (the inverse of the
//! gateway's decoding), so tests can round-trip.
#![allow(dead_code)]

use pumptwin_edge::candump::{
    format_line, Frame, FrameKind, FrameSource, SourceError, CANFD_LENGTHS,
};
use pumptwin_edge::sensor_map::SensorMap;

/// Two channels: DE with a sequence counter (9-byte layout → CAN FD, padded to 12),
/// FE without (8 bytes, classic).
pub const MAP_DE_FE: &str = r#"
[machine]
rpm = 1797.0
bearing = "cwru-6205-de"
fs_hz = 12000.0

[[channel]]
name = "DE"
can_id = 0x101
samples_per_frame = 4
scale = 0.001
sequence_byte = 0

[[channel]]
name = "FE"
can_id = 0x102
samples_per_frame = 4
scale = 0.001
"#;

pub const FS: f64 = 12_000.0;
pub const T0_US: u64 = 1_700_000_000_000_000;

pub fn map(text: &str) -> SensorMap {
    SensorMap::from_toml_str(text).expect("test sensor map")
}

/// xorshift64 with a Box–Muller normal.
pub struct XorShift(pub u64);

impl XorShift {
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    /// Uniform in (0, 1].
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    }
    pub fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// Inner-race-like signal: 3 kHz bursts decaying at 900 /s, struck at `rate_hz`,
/// amplitude `amp` g, plus Gaussian noise of `noise` g.
pub fn impact_signal(n: usize, rate_hz: f64, amp: f64, noise: f64, seed: u64) -> Vec<f32> {
    let mut rng = XorShift(seed);
    (0..n)
        .map(|i| {
            let t = i as f64 / FS;
            let since = t % (1.0 / rate_hz);
            let burst =
                (-since * 900.0).exp() * (2.0 * std::f64::consts::PI * 3000.0 * since).sin();
            (amp * burst + noise * rng.normal()) as f32
        })
        .collect()
}

/// BPFI of the CWRU 6205 at 1797 rpm, Hz.
pub fn bpfi_hz() -> f64 {
    let f = pumptwin_core::bearing::BearingGeometry::CWRU_6205_DE.frequencies(1797.0 / 60.0);
    f64::from(f.bpfi)
}

/// Frames carrying `signals[c]` (physical units) on channel `c` of `map`, in time order.
/// Frame `j` of a channel holds samples `[j·k, (j+1)·k)` and is stamped with the time of
/// its last sample; a layout over 8 bytes goes as CAN FD, padded to a CAN FD length;
/// sequence counters start at `seq0` and wrap.
pub fn encode(map: &SensorMap, signals: &[Vec<f32>], seq0: u8) -> Vec<Frame> {
    let mut frames = Vec::new();
    for (ch, x) in map.channels.iter().zip(signals) {
        let k = ch.samples_per_frame;
        for (j, chunk) in x.chunks_exact(k).enumerate() {
            let mut data = ch.encode(chunk, seq0.wrapping_add(j as u8));
            let fd = ch.needs_fd();
            if fd {
                let len = *CANFD_LENGTHS.iter().find(|&&l| l >= data.len()).unwrap();
                data.resize(len, 0).unwrap();
            }
            let last = (j + 1) * k - 1;
            frames.push(Frame {
                ts_us: T0_US + (last as f64 / FS * 1e6).round() as u64,
                iface: "can0".try_into().unwrap(),
                id: ch.can_id,
                extended: ch.extended,
                fd,
                fd_flags: if fd { 1 } else { 0 },
                kind: FrameKind::Data,
                data,
            });
        }
    }
    // Stable: at equal times, sensor-map order.
    frames.sort_by_key(|f| f.ts_us);
    frames
}

/// The frames as a candump -l log.
pub fn log_text(frames: &[Frame]) -> String {
    let mut s = String::from("# synthetic log written by the edge-app test kit\n");
    for f in frames {
        s.push_str(&format_line(f));
        s.push('\n');
    }
    s
}

/// A scripted bus: frames (or errors) in order.
pub struct ScriptedBus(pub std::vec::IntoIter<Result<Frame, SourceError>>);

impl FrameSource for ScriptedBus {
    fn next_frame(&mut self) -> Option<Result<Frame, SourceError>> {
        self.0.next()
    }
}

/// A data frame of arbitrary id and payload.
pub fn raw_frame(ts_us: u64, id: u32, data: &[u8]) -> Frame {
    Frame {
        ts_us,
        iface: "can0".try_into().unwrap(),
        id,
        extended: id > 0x7FF,
        fd: data.len() > 8,
        fd_flags: 0,
        kind: FrameKind::Data,
        data: heapless::Vec::from_slice(data).unwrap(),
    }
}
