//! The demodulation bands: which are searched, how impulsive each is (spectral
//! kurtosis, pooled over any number of windows), and the envelope spectra of one band.

use super::types::{Defect, BAND_LO_HZ, LINES_PER_BAND, MAX_BANDS, MIN_BAND_HZ};
use crate::bearing::DefectOrders;
use crate::error::{expect_len, Error, Result};
use crate::fft::{fft_in_place, power_spectrum, Complex32, Direction, Window};

/// The bands searched: `[lo + k·width/3, lo + k·width/3 + width]` for `k < count`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandPlan {
    /// Lower edge of the first band, Hz.
    pub lo_hz: f32,
    /// Width of every band, Hz.
    pub width_hz: f32,
    /// Number of bands (≤ [`MAX_BANDS`]).
    pub count: usize,
}

impl BandPlan {
    /// The bands at `fs_hz` for a bearing of `orders` at `shaft_hz`: from
    /// [`BAND_LO_HZ`] to the common band limit (or 0.45·fs), each at least
    /// [`MIN_BAND_HZ`] and [`LINES_PER_BAND`] times the highest family's fundamental
    /// wide, overlapping by two thirds.
    pub fn new(fs_hz: f32, shaft_hz: f32, orders: &DefectOrders) -> Result<Self> {
        let params = [fs_hz, shaft_hz, orders.bpfo, orders.bpfi, orders.bsf];
        if params.iter().any(|v| !v.is_finite() || *v <= 0.0) {
            return Err(Error::InvalidParameter(
                "sampling rate, shaft rate and defect orders must be finite and > 0",
            ));
        }
        let highest = Defect::ALL
            .iter()
            .fold(0.0f32, |m, d| m.max(d.order(orders) * shaft_hz));
        let top = crate::fir::BAND_LIMIT_HZ.min(0.45 * fs_hz);
        let span = top - BAND_LO_HZ;
        let width = MIN_BAND_HZ.max(LINES_PER_BAND * highest);
        if span < width {
            return Err(Error::InvalidParameter(
                "no demodulation band fits: sampling rate too low or shaft speed too high",
            ));
        }
        let step = width / 3.0;
        let count = (((span - width) / step) as usize + 1).min(MAX_BANDS);
        Ok(Self {
            lo_hz: BAND_LO_HZ,
            width_hz: width,
            count,
        })
    }

    /// Edges of band `k`, Hz.
    pub fn band(&self, k: usize) -> (f32, f32) {
        let lo = self.lo_hz + k as f32 * self.width_hz / 3.0;
        (lo, lo + self.width_hz)
    }
}

/// Sums of `|z|²` and `|z|⁴` of each band's analytic signal: its spectral kurtosis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandMoments {
    m2: [f64; MAX_BANDS],
    m4: [f64; MAX_BANDS],
    samples: u64,
}

impl BandMoments {
    /// Nothing yet.
    pub const ZERO: Self = Self {
        m2: [0.0; MAX_BANDS],
        m4: [0.0; MAX_BANDS],
        samples: 0,
    };

    /// Spectral kurtosis of band `k`: `E|z|⁴ / (E|z|²)² − 2` (0 for Gaussian noise).
    pub fn kurtosis(&self, k: usize) -> f32 {
        let (Some(&m2), Some(&m4)) = (self.m2.get(k), self.m4.get(k)) else {
            return 0.0;
        };
        if m2 <= 0.0 || self.samples == 0 {
            return 0.0;
        }
        let n = self.samples as f64;
        let (m2, m4) = (m2 / n, m4 / n);
        (m4 / (m2 * m2) - 2.0) as f32
    }

    /// The most impulsive of the plan's bands and its kurtosis.
    pub fn most_impulsive(&self, plan: &BandPlan) -> (usize, f32) {
        (0..plan.count).fold((0, f32::MIN), |best, k| {
            let sk = self.kurtosis(k);
            if sk > best.1 {
                (k, sk)
            } else {
                best
            }
        })
    }
}

/// The window's spectrum (mean removed) into `spectrum`; non-finite samples and a
/// flat window (a dead sensor: nothing to diagnose, and never "normal") are errors.
pub fn window_spectrum(x: &[f32], spectrum: &mut [Complex32]) -> Result<()> {
    let n = x.len();
    if n < 16 || !n.is_power_of_two() {
        return Err(Error::NotPowerOfTwo(n));
    }
    expect_len(spectrum.len(), n)?;
    let mut mean = 0.0f64;
    for &v in x {
        if !v.is_finite() {
            return Err(Error::NonFinite);
        }
        mean += f64::from(v);
    }
    let first = x.first().copied().unwrap_or(0.0);
    if x.iter().all(|&v| v == first) {
        return Err(Error::Degenerate);
    }
    let mean = (mean / n as f64) as f32;
    for (z, &v) in spectrum.iter_mut().zip(x) {
        *z = Complex32::new(v - mean, 0.0);
    }
    fft_in_place(spectrum, Direction::Forward)
}

/// The analytic signal of `[lo, hi]` from a window's spectrum into `scratch`.
fn analytic(
    spectrum: &[Complex32],
    scratch: &mut [Complex32],
    fs_hz: f32,
    lo: f32,
    hi: f32,
) -> Result<()> {
    let n = spectrum.len();
    expect_len(scratch.len(), n)?;
    let df = fs_hz / n as f32;
    for (k, (z, &s)) in scratch.iter_mut().zip(spectrum).enumerate() {
        let f = k as f32 * df;
        *z = if k > 0 && k < n / 2 && f >= lo && f <= hi {
            Complex32::new(2.0 * s.re, 2.0 * s.im)
        } else {
            Complex32::ZERO
        };
    }
    fft_in_place(scratch, Direction::Inverse)
}

/// Every band's moments of one window's spectrum (`scratch`: its length).
pub fn band_moments(
    spectrum: &[Complex32],
    plan: &BandPlan,
    fs_hz: f32,
    scratch: &mut [Complex32],
) -> Result<BandMoments> {
    let mut m = BandMoments::ZERO;
    m.samples = spectrum.len() as u64;
    for k in 0..plan.count.min(MAX_BANDS) {
        let (lo, hi) = plan.band(k);
        analytic(spectrum, scratch, fs_hz, lo, hi)?;
        let (mut m2, mut m4) = (0.0f64, 0.0f64);
        for z in scratch.iter() {
            let p = f64::from(z.norm_sqr());
            m2 += p;
            m4 += p * p;
        }
        if let (Some(a), Some(b)) = (m.m2.get_mut(k), m.m4.get_mut(k)) {
            *a = m2;
            *b = m4;
        }
    }
    Ok(m)
}

/// One band's envelope spectrum (of `|z|`, for the lines) into `es` and squared
/// envelope spectrum (of `|z|²`, for the severity) into `ses`, both Hann power
/// spectra of the mean-removed signal; returns the band's power `mean |z|²`.
/// `scratch`, `env`: the window's length; `es`, `ses`: half of it plus one.
pub fn band_envelope_spectra(
    spectrum: &[Complex32],
    fs_hz: f32,
    band: (f32, f32),
    scratch: &mut [Complex32],
    env: &mut [f32],
    es: &mut [f32],
    ses: &mut [f32],
) -> Result<f32> {
    let n = spectrum.len();
    expect_len(env.len(), n)?;
    analytic(spectrum, scratch, fs_hz, band.0, band.1)?;
    for (e, z) in env.iter_mut().zip(scratch.iter()) {
        *e = z.norm();
    }
    let mean = env.iter().map(|&v| f64::from(v)).sum::<f64>() / n as f64;
    let p0 = env
        .iter()
        .map(|&v| f64::from(v) * f64::from(v))
        .sum::<f64>()
        / n as f64;
    for e in env.iter_mut() {
        *e -= mean as f32;
    }
    power_spectrum(env, Window::Hann, scratch, es)?;
    for e in env.iter_mut() {
        let v = f64::from(*e) + mean;
        *e = (v * v - p0) as f32;
    }
    power_spectrum(env, Window::Hann, scratch, ses)?;
    Ok(p0 as f32)
}
