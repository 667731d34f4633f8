//! Slow sensors from a DBC file: shaft speed, temperature and pressure signals.
//!
//! The sensor map names the DBC file and, per role, the signal to read:
//!
//! ```toml
//! [dbc]
//! file = "pump.dbc"              # relative to the sensor map
//! rpm = "ShaftSpeed"             # optional; updates the shaft rate of the features
//! temperature = "BearingTemp"    # optional
//! pressure = "DischargePressure" # optional
//! ```
//!
//! A frame whose identifier is a DBC message carrying one of these signals is decoded
//! (Intel or Motorola bit order, signed or unsigned, `physical = raw · factor +
//! offset`, as the DBC says) and counted as `used`; a frame too short for a signal is
//! `malformed`. The latest value of each role goes into every window's line under
//! `"slow"`, and a valid speed (finite, > 0) replaces the map's nominal rpm for the
//! features of the following windows.

use std::path::{Path, PathBuf};

use can_dbc::{ByteOrder, Dbc, MessageId, ValueType};

use crate::candump::Frame;

/// The slow-signal roles.
pub const ROLES: [&str; 3] = ["rpm", "temperature", "pressure"];

/// Why the DBC part of a sensor map was rejected.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum DbcError {
    /// The DBC file cannot be read.
    #[error("cannot read DBC file {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The DBC file does not parse.
    #[error("DBC file {path} does not parse: {reason}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        reason: String,
    },
    /// A named signal is in no message of the file.
    #[error("DBC file {path} has no signal {signal:?} (for {role})")]
    NoSignal {
        /// The file.
        path: PathBuf,
        /// The role it was named for.
        role: &'static str,
        /// The name.
        signal: String,
    },
    /// A signal wider than 64 bits, or multiplexed (not supported for slow sensors).
    #[error("DBC signal {signal:?}: {reason}")]
    Unsupported {
        /// The signal.
        signal: String,
        /// Why.
        reason: &'static str,
    },
}

/// One signal to decode.
#[derive(Debug, Clone, PartialEq)]
pub struct SlowSignal {
    /// Role (`rpm`, `temperature`, `pressure`).
    pub role: &'static str,
    /// DBC signal name.
    pub name: String,
    /// Unit from the DBC.
    pub unit: String,
    id: u32,
    extended: bool,
    start_bit: u32,
    size: u32,
    motorola: bool,
    signed: bool,
    factor: f64,
    offset: f64,
}

impl SlowSignal {
    /// Its message's identifier.
    pub fn id(&self) -> u32 {
        self.id
    }

    /// Whether its message has a 29-bit identifier.
    pub fn extended(&self) -> bool {
        self.extended
    }

    /// Whether `frame` carries this signal.
    pub fn matches(&self, frame: &Frame) -> bool {
        frame.id == self.id && frame.extended == self.extended
    }

    /// The physical value in `data`, or `None` if the payload is too short.
    pub fn decode(&self, data: &[u8]) -> Option<f64> {
        let bit = |pos: u32| -> Option<u64> {
            let byte = data.get((pos / 8) as usize)?;
            Some(u64::from((byte >> (pos % 8)) & 1))
        };
        let mut raw = 0u64;
        if self.motorola {
            // DBC Motorola: start bit is the MSB; walk down within a byte, then to
            // bit 7 of the next byte.
            let mut pos = self.start_bit;
            for _ in 0..self.size {
                raw = (raw << 1) | bit(pos)?;
                pos = if pos % 8 == 0 { pos + 15 } else { pos - 1 };
            }
        } else {
            for i in 0..self.size {
                raw |= bit(self.start_bit + i)? << i;
            }
        }
        let value = if self.signed && self.size < 64 && raw >> (self.size - 1) & 1 == 1 {
            (raw | (u64::MAX << self.size)) as i64 as f64
        } else if self.signed {
            raw as i64 as f64
        } else {
            raw as f64
        };
        Some(value * self.factor + self.offset)
    }
}

/// The slow signals of a sensor map and their latest values.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SlowSignals {
    /// The signals.
    pub signals: Vec<SlowSignal>,
    /// Latest value per signal (same order), `None` until first seen.
    pub latest: Vec<Option<f64>>,
}

impl SlowSignals {
    /// Read `file` and pick the signals named per role (`(role, name)` pairs).
    ///
    /// # Errors
    /// [`DbcError`]: unreadable, unparsable, a name not in the file, a multiplexed or
    /// over-wide signal.
    pub fn load(file: &Path, names: &[(&'static str, String)]) -> Result<Self, DbcError> {
        let text = std::fs::read_to_string(file).map_err(|source| DbcError::Read {
            path: file.to_owned(),
            source,
        })?;
        Self::parse(&text, file, names)
    }

    /// [`SlowSignals::load`] on DBC text already read; `file` only names it in errors.
    ///
    /// # Errors
    /// Those of [`SlowSignals::load`] but [`DbcError::Read`].
    pub fn parse(
        text: &str,
        file: &Path,
        names: &[(&'static str, String)],
    ) -> Result<Self, DbcError> {
        let dbc = Dbc::try_from(text).map_err(|e| DbcError::Parse {
            path: file.to_owned(),
            reason: format!("{e:?}"),
        })?;
        let mut out = Self::default();
        for (role, name) in names {
            let found = dbc.messages.iter().find_map(|m| {
                m.signals
                    .iter()
                    .find(|s| &s.name == name)
                    .map(|s| (m.id, s))
            });
            let Some((id, s)) = found else {
                return Err(DbcError::NoSignal {
                    path: file.to_owned(),
                    role,
                    signal: name.clone(),
                });
            };
            if s.size == 0 || s.size > 64 || s.start_bit > 511 {
                return Err(DbcError::Unsupported {
                    signal: name.clone(),
                    reason: "size must be 1..=64 bits within a 64-byte frame",
                });
            }
            if !matches!(s.multiplexer_indicator, can_dbc::MultiplexIndicator::Plain) {
                return Err(DbcError::Unsupported {
                    signal: name.clone(),
                    reason: "multiplexed signals are not supported for slow sensors",
                });
            }
            let (id, extended) = match id {
                MessageId::Standard(i) => (u32::from(i), false),
                MessageId::Extended(i) => (i, true),
            };
            out.signals.push(SlowSignal {
                role,
                name: name.clone(),
                unit: s.unit.clone(),
                id,
                extended,
                start_bit: s.start_bit as u32,
                size: s.size as u32,
                motorola: s.byte_order == ByteOrder::BigEndian,
                signed: s.value_type == ValueType::Signed,
                factor: s.factor,
                offset: s.offset,
            });
            out.latest.push(None);
        }
        Ok(out)
    }

    /// Whether `frame` is a DBC message with a slow signal.
    pub fn matches(&self, frame: &Frame) -> bool {
        self.signals.iter().any(|s| s.matches(frame))
    }

    /// Decode every slow signal of `frame`; `false` if one did not fit its payload
    /// (the frame is malformed; values that did fit are kept).
    pub fn update(&mut self, frame: &Frame) -> bool {
        let mut ok = true;
        for (s, v) in self.signals.iter().zip(self.latest.iter_mut()) {
            if s.matches(frame) {
                match s.decode(&frame.data) {
                    Some(x) if x.is_finite() => *v = Some(x),
                    _ => ok = false,
                }
            }
        }
        ok
    }

    /// The latest value of `role`.
    pub fn value(&self, role: &str) -> Option<f64> {
        self.signals
            .iter()
            .zip(&self.latest)
            .find(|(s, _)| s.role == role)
            .and_then(|(_, v)| *v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DBC: &str = r#"VERSION ""

NS_ :

BS_:

BU_: PUMP

BO_ 1536 PumpSlow: 8 PUMP
 SG_ ShaftSpeed : 0|16@1+ (0.25,0) [0|16000] "rpm" Vector__XXX
 SG_ BearingTemp : 16|12@1- (0.1,-20) [-40|150] "degC" Vector__XXX
 SG_ DischargePressure : 39|16@0+ (0.001,0) [0|60] "bar" Vector__XXX

"#;

    fn frame(id: u32, data: &[u8]) -> Frame {
        let mut f = crate::candump::parse_line(b"(1.000000) can0 600#0000000000000000")
            .unwrap()
            .unwrap();
        f.id = id;
        f.data.clear();
        f.data.extend_from_slice(data).unwrap();
        f
    }

    #[test]
    fn intel_motorola_signed_and_scaled() {
        let dir = std::env::temp_dir().join(format!("pumptwin-dbc-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("pump.dbc");
        std::fs::write(&path, DBC).unwrap();
        let names = [
            ("rpm", "ShaftSpeed".to_string()),
            ("temperature", "BearingTemp".to_string()),
            ("pressure", "DischargePressure".to_string()),
        ];
        let mut s = SlowSignals::load(&path, &names).unwrap();
        // rpm 1797 → raw 7188 = 0x1C14 (Intel, LSB first)
        // temp 35.0 °C → raw (35 + 20)/0.1 = 550 = 0x226, 12-bit signed at bit 16
        // pressure 4.2 bar → raw 4200 = 0x1068, Motorola from bit 39 (byte 4 MSB)
        let mut d = [0u8; 8];
        d[0] = 0x14;
        d[1] = 0x1C;
        d[2] = 0x26;
        d[3] = 0x02;
        d[4] = 0x10;
        d[5] = 0x68;
        let f = frame(1536, &d);
        assert!(s.matches(&f));
        assert!(s.update(&f));
        assert!((s.value("rpm").unwrap() - 1797.0).abs() < 1e-9);
        assert!((s.value("temperature").unwrap() - 35.0).abs() < 1e-9);
        assert!((s.value("pressure").unwrap() - 4.2).abs() < 1e-9);
        // A negative temperature: −30 °C → raw −100 = 0xF9C in 12 bits.
        d[2] = 0x9C;
        d[3] = 0x0F;
        s.update(&frame(1536, &d));
        assert!((s.value("temperature").unwrap() + 30.0).abs() < 1e-9);
        // Too short: malformed, old values kept.
        assert!(!s.update(&frame(1536, &d[..2])));
        assert!((s.value("pressure").unwrap() - 4.2).abs() < 1e-9);
        // Unknown names and unparsable files are named errors.
        assert!(matches!(
            SlowSignals::load(&path, &[("rpm", "Nope".to_string())]),
            Err(DbcError::NoSignal { .. })
        ));
        std::fs::write(&path, "this is not a DBC file {{{").unwrap();
        assert!(matches!(
            SlowSignals::load(&path, &names),
            Err(DbcError::Parse { .. })
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
