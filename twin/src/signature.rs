//! What the twin compares: phase-free signatures of a signal. Impacts are not
//! phase-locked to a record, so a simulated and a measured record are compared in
//! domains where the phase does not matter (issue: "compare in domains where that does
//! not matter"): the Welch power spectrum in dB, the Welch envelope spectrum in dB, and
//! time statistics (RMS, kurtosis).

use pumptwin_core::features::{envelope_spectrum, EnvelopeBand, TimeStats};
use pumptwin_core::fft::{power_spectrum, Complex32, Window};

/// Floor added before taking dB, relative to the spectrum's mean level.
const DB_FLOOR_REL: f32 = 1e-6;

/// The shortest Welch block [`SignatureConfig::for_length`] shortens a block to.
pub const MIN_BLOCK: usize = 2048;

/// `n_max` halved, down to [`MIN_BLOCK`], until `count` blocks fit in `len` samples (a
/// block of `n_max` or less is kept as it is).
pub fn block_within(n_max: usize, len: usize, count: usize) -> usize {
    let mut block = n_max;
    while count * block > len && block > MIN_BLOCK {
        block /= 2;
    }
    block
}

/// How signatures are computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignatureConfig {
    /// Sampling rate, Hz.
    pub fs_hz: f32,
    /// Welch block length of the power spectrum (power of two).
    pub psd_n: usize,
    /// Welch block length of the envelope spectrum (power of two).
    pub env_n: usize,
    /// Envelope demodulation band.
    pub env_band: EnvelopeBand,
    /// Highest envelope-spectrum frequency kept, Hz.
    pub env_max_hz: f32,
    /// Power-spectrum bins compared: `[psd_lo_hz, psd_hi_hz]`.
    pub psd_lo_hz: f32,
    /// Upper edge of the compared power spectrum (the common band limit).
    pub psd_hi_hz: f32,
}

impl SignatureConfig {
    /// Fit resolution: 1024-point PSD (11.7 Hz at 12 kHz), 8192-point envelope spectrum
    /// (1.5 Hz), envelope up to 1 kHz (BPFI harmonics up to ×5 at CWRU speeds).
    pub fn fit(fs_hz: f32) -> Self {
        Self {
            fs_hz,
            psd_n: 1024,
            env_n: 8192,
            env_band: EnvelopeBand {
                lo_hz: 500.0,
                hi_hz: 5000.0f32.min(0.45 * fs_hz),
            },
            env_max_hz: 1000.0,
            psd_lo_hz: 20.0,
            // Below the band limit's transition (≈ 4.7–5.3 kHz for the 101-tap filter at
            // 12 kHz), where the measurement chain and the model's are both flat.
            psd_hi_hz: 4600.0f32.min(0.38 * fs_hz),
        }
    }
    /// Residual resolution: 4096-point PSD (2.9 Hz) to resolve lines.
    pub fn residual(fs_hz: f32) -> Self {
        Self {
            psd_n: 4096,
            ..Self::fit(fs_hz)
        }
    }
    /// The configuration for a record of `n` samples: each Welch block (power spectrum,
    /// envelope spectrum) is halved, down to [`MIN_BLOCK`], until two of them fit, so
    /// that a short snapshot (20 480 samples at 20 kHz, 12 288 at the model rate; 1.28 s
    /// at 25.6 kHz) is compared at a coarser resolution instead of refused. The
    /// envelope's 8192-point block (1.5 Hz at 12 kHz) needs 1.4 s; at 2048 points the
    /// envelope bins are 5.9 Hz, still a tenth of BPFO at 600 rpm.
    ///
    /// # Errors
    /// [`SignatureError::TooShort`] when two blocks of [`MIN_BLOCK`] do not fit.
    pub fn for_length(self, n: usize) -> Result<Self, SignatureError> {
        if n < 2 * MIN_BLOCK {
            return Err(SignatureError::TooShort {
                need: 2 * MIN_BLOCK,
                got: n,
            });
        }
        Ok(Self {
            psd_n: block_within(self.psd_n, n, 2),
            env_n: block_within(self.env_n, n, 2),
            ..self
        })
    }
    /// Frequency of PSD bin `k`.
    pub fn psd_freq(&self, k: usize) -> f32 {
        k as f32 * self.fs_hz / self.psd_n as f32
    }
    /// Frequency of envelope bin `k`.
    pub fn env_freq(&self, k: usize) -> f32 {
        k as f32 * self.fs_hz / self.env_n as f32
    }
    /// PSD bins compared.
    pub fn psd_bins(&self) -> std::ops::RangeInclusive<usize> {
        let df = self.fs_hz / self.psd_n as f32;
        ((self.psd_lo_hz / df).ceil() as usize).max(1)
            ..=((self.psd_hi_hz / df) as usize).min(self.psd_n / 2)
    }
    /// Envelope bins compared (DC excluded).
    pub fn env_bins(&self) -> std::ops::RangeInclusive<usize> {
        let df = self.fs_hz / self.env_n as f32;
        1..=((self.env_max_hz / df) as usize).min(self.env_n / 2)
    }
}

/// Phase-free description of one signal.
#[derive(Debug, Clone, PartialEq)]
pub struct Signature {
    /// Welch PSD, linear, bins `0..=psd_n/2`.
    pub psd: Vec<f32>,
    /// Welch envelope spectrum, linear, bins `0..=env_n/2`.
    pub env: Vec<f32>,
    /// RMS of the signal.
    pub rms: f32,
    /// Kurtosis of the signal.
    pub kurtosis: f32,
}

/// Errors computing a signature.
#[derive(Debug, thiserror::Error)]
pub enum SignatureError {
    /// The signal is shorter than one envelope block.
    #[error("signal of {got} samples is shorter than one {need}-sample block")]
    TooShort {
        /// Samples needed.
        need: usize,
        /// Samples given.
        got: usize,
    },
    /// The core rejected the signal (NaN, constant…).
    #[error("{0}")]
    Core(#[from] pumptwin_core::Error),
}

/// Welch average of `f(block) -> spectrum` over 50 %-overlapping blocks of `n`
/// (every averaged spectrum in the project goes through here).
pub fn welch(
    x: &[f32],
    n: usize,
    mut f: impl FnMut(&[f32], &mut [f32]) -> Result<(), pumptwin_core::Error>,
) -> Result<Vec<f32>, SignatureError> {
    if x.len() < n {
        return Err(SignatureError::TooShort {
            need: n,
            got: x.len(),
        });
    }
    let mut acc = vec![0.0f32; n / 2 + 1];
    let mut block = vec![0.0f32; n / 2 + 1];
    let mut count = 0usize;
    for start in (0..=x.len() - n).step_by(n / 2) {
        f(&x[start..start + n], &mut block)?;
        acc.iter_mut().zip(&block).for_each(|(a, b)| *a += b);
        count += 1;
    }
    let inv = 1.0 / count as f32;
    acc.iter_mut().for_each(|a| *a *= inv);
    Ok(acc)
}

impl Signature {
    /// Compute the signature of `x`.
    pub fn of(x: &[f32], cfg: &SignatureConfig) -> Result<Self, SignatureError> {
        let mut scratch = vec![Complex32::ZERO; cfg.psd_n.max(cfg.env_n)];
        let psd = welch(x, cfg.psd_n, |b, out| {
            power_spectrum(b, Window::Hann, &mut scratch[..cfg.psd_n], out)
        })?;
        let mut env_buf = vec![0.0f32; cfg.env_n];
        let env = welch(x, cfg.env_n, |b, out| {
            envelope_spectrum(
                b,
                cfg.fs_hz,
                cfg.env_band,
                &mut scratch[..cfg.env_n],
                &mut env_buf,
                out,
            )
        })?;
        let stats = TimeStats::compute(x)?;
        Ok(Self {
            psd,
            env,
            rms: stats.rms,
            kurtosis: stats.kurtosis,
        })
    }
}

/// `10·log10(p + floor)` with the floor relative to the mean of `reference`.
pub fn to_db(p: &[f32], reference: &[f32]) -> Vec<f32> {
    let mean = reference.iter().sum::<f32>() / reference.len().max(1) as f32;
    let floor = (mean * DB_FLOOR_REL).max(f32::MIN_POSITIVE);
    p.iter().map(|v| 10.0 * (v + floor).log10()).collect()
}

/// The two error figures every loop step reports.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ErrorFigures {
    /// RMS over the compared band of the dB difference of the power spectra.
    pub psd_log_rmse_db: f32,
    /// RMS of the envelope-spectrum difference, both divided by the measured
    /// envelope spectrum's mean level (dimensionless).
    pub envelope_rmse: f32,
    /// RMS over the compared envelope bins of the dB difference of the envelope spectra.
    pub envelope_log_rmse_db: f32,
    /// `ln(rms_sim / rms_meas)`.
    pub log_rms_ratio: f32,
    /// Kurtosis of the simulation minus that of the measurement.
    pub kurtosis_diff: f32,
    /// `ln(kurtosis_sim / kurtosis_meas)`.
    pub log_kurtosis_ratio: f32,
}

/// Compare a simulated signature with the measured one.
pub fn error_figures(sim: &Signature, meas: &Signature, cfg: &SignatureConfig) -> ErrorFigures {
    let psd_s = to_db(&sim.psd, &meas.psd);
    let psd_m = to_db(&meas.psd, &meas.psd);
    let bins = cfg.psd_bins();
    let n_psd = bins.clone().count() as f32;
    let psd_mse = bins.map(|k| (psd_s[k] - psd_m[k]).powi(2)).sum::<f32>() / n_psd;
    let env_bins = cfg.env_bins();
    let mean_env =
        env_bins.clone().map(|k| meas.env[k]).sum::<f32>() / env_bins.clone().count() as f32;
    let n_env = env_bins.clone().count() as f32;
    let env_mse = env_bins
        .clone()
        .map(|k| ((sim.env[k] - meas.env[k]) / mean_env).powi(2))
        .sum::<f32>()
        / n_env;
    let env_s = to_db(&sim.env, &meas.env);
    let env_m = to_db(&meas.env, &meas.env);
    let env_db_mse = env_bins.map(|k| (env_s[k] - env_m[k]).powi(2)).sum::<f32>() / n_env;
    ErrorFigures {
        psd_log_rmse_db: psd_mse.sqrt(),
        envelope_rmse: env_mse.sqrt(),
        envelope_log_rmse_db: env_db_mse.sqrt(),
        log_rms_ratio: (sim.rms / meas.rms).ln(),
        kurtosis_diff: sim.kurtosis - meas.kurtosis,
        log_kurtosis_ratio: (sim.kurtosis / meas.kurtosis).ln(),
    }
}

/// The scalar the loop minimizes and compares between steps: the mean of the squared
/// PSD and envelope dB errors (equal weight; both in dB), plus the time statistics as
/// log ratios (RMS weighted 10, kurtosis 4). Equals `Σ r²` of [`residual_vector`].
pub fn total_error(e: &ErrorFigures) -> f32 {
    0.5 * (e.psd_log_rmse_db.powi(2) + e.envelope_log_rmse_db.powi(2))
        + 10.0 * e.log_rms_ratio.powi(2)
        + 4.0 * e.log_kurtosis_ratio.powi(2)
}

/// Residual vector for Gauss–Newton: PSD dB differences, envelope dB differences
/// (each scaled by 1/√bins so the two blocks weigh equally), and the time statistics.
pub fn residual_vector(
    sim: &Signature,
    meas_psd_db: &[f32],
    meas_env_db: &[f32],
    meas: &Signature,
    cfg: &SignatureConfig,
) -> Vec<f32> {
    let psd_s = to_db(&sim.psd, &meas.psd);
    let env_s = to_db(&sim.env, &meas.env);
    let bins = cfg.psd_bins();
    let env_bins = cfg.env_bins();
    let wp = (0.5 / bins.clone().count() as f32).sqrt();
    let we = (0.5 / env_bins.clone().count() as f32).sqrt();
    let mut r: Vec<f32> = bins.map(|k| wp * (psd_s[k] - meas_psd_db[k])).collect();
    r.extend(env_bins.map(|k| we * (env_s[k] - meas_env_db[k])));
    r.push(10.0f32.sqrt() * (sim.rms / meas.rms).ln());
    r.push(2.0 * (sim.kurtosis / meas.kurtosis).ln());
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A short snapshot is compared with shorter blocks, down to two of `MIN_BLOCK`.
    #[test]
    fn a_short_record_gets_shorter_blocks() {
        let fit = SignatureConfig::fit(12_000.0);
        assert_eq!(fit.for_length(60_000).unwrap(), fit);
        // 1 s at 20 kHz, brought to 12 kHz: 12 000 samples.
        let short = fit.for_length(12_000).unwrap();
        assert_eq!((short.psd_n, short.env_n), (1024, 4096));
        let res = SignatureConfig::residual(12_000.0)
            .for_length(12_000)
            .unwrap();
        assert_eq!((res.psd_n, res.env_n), (4096, 4096));
        let shortest = fit.for_length(2 * MIN_BLOCK).unwrap();
        assert_eq!(shortest.env_n, MIN_BLOCK);
        assert!(matches!(
            fit.for_length(2 * MIN_BLOCK - 1),
            Err(SignatureError::TooShort { need, got })
                if need == 2 * MIN_BLOCK && got == 2 * MIN_BLOCK - 1
        ));
        // The blocks fit the record they were made for.
        let x: Vec<f32> = (0..12_000).map(|i| (i as f32 * 0.37).sin()).collect();
        assert!(Signature::of(&x, &short).is_ok());
        assert!(Signature::of(&x, &res).is_ok());
    }
}
