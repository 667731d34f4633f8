//! Spectral peaks: parabolic refinement of a peak bin, the peak frequency within a
//! range, and the level of a line's harmonics above a floor.

use crate::error::{Error, Result};
use crate::math;

/// Bin position of a peak at bin `k` of `p` refined by a parabola through its
/// neighbours (`k` itself at either end of `p`, or where the three are collinear).
pub fn interpolated_peak(p: &[f32], k: usize) -> f32 {
    if k == 0 || k + 1 >= p.len() {
        return k as f32;
    }
    let (Some(&a), Some(&b), Some(&c)) = (p.get(k - 1), p.get(k), p.get(k + 1)) else {
        return k as f32;
    };
    let denom = a - 2.0 * b + c;
    if denom.abs() < f32::MIN_POSITIVE {
        return k as f32;
    }
    let delta = 0.5 * (a - c) / denom;
    k as f32 + delta.clamp(-0.5, 0.5)
}

/// Frequency of the largest bin of a one-sided spectrum within `[lo_hz, hi_hz]`,
/// refined by parabolic interpolation. `n_fft = 2·(spectrum.len() − 1)`.
pub fn peak_frequency(spectrum: &[f32], fs_hz: f32, lo_hz: f32, hi_hz: f32) -> Result<f32> {
    if spectrum.len() < 3 {
        return Err(Error::BufferSize {
            expected: 3,
            got: spectrum.len(),
        });
    }
    let df = fs_hz / (2 * (spectrum.len() - 1)) as f32;
    let k_lo = ((lo_hz / df) as usize).max(1);
    let k_hi = ((hi_hz / df) as usize).min(spectrum.len() - 2);
    if k_lo > k_hi {
        return Err(Error::InvalidParameter("empty frequency range"));
    }
    let mut k_peak = k_lo;
    for k in k_lo..=k_hi {
        if spectrum[k] > spectrum[k_peak] {
            k_peak = k;
        }
    }
    Ok(interpolated_peak(spectrum, k_peak) * df)
}

/// `10·log10(Σ_{h=1..H} max_{|ν − h·f0| ≤ tol_h} S(ν) / (H·floor))` with
/// `tol_h = max(1 bin, slip·h·f0)`; harmonics above the spectrum are skipped.
pub fn harmonic_level_db(
    spectrum: &[f32],
    fs_hz: f32,
    f0_hz: f32,
    harmonics: usize,
    slip: f32,
    floor: f32,
) -> f32 {
    let df = fs_hz / (2 * (spectrum.len().max(2) - 1)) as f32;
    let mut sum = 0.0f32;
    let mut used = 0usize;
    for h in 1..=harmonics {
        let f = h as f32 * f0_hz;
        let tol = df.max(slip * f);
        let lo = ((f - tol) / df).max(1.0) as usize;
        // Saturating: a huge (finite) f0 — a speed signal gone wild — must end the
        // loop, not wrap `hi` to 0 and index backwards.
        let hi = (((f + tol) / df) as usize).saturating_add(1);
        if hi >= spectrum.len() {
            break;
        }
        let mut best = 0.0f32;
        for &s in spectrum.get(lo..=hi).unwrap_or_default() {
            best = best.max(s);
        }
        sum += best;
        used += 1;
    }
    if used == 0 || floor.is_nan() || floor <= 0.0 {
        return 0.0;
    }
    10.0 * math::log10f(sum / (used as f32 * floor) + 1e-12)
}
