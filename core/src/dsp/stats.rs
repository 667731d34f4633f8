//! Time-domain statistics of a segment (mean, RMS, crest factor, kurtosis, skewness,
//! peak-to-peak, shape and impulse factors) from f64 central moments.

use crate::error::{Error, Result};
use crate::math;

/// The central moments `(m2, m3, m4)` of `x` about `mean`, accumulated in f64 (the
/// second pass of [`TimeStats::compute`] and of
/// `features::noise_compensated_kurtosis`).
pub(crate) fn central_moments(x: &[f32], mean: f64) -> (f64, f64, f64) {
    let (mut m2, mut m3, mut m4) = (0.0f64, 0.0f64, 0.0f64);
    for &v in x {
        let d = f64::from(v) - mean;
        let d2 = d * d;
        m2 += d2;
        m3 += d2 * d;
        m4 += d2 * d2;
    }
    let n = x.len().max(1) as f64;
    (m2 / n, m3 / n, m4 / n)
}

/// Time-domain statistics of one segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeStats {
    /// Mean.
    pub mean: f32,
    /// Root mean square.
    pub rms: f32,
    /// Peak / RMS.
    pub crest_factor: f32,
    /// Fourth standardized moment (3 for a Gaussian).
    pub kurtosis: f32,
    /// Third standardized moment.
    pub skewness: f32,
    /// Max − min.
    pub peak_to_peak: f32,
    /// RMS / mean absolute value.
    pub shape_factor: f32,
    /// Peak / mean absolute value.
    pub impulse_factor: f32,
}

impl TimeStats {
    /// Compute in f64 accumulators (two passes: mean, then central moments).
    ///
    /// # Errors
    /// [`Error::NonFinite`] for NaN/∞ samples, [`Error::Degenerate`] for an empty or
    /// constant segment (a dead sensor: the caller masks the node).
    pub fn compute(x: &[f32]) -> Result<Self> {
        if x.is_empty() {
            return Err(Error::Degenerate);
        }
        let n = x.len() as f64;
        let (mut sum, mut sum_sq, mut sum_abs) = (0.0f64, 0.0f64, 0.0f64);
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for &v in x {
            if !v.is_finite() {
                return Err(Error::NonFinite);
            }
            let d = f64::from(v);
            sum += d;
            sum_sq += d * d;
            sum_abs += d.abs();
            lo = lo.min(v);
            hi = hi.max(v);
        }
        let mean = sum / n;
        let (m2, m3, m4) = central_moments(x, mean);
        if m2 <= 1e-30 || hi <= lo {
            return Err(Error::Degenerate);
        }
        let rms = math::sqrt(sum_sq / n);
        let peak = f64::from(hi.abs().max(lo.abs()));
        let mean_abs = sum_abs / n;
        Ok(Self {
            mean: mean as f32,
            rms: rms as f32,
            crest_factor: (peak / rms) as f32,
            kurtosis: (m4 / (m2 * m2)) as f32,
            skewness: (m3 / (m2 * math::sqrt(m2))) as f32,
            peak_to_peak: hi - lo,
            shape_factor: (rms / mean_abs) as f32,
            impulse_factor: (peak / mean_abs) as f32,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro128pp;
    use std::vec::Vec;

    #[test]
    fn time_stats_of_a_sine() {
        let x: Vec<f32> = (0..4096)
            .map(|i| (2.0 * math::PI * i as f64 / 64.0).sin() as f32)
            .collect();
        let s = TimeStats::compute(&x).unwrap();
        let sq2 = core::f32::consts::SQRT_2;
        assert!(s.mean.abs() < 1e-6);
        assert!((s.rms - 1.0 / sq2).abs() < 1e-5);
        assert!((s.crest_factor - sq2).abs() < 1e-4);
        assert!((s.kurtosis - 1.5).abs() < 1e-4);
        assert!(s.skewness.abs() < 1e-4);
        assert!((s.peak_to_peak - 2.0).abs() < 1e-5);
        // shape = rms / (2/π) = π/(2√2)
        assert!((s.shape_factor - core::f32::consts::PI / (2.0 * sq2)).abs() < 1e-3);
    }

    /// Against a plain f64 reference of the textbook formulas on Gaussian noise.
    #[test]
    fn time_stats_match_reference() {
        let mut r = Xoshiro128pp::seed_from_u64(4);
        let x: Vec<f32> = (0..1000).map(|_| (r.normal() * 2.0 + 0.5) as f32).collect();
        let s = TimeStats::compute(&x).unwrap();
        let n = x.len() as f64;
        let xd: Vec<f64> = x.iter().map(|&v| f64::from(v)).collect();
        let mean = xd.iter().sum::<f64>() / n;
        let var = xd.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
        let kurt = xd.iter().map(|v| (v - mean).powi(4)).sum::<f64>() / n / (var * var);
        let skew = xd.iter().map(|v| (v - mean).powi(3)).sum::<f64>() / n / var.powf(1.5);
        assert!((f64::from(s.mean) - mean).abs() < 1e-6);
        assert!((f64::from(s.kurtosis) - kurt).abs() < 1e-5);
        assert!((f64::from(s.skewness) - skew).abs() < 1e-5);
    }

    #[test]
    fn degenerate_and_non_finite_segments() {
        assert_eq!(TimeStats::compute(&[1.0; 16]), Err(Error::Degenerate));
        assert_eq!(TimeStats::compute(&[]), Err(Error::Degenerate));
        assert_eq!(TimeStats::compute(&[1.0, f32::NAN]), Err(Error::NonFinite));
    }
}
