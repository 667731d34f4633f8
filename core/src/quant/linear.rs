//! Int8 fully connected layer: the `W·x + b` inside every equation of §4.2 (the GAT
//! projection of eq. 4/6, the GRU gate products of eq. 7, the classifier of eq. 8).
//!
//! ```text
//! float:  y[o]  = Σ_k W[o][k] · x[k] + b[o]
//! int8:   acc[o] = bq[o] + Σ_k Wq[o][k] · xq[k]                       (i32, exact)
//!         yq[o]  = clamp(round_half_away(acc[o] · M[o]), −127, 127)
//!         W[o][k] ≈ s_w[o]·Wq[o][k],  b[o] ≈ s_x·s_w[o]·bq[o],  M[o] ≈ s_x·s_w[o] / s_y
//! ```
//!
//! # Shapes
//! - `W`: `[OUT][IN]` (row `o` is output channel `o`, with its own scale `s_w[o]`)
//! - `x`: `[IN]` at the per-tensor input scale `s_x`
//! - `y`: `[OUT]` at the per-tensor output scale `s_y`
//!
//! # Tolerance (derived, tested)
//! Against [`LinearF32`] run on the dequantized input `x̂ = s_x·xq`, for every output
//! that does not saturate:
//!
//! ```text
//! |s_y·yq[o] − y[o]| ≤ s_y/2                      (output rounding)
//!                    + (s_w[o]/2) · Σ_k |x̂[k]|     (weight rounding, |ΔW| ≤ s_w/2)
//!                    + s_x·s_w[o]/2                (bias rounding)
//!                    + 2^−31·|acc|·s_x·s_w[o]      (multiplier mantissa; negligible)
//! ```
//!
//! Measured over 2 000 random layers × 8 inputs × 10 outputs (seed 21, `IN = 24`):
//! max error 1.29 output LSB, 82 % of this bound (the `[quant] linear` line of
//! `cargo test -p pumptwin-core quant -- --nocapture`).

use crate::error::{Error, Result};

use super::arith::{dot_i8, round_half_away};
use super::qparams::{per_channel_scales, quantize_value, QMultiplier, QScale};

/// Largest bias magnitude (keeps `bias + dot` inside i32, see [`super::MAX_DOT_LEN`]).
pub const MAX_BIAS: i32 = (1 << 30) - 1;

/// Float reference: `y = W·x + b`.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearF32<const IN: usize, const OUT: usize> {
    /// Weights, `[OUT][IN]`.
    pub w: [[f32; IN]; OUT],
    /// Bias, `[OUT]`.
    pub b: [f32; OUT],
}

impl<const IN: usize, const OUT: usize> LinearF32<IN, OUT> {
    /// All weights and biases zero.
    pub const ZERO: Self = Self {
        w: [[0.0; IN]; OUT],
        b: [0.0; OUT],
    };

    /// `y = W·x + b` (f32 accumulation).
    pub fn forward(&self, x: &[f32; IN], y: &mut [f32; OUT]) {
        for (yo, (row, &b)) in y.iter_mut().zip(self.w.iter().zip(&self.b)) {
            let mut acc = b;
            for (&w, &xk) in row.iter().zip(x) {
                acc += w * xk;
            }
            *yo = acc;
        }
    }
}

/// Int8 fully connected layer with per-output-channel weight scales, i32 biases and
/// per-channel integer requantization. Plain data: a model-file decoder fills it
/// through [`QLinear::from_parts`]; the trainer builds it with [`QLinear::from_f32`].
#[derive(Debug, Clone, PartialEq)]
pub struct QLinear<const IN: usize, const OUT: usize> {
    weights: [[i8; IN]; OUT],
    weight_scales: [QScale; OUT],
    bias: [i32; OUT],
    input_scale: QScale,
    output_scale: QScale,
    requant: [QMultiplier; OUT],
}

impl<const IN: usize, const OUT: usize> QLinear<IN, OUT> {
    /// An all-zero layer (every scale 1/127): the starting value of a layer that is
    /// filled in place with [`QLinear::set_parts`] (e.g. in a `static`).
    pub const EMPTY: Self = Self {
        weights: [[0; IN]; OUT],
        weight_scales: [QScale::UNIT; OUT],
        bias: [0; OUT],
        input_scale: QScale::UNIT,
        output_scale: QScale::UNIT,
        requant: [QMultiplier::INV_127; OUT],
    };

    /// [`QLinear::from_parts`] in place, from slices: the first `rows` output channels
    /// get `weights` (`rows·IN` codes, row-major), `weight_scales` and `bias` (`rows`
    /// each, `1 ≤ rows ≤ OUT`); the rest are zero padding (zero weights and bias, the
    /// first row's scale). Needs no temporary of the layer's size, so a decoder on an
    /// MCU can fill a layer that lives in a `static`.
    ///
    /// # Errors
    /// [`Error::BufferSize`] for slice lengths that do not fit; the errors of
    /// [`QLinear::from_parts`]. On error `self` is partly overwritten.
    pub fn set_parts(
        &mut self,
        weights: &[i8],
        weight_scales: &[QScale],
        bias: &[i32],
        input_scale: QScale,
        output_scale: QScale,
    ) -> Result<()> {
        let rows = weight_scales.len();
        if rows == 0 || rows > OUT || bias.len() != rows || weights.len() != rows * IN {
            return Err(Error::BufferSize {
                expected: rows.clamp(1, OUT) * IN,
                got: weights.len(),
            });
        }
        if bias.iter().any(|b| b.unsigned_abs() > MAX_BIAS as u32) {
            return Err(Error::InvalidParameter("int32 bias exceeds 2^30 - 1"));
        }
        self.input_scale = input_scale;
        self.output_scale = output_scale;
        for o in 0..OUT {
            let (sw, b) = if o < rows {
                (weight_scales[o], bias[o])
            } else {
                (weight_scales[0], 0)
            };
            match weights.get(o * IN..(o + 1) * IN) {
                Some(src) if o < rows => self.weights[o].copy_from_slice(src),
                _ => self.weights[o] = [0; IN],
            }
            self.weight_scales[o] = sw;
            self.bias[o] = b;
            self.requant[o] = QMultiplier::from_scales(input_scale, sw, output_scale).ok_or(
                Error::InvalidParameter("requantization ratio outside [2^-32, 2^31)"),
            )?;
        }
        Ok(())
    }

    /// Assemble from stored parts; derives the multipliers `s_x·s_w[o]/s_y`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if a bias exceeds [`MAX_BIAS`] in magnitude or a
    /// ratio `s_x·s_w[o]/s_y` is outside `[2^−32, 2^31)`.
    pub fn from_parts(
        weights: [[i8; IN]; OUT],
        weight_scales: [QScale; OUT],
        bias: [i32; OUT],
        input_scale: QScale,
        output_scale: QScale,
    ) -> Result<Self> {
        if bias.iter().any(|b| b.unsigned_abs() > MAX_BIAS as u32) {
            return Err(Error::InvalidParameter("int32 bias exceeds 2^30 - 1"));
        }
        let mut requant = [QMultiplier::INV_127; OUT];
        for (m, &sw) in requant.iter_mut().zip(&weight_scales) {
            *m = QMultiplier::from_scales(input_scale, sw, output_scale).ok_or(
                Error::InvalidParameter("requantization ratio outside [2^-32, 2^31)"),
            )?;
        }
        Ok(Self {
            weights,
            weight_scales,
            bias,
            input_scale,
            output_scale,
            requant,
        })
    }

    /// Quantize a float layer: per-channel max-abs weight scales, biases at the
    /// accumulator scale `s_x·s_w[o]`, for the given input and output scales.
    ///
    /// # Errors
    /// [`Error::NonFinite`] for a NaN/∞ weight or bias; the errors of
    /// [`QLinear::from_parts`] (e.g. a bias too large for its accumulator scale).
    pub fn from_f32(
        float: &LinearF32<IN, OUT>,
        input_scale: QScale,
        output_scale: QScale,
    ) -> Result<Self> {
        let weight_scales = per_channel_scales(&float.w)?;
        let mut weights = [[0i8; IN]; OUT];
        let mut bias = [0i32; OUT];
        for o in 0..OUT {
            for k in 0..IN {
                weights[o][k] = quantize_value(float.w[o][k], weight_scales[o])?;
            }
            bias[o] = quantize_bias(
                float.b[o],
                f64::from(input_scale.get()) * f64::from(weight_scales[o].get()),
            )?;
        }
        Self::from_parts(weights, weight_scales, bias, input_scale, output_scale)
    }

    /// `acc = W·x + b` in i32 (exact; no requantization).
    pub fn accumulate(&self, x: &[i8; IN], acc: &mut [i32; OUT]) {
        for ((a, row), &b) in acc.iter_mut().zip(&self.weights).zip(&self.bias) {
            *a = b.saturating_add(dot_i8(row, x));
        }
    }

    /// `yq = requant(W·x + b)`: int8 at the output scale, saturated to `[−127, 127]`.
    pub fn forward(&self, x: &[i8; IN], y: &mut [i8; OUT]) {
        for (((yo, row), &b), m) in y
            .iter_mut()
            .zip(&self.weights)
            .zip(&self.bias)
            .zip(&self.requant)
        {
            *yo = m.apply(b.saturating_add(dot_i8(row, x)));
        }
    }

    /// Like [`QLinear::forward`] but the result stays i32 (rounded to the output
    /// scale, saturated only at the i32 range): logits with a common fine scale.
    pub fn forward_i32(&self, x: &[i8; IN], y: &mut [i32; OUT]) {
        for (((yo, row), &b), m) in y
            .iter_mut()
            .zip(&self.weights)
            .zip(&self.bias)
            .zip(&self.requant)
        {
            *yo = m.apply_i32(b.saturating_add(dot_i8(row, x)));
        }
    }

    /// Int8 weights, `[OUT][IN]`.
    pub fn weights(&self) -> &[[i8; IN]; OUT] {
        &self.weights
    }
    /// Per-output-channel weight scales.
    pub fn weight_scales(&self) -> &[QScale; OUT] {
        &self.weight_scales
    }
    /// I32 biases at the accumulator scales `s_x·s_w[o]`.
    pub fn bias(&self) -> &[i32; OUT] {
        &self.bias
    }
    /// The input scale `s_x`.
    pub fn input_scale(&self) -> QScale {
        self.input_scale
    }
    /// The output scale `s_y`.
    pub fn output_scale(&self) -> QScale {
        self.output_scale
    }
    /// The per-channel requantization multipliers `s_x·s_w[o]/s_y`.
    pub fn requant(&self) -> &[QMultiplier; OUT] {
        &self.requant
    }
}

/// `round_half_away(b / acc_scale)` as an i32 bias within [`MAX_BIAS`].
pub(crate) fn quantize_bias(b: f32, acc_scale: f64) -> Result<i32> {
    if !b.is_finite() {
        return Err(Error::NonFinite);
    }
    let q = round_half_away(f64::from(b) / acc_scale);
    if q.abs() > f64::from(MAX_BIAS) {
        return Err(Error::InvalidParameter(
            "bias too large for its accumulator scale",
        ));
    }
    Ok(q as i32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quant::qparams::{MaxAbs, QScale};
    use crate::quant::testkit::{
        kernel_pair_tests, random_matrix, random_vector, uniform, KernelPair, Sample,
    };
    use crate::rng::Xoshiro128pp;
    use std::vec::Vec;

    const IN: usize = 24;
    const OUT: usize = 10;

    /// A random float layer with weights in ±amp and biases in ±1.
    fn random_linear<const I: usize, const O: usize>(rng: &mut Xoshiro128pp) -> LinearF32<I, O> {
        let amp = f64::from(uniform(rng, 0.05, 2.0));
        LinearF32 {
            w: random_matrix(rng, amp),
            b: random_vector(rng, 1.0),
        }
    }

    struct Linear;
    impl KernelPair for Linear {
        const NAME: &'static str = "linear (QLinear vs LinearF32)";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            let float = random_linear::<IN, OUT>(rng);
            let x_amp = f64::from(uniform(rng, 0.1, 5.0));
            let xs: [[f32; IN]; 8] = random_matrix(rng, x_amp);
            // Calibrate: input and output scales by max-abs over the batch.
            let mut in_range = MaxAbs::new();
            xs.iter().for_each(|x| in_range.observe_all(x));
            let s_x = in_range.scale().unwrap();
            let mut xq = [[0i8; IN]; 8];
            let mut xhat = [[0f32; IN]; 8];
            for (n, x) in xs.iter().enumerate() {
                crate::quant::qparams::quantize_symmetric(x, s_x, &mut xq[n]).unwrap();
                crate::quant::qparams::dequantize(&xq[n], s_x, &mut xhat[n]).unwrap();
            }
            let mut out_range = MaxAbs::new();
            let mut yf = [[0f32; OUT]; 8];
            for n in 0..8 {
                float.forward(&xhat[n], &mut yf[n]);
                out_range.observe_all(&yf[n]);
            }
            let s_y = out_range.scale().unwrap();
            let q = QLinear::from_f32(&float, s_x, s_y).unwrap();
            for n in 0..8 {
                let mut yq = [0i8; OUT];
                q.forward(&xq[n], &mut yq);
                let l1: f64 = xhat[n].iter().map(|v| f64::from(v.abs())).sum();
                for o in 0..OUT {
                    let sw = f64::from(q.weight_scales()[o].get());
                    let sx = f64::from(s_x.get());
                    let sy = f64::from(s_y.get());
                    let want = f64::from(yf[n][o]);
                    let tol = 0.5 * sy + 0.5 * sw * l1 + 0.5 * sx * sw + 1e-6 * (1.0 + want.abs());
                    out.push(Sample::new(f64::from(yq[o]) * sy, want, tol, sy));
                }
            }
        }
    }

    kernel_pair_tests! {
        linear_within_derived_bound: Linear, seed 21, cases 2000;
    }

    #[test]
    fn integer_path_is_exact() {
        // Miri interprets this a thousand times slower (144 s for the 200 cases):
        // the kernels' memory accesses do not depend on the values, so twenty cases
        // walk every path there; the native runs keep all 200.
        let cases = if cfg!(miri) { 20 } else { 200 };
        let mut rng = Xoshiro128pp::seed_from_u64(22);
        for _ in 0..cases {
            let float = random_linear::<IN, OUT>(&mut rng);
            let s_x = QScale::new(0.03).unwrap();
            let q = QLinear::from_f32(&float, s_x, QScale::new(0.05).unwrap()).unwrap();
            let x: [i8; IN] = core::array::from_fn(|_| (rng.next_u32() % 255) as i8);
            let mut acc = [0i32; OUT];
            let mut y = [0i8; OUT];
            let mut y32 = [0i32; OUT];
            q.accumulate(&x, &mut acc);
            q.forward(&x, &mut y);
            q.forward_i32(&x, &mut y32);
            for o in 0..OUT {
                let wide: i64 = q.bias()[o] as i64
                    + (0..IN)
                        .map(|k| i64::from(q.weights()[o][k]) * i64::from(x[k]))
                        .sum::<i64>();
                assert_eq!(i64::from(acc[o]), wide);
                let m = q.requant()[o];
                let p = i128::from(acc[o]) * i128::from(m.mult());
                let d = 1i128 << m.shift();
                let r = (p.abs() + d / 2) / d * p.signum();
                assert_eq!(i128::from(y32[o]), r);
                assert_eq!(i128::from(y[o]), r.clamp(-127, 127));
            }
        }
    }

    #[test]
    fn rejects_bad_parts() {
        let s = QScale::ONE;
        let too_big = QLinear::<2, 1>::from_parts([[1, 2]], [s], [1 << 30], s, s);
        assert!(matches!(too_big, Err(Error::InvalidParameter(_))));
        let tiny = QScale::new(1e-30).unwrap();
        let bad_ratio = QLinear::<2, 1>::from_parts([[1, 2]], [tiny], [0], tiny, s);
        assert!(matches!(bad_ratio, Err(Error::InvalidParameter(_))));
        let mut float = LinearF32::<2, 1>::ZERO;
        float.w[0][1] = f32::NAN;
        assert_eq!(QLinear::from_f32(&float, s, s), Err(Error::NonFinite));
        let mut float = LinearF32::<2, 1>::ZERO;
        float.b[0] = 1e6;
        let small = QScale::new(1e-3).unwrap();
        assert!(QLinear::from_f32(&float, small, s).is_err());
    }
}
