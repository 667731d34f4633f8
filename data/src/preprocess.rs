//! Bring every recording to the model rate with the same band limit.
//!
//! Two jobs, done by the core's zero-phase FIR ([`pumptwin_core::fir`]) so host and
//! edge filter identically:
//!
//! 1. **Rate.** A recording at an integer multiple `M` of the model rate (CWRU's
//!    48 kHz normal record, `M = 4`, for the 12 kHz model) is low-passed and every
//!    `M`-th sample kept. A non-integer ratio `r` (25.6, 44.1, 64 or 97.656 kHz →
//!    12 kHz) goes through [`Resampler`]: the same Blackman-windowed sinc,
//!    evaluated at the fractional source positions `m·r` (a table of the kernel,
//!    512 steps per source sample, linearly interpolated), each output normalized
//!    by its weights' sum so that every phase passes DC at gain 1. At an integer
//!    `r` it reproduces the decimator (tested). Recordings slower than the model
//!    rate are refused (upsampling cannot create the missing band), and so are
//!    rates above [`MAX_RATE_RATIO`] times the model rate (a wrong `--fs`, not an
//!    acquisition: the filter grows with the ratio).
//! 2. **Common band limit** ([`BAND_LIMIT_HZ`], 5 kHz by default). The guard against
//!    an acquisition shortcut: the CWRU normal record reaches 12 kHz through a
//!    different chain (48 kHz) and carries far more energy above 5.5 kHz than the
//!    12 kHz fault records, so a classifier can tell "normal" from the sampling chain
//!    instead of from the bearing. Low-passing every channel of every record at the
//!    same cutoff removes that cue.
//!
//! One cutoff for every record, whatever its source rate:
//!
//! ```text
//! f_c = min(band_limit, 0.45 · fs_model)          (5000 Hz at 12 kHz)
//! L   = L0 · M, plus 1 when that is even           (L0 = 101 taps at the model rate)
//! ```
//!
//! The 0.45 factor keeps the anti-alias stop band (f_c plus half the transition
//! width) below the model Nyquist frequency. The tap count scales with `M` because the
//! transition width of the Blackman-windowed sinc is about `5.5 · fs / L` Hz: with
//! `L = L0 · M` taps at `fs = M · fs_model` a decimated record gets the same
//! transition width in hertz (≈ 650 Hz) as a native-rate record filtered with `L0`
//! taps. A decimated record is therefore filtered **once**, by this anti-alias filter,
//! which *is* its band limit; filtering it again at the model rate would attenuate
//! the band just below f_c twice (gain 0.25 instead of 0.5 at f_c) and create a new
//! difference between 48 kHz and 12 kHz records, the very thing the band limit is
//! there to remove. A native-rate record gets the `L0`-tap filter at f_c.

use pumptwin_core::fir::{
    decimated_len, design_lowpass, filter_decimate, mirror_index, BAND_LIMIT_HZ,
};

use crate::recording::{Channel, Recording};

/// Default model sampling rate in Hz.
pub const MODEL_FS_HZ: f32 = 12_000.0;

/// Default filter length at the model rate, and the highest cutoff as a fraction of
/// the model rate (the edge's streaming filter uses the same, from the core).
pub use pumptwin_core::fir::{BAND_LIMIT_TAPS, MAX_CUTOFF_FRACTION};

/// How recordings are brought to the model rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreprocessConfig {
    /// Model sampling rate in Hz.
    pub target_fs_hz: f32,
    /// Common band limit in Hz; `None` turns it off (only for the ablation that shows
    /// the acquisition shortcut — decimated records are then still anti-aliased at
    /// `0.45 · target_fs_hz`).
    pub band_limit_hz: Option<f32>,
    /// Filter length at the model rate (odd, ≥ 3); scaled by the decimation factor.
    pub taps: usize,
}

impl Default for PreprocessConfig {
    fn default() -> Self {
        Self {
            target_fs_hz: MODEL_FS_HZ,
            band_limit_hz: Some(BAND_LIMIT_HZ),
            taps: BAND_LIMIT_TAPS,
        }
    }
}

/// Errors preprocessing a recording.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum PreprocessError {
    /// The source rate is not an integer multiple of the model rate.
    #[error(
        "resampling from {fs_hz} Hz to {target_fs_hz} Hz is a non-integer ratio ({ratio:.4}); \
         only integer decimation is supported for now — record at an integer multiple \
         of the model rate"
    )]
    NonIntegerRatio {
        /// Source rate.
        fs_hz: f32,
        /// Model rate.
        target_fs_hz: f32,
        /// `fs_hz / target_fs_hz`.
        ratio: f64,
    },
    /// The source rate is below the model rate.
    #[error("{fs_hz} Hz is below the model rate {target_fs_hz} Hz; upsampling is not supported")]
    Upsampling {
        /// Source rate.
        fs_hz: f32,
        /// Model rate.
        target_fs_hz: f32,
    },
    /// The source rate is implausibly far above the model rate.
    #[error(
        "{fs_hz} Hz is more than {MAX_RATE_RATIO} times the model rate {target_fs_hz} Hz; \
         check the sampling rate, or decimate the recording first"
    )]
    TooFast {
        /// Source rate.
        fs_hz: f32,
        /// Model rate.
        target_fs_hz: f32,
    },
    /// The configuration is unusable.
    #[error("bad preprocessing configuration: {reason}")]
    BadConfig {
        /// What is wrong.
        reason: String,
    },
    /// A channel has no samples.
    #[error("channel {channel} is empty")]
    EmptyChannel {
        /// Channel name.
        channel: String,
    },
    /// The core filter refused a channel (e.g. a non-finite sample).
    #[error("cannot filter channel {channel}")]
    Filter {
        /// Channel name.
        channel: String,
        /// The core's error.
        #[source]
        source: pumptwin_core::Error,
    },
}

/// Largest source rate, as a multiple of the model rate, that is brought down (768 kHz
/// for the 12 kHz model).
pub const MAX_RATE_RATIO: f64 = 64.0;

/// The decimation factor `M = fs / target` for an integer ratio.
pub fn decimation_factor(fs_hz: f32, target_fs_hz: f32) -> Result<usize, PreprocessError> {
    if !(fs_hz.is_finite() && fs_hz > 0.0 && target_fs_hz.is_finite() && target_fs_hz > 0.0) {
        return Err(PreprocessError::BadConfig {
            reason: format!(
                "rates must be positive and finite (source {fs_hz} Hz, model {target_fs_hz} Hz)"
            ),
        });
    }
    let ratio = f64::from(fs_hz) / f64::from(target_fs_hz);
    if ratio > MAX_RATE_RATIO {
        return Err(PreprocessError::TooFast {
            fs_hz,
            target_fs_hz,
        });
    }
    let factor = ratio.round();
    if (ratio - factor).abs() > 1e-6 * ratio {
        if ratio < 1.0 {
            return Err(PreprocessError::Upsampling {
                fs_hz,
                target_fs_hz,
            });
        }
        return Err(PreprocessError::NonIntegerRatio {
            fs_hz,
            target_fs_hz,
            ratio,
        });
    }
    if factor < 1.0 {
        return Err(PreprocessError::Upsampling {
            fs_hz,
            target_fs_hz,
        });
    }
    Ok(factor as usize)
}

/// Samples per channel at the model rate for `n` samples at `fs_hz`.
pub fn model_rate_len(
    n: usize,
    fs_hz: f32,
    cfg: &PreprocessConfig,
) -> Result<usize, PreprocessError> {
    match decimation_factor(fs_hz, cfg.target_fs_hz) {
        Ok(m) => Ok(decimated_len(n, m)),
        Err(PreprocessError::NonIntegerRatio { ratio, .. }) => Ok(resampled_len(n, ratio)),
        Err(e) => Err(e),
    }
}

/// Output length of [`Resampler::apply`] for `n` source samples: the output times
/// `m·r` that lie on the record, `0 ≤ m·r ≤ n − 1` (at an integer `r`,
/// [`decimated_len`]).
pub fn resampled_len(n: usize, ratio: f64) -> usize {
    if n == 0 {
        0
    } else {
        ((n - 1) as f64 / ratio).floor() as usize + 1
    }
}

/// Kernel table steps per source sample.
const TABLE_STEPS: usize = 512;

/// Rate change by a non-integer ratio: the decimator's windowed-sinc low-pass,
/// evaluated at fractional positions (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Resampler {
    /// Source samples per output sample, `fs / target`.
    pub ratio: f64,
    /// Kernel half-width in source samples, `(L − 1) / 2` for the decimator's `L`.
    half_width: usize,
    /// The kernel at `|τ| = i / TABLE_STEPS` source samples, `i = 0 ..= half_width · TABLE_STEPS`
    /// (unnormalized: each output divides by its weights' sum).
    table: Vec<f32>,
}

impl Resampler {
    /// The resampler from `fs_hz` by `ratio` with cutoff `cutoff_hz`, with the
    /// decimator's length rule: `taps_at_model · ratio` taps, made odd.
    pub fn new(
        ratio: f64,
        cutoff_hz: f32,
        fs_hz: f32,
        taps_at_model: usize,
    ) -> Result<Self, PreprocessError> {
        let fc = f64::from(cutoff_hz) / f64::from(fs_hz);
        if !(ratio.is_finite() && (1.0..=MAX_RATE_RATIO).contains(&ratio) && fc > 0.0 && fc < 0.5) {
            return Err(PreprocessError::BadConfig {
                reason: format!(
                    "resampling ratio {ratio} with cutoff {cutoff_hz} Hz at {fs_hz} Hz"
                ),
            });
        }
        let len = (taps_at_model.max(3) as f64 * ratio).round() as usize;
        let len = len + (1 - len % 2);
        let half_width = (len - 1) / 2;
        // The decimator's kernel (the core's windowed sinc), designed at TABLE_STEPS
        // times the source rate over the same span in seconds: its right half is the
        // kernel at every TABLE_STEPS-th of a source sample.
        let mut fine = vec![0.0f32; 2 * half_width * TABLE_STEPS + 1];
        design_lowpass(cutoff_hz, fs_hz * TABLE_STEPS as f32, &mut fine).map_err(|source| {
            PreprocessError::Filter {
                channel: "(design)".into(),
                source,
            }
        })?;
        let table = fine.split_off(half_width * TABLE_STEPS);
        Ok(Self {
            ratio,
            half_width,
            table,
        })
    }

    /// The kernel at offset `tau` source samples (0 beyond the half-width).
    fn weight(&self, tau: f64) -> f64 {
        let p = tau.abs() * TABLE_STEPS as f64;
        let i = p.floor() as usize;
        match (self.table.get(i), self.table.get(i + 1)) {
            (Some(&a), Some(&b)) => f64::from(a) + f64::from(b - a) * (p - i as f64),
            (Some(&a), None) if p == i as f64 => f64::from(a),
            _ => 0.0,
        }
    }

    /// Resample one channel: `y[m] = Σ_n h(m·r − n)·x[n] / Σ_n h(m·r − n)`, the record
    /// extended by mirror reflection at both ends (as the decimator does).
    pub fn apply(&self, x: &[f32]) -> Result<Vec<f32>, pumptwin_core::Error> {
        if x.is_empty() {
            return Err(pumptwin_core::Error::BufferSize {
                expected: 1,
                got: 0,
            });
        }
        if x.iter().any(|v| !v.is_finite()) {
            return Err(pumptwin_core::Error::NonFinite);
        }
        let hw = self.half_width as isize;
        Ok((0..resampled_len(x.len(), self.ratio))
            .map(|m| {
                let t = m as f64 * self.ratio;
                let centre = t.floor() as isize;
                let (mut acc, mut sum) = (0.0f64, 0.0f64);
                for j in centre - hw..=centre + hw + 1 {
                    let w = self.weight(t - j as f64);
                    acc += w * f64::from(x[mirror_index(j, x.len())]);
                    sum += w;
                }
                (acc / sum) as f32
            })
            .collect())
    }
}

/// The one low-pass for a source rate: cutoff, taps, decimation factor.
#[derive(Debug, Clone, PartialEq)]
pub struct FilterPlan {
    /// Decimation factor `M`.
    pub factor: usize,
    /// Cutoff in Hz, `None` when nothing is filtered (native rate, no band limit).
    pub cutoff_hz: Option<f32>,
    /// Filter taps at the source rate (empty when `cutoff_hz` is `None`, or when
    /// `resampler` does the work).
    pub taps: Vec<f32>,
    /// For a non-integer ratio (then `factor` is 1 and `taps` empty).
    pub resampler: Option<Resampler>,
}

impl FilterPlan {
    /// Design the filter for recordings at `fs_hz` (see the module docs).
    pub fn new(fs_hz: f32, cfg: &PreprocessConfig) -> Result<Self, PreprocessError> {
        if cfg.taps < 3 || cfg.taps % 2 == 0 {
            return Err(PreprocessError::BadConfig {
                reason: format!("filter length {} must be odd and at least 3", cfg.taps),
            });
        }
        let anti_alias = MAX_CUTOFF_FRACTION * cfg.target_fs_hz;
        // An integer factor, or the ratio the resampler takes.
        let rate = match decimation_factor(fs_hz, cfg.target_fs_hz) {
            Ok(m) => Ok(m),
            Err(PreprocessError::NonIntegerRatio { ratio, .. }) => Err(ratio),
            Err(e) => return Err(e),
        };
        // One cutoff rule for both: nothing to filter only at the native rate without a
        // band limit; otherwise the band limit, never above the anti-alias cutoff.
        let cutoff_hz = match (cfg.band_limit_hz, rate) {
            (None, Ok(1)) => None,
            (None, _) => Some(anti_alias),
            (Some(b), _) if b.is_finite() && b > 0.0 => Some(b.min(anti_alias)),
            (Some(b), _) => {
                return Err(PreprocessError::BadConfig {
                    reason: format!("band limit {b} Hz must be positive and finite"),
                })
            }
        };
        let factor = match (rate, cutoff_hz) {
            (Ok(m), _) => m,
            (Err(ratio), fc) => {
                let fc = fc.unwrap_or(anti_alias);
                return Ok(Self {
                    factor: 1,
                    cutoff_hz: Some(fc),
                    taps: Vec::new(),
                    resampler: Some(Resampler::new(ratio, fc, fs_hz, cfg.taps)?),
                });
            }
        };
        let taps = match cutoff_hz {
            None => Vec::new(),
            Some(fc) => {
                let len =
                    cfg.taps
                        .checked_mul(factor)
                        .ok_or_else(|| PreprocessError::BadConfig {
                            reason: format!("{} taps × factor {factor} overflows", cfg.taps),
                        })?;
                let len = len + (1 - len % 2);
                let mut taps = vec![0.0f32; len];
                design_lowpass(fc, fs_hz, &mut taps).map_err(|source| PreprocessError::Filter {
                    channel: "(design)".into(),
                    source,
                })?;
                taps
            }
        };
        Ok(Self {
            factor,
            cutoff_hz,
            taps,
            resampler: None,
        })
    }

    /// Filter and decimate one channel's samples.
    pub fn apply(&self, channel: &str, samples: &[f32]) -> Result<Vec<f32>, PreprocessError> {
        if samples.is_empty() {
            return Err(PreprocessError::EmptyChannel {
                channel: channel.to_string(),
            });
        }
        if let Some(r) = &self.resampler {
            return r.apply(samples).map_err(|source| PreprocessError::Filter {
                channel: channel.to_string(),
                source,
            });
        }
        if self.taps.is_empty() {
            return Ok(samples.to_vec());
        }
        let mut out = vec![0.0f32; decimated_len(samples.len(), self.factor)];
        filter_decimate(samples, &self.taps, self.factor, &mut out).map_err(|source| {
            PreprocessError::Filter {
                channel: channel.to_string(),
                source,
            }
        })?;
        Ok(out)
    }
}

/// Bring a recording to the model rate with the common band limit on every channel.
pub fn preprocess(
    recording: &Recording,
    cfg: &PreprocessConfig,
) -> Result<Recording, PreprocessError> {
    let plan = FilterPlan::new(recording.fs_hz, cfg)?;
    let channels = recording
        .channels
        .iter()
        .map(|c| {
            Ok(Channel {
                name: c.name.clone(),
                samples: plan.apply(&c.name, &c.samples)?,
            })
        })
        .collect::<Result<Vec<_>, PreprocessError>>()?;
    Ok(Recording {
        name: recording.name.clone(),
        fs_hz: cfg.target_fs_hz,
        rpm: recording.rpm,
        channels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::load_cwru_mat;
    use crate::test_support::cwru_dir;
    use rustfft::{num_complex::Complex, FftPlanner};

    fn tone_recording(fs_hz: f32, n: usize, tones: &[(f64, f64)]) -> Recording {
        let samples = (0..n)
            .map(|i| {
                let t = i as f64 / f64::from(fs_hz);
                tones
                    .iter()
                    .map(|(f, a)| a * (2.0 * std::f64::consts::PI * f * t).sin())
                    .sum::<f64>() as f32
            })
            .collect();
        Recording {
            name: "tones".into(),
            fs_hz,
            rpm: None,
            channels: vec![Channel {
                name: "DE".into(),
                samples,
            }],
        }
    }

    /// Amplitude of the component at `f_hz`, by projection on sin/cos over the
    /// interior (edges dropped) of the signal.
    fn amplitude(x: &[f32], fs_hz: f32, f_hz: f64) -> f64 {
        let edge = x.len() / 8;
        let inner = &x[edge..x.len() - edge];
        let (mut s, mut c) = (0.0f64, 0.0f64);
        for (i, &v) in inner.iter().enumerate() {
            let ph = 2.0 * std::f64::consts::PI * f_hz * (i + edge) as f64 / f64::from(fs_hz);
            s += f64::from(v) * ph.sin();
            c += f64::from(v) * ph.cos();
        }
        2.0 * (s * s + c * c).sqrt() / inner.len() as f64
    }

    /// Fraction of the (mean-removed) signal energy above `f_hz`, by FFT.
    fn energy_fraction_above(x: &[f32], fs_hz: f32, f_hz: f64) -> f64 {
        let mean = x.iter().map(|&v| f64::from(v)).sum::<f64>() / x.len() as f64;
        let mut buf: Vec<Complex<f64>> = x
            .iter()
            .map(|&v| Complex::new(f64::from(v) - mean, 0.0))
            .collect();
        let n = buf.len();
        FftPlanner::new().plan_fft_forward(n).process(&mut buf);
        let (mut above, mut total) = (0.0, 0.0);
        for (k, z) in buf.iter().enumerate().take(n / 2 + 1).skip(1) {
            let p = z.norm_sqr();
            total += p;
            if k as f64 * f64::from(fs_hz) / n as f64 > f_hz {
                above += p;
            }
        }
        above / total
    }

    #[test]
    fn decimation_removes_aliases_and_keeps_the_pass_band() {
        // 8 kHz at 48 kHz would alias to 4 kHz at 12 kHz without the anti-alias filter.
        let rec = tone_recording(48_000.0, 48_000, &[(1_000.0, 1.0), (8_000.0, 1.0)]);
        let out = preprocess(&rec, &PreprocessConfig::default()).expect("integer ratio");
        assert_eq!(out.fs_hz, 12_000.0);
        assert_eq!(out.len(), 12_000);
        let x = &out.channels[0].samples;
        let pass = amplitude(x, 12_000.0, 1_000.0);
        let alias = amplitude(x, 12_000.0, 4_000.0);
        assert!((pass - 1.0).abs() < 0.01, "1 kHz amplitude {pass}");
        assert!(
            alias < 1e-3,
            "aliased 8 kHz tone at 4 kHz has amplitude {alias}"
        );
        // Without the filter the alias is there: the check above can fail.
        let naive: Vec<f32> = rec.channels[0].samples.iter().step_by(4).copied().collect();
        assert!(amplitude(&naive, 12_000.0, 4_000.0) > 0.5);
    }

    #[test]
    fn native_and_decimated_records_get_the_same_band_limit() {
        let cfg = PreprocessConfig::default();
        for f in [2_000.0, 4_500.0, 4_800.0, 5_000.0, 5_300.0, 5_700.0] {
            let native =
                preprocess(&tone_recording(12_000.0, 24_000, &[(f, 1.0)]), &cfg).expect("12 kHz");
            let from_48k =
                preprocess(&tone_recording(48_000.0, 96_000, &[(f, 1.0)]), &cfg).expect("48 kHz");
            let a = amplitude(&native.channels[0].samples, 12_000.0, f);
            let b = amplitude(&from_48k.channels[0].samples, 12_000.0, f);
            assert!(
                (a - b).abs() < 0.02,
                "{f} Hz: native gain {a}, decimated gain {b}"
            );
            if f <= 4_500.0 {
                assert!(a > 0.97, "{f} Hz is in the pass band, gain {a}");
            }
            if f >= 5_700.0 {
                assert!(a < 1e-3, "{f} Hz is in the stop band, gain {a}");
            }
        }
    }

    #[test]
    fn refuses_unsupported_rates_and_configs() {
        let cfg = PreprocessConfig::default();
        let err = preprocess(&tone_recording(1e12, 100, &[]), &cfg).expect_err("1 THz");
        assert!(matches!(err, PreprocessError::TooFast { .. }), "{err}");
        assert!(err.to_string().contains("check the sampling rate"), "{err}");
        let err = preprocess(&tone_recording(8_000.0, 100, &[]), &cfg).expect_err("8 kHz");
        assert!(matches!(err, PreprocessError::Upsampling { .. }), "{err}");
        let even = PreprocessConfig { taps: 100, ..cfg };
        assert!(matches!(
            preprocess(&tone_recording(12_000.0, 100, &[]), &even),
            Err(PreprocessError::BadConfig { .. })
        ));
        let mut empty = tone_recording(12_000.0, 0, &[]);
        empty.channels[0].name = "FE".into();
        assert!(matches!(
            preprocess(&empty, &cfg),
            Err(PreprocessError::EmptyChannel { channel }) if channel == "FE"
        ));
    }

    #[test]
    fn resampler_reproduces_the_decimator_at_an_integer_ratio() {
        let cfg = PreprocessConfig::default();
        let rec = tone_recording(
            48_000.0,
            4_801,
            &[(700.0, 1.0), (3_100.0, 0.5), (9_000.0, 0.3)],
        );
        let x = &rec.channels[0].samples;
        let want = FilterPlan::new(48_000.0, &cfg)
            .expect("plan")
            .apply("DE", x)
            .expect("dec");
        let r = Resampler::new(4.0, BAND_LIMIT_HZ, 48_000.0, cfg.taps).expect("resampler");
        let got = r.apply(x).expect("resample");
        assert_eq!(got.len(), want.len());
        let worst = got
            .iter()
            .zip(&want)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "largest difference {worst}");
    }

    #[test]
    fn resamples_the_rates_of_other_rigs() {
        // Pass band kept, the band above the model Nyquist rate not folded back in:
        // a tone at 9 kHz would alias to 3 kHz at 12 kHz.
        let cfg = PreprocessConfig::default();
        for fs in [25_600.0f32, 44_100.0, 64_000.0, 97_656.0] {
            let n = (fs * 0.5) as usize;
            let rec = tone_recording(fs, n, &[(1_000.0, 1.0), (4_000.0, 0.5), (9_000.0, 1.0)]);
            let out = preprocess(&rec, &cfg).expect("resampled");
            let y = &out.channels[0].samples;
            assert_eq!(out.fs_hz, 12_000.0);
            assert_eq!(y.len(), model_rate_len(n, fs, &cfg).expect("len"));
            assert!(
                (y.len() as f32 - n as f32 * 12_000.0 / fs).abs() <= 1.0,
                "{fs}: {}",
                y.len()
            );
            let a1 = amplitude(y, 12_000.0, 1_000.0);
            let a4 = amplitude(y, 12_000.0, 4_000.0);
            let alias = amplitude(y, 12_000.0, 3_000.0);
            assert!((a1 - 1.0).abs() < 0.01, "{fs} Hz: 1 kHz gain {a1}");
            assert!((a4 - 0.5).abs() < 0.02, "{fs} Hz: 4 kHz gain {}", a4 / 0.5);
            assert!(alias < 1e-3, "{fs} Hz: 9 kHz folded to 3 kHz at {alias}");
        }
    }

    #[test]
    fn tap_count_scales_with_the_factor() {
        let cfg = PreprocessConfig::default();
        assert_eq!(FilterPlan::new(12_000.0, &cfg).expect("1").taps.len(), 101);
        assert_eq!(FilterPlan::new(24_000.0, &cfg).expect("2").taps.len(), 203);
        assert_eq!(FilterPlan::new(36_000.0, &cfg).expect("3").taps.len(), 303);
        let plan = FilterPlan::new(48_000.0, &cfg).expect("4");
        assert_eq!(
            (plan.factor, plan.taps.len(), plan.cutoff_hz),
            (4, 405, Some(BAND_LIMIT_HZ))
        );
        let off = PreprocessConfig {
            band_limit_hz: None,
            ..cfg
        };
        assert_eq!(
            FilterPlan::new(12_000.0, &off).expect("off").cutoff_hz,
            None
        );
        assert_eq!(
            FilterPlan::new(48_000.0, &off).expect("aa").cutoff_hz,
            Some(5_400.0)
        );
        let rec = tone_recording(12_000.0, 50, &[(500.0, 1.0)]);
        assert_eq!(
            preprocess(&rec, &off).expect("pass-through"),
            Recording {
                fs_hz: 12_000.0,
                ..rec
            }
        );
    }

    #[test]
    fn cwru_normal_record_loses_its_high_band_energy() {
        let Some(dir) = cwru_dir() else { return };
        let cfg = PreprocessConfig::default();
        let normal =
            load_cwru_mat(&dir.join("normal/97.mat"), Some(97), 48_000.0, None).expect("97.mat");
        let fault =
            load_cwru_mat(&dir.join("12k_DE/105.mat"), Some(105), 12_000.0, None).expect("105.mat");
        let normal_de = &normal.channel("DE").expect("DE").samples;
        let fault_de = &fault.channel("DE").expect("DE").samples;

        // The shortcut as it comes out of naive decimation: far more energy above 5.5 kHz.
        let naive: Vec<f32> = normal_de.iter().step_by(4).copied().collect();
        let naive_normal = energy_fraction_above(&naive, 12_000.0, 5_500.0);
        let raw_fault = energy_fraction_above(fault_de, 12_000.0, 5_500.0);

        let pp_normal = preprocess(&normal, &cfg).expect("normal");
        let pp_fault = preprocess(&fault, &cfg).expect("fault");
        assert_eq!(pp_normal.fs_hz, 12_000.0);
        assert_eq!(pp_normal.len(), decimated_len(normal.len(), 4));
        assert_eq!(pp_fault.len(), fault.len());
        let after_normal = energy_fraction_above(
            &pp_normal.channel("DE").expect("DE").samples,
            12_000.0,
            5_500.0,
        );
        let after_fault = energy_fraction_above(
            &pp_fault.channel("DE").expect("DE").samples,
            12_000.0,
            5_500.0,
        );
        eprintln!(
            "energy above 5.5 kHz: normal naive {naive_normal:.3e} → {after_normal:.3e}, \
             fault raw {raw_fault:.3e} → {after_fault:.3e}"
        );
        // Before: the 48 kHz chain shows at 12 kHz as over an order of magnitude more
        // energy above 5.5 kHz than the 12 kHz fault record (about 200× on this data).
        assert!(
            naive_normal > 20.0 * raw_fault,
            "the raw shortcut should be visible ({naive_normal} vs {raw_fault})"
        );
        // After: both at the filter's stop-band floor, and within a factor 3 of each other.
        assert!(
            after_normal < 1e-5,
            "normal after band limit: {after_normal}"
        );
        assert!(after_fault < 1e-5, "fault after band limit: {after_fault}");
        let ratio = after_normal / after_fault;
        assert!(
            (1.0 / 3.0..3.0).contains(&ratio),
            "normal/fault high-band ratio {ratio}"
        );
    }
}
