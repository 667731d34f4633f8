//! Int8 inference kernels for the DS-STGAT (paper §4.2, eqs. 4–8), each with a plain
//! float reference beside it.
//!
//! | file | int8 kernel | float reference | paper |
//! |---|---|---|---|
//! | [`qparams`] | [`QScale`], [`QMultiplier`] (requantization), quantize helpers | `round(acc · real)` | — |
//! | [`linear`] | [`QLinear`] `y = requant(W·x + b)` | [`LinearF32`] | eqs. 4, 6–8 (every `W·x`) |
//! | [`lut`] | [`Lut8`] sigmoid/tanh, [`ExpLut`], [`LeakyRelu`] | f64 functions | eqs. 4, 5, 7 |
//! | [`softmax`] | [`softmax_q15`], [`softmax_q15_prior`] | [`softmax_f32`], [`softmax_prior_f32`] | eq. 5 |
//! | [`gat`] | [`GatLayer`] | [`GatLayerF32`] | eqs. 4–6 |
//! | [`gru`] | [`GruCell`] | [`GruCellF32`] | eq. 7 |
//! | [`pool`] | [`AttentionPool`], [`Classifier`] | [`AttentionPoolF32`], [`LinearF32`] | §4.2 pooling, eq. 8 |
//!
//! # The quantization scheme
//!
//! ```text
//! real value  r ≈ s · q            q ∈ [−127, 127] (int8), s > 0 (QScale), zero point 0
//! weights     W[o][k] ≈ s_w[o] · Wq[o][k]     s_w[o] = max_k |W[o][k]| / 127   (per output channel)
//! biases      b[o]    ≈ s_x · s_w[o] · bq[o]  bq: i32  (the accumulator's scale)
//! accumulate  acc[o]  = bq[o] + Σ_k Wq[o][k] · xq[k]            (i32, exact)
//! requantize  yq[o]   = clamp(round_half_away(acc[o] · M[o]), −127, 127)
//!             M[o]    = s_x · s_w[o] / s_y  ≈  mult · 2^−shift   (QMultiplier, integer only)
//! ```
//!
//! Choices, and why:
//! - **Symmetric activations (zero point 0).** Every kernel then is a plain integer dot
//!   product with no zero-point correction terms, the same code serves weights and
//!   activations, and negation is closed on the code range. The price is one bit on
//!   the ReLU outputs of the GAT layer (only codes 0..=127 are used there); the GRU
//!   hidden state, the tanh/sigmoid gates and the attention logits are signed or
//!   centred anyway, so an asymmetric scheme would buy nothing there.
//! - **Codes in [−127, 127]**, never −128: the range is symmetric, so `|q| ≤ 127`
//!   bounds every product by 127² and saturation is the same on both sides.
//! - **Rounding: round half away from zero** ([`Rounding::HalfAwayFromZero`]) everywhere,
//!   in the float quantizers and in the integer requantization alike (as gemmlowp's
//!   `RoundingDivideByPOT` and TFLite's reference kernels do): symmetric under negation,
//!   so a sign flip of the input flips the output exactly.
//! - **Fixed scales where the maths bounds the range**: the GRU hidden state, tanh and
//!   sigmoid outputs and the adjacency use `1/127` ([`QScale::UNIT`]); attention
//!   probabilities are Q0.15 (`1.0 = 32768`). Everything else is calibrated by max-abs
//!   over calibration data ([`MaxAbs`]) and fixed in the model file.
//! - **No floats inside the int8 forward passes.** Floats appear only in the
//!   constructors (`from_f32`, LUT building, multiplier derivation) and in the float
//!   references. The one float→int boundary at run time is [`QAdjacency::from_adjacency`]
//!   (N² values per graph, outside every inner loop).
//!
//! # Testing
//!
//! Every kernel runs through one shared suite (`testkit`, test-only): a `KernelPair`
//! draws seeded random weights and inputs from [`crate::rng::Xoshiro128pp`], runs the
//! int8 kernel and its float reference on the *same* inputs (the reference gets the
//! int8 inputs dequantized), and checks every output against a stated tolerance; the
//! module docs of each kernel state its tolerance and the measured maximum error.

pub mod gat;
pub mod gru;
pub mod linear;
pub mod lut;
pub mod pool;
pub mod qparams;
pub mod softmax;

#[cfg(test)]
mod testkit;

pub use gat::{GatLayer, GatLayerF32, GatRanges, GatScales, GatScratch, GatScratchF32, QAdjacency};
pub use gru::{GruCell, GruCellF32, GruScratch};
pub use linear::{LinearF32, QLinear};
pub use lut::{ExpLut, LeakyRelu, Lut8};
pub use pool::{argmax_i32, AttentionPool, AttentionPoolF32, Classifier};
pub use qparams::{
    dequantize, per_channel_scales, quantize_symmetric, quantize_value, MaxAbs, QMultiplier,
    QScale, Rounding, Q_MAX,
};
pub use softmax::{softmax_f32, softmax_prior_f32, softmax_q15, softmax_q15_prior, Q15_ONE};

use crate::math;

/// Largest dot-product length for which an i8·i8 sum cannot overflow i32 even with
/// −128 codes: `65536 · 128² = 2^30`, leaving room for a bias of at most
/// [`linear::MAX_BIAS`] `= 2^30 − 1`.
pub const MAX_DOT_LEN: usize = 1 << 16;

/// `Σ a[k]·b[k]` in i32; the length bound is checked at compile time.
#[inline]
pub(crate) fn dot_i8<const N: usize>(a: &[i8; N], b: &[i8; N]) -> i32 {
    const {
        assert!(
            N <= MAX_DOT_LEN,
            "int8 dot product too long for an i32 accumulator"
        )
    };
    let mut acc = 0i32;
    for k in 0..N {
        acc += i32::from(a[k]) * i32::from(b[k]);
    }
    acc
}

/// Round half away from zero in f64 (exact: no `x + 0.5` double rounding).
pub(crate) fn round_half_away(x: f64) -> f64 {
    let a = if x < 0.0 { -x } else { x };
    let f = math::floor(a);
    let r = if a - f >= 0.5 { f + 1.0 } else { f };
    if x < 0.0 {
        -r
    } else {
        r
    }
}

/// Logistic sigmoid `1 / (1 + e^−x)` through the libm shim.
pub(crate) fn sigmoid_f64(x: f64) -> f64 {
    1.0 / (1.0 + math::exp(-x))
}

/// `tanh x = 1 − 2 / (e^{2x} + 1)` through the libm shim (saturates cleanly at ±1).
pub(crate) fn tanh_f64(x: f64) -> f64 {
    1.0 - 2.0 / (math::exp(2.0 * x) + 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_half_away_ties_and_signs() {
        for (x, want) in [
            (0.5, 1.0),
            (-0.5, -1.0),
            (1.5, 2.0),
            (-1.5, -2.0),
            (2.5, 3.0),
            (0.499_999_999_999_999_94, 0.0),
            (-0.499_999_999_999_999_94, 0.0),
            (126.4, 126.0),
            (-126.6, -127.0),
            (0.0, 0.0),
        ] {
            assert_eq!(round_half_away(x), want, "{x}");
        }
    }

    #[test]
    fn sigmoid_tanh_match_std() {
        for i in -400..=400 {
            let x = f64::from(i) * 0.05;
            assert!((sigmoid_f64(x) - 1.0 / (1.0 + (-x).exp())).abs() < 1e-15);
            assert!((tanh_f64(x) - x.tanh()).abs() < 1e-15, "{x}");
        }
        assert_eq!(tanh_f64(1000.0), 1.0);
        assert_eq!(tanh_f64(-1000.0), -1.0);
    }

    #[test]
    fn dot_matches_wide_sum() {
        let a: [i8; 5] = [127, -127, 3, -128, 0];
        let b: [i8; 5] = [127, 127, -3, -128, 99];
        assert_eq!(dot_i8(&a, &b), 127 * 127 - 127 * 127 - 9 + 128 * 128);
    }
}
