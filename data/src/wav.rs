//! WAV recordings, as portable vibration collectors and sound cards write them.
//!
//! ```text
//! RIFF/WAVE (hound): channels, sample rate, integer 8–32 bit or float 32 bit
//!   → channel k of n named DE, FE, BA (the sensor map's first three nodes), then
//!     ch4, ch5, … (a file holds no channel names)
//!   → integers scaled to full scale ±1 (a WAV file holds no physical unit: the
//!     physical diagnosis reads ratios only; a network reads the level, so a
//!     recording in other units than the training data's g may need rescaling)
//!   → the sampling rate from the header; rpm from the caller
//! ```
//!
//! A truncated file, a header that does not parse, zero channels or a zero rate, a
//! non-finite float sample: a [`WavError`] naming it, never a panic and never a
//! silently shortened record (hound stops at the data chunk's declared end; a chunk
//! cut short is an error).

use std::io::Cursor;
use std::path::Path;

use crate::recording::{Channel, Recording};

/// What can go wrong reading a WAV file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WavError {
    /// The RIFF/WAVE structure or its sample data is malformed or cut short.
    #[error("malformed WAV: {0}")]
    Format(String),
    /// The header declares no channel or a zero sampling rate.
    #[error("WAV header declares {channels} channels at {rate} Hz")]
    Empty {
        /// Declared channels.
        channels: u16,
        /// Declared rate, Hz.
        rate: u32,
    },
    /// A float sample is NaN or infinite.
    #[error("non-finite sample at frame {frame}, channel {channel}")]
    NonFinite {
        /// Frame (sample index per channel).
        frame: usize,
        /// Channel.
        channel: usize,
    },
    /// The file holds no sample.
    #[error("WAV file holds no sample")]
    NoSamples,
}

/// The channel name of channel `k` (0-based).
pub fn channel_name(k: usize) -> String {
    match k {
        0 => "DE".to_string(),
        1 => "FE".to_string(),
        2 => "BA".to_string(),
        _ => format!("ch{}", k + 1),
    }
}

/// A WAV file's bytes as a recording named `name` at shaft speed `rpm`.
pub fn parse_wav(bytes: &[u8], name: &str, rpm: Option<f32>) -> Result<Recording, WavError> {
    let reader =
        hound::WavReader::new(Cursor::new(bytes)).map_err(|e| WavError::Format(e.to_string()))?;
    let spec = reader.spec();
    if spec.channels == 0 || spec.sample_rate == 0 {
        return Err(WavError::Empty {
            channels: spec.channels,
            rate: spec.sample_rate,
        });
    }
    let n_ch = usize::from(spec.channels);
    let samples: Vec<f32> = match spec.sample_format {
        hound::SampleFormat::Float => reader
            .into_samples::<f32>()
            .collect::<Result<_, _>>()
            .map_err(|e| WavError::Format(e.to_string()))?,
        hound::SampleFormat::Int => {
            let bits = spec.bits_per_sample.clamp(1, 32);
            let full = (1u64 << (bits - 1)) as f32;
            reader
                .into_samples::<i32>()
                .map(|s| s.map(|v| v as f32 / full))
                .collect::<Result<_, _>>()
                .map_err(|e| WavError::Format(e.to_string()))?
        }
    };
    if samples.is_empty() {
        return Err(WavError::NoSamples);
    }
    // hound reads whole frames only if the data chunk holds them; a partial last
    // frame is a malformed file, not a shorter channel.
    if samples.len() % n_ch != 0 {
        return Err(WavError::Format(format!(
            "{} samples do not fill whole frames of {n_ch} channels",
            samples.len()
        )));
    }
    let frames = samples.len() / n_ch;
    let mut channels: Vec<Channel> = (0..n_ch)
        .map(|k| Channel {
            name: channel_name(k),
            samples: Vec::with_capacity(frames),
        })
        .collect();
    for (i, &v) in samples.iter().enumerate() {
        if !v.is_finite() {
            return Err(WavError::NonFinite {
                frame: i / n_ch,
                channel: i % n_ch,
            });
        }
        channels[i % n_ch].samples.push(v);
    }
    Ok(Recording {
        name: name.to_string(),
        fs_hz: spec.sample_rate as f32,
        rpm,
        channels,
    })
}

/// The file's stem, the recording's name.
pub fn record_name(path: &Path) -> String {
    path.file_stem()
        .map_or_else(|| "wav".to_string(), |s| s.to_string_lossy().into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wav(spec: hound::WavSpec, frames: &[Vec<f32>]) -> Vec<u8> {
        let mut buf = Cursor::new(Vec::new());
        {
            let mut w = hound::WavWriter::new(&mut buf, spec).unwrap();
            for f in frames {
                for &v in f {
                    match spec.sample_format {
                        hound::SampleFormat::Float => w.write_sample(v).unwrap(),
                        hound::SampleFormat::Int => w
                            .write_sample(
                                (v * ((1i64 << (spec.bits_per_sample - 1)) as f32 - 1.0)) as i32,
                            )
                            .unwrap(),
                    }
                }
            }
            w.finalize().unwrap();
        }
        buf.into_inner()
    }

    #[test]
    fn channels_rate_and_scale_come_from_the_file() {
        let frames: Vec<Vec<f32>> = (0..100)
            .map(|i| vec![0.5 * (i as f32 * 0.1).sin(), -0.25, 0.125])
            .collect();
        for (bits, format) in [
            (16, hound::SampleFormat::Int),
            (24, hound::SampleFormat::Int),
            (32, hound::SampleFormat::Float),
        ] {
            let spec = hound::WavSpec {
                channels: 3,
                sample_rate: 25_600,
                bits_per_sample: bits,
                sample_format: format,
            };
            let r = parse_wav(&wav(spec, &frames), "r", Some(1797.0)).unwrap();
            assert_eq!(r.fs_hz, 25_600.0);
            let names: Vec<&str> = r.channels.iter().map(|c| c.name.as_str()).collect();
            assert_eq!(names, ["DE", "FE", "BA"]);
            assert_eq!(r.len(), 100);
            for (k, f) in frames.iter().enumerate() {
                for (c, &v) in f.iter().enumerate() {
                    assert!((r.channels[c].samples[k] - v).abs() < 1e-4, "{bits} bit");
                }
            }
            r.validate().unwrap();
        }
    }

    #[test]
    fn bad_files_are_errors_not_panics() {
        let spec = hound::WavSpec {
            channels: 2,
            sample_rate: 12_000,
            bits_per_sample: 32,
            sample_format: hound::SampleFormat::Float,
        };
        let good = wav(spec, &vec![vec![0.1, 0.2]; 50]);
        assert!(parse_wav(&good, "r", None).is_ok());
        // Every truncation: an error (or, where the cut leaves whole frames only of a
        // data chunk hound accepts, never a ragged or panicking read).
        for n in 0..good.len() {
            if let Ok(r) = parse_wav(&good[..n], "r", None) {
                assert_eq!(r.channels[0].samples.len(), r.channels[1].samples.len());
            }
        }
        let mut nan = wav(spec, &vec![vec![0.1, 0.2]; 4]);
        let at = nan.len() - 4;
        nan[at..].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(matches!(
            parse_wav(&nan, "r", None),
            Err(WavError::NonFinite {
                frame: 3,
                channel: 1
            })
        ));
        assert!(matches!(
            parse_wav(b"RIFF", "r", None),
            Err(WavError::Format(_))
        ));
        assert!(matches!(
            parse_wav(&wav(spec, &[]), "r", None),
            Err(WavError::NoSamples)
        ));
    }
}
