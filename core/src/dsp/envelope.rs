//! Envelope (Hilbert) demodulation: the band-passed analytic signal's magnitude and its
//! power spectrum, both through the radix-2 FFT on caller-owned buffers.

use crate::error::{expect_len, Error, Result};
use crate::fft::{fft_in_place, power_spectrum, Complex32, Direction, Window};

/// Band for the envelope (Hilbert) demodulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnvelopeBand {
    /// Lower edge, Hz (removes shaft harmonics and structural low-frequency content).
    pub lo_hz: f32,
    /// Upper edge, Hz (the common band limit).
    pub hi_hz: f32,
}

impl EnvelopeBand {
    /// 500 Hz – 5 kHz: above shaft and gear-mesh content, below the common band limit.
    pub const DEFAULT: Self = Self {
        lo_hz: 500.0,
        hi_hz: crate::fir::BAND_LIMIT_HZ,
    };
}

/// Envelope `|analytic(bandpass(x))|` of `x` (power-of-two length) into `env`.
/// The mean is removed before the transform. `scratch.len() == env.len() == x.len()`.
pub fn envelope(
    x: &[f32],
    fs_hz: f32,
    band: EnvelopeBand,
    scratch: &mut [Complex32],
    env: &mut [f32],
) -> Result<()> {
    let n = x.len();
    expect_len(scratch.len(), n)?;
    expect_len(env.len(), n)?;
    let mut mean = 0.0f64;
    for &v in x {
        if !v.is_finite() {
            return Err(Error::NonFinite);
        }
        mean += f64::from(v);
    }
    let mean = (mean / n.max(1) as f64) as f32;
    for (z, &v) in scratch.iter_mut().zip(x.iter()) {
        *z = Complex32::new(v - mean, 0.0);
    }
    fft_in_place(scratch, Direction::Forward)?;
    // Analytic signal: keep positive frequencies inside the band, doubled; zero the rest.
    let df = fs_hz / n as f32;
    for (k, z) in scratch.iter_mut().enumerate() {
        let f = k as f32 * df;
        let keep = k > 0 && k < n / 2 && f >= band.lo_hz && f <= band.hi_hz;
        *z = if keep {
            Complex32::new(2.0 * z.re, 2.0 * z.im)
        } else {
            Complex32::ZERO
        };
    }
    fft_in_place(scratch, Direction::Inverse)?;
    for (e, z) in env.iter_mut().zip(scratch.iter()) {
        *e = z.norm();
    }
    Ok(())
}

/// Envelope spectrum: power spectrum of `envelope(x) − mean`.
/// `scratch`, `env`: length `N = x.len()`; `out`: length `N/2 + 1`.
pub fn envelope_spectrum(
    x: &[f32],
    fs_hz: f32,
    band: EnvelopeBand,
    scratch: &mut [Complex32],
    env: &mut [f32],
    out: &mut [f32],
) -> Result<()> {
    envelope(x, fs_hz, band, scratch, env)?;
    let mean = env.iter().map(|&v| f64::from(v)).sum::<f64>() / env.len() as f64;
    for e in env.iter_mut() {
        *e -= mean as f32;
    }
    power_spectrum(env, Window::Hann, scratch, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dsp::peaks::peak_frequency;
    use crate::math;
    use std::vec::Vec;

    /// An amplitude-modulated carrier: the envelope spectrum peaks at the modulation rate.
    #[test]
    fn envelope_spectrum_finds_the_modulation() {
        let fs = 12_000.0f64;
        let n = 8192;
        let f_mod = 107.3;
        let x: Vec<f32> = (0..n)
            .map(|i| {
                let t = i as f64 / fs;
                ((1.0 + 0.8 * (2.0 * math::PI * f_mod * t).cos())
                    * (2.0 * math::PI * 3000.0 * t).sin()) as f32
            })
            .collect();
        let mut scratch = std::vec![Complex32::ZERO; n];
        let mut env = std::vec![0.0f32; n];
        let mut spec = std::vec![0.0f32; n / 2 + 1];
        envelope_spectrum(
            &x,
            fs as f32,
            EnvelopeBand::DEFAULT,
            &mut scratch,
            &mut env,
            &mut spec,
        )
        .unwrap();
        let f = peak_frequency(&spec, fs as f32, 20.0, 500.0).unwrap();
        assert!((f - f_mod as f32).abs() < 0.5, "peak {f}");
    }
}
