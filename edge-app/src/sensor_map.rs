//! The sensor map: what the gateway is told about the machine and which CAN frames
//! carry which accelerometer channel, in which layout.
//!
//! ```toml
//! [machine]
//! rpm = 1797.0              # nominal shaft speed, rev/min
//! bearing = "cwru-6205-de"  # preset, or { n = 9, d = 0.3126, pitch = 1.537, angle = 0.0 }
//! fs_hz = 12000.0           # sampling rate of every channel
//!
//! [[channel]]
//! name = "DE"
//! can_id = 0x101            # ≤ 0x7FF: standard id unless `extended = true`
//! samples_per_frame = 4     # k little-endian i16 samples per frame
//! scale = 0.001             # physical units (g) per count
//! sequence_byte = 0         # optional: u8 counter at this byte, samples follow it
//! ```
//!
//! Frame layout of a channel, with `s = sequence_byte` and `k = samples_per_frame`:
//!
//! ```text
//! without a counter:  bytes 0..2k          = k × i16 LE
//! with a counter:     byte s               = u8 sequence counter (wraps 255 → 0)
//!                     bytes s+1..s+1+2k    = k × i16 LE   (bytes before s are ignored)
//! sample = i16 · scale
//! ```
//!
//! A classic frame must be exactly as long as the layout; a CAN FD frame may also be
//! padded up to the next CAN FD length (a 21-byte layout travels in 24 bytes).
//! Presets: `cwru-6205-de` and `cwru-6203-fe` (the CWRU test-rig bearings, see
//! [`BearingGeometry`]). Every channel shares `fs_hz` in this version.

use crate::candump::{Frame, CANFD_LENGTHS, CANFD_MAX_DLEN, CAN_MAX_DLEN, EFF_MAX, SFF_MAX};
use crate::dbc::SlowSignals;
use pumptwin_core::bearing::BearingGeometry;
use pumptwin_core::features::FeatureConfig;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Most samples one frame can carry (64 bytes of i16).
pub const MAX_SAMPLES_PER_FRAME: usize = CANFD_MAX_DLEN / 2;

/// Lowest sampling rate with room for the envelope band: its upper edge
/// `min(5 kHz, 0.45·fs)` must lie above its 500 Hz lower edge.
pub const MIN_FS_HZ: f64 = 500.0 / 0.45;

/// Bearing presets by name.
pub const BEARING_PRESETS: [(&str, BearingGeometry); 2] = [
    ("cwru-6205-de", BearingGeometry::CWRU_6205_DE),
    ("cwru-6203-fe", BearingGeometry::CWRU_6203_FE),
];

/// A validated sensor map.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorMap {
    /// The machine.
    pub machine: Machine,
    /// Channels in file order (the order of the JSON output and of graph nodes).
    pub channels: Vec<Channel>,
    /// Slow sensors from the `[dbc]` section (empty without one).
    pub slow: SlowSignals,
}

/// What the user knows about the machine.
#[derive(Debug, Clone, PartialEq)]
pub struct Machine {
    /// Nominal shaft speed, rev/min (> 0).
    pub rpm: f32,
    /// Bearing geometry (validated).
    pub bearing: BearingGeometry,
    /// Preset name, or `"custom"`.
    pub bearing_name: String,
    /// Sampling rate of every channel, Hz (> [`MIN_FS_HZ`]).
    pub fs_hz: f32,
}

impl Machine {
    /// Shaft rate in Hz.
    pub fn shaft_hz(&self) -> f32 {
        self.rpm / 60.0
    }

    /// The feature configuration for this machine: the core's
    /// [`FeatureConfig::standard`], the one the trainer uses, so a model sees the
    /// features it was trained on.
    pub fn feature_config(&self) -> FeatureConfig {
        FeatureConfig::standard(self.fs_hz, self.shaft_hz(), self.bearing.orders())
    }
}

/// One accelerometer channel and its frame layout.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// Channel (graph node) name, unique.
    pub name: String,
    /// CAN identifier (≤ 0x7FF standard, ≤ 0x1FFFFFFF extended).
    pub can_id: u32,
    /// Extended (29-bit) identifier.
    pub extended: bool,
    /// Samples per frame, `1..=32`.
    pub samples_per_frame: usize,
    /// Physical units per count (finite, non-zero).
    pub scale: f32,
    /// Byte holding a u8 sequence counter; samples follow it.
    pub sequence_byte: Option<usize>,
}

/// A frame whose payload does not fit the channel's layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{got} data bytes, the layout needs {expected}{}", if *.fd { " (CAN FD: or padded to the next CAN FD length)" } else { "" })]
pub struct LayoutError {
    /// Bytes the layout uses.
    pub expected: usize,
    /// Bytes in the frame.
    pub got: usize,
    /// The frame was CAN FD.
    pub fd: bool,
}

impl Channel {
    /// Index of the first sample byte.
    pub fn first_sample_byte(&self) -> usize {
        self.sequence_byte.map_or(0, |s| s + 1)
    }

    /// Bytes the layout uses.
    pub fn layout_len(&self) -> usize {
        self.first_sample_byte() + 2 * self.samples_per_frame
    }

    /// Whether `frame` has this channel's identifier (data, remote or error alike).
    pub fn matches(&self, frame: &Frame) -> bool {
        frame.id == self.can_id && frame.extended == self.extended
    }

    /// Decode one payload: the samples (scaled) into `out`, the sequence counter if the
    /// layout has one.
    pub fn decode(
        &self,
        data: &[u8],
        fd: bool,
        out: &mut heapless::Vec<f32, MAX_SAMPLES_PER_FRAME>,
    ) -> Result<Option<u8>, LayoutError> {
        let expected = self.layout_len();
        let padded = fd
            && CANFD_LENGTHS
                .iter()
                .find(|&&l| l >= expected)
                .is_some_and(|&l| l == data.len());
        let error = LayoutError {
            expected,
            got: data.len(),
            fd,
        };
        if data.len() != expected && !padded {
            return Err(error);
        }
        let seq = match self.sequence_byte {
            Some(s) => Some(*data.get(s).ok_or(error)?),
            None => None,
        };
        let payload = data.get(self.first_sample_byte()..expected).ok_or(error)?;
        out.clear();
        for pair in payload.chunks_exact(2) {
            let count = i16::from_le_bytes([pair[0], pair[1]]);
            out.push(f32::from(count) * self.scale).map_err(|_| error)?;
        }
        Ok(seq)
    }

    /// Encode samples (physical units) into a payload of this layout: the inverse of
    /// [`Channel::decode`], counts rounded and saturated to i16. Writes logs for tests
    /// and for the trainer's candump export; `samples.len()` must be `samples_per_frame`.
    pub fn encode(&self, samples: &[f32], seq: u8) -> heapless::Vec<u8, CANFD_MAX_DLEN> {
        let mut data = heapless::Vec::new();
        let _ = data.resize(self.layout_len().min(CANFD_MAX_DLEN), 0);
        if let Some(s) = self.sequence_byte {
            if let Some(b) = data.get_mut(s) {
                *b = seq;
            }
        }
        let first = self.first_sample_byte();
        for (i, &x) in samples.iter().take(self.samples_per_frame).enumerate() {
            let count = (x / self.scale).round().clamp(-32768.0, 32767.0) as i16;
            let at = first + 2 * i;
            if let Some(dst) = data.get_mut(at..at + 2) {
                dst.copy_from_slice(&count.to_le_bytes());
            }
        }
        data
    }

    /// Whether frames of this layout need CAN FD (more than 8 bytes).
    pub fn needs_fd(&self) -> bool {
        self.layout_len() > CAN_MAX_DLEN
    }
}

/// Why a sensor map was rejected.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum SensorMapError {
    /// The `[dbc]` part: file unreadable or unparsable, a signal not in it.
    #[error(transparent)]
    Dbc(#[from] crate::dbc::DbcError),
    /// A DBC signal's message uses a channel's identifier.
    #[error("DBC signal {signal:?} uses the CAN id of channel {channel:?}")]
    DbcIdClash {
        /// The signal.
        signal: String,
        /// The channel.
        channel: String,
    },
    /// The file could not be read.
    #[error("reading sensor map {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not TOML, a missing or misspelled key, or a value of the wrong type.
    #[error("sensor map: {0}")]
    Toml(#[from] toml::de::Error),
    /// `machine.rpm` not finite and positive.
    #[error("machine.rpm = {0}: must be finite and > 0")]
    Rpm(f64),
    /// `machine.rpm` puts the bearing's defect lines where the envelope cannot read
    /// them (`FeatureConfig::check_speed`).
    #[error("machine.rpm = {rpm}: {reason}")]
    Speed {
        /// The speed given.
        rpm: f64,
        /// The core's reason.
        reason: String,
    },
    /// `machine.fs_hz` not finite or too low for the envelope band.
    #[error("machine.fs_hz = {0}: must be finite and > {MIN_FS_HZ:.1} Hz (the envelope band starts at 500 Hz)")]
    SampleRate(f64),
    /// `machine.bearing` names no preset.
    #[error("machine.bearing = \"{0}\": unknown preset (known: cwru-6205-de, cwru-6203-fe; or a table {{ n, d, pitch, angle }})")]
    UnknownBearing(String),
    /// `machine.bearing` is neither a preset name nor a geometry table.
    #[error(
        "machine.bearing: expected a preset name or a table {{ n, d, pitch, angle }}, got {0}"
    )]
    BearingType(String),
    /// The custom geometry table has missing, unknown or mistyped keys.
    #[error("machine.bearing: {0}")]
    BearingTable(toml::de::Error),
    /// The custom geometry is physically impossible.
    #[error("machine.bearing: {0}")]
    BearingGeometry(pumptwin_core::Error),
    /// No `[[channel]]`.
    #[error("sensor map has no [[channel]] entries")]
    NoChannels,
    /// A channel with an empty name.
    #[error("channel #{index}: name is empty")]
    EmptyName {
        /// 1-based position in the file.
        index: usize,
    },
    /// Two channels share a name.
    #[error("channel name \"{0}\" is used twice")]
    DuplicateName(String),
    /// Two channels share a CAN identifier.
    #[error("channels \"{first}\" and \"{second}\" both use CAN id {id:#x}{}", if *.extended { " (extended)" } else { "" })]
    DuplicateId {
        /// The identifier.
        id: u32,
        /// Extended identifier.
        extended: bool,
        /// The first channel with it.
        first: String,
        /// The second.
        second: String,
    },
    /// The identifier does not fit its format.
    #[error("channel \"{channel}\": can_id = {id:#x} does not fit a {} identifier (max {:#x})", if *.extended { "29-bit" } else { "11-bit" }, if *.extended { EFF_MAX } else { SFF_MAX })]
    IdRange {
        /// Channel name.
        channel: String,
        /// The identifier given.
        id: i64,
        /// Whether it was to be extended.
        extended: bool,
    },
    /// `samples_per_frame` is zero or negative.
    #[error("channel \"{channel}\": samples_per_frame = {got}: must be at least 1")]
    ZeroSamples {
        /// Channel name.
        channel: String,
        /// The value given.
        got: i64,
    },
    /// The layout needs more bytes than a CAN FD frame has.
    #[error("channel \"{channel}\": the layout needs {needed} bytes per frame (sequence byte, then 2 per sample), a CAN FD frame carries at most {CANFD_MAX_DLEN}")]
    FrameTooShort {
        /// Channel name.
        channel: String,
        /// Bytes the layout needs.
        needed: i64,
    },
    /// `sequence_byte` is negative.
    #[error("channel \"{channel}\": sequence_byte = {got}: must be a byte index >= 0")]
    SequenceByte {
        /// Channel name.
        channel: String,
        /// The value given.
        got: i64,
    },
    /// `scale` is NaN, infinite or zero.
    #[error("channel \"{channel}\": scale = {scale}: must be finite and non-zero")]
    Scale {
        /// Channel name.
        channel: String,
        /// The value given.
        scale: f64,
    },
}

/// A TOML number: integer or float (`rpm = 1800` and `rpm = 1800.0` both work).
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(untagged)]
enum Number {
    Int(i64),
    Float(f64),
}

impl Number {
    fn get(self) -> f64 {
        match self {
            Number::Int(i) => i as f64,
            Number::Float(f) => f,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMap {
    machine: RawMachine,
    #[serde(default)]
    channel: Vec<RawChannel>,
    #[serde(default)]
    dbc: Option<RawDbc>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDbc {
    file: String,
    #[serde(default)]
    rpm: Option<String>,
    #[serde(default)]
    temperature: Option<String>,
    #[serde(default)]
    pressure: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMachine {
    rpm: Number,
    bearing: toml::Value,
    fs_hz: Number,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGeometry {
    n: u8,
    d: Number,
    pitch: Number,
    #[serde(default)]
    angle: Option<Number>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawChannel {
    name: String,
    can_id: i64,
    #[serde(default)]
    extended: Option<bool>,
    samples_per_frame: i64,
    scale: Number,
    #[serde(default)]
    sequence_byte: Option<i64>,
}

impl SensorMap {
    /// Read and validate a sensor map file.
    pub fn load(path: &Path) -> Result<Self, SensorMapError> {
        let text = std::fs::read_to_string(path).map_err(|source| SensorMapError::Read {
            path: path.to_owned(),
            source,
        })?;
        Self::from_toml_str_in(&text, path.parent().unwrap_or(Path::new(".")))
    }

    /// Parse and validate a sensor map (a DBC file it names is relative to the
    /// current directory).
    pub fn from_toml_str(text: &str) -> Result<Self, SensorMapError> {
        Self::from_toml_str_in(text, Path::new("."))
    }

    /// Parse and validate a sensor map whose DBC file is relative to `base`.
    pub fn from_toml_str_in(text: &str, base: &Path) -> Result<Self, SensorMapError> {
        let raw: RawMap = toml::from_str(text)?;
        let slow = match raw.dbc {
            None => SlowSignals::default(),
            Some(d) => {
                let names: Vec<(&'static str, String)> = [
                    ("rpm", d.rpm),
                    ("temperature", d.temperature),
                    ("pressure", d.pressure),
                ]
                .into_iter()
                .filter_map(|(role, n)| n.map(|n| (role, n)))
                .collect();
                SlowSignals::load(&base.join(&d.file), &names)?
            }
        };
        let machine = validate_machine(raw.machine)?;
        if raw.channel.is_empty() {
            return Err(SensorMapError::NoChannels);
        }
        let mut channels: Vec<Channel> = Vec::with_capacity(raw.channel.len());
        for (i, rc) in raw.channel.into_iter().enumerate() {
            let ch = validate_channel(i + 1, rc)?;
            if channels.iter().any(|c| c.name == ch.name) {
                return Err(SensorMapError::DuplicateName(ch.name));
            }
            if let Some(c) = channels
                .iter()
                .find(|c| c.can_id == ch.can_id && c.extended == ch.extended)
            {
                return Err(SensorMapError::DuplicateId {
                    id: ch.can_id,
                    extended: ch.extended,
                    first: c.name.clone(),
                    second: ch.name,
                });
            }
            channels.push(ch);
        }
        if let Some((s, c)) = slow.signals.iter().find_map(|s| {
            channels
                .iter()
                .find(|c| c.can_id == s.id() && c.extended == s.extended())
                .map(|c| (s, c))
        }) {
            return Err(SensorMapError::DbcIdClash {
                signal: s.name.clone(),
                channel: c.name.clone(),
            });
        }
        Ok(Self {
            machine,
            channels,
            slow,
        })
    }

    /// Index of the channel that `frame`'s identifier belongs to.
    pub fn channel_of(&self, frame: &Frame) -> Option<usize> {
        self.channels.iter().position(|c| c.matches(frame))
    }
}

fn validate_machine(raw: RawMachine) -> Result<Machine, SensorMapError> {
    let rpm = raw.rpm.get();
    if !(rpm.is_finite() && rpm > 0.0 && (rpm as f32).is_finite()) {
        return Err(SensorMapError::Rpm(rpm));
    }
    let fs = raw.fs_hz.get();
    if !(fs.is_finite() && fs > MIN_FS_HZ && (fs as f32).is_finite()) {
        return Err(SensorMapError::SampleRate(fs));
    }
    let (bearing, bearing_name) = match raw.bearing {
        toml::Value::String(name) => {
            let key = name.to_ascii_lowercase();
            match BEARING_PRESETS.iter().find(|(n, _)| *n == key) {
                Some((n, g)) => (*g, (*n).to_owned()),
                None => return Err(SensorMapError::UnknownBearing(name)),
            }
        }
        toml::Value::Table(table) => {
            let g: RawGeometry = toml::Value::Table(table)
                .try_into()
                .map_err(SensorMapError::BearingTable)?;
            let angle = g.angle.map_or(0.0, Number::get);
            let geometry =
                BearingGeometry::new(g.n, g.d.get() as f32, g.pitch.get() as f32, angle as f32)
                    .map_err(SensorMapError::BearingGeometry)?;
            (geometry, "custom".to_owned())
        }
        other => return Err(SensorMapError::BearingType(other.type_str().to_owned())),
    };
    let machine = Machine {
        rpm: rpm as f32,
        bearing,
        bearing_name,
        fs_hz: fs as f32,
    };
    machine
        .feature_config()
        .check_speed(pumptwin_core::layout::WINDOW)
        .map_err(|e| SensorMapError::Speed {
            rpm,
            reason: e.to_string(),
        })?;
    Ok(machine)
}

fn validate_channel(index: usize, raw: RawChannel) -> Result<Channel, SensorMapError> {
    let name = raw.name.trim().to_owned();
    if name.is_empty() {
        return Err(SensorMapError::EmptyName { index });
    }
    let extended = raw.extended.unwrap_or(raw.can_id > i64::from(SFF_MAX));
    let max_id = if extended { EFF_MAX } else { SFF_MAX };
    if !(0..=i64::from(max_id)).contains(&raw.can_id) {
        return Err(SensorMapError::IdRange {
            channel: name,
            id: raw.can_id,
            extended,
        });
    }
    if raw.samples_per_frame < 1 {
        return Err(SensorMapError::ZeroSamples {
            channel: name,
            got: raw.samples_per_frame,
        });
    }
    if let Some(s) = raw.sequence_byte.filter(|&s| s < 0) {
        return Err(SensorMapError::SequenceByte {
            channel: name,
            got: s,
        });
    }
    let first = raw.sequence_byte.map_or(0i64, |s| s.saturating_add(1));
    let needed = raw
        .samples_per_frame
        .saturating_mul(2)
        .saturating_add(first);
    if needed > CANFD_MAX_DLEN as i64 {
        return Err(SensorMapError::FrameTooShort {
            channel: name,
            needed,
        });
    }
    let scale = raw.scale.get();
    if !(scale.is_finite() && scale != 0.0 && (scale as f32).is_normal()) {
        return Err(SensorMapError::Scale {
            channel: name,
            scale,
        });
    }
    Ok(Channel {
        name,
        can_id: raw.can_id as u32,
        extended,
        samples_per_frame: raw.samples_per_frame as usize,
        scale: scale as f32,
        sequence_byte: raw.sequence_byte.map(|s| s as usize),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
        [machine]
        rpm = 1797.0            # nominal speed
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
        samples_per_frame = 3
        scale = 0.001

        [[channel]]
        name = "BA"
        can_id = 0x18FF0001
        samples_per_frame = 30
        scale = 1e-3
        sequence_byte = 2
    "#;

    fn with_channel(channel: &str) -> String {
        format!(
            "[machine]\nrpm = 1797\nbearing = \"cwru-6205-de\"\nfs_hz = 12000\n\
             [[channel]]\nname = \"DE\"\ncan_id = 0x101\nsamples_per_frame = 4\nscale = 0.001\n\
             [[channel]]\n{channel}\n"
        )
    }

    fn err(text: &str) -> SensorMapError {
        match SensorMap::from_toml_str(text) {
            Err(e) => e,
            Ok(m) => panic!("accepted: {m:?}"),
        }
    }

    #[test]
    fn parses_presets_layouts_and_defaults() {
        let m = SensorMap::from_toml_str(GOOD).unwrap();
        assert_eq!(m.machine.bearing, BearingGeometry::CWRU_6205_DE);
        assert_eq!(m.machine.bearing_name, "cwru-6205-de");
        assert!((m.machine.shaft_hz() - 29.95).abs() < 1e-4);
        let names: Vec<&str> = m.channels.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["DE", "FE", "BA"]);
        let de = &m.channels[0];
        assert_eq!((de.can_id, de.extended, de.layout_len()), (0x101, false, 9));
        assert!(de.needs_fd());
        assert_eq!(m.channels[1].layout_len(), 6);
        assert!(!m.channels[1].needs_fd());
        let ba = &m.channels[2];
        assert_eq!(
            (ba.extended, ba.first_sample_byte(), ba.layout_len()),
            (true, 3, 63)
        );
    }

    #[test]
    fn custom_bearing_table() {
        let text = GOOD.replace(
            "bearing = \"cwru-6205-de\"",
            "bearing = { n = 11, d = 7.9, pitch = 39, angle = 15.0 }",
        );
        let m = SensorMap::from_toml_str(&text).unwrap();
        assert_eq!(
            m.machine.bearing,
            BearingGeometry::new(11, 7.9, 39.0, 15.0).unwrap()
        );
        assert_eq!(m.machine.bearing_name, "custom");
        let text = GOOD.replace("\"cwru-6205-de\"", "\"CWRU-6203-FE\"");
        let m = SensorMap::from_toml_str(&text).unwrap();
        assert_eq!(m.machine.bearing, BearingGeometry::CWRU_6203_FE);
    }

    #[test]
    fn decode_and_encode_are_inverse() {
        let m = SensorMap::from_toml_str(GOOD).unwrap();
        let de = &m.channels[0];
        let x = [0.5f32, -1.25, 0.001, -32.768];
        let data = de.encode(&x, 200);
        assert_eq!(data.len(), 9);
        let mut out = heapless::Vec::new();
        assert_eq!(de.decode(&data, true, &mut out), Ok(Some(200)));
        for (a, b) in out.iter().zip(x) {
            assert!((a - b).abs() < 1e-6, "{a} {b}");
        }
        // CAN FD padding up to the next CAN FD length (9 → 12) is accepted, more is not.
        let mut padded = data.clone();
        padded.extend_from_slice(&[0, 0, 0]).unwrap();
        assert!(de.decode(&padded, true, &mut out).is_ok());
        assert_eq!(
            de.decode(&padded, false, &mut out),
            Err(LayoutError {
                expected: 9,
                got: 12,
                fd: false
            })
        );
        padded.extend_from_slice(&[0; 4]).unwrap();
        assert!(de.decode(&padded, true, &mut out).is_err());
        assert!(de.decode(&data[..8], false, &mut out).is_err());
        assert!(de.decode(&[], false, &mut out).is_err());
        // Saturation instead of wrap-around.
        let fe = &m.channels[1];
        let data = fe.encode(&[1e9, -1e9, 0.0], 0);
        fe.decode(&data, false, &mut out).unwrap();
        assert_eq!(
            out.as_slice(),
            &[32767.0 * fe.scale, -32768.0 * fe.scale, 0.0]
        );
    }

    #[test]
    fn validation_errors_name_the_problem() {
        use SensorMapError as E;
        let e = err(&with_channel(
            "name = \"DE\"\ncan_id = 0x103\nsamples_per_frame = 4\nscale = 1.0",
        ));
        assert!(matches!(&e, E::DuplicateName(n) if n == "DE"), "{e}");
        let e = err(&with_channel(
            "name = \"FE\"\ncan_id = 0x101\nsamples_per_frame = 4\nscale = 1.0",
        ));
        assert!(matches!(&e, E::DuplicateId { id: 0x101, .. }), "{e}");
        assert!(e.to_string().contains("\"DE\" and \"FE\""), "{e}");
        // Same number, other format: a different CAN id.
        assert!(SensorMap::from_toml_str(&with_channel(
            "name = \"FE\"\ncan_id = 0x101\nextended = true\nsamples_per_frame = 4\nscale = 1.0"
        ))
        .is_ok());
        let e = err(&with_channel(
            "name = \"FE\"\ncan_id = 0x102\nsamples_per_frame = 0\nscale = 1.0",
        ));
        assert!(matches!(&e, E::ZeroSamples { got: 0, .. }), "{e}");
        let e = err(&with_channel(
            "name = \"FE\"\ncan_id = 0x102\nsamples_per_frame = 32\nscale = 1.0\nsequence_byte = 0",
        ));
        assert!(matches!(&e, E::FrameTooShort { needed: 65, .. }), "{e}");
        let e = err(&with_channel(
            "name = \"FE\"\ncan_id = 0x102\nsamples_per_frame = 2\nscale = 1.0\nsequence_byte = 60",
        ));
        assert!(matches!(&e, E::FrameTooShort { needed: 65, .. }), "{e}");
        let e = err(&with_channel(
            "name = \"FE\"\ncan_id = 0x102\nsamples_per_frame = 9223372036854775807\nscale = 1.0",
        ));
        assert!(matches!(&e, E::FrameTooShort { .. }), "{e}");
        let e = err(&with_channel(
            "name = \"FE\"\ncan_id = 0x102\nsamples_per_frame = 2\nscale = 1.0\nsequence_byte = -1",
        ));
        assert!(matches!(&e, E::SequenceByte { got: -1, .. }), "{e}");
        for bad in ["nan", "inf", "-inf", "0.0", "1e-60", "1e60"] {
            let e = err(&with_channel(&format!(
                "name = \"FE\"\ncan_id = 0x102\nsamples_per_frame = 2\nscale = {bad}"
            )));
            assert!(matches!(&e, E::Scale { .. }), "{bad}: {e}");
        }
        let e = err(&with_channel(
            "name = \"FE\"\ncan_id = 0x800\nextended = false\nsamples_per_frame = 2\nscale = 1.0",
        ));
        assert!(
            matches!(
                &e,
                E::IdRange {
                    id: 0x800,
                    extended: false,
                    ..
                }
            ),
            "{e}"
        );
        let e = err(&with_channel(
            "name = \"FE\"\ncan_id = 0x20000000\nsamples_per_frame = 2\nscale = 1.0",
        ));
        assert!(matches!(&e, E::IdRange { extended: true, .. }), "{e}");
        let e = err(&with_channel(
            "name = \"FE\"\ncan_id = -1\nsamples_per_frame = 2\nscale = 1.0",
        ));
        assert!(matches!(&e, E::IdRange { id: -1, .. }), "{e}");
        let e = err(&with_channel(
            "name = \"  \"\ncan_id = 0x102\nsamples_per_frame = 2\nscale = 1.0",
        ));
        assert!(matches!(&e, E::EmptyName { index: 2 }), "{e}");
        // Misspelled and missing keys are TOML errors that name the key.
        let e = err(&with_channel(
            "name = \"FE\"\ncan_id = 0x102\nsamples_per_fram = 2\nscale = 1.0",
        ));
        assert!(
            matches!(&e, E::Toml(_)) && e.to_string().contains("samples_per_fram"),
            "{e}"
        );
        let e = err("[machine]\nrpm = 1797\nbearing = \"cwru-6205-de\"\nfs_hz = 12000\n");
        assert!(matches!(e, E::NoChannels), "{e}");
        let e = err("not toml at all [");
        assert!(matches!(e, E::Toml(_)), "{e}");
    }

    #[test]
    fn machine_errors() {
        use SensorMapError as E;
        let e = err(&GOOD.replace("rpm = 1797.0", "rpm = -5"));
        assert!(matches!(e, E::Rpm(_)), "{e}");
        let e = err(&GOOD.replace("rpm = 1797.0", "rpm = nan"));
        assert!(matches!(e, E::Rpm(_)), "{e}");
        let e = err(&GOOD.replace("fs_hz = 12000.0", "fs_hz = 1000"));
        assert!(matches!(e, E::SampleRate(_)), "{e}");
        let e = err(&GOOD.replace("\"cwru-6205-de\"", "\"skf-6309\""));
        assert!(matches!(&e, E::UnknownBearing(n) if n == "skf-6309"), "{e}");
        let e = err(&GOOD.replace("\"cwru-6205-de\"", "42"));
        assert!(matches!(e, E::BearingType(_)), "{e}");
        let e = err(&GOOD.replace("\"cwru-6205-de\"", "{ n = 9, d = 2.0, pitch = 1.0 }"));
        assert!(matches!(e, E::BearingGeometry(_)), "{e}");
        let e = err(&GOOD.replace("\"cwru-6205-de\"", "{ n = 9, d = 0.3 }"));
        assert!(
            matches!(e, E::BearingTable(_)) && e.to_string().contains("pitch"),
            "{e}"
        );
        let e = err(&GOOD.replace("\"cwru-6205-de\"", "{ n = 300, d = 0.3, pitch = 1.5 }"));
        assert!(matches!(e, E::BearingTable(_)), "{e}");
    }
}
