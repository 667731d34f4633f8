//! Attention pooling over nodes and time into the system representation, and the
//! classifier head (paper §4.2 "attention pooling", eq. 8).
//!
//! ```text
//! s_ti  = wᵀ h_ti + b                                   score of node i at step t
//! β_ti  = exp(s_ti) / Σ_{(τ,k) present} exp(s_τk)        softmax over present pairs
//! g     = Σ_{(t,i) present} β_ti · h_ti                 g_system
//! ŷ     = Softmax(W_o g + b_o)                          (8)
//! ```
//!
//! Int8 (no floats; one streaming pass for the maximum, one for the sums, so no
//! `N·T` scratch):
//!
//! ```text
//! sq_ti = requant(wqᵀ hq_ti + bq)                       [s_s]
//! w_ti  = ExpLut[max sq − sq_ti]                        Q0.15, the maximum weighs 1.0
//! gq[k] = round_half_away( Σ w_ti·hq_ti[k] / Σ w_ti )   [s_h]  (i64 / u64, exact ratio)
//! logit = requant_i32(W_oq·gq + b_oq)                   [s_l]  i32, argmax = class
//! ```
//!
//! `g` keeps the hidden scale `s_h` (a convex combination cannot leave its range).
//! The classifier returns i32 logits at one common fine scale `s_l`; the class is their
//! argmax (eq. 8's softmax is monotone, so it is not needed for the decision).
//!
//! # Shapes
//! - `h`: `[T][N][H]` (step, node, feature) at `s_h`; `mask`: `[N]` (a node is present
//!   for the whole window or not at all); `g`: `[H]`
//! - `W_o`: `[C][H]`, `b_o`, logits: `[C]`
//!
//! # Tolerance (derived per output, tested)
//! Against [`AttentionPoolF32`] on the dequantized `ĥ`, with `L` present pairs and the
//! score error bound `δ = s_s/2 + max_ti (s_w/2)·‖ĥ_ti‖₁ + s_h·s_w/2`:
//!
//! ```text
//! |ĝ_k − g_k| ≤ s_h/2 + max_ti |ĥ_ti[k]| · ( e^{2δ} − 1 + 2L·2^−16 )
//! ```
//!
//! and the logits, against [`LinearF32`] applied to the float `g`, within the
//! [`super::linear`] bound plus `Σ_k |W_o[c][k]|·|ĝ_k − g_k|`.
//!
//! Measured (2 000 random instances, `N = 4`, `T = 6`, `H = 16`, `C = 10`, `h` over
//! the full code range): `g` max 1.22 LSB of 1/127 (28 % of the bound); logits max
//! `|err|` 0.032 in logit units (11 % of the bound); the int8 class equals the float
//! class whenever the float top-two margin exceeds 0.1.

use crate::error::{Error, Result};
use crate::graph::NodeMask;
use crate::math;

use super::linear::{LinearF32, QLinear};
use super::lut::ExpLut;
use super::qparams::{div_round_half_away, saturate_i8, MaxAbs, QScale};

/// Most `(step, node)` pairs one pooling accepts (keeps the sums far inside i64/u64).
pub const MAX_POOL_PAIRS: usize = 1 << 16;

/// Float reference attention pooling.
#[derive(Debug, Clone, PartialEq)]
pub struct AttentionPoolF32<const H: usize> {
    /// Score weights `w`, `[H]`.
    pub w: [f32; H],
    /// Score bias `b`.
    pub b: f32,
}

impl<const H: usize> AttentionPoolF32<H> {
    fn score(&self, h: &[f32; H]) -> f32 {
        self.b + self.w.iter().zip(h).map(|(a, b)| a * b).sum::<f32>()
    }

    /// Pool `h` (`[T][N][H]`) over present nodes and all steps into `g`.
    ///
    /// # Errors
    /// [`Error::NothingPresent`] if `T = 0` or no node is present (then `g` is zero),
    /// [`Error::NonFinite`] for a NaN/∞ feature of a present node.
    pub fn forward<const N: usize>(
        &self,
        h: &[[[f32; H]; N]],
        mask: &NodeMask<N>,
        g: &mut [f32; H],
    ) -> Result<()> {
        let mut range = MaxAbs::new();
        self.forward_observed(h, mask, g, &mut range)
    }

    /// [`AttentionPoolF32::forward`], recording the score range for calibration.
    ///
    /// # Errors
    /// As [`AttentionPoolF32::forward`].
    pub fn forward_observed<const N: usize>(
        &self,
        h: &[[[f32; H]; N]],
        mask: &NodeMask<N>,
        g: &mut [f32; H],
        score_range: &mut MaxAbs,
    ) -> Result<()> {
        *g = [0.0; H];
        let present = |i: usize| mask.0[i];
        let mut max: Option<f32> = None;
        for step in h {
            for (i, hi) in step.iter().enumerate() {
                if !present(i) {
                    continue;
                }
                if hi.iter().any(|v| !v.is_finite()) {
                    return Err(Error::NonFinite);
                }
                let s = self.score(hi);
                score_range.observe(s);
                if max.is_none_or(|m| s > m) {
                    max = Some(s);
                }
            }
        }
        let Some(max) = max else {
            return Err(Error::NothingPresent);
        };
        let mut sum = 0f64;
        let mut acc = [0f64; H];
        for step in h {
            for (i, hi) in step.iter().enumerate() {
                if present(i) {
                    let w = math::exp(f64::from(self.score(hi) - max));
                    sum += w;
                    for (a, &v) in acc.iter_mut().zip(hi) {
                        *a += w * f64::from(v);
                    }
                }
            }
        }
        for (gk, a) in g.iter_mut().zip(&acc) {
            *gk = (a / sum) as f32;
        }
        Ok(())
    }
}

/// Int8 attention pooling. Uses `8·H` bytes of stack for the i64 sums.
#[derive(Debug, Clone, PartialEq)]
pub struct AttentionPool<const H: usize> {
    score: QLinear<H, 1>,
    exp: ExpLut,
}

impl<const H: usize> AttentionPool<H> {
    /// A placeholder to fill in place with [`AttentionPool::set_in_place`].
    pub const EMPTY: Self = Self {
        score: QLinear::EMPTY,
        exp: ExpLut::EMPTY,
    };

    /// [`AttentionPool::from_parts`] in place: `load` fills the score layer.
    ///
    /// # Errors
    /// The loader's errors.
    pub fn set_in_place(
        &mut self,
        load: impl FnOnce(&mut QLinear<H, 1>) -> Result<()>,
    ) -> Result<()> {
        load(&mut self.score)?;
        self.exp = ExpLut::new(self.score.output_scale());
        Ok(())
    }

    /// From a stored score layer (`s_h → s_s`); the exp table is derived from `s_s`.
    pub fn from_parts(score: QLinear<H, 1>) -> Self {
        let exp = ExpLut::new(score.output_scale());
        Self { score, exp }
    }

    /// Quantize a float pooling for hidden states at `hidden_scale` and scores at
    /// `score_scale` (calibrate it with [`AttentionPoolF32::forward_observed`]).
    ///
    /// # Errors
    /// The errors of [`QLinear::from_f32`].
    pub fn from_f32(
        float: &AttentionPoolF32<H>,
        hidden_scale: QScale,
        score_scale: QScale,
    ) -> Result<Self> {
        let score = QLinear::from_f32(
            &LinearF32 {
                w: [float.w],
                b: [float.b],
            },
            hidden_scale,
            score_scale,
        )?;
        Ok(Self::from_parts(score))
    }

    /// Pool `h` (`[T][N][H]`, at the hidden scale) into `g` (same scale). Integer only.
    ///
    /// # Errors
    /// [`Error::NothingPresent`] if `T = 0` or no node is present (then `g` is zero);
    /// [`Error::InvalidParameter`] for more than [`MAX_POOL_PAIRS`] present pairs.
    pub fn forward<const N: usize>(
        &self,
        h: &[[[i8; H]; N]],
        mask: &NodeMask<N>,
        g: &mut [i8; H],
    ) -> Result<()> {
        *g = [0; H];
        let pairs = h.len().saturating_mul(mask.count());
        if pairs == 0 {
            return Err(Error::NothingPresent);
        }
        if pairs > MAX_POOL_PAIRS {
            return Err(Error::InvalidParameter(
                "more than 65536 pooled (step, node) pairs",
            ));
        }
        let score = |hi: &[i8; H]| {
            let mut s = [0i8; 1];
            self.score.forward(hi, &mut s);
            s[0]
        };
        let mut max = i8::MIN;
        for step in h {
            for (i, hi) in step.iter().enumerate() {
                if mask.0[i] {
                    max = max.max(score(hi));
                }
            }
        }
        let mut sum = 0i64; // ≤ 2^16 · 2^15
        let mut acc = [0i64; H]; // |·| ≤ 2^16 · 2^15 · 128
        for step in h {
            for (i, hi) in step.iter().enumerate() {
                if mask.0[i] {
                    let d = (i16::from(max) - i16::from(score(hi))) as u8;
                    let w = i64::from(self.exp.lookup(d));
                    sum += w;
                    for (a, &v) in acc.iter_mut().zip(hi) {
                        *a += w * i64::from(v);
                    }
                }
            }
        }
        for (gk, &a) in g.iter_mut().zip(&acc) {
            *gk = saturate_i8(div_round_half_away(a, sum));
        }
        Ok(())
    }

    /// The score layer (`s_h → s_s`).
    pub fn score(&self) -> &QLinear<H, 1> {
        &self.score
    }
}

/// The classifier head of eq. 8: i32 logits at one common scale, and the class.
#[derive(Debug, Clone, PartialEq)]
pub struct Classifier<const H: usize, const C: usize> {
    linear: QLinear<H, C>,
}

impl<const H: usize, const C: usize> Classifier<H, C> {
    /// A placeholder to fill in place through [`Classifier::linear_mut`].
    pub const EMPTY: Self = Self {
        linear: QLinear::EMPTY,
    };

    /// The underlying layer, to fill in place.
    pub fn linear_mut(&mut self) -> &mut QLinear<H, C> {
        &mut self.linear
    }

    /// From a stored layer (`s_g → s_l`).
    pub fn from_linear(linear: QLinear<H, C>) -> Self {
        Self { linear }
    }

    /// Quantize `W_o, b_o` for `g` at `input_scale` and logits at `logit_scale`
    /// (choose it fine, e.g. `max|logit| / 2^15`: the logits are i32).
    ///
    /// # Errors
    /// The errors of [`QLinear::from_f32`].
    pub fn from_f32(
        float: &LinearF32<H, C>,
        input_scale: QScale,
        logit_scale: QScale,
    ) -> Result<Self> {
        Ok(Self {
            linear: QLinear::from_f32(float, input_scale, logit_scale)?,
        })
    }

    /// Logits `W_o·g + b_o` (i32 at the logit scale) and the predicted class (the first
    /// maximum).
    pub fn forward(&self, g: &[i8; H], logits: &mut [i32; C]) -> usize {
        const { assert!(C > 0, "a classifier needs at least one class") };
        self.linear.forward_i32(g, logits);
        argmax_i32(logits).unwrap_or(0)
    }

    /// The underlying layer.
    pub fn linear(&self) -> &QLinear<H, C> {
        &self.linear
    }

    /// The logits' scale.
    pub fn logit_scale(&self) -> QScale {
        self.linear.output_scale()
    }
}

/// Index of the first maximum, `None` for an empty slice.
pub fn argmax_i32(x: &[i32]) -> Option<usize> {
    let mut best: Option<(usize, i32)> = None;
    for (i, &v) in x.iter().enumerate() {
        if best.is_none_or(|(_, b)| v > b) {
            best = Some((i, v));
        }
    }
    best.map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quant::testkit::{
        kernel_pair_tests, random_matrix, random_vector, uniform, KernelPair, Sample,
    };
    use crate::rng::Xoshiro128pp;
    use std::vec::Vec;

    const N: usize = 4;
    const T: usize = 6;
    const H: usize = 16;
    const C: usize = 10;
    const Q15: f64 = 1.0 / 32768.0;

    fn random_mask(rng: &mut Xoshiro128pp) -> NodeMask<N> {
        let mut m: [bool; N] = core::array::from_fn(|_| rng.next_u32() % 4 != 0);
        m[(rng.next_u32() as usize) % N] = true;
        NodeMask(m)
    }

    /// One random pooling + classifier instance; pushes the `g` samples to `pooled`
    /// and the logit samples to `logit_out`.
    fn pool_case(rng: &mut Xoshiro128pp, pooled: &mut Vec<Sample>, logit_out: &mut Vec<Sample>) {
        let amp = f64::from(uniform(rng, 0.5, 4.0)) / (H as f64).sqrt();
        let pool_f = AttentionPoolF32::<H> {
            w: random_vector(rng, amp),
            b: uniform(rng, -1.0, 1.0),
        };
        let head_f = LinearF32::<H, C> {
            w: random_matrix(rng, 1.0),
            b: random_vector(rng, 0.5),
        };
        // Hidden states in [−1, 1] at the GRU's fixed scale 1/127.
        let s_h = QScale::UNIT;
        let mask = random_mask(rng);
        let hq: Vec<[[i8; H]; N]> = (0..T)
            .map(|_| {
                core::array::from_fn(|_| {
                    core::array::from_fn(|_| ((rng.next_u32() % 255) as i32 - 127) as i8)
                })
            })
            .collect();
        let hf: Vec<[[f32; H]; N]> = hq
            .iter()
            .map(|s| s.map(|n| n.map(|v| s_h.dequantize(i32::from(v)))))
            .collect();
        let mut score_range = MaxAbs::new();
        let mut gf = [0f32; H];
        pool_f
            .forward_observed(&hf, &mask, &mut gf, &mut score_range)
            .unwrap();
        let s_s = score_range.scale().unwrap();
        let pool = AttentionPool::from_f32(&pool_f, s_h, s_s).unwrap();
        let mut gq = [0i8; H];
        pool.forward(&hq, &mask, &mut gq).unwrap();

        // Pool bound.
        let sw = f64::from(pool.score().weight_scales()[0].get());
        let (s_h64, s_s64) = (f64::from(s_h.get()), f64::from(s_s.get()));
        let l1_max = hf
            .iter()
            .flat_map(|s| s.iter().enumerate())
            .filter(|(i, _)| mask.0[*i])
            .map(|(_, hi)| hi.iter().map(|v| f64::from(v.abs())).sum::<f64>())
            .fold(0.0, f64::max);
        let delta = 0.5 * s_s64 + 0.5 * sw * l1_max + 0.5 * s_h64 * sw;
        let pairs = (T * mask.count()) as f64;
        let mut tol_g = [0f64; H];
        for k in 0..H {
            let h_max = hf
                .iter()
                .flat_map(|s| s.iter().enumerate())
                .filter(|(i, _)| mask.0[*i])
                .map(|(_, hi)| f64::from(hi[k].abs()))
                .fold(0.0, f64::max);
            tol_g[k] = 0.5 * s_h64
                + h_max * (crate::math::exp(2.0 * delta) - 1.0 + 2.0 * pairs * Q15 / 2.0)
                + 1e-6;
            pooled.push(Sample::new(
                f64::from(gq[k]) * s_h64,
                f64::from(gf[k]),
                tol_g[k],
                s_h64,
            ));
        }

        // Classifier: int8 path from gq, float path from the float g.
        let mut logits_f = [0f32; C];
        head_f.forward(&gf, &mut logits_f);
        let mut lr = MaxAbs::new();
        lr.observe_all(&logits_f);
        let s_l = QScale::new(lr.max_abs().max(1e-3) / 32768.0).unwrap();
        let head = Classifier::from_f32(&head_f, s_h, s_l).unwrap();
        let mut logits = [0i32; C];
        let class = head.forward(&gq, &mut logits);
        let s_l64 = f64::from(s_l.get());
        let g_hat_l1: f64 = gq
            .iter()
            .map(|&v| f64::from(v.unsigned_abs()) * s_h64)
            .sum();
        for c in 0..C {
            let swc = f64::from(head.linear().weight_scales()[c].get());
            let carried: f64 = (0..H)
                .map(|k| f64::from(head_f.w[c][k].abs()) * tol_g[k])
                .sum();
            let tol = 0.5 * s_l64
                + 0.5 * swc * g_hat_l1
                + 0.5 * s_h64 * swc
                + carried
                + 1e-5 * (1.0 + f64::from(logits_f[c].abs()));
            logit_out.push(Sample::new(
                f64::from(logits[c]) * s_l64,
                f64::from(logits_f[c]),
                tol,
                s_l64,
            ));
        }
        assert_eq!(argmax_i32(&logits), Some(class));
    }

    struct Pool;
    impl KernelPair for Pool {
        const NAME: &'static str =
            "attention pool g (AttentionPool vs AttentionPoolF32), N=4 T=6 H=16";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            pool_case(rng, out, &mut Vec::new());
        }
    }
    struct PoolClassify;
    impl KernelPair for PoolClassify {
        const NAME: &'static str =
            "classifier logits after int8 pooling (i32 logits at max|logit|/2^15 vs float pool+head), C=10";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            pool_case(rng, &mut Vec::new(), out);
        }
    }

    kernel_pair_tests! {
        pool_within_derived_bound: Pool, seed 71, cases 2000;
        classifier_logits_within_derived_bound: PoolClassify, seed 71, cases 2000;
    }

    #[test]
    fn class_agrees_with_float_when_margin_is_clear() {
        let mut rng = Xoshiro128pp::seed_from_u64(72);
        let (mut checked, mut agree) = (0, 0);
        for _ in 0..500 {
            let pool_f = AttentionPoolF32::<H> {
                w: random_vector(&mut rng, 0.5),
                b: 0.0,
            };
            let head_f = LinearF32::<H, C> {
                w: random_matrix(&mut rng, 1.0),
                b: random_vector(&mut rng, 0.5),
            };
            let mask = NodeMask([true; N]);
            let hq: Vec<[[i8; H]; N]> = (0..T)
                .map(|_| {
                    core::array::from_fn(|_| {
                        core::array::from_fn(|_| ((rng.next_u32() % 255) as i32 - 127) as i8)
                    })
                })
                .collect();
            let hf: Vec<[[f32; H]; N]> = hq
                .iter()
                .map(|s| s.map(|n| n.map(|v| f32::from(v) / 127.0)))
                .collect();
            let mut gf = [0f32; H];
            pool_f.forward(&hf, &mask, &mut gf).unwrap();
            let mut lf = [0f32; C];
            head_f.forward(&gf, &mut lf);
            let pool =
                AttentionPool::from_f32(&pool_f, QScale::UNIT, QScale::new(0.05).unwrap()).unwrap();
            let head =
                Classifier::from_f32(&head_f, QScale::UNIT, QScale::new(1e-4).unwrap()).unwrap();
            let mut gq = [0i8; H];
            pool.forward(&hq, &mask, &mut gq).unwrap();
            let mut logits = [0i32; C];
            let class = head.forward(&gq, &mut logits);
            let mut sorted = lf;
            sorted.sort_by(|a, b| b.total_cmp(a));
            if sorted[0] - sorted[1] > 0.1 {
                checked += 1;
                let want = lf.iter().position(|&v| v == sorted[0]).unwrap();
                agree += usize::from(class == want);
            }
        }
        assert!(checked > 100);
        assert_eq!(agree, checked);
    }

    #[test]
    fn masks_and_errors() {
        let pool_f = AttentionPoolF32::<2> {
            w: [1.0, 0.0],
            b: 0.0,
        };
        let pool =
            AttentionPool::from_f32(&pool_f, QScale::UNIT, QScale::new(0.1).unwrap()).unwrap();
        let mut g = [5i8; 2];
        let none = NodeMask([false; 3]);
        assert_eq!(
            pool.forward(&[[[1i8, 2]; 3]; 2], &none, &mut g),
            Err(Error::NothingPresent)
        );
        assert_eq!(g, [0, 0]);
        let empty: [[[i8; 2]; 3]; 0] = [];
        assert_eq!(
            pool.forward(&empty, &NodeMask::ALL, &mut g),
            Err(Error::NothingPresent)
        );
        // Masked node 1 carries garbage; it is ignored.
        let h = [[[50i8, 10], [127, 127], [50, 10]]];
        pool.forward(&h, &NodeMask([true, false, true]), &mut g)
            .unwrap();
        assert_eq!(g, [50, 10]);
        let mut gf = [0f32; 2];
        let hf = [[[0.5f32, 0.1], [f32::NAN, 9.0], [0.5, 0.1]]];
        pool_f
            .forward(&hf, &NodeMask([true, false, true]), &mut gf)
            .unwrap();
        assert!((gf[0] - 0.5).abs() < 1e-7);
        assert_eq!(
            pool_f.forward(&hf, &NodeMask::ALL, &mut gf),
            Err(Error::NonFinite)
        );
        assert_eq!(argmax_i32(&[]), None);
        assert_eq!(argmax_i32(&[3, 7, 7, -1]), Some(1));
    }
}
