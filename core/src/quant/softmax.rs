//! Integer softmax over a short masked row: the attention normalization of eq. 5 over a
//! GAT neighbourhood (N ≤ 16 nodes), optionally weighted by an edge prior.
//!
//! ```text
//! α_j = exp(e_j) / Σ_{k ∈ N} exp(e_k)                     (5)   j ∈ N (present)
//! with prior a_j > 0:
//! α_j = a_j·exp(e_j) / Σ_{k ∈ N} a_k·exp(e_k)  =  softmax_j(e_j + ln a_j)
//!
//! int8:  m   = max_{j∈N} eq_j
//!        w_j = a_j · ExpLut[m − eq_j]                 (Q0.15 · a_j, u32; the max weighs a_j·2^15)
//!        S   = Σ_{j∈N} w_j                            (u64)
//!        p_j = ⌊(w_j · 2^15 + S/2) / S⌋               (u16 Q0.15: 32768 = 1.0; absent → 0)
//! ```
//!
//! No floats; one integer division per entry.
//!
//! # Shapes
//! `logits`, `mask` / `prior`, `out`: all `[L]`, `1 ≤ L ≤` [`MAX_SOFTMAX_LEN`].
//!
//! # Bounds (stated, tested)
//! - **Sum:** each `p_j` is rounded once (half up), so `|Σ_j p_j − 32768| ≤ n/2` Q0.15
//!   LSBs for `n` present entries: `≤ 8 LSB = 2.4·10^−4` for a 16-node neighbourhood.
//! - **Per entry**, vs [`softmax_f32`]/[`softmax_prior_f32`] on the same (dequantized)
//!   logits: with exp-table errors `|δ_k| ≤ 2^−16`, `Ŝ = Σ a_k·ExpLut[m − eq_k]/2^15 ≥ 1`,
//!   ```text
//!   |p̂_j − α_j| ≤ 2^−16 · (1 + (a_j + α_j·Σ_k a_k) / Ŝ)
//!   ```
//!   which for the plain softmax (`a ≡ 1`) is `≤ (2 + n)·2^−16 = (1 + n/2)` LSB.
//!
//! Measured (5 000 random rows of 1..=16 entries, logit scales 0.005..0.15): plain
//! softmax max 2.05 LSB (`6.3·10^−5`); with an int8 prior 34.7 LSB (`1.06·10^−3`),
//! in rows where a large prior sits on a logit far below the maximum, so the table's
//! absolute step `2^−16` is multiplied by `a_j/Ŝ`. Both use 99 % of the bound above
//! (the bound is tight). Against the logit quantization itself (`s_e/2` per logit,
//! a relative `≈ s_e` on `α`) both are small.

use crate::error::{expect_len, Error, Result};
use crate::math;

use super::lut::ExpLut;

/// 1.0 in the Q0.15 probabilities.
pub const Q15_ONE: u32 = 1 << 15;
/// Longest row accepted (keeps `Σ w_j` and `w_j·2^15` far inside u64).
pub const MAX_SOFTMAX_LEN: usize = 1024;

/// The integer core: `weight(j)` is the prior (0 = absent). Returns `false` (and zeros)
/// when no entry is present. The caller guarantees equal lengths.
pub(crate) fn softmax_row_q15(
    logits: &[i8],
    weight: impl Fn(usize) -> u32,
    exp: &ExpLut,
    out: &mut [u16],
) -> bool {
    let mut max: Option<i8> = None;
    for (j, &e) in logits.iter().enumerate() {
        if weight(j) > 0 && max.is_none_or(|m| e > m) {
            max = Some(e);
        }
    }
    let Some(max) = max else {
        out.iter_mut().for_each(|p| *p = 0);
        return false;
    };
    let w = |j: usize, e: i8| -> u64 {
        let a = weight(j);
        if a == 0 {
            0
        } else {
            // max − e ∈ [0, 255] for int8 codes.
            let d = (i16::from(max) - i16::from(e)) as u8;
            u64::from(exp.lookup(d)) * u64::from(a)
        }
    };
    let mut sum = 0u64;
    for (j, &e) in logits.iter().enumerate() {
        sum += w(j, e);
    }
    // sum ≥ a_max · 32768 > 0: the maximum's table entry is exactly 1.0.
    let sum = sum.max(1);
    for (j, (p, &e)) in out.iter_mut().zip(logits).enumerate() {
        let num = (w(j, e) << 15) + sum / 2;
        *p = (num / sum).min(u64::from(Q15_ONE)) as u16;
    }
    true
}

fn check_row(len: usize, mask_len: usize, out_len: usize) -> Result<()> {
    expect_len(mask_len, len)?;
    expect_len(out_len, len)?;
    if len > MAX_SOFTMAX_LEN {
        return Err(Error::InvalidParameter("softmax row longer than 1024"));
    }
    Ok(())
}

/// Integer softmax over the present entries of an int8 logit row (eq. 5), Q0.15 out.
/// The logit scale is the one `exp` was built for; absent entries get 0.
///
/// # Errors
/// [`Error::BufferSize`] on a length mismatch, [`Error::InvalidParameter`] if the row
/// is longer than [`MAX_SOFTMAX_LEN`], [`Error::NothingPresent`] if no entry is
/// present (then `out` is all zeros).
pub fn softmax_q15(logits: &[i8], mask: &[bool], exp: &ExpLut, out: &mut [u16]) -> Result<()> {
    check_row(logits.len(), mask.len(), out.len())?;
    if softmax_row_q15(logits, |j| u32::from(mask[j]), exp, out) {
        Ok(())
    } else {
        Err(Error::NothingPresent)
    }
}

/// Integer softmax weighted by an int8 prior (`a_j > 0` present, `≤ 0` absent):
/// `α_j ∝ a_j·exp(e_j)`, Q0.15 out. The prior's scale cancels.
///
/// # Errors
/// As [`softmax_q15`].
pub fn softmax_q15_prior(logits: &[i8], prior: &[i8], exp: &ExpLut, out: &mut [u16]) -> Result<()> {
    check_row(logits.len(), prior.len(), out.len())?;
    let weight = |j: usize| if prior[j] > 0 { prior[j] as u32 } else { 0 };
    if softmax_row_q15(logits, weight, exp, out) {
        Ok(())
    } else {
        Err(Error::NothingPresent)
    }
}

/// Float reference core (f64 inside): `α_j = a_j·exp(e_j − m) / Σ_k a_k·exp(e_k − m)`.
pub(crate) fn softmax_row_f32(
    logits: &[f32],
    weight: impl Fn(usize) -> f32,
    out: &mut [f32],
) -> bool {
    let mut max: Option<f32> = None;
    for (j, &e) in logits.iter().enumerate() {
        if weight(j) > 0.0 && max.is_none_or(|m| e > m) {
            max = Some(e);
        }
    }
    let Some(max) = max else {
        out.iter_mut().for_each(|p| *p = 0.0);
        return false;
    };
    let w = |j: usize, e: f32| -> f64 {
        let a = weight(j);
        if a > 0.0 {
            f64::from(a) * math::exp(f64::from(e) - f64::from(max))
        } else {
            0.0
        }
    };
    let sum: f64 = logits.iter().enumerate().map(|(j, &e)| w(j, e)).sum();
    for (j, (p, &e)) in out.iter_mut().zip(logits).enumerate() {
        *p = (w(j, e) / sum) as f32;
    }
    true
}

/// Float reference of [`softmax_q15`].
///
/// # Errors
/// [`Error::BufferSize`] on a length mismatch, [`Error::NonFinite`] for a NaN/∞ logit
/// of a present entry, [`Error::NothingPresent`] if no entry is present.
pub fn softmax_f32(logits: &[f32], mask: &[bool], out: &mut [f32]) -> Result<()> {
    expect_len(mask.len(), logits.len())?;
    expect_len(out.len(), logits.len())?;
    if logits.iter().zip(mask).any(|(e, &m)| m && !e.is_finite()) {
        return Err(Error::NonFinite);
    }
    if softmax_row_f32(logits, |j| if mask[j] { 1.0 } else { 0.0 }, out) {
        Ok(())
    } else {
        Err(Error::NothingPresent)
    }
}

/// Float reference of [`softmax_q15_prior`]: `α_j ∝ a_j·exp(e_j)` over `a_j > 0`.
///
/// # Errors
/// As [`softmax_f32`]; [`Error::NonFinite`] also for a NaN/∞ prior.
pub fn softmax_prior_f32(logits: &[f32], prior: &[f32], out: &mut [f32]) -> Result<()> {
    expect_len(prior.len(), logits.len())?;
    expect_len(out.len(), logits.len())?;
    if logits
        .iter()
        .zip(prior)
        .any(|(e, &a)| !a.is_finite() || (a > 0.0 && !e.is_finite()))
    {
        return Err(Error::NonFinite);
    }
    if softmax_row_f32(logits, |j| prior[j], out) {
        Ok(())
    } else {
        Err(Error::NothingPresent)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quant::qparams::QScale;
    use crate::quant::testkit::{kernel_pair_tests, uniform, KernelPair, Sample};
    use crate::rng::Xoshiro128pp;
    use std::vec::Vec;

    const LSB: f64 = 1.0 / 32768.0;

    /// A random row of length 1..=16 with some entries absent (at least one present).
    fn random_row(rng: &mut Xoshiro128pp) -> (Vec<i8>, Vec<i8>, QScale) {
        let len = 1 + (rng.next_u32() % 16) as usize;
        let s = QScale::new(uniform(rng, 0.005, 0.15)).unwrap();
        let spread = 1 + rng.next_u32() % 127;
        let logits: Vec<i8> = (0..len)
            .map(|_| (rng.next_u32() % (2 * spread + 1)) as i32 - spread as i32)
            .map(|v| v as i8)
            .collect();
        let mut prior: Vec<i8> = (0..len)
            .map(|_| match rng.next_u32() % 4 {
                0 => 0,
                _ => 1 + (rng.next_u32() % 127) as i8,
            })
            .collect();
        if prior.iter().all(|&a| a == 0) {
            prior[0] = 127;
        }
        (logits, prior, s)
    }

    fn compare(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>, use_prior: bool) {
        let (logits, mut prior, s) = random_row(rng);
        if !use_prior {
            prior
                .iter_mut()
                .for_each(|a| *a = if *a > 0 { 1 } else { 0 });
        }
        let exp = ExpLut::new(s);
        let mut p = std::vec![0u16; logits.len()];
        softmax_q15_prior(&logits, &prior, &exp, &mut p).unwrap();
        let lf: Vec<f32> = logits.iter().map(|&q| s.dequantize(i32::from(q))).collect();
        let af: Vec<f32> = prior.iter().map(|&a| f32::from(a)).collect();
        let mut pf = std::vec![0f32; logits.len()];
        softmax_prior_f32(&lf, &af, &mut pf).unwrap();
        // The derived bound, from the integer row's own Ŝ.
        let m = logits
            .iter()
            .zip(&prior)
            .filter(|(_, &a)| a > 0)
            .map(|(&e, _)| e)
            .max()
            .unwrap();
        let s_hat: f64 = logits
            .iter()
            .zip(&prior)
            .filter(|(_, &a)| a > 0)
            .map(|(&e, &a)| f64::from(a) * f64::from(exp.lookup((m as i16 - e as i16) as u8)) * LSB)
            .sum();
        let sum_a: f64 = prior
            .iter()
            .filter(|&&a| a > 0)
            .map(|&a| f64::from(a))
            .sum();
        let n = prior.iter().filter(|&&a| a > 0).count();
        let total: u32 = p.iter().map(|&v| u32::from(v)).sum();
        assert!(
            (f64::from(total) - 32768.0).abs() <= n as f64 / 2.0,
            "sum {total} for n {n}"
        );
        for j in 0..logits.len() {
            let alpha = f64::from(pf[j]);
            let a = f64::from(prior[j].max(0));
            // The f32 reference's own rounding: logits up to 19 in magnitude carry
            // ≤ 1.2e-6 each, so α is off by ≤ 2.4e-6 relative.
            let tol = LSB / 2.0 * (1.0 + (a + alpha * sum_a) / s_hat) + 3e-6 * alpha + 1e-7;
            out.push(Sample::new(f64::from(p[j]) * LSB, alpha, tol, LSB));
        }
    }

    struct Softmax;
    impl KernelPair for Softmax {
        const NAME: &'static str = "softmax_q15 vs softmax_f32 (masked rows, n <= 16)";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            compare(rng, out, false);
        }
    }
    struct SoftmaxPrior;
    impl KernelPair for SoftmaxPrior {
        const NAME: &'static str = "softmax_q15_prior vs softmax_prior_f32";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            compare(rng, out, true);
        }
    }

    kernel_pair_tests! {
        softmax_within_derived_bound: Softmax, seed 41, cases 5000;
        softmax_prior_within_derived_bound: SoftmaxPrior, seed 42, cases 5000;
    }

    #[test]
    fn masks_errors_and_edge_cases() {
        let exp = ExpLut::new(QScale::new(0.1).unwrap());
        let mut p = [0u16; 4];
        softmax_q15(&[5, 5, 5, 5], &[true; 4], &exp, &mut p).unwrap();
        assert_eq!(p, [8192; 4]);
        softmax_q15(
            &[-128, 127, 0, 0],
            &[false, true, false, false],
            &exp,
            &mut p,
        )
        .unwrap();
        assert_eq!(p, [0, 32768, 0, 0]);
        // The extreme spread: 255 steps below the max still indexes the table.
        softmax_q15(
            &[-128, 127, 0, 0],
            &[true, true, false, false],
            &exp,
            &mut p,
        )
        .unwrap();
        assert_eq!(p, [0, 32768, 0, 0]);
        assert_eq!(
            softmax_q15(&[1, 2, 3, 4], &[false; 4], &exp, &mut p),
            Err(Error::NothingPresent)
        );
        assert_eq!(p, [0; 4]);
        assert!(softmax_q15(&[1, 2, 3], &[true; 4], &exp, &mut p).is_err());
        assert!(softmax_q15_prior(&[1, 2, 3, 4], &[0, -5, 0, 0], &exp, &mut p).is_err());
        let long = [0i8; MAX_SOFTMAX_LEN + 1];
        let mut long_out = [0u16; MAX_SOFTMAX_LEN + 1];
        assert!(matches!(
            softmax_q15(&long, &[true; MAX_SOFTMAX_LEN + 1], &exp, &mut long_out),
            Err(Error::InvalidParameter(_))
        ));
        // A prior of 3:1 on equal logits gives 3/4 : 1/4.
        softmax_q15_prior(&[9, 9, 0, 0], &[96, 32, 0, 0], &exp, &mut p).unwrap();
        assert_eq!(p, [24576, 8192, 0, 0]);
        let mut pf = [0f32; 4];
        softmax_prior_f32(&[0.9, 0.9, 0.0, 0.0], &[0.75, 0.25, 0.0, 0.0], &mut pf).unwrap();
        assert!((pf[0] - 0.75).abs() < 1e-7 && pf[2] == 0.0);
        assert_eq!(
            softmax_f32(&[f32::NAN, 0.0], &[true, true], &mut pf[..2]),
            Err(Error::NonFinite)
        );
        softmax_f32(&[f32::NAN, 0.0], &[false, true], &mut pf[..2]).unwrap();
        assert_eq!(&pf[..2], &[0.0, 1.0]);
    }
}
