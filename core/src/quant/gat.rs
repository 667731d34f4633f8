//! One graph-attention layer (paper eqs. 4–6) in int8, with its float reference.
//!
//! ```text
//! z_j    = W·x_j                                                  projection
//! e_ij   = LeakyReLU_0.2( a_srcᵀ z_i + a_dstᵀ z_j )               (4)  a = [a_src ; a_dst]
//! N_i    = { j : node i and node j present, Â_ij > 0 }            (self-loop: i ∈ N_i)
//! α_ij   = Â_ij·exp(e_ij) / Σ_{k∈N_i} Â_ik·exp(e_ik)              (5) with the edge prior
//!        = softmax_{j∈N_i}( e_ij + ln Â_ij )
//! h_i    = ReLU( Σ_{j∈N_i} α_ij · z_j + b )                       (6)   σ = ReLU
//! h_i    = 0                                                      node i absent
//! ```
//!
//! Choices, and why:
//! - **`a = [a_src ; a_dst]`**: eq. 4's `aᵀ[W h_i ‖ W h_j]` split in halves; `a_src`
//!   multiplies the node being updated (`i`), `a_dst` the neighbour (`j`). (PyTorch
//!   Geometric names them the other way round: its `att_dst` is our `a_src`.)
//! - **The edge weight is a multiplicative prior** on the attention: `α ∝ Â·exp(e)`.
//!   This is exactly "add `ln Â_ij` to the logit", keeps the graph's weighted
//!   structure (eqs. 1–3) and its physics prior in the attention, costs one integer
//!   multiply per edge, and needs no log table. Edges with `Â_ij = 0` are absent.
//! - **σ = ReLU** in eq. 6: exact in int8 (a max with 0) and needs no table.
//! - **A bias `b` after aggregation** (as PyTorch Geometric's `GATConv`); set it to zero
//!   for eq. 6 as printed. One head.
//! - **The adjacency is int8 at scale 1/127** ([`QAdjacency`]), since `Â ∈ [0, 1]`.
//!   A nonzero entry below half a step is kept as 1, not rounded away, so the
//!   neighbourhoods `N_i` are identical to the float graph's.
//!
//! Int8 data flow (scales in brackets; no floats):
//!
//! ```text
//! zq_j   = requant(Wq·xq_j)                               [s_z]       (QLinear, no bias)
//! src_i  = a_srcqᵀ zq_i                                   [s_z·s_as]  (i32)
//! dst_j  = M_d( a_dstqᵀ zq_j )                            [s_z·s_as]  M_d ≈ s_ad/s_as
//! eq_ij  = requant( LeakyReLU(src_i + dst_j) )            [s_e]       (int8 logit)
//! αq_ij  = softmax_q15_prior(eq_i·, Âq_i·)                [2^−15]     (u16)
//! hq_i   = requant( max(0, bq + Σ_j αq_ij·zq_j) )         [s_h]       bq at s_z·2^−15
//! ```
//!
//! # Shapes
//! - `x`: `[N][F]` node features at `s_x`; `W`: `[H][F]`; `a_src`, `a_dst`, `b`: `[H]`
//! - `adj`: `[N][N]` (row `i` = the neighbours of node `i`); `mask`: `[N]`
//! - `out`: `[N][H]` at `s_h` (codes `0..=127` after the ReLU)
//!
//! # Tolerance (derived per output, tested)
//! Against [`GatLayerF32`] on the dequantized inputs (`x̂`, `Âq/127`), with
//! `Δz[o] = s_z/2 + (s_w[o]/2)·max_j ‖x̂_j‖₁` the projection bound of [`super::linear`],
//! `δ_i` the logit error bound of row `i`,
//!
//! ```text
//! δ_i  = s_e/2 + ‖a_src‖₁·Δz + ‖a_dst‖₁·Δz + (s_as/2)·‖z_i‖₁ + (s_ad/2)·max_j ‖z_j‖₁
//! |ĥ_io − h_io| ≤ s_h/2 + Δz[o]·(1 + n·2^−16)
//!              + max_j |z_jo| · ( e^{2δ_i} − 1 + 2^−16·(n + 2·Σ_j Âq_ij) )  + s_z·2^−16
//! ```
//!
//! (`e^{2δ} − 1` bounds `Σ_j |Δα_j|` when every logit moves by at most `δ`; the
//! `2^−16` terms are the integer softmax's own bound with `Ŝ ≥ 1`.)
//!
//! Measured (random layers, sparse weighted graphs, ~1/7 of the nodes absent,
//! scales calibrated on the batch): `N = 8` max 4.50 output LSB (25 % of the bound),
//! `N = 16` max 2.77 LSB (15 %). Split, for `N = 8`: the projection path (int8 `z`)
//! accounts for ≤ 2.0 LSB, the attention path for ≤ 4.4 LSB — dominated by the int8
//! logit rounding (`s_e/2` per logit moves `α` by a relative `≈ s_e`).

use crate::error::{Error, Result};
use crate::graph::{Adjacency, NodeMask};

use super::arith::{dot_i8, round_half_away};
use super::linear::{quantize_bias, LinearF32, QLinear};
use super::lut::{ExpLut, LeakyRelu};
use super::qparams::{quantize_value, MaxAbs, QMultiplier, QScale};
use super::softmax::{softmax_row_f32, softmax_row_q15, MAX_SOFTMAX_LEN};

/// A normalized adjacency `Â` quantized to int8 at scale 1/127 (entries `0..=127`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QAdjacency<const N: usize>(pub [[i8; N]; N]);

impl<const N: usize> QAdjacency<N> {
    /// The fixed scale, 1/127.
    pub const SCALE: QScale = QScale::UNIT;

    /// Quantize `Â` (entries in `[0, 1]`): `round(127·Â_ij)`, except that a nonzero
    /// entry below half a step becomes 1 so that no edge disappears.
    ///
    /// # Errors
    /// [`Error::NonFinite`] for NaN/∞, [`Error::InvalidParameter`] for an entry
    /// outside `[0, 1]` (a tolerance of 1e−5 above 1 is clamped).
    pub fn from_adjacency(a: &Adjacency<N>) -> Result<Self> {
        let mut q = [[0i8; N]; N];
        for (qr, ar) in q.iter_mut().zip(&a.0) {
            for (qv, &v) in qr.iter_mut().zip(ar) {
                if !v.is_finite() {
                    return Err(Error::NonFinite);
                }
                if !(0.0..=1.0 + 1e-5).contains(&v) {
                    return Err(Error::InvalidParameter(
                        "adjacency entries must be in [0, 1]",
                    ));
                }
                let code = round_half_away(f64::from(v) * 127.0).min(127.0) as i8;
                *qv = if v > 0.0 && code == 0 { 1 } else { code };
            }
        }
        Ok(Self(q))
    }

    /// Back to floats (`code/127`, negative codes as 0).
    pub fn to_adjacency(&self) -> Adjacency<N> {
        let mut a = Adjacency::<N>::ZERO;
        for (ar, qr) in a.0.iter_mut().zip(&self.0) {
            for (v, &c) in ar.iter_mut().zip(qr) {
                *v = f32::from(c.max(0)) / 127.0;
            }
        }
        a
    }
}

/// The activation scales of one GAT layer, fixed at calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GatScales {
    /// `s_x`: node features in.
    pub input: QScale,
    /// `s_z`: the projection `W·x`.
    pub projected: QScale,
    /// `s_e`: the attention logits `e_ij`.
    pub logit: QScale,
    /// `s_h`: the layer output.
    pub output: QScale,
}

/// Max-abs observers of a GAT layer's activations ([`GatLayerF32::forward_observed`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GatRanges {
    /// Node features of present nodes.
    pub input: MaxAbs,
    /// `W·x` of present nodes.
    pub projected: MaxAbs,
    /// `e_ij` over present edges.
    pub logit: MaxAbs,
    /// Outputs of present nodes.
    pub output: MaxAbs,
}

impl GatRanges {
    /// Nothing observed.
    pub const fn new() -> Self {
        Self {
            input: MaxAbs::new(),
            projected: MaxAbs::new(),
            logit: MaxAbs::new(),
            output: MaxAbs::new(),
        }
    }

    /// Max-abs scales of everything observed.
    ///
    /// # Errors
    /// [`Error::NonFinite`] if a NaN or infinity was observed.
    pub fn scales(&self) -> Result<GatScales> {
        Ok(GatScales {
            input: self.input.scale()?,
            projected: self.projected.scale()?,
            logit: self.logit.scale()?,
            output: self.output.scale()?,
        })
    }
}

/// Scratch of the float reference: projections, attention terms, one row of weights.
#[derive(Debug, Clone, PartialEq)]
pub struct GatScratchF32<const N: usize, const H: usize> {
    z: [[f32; H]; N],
    src: [f32; N],
    dst: [f32; N],
    logits: [f32; N],
    alpha: [f32; N],
}

impl<const N: usize, const H: usize> GatScratchF32<N, H> {
    /// Zeroed scratch.
    pub const fn new() -> Self {
        Self {
            z: [[0.0; H]; N],
            src: [0.0; N],
            dst: [0.0; N],
            logits: [0.0; N],
            alpha: [0.0; N],
        }
    }
}

impl<const N: usize, const H: usize> Default for GatScratchF32<N, H> {
    fn default() -> Self {
        Self::new()
    }
}

/// Float reference GAT layer (eqs. 4–6 as in the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct GatLayerF32<const F: usize, const H: usize> {
    /// Projection `W`, `[H][F]`.
    pub w: [[f32; F]; H],
    /// Attention half for the node being updated, `[H]`.
    pub a_src: [f32; H],
    /// Attention half for the neighbour, `[H]`.
    pub a_dst: [f32; H],
    /// Bias after aggregation, `[H]`.
    pub bias: [f32; H],
}

impl<const F: usize, const H: usize> GatLayerF32<F, H> {
    /// The LeakyReLU slope of eq. 4.
    pub const NEGATIVE_SLOPE: f32 = 0.2;

    /// Forward pass into `out`.
    ///
    /// # Errors
    /// [`Error::NonFinite`] for a NaN/∞ feature of a present node or adjacency entry;
    /// [`Error::InvalidParameter`] for a negative adjacency entry.
    pub fn forward<const N: usize>(
        &self,
        x: &[[f32; F]; N],
        adj: &Adjacency<N>,
        mask: &NodeMask<N>,
        out: &mut [[f32; H]; N],
        scratch: &mut GatScratchF32<N, H>,
    ) -> Result<()> {
        let mut ranges = GatRanges::new();
        self.forward_observed(x, adj, mask, out, scratch, &mut ranges)
    }

    /// [`GatLayerF32::forward`], recording activation ranges for calibration.
    ///
    /// # Errors
    /// As [`GatLayerF32::forward`].
    pub fn forward_observed<const N: usize>(
        &self,
        x: &[[f32; F]; N],
        adj: &Adjacency<N>,
        mask: &NodeMask<N>,
        out: &mut [[f32; H]; N],
        scratch: &mut GatScratchF32<N, H>,
        ranges: &mut GatRanges,
    ) -> Result<()> {
        for (i, row) in adj.0.iter().enumerate() {
            if row.iter().any(|v| !v.is_finite()) {
                return Err(Error::NonFinite);
            }
            if row.iter().any(|&v| v < 0.0) {
                return Err(Error::InvalidParameter("adjacency entries must be >= 0"));
            }
            if mask.0[i] && x[i].iter().any(|v| !v.is_finite()) {
                return Err(Error::NonFinite);
            }
        }
        let project = LinearF32 {
            w: self.w,
            b: [0.0; H],
        };
        for j in 0..N {
            if mask.0[j] {
                ranges.input.observe_all(&x[j]);
                project.forward(&x[j], &mut scratch.z[j]);
                ranges.projected.observe_all(&scratch.z[j]);
            } else {
                scratch.z[j] = [0.0; H];
            }
            scratch.src[j] = dot_f32(&self.a_src, &scratch.z[j]);
            scratch.dst[j] = dot_f32(&self.a_dst, &scratch.z[j]);
        }
        for i in 0..N {
            if !mask.0[i] {
                out[i] = [0.0; H];
                continue;
            }
            for j in 0..N {
                let e = scratch.src[i] + scratch.dst[j];
                scratch.logits[j] = if e >= 0.0 {
                    e
                } else {
                    e * Self::NEGATIVE_SLOPE
                };
            }
            let row = &adj.0[i];
            let weight = |j: usize| if mask.0[j] { row[j] } else { 0.0 };
            for j in 0..N {
                if weight(j) > 0.0 {
                    ranges.logit.observe(scratch.logits[j]);
                }
            }
            let any = softmax_row_f32(&scratch.logits, weight, &mut scratch.alpha);
            for o in 0..H {
                let mut acc = self.bias[o];
                if any {
                    for j in 0..N {
                        acc += scratch.alpha[j] * scratch.z[j][o];
                    }
                }
                out[i][o] = acc.max(0.0);
            }
            ranges.output.observe_all(&out[i]);
        }
        Ok(())
    }
}

fn dot_f32<const H: usize>(a: &[f32; H], b: &[f32; H]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Caller-owned scratch of [`GatLayer::forward`]: `N·H + 11·N` bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GatScratch<const N: usize, const H: usize> {
    z: [[i8; H]; N],
    src: [i32; N],
    dst: [i32; N],
    logits: [i8; N],
    alpha: [u16; N],
}

impl<const N: usize, const H: usize> GatScratch<N, H> {
    /// Zeroed scratch.
    pub const fn new() -> Self {
        Self {
            z: [[0; H]; N],
            src: [0; N],
            dst: [0; N],
            logits: [0; N],
            alpha: [0; N],
        }
    }
}

impl<const N: usize, const H: usize> Default for GatScratch<N, H> {
    fn default() -> Self {
        Self::new()
    }
}

/// Int8 GAT layer. Plain data: [`GatLayer::from_parts`] for a model-file decoder,
/// [`GatLayer::from_f32`] for the trainer.
#[derive(Debug, Clone, PartialEq)]
pub struct GatLayer<const F: usize, const H: usize> {
    project: QLinear<F, H>,
    a_src: [i8; H],
    a_src_scale: QScale,
    a_dst: [i8; H],
    a_dst_scale: QScale,
    bias: [i32; H],
    scales: GatScales,
    // Derived.
    dst_to_src: QMultiplier,
    to_logit: QMultiplier,
    to_output: QMultiplier,
    leaky: LeakyRelu,
    exp: ExpLut,
}

/// `2^−15` as f64 (the attention probabilities' scale).
const Q15: f64 = 1.0 / 32768.0;

fn ratio(num: f64, den: f64) -> Result<QMultiplier> {
    QMultiplier::from_f64(num / den).ok_or(Error::InvalidParameter(
        "GAT scale ratio outside [2^-32, 2^31)",
    ))
}

impl<const F: usize, const H: usize> GatLayer<F, H> {
    /// A placeholder layer (all zero) to fill in place with [`GatLayer::set_in_place`].
    pub const EMPTY: Self = Self {
        project: QLinear::EMPTY,
        a_src: [0; H],
        a_src_scale: QScale::UNIT,
        a_dst: [0; H],
        a_dst_scale: QScale::UNIT,
        bias: [0; H],
        scales: GatScales {
            input: QScale::UNIT,
            projected: QScale::UNIT,
            logit: QScale::UNIT,
            output: QScale::UNIT,
        },
        dst_to_src: QMultiplier::INV_127,
        to_logit: QMultiplier::INV_127,
        to_output: QMultiplier::INV_127,
        leaky: LeakyRelu::GAT,
        exp: ExpLut::EMPTY,
    };

    /// [`GatLayer::from_parts`] in place: `load_project` fills `W` where it lives,
    /// the attention vectors and bias are copied from slices of length `H`, and the
    /// layer checks everything and derives its multipliers and table.
    ///
    /// # Errors
    /// The loader's errors; [`Error::BufferSize`] for vectors not of length `H`; those
    /// of [`GatLayer::from_parts`]. On error `self` is partly overwritten.
    pub fn set_in_place(
        &mut self,
        load_project: impl FnOnce(&mut QLinear<F, H>) -> Result<()>,
        a_src: (&[i8], QScale),
        a_dst: (&[i8], QScale),
        bias: &[i32],
        logit: QScale,
        output: QScale,
    ) -> Result<()> {
        load_project(&mut self.project)?;
        let copy = |dst: &mut [i8; H], src: &[i8]| -> Result<()> {
            *dst = src.try_into().map_err(|_| Error::BufferSize {
                expected: H,
                got: src.len(),
            })?;
            Ok(())
        };
        copy(&mut self.a_src, a_src.0)?;
        copy(&mut self.a_dst, a_dst.0)?;
        self.bias = bias.try_into().map_err(|_| Error::BufferSize {
            expected: H,
            got: bias.len(),
        })?;
        self.a_src_scale = a_src.1;
        self.a_dst_scale = a_dst.1;
        self.scales = GatScales {
            input: self.project.input_scale(),
            projected: self.project.output_scale(),
            logit,
            output,
        };
        self.derive()
    }

    /// Check the parts and derive the multipliers and the exp table.
    fn derive(&mut self) -> Result<()> {
        let scales = self.scales;
        let project = &self.project;
        if project.input_scale() != scales.input || project.output_scale() != scales.projected {
            return Err(Error::InvalidParameter(
                "GAT projection scales do not match",
            ));
        }
        if project.bias().iter().any(|&b| b != 0) {
            return Err(Error::InvalidParameter("GAT projection must have no bias"));
        }
        let s_z = f64::from(scales.projected.get());
        let s_as = f64::from(self.a_src_scale.get());
        let s_ad = f64::from(self.a_dst_scale.get());
        self.dst_to_src = ratio(s_ad, s_as)?;
        self.to_logit = ratio(s_z * s_as, f64::from(scales.logit.get()))?;
        self.to_output = ratio(s_z * Q15, f64::from(scales.output.get()))?;
        self.leaky = LeakyRelu::GAT;
        self.exp = ExpLut::new(scales.logit);
        Ok(())
    }

    /// Assemble from stored parts. `project` (`W`) must map `scales.input →
    /// scales.projected` and have zero bias (the layer's bias `bias` comes after the
    /// aggregation, at `s_z·2^−15`).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for mismatched projection scales, a nonzero
    /// projection bias, or a scale ratio that no [`QMultiplier`] represents.
    pub fn from_parts(
        project: QLinear<F, H>,
        a_src: ([i8; H], QScale),
        a_dst: ([i8; H], QScale),
        bias: [i32; H],
        scales: GatScales,
    ) -> Result<Self> {
        let mut layer = Self {
            project,
            a_src: a_src.0,
            a_src_scale: a_src.1,
            a_dst: a_dst.0,
            a_dst_scale: a_dst.1,
            bias,
            scales,
            ..Self::EMPTY
        };
        layer.derive()?;
        Ok(layer)
    }

    /// Quantize a float layer with calibrated activation scales.
    ///
    /// # Errors
    /// [`Error::NonFinite`] for NaN/∞ parameters; the errors of [`GatLayer::from_parts`]
    /// and of [`QLinear::from_f32`].
    pub fn from_f32(float: &GatLayerF32<F, H>, scales: GatScales) -> Result<Self> {
        let project = QLinear::from_f32(
            &LinearF32 {
                w: float.w,
                b: [0.0; H],
            },
            scales.input,
            scales.projected,
        )?;
        let quantize_vec = |v: &[f32; H]| -> Result<([i8; H], QScale)> {
            let mut m = MaxAbs::new();
            m.observe_all(v);
            let s = m.scale()?;
            let mut q = [0i8; H];
            for (qo, &x) in q.iter_mut().zip(v) {
                *qo = quantize_value(x, s)?;
            }
            Ok((q, s))
        };
        let mut bias = [0i32; H];
        for (bq, &b) in bias.iter_mut().zip(&float.bias) {
            *bq = quantize_bias(b, f64::from(scales.projected.get()) * Q15)?;
        }
        Self::from_parts(
            project,
            quantize_vec(&float.a_src)?,
            quantize_vec(&float.a_dst)?,
            bias,
            scales,
        )
    }

    /// Forward pass (integer only). Absent nodes output zeros and send no messages;
    /// a present node with an empty neighbourhood outputs `ReLU(b)`.
    pub fn forward<const N: usize>(
        &self,
        x: &[[i8; F]; N],
        adj: &QAdjacency<N>,
        mask: &NodeMask<N>,
        out: &mut [[i8; H]; N],
        scratch: &mut GatScratch<N, H>,
    ) {
        const { assert!(N <= MAX_SOFTMAX_LEN, "too many nodes for one softmax row") };
        for j in 0..N {
            if mask.0[j] {
                self.project.forward(&x[j], &mut scratch.z[j]);
            } else {
                scratch.z[j] = [0; H];
            }
            scratch.src[j] = dot_i8(&self.a_src, &scratch.z[j]);
            scratch.dst[j] = self
                .dst_to_src
                .apply_i32(dot_i8(&self.a_dst, &scratch.z[j]));
        }
        for i in 0..N {
            if !mask.0[i] {
                out[i] = [0; H];
                continue;
            }
            for j in 0..N {
                let e = self
                    .leaky
                    .apply_i32(scratch.src[i].saturating_add(scratch.dst[j]));
                scratch.logits[j] = self.to_logit.apply(e);
            }
            let row = &adj.0[i];
            let weight = |j: usize| match (mask.0.get(j), row.get(j)) {
                (Some(true), Some(&r)) if r > 0 => r as u32,
                _ => 0,
            };
            let any = softmax_row_q15(&scratch.logits, weight, &self.exp, &mut scratch.alpha);
            for o in 0..H {
                let mut acc = self.bias[o];
                if any {
                    let mut sum = 0i32; // ≤ (32768 + N/2)·127: no overflow
                    for j in 0..N {
                        sum += i32::from(scratch.alpha[j]) * i32::from(scratch.z[j][o]);
                    }
                    acc = acc.saturating_add(sum);
                }
                out[i][o] = self.to_output.apply(acc.max(0));
            }
        }
    }

    /// The projection `W` (no bias), `s_x → s_z`.
    pub fn project(&self) -> &QLinear<F, H> {
        &self.project
    }
    /// `a_src` codes and scale.
    pub fn a_src(&self) -> (&[i8; H], QScale) {
        (&self.a_src, self.a_src_scale)
    }
    /// `a_dst` codes and scale.
    pub fn a_dst(&self) -> (&[i8; H], QScale) {
        (&self.a_dst, self.a_dst_scale)
    }
    /// Bias codes at `s_z·2^−15`.
    pub fn bias(&self) -> &[i32; H] {
        &self.bias
    }
    /// The activation scales.
    pub fn scales(&self) -> GatScales {
        self.scales
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::normalize_symmetric;
    use crate::quant::testkit::{
        kernel_pair_tests, random_matrix, random_vector, uniform, KernelPair, Sample,
    };
    use crate::rng::Xoshiro128pp;
    use std::boxed::Box;
    use std::vec::Vec;

    const N: usize = 8;
    const N16: usize = 16;
    const F: usize = 12;
    const H: usize = 16;
    const BATCH: usize = 4;

    fn random_layer(rng: &mut Xoshiro128pp) -> GatLayerF32<F, H> {
        let w_amp = f64::from(uniform(rng, 0.5, 2.0)) / (F as f64).sqrt();
        let a_amp = f64::from(uniform(rng, 0.3, 2.0)) / (H as f64).sqrt();
        GatLayerF32 {
            w: random_matrix(rng, w_amp),
            a_src: random_vector(rng, a_amp),
            a_dst: random_vector(rng, a_amp),
            bias: random_vector(rng, 0.3),
        }
    }

    fn random_mask<const N: usize>(rng: &mut Xoshiro128pp) -> NodeMask<N> {
        let mut m = [true; N];
        for v in m.iter_mut() {
            *v = rng.next_u32() % 7 != 0;
        }
        m[(rng.next_u32() as usize) % N] = true;
        NodeMask(m)
    }

    /// A sparse weighted symmetric graph with self-loops, normalized by eq. 3;
    /// absent nodes isolated as `graph::build_dynamic_graphs` does.
    fn random_adjacency<const N: usize>(
        rng: &mut Xoshiro128pp,
        mask: &NodeMask<N>,
    ) -> Adjacency<N> {
        let mut a = [[0f32; N]; N];
        for i in 0..N {
            a[i][i] = 1.0;
            for j in (i + 1)..N {
                if mask.0[i] && mask.0[j] && rng.next_u32() % 3 != 0 {
                    let w = uniform(rng, 0.0, 1.0);
                    a[i][j] = w;
                    a[j][i] = w;
                }
            }
        }
        normalize_symmetric(&mut a);
        Adjacency(a)
    }

    /// Int8 features, the same dequantized, the int8 adjacency.
    type Quantized<const N: usize> = ([[i8; F]; N], [[f32; F]; N], QAdjacency<N>);

    struct Case<const N: usize> {
        x: [[f32; F]; N],
        adj: Adjacency<N>,
        mask: NodeMask<N>,
    }

    struct Gat8;
    impl KernelPair for Gat8 {
        const NAME: &'static str = "GAT layer (GatLayer vs GatLayerF32), N=8 F=12 H=16";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            gat_case::<N>(rng, out);
        }
    }
    struct Gat16;
    impl KernelPair for Gat16 {
        const NAME: &'static str = "GAT layer (GatLayer vs GatLayerF32), N=16 F=12 H=16";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            gat_case::<N16>(rng, out);
        }
    }

    fn gat_case<const N: usize>(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
        let float = random_layer(rng);
        let x_amp = f64::from(uniform(rng, 0.5, 3.0));
        let cases: Vec<Case<N>> = (0..BATCH)
            .map(|_| {
                let mask = random_mask(rng);
                Case {
                    x: random_matrix(rng, x_amp),
                    adj: random_adjacency(rng, &mask),
                    mask,
                }
            })
            .collect();
        // Quantize the inputs; the reference sees them dequantized.
        let mut in_range = MaxAbs::new();
        for c in &cases {
            for (i, row) in c.x.iter().enumerate() {
                if c.mask.0[i] {
                    in_range.observe_all(row);
                }
            }
        }
        let s_x = in_range.scale().unwrap();
        let quantized: Vec<Quantized<N>> = cases
            .iter()
            .map(|c| {
                let mut xq = [[0i8; F]; N];
                let mut xhat = [[0f32; F]; N];
                for i in 0..N {
                    crate::quant::qparams::quantize_symmetric(&c.x[i], s_x, &mut xq[i]).unwrap();
                    crate::quant::qparams::dequantize(&xq[i], s_x, &mut xhat[i]).unwrap();
                }
                (xq, xhat, QAdjacency::from_adjacency(&c.adj).unwrap())
            })
            .collect();
        // Calibrate on the batch.
        let mut ranges = GatRanges::new();
        let mut scratch_f = Box::new(GatScratchF32::<N, H>::new());
        let mut yf = [[0f32; H]; N];
        for (c, (_, xhat, aq)) in cases.iter().zip(&quantized) {
            float
                .forward_observed(
                    xhat,
                    &aq.to_adjacency(),
                    &c.mask,
                    &mut yf,
                    &mut scratch_f,
                    &mut ranges,
                )
                .unwrap();
        }
        let mut scales = ranges.scales().unwrap();
        scales.input = s_x;
        let q = GatLayer::from_f32(&float, scales).unwrap();

        let s_z = f64::from(scales.projected.get());
        let s_e = f64::from(scales.logit.get());
        let s_h = f64::from(scales.output.get());
        let (_, s_as) = q.a_src();
        let (_, s_ad) = q.a_dst();
        let (s_as, s_ad) = (f64::from(s_as.get()), f64::from(s_ad.get()));
        let l1 = |v: &[f32]| v.iter().map(|x| f64::from(x.abs())).sum::<f64>();
        let (a_src_l1, a_dst_l1) = (l1(&float.a_src), l1(&float.a_dst));

        let mut scratch = Box::new(GatScratch::<N, H>::new());
        for (c, (xq, xhat, aq)) in cases.iter().zip(&quantized) {
            let mut yq = [[0i8; H]; N];
            q.forward(xq, aq, &c.mask, &mut yq, &mut scratch);
            let adj_hat = aq.to_adjacency();
            float
                .forward(xhat, &adj_hat, &c.mask, &mut yf, &mut scratch_f)
                .unwrap();
            // Per-output projection bound Δz[o] over present nodes.
            let max_x_l1 = (0..N)
                .filter(|&j| c.mask.0[j])
                .map(|j| l1(&xhat[j]))
                .fold(0.0, f64::max);
            let dz: [f64; H] = core::array::from_fn(|o| {
                0.5 * s_z + 0.5 * f64::from(q.project().weight_scales()[o].get()) * max_x_l1
            });
            let dz_max = dz.iter().copied().fold(0.0, f64::max);
            let z_l1_max = (0..N).map(|j| l1(&scratch_f.z[j])).fold(0.0, f64::max);
            for i in 0..N {
                let n = (0..N).filter(|&j| c.mask.0[j] && aq.0[i][j] > 0).count();
                let sum_a: f64 = (0..N)
                    .filter(|&j| c.mask.0[j] && aq.0[i][j] > 0)
                    .map(|j| f64::from(aq.0[i][j]))
                    .sum();
                let delta = 0.5 * s_e
                    + (a_src_l1 + a_dst_l1) * dz_max
                    + 0.5 * s_as * (l1(&scratch_f.z[i]) + H as f64 * dz_max)
                    + 0.5 * s_ad * (z_l1_max + H as f64 * dz_max);
                for o in 0..H {
                    let want = f64::from(yf[i][o]);
                    let got = f64::from(yq[i][o]) * s_h;
                    if !c.mask.0[i] {
                        assert_eq!(yq[i][o], 0);
                    }
                    let z_max = (0..N)
                        .map(|j| f64::from(scratch_f.z[j][o].abs()) + dz[o])
                        .fold(0.0, f64::max);
                    let soft =
                        crate::math::exp(2.0 * delta) - 1.0 + Q15 / 2.0 * (n as f64 + 2.0 * sum_a);
                    let tol = 0.5 * s_h
                        + dz[o] * (1.0 + n as f64 * Q15 / 2.0)
                        + z_max * soft
                        + s_z * Q15
                        + 1e-5 * (1.0 + want.abs());
                    out.push(Sample::new(got, want, tol, s_h));
                }
            }
        }
    }

    kernel_pair_tests! {
        gat_n8_within_derived_bound: Gat8, seed 51, cases 300;
        gat_n16_within_derived_bound: Gat16, seed 54, cases 100;
    }

    #[test]
    fn adjacency_quantization_keeps_every_edge() {
        let mut a = Adjacency::<3>::ZERO;
        a.0 = [
            [1.0, 0.001, 0.0],
            [0.001, 0.5, 0.25],
            [0.0, 0.25, 1.0 + 1e-6],
        ];
        let q = QAdjacency::from_adjacency(&a).unwrap();
        assert_eq!(q.0, [[127, 1, 0], [1, 64, 32], [0, 32, 127]]);
        a.0[0][2] = -0.1;
        assert!(QAdjacency::from_adjacency(&a).is_err());
        a.0[0][2] = f32::NAN;
        assert_eq!(QAdjacency::from_adjacency(&a), Err(Error::NonFinite));
    }

    #[test]
    fn masked_nodes_isolated_and_empty_rows_give_relu_bias() {
        let mut rng = Xoshiro128pp::seed_from_u64(52);
        let mut float = random_layer(&mut rng);
        float.bias[0] = 0.25;
        float.bias[1] = -0.25;
        let mask = NodeMask([true, true, false, true, true, true, true, true]);
        let mut adj = random_adjacency::<N>(&mut rng, &mask);
        // Node 3 loses every edge, even its self-loop.
        adj.0[3] = [0.0; N];
        let x: [[f32; F]; N] = random_matrix(&mut rng, 1.0);
        let scales = GatScales {
            input: QScale::new(1.0 / 127.0).unwrap(),
            projected: QScale::new(0.02).unwrap(),
            logit: QScale::new(0.02).unwrap(),
            output: QScale::new(0.01).unwrap(),
        };
        let q = GatLayer::from_f32(&float, scales).unwrap();
        let mut xq = [[0i8; F]; N];
        for i in 0..N {
            crate::quant::qparams::quantize_symmetric(&x[i], scales.input, &mut xq[i]).unwrap();
        }
        let aq = QAdjacency::from_adjacency(&adj).unwrap();
        let mut out = [[0i8; H]; N];
        q.forward(&xq, &aq, &mask, &mut out, &mut GatScratch::new());
        assert_eq!(out[2], [0; H]);
        assert_eq!(out[3][0], 25);
        assert_eq!(out[3][1], 0);
        // Garbage in a masked node's features changes nothing.
        let mut xq2 = xq;
        xq2[2] = [127; F];
        let mut out2 = [[0i8; H]; N];
        q.forward(&xq2, &aq, &mask, &mut out2, &mut GatScratch::new());
        assert_eq!(out, out2);
        let mut yf = [[0f32; H]; N];
        let mut xf = x;
        xf[2] = [f32::NAN; F];
        float
            .forward(&xf, &adj, &mask, &mut yf, &mut GatScratchF32::new())
            .unwrap();
        assert_eq!(yf[2], [0.0; H]);
        assert!((yf[3][0] - 0.25).abs() < 1e-7 && yf[3][1] == 0.0);
    }

    #[test]
    fn from_parts_checks_scales() {
        let mut rng = Xoshiro128pp::seed_from_u64(53);
        let float = random_layer(&mut rng);
        let s = QScale::new(0.05).unwrap();
        let scales = GatScales {
            input: s,
            projected: s,
            logit: s,
            output: s,
        };
        let q = GatLayer::from_f32(&float, scales).unwrap();
        let rebuilt = GatLayer::from_parts(
            q.project().clone(),
            (*q.a_src().0, q.a_src().1),
            (*q.a_dst().0, q.a_dst().1),
            *q.bias(),
            q.scales(),
        )
        .unwrap();
        assert_eq!(rebuilt, q);
        let other = GatScales {
            input: QScale::ONE,
            ..scales
        };
        assert!(GatLayer::from_parts(
            q.project().clone(),
            (*q.a_src().0, q.a_src().1),
            (*q.a_dst().0, q.a_dst().1),
            *q.bias(),
            other
        )
        .is_err());
    }
}
