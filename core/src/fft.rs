//! Radix-2 complex FFT, in place, no tables: twiddles come from a per-stage f64
//! recurrence `w_{j+1} = w_j · e^{∓2πi/len}` (error ≈ j·ε_f64, far below f32
//! resolution), so the transform needs no plan memory at all, just the caller's buffer.
//!
//! ```text
//! forward:  X_k = Σ_n x_n · e^{−2πi·kn/N}
//! inverse:  x_n = (1/N) · Σ_k X_k · e^{+2πi·kn/N}
//! ```

use crate::error::{Error, Result};
use crate::math;

/// A complex number in f32.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Complex32 {
    /// Real part.
    pub re: f32,
    /// Imaginary part.
    pub im: f32,
}

impl Complex32 {
    /// Zero.
    pub const ZERO: Self = Self { re: 0.0, im: 0.0 };
    /// `re + i·im`.
    pub const fn new(re: f32, im: f32) -> Self {
        Self { re, im }
    }
    /// `|z|²`.
    #[inline]
    pub fn norm_sqr(self) -> f32 {
        self.re * self.re + self.im * self.im
    }
    /// `|z|`.
    #[inline]
    pub fn norm(self) -> f32 {
        math::sqrtf(self.norm_sqr())
    }
}

/// Transform direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// `e^{−2πi kn/N}`, unscaled.
    Forward,
    /// `e^{+2πi kn/N}`, scaled by `1/N`.
    Inverse,
}

/// Twiddles held at a time by the blocked stages of [`fft_in_place`] (512 bytes of
/// stack); stages with fewer twiddles walk the buffer once per twiddle.
const TWIDDLE_RUN: usize = 64;

/// Length from which the stages with many twiddles go block by block: below it the
/// buffer (32 KiB at 4096 points) stays near a desktop core's L1 cache and the strided
/// walk is the faster (measured on the 2-core VM, same results bit for bit: blocked
/// 1.15× the time at 4096 points, 0.75× at 8192, the envelope block of the twin's fit).
const BLOCKED_FROM: usize = 8192;

/// In-place FFT of a power-of-two length ≥ 2.
///
/// # Errors
/// [`Error::NotPowerOfTwo`] for any other length.
pub fn fft_in_place(buf: &mut [Complex32], direction: Direction) -> Result<()> {
    fft_walked(buf, direction, BLOCKED_FROM)
}

/// [`fft_in_place`] with the stages of `half ≥ 64` twiddles going block by block from
/// length `blocked_from` (the library uses [`BLOCKED_FROM`]): `usize::MAX` walks every
/// stage by twiddle, `0` blocks every stage that has enough twiddles. The results are
/// the same bit for bit; only the memory walk differs. For the bench that measures
/// the two walks side by side (`cargo bench -p pumptwin-core --bench core_bench`) and
/// the test that they agree.
#[doc(hidden)]
pub fn fft_walked(buf: &mut [Complex32], direction: Direction, blocked_from: usize) -> Result<()> {
    let n = buf.len();
    if n < 2 || !n.is_power_of_two() {
        return Err(Error::NotPowerOfTwo(n));
    }
    // Bit-reversal permutation.
    let bits = n.trailing_zeros();
    for i in 0..n {
        let j = i.reverse_bits() >> (usize::BITS - bits);
        // `j < n` always holds; saying so lets the optimiser drop `swap`'s panic path.
        if j > i && j < n {
            buf.swap(i, j);
        }
    }
    let sign = match direction {
        Direction::Forward => -1.0,
        Direction::Inverse => 1.0,
    };
    let mut len = 2;
    while len <= n {
        let half = len / 2;
        let theta = sign * 2.0 * math::PI / len as f64;
        let (step_re, step_im) = (math::cos(theta), math::sin(theta));
        if half < TWIDDLE_RUN || n < blocked_from {
            stage_by_twiddle(buf, len, (step_re, step_im));
        } else {
            stage_by_block(buf, len, (step_re, step_im));
        }
        len *= 2;
    }
    if direction == Direction::Inverse {
        let s = 1.0 / n as f32;
        for z in buf.iter_mut() {
            z.re *= s;
            z.im *= s;
        }
    }
    Ok(())
}

/// Twiddle `w_j` of a stage, walked j by j: `w_0 = 1`, `w_{j+1} = w_j · step` in f64.
#[inline(always)]
fn next_twiddle(w: &mut (f64, f64), step: (f64, f64)) -> (f32, f32) {
    let out = (w.0 as f32, w.1 as f32);
    let re = w.0 * step.0 - w.1 * step.1;
    w.1 = w.0 * step.1 + w.1 * step.0;
    w.0 = re;
    out
}

/// The butterfly of `a` and `b` with twiddle `(wr, wi)`.
#[inline(always)]
fn butterfly(a: &mut Complex32, b: &mut Complex32, (wr, wi): (f32, f32)) {
    let (x, y) = (*a, *b);
    let t = Complex32::new(y.re * wr - y.im * wi, y.re * wi + y.im * wr);
    *a = Complex32::new(x.re + t.re, x.im + t.im);
    *b = Complex32::new(x.re - t.re, x.im - t.im);
}

/// One stage of butterfly span `len`, j outer: each twiddle is applied down the whole
/// buffer (a strided walk; few twiddles, so few walks).
#[inline]
fn stage_by_twiddle(buf: &mut [Complex32], len: usize, step: (f64, f64)) {
    let half = len / 2;
    let mut w = (1.0f64, 0.0f64);
    for j in 0..half {
        let tw = next_twiddle(&mut w, step);
        let mut k = j;
        // `k + half < n` for every `k ≡ j (mod len)` below `n`, as `j < half`; the
        // checked accesses make that visible to the optimiser (no panic path).
        while let (Some(&a), Some(&b)) = (buf.get(k), buf.get(k + half)) {
            let (mut x, mut y) = (a, b);
            butterfly(&mut x, &mut y, tw);
            if let Some(slot) = buf.get_mut(k) {
                *slot = x;
            }
            if let Some(slot) = buf.get_mut(k + half) {
                *slot = y;
            }
            k += len;
        }
    }
}

/// One stage of butterfly span `len`, blocks outer: the twiddles of [`TWIDDLE_RUN`]
/// consecutive j, from the same j-by-j recurrence (so every `w_j` has the value
/// [`stage_by_twiddle`] gives it), are applied to every block, whose run of butterflies
/// is contiguous in memory; a walk per twiddle would stride the buffer `half` times.
fn stage_by_block(buf: &mut [Complex32], len: usize, step: (f64, f64)) {
    let half = len / 2;
    let mut w = (1.0f64, 0.0f64);
    let mut run = [(0.0f32, 0.0f32); TWIDDLE_RUN];
    let mut j0 = 0;
    while j0 < half {
        let m = TWIDDLE_RUN.min(half - j0);
        for t in run.iter_mut().take(m) {
            *t = next_twiddle(&mut w, step);
        }
        for block in buf.chunks_exact_mut(len) {
            let (lo, hi) = block.split_at_mut(half);
            let (Some(lo), Some(hi)) = (lo.get_mut(j0..), hi.get_mut(j0..)) else {
                continue;
            };
            for ((a, b), &tw) in lo.iter_mut().zip(hi.iter_mut()).zip(run.iter().take(m)) {
                butterfly(a, b, tw);
            }
        }
        j0 += m;
    }
}

/// Window applied before a spectrum.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Window {
    /// No taper.
    Rectangular,
    /// `0.5 − 0.5·cos(2πn/N)` (periodic Hann).
    Hann,
}

impl Window {
    /// Weight of sample `i` of `n`.
    #[inline]
    pub fn weight(self, i: usize, n: usize) -> f32 {
        match self {
            Window::Rectangular => 1.0,
            Window::Hann => (0.5 - 0.5 * math::cos(2.0 * math::PI * i as f64 / n as f64)) as f32,
        }
    }
}

/// One-sided power spectrum of a real signal: `out[k] = |X_k|² / (N·Σw²)` doubled
/// for `0 < k < N/2` (so `Σ out ≈ mean square` for a rectangular window).
/// `scratch.len() == x.len()` (power of two), `out.len() == N/2 + 1`.
pub fn power_spectrum(
    x: &[f32],
    window: Window,
    scratch: &mut [Complex32],
    out: &mut [f32],
) -> Result<()> {
    let n = x.len();
    crate::error::expect_len(scratch.len(), n)?;
    crate::error::expect_len(out.len(), n / 2 + 1)?;
    let mut wsum = 0.0f32;
    match window {
        Window::Rectangular => {
            for (z, &v) in scratch.iter_mut().zip(x.iter()) {
                *z = Complex32::new(v, 0.0);
            }
            wsum = n as f32;
        }
        Window::Hann => {
            // cos(2πi/n) by a rotation recurrence in f64 (error ≈ i·ε_f64), not one
            // libm call per sample: this loop runs for every segment of every node.
            let theta = 2.0 * math::PI / n as f64;
            let (c1, s1) = (math::cos(theta), math::sin(theta));
            let (mut c, mut s) = (1.0f64, 0.0f64);
            for (z, &v) in scratch.iter_mut().zip(x.iter()) {
                let w = (0.5 - 0.5 * c) as f32;
                wsum += w * w;
                *z = Complex32::new(v * w, 0.0);
                let next = c * c1 - s * s1;
                s = s * c1 + c * s1;
                c = next;
            }
        }
    }
    fft_in_place(scratch, Direction::Forward)?;
    let norm = 1.0 / (n as f32 * wsum);
    for (k, (o, z)) in out.iter_mut().zip(scratch.iter()).enumerate() {
        let p = z.norm_sqr() * norm;
        *o = if k == 0 || k == n / 2 { p } else { 2.0 * p };
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro128pp;
    use std::vec::Vec;

    fn random_signal(n: usize, seed: u64) -> Vec<Complex32> {
        let mut r = Xoshiro128pp::seed_from_u64(seed);
        (0..n)
            .map(|_| Complex32::new(r.normal() as f32, r.normal() as f32))
            .collect()
    }

    /// Against a naive f64 DFT, fixed seed; max error relative to the spectrum's RMS.
    #[test]
    fn matches_naive_dft() {
        for &n in &[2usize, 4, 8, 64, 256] {
            let x = random_signal(n, n as u64);
            let mut y = x.clone();
            fft_in_place(&mut y, Direction::Forward).unwrap();
            let mut rms = 0.0f64;
            let mut max_err = 0.0f64;
            for k in 0..n {
                let (mut re, mut im) = (0.0f64, 0.0f64);
                for (j, z) in x.iter().enumerate() {
                    let a = -2.0 * math::PI * (k * j % n) as f64 / n as f64;
                    re += f64::from(z.re) * math::cos(a) - f64::from(z.im) * math::sin(a);
                    im += f64::from(z.re) * math::sin(a) + f64::from(z.im) * math::cos(a);
                }
                rms += re * re + im * im;
                max_err = max_err
                    .max((re - f64::from(y[k].re)).abs())
                    .max((im - f64::from(y[k].im)).abs());
            }
            let rms = (rms / n as f64).sqrt();
            assert!(max_err / rms < 1e-5, "n {n}: rel err {}", max_err / rms);
        }
    }

    /// Against rustfft at the feature sizes; stated tolerance 2e-5 of the RMS.
    #[test]
    fn matches_rustfft() {
        use rustfft::{num_complex::Complex, FftPlanner};
        for &n in &[512usize, 2048, 16384] {
            let x = random_signal(n, 11);
            let mut ours = x.clone();
            fft_in_place(&mut ours, Direction::Forward).unwrap();
            let mut theirs: Vec<Complex<f64>> = x
                .iter()
                .map(|z| Complex::new(f64::from(z.re), f64::from(z.im)))
                .collect();
            FftPlanner::<f64>::new()
                .plan_fft_forward(n)
                .process(&mut theirs);
            let rms = (theirs.iter().map(|z| z.norm_sqr()).sum::<f64>() / n as f64).sqrt();
            let max_err = ours
                .iter()
                .zip(theirs.iter())
                .map(|(a, b)| {
                    (f64::from(a.re) - b.re)
                        .abs()
                        .max((f64::from(a.im) - b.im).abs())
                })
                .fold(0.0, f64::max);
            assert!(max_err / rms < 2e-5, "n {n}: rel err {}", max_err / rms);
        }
    }

    /// The two memory walks give the same spectrum bit for bit, at every size from
    /// one where no stage is blocked to the twin's longest envelope block, both ways.
    #[test]
    fn both_walks_are_bit_identical() {
        for &n in &[256usize, 4096, 8192, 32768] {
            let x = random_signal(n, 17);
            for dir in [Direction::Forward, Direction::Inverse] {
                let (mut strided, mut blocked) = (x.clone(), x.clone());
                fft_walked(&mut strided, dir, usize::MAX).unwrap();
                fft_walked(&mut blocked, dir, 0).unwrap();
                let same = strided.iter().zip(&blocked).all(|(a, b)| {
                    a.re.to_bits() == b.re.to_bits() && a.im.to_bits() == b.im.to_bits()
                });
                assert!(same, "n {n} {dir:?}: the walks differ");
            }
        }
    }

    #[test]
    fn inverse_round_trip() {
        let x = random_signal(1024, 5);
        let mut y = x.clone();
        fft_in_place(&mut y, Direction::Forward).unwrap();
        fft_in_place(&mut y, Direction::Inverse).unwrap();
        for (a, b) in x.iter().zip(y.iter()) {
            assert!((a.re - b.re).abs() < 1e-5 && (a.im - b.im).abs() < 1e-5);
        }
    }

    #[test]
    fn parseval_power_spectrum() {
        let n = 1024;
        let x: Vec<f32> = random_signal(n, 2).iter().map(|z| z.re).collect();
        let mut scratch = std::vec![Complex32::ZERO; n];
        let mut p = std::vec![0.0f32; n / 2 + 1];
        power_spectrum(&x, Window::Rectangular, &mut scratch, &mut p).unwrap();
        let ms = x.iter().map(|v| v * v).sum::<f32>() / n as f32;
        assert!((p.iter().sum::<f32>() / ms - 1.0).abs() < 1e-4);
    }

    #[test]
    fn rejects_bad_lengths() {
        let mut b = [Complex32::ZERO; 12];
        assert_eq!(
            fft_in_place(&mut b, Direction::Forward),
            Err(Error::NotPowerOfTwo(12))
        );
        assert_eq!(
            fft_in_place(&mut b[..1], Direction::Forward),
            Err(Error::NotPowerOfTwo(1))
        );
    }
}
