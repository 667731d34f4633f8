//! Linear-phase FIR low-pass filters: the common band limit applied to every record
//! before features, and the anti-alias filter for decimation (e.g. CWRU's 48 kHz
//! normal record down to 12 kHz).
//!
//! Design: windowed sinc with a Blackman window (≈ 74 dB stop-band attenuation,
//! transition width ≈ 5.5·fs/L for L taps), normalized to unit DC gain:
//!
//! ```text
//! h[j] = w[j] · 2·fc/fs · sinc(2·fc/fs · (j − (L−1)/2)),   j = 0..L−1,  L odd
//! w[j] = 0.42 − 0.5·cos(2πj/(L−1)) + 0.08·cos(4πj/(L−1))
//! ```
//!
//! Why a common band limit: the CWRU normal record reaches 12 kHz through a different
//! anti-alias chain (48 kHz, decimated) and carries several times more energy above
//! 5.5 kHz than any 12 kHz fault record. A classifier can key on that acquisition
//! artefact; low-passing every record at the same cutoff (5 kHz by default) removes it.

use crate::error::{expect_len, Error, Result};
use crate::math;

/// Default common band limit in Hz, applied to every record before features.
pub const BAND_LIMIT_HZ: f32 = 5_000.0;

/// Length of the band-limit filter at the model rate (odd): the trainer's
/// preprocessing (scaled by the decimation factor there) and the edge's streaming
/// filter use the same.
pub const BAND_LIMIT_TAPS: usize = 101;

/// Highest cutoff as a fraction of the rate: keeps the anti-alias stop band below the
/// Nyquist frequency.
pub const MAX_CUTOFF_FRACTION: f32 = 0.45;

/// Fill `taps` (odd length ≥ 3) with a Blackman-windowed-sinc low-pass at `cutoff_hz`.
pub fn design_lowpass(cutoff_hz: f32, fs_hz: f32, taps: &mut [f32]) -> Result<()> {
    let l = taps.len();
    if l < 3 || l % 2 == 0 {
        return Err(Error::InvalidParameter(
            "FIR length must be odd and at least 3",
        ));
    }
    if !(cutoff_hz.is_finite() && fs_hz.is_finite()) {
        return Err(Error::NonFinite);
    }
    if !(cutoff_hz > 0.0 && cutoff_hz < 0.5 * fs_hz) {
        return Err(Error::InvalidParameter("cutoff must be in (0, fs/2)"));
    }
    let fc = f64::from(cutoff_hz) / f64::from(fs_hz);
    let mid = (l - 1) as f64 / 2.0;
    let span = (l - 1) as f64;
    let mut sum = 0.0f64;
    let mut coef = [0.0f64; 1];
    for (j, t) in taps.iter_mut().enumerate() {
        let x = j as f64 - mid;
        let sinc = if x == 0.0 {
            2.0 * fc
        } else {
            math::sin(2.0 * math::PI * fc * x) / (math::PI * x)
        };
        let a = 2.0 * math::PI * j as f64 / span;
        let w = 0.42 - 0.5 * math::cos(a) + 0.08 * math::cos(2.0 * a);
        coef[0] = sinc * w;
        sum += coef[0];
        *t = coef[0] as f32;
    }
    let inv = (1.0 / sum) as f32;
    for t in taps.iter_mut() {
        *t *= inv;
    }
    Ok(())
}

/// Output length of [`filter_decimate`] for `n` input samples and decimation `factor`.
pub const fn decimated_len(n: usize, factor: usize) -> usize {
    if factor == 0 {
        0
    } else {
        n.div_ceil(factor)
    }
}

/// Index `i` of a record of `n ≥ 1` samples extended by mirror reflection at both
/// ends, without repeating the edge sample (`−1 → 1`, `n → n − 2`), folded until it
/// lies inside (records shorter than the filter); 0 for `n ≤ 1`.
pub fn mirror_index(i: isize, n: usize) -> usize {
    let n = n as isize;
    let mut i = i;
    loop {
        if n <= 1 {
            return 0;
        }
        if i < 0 {
            i = -i;
        } else if i >= n {
            i = 2 * (n - 1) - i;
        } else {
            return i as usize;
        }
    }
}

/// Zero-phase filtering (the linear-phase delay is compensated) followed by keeping
/// every `factor`-th sample: `out[k] = Σ_j h[j] · x[k·M + (L−1)/2 − j]`.
/// The record is extended by mirror reflection at both ends, so the edges carry no
/// zero-padding transient. `out.len()` must be [`decimated_len`]`(input.len(), factor)`.
pub fn filter_decimate(input: &[f32], taps: &[f32], factor: usize, out: &mut [f32]) -> Result<()> {
    if factor == 0 {
        return Err(Error::InvalidParameter("decimation factor must be >= 1"));
    }
    if taps.is_empty() || taps.len() % 2 == 0 {
        return Err(Error::InvalidParameter("FIR length must be odd"));
    }
    let n = input.len();
    if n == 0 {
        return Err(Error::BufferSize {
            expected: 1,
            got: 0,
        });
    }
    expect_len(out.len(), decimated_len(n, factor))?;
    if input.iter().any(|x| !x.is_finite()) {
        return Err(Error::NonFinite);
    }
    let half = (taps.len() - 1) / 2;
    let n_i = n as isize;
    for (k, y) in out.iter_mut().enumerate() {
        let centre = (k * factor) as isize;
        let lo = centre - half as isize;
        let hi = centre + half as isize;
        let mut acc = 0.0f32;
        if lo >= 0 && hi < n_i {
            // Fast path: no reflection needed. x index = centre + half − j, taken as
            // the window read backwards (the same order of sums, no index checks).
            if let Some(window) = input.get(lo as usize..=hi as usize) {
                for (h, x) in taps.iter().zip(window.iter().rev()) {
                    acc += h * x;
                }
            }
        } else {
            for (j, h) in taps.iter().enumerate() {
                acc += h * input[mirror_index(centre + half as isize - j as isize, n)];
            }
        }
        *y = acc;
    }
    Ok(())
}

/// Streaming FIR low-pass with `L` taps and its own delay line, for sample-by-sample
/// use on the edge. Output is delayed by `(L − 1) / 2` samples.
#[derive(Debug, Clone)]
pub struct FirLowpass<const L: usize> {
    taps: [f32; L],
    line: [f32; L],
    pos: usize,
}

impl<const L: usize> FirLowpass<L> {
    /// Design the filter (`L` odd ≥ 3).
    pub fn new(cutoff_hz: f32, fs_hz: f32) -> Result<Self> {
        let mut taps = [0.0; L];
        design_lowpass(cutoff_hz, fs_hz, &mut taps)?;
        Ok(Self {
            taps,
            line: [0.0; L],
            pos: 0,
        })
    }
    /// Group delay in samples.
    pub const fn delay(&self) -> usize {
        (L - 1) / 2
    }
    /// The taps.
    pub fn taps(&self) -> &[f32; L] {
        &self.taps
    }
    /// Push one sample, get one filtered sample.
    pub fn push(&mut self, x: f32) -> f32 {
        // `pos < L` always; the checked split is the panic-free way to say so.
        let Some((newer, older)) = self.line.split_at_mut_checked(self.pos + 1) else {
            self.pos = 0;
            return 0.0;
        };
        if let Some(newest) = newer.last_mut() {
            *newest = x;
        }
        // taps[0] multiplies the newest sample: line[pos], line[pos − 1], …, line[0],
        // then line[L − 1], …, line[pos + 1].
        let mut acc = 0.0;
        for (h, v) in self
            .taps
            .iter()
            .zip(newer.iter().rev().chain(older.iter().rev()))
        {
            acc += h * v;
        }
        self.pos = if self.pos + 1 >= L { 0 } else { self.pos + 1 };
        acc
    }
    /// Forget the history.
    pub fn reset(&mut self) {
        self.line = [0.0; L];
        self.pos = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tone(f: f64, fs: f64, n: usize) -> [f32; 4096] {
        let mut x = [0.0f32; 4096];
        for (i, v) in x.iter_mut().take(n).enumerate() {
            *v = math::sin(2.0 * math::PI * f * i as f64 / fs) as f32;
        }
        x
    }

    fn rms(x: &[f32]) -> f32 {
        math::sqrtf(x.iter().map(|v| v * v).sum::<f32>() / x.len() as f32)
    }

    #[test]
    fn passband_and_stopband() {
        let mut taps = [0.0f32; 101];
        design_lowpass(5000.0, 12000.0, &mut taps).unwrap();
        assert!((taps.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        let mut out = [0.0f32; 4096];
        // 1 kHz passes (within 0.1 dB), 5.8 kHz is attenuated by ≥ 40 dB.
        let x = tone(1000.0, 12000.0, 4096);
        filter_decimate(&x, &taps, 1, &mut out).unwrap();
        let g = rms(&out[200..3900]) / rms(&x[200..3900]);
        assert!((g - 1.0).abs() < 0.012, "passband gain {g}");
        let x = tone(5800.0, 12000.0, 4096);
        filter_decimate(&x, &taps, 1, &mut out).unwrap();
        let g = rms(&out[200..3900]) / rms(&x[200..3900]);
        assert!(g < 0.01, "stopband gain {g}");
    }

    #[test]
    fn decimation_keeps_phase() {
        // A 600 Hz tone at 48 kHz decimated by 4 equals the same tone sampled at 12 kHz.
        let mut taps = [0.0f32; 301];
        design_lowpass(5000.0, 48000.0, &mut taps).unwrap();
        let x = tone(600.0, 48000.0, 4096);
        let mut out = [0.0f32; 1024];
        filter_decimate(&x, &taps, 4, &mut out).unwrap();
        let want = tone(600.0, 12000.0, 1024);
        for k in 100..900 {
            assert!(
                (out[k] - want[k]).abs() < 2e-3,
                "k {k}: {} vs {}",
                out[k],
                want[k]
            );
        }
    }

    #[test]
    fn streaming_matches_block() {
        let mut f = FirLowpass::<31>::new(2000.0, 12000.0).unwrap();
        let x = tone(700.0, 12000.0, 512);
        let mut block = [0.0f32; 512];
        filter_decimate(&x[..512], f.taps(), 1, &mut block).unwrap();
        let d = f.delay();
        for i in 0..512 {
            let y = f.push(x[i]);
            if i >= 2 * d && i < 512 {
                assert!((y - block[i - d]).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let mut taps = [0.0f32; 4];
        assert!(design_lowpass(100.0, 1000.0, &mut taps).is_err());
        let mut taps = [0.0f32; 5];
        assert!(design_lowpass(600.0, 1000.0, &mut taps).is_err());
        design_lowpass(100.0, 1000.0, &mut taps).unwrap();
        let mut out = [0.0f32; 2];
        assert_eq!(
            filter_decimate(&[1.0, f32::NAN, 0.0], &taps, 2, &mut out),
            Err(Error::NonFinite)
        );
        let mut out = [0.0f32; 3];
        assert!(matches!(
            filter_decimate(&[1.0, 2.0, 3.0], &taps, 2, &mut out),
            Err(Error::BufferSize { .. })
        ));
    }
}
