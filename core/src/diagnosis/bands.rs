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
/// spectra of the mean-removed signal, leaving `|z|²` in `env`; returns the band's
/// power `mean |z|²`. `scratch`, `env`: the window's length; `es`, `ses`: half of
/// it plus one.
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
    for e in env.iter_mut() {
        *e += p0 as f32;
    }
    Ok(p0 as f32)
}

/// The mean of exponential samples under their mean, over their mean:
/// `(1 − 2/e)/(1 − 1/e)`.
const NOISE_BELOW_MEAN: f64 = 0.418_023;

/// Most impacts [`impact_pulse_s`] reads (the strongest are not chosen: the first in
/// the window, which is any of them).
const PULSE_IMPACTS: usize = 64;

/// How long one impact's squared envelope takes to rise from `1/e` of its peak to
/// the peak and to fall back to `1/e` in the band, s: `[rise, fall]`, each the median
/// over the window's clear impacts (peaks of `|z|²` at least eight times the
/// background's, each the highest within `gap` samples either side, that rise from
/// and fall to `1/e` within them), log-interpolated between samples; `[0, 0]` where
/// no impact reads one. The background is read from the samples under `mean`
/// (`mean |z|²`): for noise alone (`|z|²` exponential) their mean is
/// `(1 − 2/e)/(1 − 1/e) = 0.418` of the noise's, and impacts, which raise the mean,
/// only raise that estimate where their tails fill the gaps. What it reads is one
/// impact's pulse — the ring-down of what it excites, through the band's own
/// response, which also sets the rise — that every line of the envelope carries
/// whatever the defect's width; a spall's entry before its exit lengthens the rise
/// only where it reaches `1/e` of the exit (module docs of `crate::diagnosis`, "the
/// band's own fall").
pub fn impact_pulse_s(power: &[f32], fs_hz: f32, gap: usize, mean: f32) -> [f32; 2] {
    let mut found = [[0.0f32; 2]; PULSE_IMPACTS];
    let mut count = 0usize;
    let (below, count_below) = power
        .iter()
        .filter(|&&v| v < mean)
        .fold((0.0f64, 0usize), |(s, c), &v| (s + f64::from(v), c + 1));
    if count_below == 0 {
        return [0.0; 2];
    }
    let background = (below / count_below as f64 / NOISE_BELOW_MEAN) as f32;
    let threshold = 8.0 * background;
    let gap = gap.max(2);
    let mut i = gap;
    while i + gap < power.len() && count < PULSE_IMPACTS {
        let p = power.get(i).copied().unwrap_or(0.0);
        // A NaN sample is never a peak.
        if p.partial_cmp(&threshold) != Some(core::cmp::Ordering::Greater) {
            i += 1;
            continue;
        }
        let ahead = power.get(i + 1..=i + gap).unwrap_or_default();
        if let Some(k) = ahead.iter().position(|&v| v > p) {
            i += k + 1;
            continue;
        }
        let behind = power.get(i - gap..i).unwrap_or_default();
        let fall = e_fold(p, ahead.iter().copied());
        let rise = e_fold(p, behind.iter().rev().copied());
        if let (Some(f), Some(r), Some(slot)) = (fall, rise, found.get_mut(count)) {
            *slot = [r / fs_hz, f / fs_hz];
            count += 1;
        }
        i += gap;
    }
    let read = found.get_mut(..count).unwrap_or_default();
    let mut out = [0.0f32; 2];
    for (side, o) in out.iter_mut().enumerate() {
        read.sort_unstable_by(|a, b| a[side].total_cmp(&b[side]));
        *o = read.get(count / 2).map_or(0.0, |v| v[side]);
    }
    out
}

/// Samples (log-interpolated) until `side`, read away from a peak `p`, first falls to
/// `p/e`; `None` where it never does or rises above `p` first.
fn e_fold(p: f32, side: impl Iterator<Item = f32>) -> Option<f32> {
    let target = p / core::f32::consts::E;
    let mut before = p;
    for (j, v) in side.enumerate() {
        if v > p {
            return None;
        }
        if v <= target {
            let after = v.max(f32::MIN_POSITIVE);
            let step = crate::math::ln(f64::from(before / after));
            let part = if step > 0.0 {
                crate::math::ln(f64::from(before / target)) / step
            } else {
                1.0
            };
            return Some(j as f32 + part as f32);
        }
        before = v;
    }
    None
}

/// The band pulse's power at `2·f` and `3·f` over its power at `f`, for a squared
/// envelope that rises as `e^{t/τ_r}` to each impact's peak and falls as `e^{-t/τ_f}`
/// after it (`[τ_r, τ_f]` = [`impact_pulse_s`]): that pulse's transform is
/// `(τ_r + τ_f)/((1 − i·2πf·τ_r)(1 + i·2πf·τ_f))`, so
/// `|G(f)|² ∝ 1/((1 + (2πf·τ_r)²)(1 + (2πf·τ_f)²))` and the result is
/// `[|G(2f)|²/|G(f)|², |G(3f)|²/|G(f)|²]`; `[1, 1]` where nothing was read.
pub fn pulse_transfer_of(pulse_s: [f32; 2], f: f32) -> [f32; 2] {
    let l = |h: f32| {
        pulse_s.iter().fold(1.0f32, |g, &tau| {
            let w = 2.0 * core::f32::consts::PI * h * f * tau;
            g / (1.0 + w * w)
        })
    };
    if !(f > 0.0 && f.is_finite() && pulse_s.iter().all(|t| *t >= 0.0 && t.is_finite())) {
        return [1.0, 1.0];
    }
    [l(2.0) / l(1.0), l(3.0) / l(1.0)]
}
