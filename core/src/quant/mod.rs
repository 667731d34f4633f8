//! Int8 inference kernels for the DS-STGAT (paper §4.2, eqs. 4–8), each with a plain
//! float reference beside it.
//!
//! | file | int8 kernel | float reference | paper |
//! |---|---|---|---|
//! | `arith` (private) | the i8·i8 dot product ([`MAX_DOT_LEN`]), rounding half away from zero | f64 sigmoid, tanh | — |
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

mod arith;
pub mod gat;
pub mod gru;
pub mod linear;
pub mod lut;
pub mod pool;
pub mod qparams;
pub mod softmax;

#[cfg(test)]
mod testkit;

pub use arith::MAX_DOT_LEN;
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
