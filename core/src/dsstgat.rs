//! The whole DS-STGAT forward pass on one window (paper §4.2, eqs. 4–8 and 13): the
//! int8 network [`DsStgat`] and its float reference [`DsStgatF32`], layer for layer the
//! trainer's burn model.
//!
//! ```text
//! x_ti   normalized node features (FeatureNorm)             [T][N][F]   f32 in
//! e_ti   = ReLU(W_in x_ti + b_in)                            embedding (eq. 9's f_embed)
//! u_t    = GAT(e_t, Â_t, mask)                               eqs. 4–6 (quant::gat)
//! s_ti   = GRU(u_ti, s_(t−1)i),  s_0 = 0                     eq. 7   (quant::gru)
//! g      = AttentionPool(s, mask.readout())                  §4.2    (quant::pool)
//! x̄_i    = (1/T) Σ_t x_ti[SENSOR_HEAD_FEATURES]             window mean, 0 if i absent
//! logits = W_o' g + b_o' + V [x̄_0 … x̄_(S−1)] + b_v          eq. 8 + the sensor head
//!          + vote(x̄_0)                                        the defect-line vote
//! ind    = W_f' g + b_f'                                     eq. 13, W_f' = W_f W_c folded
//! ```
//!
//! The compression `Z = W_c g + b_c` (eq. 12) is linear and feeds only linear heads,
//! so the exporter folds it into both heads; the logits and indicators are then one
//! layer from `g`, with no rounding of `Z`.
//!
//! # Int8 data flow
//! The one float→int boundary is the input: the normalized features are quantized at
//! the calibrated input scale (`T·N·F` values per window), and the adjacency at 1/127
//! ([`QAdjacency`]); everything after that is integer ([`crate::quant`]). The heads
//! return i32 at fine scales (max-abs over calibration / 2^15), so the class is an
//! exact integer argmax and the logits dequantize without a coarse int8 step.
//!
//! # Absent nodes
//! A node missing from `mask` (a dead or unmapped sensor) is excluded everywhere: its
//! features are never read, it gets and sends no attention, its GRU state is not
//! advanced and it has no weight in the pooling. A window with no node present is
//! [`Error::NothingPresent`].
//!
//! # The sensor head
//! The class logits add a linear read of each sensor's window-mean features, with a
//! weight row per sensor slot (`V`, [`SENSOR_HEAD_INPUTS`] inputs): the network's
//! weights are shared by the nodes, so it cannot tell "this level at the fan end"
//! from "this level at the drive end", and each sensor sits behind its own transfer
//! path. Its features per sensor are the band shares and the envelope features
//! ([`SENSOR_HEAD_FEATURES`]); the trainer trains the two sets as two experts beside
//! the network (each on a cross-entropy of its own) and folds their weights `γ`,
//! `γ_k` into this one layer (the trainer says why and what it measured). Averaging
//! the steps first is also what makes the head robust to noise: the mean of `T`
//! segment features has a `√T` smaller spread.
//!
//! # Readout at the source node
//! The pooling reads the states of node 0, the sensor on the monitored bearing, when
//! it is present, and of every present node otherwise ([`NodeMask::readout`], which
//! says why); the other nodes inform node 0 through the GAT of every step.
//!
//! # Shapes
//! - `x`: `[T][N][F]`, `adj`: `[T]` adjacencies `[N][N]`, `mask`: `[N]`
//! - hidden size `H` for the embedding, the GAT and the GRU (the trainer's one `H`)
//! - logits `[C]`, indicators `[K]` (in the z-score units the head was trained on)
//!
//! # Memory
//! [`DsStgat`] is plain data (its size is the sum of its kernels'); [`Scratch`] holds
//! `T·N·H + 4·N·H + N·F` bytes plus the GAT/GRU scratch (1 656 B for `T = 8`,
//! `N = 3`, `H = 32`, `F = 28`); the sensor head's input (`SENSOR_HEAD_INPUTS` f32 and
//! as many i8) lives on the stack of a forward pass. Nothing allocates.

use crate::error::{Error, Result};
use crate::graph::{Adjacency, NodeMask};
use crate::model_file::{LayerId, ModelFile};
use crate::quant::{
    argmax_i32, quantize_value, AttentionPool, AttentionPoolF32, Classifier, GatLayer, GatLayerF32,
    GatRanges, GatScales, GatScratch, GatScratchF32, GruCell, GruCellF32, GruScratch, LinearF32,
    MaxAbs, QAdjacency, QLinear, QScale,
};

/// The heads' i32 outputs use `max|value| / HEAD_RESOLUTION` as their scale.
pub const HEAD_RESOLUTION: f32 = 32768.0;

pub use crate::layout::{
    SENSOR_HEAD_DIM, SENSOR_HEAD_FEATURES, SENSOR_HEAD_INPUTS, SENSOR_HEAD_KINEMATIC,
    SENSOR_HEAD_NODES, SENSOR_HEAD_SPECTRAL,
};

/// The sensor head's input: slot `i < N` holds the mean over the `T` steps of node
/// `i`'s features [`SENSOR_HEAD_FEATURES`] when the node is present, zero when it is
/// absent; slots `≥ N` are zero. One definition for the float and int8 networks (the
/// trainer's burn model is tested against it).
///
/// # Errors
/// [`Error::ModelDimensions`] for more nodes than [`SENSOR_HEAD_NODES`] or rows
/// narrower than the features the head reads.
pub fn sensor_head_input<const T: usize, const N: usize, const F: usize>(
    x: &[[[f32; F]; N]; T],
    mask: &NodeMask<N>,
    out: &mut [f32; SENSOR_HEAD_INPUTS],
) -> Result<()> {
    if N > SENSOR_HEAD_NODES {
        return Err(Error::ModelDimensions(
            "more nodes than the sensor head's slots (SENSOR_HEAD_NODES)",
        ));
    }
    *out = [0.0; SENSOR_HEAD_INPUTS];
    let inv_t = 1.0 / T as f32;
    for (i, slot) in out.chunks_exact_mut(SENSOR_HEAD_DIM).take(N).enumerate() {
        if !mask.0[i] {
            continue;
        }
        for (o, &f) in slot.iter_mut().zip(&SENSOR_HEAD_FEATURES) {
            let mut acc = 0.0f32;
            for xt in x {
                acc += *xt[i].get(f).ok_or(Error::ModelDimensions(
                    "node rows narrower than the sensor head's features",
                ))?;
            }
            *o = acc * inv_t;
        }
    }
    Ok(())
}

/// Threshold `τ` of the defect-line vote: dB of a defect line over the envelope
/// spectrum's median (the core's `env_*_db`) below which it casts no vote. White noise
/// alone gives about 5 dB (the largest of a few exponential bins over their median),
/// so 7 dB is a line, not the floor. Chosen with [`LINE_VOTE_WEIGHT`] on the
/// development protocols only (`bash scripts/expert-fusion.sh`, trainer docs).
pub const LINE_VOTE_THRESHOLD_DB: f32 = 7.0;
/// Weight `β` of the defect-line vote: logits per dB above [`LINE_VOTE_THRESHOLD_DB`].
pub const LINE_VOTE_WEIGHT: f32 = 2.0;
/// The envelope lines the vote reads, in [`defect_line`]'s order: outer race (BPFO),
/// inner race (BPFI), rolling element (BSF) (indices into
/// [`crate::features::FEATURE_NAMES`]).
pub const LINE_VOTE_FEATURES: [usize; 3] = [
    crate::features::feature_index("env_bpfo_db"),
    crate::features::feature_index("env_bpfi_db"),
    crate::features::feature_index("env_bsf_db"),
];
/// "No line" in [`LineVote`]'s per-class table.
const NO_LINE: u8 = u8::MAX;

/// The position of feature `f` in a sensor head slot ([`SENSOR_HEAD_FEATURES`]).
const fn slot_position(f: usize) -> usize {
    let mut j = 0;
    while j < SENSOR_HEAD_DIM {
        if SENSOR_HEAD_FEATURES[j] == f {
            return j;
        }
        j += 1;
    }
    panic!("a line the vote reads is not among the sensor head's features")
}
const LINE_SLOT: [usize; 3] = [
    slot_position(LINE_VOTE_FEATURES[0]),
    slot_position(LINE_VOTE_FEATURES[1]),
    slot_position(LINE_VOTE_FEATURES[2]),
];

/// The defect line of a class's fault type, from the class name's prefix (the CWRU
/// labels the project trains on: `IR007`, `B014`, `OR021`, …): `OR…` → 0 (BPFO),
/// `IR…` → 1 (BPFI), `B` followed by a digit or nothing → 2 (BSF); any other class
/// (`normal`) has none.
pub fn defect_line(class_name: &str) -> Option<usize> {
    let b = class_name.as_bytes();
    match b {
        [b'O', b'R', ..] => Some(0),
        [b'I', b'R', ..] => Some(1),
        [b'B'] => Some(2),
        [b'B', d, ..] if d.is_ascii_digit() => Some(2),
        _ => None,
    }
}

/// The defect-line vote: the kinematic physics of a rolling bearing as a prior on the
/// class logits, the envelope analysis a vibration analyst does by hand.
///
/// ```text
/// L_l    = σ_l · x̄_0[l] + μ_l       window-mean line l at node 0, in dB (undoing the
///                                    feature normalization), l ∈ {BPFO, BPFI, BSF}
/// vote_c = β · max(0, L_line(c) − τ)  for a class whose fault type has line(c)
///          0                          for the others, and for all when node 0 is absent
/// logits += vote
/// ```
///
/// Where a defect sits on the bearing sets the rate of its impacts (BPFO, BPFI, BSF
/// follow from the geometry and the shaft speed alone), whatever the defect's size,
/// the load or the transfer path; the learned parts read shapes that change with
/// them. The vote reads node 0, the sensor on the monitored bearing (the readout's
/// source node). It is not trained: its weights are the physics, `τ` and `β`
/// ([`LINE_VOTE_THRESHOLD_DB`], [`LINE_VOTE_WEIGHT`]) were chosen on the development
/// protocols. Under noise the lines sink under the threshold and the vote falls
/// silent instead of voting wrong.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineVote<const C: usize> {
    /// Per class: the index of its line in [`LINE_VOTE_FEATURES`], or [`NO_LINE`].
    line: [u8; C],
    /// Per line: the normalization's mean and standard deviation of its feature.
    mean: [f32; 3],
    std: [f32; 3],
}

impl<const C: usize> LineVote<C> {
    /// A vote that votes for nothing.
    pub const NONE: Self = Self {
        line: [NO_LINE; C],
        mean: [0.0; 3],
        std: [1.0; 3],
    };

    /// The vote for classes `class_names` (in logit order; classes past them vote
    /// nothing) of a model whose features are normalized by `norm`.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] for more names than `C`.
    pub fn new<'a>(
        class_names: impl IntoIterator<Item = &'a str>,
        norm: &crate::features::FeatureNorm,
    ) -> Result<Self> {
        let mut vote = Self::NONE;
        vote.set(class_names, &norm.mean, &norm.std)?;
        Ok(vote)
    }

    /// [`LineVote::new`] in place, from the normalization's means and standard
    /// deviations (a model file's `NormParts`): the MCU's in-place build keeps no copy
    /// of the normalization on its stack.
    ///
    /// # Errors
    /// As [`LineVote::new`]; on error the vote votes for nothing.
    pub fn set<'a>(
        &mut self,
        class_names: impl IntoIterator<Item = &'a str>,
        mean: &[f32; crate::features::FEATURE_DIM],
        std: &[f32; crate::features::FEATURE_DIM],
    ) -> Result<()> {
        *self = Self::NONE;
        for (k, name) in class_names.into_iter().enumerate() {
            let Some(slot) = self.line.get_mut(k) else {
                *self = Self::NONE;
                return Err(Error::ModelDimensions(
                    "more class names than the vote's classes",
                ));
            };
            *slot = defect_line(name).map_or(NO_LINE, |l| l as u8);
        }
        for (l, &f) in LINE_VOTE_FEATURES.iter().enumerate() {
            if let (Some(&m), Some(&s)) = (mean.get(f), std.get(f)) {
                self.mean[l] = m;
                self.std[l] = s;
            }
        }
        Ok(())
    }

    /// Node 0's window-mean defect lines `L` in dB over the envelope median (BPFO,
    /// BPFI, BSF: [`LINE_VOTE_FEATURES`]), the normalization undone, from a window's
    /// sensor head input (slot 0 is node 0's window-mean normalized features,
    /// [`sensor_head_input`]).
    pub fn lines_db(&self, head_input: &[f32]) -> [f32; 3] {
        let mut db = [0.0f32; 3];
        for (l, d) in db.iter_mut().enumerate() {
            let x = head_input.get(LINE_SLOT[l]).copied().unwrap_or(0.0);
            *d = self.std[l] * x + self.mean[l];
        }
        db
    }

    /// The votes `[C]` of a window from its sensor head input ([`LineVote::lines_db`]);
    /// zero when node 0 is absent.
    pub fn votes(&self, head_input: &[f32], node0_present: bool) -> [f32; C] {
        let mut out = [0.0; C];
        if !node0_present {
            return out;
        }
        let mut strength = self.lines_db(head_input);
        for s in strength.iter_mut() {
            let v = LINE_VOTE_WEIGHT * (*s - LINE_VOTE_THRESHOLD_DB);
            *s = if v > 0.0 { v } else { 0.0 }; // also maps NaN to 0
        }
        for (o, &l) in out.iter_mut().zip(&self.line) {
            if let Some(&s) = strength.get(usize::from(l)) {
                *o = s;
            }
        }
        out
    }
}

/// Float reference DS-STGAT.
#[derive(Debug, Clone, PartialEq)]
pub struct DsStgatF32<const F: usize, const H: usize, const C: usize, const K: usize> {
    /// Node embedding `W_in, b_in` (`[H][F]`), ReLU after it.
    pub embed: LinearF32<F, H>,
    /// GAT layer (eqs. 4–6).
    pub gat: GatLayerF32<H, H>,
    /// GRU cell (eq. 7).
    pub gru: GruCellF32<H, H>,
    /// Attention pooling.
    pub pool: AttentionPoolF32<H>,
    /// Classifier (eq. 8, compression folded in).
    pub classifier: LinearF32<H, C>,
    /// Indicator head (eq. 13, compression folded in).
    pub indicator: LinearF32<H, K>,
    /// Sensor head: its logits add to the classifier's ([`sensor_head_input`]).
    pub sensor: LinearF32<SENSOR_HEAD_INPUTS, C>,
    /// The defect-line vote, added to the logits last ([`LineVote`]).
    pub line_vote: LineVote<C>,
}

/// Max-abs observers of every calibrated activation of the network.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ranges {
    /// Normalized input features of present nodes.
    pub input: MaxAbs,
    /// Embedding outputs (after the ReLU).
    pub embedded: MaxAbs,
    /// The GAT layer's activations.
    pub gat: GatRanges,
    /// Pooling scores.
    pub score: MaxAbs,
    /// The sensor head's inputs (window-mean features).
    pub sensor_input: MaxAbs,
    /// Logits (network and sensor head together).
    pub logits: MaxAbs,
    /// Indicator outputs.
    pub indicators: MaxAbs,
}

/// Scratch of the float reference.
#[derive(Debug, Clone, PartialEq)]
pub struct ScratchF32<const T: usize, const N: usize, const H: usize> {
    embedded: [[f32; H]; N],
    gat_out: [[f32; H]; N],
    hidden: [[f32; H]; N],
    states: [[[f32; H]; N]; T],
    gat: GatScratchF32<N, H>,
}

impl<const T: usize, const N: usize, const H: usize> ScratchF32<T, N, H> {
    /// Zeroed scratch.
    pub const fn new() -> Self {
        Self {
            embedded: [[0.0; H]; N],
            gat_out: [[0.0; H]; N],
            hidden: [[0.0; H]; N],
            states: [[[0.0; H]; N]; T],
            gat: GatScratchF32::new(),
        }
    }
}

impl<const T: usize, const N: usize, const H: usize> Default for ScratchF32<T, N, H> {
    fn default() -> Self {
        Self::new()
    }
}

/// Float outputs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutputF32<const C: usize, const K: usize> {
    /// Class logits.
    pub logits: [f32; C],
    /// Indicator outputs (z-score units of the training targets).
    pub indicators: [f32; K],
}

impl<const C: usize, const K: usize> Default for OutputF32<C, K> {
    fn default() -> Self {
        Self {
            logits: [0.0; C],
            indicators: [0.0; K],
        }
    }
}

impl<const C: usize, const K: usize> OutputF32<C, K> {
    /// The first class with the largest logit.
    pub fn class(&self) -> usize {
        let mut best = 0;
        for (c, &l) in self.logits.iter().enumerate() {
            if l > self.logits[best] {
                best = c;
            }
        }
        best
    }
}

fn check_window<const T: usize, const N: usize, const F: usize>(
    x: &[[[f32; F]; N]; T],
    mask: &NodeMask<N>,
) -> Result<()> {
    const { assert!(T > 0 && N > 0, "a window needs steps and nodes") };
    if mask.count() == 0 {
        return Err(Error::NothingPresent);
    }
    for step in x {
        for (i, xi) in step.iter().enumerate() {
            if mask.0[i] && xi.iter().any(|v| !v.is_finite()) {
                return Err(Error::NonFinite);
            }
        }
    }
    Ok(())
}

impl<const F: usize, const H: usize, const C: usize, const K: usize> DsStgatF32<F, H, C, K> {
    /// Forward pass on one window.
    ///
    /// # Errors
    /// [`Error::NothingPresent`] if no node is present; [`Error::NonFinite`] for a NaN/∞
    /// feature of a present node or adjacency entry; the errors of the GAT reference.
    pub fn forward<const T: usize, const N: usize>(
        &self,
        x: &[[[f32; F]; N]; T],
        adj: &[Adjacency<N>; T],
        mask: &NodeMask<N>,
        out: &mut OutputF32<C, K>,
        scratch: &mut ScratchF32<T, N, H>,
    ) -> Result<()> {
        let mut ranges = Ranges::default();
        self.forward_observed(x, adj, mask, out, scratch, &mut ranges)
    }

    /// [`DsStgatF32::forward`], recording every activation range for calibration.
    ///
    /// # Errors
    /// As [`DsStgatF32::forward`].
    pub fn forward_observed<const T: usize, const N: usize>(
        &self,
        x: &[[[f32; F]; N]; T],
        adj: &[Adjacency<N>; T],
        mask: &NodeMask<N>,
        out: &mut OutputF32<C, K>,
        scratch: &mut ScratchF32<T, N, H>,
        ranges: &mut Ranges,
    ) -> Result<()> {
        check_window(x, mask)?;
        let mut xs = [0.0f32; SENSOR_HEAD_INPUTS];
        sensor_head_input(x, mask, &mut xs)?;
        ranges.sensor_input.observe_all(&xs);
        scratch.hidden = [[0.0; H]; N];
        for (t, (xt, at)) in x.iter().zip(adj).enumerate() {
            for (i, (xi, ei)) in xt.iter().zip(scratch.embedded.iter_mut()).enumerate() {
                if mask.0[i] {
                    ranges.input.observe_all(xi);
                    self.embed.forward(xi, ei);
                    for v in ei.iter_mut() {
                        *v = v.max(0.0);
                    }
                    ranges.embedded.observe_all(ei);
                } else {
                    *ei = [0.0; H];
                }
            }
            self.gat.forward_observed(
                &scratch.embedded,
                at,
                mask,
                &mut scratch.gat_out,
                &mut scratch.gat,
                &mut ranges.gat,
            )?;
            for i in 0..N {
                if mask.0[i] {
                    self.gru.step(&scratch.gat_out[i], &mut scratch.hidden[i]);
                }
            }
            scratch.states[t] = scratch.hidden;
        }
        let mut g = [0.0f32; H];
        self.pool
            .forward_observed(&scratch.states, &mask.readout(), &mut g, &mut ranges.score)?;
        self.classifier.forward(&g, &mut out.logits);
        let mut sensor = [0.0f32; C];
        self.sensor.forward(&xs, &mut sensor);
        for (l, v) in out.logits.iter_mut().zip(sensor) {
            *l += v;
        }
        self.indicator.forward(&g, &mut out.indicators);
        // The head scale is the network's and the sensor head's: the vote adds after
        // it (in the int8 network too, at the logits' scale).
        ranges.logits.observe_all(&out.logits);
        ranges.indicators.observe_all(&out.indicators);
        let vote = self.line_vote.votes(&xs, mask.0[0]);
        for (l, v) in out.logits.iter_mut().zip(vote) {
            *l += v;
        }
        Ok(())
    }
}

/// Caller-owned scratch of [`DsStgat::forward`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Scratch<const T: usize, const N: usize, const F: usize, const H: usize> {
    input: [[i8; F]; N],
    embedded: [[i8; H]; N],
    gat_out: [[i8; H]; N],
    hidden: [[i8; H]; N],
    states: [[[i8; H]; N]; T],
    gat: GatScratch<N, H>,
    gru: GruScratch<H>,
}

impl<const T: usize, const N: usize, const F: usize, const H: usize> Scratch<T, N, F, H> {
    /// Zeroed scratch.
    pub const fn new() -> Self {
        Self {
            input: [[0; F]; N],
            embedded: [[0; H]; N],
            gat_out: [[0; H]; N],
            hidden: [[0; H]; N],
            states: [[[0; H]; N]; T],
            gat: GatScratch::new(),
            gru: GruScratch::new(),
        }
    }
}

impl<const T: usize, const N: usize, const F: usize, const H: usize> Default
    for Scratch<T, N, F, H>
{
    fn default() -> Self {
        Self::new()
    }
}

/// Int8 outputs: i32 logits and indicators at the heads' scales, and the class.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Output<const C: usize, const K: usize> {
    /// Logits at [`DsStgat::logit_scale`] (the first [`DsStgat::classes`] are used).
    pub logits: [i32; C],
    /// Indicators at [`DsStgat::indicator_scale`].
    pub indicators: [i32; K],
    /// The predicted class (first maximum of the used logits).
    pub class: usize,
}

impl<const C: usize, const K: usize> Default for Output<C, K> {
    fn default() -> Self {
        Self {
            logits: [0; C],
            indicators: [0; K],
            class: 0,
        }
    }
}

/// The int8 DS-STGAT (see the module docs). Plain data.
#[derive(Debug, Clone, PartialEq)]
pub struct DsStgat<const F: usize, const H: usize, const C: usize, const K: usize> {
    embed: QLinear<F, H>,
    gat: GatLayer<H, H>,
    gru: GruCell<H, H>,
    pool: AttentionPool<H>,
    classifier: Classifier<H, C>,
    indicator: QLinear<H, K>,
    sensor: QLinear<SENSOR_HEAD_INPUTS, C>,
    line_vote: LineVote<C>,
    /// Classes in use (`≤ C`; the rest are zero padding).
    classes: usize,
    /// Indicators in use (`≤ K`).
    indicators: usize,
}

/// The i32 head scale for outputs up to `range`.
fn head_scale(range: &MaxAbs) -> Result<QScale> {
    let m = range.max_abs();
    if !m.is_finite() {
        return Err(Error::NonFinite);
    }
    QScale::new(m.max(1e-6) / HEAD_RESOLUTION).ok_or(Error::InvalidParameter(
        "head output scale is not representable",
    ))
}

impl<const F: usize, const H: usize, const C: usize, const K: usize> DsStgat<F, H, C, K> {
    /// Quantize a float network with the ranges observed on calibration windows
    /// ([`DsStgatF32::forward_observed`]).
    ///
    /// # Errors
    /// [`Error::NonFinite`] for NaN/∞ parameters or ranges; the kernels' errors.
    pub fn from_f32(float: &DsStgatF32<F, H, C, K>, ranges: &Ranges) -> Result<Self> {
        let s_in = ranges.input.scale()?;
        let s_emb = ranges.embedded.scale()?;
        let embed = QLinear::from_f32(&float.embed, s_in, s_emb)?;
        let gat_scales = GatScales {
            input: s_emb,
            projected: ranges.gat.projected.scale()?,
            logit: ranges.gat.logit.scale()?,
            output: ranges.gat.output.scale()?,
        };
        let gat = GatLayer::from_f32(&float.gat, gat_scales)?;
        let gru = GruCell::from_f32(&float.gru, gat_scales.output)?;
        let hidden = GruCell::<H, H>::HIDDEN_SCALE;
        let pool = AttentionPool::from_f32(&float.pool, hidden, ranges.score.scale()?)?;
        let classifier =
            Classifier::from_f32(&float.classifier, hidden, head_scale(&ranges.logits)?)?;
        let indicator =
            QLinear::from_f32(&float.indicator, hidden, head_scale(&ranges.indicators)?)?;
        // The sensor head writes i32 logits at the classifier's scale: they add exactly.
        let sensor = QLinear::from_f32(
            &float.sensor,
            ranges.sensor_input.scale()?,
            head_scale(&ranges.logits)?,
        )?;
        Ok(Self {
            embed,
            gat,
            gru,
            pool,
            classifier,
            indicator,
            sensor,
            line_vote: float.line_vote,
            classes: C,
            indicators: K,
        })
    }

    /// Build from a decoded model file whose dimensions are `F` and `H` (GAT and GRU),
    /// with at most `C` classes and `K` indicators: smaller heads are padded with zero
    /// rows that [`DsStgat::forward`] never reads (see [`ModelFile::linear_padded`]).
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] when the sizes do not fit the file's; the errors of
    /// the typed builders of [`ModelFile`].
    pub fn from_model_file(m: &ModelFile) -> Result<Self> {
        let mut net = Self::EMPTY;
        net.load(m)?;
        Ok(net)
    }

    /// An all-zero network: the starting value of one that [`DsStgat::load`] fills in
    /// place (a `static` on an MCU, in `.bss`).
    pub const EMPTY: Self = Self {
        embed: QLinear::EMPTY,
        gat: GatLayer::EMPTY,
        gru: GruCell::EMPTY,
        pool: AttentionPool::EMPTY,
        classifier: Classifier::EMPTY,
        indicator: QLinear::EMPTY,
        sensor: QLinear::EMPTY,
        line_vote: LineVote::NONE,
        classes: 0,
        indicators: 0,
    };

    /// [`DsStgat::from_model_file`] in place: every layer is written where it lives,
    /// one at a time, so the stack needs no copy of the network (the MCU path: a few
    /// KiB of stack, see `firmware-probe/`).
    ///
    /// # Errors
    /// As [`DsStgat::from_model_file`]. On error `self` is partly overwritten and
    /// reports 0 classes, so [`DsStgat::forward`] on it gives class 0 of nothing: do
    /// not use it.
    pub fn load(&mut self, m: &ModelFile) -> Result<()> {
        self.classes = 0;
        self.indicators = 0;
        if usize::from(m.dims.gat_hidden) != H || usize::from(m.dims.gru_hidden) != H {
            return Err(Error::ModelDimensions(
                "the int8 DS-STGAT needs equal GAT and GRU hidden sizes H",
            ));
        }
        if usize::from(m.dims.nodes) > SENSOR_HEAD_NODES {
            return Err(Error::ModelDimensions(
                "more nodes than the sensor head's slots (SENSOR_HEAD_NODES)",
            ));
        }
        if m.dims.layer_shape(LayerId::Embed) != (F, H) {
            return Err(Error::ModelDimensions(
                "embed: sizes asked for != the file's (inputs, outputs)",
            ));
        }
        m.linear_into(LayerId::Embed, &mut self.embed)?;
        m.gat_layer_into(&mut self.gat)?;
        m.gru_cell_into(&mut self.gru)?;
        self.pool
            .set_in_place(|s| m.linear_into(LayerId::PoolScore, s).map(|_| ()))?;
        let classes = m.linear_into(LayerId::Classifier, self.classifier.linear_mut())?;
        let indicators = m.linear_into(LayerId::Indicator, &mut self.indicator)?;
        if m.linear_into(LayerId::SensorHead, &mut self.sensor)? != classes {
            return Err(Error::ModelDimensions(
                "sensor_head: outputs != the classifier's classes",
            ));
        }
        self.line_vote.set(
            m.class_names.iter().map(|n| n.as_str()),
            &m.feature_norm.mean,
            &m.feature_norm.std,
        )?;
        self.classes = classes;
        self.indicators = indicators;
        Ok(())
    }

    /// Forward pass on one window of normalized features (see the module docs).
    ///
    /// # Errors
    /// [`Error::NothingPresent`] if no node is present; [`Error::NonFinite`] for a NaN/∞
    /// feature of a present node or adjacency entry; [`Error::InvalidParameter`] for an
    /// adjacency entry outside `[0, 1]`. On error `out` is unchanged.
    pub fn forward<const T: usize, const N: usize>(
        &self,
        x: &[[[f32; F]; N]; T],
        adj: &[Adjacency<N>; T],
        mask: &NodeMask<N>,
        out: &mut Output<C, K>,
        s: &mut Scratch<T, N, F, H>,
    ) -> Result<()> {
        check_window(x, mask)?;
        let mut sensor_in = [0.0f32; SENSOR_HEAD_INPUTS];
        sensor_head_input(x, mask, &mut sensor_in)?;
        let mut sensor_q = [0i8; SENSOR_HEAD_INPUTS];
        let s_sensor = self.sensor.input_scale();
        for (q, &v) in sensor_q.iter_mut().zip(&sensor_in) {
            *q = quantize_value(v, s_sensor)?;
        }
        let s_in = self.embed.input_scale();
        s.hidden = [[0; H]; N];
        for (t, (xt, at)) in x.iter().zip(adj).enumerate() {
            for i in 0..N {
                if mask.0[i] {
                    for (q, &v) in s.input[i].iter_mut().zip(&xt[i]) {
                        *q = quantize_value(v, s_in)?;
                    }
                    self.embed.forward(&s.input[i], &mut s.embedded[i]);
                    for v in s.embedded[i].iter_mut() {
                        *v = (*v).max(0);
                    }
                } else {
                    s.embedded[i] = [0; H];
                }
            }
            let qadj = QAdjacency::from_adjacency(at)?;
            self.gat
                .forward(&s.embedded, &qadj, mask, &mut s.gat_out, &mut s.gat);
            for i in 0..N {
                if mask.0[i] {
                    self.gru.step(&s.gat_out[i], &mut s.hidden[i], &mut s.gru);
                }
            }
            s.states[t] = s.hidden;
        }
        let mut g = [0i8; H];
        self.pool.forward(&s.states, &mask.readout(), &mut g)?;
        self.classifier.linear().forward_i32(&g, &mut out.logits);
        let mut sensor = [0i32; C];
        self.sensor.forward_i32(&sensor_q, &mut sensor);
        // The vote in logit codes (≥ 0, rounded half up; saturating).
        let inv_scale = 1.0 / self.logit_scale().get();
        let vote = self.line_vote.votes(&sensor_in, mask.0[0]);
        for ((l, v), w) in out.logits.iter_mut().zip(sensor).zip(vote) {
            let w = w * inv_scale + 0.5;
            let w = if w < i32::MAX as f32 {
                w as i32
            } else {
                i32::MAX
            };
            *l = l.saturating_add(v).saturating_add(w);
        }
        out.class = out
            .logits
            .get(..self.classes)
            .and_then(argmax_i32)
            .unwrap_or(0);
        self.indicator.forward_i32(&g, &mut out.indicators);
        Ok(())
    }

    /// Write the network into `file`: the layers, and the dimensions `gat_hidden`,
    /// `gru_hidden`, `features`, `heads`, `classes` and `indicators` (the first
    /// `classes` / `indicators` rows of the heads; the rest must be padding). The
    /// caller fills names, normalization, graph, physics and geometry.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] for `classes` or `indicators` of 0 or above the
    /// network's, or layers larger than the file's buffers.
    pub fn store(&self, file: &mut ModelFile, classes: usize, indicators: usize) -> Result<()> {
        use crate::model_file::{GatParts, GruParts, QLinearParts};
        if classes == 0 || classes > self.classes || indicators == 0 || indicators > self.indicators
        {
            return Err(Error::ModelDimensions(
                "stored heads must have 1..=C classes and 1..=K indicators",
            ));
        }
        let too_big = Error::ModelDimensions("network larger than the model file's buffers");
        let h = u16::try_from(H).map_err(|_| too_big)?;
        file.dims.features = u16::try_from(F).map_err(|_| too_big)?;
        file.dims.gat_hidden = h;
        file.dims.gru_hidden = h;
        file.dims.heads = 1;
        file.dims.classes = u16::try_from(classes).map_err(|_| too_big)?;
        file.dims.indicators = u16::try_from(indicators).map_err(|_| too_big)?;
        file.embed = QLinearParts::from_qlinear(&self.embed)?;
        file.gat = GatParts::from_layer(&self.gat)?;
        file.gru = GruParts::from_cell(&self.gru)?;
        file.pool = QLinearParts::from_qlinear(self.pool.score())?;
        let mut c = QLinearParts::from_qlinear(self.classifier.linear())?;
        c.weights.truncate(classes * H);
        c.weight_scales.truncate(classes);
        c.bias.truncate(classes);
        file.classifier = c;
        let mut k = QLinearParts::from_qlinear(&self.indicator)?;
        k.weights.truncate(indicators * H);
        k.weight_scales.truncate(indicators);
        k.bias.truncate(indicators);
        file.indicator.head = k;
        let mut v = QLinearParts::from_qlinear(&self.sensor)?;
        v.weights.truncate(classes * SENSOR_HEAD_INPUTS);
        v.weight_scales.truncate(classes);
        v.bias.truncate(classes);
        file.sensor_head = v;
        Ok(())
    }

    /// Classes in use: the first `classes()` logits are meaningful.
    pub fn classes(&self) -> usize {
        self.classes
    }

    /// The sensor head (`[C][SENSOR_HEAD_INPUTS]`).
    pub fn sensor_head(&self) -> &QLinear<SENSOR_HEAD_INPUTS, C> {
        &self.sensor
    }

    /// Indicators in use: the first `indicators()` outputs are meaningful.
    pub fn indicators(&self) -> usize {
        self.indicators
    }

    /// The logits' scale (real logit = scale · code).
    pub fn logit_scale(&self) -> QScale {
        self.classifier.logit_scale()
    }

    /// The indicators' scale.
    pub fn indicator_scale(&self) -> QScale {
        self.indicator.output_scale()
    }

    /// The input scale of the normalized features.
    pub fn input_scale(&self) -> QScale {
        self.embed.input_scale()
    }

    /// The embedding layer.
    pub fn embed(&self) -> &QLinear<F, H> {
        &self.embed
    }
    /// The GAT layer.
    pub fn gat(&self) -> &GatLayer<H, H> {
        &self.gat
    }
    /// The GRU cell.
    pub fn gru(&self) -> &GruCell<H, H> {
        &self.gru
    }
    /// The attention pooling.
    pub fn pool(&self) -> &AttentionPool<H> {
        &self.pool
    }
    /// The classifier.
    pub fn classifier(&self) -> &Classifier<H, C> {
        &self.classifier
    }
    /// The indicator head.
    pub fn indicator(&self) -> &QLinear<H, K> {
        &self.indicator
    }
}

/// Features per node of every shipped model ([`crate::features::FEATURE_DIM`]).
pub const MODEL_FEATURES: usize = crate::features::FEATURE_DIM;
/// Logit capacity of [`InferenceModel`] (files with fewer classes are padded).
pub const MODEL_CLASSES: usize = crate::model_file::MAX_CLASSES;
/// Indicator capacity of [`InferenceModel`].
pub const MODEL_INDICATORS: usize = crate::model_file::MAX_INDICATORS;

/// An int8 DS-STGAT of any hidden size the project trains (`H` = 16 or 32), chosen
/// at run time from a model file: what a gateway loads when it does not know the
/// model at compile time. Firmware with one fixed model uses [`DsStgat`] directly.
// No heap in the core, so no boxing: the enum is as large as its H = 32 variant,
// which is the memory a gateway must reserve anyway.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum InferenceModel {
    /// `H = 16`.
    H16(DsStgat<MODEL_FEATURES, 16, MODEL_CLASSES, MODEL_INDICATORS>),
    /// `H = 32`.
    H32(DsStgat<MODEL_FEATURES, 32, MODEL_CLASSES, MODEL_INDICATORS>),
}

/// Scratch of an [`InferenceModel`] (room for the largest `H`).
pub type InferenceScratch<const T: usize, const N: usize> = (
    Scratch<T, N, MODEL_FEATURES, 16>,
    Scratch<T, N, MODEL_FEATURES, 32>,
);

impl InferenceModel {
    /// Build from a decoded model file.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] for a hidden size other than 16 or 32, or sizes
    /// that do not fit; the errors of [`DsStgat::from_model_file`].
    pub fn from_model_file(m: &ModelFile) -> Result<Self> {
        match m.dims.gat_hidden {
            16 => Ok(Self::H16(DsStgat::from_model_file(m)?)),
            32 => Ok(Self::H32(DsStgat::from_model_file(m)?)),
            _ => Err(Error::ModelDimensions(
                "inference models have hidden size 16 or 32",
            )),
        }
    }

    /// [`DsStgat::forward`] of the model inside.
    ///
    /// # Errors
    /// As [`DsStgat::forward`].
    pub fn forward<const T: usize, const N: usize>(
        &self,
        x: &[[[f32; MODEL_FEATURES]; N]; T],
        adj: &[Adjacency<N>; T],
        mask: &NodeMask<N>,
        out: &mut Output<MODEL_CLASSES, MODEL_INDICATORS>,
        scratch: &mut InferenceScratch<T, N>,
    ) -> Result<()> {
        match self {
            Self::H16(m) => m.forward(x, adj, mask, out, &mut scratch.0),
            Self::H32(m) => m.forward(x, adj, mask, out, &mut scratch.1),
        }
    }

    /// Classes in use.
    pub fn classes(&self) -> usize {
        match self {
            Self::H16(m) => m.classes(),
            Self::H32(m) => m.classes(),
        }
    }

    /// Indicators in use.
    pub fn indicators(&self) -> usize {
        match self {
            Self::H16(m) => m.indicators(),
            Self::H32(m) => m.indicators(),
        }
    }

    /// The logits' scale.
    pub fn logit_scale(&self) -> QScale {
        match self {
            Self::H16(m) => m.logit_scale(),
            Self::H32(m) => m.logit_scale(),
        }
    }

    /// The indicators' scale.
    pub fn indicator_scale(&self) -> QScale {
        match self {
            Self::H16(m) => m.indicator_scale(),
            Self::H32(m) => m.indicator_scale(),
        }
    }
}

/// Softmax of dequantized logits (`scale · code`), in f32: the probabilities a report
/// shows. The decision itself is [`Output::class`], an integer argmax.
pub fn probabilities<const C: usize>(logits: &[i32; C], scale: QScale) -> [f32; C] {
    let mut p = [0.0f32; C];
    probabilities_into(logits, scale, &mut p);
    p
}

/// [`probabilities`] of a slice (e.g. the used logits) into `p` (same length).
pub fn probabilities_into(logits: &[i32], scale: QScale, p: &mut [f32]) {
    let max = logits.iter().copied().max().unwrap_or(0);
    let mut sum = 0.0f64;
    for (pc, &l) in p.iter_mut().zip(logits) {
        let e = crate::math::exp(f64::from(scale.get()) * f64::from(l - max));
        *pc = e as f32;
        sum += e;
    }
    for pc in p.iter_mut() {
        *pc = (f64::from(*pc) / sum) as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro128pp;

    const T: usize = 8;
    const N: usize = 3;
    const F: usize = crate::features::FEATURE_DIM;
    const H: usize = 16;
    const C: usize = 5;
    const K: usize = 4;

    fn uniform(rng: &mut Xoshiro128pp, amp: f64) -> f32 {
        ((rng.uniform() * 2.0 - 1.0) * amp) as f32
    }
    fn matrix<const R: usize, const Q: usize>(rng: &mut Xoshiro128pp, amp: f64) -> [[f32; Q]; R] {
        core::array::from_fn(|_| core::array::from_fn(|_| uniform(rng, amp)))
    }
    fn vector<const Q: usize>(rng: &mut Xoshiro128pp, amp: f64) -> [f32; Q] {
        core::array::from_fn(|_| uniform(rng, amp))
    }
    fn linear<const I: usize, const O: usize>(rng: &mut Xoshiro128pp) -> LinearF32<I, O> {
        let amp = 1.0 / (I as f64).sqrt();
        LinearF32 {
            w: matrix(rng, amp * 1.5),
            b: vector(rng, 0.2),
        }
    }

    fn network(seed: u64) -> DsStgatF32<F, H, C, K> {
        let mut rng = Xoshiro128pp::seed_from_u64(seed);
        let amp = 1.0 / (H as f64).sqrt();
        DsStgatF32 {
            embed: linear(&mut rng),
            gat: GatLayerF32 {
                w: matrix(&mut rng, amp * 1.5),
                a_src: vector(&mut rng, 0.5),
                a_dst: vector(&mut rng, 0.5),
                bias: vector(&mut rng, 0.1),
            },
            gru: GruCellF32 {
                w_z: linear(&mut rng),
                w_r: linear(&mut rng),
                w_n: linear(&mut rng),
                u_z: matrix(&mut rng, amp),
                u_r: matrix(&mut rng, amp),
                u_n: matrix(&mut rng, amp),
            },
            pool: AttentionPoolF32 {
                w: vector(&mut rng, 1.0),
                b: 0.1,
            },
            classifier: LinearF32 {
                w: matrix(&mut rng, 1.5),
                b: vector(&mut rng, 0.3),
            },
            indicator: linear(&mut rng),
            sensor: linear(&mut rng),
            line_vote: LineVote::new(["normal", "IR007", "B007", "OR007", "IR014"], &vote_norm())
                .unwrap(),
        }
    }

    /// A normalization that puts the test windows' line features (about ±1) around
    /// the vote's threshold, so that the vote fires on some windows and not others.
    fn vote_norm() -> crate::features::FeatureNorm {
        let mut norm = crate::features::FeatureNorm::IDENTITY;
        for &f in &LINE_VOTE_FEATURES {
            norm.mean[f] = LINE_VOTE_THRESHOLD_DB;
            norm.std[f] = 2.0;
        }
        norm
    }

    #[test]
    fn the_line_vote_reads_node_0s_defect_lines() {
        assert_eq!(defect_line("OR014"), Some(0));
        assert_eq!(defect_line("IR007"), Some(1));
        assert_eq!(defect_line("B021"), Some(2));
        assert_eq!(defect_line("B"), Some(2));
        assert_eq!(defect_line("BA"), None);
        assert_eq!(defect_line("normal"), None);
        let vote = LineVote::<5>::new(["normal", "OR007", "IR007", "B007"], &vote_norm()).unwrap();
        let mut head = [0.0f32; SENSOR_HEAD_INPUTS];
        // BPFO 3 dB over the threshold, BPFI under it, BSF NaN; node 1's lines ignored.
        head[LINE_SLOT[0]] = 1.5;
        head[LINE_SLOT[1]] = -0.5;
        head[LINE_SLOT[2]] = f32::NAN;
        head[SENSOR_HEAD_DIM + LINE_SLOT[1]] = 10.0;
        let db = vote.lines_db(&head);
        assert_eq!(
            db[..2],
            [LINE_VOTE_THRESHOLD_DB + 3.0, LINE_VOTE_THRESHOLD_DB - 1.0]
        );
        assert!(db[2].is_nan());
        let v = vote.votes(&head, true);
        assert_eq!(v, [0.0, LINE_VOTE_WEIGHT * 3.0, 0.0, 0.0, 0.0]);
        assert_eq!(vote.votes(&head, false), [0.0; 5], "node 0 absent: no vote");
        assert!(LineVote::<2>::new(["IR", "OR", "B"], &vote_norm()).is_err());
    }

    /// A window of features with class-dependent structure, a random graph (with
    /// self-loops and some zero edges) and a mask.
    struct Window {
        x: [[[f32; F]; N]; T],
        adj: [Adjacency<N>; T],
        mask: NodeMask<N>,
    }

    fn window(rng: &mut Xoshiro128pp, k: usize) -> Window {
        let shift = (k % 5) as f32 * 0.4 - 0.8;
        let x = core::array::from_fn(|_| {
            core::array::from_fn(|i| {
                core::array::from_fn(|f| (rng.normal() as f32) + if f == i { shift } else { 0.0 })
            })
        });
        let adj = core::array::from_fn(|_| {
            let mut a = [[0.0f32; N]; N];
            for i in 0..N {
                for j in i..N {
                    let v = if i == j || rng.uniform() > 0.3 {
                        rng.uniform() as f32
                    } else {
                        0.0
                    };
                    a[i][j] = v;
                    a[j][i] = v;
                }
            }
            Adjacency(a)
        });
        let mask = NodeMask(core::array::from_fn(|i| !(k % 4 == 3 && i == 2)));
        Window { x, adj, mask }
    }

    fn calibrated(seed: u64) -> (DsStgatF32<F, H, C, K>, DsStgat<F, H, C, K>) {
        let float = network(seed);
        let mut rng = Xoshiro128pp::seed_from_u64(seed ^ 0xCA1);
        let mut ranges = Ranges::default();
        let mut out = OutputF32::default();
        let mut s = ScratchF32::<T, N, H>::new();
        for k in 0..64 {
            let w = window(&mut rng, k);
            float
                .forward_observed(&w.x, &w.adj, &w.mask, &mut out, &mut s, &mut ranges)
                .unwrap();
        }
        let q = DsStgat::from_f32(&float, &ranges).unwrap();
        (float, q)
    }

    /// The int8 network follows the float reference on held-out windows: the class
    /// agrees whenever the float top-two margin is clear, and the logits stay close.
    #[test]
    fn int8_tracks_the_float_reference() {
        let mut agree = 0;
        let mut clear = 0;
        let mut total = 0;
        let mut worst = 0.0f32;
        let mut worst_ind = 0.0f32;
        for seed in 0..6 {
            let (float, q) = calibrated(seed);
            let mut rng = Xoshiro128pp::seed_from_u64(seed ^ 0x7E57);
            let mut sf = ScratchF32::<T, N, H>::new();
            let mut sq = Scratch::<T, N, F, H>::new();
            let (ls, is) = (q.logit_scale().get(), q.indicator_scale().get());
            for k in 0..100 {
                let w = window(&mut rng, k);
                let mut of = OutputF32::default();
                float
                    .forward(&w.x, &w.adj, &w.mask, &mut of, &mut sf)
                    .unwrap();
                let mut oq = Output::default();
                q.forward(&w.x, &w.adj, &w.mask, &mut oq, &mut sq).unwrap();
                let range = of
                    .logits
                    .iter()
                    .fold(0.0f32, |m, v| m.max(v.abs()))
                    .max(1.0);
                for (a, &b) in of.logits.iter().zip(&oq.logits) {
                    worst = worst.max((a - ls * b as f32).abs() / range);
                }
                for (a, &b) in of.indicators.iter().zip(&oq.indicators) {
                    worst_ind = worst_ind.max((a - is * b as f32).abs());
                }
                let mut sorted = of.logits;
                sorted.sort_by(|a, b| b.total_cmp(a));
                total += 1;
                if of.class() == oq.class {
                    agree += 1;
                }
                if sorted[0] - sorted[1] > 0.1 * range {
                    clear += 1;
                    assert_eq!(of.class(), oq.class, "seed {seed} window {k}");
                }
            }
        }
        std::println!(
            "[dsstgat] int8 vs float: class agreement {agree}/{total} ({clear} with a clear \
             margin, all equal); max logit error {:.4} of the logit range; max indicator \
             error {worst_ind:.4}",
            worst
        );
        assert!(agree * 100 >= total * 95, "{agree}/{total}");
        assert!(worst < 0.08, "logit error {worst}");
        assert!(worst_ind < 0.15, "indicator error {worst_ind}");
    }

    #[test]
    fn sensor_head_input_is_the_window_mean_of_present_nodes() {
        let mut rng = Xoshiro128pp::seed_from_u64(5);
        let w = window(&mut rng, 3);
        let mut out = [f32::NAN; SENSOR_HEAD_INPUTS];
        sensor_head_input(&w.x, &NodeMask([true, false, true]), &mut out).unwrap();
        for (e, &f) in SENSOR_HEAD_FEATURES.iter().enumerate() {
            for (i, present) in [(0, true), (1, false), (2, true)] {
                let mean = w.x.iter().map(|xt| xt[i][f]).sum::<f32>() / T as f32;
                let got = out[i * SENSOR_HEAD_DIM + e];
                let want = if present { mean } else { 0.0 };
                assert!(
                    (got - want).abs() <= 1e-6,
                    "node {i} feature {f}: {got} vs {want}"
                );
            }
        }
        assert!(out[N * SENSOR_HEAD_DIM..].iter().all(|&v| v == 0.0));
        // More nodes than slots, or rows without the head's features, are refused.
        let wide = [[[0.0f32; F]; SENSOR_HEAD_NODES + 1]; 2];
        assert!(matches!(
            sensor_head_input(&wide, &NodeMask([true; SENSOR_HEAD_NODES + 1]), &mut out),
            Err(Error::ModelDimensions(_))
        ));
        let narrow = [[[0.0f32; 4]; N]; 2];
        assert!(matches!(
            sensor_head_input(&narrow, &NodeMask([true; N]), &mut out),
            Err(Error::ModelDimensions(_))
        ));
    }

    #[test]
    fn absent_nodes_are_ignored_and_empty_windows_refused() {
        let (_, q) = calibrated(11);
        let mut rng = Xoshiro128pp::seed_from_u64(5);
        let mut w = window(&mut rng, 3); // node 2 absent
        assert!(!w.mask.0[2]);
        let mut s = Scratch::<T, N, F, H>::new();
        let mut a = Output::default();
        q.forward(&w.x, &w.adj, &w.mask, &mut a, &mut s).unwrap();
        for step in w.x.iter_mut() {
            step[2] = [f32::NAN; F]; // never read
        }
        let mut b = Output::default();
        q.forward(&w.x, &w.adj, &w.mask, &mut b, &mut s).unwrap();
        assert_eq!(a, b);
        // A NaN in a present node is an error, and `out` is untouched.
        w.x[4][0][7] = f32::NAN;
        let before = b;
        assert_eq!(
            q.forward(&w.x, &w.adj, &w.mask, &mut b, &mut s),
            Err(Error::NonFinite)
        );
        assert_eq!(b, before);
        let none = NodeMask([false; N]);
        assert_eq!(
            q.forward(&w.x, &w.adj, &none, &mut b, &mut s),
            Err(Error::NothingPresent)
        );
    }

    /// Through the model file and back (with fewer classes and indicators than the
    /// network's capacity): the int8 outputs are identical.
    #[test]
    fn model_file_round_trip_gives_identical_outputs() {
        use crate::model_file::{decode, encode, ModelFile, Name, MAX_ENCODED_LEN};
        // Zero the padded rows, as the trainer's export does.
        let mut float = network(21);
        for row in float.classifier.w.iter_mut().skip(3) {
            *row = [0.0; H];
        }
        for b in float.classifier.b.iter_mut().skip(3) {
            *b = 0.0;
        }
        float.indicator.w[3] = [0.0; H];
        float.indicator.b[3] = 0.0;
        for row in float.sensor.w.iter_mut().skip(3) {
            *row = [0.0; SENSOR_HEAD_INPUTS];
        }
        for b in float.sensor.b.iter_mut().skip(3) {
            *b = 0.0;
        }
        // The vote of the file's classes: the decoded network must build it back
        // from the class names and the normalization.
        float.line_vote = LineVote::new(["normal", "IR007", "B007"], &vote_norm()).unwrap();
        let mut rng = Xoshiro128pp::seed_from_u64(77);
        let mut ranges = Ranges::default();
        let mut sf = ScratchF32::<T, N, H>::new();
        let mut of = OutputF32::default();
        for k in 0..32 {
            let w = window(&mut rng, k);
            float
                .forward_observed(&w.x, &w.adj, &w.mask, &mut of, &mut sf, &mut ranges)
                .unwrap();
        }
        let q = DsStgat::from_f32(&float, &ranges).unwrap();
        let mut file = ModelFile::default();
        q.store(&mut file, 3, 3).unwrap();
        file.dims.nodes = N as u16;
        file.dims.steps = T as u16;
        for name in ["normal", "IR007", "B007"] {
            file.class_names
                .push(Name::try_from(name).unwrap())
                .unwrap();
        }
        for name in ["DE", "FE", "BA"] {
            file.sensor_names
                .push(Name::try_from(name).unwrap())
                .unwrap();
        }
        for name in ["a", "b", "c"] {
            file.indicator
                .names
                .push(Name::try_from(name).unwrap())
                .unwrap();
            file.indicator.mean.push(0.0).unwrap();
            file.indicator.std.push(1.0).unwrap();
        }
        file.feature_norm = (&vote_norm()).into();
        file.graph =
            crate::model_file::GraphParts::from_config(&crate::graph::GraphConfig::<N>::uniform())
                .unwrap();
        file.physics = (&crate::simulator::BearingParams::default_housing()).into();
        file.geometry = (&crate::bearing::BearingGeometry::CWRU_6205_DE).into();
        let mut buf = std::vec![0u8; MAX_ENCODED_LEN];
        let len = encode(&file, &mut buf).unwrap();
        let decoded = decode(&buf[..len]).unwrap();
        let back = DsStgat::<F, H, C, K>::from_model_file(&decoded).unwrap();
        assert_eq!((back.classes(), back.indicators()), (3, 3));
        let mut sq = Scratch::<T, N, F, H>::new();
        for k in 0..40 {
            let w = window(&mut rng, k);
            let (mut a, mut b) = (Output::default(), Output::default());
            q.forward(&w.x, &w.adj, &w.mask, &mut a, &mut sq).unwrap();
            back.forward(&w.x, &w.adj, &w.mask, &mut b, &mut sq)
                .unwrap();
            assert_eq!(a.logits, b.logits);
            assert_eq!(a.indicators[..3], b.indicators[..3]);
            assert_eq!(b.class, argmax_i32(&a.logits[..3]).unwrap());
        }
        // The run-time model picks H = 16 and computes the same.
        let any = InferenceModel::from_model_file(&decoded).unwrap();
        assert!(matches!(any, InferenceModel::H16(_)));
        let w = window(&mut rng, 1);
        let mut s2 = (Scratch::new(), Scratch::new());
        let mut a = Output::default();
        any.forward(&w.x, &w.adj, &w.mask, &mut a, &mut s2).unwrap();
        let mut b = Output::default();
        back.forward(&w.x, &w.adj, &w.mask, &mut b, &mut sq)
            .unwrap();
        assert_eq!(a.logits[..C], b.logits[..]);
    }

    #[test]
    fn probabilities_sum_to_one() {
        let p = probabilities(&[1000, -2000, 0], QScale::new(1e-3).unwrap());
        let sum: f32 = p.iter().sum();
        assert!((sum - 1.0).abs() < 1e-6);
        assert!(p[0] > p[2] && p[2] > p[1]);
    }
}
