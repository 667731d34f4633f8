//! A file's own channels → a [`Recording`]: the one path every self-describing format
//! (NI TDMS, universal file format 58) takes after its parser, so that naming, units,
//! rates and selection behave the same whatever wrote the file.
//!
//! ```text
//! FileChannel { name as the file says, unit, rate, samples }   (the parser's output)
//!   → selection: none given → every channel, each named as its sensor where its name
//!     names exactly one of DE/FE/BA as a token (`accel DE`, `DE_acc`); else the
//!     file's name; `--var DE=NAME` pairs → exactly those channels, renamed
//!   → units: a sensor channel with an acceleration unit (g, mg, m/s², mm/s²) is
//!     brought to g; a sensor channel with another unit (V, m/s) is an error (it is
//!     not an acceleration); no unit → taken as g
//!   → rate: every channel's must agree (within 1e-6), a rate given must agree with
//!     the file's (within 0.1 %); no rate anywhere → an error, never a default
//!   → equal lengths, finite samples (a NaN names its channel and index)
//! ```

use crate::recording::{Channel, Recording};

/// The sensor names a channel may carry.
pub(crate) const SENSORS: [&str; 3] = ["DE", "FE", "BA"];

/// Standard gravity, m/s² per g.
const G_M_PER_S2: f64 = 9.806_65;

/// One channel as a file describes it.
#[derive(Debug, Clone, PartialEq)]
pub struct FileChannel {
    /// The file's name for it (TDMS: the channel, or `group/channel` when two groups
    /// share it; UFF: the set's first ID line).
    pub name: String,
    /// The unit the file gives, if any.
    pub unit: Option<String>,
    /// Its sampling rate, Hz, if the file gives one.
    pub fs_hz: Option<f64>,
    /// Samples, as stored.
    pub samples: Vec<f32>,
}

/// What can go wrong turning a file's channels into a recording.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum ChannelsError {
    /// The file holds no channel with samples.
    #[error("the file holds no channel with samples")]
    NoChannels,
    /// A channel asked for is not in the file.
    #[error("no channel `{wanted}` (for {channel}); channels present: [{present}]")]
    Missing {
        /// The channel it was to fill.
        channel: String,
        /// The file's name asked for.
        wanted: String,
        /// The file's channel names.
        present: String,
    },
    /// A sensor channel's unit is not an acceleration.
    #[error("channel `{channel}`: unit `{unit}` is not an acceleration (g, mg, m/s², mm/s²)")]
    NotAcceleration {
        /// The channel.
        channel: String,
        /// Its unit.
        unit: String,
    },
    /// Two channels declare different rates.
    #[error("channels `{a}` and `{b}` are sampled at different rates ({fs_a} and {fs_b} Hz)")]
    MixedRates {
        /// One channel.
        a: String,
        /// Its rate.
        fs_a: f64,
        /// Another.
        b: String,
        /// Its rate.
        fs_b: f64,
    },
    /// A rate given disagrees with the file's.
    #[error("--fs {given} Hz disagrees with the file's {file} Hz")]
    RateMismatch {
        /// The rate given.
        given: f32,
        /// The file's.
        file: f64,
    },
    /// Neither the file nor the caller gives a rate.
    #[error("sampling rate unknown: the file gives none; pass it explicitly (e.g. --fs 25600)")]
    MissingRate,
    /// Channels of different lengths.
    #[error("channel `{a}` holds {len_a} samples, `{b}` {len_b}: not one simultaneous recording")]
    Lengths {
        /// One channel.
        a: String,
        /// Its length.
        len_a: usize,
        /// Another.
        b: String,
        /// Its length.
        len_b: usize,
    },
    /// Two channels carry the same name (e.g. two UFF sets with the same ID line).
    #[error("two channels are named `{0}`: name them apart (--var picks by the file's name)")]
    Duplicate(String),
    /// A channel holds no sample.
    #[error("channel `{0}` holds no sample")]
    Empty(String),
    /// A sample is NaN or infinite.
    #[error("channel `{channel}`: non-finite sample at index {index}")]
    NonFinite {
        /// The channel.
        channel: String,
        /// Sample index.
        index: usize,
    },
}

/// g per unit of an acceleration unit (`g`, `mg`, `m/s²` in its usual spellings,
/// `mm/s²`), `None` for anything else.
pub(crate) fn g_per_unit(unit: &str) -> Option<f64> {
    let u: String = unit
        .chars()
        .filter(|c| !matches!(c, ' ' | '^' | '*' | '·' | '.'))
        .map(|c| {
            if c == '²' {
                '2'
            } else {
                c.to_ascii_lowercase()
            }
        })
        .collect();
    match u.as_str() {
        "g" | "gn" => Some(1.0),
        "mg" => Some(1e-3),
        "m/s2" | "ms-2" | "m/s/s" => Some(1.0 / G_M_PER_S2),
        "mm/s2" | "mms-2" => Some(1e-3 / G_M_PER_S2),
        _ => None,
    }
}

/// The sensor each name names (one of DE/FE/BA as a `_`/`-`/space/`.` token, in any
/// case, unique among the names and not already another's name), or the name itself.
pub(crate) fn sensor_names(names: Vec<String>) -> Vec<String> {
    // The one sensor the name's tokens name (none, or two different ones: None).
    let sensor = |n: &str| -> Option<&'static str> {
        let mut found = n
            .split(['_', '-', ' ', '.'])
            .filter_map(|token| SENSORS.into_iter().find(|s| token.eq_ignore_ascii_case(s)));
        let first = found.next()?;
        found.all(|s| s == first).then_some(first)
    };
    let mapped: Vec<Option<&str>> = names.iter().map(|n| sensor(n)).collect();
    names
        .iter()
        .zip(&mapped)
        .map(|(n, m)| match m {
            // Unique among the columns, and no other column already has that name.
            Some(s)
                if mapped.iter().filter(|o| *o == m).count() == 1
                    && !names.iter().any(|o| o == s && o != n) =>
            {
                (*s).to_string()
            }
            _ => n.clone(),
        })
        .collect()
}

/// The file's channels, selected and named: every one under its sensor name when
/// `select` is empty, else exactly the `(channel, file name)` pairs asked for (the
/// file name matched exactly, else in any case when that is unique).
fn select(
    channels: Vec<FileChannel>,
    select: &[(String, String)],
) -> Result<Vec<FileChannel>, ChannelsError> {
    if select.is_empty() {
        let names = sensor_names(channels.iter().map(|c| c.name.clone()).collect());
        return Ok(channels
            .into_iter()
            .zip(names)
            .map(|(c, name)| FileChannel { name, ..c })
            .collect());
    }
    let present = || {
        channels
            .iter()
            .map(|c| c.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut out = Vec::with_capacity(select.len());
    for (channel, wanted) in select {
        let exact = channels.iter().find(|c| &c.name == wanted);
        let folded = || {
            let mut any = channels
                .iter()
                .filter(|c| c.name.eq_ignore_ascii_case(wanted));
            any.next().filter(|_| any.next().is_none())
        };
        let found = exact
            .or_else(folded)
            .ok_or_else(|| ChannelsError::Missing {
                channel: channel.clone(),
                wanted: wanted.clone(),
                present: present(),
            })?;
        out.push(FileChannel {
            name: channel.clone(),
            ..found.clone()
        });
    }
    Ok(out)
}

/// The one rate of the channels, checked against a rate given.
fn common_rate(channels: &[FileChannel], given: Option<f32>) -> Result<f32, ChannelsError> {
    let mut file: Option<(&str, f64)> = None;
    for c in channels {
        let Some(fs) = c.fs_hz else { continue };
        match file {
            None => file = Some((&c.name, fs)),
            Some((a, fs_a)) if (fs - fs_a).abs() > 1e-6 * fs_a => {
                return Err(ChannelsError::MixedRates {
                    a: a.to_string(),
                    fs_a,
                    b: c.name.clone(),
                    fs_b: fs,
                })
            }
            Some(_) => {}
        }
    }
    match (given, file) {
        (Some(g), Some((_, f))) if (f64::from(g) - f).abs() > 1e-3 * f => {
            Err(ChannelsError::RateMismatch { given: g, file: f })
        }
        // A rate given that agrees with the file's confirms it; the file's stands.
        (_, Some((_, f))) => Ok(f as f32),
        (Some(g), None) => Ok(g),
        (None, None) => Err(ChannelsError::MissingRate),
    }
}

/// A sensor channel's samples in g (module docs).
fn to_g(c: FileChannel) -> Result<Channel, ChannelsError> {
    let is_sensor = SENSORS.contains(&c.name.as_str());
    let scale = match (&c.unit, is_sensor) {
        (Some(u), true) => g_per_unit(u).ok_or_else(|| ChannelsError::NotAcceleration {
            channel: c.name.clone(),
            unit: u.clone(),
        })?,
        _ => 1.0,
    };
    if let Some(index) = c.samples.iter().position(|v| !v.is_finite()) {
        return Err(ChannelsError::NonFinite {
            channel: c.name,
            index,
        });
    }
    let mut samples = c.samples;
    if scale != 1.0 {
        samples
            .iter_mut()
            .for_each(|v| *v = (f64::from(*v) * scale) as f32);
    }
    Ok(Channel {
        name: c.name,
        samples,
    })
}

/// The recording `name` a file's channels make (module docs); `fs_hz` a rate given,
/// `rpm` the speed (a file of these formats holds none).
pub fn assemble(
    name: &str,
    channels: Vec<FileChannel>,
    selection: &[(String, String)],
    fs_hz: Option<f32>,
    rpm: Option<f32>,
) -> Result<Recording, ChannelsError> {
    if channels.is_empty() {
        return Err(ChannelsError::NoChannels);
    }
    for (i, c) in channels.iter().enumerate() {
        if c.samples.is_empty() {
            return Err(ChannelsError::Empty(c.name.clone()));
        }
        if channels[..i].iter().any(|o| o.name == c.name) {
            return Err(ChannelsError::Duplicate(c.name.clone()));
        }
    }
    let chosen = select(channels, selection)?;
    let fs_hz = common_rate(&chosen, fs_hz)?;
    if let Some(first) = chosen.first() {
        if let Some(other) = chosen
            .iter()
            .find(|c| c.samples.len() != first.samples.len())
        {
            return Err(ChannelsError::Lengths {
                a: first.name.clone(),
                len_a: first.samples.len(),
                b: other.name.clone(),
                len_b: other.samples.len(),
            });
        }
    }
    let channels = chosen.into_iter().map(to_g).collect::<Result<_, _>>()?;
    Ok(Recording {
        name: name.to_string(),
        fs_hz,
        rpm,
        channels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ch(name: &str, unit: Option<&str>, fs: Option<f64>, samples: &[f32]) -> FileChannel {
        FileChannel {
            name: name.to_string(),
            unit: unit.map(str::to_string),
            fs_hz: fs,
            samples: samples.to_vec(),
        }
    }

    #[test]
    fn names_units_and_rates_come_from_the_file() {
        let chans = vec![
            ch("accel DE", Some("m/s^2"), Some(25_600.0), &[9.80665, 0.0]),
            ch("Accel FE", Some("g"), Some(25_600.0), &[0.5, 0.25]),
            ch("tacho", Some("V"), None, &[1.0, 0.0]),
        ];
        let r = assemble("r", chans.clone(), &[], None, Some(1500.0)).unwrap();
        let names: Vec<&str> = r.channels.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["DE", "FE", "tacho"]);
        assert!((r.channels[0].samples[0] - 1.0).abs() < 1e-6);
        assert_eq!(r.channels[2].samples, [1.0, 0.0]);
        assert_eq!(r.fs_hz, 25_600.0);
        // Selected by the file's name (exact, else in any case), renamed.
        let pick = [("DE".to_string(), "accel fe".to_string())];
        let r = assemble("r", chans.clone(), &pick, Some(25_600.0), None).unwrap();
        assert_eq!(r.channels.len(), 1);
        assert_eq!(
            (r.channels[0].name.as_str(), r.channels[0].samples[0]),
            ("DE", 0.5)
        );
        // A volt channel named as a sensor is not an acceleration.
        let pick = [("DE".to_string(), "tacho".to_string())];
        assert!(matches!(
            assemble("r", chans.clone(), &pick, Some(1.0), None),
            Err(ChannelsError::NotAcceleration { .. })
        ));
        let pick = [("DE".to_string(), "nope".to_string())];
        let err = assemble("r", chans.clone(), &pick, None, None).unwrap_err();
        assert!(
            err.to_string().contains("accel DE, Accel FE, tacho"),
            "{err}"
        );
        assert!(matches!(
            assemble("r", chans, &[], Some(12_000.0), None),
            Err(ChannelsError::RateMismatch { .. })
        ));
    }

    #[test]
    fn what_cannot_be_one_recording_is_refused() {
        let a = ch("DE", None, Some(1000.0), &[0.0, 1.0]);
        let b = ch("FE", None, Some(2000.0), &[0.0, 1.0]);
        assert!(matches!(
            assemble("r", vec![a.clone(), b], &[], None, None),
            Err(ChannelsError::MixedRates { .. })
        ));
        let short = ch("FE", None, None, &[0.0]);
        assert!(matches!(
            assemble("r", vec![a.clone(), short], &[], None, None),
            Err(ChannelsError::Lengths { .. })
        ));
        let nan = ch("FE", None, None, &[0.0, f32::NAN]);
        assert_eq!(
            assemble("r", vec![a, nan], &[], None, None),
            Err(ChannelsError::NonFinite {
                channel: "FE".into(),
                index: 1
            })
        );
        let no_rate = ch("DE", None, None, &[0.0]);
        assert_eq!(
            assemble("r", vec![no_rate], &[], None, None),
            Err(ChannelsError::MissingRate)
        );
        assert_eq!(
            assemble("r", vec![], &[], Some(1.0), None),
            Err(ChannelsError::NoChannels)
        );
        let a = ch("DE", None, Some(1000.0), &[0.0, 1.0]);
        assert_eq!(
            assemble("r", vec![a.clone(), a.clone()], &[], None, None),
            Err(ChannelsError::Duplicate("DE".into()))
        );
        assert_eq!(
            assemble("r", vec![ch("DE", None, Some(1.0), &[])], &[], None, None),
            Err(ChannelsError::Empty("DE".into()))
        );
        // A rate given within 0.1 % confirms the file's, which stands.
        let r = assemble("r", vec![a], &[], Some(1000.5), None).unwrap();
        assert_eq!(r.fs_hz, 1000.0);
    }
}
