//! A measured recording: channels of samples at one rate, and the checks every
//! consumer relies on. Plain types: the loaders ([`crate::record`], [`crate::csv`]) make
//! one, preprocessing and featurization read one.

/// CWRU channel names in the order a [`Recording`] lists them.
pub const CWRU_CHANNELS: [&str; 3] = ["DE", "FE", "BA"];

/// One sensor's samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// `DE`, `FE`, `BA` for CWRU data; the header name for CSV.
    pub name: String,
    /// Samples (accelerations, in g for CWRU) at the recording's rate.
    pub samples: Vec<f32>,
}

/// Simultaneously sampled channels of one measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// Name (file stem, e.g. `105`).
    pub name: String,
    /// Sampling rate in Hz.
    pub fs_hz: f32,
    /// Shaft speed in rpm, if known.
    pub rpm: Option<f32>,
    /// Channels, all of the same length.
    pub channels: Vec<Channel>,
}

impl Recording {
    /// Samples per channel (0 without channels).
    pub fn len(&self) -> usize {
        self.channels.first().map_or(0, |c| c.samples.len())
    }

    /// Whether the recording holds no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Duration in seconds.
    pub fn duration_s(&self) -> f64 {
        self.len() as f64 / f64::from(self.fs_hz)
    }

    /// The channel called `name`, if present.
    pub fn channel(&self, name: &str) -> Option<&Channel> {
        self.channels.iter().find(|c| c.name == name)
    }

    /// Check what every consumer relies on: a positive finite rate (and speed), at
    /// least one channel, equal channel lengths, and finite samples.
    pub fn validate(&self) -> Result<(), RecordingError> {
        check_positive("fs_hz", self.fs_hz)?;
        if let Some(rpm) = self.rpm {
            check_positive("rpm", rpm)?;
        }
        let Some(first) = self.channels.first() else {
            return Err(RecordingError::NoChannels {
                record: self.name.clone(),
                present: String::new(),
            });
        };
        if self
            .channels
            .iter()
            .any(|c| c.samples.len() != first.samples.len())
        {
            return Err(RecordingError::UnequalChannelLengths {
                record: self.name.clone(),
                lengths: self
                    .channels
                    .iter()
                    .map(|c| format!("{} {}", c.name, c.samples.len()))
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        for c in &self.channels {
            if let Some(index) = c.samples.iter().position(|x| !x.is_finite()) {
                return Err(RecordingError::NonFiniteSample {
                    record: self.name.clone(),
                    channel: c.name.clone(),
                    index,
                    value: f64::from(c.samples[index]),
                });
            }
        }
        Ok(())
    }
}

/// A recording that breaks what every consumer relies on (a loader's
/// [`crate::record::DataError::Invalid`]).
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// A parameter is not a positive finite number.
    #[error("{what} must be a positive finite number, got {value}")]
    InvalidParameter {
        /// Which parameter.
        what: &'static str,
        /// The value.
        value: f32,
    },
    /// No channel variables were found.
    #[error(
        "{record}: no channels found (looked for X<nnn>_DE_time, _FE_time, _BA_time); \
         variables present: [{present}]"
    )]
    NoChannels {
        /// Recording name.
        record: String,
        /// Names of the variables that are present.
        present: String,
    },
    /// A sample is NaN or infinite (or overflows `f32`).
    #[error("{record}: channel {channel}: sample {index} is not finite ({value})")]
    NonFiniteSample {
        /// Recording name.
        record: String,
        /// Channel name.
        channel: String,
        /// 0-based sample index.
        index: usize,
        /// The value as read.
        value: f64,
    },
    /// Channels of one recording differ in length.
    #[error("{record}: channels differ in length ({lengths})")]
    UnequalChannelLengths {
        /// Recording name.
        record: String,
        /// `name length` per channel.
        lengths: String,
    },
}

pub(crate) fn check_positive(what: &'static str, value: f32) -> Result<(), RecordingError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(RecordingError::InvalidParameter { what, value })
    }
}
