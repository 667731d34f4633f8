//! The model file: one postcard-encoded file with everything the edge needs to run a
//! trained DS-STGAT, decoded without allocation into fixed-capacity buffers.
//!
//! # Layout (format version 8)
//!
//! | offset | bytes | field | encoding |
//! |---|---|---|---|
//! | 0 | 8 | magic [`MAGIC`] = `PTWINMDL` | ASCII |
//! | 8 | 2 | format version [`FORMAT_VERSION`] = 9 | u16, little-endian |
//! | 10 | 4 | payload length `L` | u32, little-endian |
//! | 14 | `L` | payload: a [`ModelFile`] | postcard 1.x |
//! | 14 + `L` | 4 | CRC-32 of the payload (see [`crc32`]) | u32, little-endian |
//!
//! The payload is the [`ModelFile`] struct, fields in this order (postcard: integers
//! other than `u8`/`i8` are varints, `i32` zigzag; `f32`/`f64` are 4/8 bytes
//! little-endian; a `heapless::Vec`/`String` is a varint length then its elements;
//! a fixed array has no length prefix):
//!
//! | field | type | what |
//! |---|---|---|
//! | `model_name`, `created` | `String<32>` ×2 | free-form name, creation date |
//! | `dims` | [`Dimensions`] | `N` nodes, `F` features, `T` steps, GAT and GRU hidden sizes, heads, `C` classes, `K` indicators |
//! | `class_names` | `Vec<String<16>, 16>` | `C` names, in logit order |
//! | `sensor_names` | `Vec<String<16>, 8>` | `N` names, in node order |
//! | `feature_norm` | [`NormParts`] | mean, std: `[f32; FEATURE_DIM]` each |
//! | `graph` | [`GraphParts`] | β, τ_corr, window `w`, prior `P` (`N·N` f32, row-major) |
//! | `embed` | [`EmbedParts`] | node embedding `W_in, b_in` (`[H_gat][F]`), ReLU after it |
//! | `gat` | [`GatParts`] | projection `W` (`[H_gat][H_gat]`), `a_src`, `a_dst`, bias, scales |
//! | `gru` | [`GruParts`] | `W_z, U_z, W_r, U_r, W_n, U_n` |
//! | `pool` | [`PoolScoreParts`] | attention-pooling score layer (`[1][H_gru]`) |
//! | `classifier` | [`ClassifierParts`] | eq. 8 head (`[C][H_gru]`, `W_o W_c` folded) |
//! | `sensor_head` | [`SensorHeadParts`] | sensor head (`[C][SENSOR_HEAD_INPUTS]`), logits at the classifier's scale |
//! | `indicator` | [`IndicatorParts`] | eq. 13 head (`[K][H_gru]`, `W_f W_c` folded), names, target mean/std |
//! | `physics` | [`PhysicsParts`] | default [`BearingParams`] (f64, SI) |
//! | `geometry` | [`GeometryParts`] | bearing `n`, `d`, `D`, contact angle |
//!
//! Every int8 layer is a [`QLinearParts`]: input and output scales (f32), per-output-
//! channel weight scales (f32), i32 biases, and the int8 weights row-major
//! (`[OUT][IN]`), exactly the parts of [`QLinear::from_parts`].
//!
//! # Decoding
//!
//! [`decode`] checks, in order, and stops at the first failure:
//!
//! ```text
//! 1. len ≥ 14                                   else ModelTruncated
//! 2. magic == "PTWINMDL"                        else ModelMagic
//! 3. version == FORMAT_VERSION                  else ModelVersion { found, supported }
//! 4. len == 14 + L + 4                          else ModelTruncated / ModelTrailingBytes
//! 5. CRC-32(payload) == stored                  else ModelChecksum
//! 6. postcard decodes all L bytes               else ModelDecode (incl. a buffer over capacity)
//! 7. dimensions: within the maxima below, names/prior/blob lengths match them
//!                                               else ModelDimensions
//! 8. values: scales finite > 0, codes ≠ −128, |bias| ≤ 2^30 − 1, requantization
//!    ratios representable, the sensor head's output scale the classifier's, feature std > 0, graph and physical parameters valid
//!                                               else ModelValue
//! ```
//!
//! Nothing allocates (postcard deserializes into the `heapless` buffers) and nothing
//! panics: every malformed input is an [`Error`]. [`encode`] runs steps 7–8 before
//! writing, so it never writes a file that [`decode`] would refuse. The typed builders
//! ([`ModelFile::gat_layer`], [`ModelFile::gru_cell`], [`ModelFile::linear`], …) then
//! check the compile-time sizes asked for against the file's and assemble the
//! [`crate::quant`] kernels.
//!
//! # Capacities and memory
//!
//! | const | value | bounds |
//! |---|---|---|
//! | [`MAX_NODES`] | 8 | `N` |
//! | [`MAX_CLASSES`] | 16 | `C` |
//! | [`MAX_HIDDEN`] | 32 | `H_gat`, `H_gru` |
//! | [`MAX_STEPS`] | 8192 | `T` (`T·N ≤` [`MAX_POOL_PAIRS`]) |
//! | [`MAX_INDICATORS`] | 8 | `K` |
//! | [`MAX_EMBED_WEIGHTS`] | 640 | `H_gat·F` |
//! | [`MAX_GAT_WEIGHTS`] | 1024 | `H_gat·H_gat` |
//! | [`MAX_GRU_WEIGHTS`] | 1024 | each GRU matrix |
//! | [`MAX_CLASSIFIER_WEIGHTS`] | 512 | `C·H_gru` |
//! | [`MAX_SENSOR_HEAD_WEIGHTS`] | `16·SENSOR_HEAD_INPUTS` | `C·SENSOR_HEAD_INPUTS` |
//! | [`MAX_INDICATOR_WEIGHTS`] | 256 | `K·H_gru` |
//!
//! `F` must equal [`FEATURE_DIM`] (the normalization has that many entries).
//!
//! `size_of::<ModelFile>()` is 14 088 bytes on `thumbv7em-none-eabihf` (with the
//! sensor head's 1 008 weights, 16 classes × 63 inputs; 13 848 with its 48 inputs of
//! format 7, 12 936 before it), asserted at compile time to stay within [`DECODED_SIZE_BUDGET`]
//! (16 KiB); six full 32×32 GRU matrices are 6 KiB of it. A file is at most
//! [`MAX_ENCODED_LEN`] bytes. On an MCU decode with [`decode_into`] into storage
//! the firmware owns (a `static`): it fills the buffers in place and needs 1.4 KiB
//! of stack (measured on a Cortex-M4F, `firmware-probe/`). [`decode`] returns the
//! model by value and needs about three times its size of stack (the default value,
//! the returned value and the caller's copy) — fine on a host. A derived
//! `Deserialize` would have built every nested struct as a local and moved it up,
//! hence the hand-written in-place decoding below.
//!
//! The typed builders come in two forms. [`ModelFile::linear`],
//! [`ModelFile::gat_layer`], [`ModelFile::gru_cell`] return the kernels by value
//! (convenient on a host; the by-value build of the whole H = 32 network took
//! 105 KB of stack on the Cortex-M4F, every kernel moved several times).
//! [`ModelFile::linear_into`], [`ModelFile::gat_layer_into`],
//! [`ModelFile::gru_cell_into`] fill kernels where they live, and
//! [`crate::dsstgat::DsStgat::load`] builds the whole network that way: 1.6 KiB of
//! stack on the same MCU (each builder in its own frame), so decoded model, network
//! and scratch fit 32 KiB of RAM (the scratch taking the decoded model's place once
//! the network is built, `firmware-probe/`).
//!
//! # Writing
//!
//! The trainer fills a [`ModelFile`] from its quantized kernels with
//! [`QLinearParts::from_qlinear`], [`GatParts::from_layer`], [`GruParts::from_cell`],
//! [`GraphParts::from_config`] and the `From` impls of [`NormParts`],
//! [`PhysicsParts`] and [`GeometryParts`], then calls [`encode`] into a buffer of
//! [`ModelFile::encoded_len`] (or [`MAX_ENCODED_LEN`]) bytes. Decoding that file and
//! rebuilding the kernels gives back values equal to the exported ones (tested).
//!
//! # Versioning
//!
//! Any change to the payload (a field added, removed, reordered or retyped, a
//! capacity lowered) or to what the network computes from it needs a new
//! [`FORMAT_VERSION`]; a reader rejects every version
//! but its own rather than guess. Version 3: node features went from 20 to 32 (the
//! four linear band shares became sixteen log band shares), so a version-2 file's
//! normalization and embedding no longer fit the features the core computes.
//! Version 4: node features went from 32 to 27 (the broadband shape statistics —
//! crest, kurtosis, skewness, shape and impulse factors — left the node features,
//! `crate::features`), so a version-3 file means five features the core no longer
//! computes. Version 5: node features went from 27 to 28 (the window's
//! noise-compensated kurtosis, `features::noise_compensated_kurtosis`), so a
//! version-4 file's normalization and embedding lack a column. Version 6: the same
//! payload, but the network reads its diagnosis at the source node
//! (`graph::NodeMask::readout`), so a version-5 file's pooling and heads were trained
//! for a readout over every node and would be run with the wrong one. Version 7: the
//! sensor head joined the payload (`crate::dsstgat`, its logits add to the
//! classifier's), so a version-6 file lacks a layer the network needs. Version 8:
//! the sensor head reads the five envelope features of each sensor after its sixteen
//! band shares (`crate::dsstgat::SENSOR_HEAD_FEATURES`: 21 per slot, 63 inputs), so a
//! version-7 file's head has the wrong width. Version 9: the same payload, but the
//! logits add the defect-line vote (`crate::dsstgat::LineVote`, built from the class
//! names and the normalization), so a version-8 file's golden logits and parity
//! figures are no longer what the network computes from it.

use heapless::{String, Vec};
use serde::{Deserialize, Serialize};

use crate::bearing::BearingGeometry;
use crate::error::{Error, Result};
use crate::features::{FeatureNorm, FEATURE_DIM};
use crate::graph::GraphConfig;
use crate::layout::SENSOR_HEAD_INPUTS;
use crate::quant::linear::MAX_BIAS;
use crate::quant::pool::MAX_POOL_PAIRS;
use crate::quant::{
    AttentionPool, Classifier, GatLayer, GatScales, GruCell, QLinear, QMultiplier, QScale,
};
use crate::simulator::BearingParams;

/// The first 8 bytes of every model file.
pub const MAGIC: [u8; 8] = *b"PTWINMDL";
/// The format version this core writes and reads.
pub const FORMAT_VERSION: u16 = 9;
/// Bytes before the payload: magic, version, payload length.
pub const HEADER_LEN: usize = 14;
/// Bytes after the payload: the CRC-32.
pub const CRC_LEN: usize = 4;

/// Most sensor nodes `N`.
pub const MAX_NODES: usize = 8;
/// Most classes `C`.
pub const MAX_CLASSES: usize = 16;
/// Largest GAT or GRU hidden size.
pub const MAX_HIDDEN: usize = 32;
/// Most time steps `T` (so that `T·N` pooled pairs never exceed [`MAX_POOL_PAIRS`]).
pub const MAX_STEPS: usize = MAX_POOL_PAIRS / MAX_NODES;
/// Capacity in bytes of a class or sensor name.
pub const NAME_LEN: usize = 16;
/// Capacity in bytes of the model name and the creation date.
pub const TEXT_LEN: usize = 32;
/// Entries of the largest graph prior, `MAX_NODES²`.
pub const MAX_PRIOR: usize = MAX_NODES * MAX_NODES;
/// Most physical-indicator outputs `K` (eq. 13).
pub const MAX_INDICATORS: usize = 8;
/// Int8 weights of the node embedding, `MAX_HIDDEN · FEATURE_DIM`.
pub const MAX_EMBED_WEIGHTS: usize = MAX_HIDDEN * FEATURE_DIM;
/// Int8 weights of the indicator head, `MAX_INDICATORS · MAX_HIDDEN`.
pub const MAX_INDICATOR_WEIGHTS: usize = MAX_INDICATORS * MAX_HIDDEN;
/// Int8 weights of the GAT projection, `MAX_HIDDEN · MAX_HIDDEN`.
pub const MAX_GAT_WEIGHTS: usize = MAX_HIDDEN * MAX_HIDDEN;
/// Int8 weights of one GRU matrix (`W_g` or `U_g`), `MAX_HIDDEN²`.
pub const MAX_GRU_WEIGHTS: usize = MAX_HIDDEN * MAX_HIDDEN;
/// Int8 weights of the classifier, `MAX_CLASSES · MAX_HIDDEN`.
pub const MAX_CLASSIFIER_WEIGHTS: usize = MAX_CLASSES * MAX_HIDDEN;
/// Int8 weights of the sensor head, `MAX_CLASSES · SENSOR_HEAD_INPUTS`.
pub const MAX_SENSOR_HEAD_WEIGHTS: usize = MAX_CLASSES * SENSOR_HEAD_INPUTS;
/// Upper bound of `size_of::<ModelFile>()`, checked at compile time for every target.
pub const DECODED_SIZE_BUDGET: usize = 16 * 1024;

/// The physical indicators of the indicator head (paper eq. 13), full names in output
/// order. The file stores each name's first [`NAME_LEN`] bytes (a fixed-size field);
/// [`indicator_full_name`] gives the full name back.
pub const INDICATOR_NAMES: [&str; 4] = [
    "impact_intensity",
    "dominant_band_energy_ratio",
    "adjacent_node_energy_difference_db",
    "graph_embedding_inconsistency",
];

/// The full name of an indicator whose stored (possibly cut) name is `stored`: the
/// [`INDICATOR_NAMES`] entry it is the [`NAME_LEN`]-byte prefix of, else `stored`.
pub fn indicator_full_name(stored: &str) -> &str {
    INDICATOR_NAMES
        .iter()
        .find(|n| n.get(..NAME_LEN).unwrap_or(n) == stored)
        .copied()
        .unwrap_or(stored)
}

/// A class or sensor name.
pub type Name = String<NAME_LEN>;
/// The model name or the creation date.
pub type Text = String<TEXT_LEN>;
/// The node embedding `W_in, b_in` (`[H_gat][F]`).
pub type EmbedParts = QLinearParts<MAX_EMBED_WEIGHTS, MAX_HIDDEN>;
/// The indicator head (`[K][H_gru]`).
pub type IndicatorHeadParts = QLinearParts<MAX_INDICATOR_WEIGHTS, MAX_INDICATORS>;
/// The GAT projection `W` (`[H_gat][H_gat]`).
pub type GatProjectParts = QLinearParts<MAX_GAT_WEIGHTS, MAX_HIDDEN>;
/// One GRU matrix (`W_g`: `[H_gru][H_gat]`, `U_g`: `[H_gru][H_gru]`).
pub type GruMatrixParts = QLinearParts<MAX_GRU_WEIGHTS, MAX_HIDDEN>;
/// The attention-pooling score layer (`[1][H_gru]`).
pub type PoolScoreParts = QLinearParts<MAX_HIDDEN, 1>;
/// The classifier (`[C][H_gru]`).
pub type ClassifierParts = QLinearParts<MAX_CLASSIFIER_WEIGHTS, MAX_CLASSES>;
/// The sensor head (`[C][SENSOR_HEAD_INPUTS]`).
pub type SensorHeadParts = QLinearParts<MAX_SENSOR_HEAD_WEIGHTS, MAX_CLASSES>;

const _: () = assert!(
    MAX_STEPS <= u16::MAX as usize,
    "dimensions (T the largest) are stored as u16"
);
const _: () = assert!(
    FEATURE_DIM <= 32,
    "serde (de)serializes fixed arrays of at most 32 elements"
);
const _: () = assert!(
    core::mem::size_of::<ModelFile>() <= DECODED_SIZE_BUDGET,
    "the decoded model outgrew its MCU memory budget"
);

// ---------------------------------------------------------------------------------
// CRC-32
// ---------------------------------------------------------------------------------

/// The reflected CRC-32 polynomial (IEEE 802.3).
const CRC32_POLY: u32 = 0xEDB8_8320;

/// Byte-at-a-time table of the reflected CRC-32.
const fn crc32_table() -> [u32; 256] {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 {
                CRC32_POLY ^ (c >> 1)
            } else {
                c >> 1
            };
            k += 1;
        }
        table[i] = c;
        i += 1;
    }
    table
}

static CRC32_TABLE: [u32; 256] = crc32_table();

/// CRC-32 (IEEE 802.3, as zlib, PNG and Ethernet): reflected polynomial `0xEDB88320`,
/// initial value and final XOR `0xFFFFFFFF`. Check value: `crc32(b"123456789") ==
/// 0xCBF43926`.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c = CRC32_TABLE[((c ^ u32::from(b)) & 0xFF) as usize] ^ (c >> 8);
    }
    !c
}

// ---------------------------------------------------------------------------------
// Payload
// ---------------------------------------------------------------------------------

/// Architecture dimensions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Dimensions {
    /// Sensor nodes `N`, `1..=`[`MAX_NODES`].
    pub nodes: u16,
    /// Node features `F`, equal to [`FEATURE_DIM`].
    pub features: u16,
    /// Time steps `T` per window, `1..=`[`MAX_STEPS`].
    pub steps: u16,
    /// GAT hidden size `H_gat`, `1..=`[`MAX_HIDDEN`].
    pub gat_hidden: u16,
    /// GRU hidden size `H_gru`, `1..=`[`MAX_HIDDEN`].
    pub gru_hidden: u16,
    /// Attention heads (the int8 GAT has one).
    pub heads: u16,
    /// Classes `C`, `1..=`[`MAX_CLASSES`].
    pub classes: u16,
    /// Physical indicators `K` (eq. 13), `1..=`[`MAX_INDICATORS`].
    pub indicators: u16,
}

impl Dimensions {
    /// `(inputs, outputs)` of a layer under these dimensions.
    pub fn layer_shape(&self, id: LayerId) -> (usize, usize) {
        let f = usize::from(self.features);
        let hg = usize::from(self.gat_hidden);
        let hr = usize::from(self.gru_hidden);
        match id {
            LayerId::Embed => (f, hg),
            LayerId::GatProject => (hg, hg),
            LayerId::GruWz | LayerId::GruWr | LayerId::GruWn => (hg, hr),
            LayerId::GruUz | LayerId::GruUr | LayerId::GruUn => (hr, hr),
            LayerId::PoolScore => (hr, 1),
            LayerId::Classifier => (hr, usize::from(self.classes)),
            LayerId::SensorHead => (SENSOR_HEAD_INPUTS, usize::from(self.classes)),
            LayerId::Indicator => (hr, usize::from(self.indicators)),
        }
    }
}

/// The int8 layers of the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LayerId {
    /// Node embedding `W_in, b_in` (eq. 9's `f_embed`), `F → H_gat`, ReLU after it.
    Embed,
    /// GAT projection `W` (eqs. 4, 6), `H_gat → H_gat`, no bias.
    GatProject,
    /// GRU `W_z` with `b_z` (eq. 7a), `H_gat → H_gru`.
    GruWz,
    /// GRU `U_z` (eq. 7a), `H_gru → H_gru`, no bias.
    GruUz,
    /// GRU `W_r` with `b_r` (eq. 7b).
    GruWr,
    /// GRU `U_r` (eq. 7b).
    GruUr,
    /// GRU `W_n` with `b_n` (eq. 7c).
    GruWn,
    /// GRU `U_n` (eq. 7c).
    GruUn,
    /// Attention-pooling score, `H_gru → 1`.
    PoolScore,
    /// Classifier `W_o, b_o` (eq. 8), `H_gru → C`.
    Classifier,
    /// Sensor head `V, b_v`, `SENSOR_HEAD_INPUTS → C`: its logits add to the
    /// classifier's (`crate::dsstgat::sensor_head_input`).
    SensorHead,
    /// Physical-indicator head `W_f, b_f` (eq. 13), `H_gru → K`.
    Indicator,
}

/// A message naming the layer, built at compile time.
macro_rules! layer_msg {
    ($id:expr, $what:literal) => {
        match $id {
            LayerId::Embed => concat!("embed: ", $what),
            LayerId::GatProject => concat!("gat.project: ", $what),
            LayerId::GruWz => concat!("gru.w_z: ", $what),
            LayerId::GruUz => concat!("gru.u_z: ", $what),
            LayerId::GruWr => concat!("gru.w_r: ", $what),
            LayerId::GruUr => concat!("gru.u_r: ", $what),
            LayerId::GruWn => concat!("gru.w_n: ", $what),
            LayerId::GruUn => concat!("gru.u_n: ", $what),
            LayerId::PoolScore => concat!("pool: ", $what),
            LayerId::Classifier => concat!("classifier: ", $what),
            LayerId::SensorHead => concat!("sensor_head: ", $what),
            LayerId::Indicator => concat!("indicator.head: ", $what),
        }
    };
}

impl LayerId {
    /// Every layer, in payload order.
    pub const ALL: [LayerId; 12] = [
        LayerId::Embed,
        LayerId::GatProject,
        LayerId::GruWz,
        LayerId::GruUz,
        LayerId::GruWr,
        LayerId::GruUr,
        LayerId::GruWn,
        LayerId::GruUn,
        LayerId::PoolScore,
        LayerId::Classifier,
        LayerId::SensorHead,
        LayerId::Indicator,
    ];

    /// The layer's field path in the payload, e.g. `"gru.w_z"`.
    pub const fn name(self) -> &'static str {
        match self {
            LayerId::Embed => "embed",
            LayerId::GatProject => "gat.project",
            LayerId::GruWz => "gru.w_z",
            LayerId::GruUz => "gru.u_z",
            LayerId::GruWr => "gru.w_r",
            LayerId::GruUr => "gru.u_r",
            LayerId::GruWn => "gru.w_n",
            LayerId::GruUn => "gru.u_n",
            LayerId::PoolScore => "pool",
            LayerId::Classifier => "classifier",
            LayerId::SensorHead => "sensor_head",
            LayerId::Indicator => "indicator.head",
        }
    }
}

/// The stored parts of one int8 fully connected layer ([`QLinear::from_parts`]),
/// with room for `W` weights and `CH` output channels.
///
/// # Shapes
/// - `weights`: `OUT·IN` codes, row-major `[OUT][IN]`
/// - `weight_scales`, `bias`: `[OUT]`
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct QLinearParts<const W: usize, const CH: usize> {
    /// Input scale `s_x`.
    pub input_scale: f32,
    /// Output scale `s_y`.
    pub output_scale: f32,
    /// Per-output-channel weight scales `s_w[o]`.
    pub weight_scales: Vec<f32, CH>,
    /// I32 biases at the accumulator scales `s_x·s_w[o]`.
    pub bias: Vec<i32, CH>,
    /// Int8 weights, row-major `[OUT][IN]`.
    pub weights: Vec<i8, W>,
}

impl<const W: usize, const CH: usize> QLinearParts<W, CH> {
    /// The parts of a quantized layer.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] if the layer does not fit `W` weights or `CH` channels.
    pub fn from_qlinear<const IN: usize, const OUT: usize>(q: &QLinear<IN, OUT>) -> Result<Self> {
        const TOO_BIG: Error = Error::ModelDimensions("layer larger than its model-file buffer");
        let mut parts = Self {
            input_scale: q.input_scale().get(),
            output_scale: q.output_scale().get(),
            ..Self::default()
        };
        for s in q.weight_scales() {
            parts.weight_scales.push(s.get()).map_err(|_| TOO_BIG)?;
        }
        parts
            .bias
            .extend_from_slice(q.bias())
            .map_err(|_| TOO_BIG)?;
        for row in q.weights() {
            parts.weights.extend_from_slice(row).map_err(|_| TOO_BIG)?;
        }
        Ok(parts)
    }

    /// Borrow as slices.
    pub fn view(&self) -> LayerView<'_> {
        LayerView {
            input_scale: self.input_scale,
            output_scale: self.output_scale,
            weight_scales: &self.weight_scales,
            bias: &self.bias,
            weights: &self.weights,
        }
    }
}

/// One layer's parts as slices, whatever its buffer capacities.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerView<'a> {
    /// Input scale `s_x`.
    pub input_scale: f32,
    /// Output scale `s_y`.
    pub output_scale: f32,
    /// Per-output-channel weight scales, `[OUT]`.
    pub weight_scales: &'a [f32],
    /// I32 biases, `[OUT]`.
    pub bias: &'a [i32],
    /// Int8 weights, row-major `[OUT][IN]`.
    pub weights: &'a [i8],
}

/// Feature normalization ([`FeatureNorm`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NormParts {
    /// Mean of each feature.
    pub mean: [f32; FEATURE_DIM],
    /// Standard deviation of each feature (> 0).
    pub std: [f32; FEATURE_DIM],
}

impl Default for NormParts {
    fn default() -> Self {
        Self::from(&FeatureNorm::IDENTITY)
    }
}

impl From<&FeatureNorm> for NormParts {
    fn from(n: &FeatureNorm) -> Self {
        Self {
            mean: n.mean,
            std: n.std,
        }
    }
}

/// Graph construction parameters ([`GraphConfig`]).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct GraphParts {
    /// Blend weight `β` ∈ [0, 1] of the prior.
    pub prior_weight: f32,
    /// Correlation threshold `τ_corr` ∈ [−1, 1].
    pub tau_corr: f32,
    /// Sliding window `w` in steps, `1..=T`.
    pub window_steps: u16,
    /// Prior `P`, `N·N` entries row-major (symmetric, in [0, 1]).
    pub prior: Vec<f32, MAX_PRIOR>,
}

impl GraphParts {
    /// The parts of a graph configuration.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] for `N >` [`MAX_NODES`] or a window over `u16::MAX`.
    pub fn from_config<const N: usize>(cfg: &GraphConfig<N>) -> Result<Self> {
        let window_steps = u16::try_from(cfg.window_steps)
            .map_err(|_| Error::ModelDimensions("graph window longer than u16::MAX steps"))?;
        let mut prior = Vec::new();
        for row in &cfg.prior {
            prior
                .extend_from_slice(row)
                .map_err(|_| Error::ModelDimensions("graph prior larger than MAX_NODES²"))?;
        }
        Ok(Self {
            prior_weight: cfg.prior_weight,
            tau_corr: cfg.tau_corr,
            window_steps,
            prior,
        })
    }
}

/// The GAT layer's parts ([`GatLayer::from_parts`]); the projection maps
/// `s_x → s_z` and has zero bias, the layer's bias comes after aggregation.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct GatParts {
    /// Projection `W`, `[H_gat][F]`, `s_x → s_z`, zero bias.
    pub project: GatProjectParts,
    /// `a_src` codes, `[H_gat]`.
    pub a_src: Vec<i8, MAX_HIDDEN>,
    /// `a_src` scale.
    pub a_src_scale: f32,
    /// `a_dst` codes, `[H_gat]`.
    pub a_dst: Vec<i8, MAX_HIDDEN>,
    /// `a_dst` scale.
    pub a_dst_scale: f32,
    /// Bias after aggregation, `[H_gat]`, at `s_z·2^−15`.
    pub bias: Vec<i32, MAX_HIDDEN>,
    /// Attention-logit scale `s_e`.
    pub logit_scale: f32,
    /// Output scale `s_h`.
    pub output_scale: f32,
}

impl GatParts {
    /// The parts of a quantized GAT layer.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] if the layer does not fit the buffers.
    pub fn from_layer<const F: usize, const H: usize>(g: &GatLayer<F, H>) -> Result<Self> {
        const TOO_BIG: Error = Error::ModelDimensions("GAT layer larger than MAX_HIDDEN");
        let (a_src, a_src_scale) = g.a_src();
        let (a_dst, a_dst_scale) = g.a_dst();
        let scales = g.scales();
        Ok(Self {
            project: QLinearParts::from_qlinear(g.project())?,
            a_src: Vec::from_slice(a_src).map_err(|_| TOO_BIG)?,
            a_src_scale: a_src_scale.get(),
            a_dst: Vec::from_slice(a_dst).map_err(|_| TOO_BIG)?,
            a_dst_scale: a_dst_scale.get(),
            bias: Vec::from_slice(g.bias()).map_err(|_| TOO_BIG)?,
            logit_scale: scales.logit.get(),
            output_scale: scales.output.get(),
        })
    }
}

/// The GRU cell's gate matrices ([`GruCell::from_parts`]), gate order z, r, n.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct GruParts {
    /// `W_z`, `b_z`.
    pub w_z: GruMatrixParts,
    /// `U_z` (no bias).
    pub u_z: GruMatrixParts,
    /// `W_r`, `b_r`.
    pub w_r: GruMatrixParts,
    /// `U_r` (no bias).
    pub u_r: GruMatrixParts,
    /// `W_n`, `b_n`.
    pub w_n: GruMatrixParts,
    /// `U_n` (no bias).
    pub u_n: GruMatrixParts,
}

impl GruParts {
    /// The parts of a quantized GRU cell.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] if a matrix does not fit [`MAX_GRU_WEIGHTS`].
    pub fn from_cell<const IN: usize, const H: usize>(c: &GruCell<IN, H>) -> Result<Self> {
        let [(w_z, u_z), (w_r, u_r), (w_n, u_n)] = c.gates();
        Ok(Self {
            w_z: QLinearParts::from_qlinear(w_z)?,
            u_z: QLinearParts::from_qlinear(u_z)?,
            w_r: QLinearParts::from_qlinear(w_r)?,
            u_r: QLinearParts::from_qlinear(u_r)?,
            w_n: QLinearParts::from_qlinear(w_n)?,
            u_n: QLinearParts::from_qlinear(u_n)?,
        })
    }
}

/// The physical-indicator head (eq. 13) with what it takes to read its outputs:
/// indicator `k` in physical units is `mean[k] + std[k]·ẑ_k`, `ẑ` the head's output
/// (the trainer fits the head on z-scored targets).
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct IndicatorParts {
    /// Indicator names, `[K]`.
    pub names: Vec<Name, MAX_INDICATORS>,
    /// Target means, `[K]`.
    pub mean: Vec<f32, MAX_INDICATORS>,
    /// Target standard deviations (> 0), `[K]`.
    pub std: Vec<f32, MAX_INDICATORS>,
    /// The head `W_f W_c`, `b_f + W_f b_c`: `[K][H_gru]`.
    pub head: IndicatorHeadParts,
}

/// Default physical parameters of the 2-DOF model ([`BearingParams`], SI units).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PhysicsParts {
    /// Equivalent mass `m`, kg.
    pub mass: f64,
    /// Radial damping `c_r`, N·s/m.
    pub damping_radial: f64,
    /// Angular damping `c_θ`.
    pub damping_angular: f64,
    /// Radial linear stiffness `k_r`, N/m.
    pub stiffness_radial: f64,
    /// Angular linear stiffness `k_θ`.
    pub stiffness_angular: f64,
    /// Radial cubic stiffness `k_r,NL`, N/m³.
    pub stiffness_nl_radial: f64,
    /// Angular cubic stiffness `k_θ,NL`.
    pub stiffness_nl_angular: f64,
}

impl From<&BearingParams> for PhysicsParts {
    fn from(p: &BearingParams) -> Self {
        Self {
            mass: p.mass,
            damping_radial: p.damping_radial,
            damping_angular: p.damping_angular,
            stiffness_radial: p.stiffness_radial,
            stiffness_angular: p.stiffness_angular,
            stiffness_nl_radial: p.stiffness_nl_radial,
            stiffness_nl_angular: p.stiffness_nl_angular,
        }
    }
}

impl PhysicsParts {
    fn to_params(self) -> BearingParams {
        BearingParams {
            mass: self.mass,
            damping_radial: self.damping_radial,
            damping_angular: self.damping_angular,
            stiffness_radial: self.stiffness_radial,
            stiffness_angular: self.stiffness_angular,
            stiffness_nl_radial: self.stiffness_nl_radial,
            stiffness_nl_angular: self.stiffness_nl_angular,
        }
    }
}

/// Bearing geometry ([`BearingGeometry`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct GeometryParts {
    /// Rolling elements `n`.
    pub n_elements: u8,
    /// Rolling-element diameter `d`.
    pub element_diameter: f32,
    /// Pitch diameter `D`.
    pub pitch_diameter: f32,
    /// Contact angle `φ`, degrees.
    pub contact_angle_deg: f32,
}

impl From<&BearingGeometry> for GeometryParts {
    fn from(g: &BearingGeometry) -> Self {
        Self {
            n_elements: g.n_elements,
            element_diameter: g.element_diameter,
            pitch_diameter: g.pitch_diameter,
            contact_angle_deg: g.contact_angle_deg,
        }
    }
}

impl GeometryParts {
    fn to_geometry(self) -> BearingGeometry {
        BearingGeometry {
            n_elements: self.n_elements,
            element_diameter: self.element_diameter,
            pitch_diameter: self.pitch_diameter,
            contact_angle_deg: self.contact_angle_deg,
        }
    }
}

/// A decoded model file: plain data in fixed-capacity buffers (the payload, in
/// payload order). [`decode`] returns only values that pass [`ModelFile::validate`];
/// [`encode`] writes only such values.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct ModelFile {
    /// Free-form model name.
    pub model_name: Text,
    /// Creation date (e.g. ISO 8601).
    pub created: Text,
    /// Architecture dimensions.
    pub dims: Dimensions,
    /// Class names, `[C]`, in logit order.
    pub class_names: Vec<Name, MAX_CLASSES>,
    /// Sensor names, `[N]`, in node order.
    pub sensor_names: Vec<Name, MAX_NODES>,
    /// Feature normalization.
    pub feature_norm: NormParts,
    /// Graph construction.
    pub graph: GraphParts,
    /// Node embedding.
    pub embed: EmbedParts,
    /// GAT layer.
    pub gat: GatParts,
    /// GRU cell.
    pub gru: GruParts,
    /// Attention-pooling score layer.
    pub pool: PoolScoreParts,
    /// Classifier head.
    pub classifier: ClassifierParts,
    /// Sensor head.
    pub sensor_head: SensorHeadParts,
    /// Physical-indicator head.
    pub indicator: IndicatorParts,
    /// Default physical parameters.
    pub physics: PhysicsParts,
    /// Bearing geometry.
    pub geometry: GeometryParts,
}

// ---------------------------------------------------------------------------------
// In-place deserialization
// ---------------------------------------------------------------------------------

/// Deserialization straight into caller-owned storage.
///
/// A derived `Deserialize` builds every field as a local and moves it into the
/// struct, level by level: decoding the ~32 KiB [`ModelFile`] that way took ~228 KiB
/// of stack in a release build (measured on x86-64), far beyond an MCU's. Here each
/// struct of the payload writes its fields into `place` and each `heapless::Vec`
/// pushes its elements into the existing buffer, so [`decode_into`] needs only a
/// few KiB of stack whatever the model's size. Small leaf types (scalars, names,
/// [`Dimensions`], …) are built and assigned, as derived code would.
mod in_place {
    use core::fmt;

    use heapless::{String, Vec};
    use serde::de::{self, Deserialize, DeserializeSeed, Deserializer, SeqAccess, Visitor};

    /// Deserialize into an existing value (postcard's sequence form of structs).
    pub(super) trait DecodeInPlace<'de> {
        /// Overwrite `place` with the next value of `d`. On error `place` holds a
        /// partly overwritten, memory-safe but meaningless value.
        fn decode_in_place<D: Deserializer<'de>>(d: D, place: &mut Self) -> Result<(), D::Error>;
    }

    /// A [`DeserializeSeed`] that decodes into the borrowed value.
    pub(super) struct InPlace<'a, T>(pub(super) &'a mut T);

    impl<'de, T: DecodeInPlace<'de>> DeserializeSeed<'de> for InPlace<'_, T> {
        type Value = ();
        fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
            T::decode_in_place(d, self.0)
        }
    }

    /// Small values: build and assign.
    macro_rules! assign_in_place {
        ($($t:ty),+ $(,)?) => {$(
            impl<'de> in_place::DecodeInPlace<'de> for $t {
                fn decode_in_place<D: serde::Deserializer<'de>>(
                    d: D,
                    place: &mut Self,
                ) -> core::result::Result<(), D::Error> {
                    *place = <$t as serde::Deserialize<'de>>::deserialize(d)?;
                    Ok(())
                }
            }
        )+};
    }
    pub(super) use assign_in_place;

    impl<'de, const N: usize> DecodeInPlace<'de> for String<N> {
        fn decode_in_place<D: Deserializer<'de>>(d: D, place: &mut Self) -> Result<(), D::Error> {
            *place = Self::deserialize(d)?;
            Ok(())
        }
    }

    /// A `heapless::Vec` fills its own buffer: no temporary of its capacity.
    impl<'de, T: Deserialize<'de>, const N: usize> DecodeInPlace<'de> for Vec<T, N> {
        fn decode_in_place<D: Deserializer<'de>>(d: D, place: &mut Self) -> Result<(), D::Error> {
            struct Fill<'a, T, const N: usize>(&'a mut Vec<T, N>);
            impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for Fill<'_, T, N> {
                type Value = ();
                fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                    write!(f, "a sequence of at most {N} elements")
                }
                fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
                    self.0.clear();
                    while let Some(v) = seq.next_element::<T>()? {
                        if self.0.push(v).is_err() {
                            return Err(de::Error::invalid_length(N + 1, &self));
                        }
                    }
                    Ok(())
                }
            }
            d.deserialize_seq(Fill(place))
        }
    }

    /// Decode a struct field by field into place (fields in declaration order, which
    /// is the order `derive(Serialize)` writes), and give it a `Deserialize` impl
    /// built on that. The destructuring pattern fails to compile if a field is
    /// missing from the list.
    macro_rules! struct_in_place {
        ($name:ident $(<$(const $g:ident: usize),+>)? { $($field:ident),+ $(,)? }) => {
            impl<'de $($(, const $g: usize)+)?> in_place::DecodeInPlace<'de>
                for $name $(<$($g),+>)?
            {
                fn decode_in_place<D: serde::Deserializer<'de>>(
                    d: D,
                    place: &mut Self,
                ) -> core::result::Result<(), D::Error> {
                    struct Fields<'a $($(, const $g: usize)+)?>(&'a mut $name $(<$($g),+>)?);
                    impl<'de $($(, const $g: usize)+)?> serde::de::Visitor<'de>
                        for Fields<'_ $($(, $g)+)?>
                    {
                        type Value = ();
                        fn expecting(
                            &self,
                            f: &mut core::fmt::Formatter<'_>,
                        ) -> core::fmt::Result {
                            f.write_str(concat!("struct ", stringify!($name)))
                        }
                        fn visit_seq<A: serde::de::SeqAccess<'de>>(
                            self,
                            mut seq: A,
                        ) -> core::result::Result<(), A::Error> {
                            let $name { $($field),+ } = self.0;
                            let mut index = 0usize;
                            $(
                                if seq
                                    .next_element_seed(in_place::InPlace($field))?
                                    .is_none()
                                {
                                    return Err(serde::de::Error::invalid_length(
                                        index,
                                        &concat!("struct ", stringify!($name)),
                                    ));
                                }
                                index += 1;
                            )+
                            let _ = index;
                            Ok(())
                        }
                    }
                    const FIELDS: &[&str] = &[$(stringify!($field)),+];
                    d.deserialize_struct(stringify!($name), FIELDS, Fields(place))
                }
            }

            impl<'de $($(, const $g: usize)+)?> serde::Deserialize<'de> for $name $(<$($g),+>)? {
                fn deserialize<D: serde::Deserializer<'de>>(
                    d: D,
                ) -> core::result::Result<Self, D::Error> {
                    let mut value = Self::default();
                    in_place::DecodeInPlace::decode_in_place(d, &mut value)?;
                    Ok(value)
                }
                fn deserialize_in_place<D: serde::Deserializer<'de>>(
                    d: D,
                    place: &mut Self,
                ) -> core::result::Result<(), D::Error> {
                    in_place::DecodeInPlace::decode_in_place(d, place)
                }
            }
        };
    }
    pub(super) use struct_in_place;
}

in_place::assign_in_place!(
    f32,
    Dimensions,
    NormParts,
    GraphParts,
    PhysicsParts,
    GeometryParts
);
in_place::struct_in_place!(QLinearParts<const W: usize, const CH: usize> {
    input_scale,
    output_scale,
    weight_scales,
    bias,
    weights,
});
in_place::struct_in_place!(GatParts {
    project,
    a_src,
    a_src_scale,
    a_dst,
    a_dst_scale,
    bias,
    logit_scale,
    output_scale,
});
in_place::struct_in_place!(GruParts {
    w_z,
    u_z,
    w_r,
    u_r,
    w_n,
    u_n,
});
in_place::struct_in_place!(IndicatorParts {
    names,
    mean,
    std,
    head,
});
in_place::struct_in_place!(ModelFile {
    model_name,
    created,
    dims,
    class_names,
    sensor_names,
    feature_norm,
    graph,
    embed,
    gat,
    gru,
    pool,
    classifier,
    sensor_head,
    indicator,
    physics,
    geometry,
});

// ---------------------------------------------------------------------------------
// Framing
// ---------------------------------------------------------------------------------

/// Postcard's varint length of `n`.
const fn varint_len(mut n: usize) -> usize {
    let mut len = 1;
    while n >= 0x80 {
        n >>= 7;
        len += 1;
    }
    len
}

/// Largest encoding of a sequence of at most `cap` elements of at most `elem` bytes.
const fn seq_max(cap: usize, elem: usize) -> usize {
    varint_len(cap) + cap * elem
}

/// Largest encoding of a [`QLinearParts<W, CH>`].
const fn linear_max(w: usize, ch: usize) -> usize {
    4 + 4 + seq_max(ch, 4) + seq_max(ch, 5) + seq_max(w, 1)
}

/// Largest payload: every buffer full, every varint at its longest.
const MAX_PAYLOAD_LEN: usize = 2 * seq_max(TEXT_LEN, 1) // model_name, created
    + 8 * 3 // dims: 8 × u16
    + seq_max(MAX_CLASSES, seq_max(NAME_LEN, 1))
    + seq_max(MAX_NODES, seq_max(NAME_LEN, 1))
    + 2 * FEATURE_DIM * 4 // feature_norm
    + 4 + 4 + 3 + seq_max(MAX_PRIOR, 4) // graph
    + linear_max(MAX_EMBED_WEIGHTS, MAX_HIDDEN)
    + linear_max(MAX_GAT_WEIGHTS, MAX_HIDDEN)
    + 2 * (seq_max(MAX_HIDDEN, 1) + 4)
    + seq_max(MAX_HIDDEN, 5)
    + 4 + 4 // gat
    + 6 * linear_max(MAX_GRU_WEIGHTS, MAX_HIDDEN)
    + linear_max(MAX_HIDDEN, 1)
    + linear_max(MAX_CLASSIFIER_WEIGHTS, MAX_CLASSES)
    + linear_max(MAX_SENSOR_HEAD_WEIGHTS, MAX_CLASSES)
    + seq_max(MAX_INDICATORS, seq_max(NAME_LEN, 1)) + 2 * seq_max(MAX_INDICATORS, 4)
    + linear_max(MAX_INDICATOR_WEIGHTS, MAX_INDICATORS)
    + 7 * 8 // physics
    + 1 + 3 * 4; // geometry

/// Upper bound of an encoded model file's length (a buffer this long always fits).
pub const MAX_ENCODED_LEN: usize = HEADER_LEN + MAX_PAYLOAD_LEN + CRC_LEN;

/// The total length a file declares in its header (`14 + L + 4`), after checking the
/// header's length, magic and version. For a file stored in a larger region (a flash
/// page padded with `0xFF`), decode its first `file_len(region)?` bytes (a region
/// shorter than that is [`Error::ModelTruncated`]).
///
/// # Errors
/// [`Error::ModelTruncated`] for fewer than [`HEADER_LEN`] bytes, [`Error::ModelMagic`],
/// [`Error::ModelVersion`].
pub fn file_len(bytes: &[u8]) -> Result<usize> {
    let truncated = Error::ModelTruncated {
        expected: HEADER_LEN,
        got: bytes.len(),
    };
    if bytes.len() < HEADER_LEN {
        return Err(truncated);
    }
    let (magic, rest) = bytes.split_first_chunk::<8>().ok_or(truncated)?;
    let (version, rest) = rest.split_first_chunk::<2>().ok_or(truncated)?;
    let (len, _) = rest.split_first_chunk::<4>().ok_or(truncated)?;
    if *magic != MAGIC {
        return Err(Error::ModelMagic);
    }
    let found = u16::from_le_bytes(*version);
    if found != FORMAT_VERSION {
        return Err(Error::ModelVersion {
            found,
            supported: FORMAT_VERSION,
        });
    }
    usize::try_from(u32::from_le_bytes(*len))
        .ok()
        .and_then(|l| l.checked_add(HEADER_LEN + CRC_LEN))
        .ok_or(Error::ModelTruncated {
            expected: usize::MAX,
            got: bytes.len(),
        })
}

/// Check the framing (steps 1–5 of the module docs) and return the payload.
fn checked_payload(bytes: &[u8]) -> Result<&[u8]> {
    let total = file_len(bytes)?;
    if bytes.len() < total {
        return Err(Error::ModelTruncated {
            expected: total,
            got: bytes.len(),
        });
    }
    if bytes.len() > total {
        return Err(Error::ModelTrailingBytes {
            extra: bytes.len() - total,
        });
    }
    let body = bytes.get(HEADER_LEN..).unwrap_or_default();
    let (payload, crc) = body
        .split_last_chunk::<CRC_LEN>()
        .ok_or(Error::ModelTruncated {
            expected: total,
            got: bytes.len(),
        })?;
    let stored = u32::from_le_bytes(*crc);
    let computed = crc32(payload);
    if stored != computed {
        return Err(Error::ModelChecksum { stored, computed });
    }
    Ok(payload)
}

/// Why postcard refused a payload, in words.
fn decode_reason(e: postcard::Error) -> &'static str {
    match e {
        postcard::Error::DeserializeUnexpectedEnd => "payload ends inside a field",
        postcard::Error::DeserializeBadVarint => "malformed varint",
        postcard::Error::DeserializeBadBool => "malformed bool",
        postcard::Error::DeserializeBadChar => "malformed char",
        postcard::Error::DeserializeBadUtf8 => "a name is not UTF-8",
        postcard::Error::DeserializeBadOption => "malformed option tag",
        postcard::Error::DeserializeBadEnum => "malformed enum tag",
        postcard::Error::DeserializeBadEncoding => "malformed encoding",
        postcard::Error::SerdeDeCustom => {
            "a length exceeds its buffer's capacity or a value is out of its type's range"
        }
        _ => "postcard error",
    }
}

/// Decode and validate a model file into caller-owned storage (e.g. a `static`), the
/// MCU path: allocates nothing, needs only a few KiB of stack, never panics.
///
/// On error `out` holds partly overwritten, meaningless (but memory-safe) data.
///
/// # Errors
/// In the order checked: [`Error::ModelTruncated`], [`Error::ModelMagic`],
/// [`Error::ModelVersion`], [`Error::ModelTruncated`] / [`Error::ModelTrailingBytes`],
/// [`Error::ModelChecksum`], [`Error::ModelDecode`], [`Error::ModelDimensions`],
/// [`Error::ModelValue`] (see the module docs).
pub fn decode_into(bytes: &[u8], out: &mut ModelFile) -> Result<()> {
    let payload = checked_payload(bytes)?;
    let mut de = postcard::Deserializer::from_bytes(payload);
    in_place::DecodeInPlace::decode_in_place(&mut de, out)
        .map_err(|e| Error::ModelDecode(decode_reason(e)))?;
    let rest = de
        .finalize()
        .map_err(|e| Error::ModelDecode(decode_reason(e)))?;
    if !rest.is_empty() {
        return Err(Error::ModelDecode("bytes left over after the model"));
    }
    out.validate()
}

/// Decode and validate a model file, returning it by value ([`decode_into`] on a
/// fresh [`ModelFile::default`]; the value itself is `size_of::<ModelFile>()` of
/// stack). Allocates nothing; never panics.
///
/// # Errors
/// Those of [`decode_into`].
pub fn decode(bytes: &[u8]) -> Result<ModelFile> {
    let mut model = ModelFile::default();
    decode_into(bytes, &mut model)?;
    Ok(model)
}

/// Validate `model` and write it as a model file into `out`; returns the number of
/// bytes written. Allocates nothing.
///
/// # Errors
/// The [`ModelFile::validate`] errors (a file [`decode`] would reject is never
/// written); [`Error::BufferSize`] if `out` is shorter than the file (`expected` is
/// the file's length, [`ModelFile::encoded_len`]; [`MAX_ENCODED_LEN`] always fits).
pub fn encode(model: &ModelFile, out: &mut [u8]) -> Result<usize> {
    model.validate()?;
    write_frame(model, out)
}

/// Postcard payload length of `model`.
fn payload_len(model: &ModelFile) -> Result<usize> {
    postcard::experimental::serialized_size(model)
        .map_err(|_| Error::InvalidParameter("postcard cannot size the model"))
}

/// Frame and write `model` without validating it.
fn write_frame(model: &ModelFile, out: &mut [u8]) -> Result<usize> {
    let len = payload_len(model)?;
    let len32 = u32::try_from(len)
        .map_err(|_| Error::ModelDimensions("payload longer than u32::MAX bytes"))?;
    let total = HEADER_LEN + len + CRC_LEN;
    let got = out.len();
    let frame = out.get_mut(..total).ok_or(Error::BufferSize {
        expected: total,
        got,
    })?;
    let (header, body) = frame.split_at_mut(HEADER_LEN);
    let (payload, crc) = body.split_at_mut(len);
    let mut h = [0u8; HEADER_LEN];
    h[..8].copy_from_slice(&MAGIC);
    h[8..10].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
    h[10..14].copy_from_slice(&len32.to_le_bytes());
    header.copy_from_slice(&h);
    let used = postcard::to_slice(model, payload)
        .map_err(|_| Error::InvalidParameter("postcard cannot serialize the model"))?
        .len();
    if used != len {
        return Err(Error::InvalidParameter(
            "postcard wrote a different length than it sized",
        ));
    }
    crc.copy_from_slice(&crc32(payload).to_le_bytes());
    Ok(total)
}

// ---------------------------------------------------------------------------------
// Validation
// ---------------------------------------------------------------------------------

/// `Err(ModelDimensions(what))` unless `lo ≤ v ≤ hi`.
fn check_range(v: u16, lo: usize, hi: usize, what: &'static str) -> Result<()> {
    if (lo..=hi).contains(&usize::from(v)) {
        Ok(())
    } else {
        Err(Error::ModelDimensions(what))
    }
}

/// `Err(ModelDimensions(what))` unless `got == want`.
fn check_len(got: usize, want: usize, what: &'static str) -> Result<()> {
    if got == want {
        Ok(())
    } else {
        Err(Error::ModelDimensions(what))
    }
}

/// A stored scale as a [`QScale`], or `ModelValue(what)`.
fn scale(s: f32, what: &'static str) -> Result<QScale> {
    QScale::new(s).ok_or(Error::ModelValue(what))
}

/// Re-label a validation error of a core type as a model-file value error.
fn as_model_value(e: Error, non_finite: &'static str) -> Error {
    match e {
        Error::InvalidParameter(what) => Error::ModelValue(what),
        _ => Error::ModelValue(non_finite),
    }
}

/// Int8 codes of the scheme are in `[−127, 127]`.
fn check_codes(codes: &[i8], what: &'static str) -> Result<()> {
    if codes.contains(&i8::MIN) {
        Err(Error::ModelValue(what))
    } else {
        Ok(())
    }
}

/// Biases stay within [`MAX_BIAS`].
fn check_bias(bias: &[i32], what: &'static str) -> Result<()> {
    if bias.iter().any(|b| b.unsigned_abs() > MAX_BIAS as u32) {
        Err(Error::ModelValue(what))
    } else {
        Ok(())
    }
}

fn check_layer_shape(dims: &Dimensions, id: LayerId, l: LayerView<'_>) -> Result<()> {
    let (inputs, outputs) = dims.layer_shape(id);
    check_len(
        l.weight_scales.len(),
        outputs,
        layer_msg!(id, "weight scale count != outputs"),
    )?;
    check_len(
        l.bias.len(),
        outputs,
        layer_msg!(id, "bias count != outputs"),
    )?;
    check_len(
        l.weights.len(),
        inputs * outputs,
        layer_msg!(id, "weight count != outputs × inputs"),
    )
}

fn check_layer_values(id: LayerId, l: LayerView<'_>) -> Result<()> {
    let bad_scale = layer_msg!(id, "a scale is not finite and > 0");
    let s_x = scale(l.input_scale, bad_scale)?;
    let s_y = scale(l.output_scale, bad_scale)?;
    for &sw in l.weight_scales {
        let sw = scale(sw, bad_scale)?;
        if QMultiplier::from_scales(s_x, sw, s_y).is_none() {
            return Err(Error::ModelValue(layer_msg!(
                id,
                "requantization ratio s_x·s_w/s_y outside [2^-32, 2^31)"
            )));
        }
    }
    check_bias(l.bias, layer_msg!(id, "a bias exceeds 2^30 - 1"))?;
    check_codes(
        l.weights,
        layer_msg!(id, "a weight code is -128 (codes are in [-127, 127])"),
    )
}

impl ModelFile {
    /// Check dimensions (against each other, the buffers and the maxima) and values;
    /// what [`decode`] checks after postcard, and [`encode`] before writing.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] or [`Error::ModelValue`], naming the first failure.
    pub fn validate(&self) -> Result<()> {
        self.check_dimensions()?;
        self.check_values()
    }

    fn check_dimensions(&self) -> Result<()> {
        let d = &self.dims;
        check_range(
            d.nodes,
            1,
            MAX_NODES,
            "nodes N must be in 1..=MAX_NODES (8)",
        )?;
        check_range(
            d.features,
            FEATURE_DIM,
            FEATURE_DIM,
            "features F must equal FEATURE_DIM (32)",
        )?;
        check_range(
            d.steps,
            1,
            MAX_STEPS,
            "steps T must be in 1..=MAX_STEPS (8192)",
        )?;
        check_range(
            d.gat_hidden,
            1,
            MAX_HIDDEN,
            "GAT hidden size must be in 1..=MAX_HIDDEN (32)",
        )?;
        check_range(
            d.gru_hidden,
            1,
            MAX_HIDDEN,
            "GRU hidden size must be in 1..=MAX_HIDDEN (32)",
        )?;
        check_range(d.heads, 1, 1, "heads must be 1 (the int8 GAT has one head)")?;
        check_range(
            d.classes,
            1,
            MAX_CLASSES,
            "classes C must be in 1..=MAX_CLASSES (16)",
        )?;
        check_range(
            d.indicators,
            1,
            MAX_INDICATORS,
            "indicators K must be in 1..=MAX_INDICATORS (8)",
        )?;
        let k = usize::from(d.indicators);
        let ind = &self.indicator;
        check_len(ind.names.len(), k, "indicator name count != indicators K")?;
        check_len(ind.mean.len(), k, "indicator mean count != indicators K")?;
        check_len(ind.std.len(), k, "indicator std count != indicators K")?;
        let n = usize::from(d.nodes);
        check_len(
            self.class_names.len(),
            usize::from(d.classes),
            "class name count != classes C",
        )?;
        check_len(self.sensor_names.len(), n, "sensor name count != nodes N")?;
        check_len(self.graph.prior.len(), n * n, "graph prior entries != N·N")?;
        check_range(
            self.graph.window_steps,
            1,
            usize::from(d.steps),
            "graph window must be in 1..=T steps",
        )?;
        for id in LayerId::ALL {
            check_layer_shape(d, id, self.layer(id))?;
        }
        let hg = usize::from(d.gat_hidden);
        check_len(
            self.gat.a_src.len(),
            hg,
            "gat.a_src length != GAT hidden size",
        )?;
        check_len(
            self.gat.a_dst.len(),
            hg,
            "gat.a_dst length != GAT hidden size",
        )?;
        check_len(
            self.gat.bias.len(),
            hg,
            "gat.bias length != GAT hidden size",
        )
    }

    fn check_values(&self) -> Result<()> {
        self.feature_norm()?;
        self.check_graph_values()?;
        for id in LayerId::ALL {
            check_layer_values(id, self.layer(id))?;
        }
        let g = &self.gat;
        let bad = "gat: an attention or activation scale is not finite and > 0";
        for s in [g.a_src_scale, g.a_dst_scale, g.logit_scale, g.output_scale] {
            scale(s, bad)?;
        }
        check_codes(&g.a_src, "gat.a_src: a code is -128")?;
        check_codes(&g.a_dst, "gat.a_dst: a code is -128")?;
        check_bias(&g.bias, "gat.bias: a bias exceeds 2^30 - 1")?;
        // The sensor head's i32 logits are added to the classifier's as they are.
        if self.sensor_head.output_scale != self.classifier.output_scale {
            return Err(Error::ModelValue(
                "sensor_head: output scale != the classifier's (their logits are added)",
            ));
        }
        let ind = &self.indicator;
        if ind.mean.iter().any(|m| !m.is_finite())
            || ind.std.iter().any(|s| !(s.is_finite() && *s > 0.0))
        {
            return Err(Error::ModelValue(
                "indicator: a mean is not finite or a std is not finite and > 0",
            ));
        }
        self.bearing_params()?;
        self.bearing_geometry()?;
        Ok(())
    }

    /// The checks of [`GraphConfig::validate`] on the stored prior (any `N`).
    fn check_graph_values(&self) -> Result<()> {
        let g = &self.graph;
        if !((0.0..=1.0).contains(&g.prior_weight) && (-1.0..=1.0).contains(&g.tau_corr)) {
            return Err(Error::ModelValue(
                "graph: prior weight must be in [0, 1], tau_corr in [-1, 1]",
            ));
        }
        let n = usize::from(self.dims.nodes);
        let bad = Error::ModelValue("graph: prior must be symmetric with entries in [0, 1]");
        for (i, row) in g.prior.chunks(n.max(1)).enumerate() {
            for (j, &p) in row.iter().enumerate() {
                let mirror = g.prior.get(j * n + i).copied().unwrap_or(f32::NAN);
                let symmetric = (p - mirror).abs() <= 1e-6;
                if !((0.0..=1.0).contains(&p) && symmetric) {
                    return Err(bad);
                }
            }
        }
        Ok(())
    }

    // -----------------------------------------------------------------------------
    // Accessors
    // -----------------------------------------------------------------------------

    /// The postcard-encoded file length of this model ([`encode`] writes this many bytes).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if postcard cannot size it (not expected).
    pub fn encoded_len(&self) -> Result<usize> {
        Ok(HEADER_LEN + payload_len(self)? + CRC_LEN)
    }

    /// Class names, `[C]`, in logit order.
    pub fn class_names(&self) -> &[Name] {
        &self.class_names
    }

    /// Name of class `i`.
    pub fn class_name(&self, i: usize) -> Option<&str> {
        self.class_names.get(i).map(|s| s.as_str())
    }

    /// Sensor names, `[N]`, in node order.
    pub fn sensor_names(&self) -> &[Name] {
        &self.sensor_names
    }

    /// Name of sensor node `i`.
    pub fn sensor_name(&self, i: usize) -> Option<&str> {
        self.sensor_names.get(i).map(|s| s.as_str())
    }

    /// The graph prior `P`, `N·N` entries row-major.
    pub fn prior(&self) -> &[f32] {
        &self.graph.prior
    }

    /// One layer's parts as slices.
    pub fn layer(&self, id: LayerId) -> LayerView<'_> {
        match id {
            LayerId::Embed => self.embed.view(),
            LayerId::GatProject => self.gat.project.view(),
            LayerId::GruWz => self.gru.w_z.view(),
            LayerId::GruUz => self.gru.u_z.view(),
            LayerId::GruWr => self.gru.w_r.view(),
            LayerId::GruUr => self.gru.u_r.view(),
            LayerId::GruWn => self.gru.w_n.view(),
            LayerId::GruUn => self.gru.u_n.view(),
            LayerId::PoolScore => self.pool.view(),
            LayerId::Classifier => self.classifier.view(),
            LayerId::SensorHead => self.sensor_head.view(),
            LayerId::Indicator => self.indicator.head.view(),
        }
    }

    /// The feature normalization.
    ///
    /// # Errors
    /// [`Error::ModelValue`] for a non-finite mean or std, or a std ≤ 0.
    pub fn feature_norm(&self) -> Result<FeatureNorm> {
        FeatureNorm::new(self.feature_norm.mean, self.feature_norm.std).map_err(|e| {
            as_model_value(e, "feature normalization: a mean or std is NaN or infinite")
        })
    }

    /// The graph configuration for `N` nodes.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] unless `N` is the file's node count (and the prior has
    /// `N·N` entries); [`Error::ModelValue`] if [`GraphConfig::validate`] refuses it.
    pub fn graph_config<const N: usize>(&self) -> Result<GraphConfig<N>> {
        const { assert!(N > 0, "a graph needs at least one node") };
        check_len(
            usize::from(self.dims.nodes),
            N,
            "graph: N asked for != the file's node count",
        )?;
        check_len(self.graph.prior.len(), N * N, "graph prior entries != N·N")?;
        let mut prior = [[0.0f32; N]; N];
        for (row, src) in prior.iter_mut().zip(self.graph.prior.chunks_exact(N)) {
            row.copy_from_slice(src);
        }
        let cfg = GraphConfig {
            prior,
            prior_weight: self.graph.prior_weight,
            window_steps: usize::from(self.graph.window_steps),
            tau_corr: self.graph.tau_corr,
        };
        cfg.validate()
            .map_err(|e| as_model_value(e, "graph: a parameter is NaN or infinite"))?;
        Ok(cfg)
    }

    /// The default physical parameters.
    ///
    /// # Errors
    /// [`Error::ModelValue`] if [`BearingParams::validate`] refuses them.
    pub fn bearing_params(&self) -> Result<BearingParams> {
        let p = self.physics.to_params();
        p.validate()
            .map_err(|e| as_model_value(e, "physics: a parameter is NaN or infinite"))?;
        Ok(p)
    }

    /// The bearing geometry.
    ///
    /// # Errors
    /// [`Error::ModelValue`] if [`BearingGeometry::validate`] refuses it.
    pub fn bearing_geometry(&self) -> Result<BearingGeometry> {
        let g = self.geometry.to_geometry();
        g.validate()
            .map_err(|e| as_model_value(e, "geometry: a dimension is NaN or infinite"))?;
        Ok(g)
    }

    // -----------------------------------------------------------------------------
    // Typed kernels
    // -----------------------------------------------------------------------------

    /// Layer `id` as an int8 kernel of the given sizes.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] unless `(IN, OUT)` is the layer's shape and its
    /// buffers have that shape; [`Error::ModelValue`] for a bad scale; the errors of
    /// [`QLinear::from_parts`].
    pub fn linear<const IN: usize, const OUT: usize>(
        &self,
        id: LayerId,
    ) -> Result<QLinear<IN, OUT>> {
        if self.dims.layer_shape(id) != (IN, OUT) {
            return Err(Error::ModelDimensions(layer_msg!(
                id,
                "sizes asked for != the file's (inputs, outputs)"
            )));
        }
        self.linear_padded(id).map(|(l, _)| l)
    }

    /// Layer `id` with `IN` inputs and at most `OUT` outputs, padded to `OUT`
    /// outputs with zero rows (zero weights and bias, the first row's weight scale),
    /// and the file's output count: for heads whose size (classes, indicators) is
    /// only known at run time. A caller reads the first `outputs` values only.
    ///
    /// # Errors
    /// [`Error::ModelDimensions`] unless the file's layer has `IN` inputs and at most
    /// `OUT` outputs; otherwise as [`ModelFile::linear`].
    pub fn linear_padded<const IN: usize, const OUT: usize>(
        &self,
        id: LayerId,
    ) -> Result<(QLinear<IN, OUT>, usize)> {
        let mut q = QLinear::EMPTY;
        let outputs = self.linear_into(id, &mut q)?;
        Ok((q, outputs))
    }

    /// [`ModelFile::linear_padded`] into a layer that already exists (e.g. inside a
    /// `static` network): no temporary of the layer's size. Returns the file's output
    /// count.
    ///
    /// # Errors
    /// As [`ModelFile::linear_padded`]. On error `out` is partly overwritten.
    // Not inlined (nor the GAT and GRU builders): inlined into `DsStgat::load`, their
    // locals added up to 2 212 B of stack on the Cortex-M4F; in their own frames the
    // build peaks at 1 668 B (`firmware-probe/`).
    #[inline(never)]
    pub fn linear_into<const IN: usize, const OUT: usize>(
        &self,
        id: LayerId,
        out: &mut QLinear<IN, OUT>,
    ) -> Result<usize> {
        const { assert!(IN > 0 && OUT > 0, "a layer needs inputs and outputs") };
        let (inputs, outputs) = self.dims.layer_shape(id);
        if inputs != IN || outputs > OUT || outputs == 0 {
            return Err(Error::ModelDimensions(layer_msg!(
                id,
                "sizes asked for do not fit the file's (inputs, outputs)"
            )));
        }
        let l = self.layer(id);
        check_layer_shape(&self.dims, id, l)?;
        let bad_scale = layer_msg!(id, "a scale is not finite and > 0");
        let mut weight_scales = [QScale::UNIT; OUT];
        for (s, &v) in weight_scales.iter_mut().zip(l.weight_scales) {
            *s = scale(v, bad_scale)?;
        }
        out.set_parts(
            l.weights,
            &weight_scales[..outputs],
            l.bias,
            scale(l.input_scale, bad_scale)?,
            scale(l.output_scale, bad_scale)?,
        )?;
        Ok(outputs)
    }

    /// The GAT layer with `F` features and `H` hidden units.
    ///
    /// # Errors
    /// Those of [`ModelFile::linear`]; [`Error::ModelDimensions`] for attention or bias
    /// vectors not of length `H`; [`Error::ModelValue`] for a bad scale; the errors of
    /// [`GatLayer::from_parts`].
    pub fn gat_layer<const F: usize, const H: usize>(&self) -> Result<GatLayer<F, H>> {
        let project = self.linear::<F, H>(LayerId::GatProject)?;
        let g = &self.gat;
        let dims = |what| Error::ModelDimensions(what);
        let a_src: [i8; H] = g
            .a_src
            .as_slice()
            .try_into()
            .map_err(|_| dims("gat.a_src length != GAT hidden size"))?;
        let a_dst: [i8; H] = g
            .a_dst
            .as_slice()
            .try_into()
            .map_err(|_| dims("gat.a_dst length != GAT hidden size"))?;
        let bias: [i32; H] = g
            .bias
            .as_slice()
            .try_into()
            .map_err(|_| dims("gat.bias length != GAT hidden size"))?;
        let bad = "gat: an attention or activation scale is not finite and > 0";
        let scales = GatScales {
            input: project.input_scale(),
            projected: project.output_scale(),
            logit: scale(g.logit_scale, bad)?,
            output: scale(g.output_scale, bad)?,
        };
        GatLayer::from_parts(
            project,
            (a_src, scale(g.a_src_scale, bad)?),
            (a_dst, scale(g.a_dst_scale, bad)?),
            bias,
            scales,
        )
    }

    /// [`ModelFile::gat_layer`] into an existing layer (no temporary of its size).
    ///
    /// # Errors
    /// As [`ModelFile::gat_layer`]. On error `out` is partly overwritten.
    #[inline(never)]
    pub fn gat_layer_into<const F: usize, const H: usize>(
        &self,
        out: &mut GatLayer<F, H>,
    ) -> Result<()> {
        if self.dims.layer_shape(LayerId::GatProject) != (F, H) {
            return Err(Error::ModelDimensions(
                "gat.project: sizes asked for != the file's (inputs, outputs)",
            ));
        }
        let g = &self.gat;
        let bad = "gat: an attention or activation scale is not finite and > 0";
        let dims = |e: Error, what| match e {
            Error::BufferSize { .. } => Error::ModelDimensions(what),
            other => other,
        };
        out.set_in_place(
            |p| self.linear_into(LayerId::GatProject, p).map(|_| ()),
            (&g.a_src, scale(g.a_src_scale, bad)?),
            (&g.a_dst, scale(g.a_dst_scale, bad)?),
            &g.bias,
            scale(g.logit_scale, bad)?,
            scale(g.output_scale, bad)?,
        )
        .map_err(|e| dims(e, "gat: a_src, a_dst or bias length != GAT hidden size"))
    }

    /// [`ModelFile::gru_cell`] into an existing cell (no temporary of its size).
    ///
    /// # Errors
    /// As [`ModelFile::gru_cell`]. On error `out` is partly overwritten.
    #[inline(never)]
    pub fn gru_cell_into<const IN: usize, const H: usize>(
        &self,
        out: &mut GruCell<IN, H>,
    ) -> Result<()> {
        const GATES: [(LayerId, LayerId); 3] = [
            (LayerId::GruWz, LayerId::GruUz),
            (LayerId::GruWr, LayerId::GruUr),
            (LayerId::GruWn, LayerId::GruUn),
        ];
        out.set_in_place(|g, w, u| {
            let (wid, uid) = GATES[g.min(2)];
            for (id, shape) in [(wid, (IN, H)), (uid, (H, H))] {
                if self.dims.layer_shape(id) != shape {
                    return Err(Error::ModelDimensions(layer_msg!(
                        id,
                        "sizes asked for != the file's (inputs, outputs)"
                    )));
                }
            }
            self.linear_into(wid, w)?;
            self.linear_into(uid, u)?;
            Ok(())
        })
    }

    /// The GRU cell with `IN` inputs (the GAT hidden size) and `H` hidden units.
    ///
    /// # Errors
    /// Those of [`ModelFile::linear`] and [`GruCell::from_parts`].
    pub fn gru_cell<const IN: usize, const H: usize>(&self) -> Result<GruCell<IN, H>> {
        GruCell::from_parts(
            (
                self.linear::<IN, H>(LayerId::GruWz)?,
                self.linear::<H, H>(LayerId::GruUz)?,
            ),
            (
                self.linear::<IN, H>(LayerId::GruWr)?,
                self.linear::<H, H>(LayerId::GruUr)?,
            ),
            (
                self.linear::<IN, H>(LayerId::GruWn)?,
                self.linear::<H, H>(LayerId::GruUn)?,
            ),
        )
    }

    /// The attention pooling over `H` hidden units.
    ///
    /// # Errors
    /// Those of [`ModelFile::linear`].
    pub fn attention_pool<const H: usize>(&self) -> Result<AttentionPool<H>> {
        Ok(AttentionPool::from_parts(
            self.linear::<H, 1>(LayerId::PoolScore)?,
        ))
    }

    /// The classifier from `H` hidden units to `C` classes.
    ///
    /// # Errors
    /// Those of [`ModelFile::linear`].
    pub fn classifier<const H: usize, const C: usize>(&self) -> Result<Classifier<H, C>> {
        Ok(Classifier::from_linear(
            self.linear::<H, C>(LayerId::Classifier)?,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quant::{AttentionPoolF32, GatLayerF32, GruCellF32, LinearF32};
    use crate::rng::Xoshiro128pp;
    use std::vec;
    use std::vec::Vec as StdVec;

    const N: usize = 3;
    const F: usize = FEATURE_DIM;
    const T: usize = 4;
    const HG: usize = 8;
    const HR: usize = 8;
    const C: usize = 4;
    const K: usize = 2;

    fn uniform(rng: &mut Xoshiro128pp, amp: f64) -> f32 {
        ((rng.uniform() * 2.0 - 1.0) * amp) as f32
    }

    fn matrix<const R: usize, const K: usize>(rng: &mut Xoshiro128pp, amp: f64) -> [[f32; K]; R] {
        core::array::from_fn(|_| core::array::from_fn(|_| uniform(rng, amp)))
    }

    fn vector<const K: usize>(rng: &mut Xoshiro128pp, amp: f64) -> [f32; K] {
        core::array::from_fn(|_| uniform(rng, amp))
    }

    fn name<const L: usize>(s: &str) -> String<L> {
        String::try_from(s).unwrap()
    }

    /// The quantized kernels of a small random model.
    struct Kernels {
        embed: QLinear<F, HG>,
        gat: GatLayer<HG, HG>,
        gru: GruCell<HG, HR>,
        pool: AttentionPool<HR>,
        classifier: Classifier<HR, C>,
        indicator: QLinear<HR, K>,
        sensor: QLinear<SENSOR_HEAD_INPUTS, C>,
    }

    fn kernels(seed: u64) -> Kernels {
        let mut rng = Xoshiro128pp::seed_from_u64(seed);
        let embed = QLinear::from_f32(
            &LinearF32::<F, HG> {
                w: matrix(&mut rng, 0.4),
                b: vector(&mut rng, 0.1),
            },
            QScale::new(5.0 / 127.0).unwrap(),
            QScale::new(3.0 / 127.0).unwrap(),
        )
        .unwrap();
        let gat_f = GatLayerF32::<HG, HG> {
            w: matrix(&mut rng, 0.4),
            a_src: vector(&mut rng, 1.0),
            a_dst: vector(&mut rng, 1.0),
            bias: vector(&mut rng, 0.1),
        };
        let gat_scales = GatScales {
            input: QScale::new(3.0 / 127.0).unwrap(),
            projected: QScale::new(4.0 / 127.0).unwrap(),
            logit: QScale::new(6.0 / 127.0).unwrap(),
            output: QScale::new(2.0 / 127.0).unwrap(),
        };
        let gat = GatLayer::from_f32(&gat_f, gat_scales).unwrap();
        let lin = |rng: &mut Xoshiro128pp| LinearF32::<HG, HR> {
            w: matrix(rng, 0.3),
            b: vector(rng, 0.1),
        };
        let gru_f = GruCellF32::<HG, HR> {
            w_z: lin(&mut rng),
            w_r: lin(&mut rng),
            w_n: lin(&mut rng),
            u_z: matrix(&mut rng, 0.3),
            u_r: matrix(&mut rng, 0.3),
            u_n: matrix(&mut rng, 0.3),
        };
        let gru = GruCell::from_f32(&gru_f, gat_scales.output).unwrap();
        let pool_f = AttentionPoolF32::<HR> {
            w: vector(&mut rng, 0.5),
            b: 0.1,
        };
        let pool =
            AttentionPool::from_f32(&pool_f, QScale::UNIT, QScale::new(4.0 / 127.0).unwrap())
                .unwrap();
        let cls_f = LinearF32::<HR, C> {
            w: matrix(&mut rng, 0.5),
            b: vector(&mut rng, 0.2),
        };
        let classifier =
            Classifier::from_f32(&cls_f, QScale::UNIT, QScale::new(1e-4).unwrap()).unwrap();
        let indicator = QLinear::from_f32(
            &LinearF32::<HR, K> {
                w: matrix(&mut rng, 0.5),
                b: vector(&mut rng, 0.2),
            },
            QScale::UNIT,
            QScale::new(1e-4).unwrap(),
        )
        .unwrap();
        let sensor = QLinear::from_f32(
            &LinearF32::<SENSOR_HEAD_INPUTS, C> {
                w: matrix(&mut rng, 0.3),
                b: vector(&mut rng, 0.2),
            },
            QScale::new(2.0 / 127.0).unwrap(),
            QScale::new(1e-4).unwrap(),
        )
        .unwrap();
        Kernels {
            embed,
            gat,
            gru,
            pool,
            classifier,
            indicator,
            sensor,
        }
    }

    fn model_from(k: &Kernels) -> ModelFile {
        let mut mean = [0.0f32; FEATURE_DIM];
        let mut std = [1.0f32; FEATURE_DIM];
        for (i, (m, s)) in mean.iter_mut().zip(std.iter_mut()).enumerate() {
            *m = i as f32 * 0.25 - 1.0;
            *s = 0.5 + i as f32 * 0.125;
        }
        let mut prior = [[0.5f32; N]; N];
        prior[0][2] = 0.25;
        prior[2][0] = 0.25;
        ModelFile {
            model_name: name("ds-stgat-cwru-test"),
            created: name("2025-01-31"),
            dims: Dimensions {
                nodes: N as u16,
                features: F as u16,
                steps: T as u16,
                gat_hidden: HG as u16,
                gru_hidden: HR as u16,
                heads: 1,
                classes: C as u16,
                indicators: K as u16,
            },
            class_names: ["normal", "IR", "B", "OR"]
                .iter()
                .map(|s| name(s))
                .collect(),
            sensor_names: ["DE", "FE", "BA"].iter().map(|s| name(s)).collect(),
            feature_norm: NormParts::from(&FeatureNorm::new(mean, std).unwrap()),
            graph: GraphParts::from_config(&GraphConfig::<N> {
                prior,
                prior_weight: 0.3,
                window_steps: 3,
                tau_corr: 0.3,
            })
            .unwrap(),
            embed: QLinearParts::from_qlinear(&k.embed).unwrap(),
            gat: GatParts::from_layer(&k.gat).unwrap(),
            gru: GruParts::from_cell(&k.gru).unwrap(),
            pool: QLinearParts::from_qlinear(k.pool.score()).unwrap(),
            classifier: QLinearParts::from_qlinear(k.classifier.linear()).unwrap(),
            sensor_head: QLinearParts::from_qlinear(&k.sensor).unwrap(),
            indicator: IndicatorParts {
                names: ["impact", "band_ratio"].iter().map(|s| name(s)).collect(),
                mean: Vec::from_slice(&[0.5, -1.0]).unwrap(),
                std: Vec::from_slice(&[2.0, 0.25]).unwrap(),
                head: QLinearParts::from_qlinear(&k.indicator).unwrap(),
            },
            physics: PhysicsParts::from(&BearingParams::default_housing()),
            geometry: GeometryParts::from(&BearingGeometry::CWRU_6205_DE),
        }
    }

    fn test_model() -> ModelFile {
        model_from(&kernels(7))
    }

    fn encode_vec(m: &ModelFile) -> StdVec<u8> {
        let mut buf = vec![0u8; MAX_ENCODED_LEN];
        let n = encode(m, &mut buf).unwrap();
        buf.truncate(n);
        buf
    }

    /// Frame without validation (to build files the encoder refuses).
    fn frame_vec(m: &ModelFile) -> StdVec<u8> {
        let mut buf = vec![0u8; MAX_ENCODED_LEN];
        let n = write_frame(m, &mut buf).unwrap();
        buf.truncate(n);
        buf
    }

    /// Rewrite the header length and CRC of a file whose payload starts at 14 and ends
    /// 4 bytes before the end, so that it passes the framing checks.
    fn reframe(payload: &[u8]) -> StdVec<u8> {
        let mut f = StdVec::with_capacity(payload.len() + HEADER_LEN + CRC_LEN);
        f.extend_from_slice(&MAGIC);
        f.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        f.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        f.extend_from_slice(payload);
        f.extend_from_slice(&crc32(payload).to_le_bytes());
        f
    }

    fn payload_of(file: &[u8]) -> &[u8] {
        &file[HEADER_LEN..file.len() - CRC_LEN]
    }

    #[test]
    fn crc32_check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
        assert_eq!(crc32(b"a"), 0xE8B7_BE43);
        assert_eq!(
            crc32(b"The quick brown fox jumps over the lazy dog"),
            0x414F_A339
        );
    }

    #[test]
    fn round_trip_is_exact() {
        let k = kernels(7);
        let m = model_from(&k);
        m.validate().unwrap();
        let file = encode_vec(&m);
        assert_eq!(file.len(), m.encoded_len().unwrap());
        assert!(file.len() <= MAX_ENCODED_LEN);
        assert_eq!(&file[..8], b"PTWINMDL");
        assert_eq!(file_len(&file).unwrap(), file.len());
        let d = decode(&file).unwrap();
        assert_eq!(d, m);
        // The typed kernels rebuilt from the file equal the ones exported.
        assert_eq!(d.linear::<F, HG>(LayerId::Embed).unwrap(), k.embed);
        assert_eq!(d.gat_layer::<HG, HG>().unwrap(), k.gat);
        // The in-place builders give the same kernels.
        let mut g = GatLayer::<HG, HG>::EMPTY;
        d.gat_layer_into(&mut g).unwrap();
        assert_eq!(g, k.gat);
        let mut c = GruCell::<HG, HR>::EMPTY;
        d.gru_cell_into(&mut c).unwrap();
        assert_eq!(c, k.gru);
        let mut small = GruCell::<HG, 4>::EMPTY;
        assert!(matches!(
            d.gru_cell_into(&mut small),
            Err(Error::ModelDimensions(_))
        ));
        assert_eq!(d.linear::<HR, K>(LayerId::Indicator).unwrap(), k.indicator);
        assert_eq!(d.gru_cell::<HG, HR>().unwrap(), k.gru);
        assert_eq!(d.attention_pool::<HR>().unwrap(), k.pool);
        assert_eq!(d.classifier::<HR, C>().unwrap(), k.classifier);
        assert_eq!(d.class_name(3), Some("OR"));
        assert_eq!(d.class_name(4), None);
        assert_eq!(d.sensor_name(2), Some("BA"));
        assert_eq!(d.prior().len(), N * N);
        assert_eq!(
            d.bearing_params().unwrap(),
            BearingParams::default_housing()
        );
        assert_eq!(d.bearing_geometry().unwrap(), BearingGeometry::CWRU_6205_DE);
        assert_eq!(d.graph_config::<N>().unwrap().prior[0][2], 0.25);
        assert_eq!(d.feature_norm().unwrap().std[19], 0.5 + 19.0 * 0.125);
        std::println!(
            "[model_file] test model (N={N} F={F} T={T} H_gat={HG} H_gru={HR} C={C}): {} bytes encoded; \
             size_of::<ModelFile>() = {} bytes; MAX_ENCODED_LEN = {}",
            file.len(),
            core::mem::size_of::<ModelFile>(),
            MAX_ENCODED_LEN
        );
    }

    #[test]
    fn encoding_is_deterministic_and_reencodes_identically() {
        let m = test_model();
        let a = encode_vec(&m);
        let b = encode_vec(&decode(&a).unwrap());
        assert_eq!(a, b);
    }

    #[test]
    fn decode_into_overwrites_previous_contents() {
        let small = test_model();
        let mut other = model_from(&kernels(8));
        other.model_name = name("another model with a longer name");
        other.class_names.truncate(3);
        other.dims.classes = 3;
        other.classifier.weights.truncate(3 * HR);
        other.classifier.weight_scales.truncate(3);
        other.classifier.bias.truncate(3);
        other.sensor_head.weights.truncate(3 * SENSOR_HEAD_INPUTS);
        other.sensor_head.weight_scales.truncate(3);
        other.sensor_head.bias.truncate(3);
        let mut out = ModelFile::default();
        decode_into(&encode_vec(&other), &mut out).unwrap();
        assert_eq!(out, other);
        decode_into(&encode_vec(&small), &mut out).unwrap();
        assert_eq!(out, small);
        // The serde `Deserialize` impls (built on the in-place decoding) agree.
        let file = encode_vec(&small);
        let via_serde: ModelFile = postcard::from_bytes(payload_of(&file)).unwrap();
        assert_eq!(via_serde, small);
    }

    #[test]
    fn typed_sizes_must_match() {
        let d = test_model();
        assert!(matches!(
            d.gat_layer::<HG, 9>(),
            Err(Error::ModelDimensions(_))
        ));
        assert!(matches!(
            d.gru_cell::<HG, 4>(),
            Err(Error::ModelDimensions(_))
        ));
        assert!(matches!(
            d.classifier::<HR, 5>(),
            Err(Error::ModelDimensions(_))
        ));
        // U is H×H, and HG == HR here.
        assert!(d.linear::<HG, HR>(LayerId::GruUz).is_ok());
        assert!(matches!(
            d.linear::<F, HR>(LayerId::GruWz),
            Err(Error::ModelDimensions(_))
        ));
        assert!(matches!(
            d.graph_config::<4>(),
            Err(Error::ModelDimensions(_))
        ));
    }

    #[test]
    fn encode_reports_short_buffer() {
        let m = test_model();
        let need = m.encoded_len().unwrap();
        let mut buf = vec![0u8; need - 1];
        assert_eq!(
            encode(&m, &mut buf),
            Err(Error::BufferSize {
                expected: need,
                got: need - 1
            })
        );
    }

    #[test]
    fn encode_refuses_invalid_models() {
        let mut m = test_model();
        m.dims.classes = 5;
        let mut buf = vec![0u8; MAX_ENCODED_LEN];
        assert!(matches!(
            encode(&m, &mut buf),
            Err(Error::ModelDimensions(_))
        ));
    }

    #[test]
    fn every_single_byte_corruption_is_rejected() {
        let file = encode_vec(&test_model());
        let mut f = file.clone();
        for i in 0..file.len() {
            for mask in [0xFFu8, 0x01, 0x80] {
                f[i] ^= mask;
                let r = decode(&f);
                assert!(r.is_err(), "byte {i} ^ {mask:#04x} accepted");
                if i >= HEADER_LEN {
                    assert!(
                        matches!(r, Err(Error::ModelChecksum { .. })),
                        "byte {i}: {r:?}"
                    );
                }
                f[i] ^= mask;
            }
        }
        assert_eq!(f, file);
    }

    #[test]
    fn every_truncation_is_rejected() {
        let file = encode_vec(&test_model());
        for len in 0..file.len() {
            assert!(
                matches!(decode(&file[..len]), Err(Error::ModelTruncated { .. })),
                "prefix {len}"
            );
        }
        let mut long = file.clone();
        long.push(0xFF);
        assert_eq!(decode(&long), Err(Error::ModelTrailingBytes { extra: 1 }));
        // A padded region decodes through file_len.
        long.extend_from_slice(&[0xFF; 100]);
        assert_eq!(
            decode(&long[..file_len(&long).unwrap()]).unwrap(),
            test_model()
        );
    }

    #[test]
    fn named_errors() {
        let m = test_model();
        let file = encode_vec(&m);

        let mut f = file.clone();
        f[0] = b'X';
        assert_eq!(decode(&f), Err(Error::ModelMagic));

        let mut f = file.clone();
        for old in [1u16, 2, 3, 4, 5, 6, 7, 8, 10] {
            f[8..10].copy_from_slice(&old.to_le_bytes());
            assert_eq!(
                decode(&f),
                Err(Error::ModelVersion {
                    found: old,
                    supported: FORMAT_VERSION
                })
            );
        }

        let mut f = file.clone();
        let n = f.len();
        f[n - 1] ^= 0x10;
        assert!(matches!(decode(&f), Err(Error::ModelChecksum { .. })));
        let mut f = file.clone();
        f[HEADER_LEN + 3] ^= 0x10;
        let computed = crc32(payload_of(&f));
        let stored = crc32(payload_of(&file));
        assert_eq!(decode(&f), Err(Error::ModelChecksum { stored, computed }));

        let mut f = file.clone();
        f[10..14].copy_from_slice(&(u32::MAX).to_le_bytes());
        assert!(matches!(decode(&f), Err(Error::ModelTruncated { .. })));

        // Inconsistent dimensions (CRC valid: the file is framed without validation).
        let dims = |e: Error| matches!(e, Error::ModelDimensions(_));
        assert!(dims(rejected(&m, |b| b.dims.gat_hidden += 1)));
        assert_eq!(
            rejected(&m, |b| {
                b.gru.u_r.weights.pop();
            }),
            Error::ModelDimensions("gru.u_r: weight count != outputs × inputs")
        );
        assert!(dims(rejected(&m, |b| b.dims.heads = 2)));
        assert!(dims(rejected(&m, |b| b.dims.nodes = 9)));
        assert!(dims(rejected(&m, |b| b.dims.features = 19)));
        assert!(dims(rejected(&m, |b| b.dims.steps = 0)));
        assert!(dims(rejected(&m, |b| b.graph.window_steps = 5)));
        assert!(dims(rejected(&m, |b| {
            b.sensor_names.pop();
        })));
        assert!(dims(rejected(&m, |b| {
            b.gat.a_dst.pop();
        })));

        // Values.
        let value = |e: Error| matches!(e, Error::ModelValue(_));
        assert_eq!(
            rejected(&m, |b| b.gru.w_z.weight_scales[0] = f32::NAN),
            Error::ModelValue("gru.w_z: a scale is not finite and > 0")
        );
        assert!(value(rejected(&m, |b| b.classifier.output_scale = -1.0)));
        assert_eq!(
            rejected(&m, |b| b.sensor_head.output_scale *= 2.0),
            Error::ModelValue(
                "sensor_head: output scale != the classifier's (their logits are added)"
            )
        );
        assert!(value(rejected(&m, |b| b.gat.logit_scale = f32::INFINITY)));
        assert!(value(rejected(&m, |b| b.gat.a_src_scale = 0.0)));
        assert_eq!(
            rejected(&m, |b| b.feature_norm.std[5] = 0.0),
            Error::ModelValue("feature std must be > 0")
        );
        assert!(value(rejected(&m, |b| b.feature_norm.mean[0] = f32::NAN)));
        // P[0][1] != P[1][0]
        assert!(value(rejected(&m, |b| b.graph.prior[1] = 0.9)));
        assert!(value(rejected(&m, |b| b.graph.tau_corr = f32::NAN)));
        assert!(value(rejected(&m, |b| b.gru.w_n.bias[0] = MAX_BIAS + 1)));
        assert!(value(rejected(&m, |b| b.gat.project.weights[0] = i8::MIN)));
        assert_eq!(
            rejected(&m, |b| b.physics.mass = -1.0),
            Error::ModelValue("mass must be > 0")
        );
        assert!(value(
            rejected(&m, |b| b.physics.stiffness_radial = f64::NAN)
        ));
        assert!(value(rejected(&m, |b| b.geometry.n_elements = 2)));
        // Requantization ratio s_x·s_w/s_y below 2^-32.
        assert!(value(rejected(&m, |b| b.pool.input_scale = 1e-30)));
    }

    /// The error `decode` gives for `m` edited by `edit`, framed without validation
    /// (one model copy per call, so the debug-build test stack stays small).
    fn rejected(m: &ModelFile, edit: impl FnOnce(&mut ModelFile)) -> Error {
        let mut bad = m.clone();
        edit(&mut bad);
        decode(&frame_vec(&bad)).expect_err("edited model accepted")
    }

    #[test]
    fn postcard_level_errors() {
        let payload = payload_of(&encode_vec(&test_model())).to_vec();
        // Garbage payload with a valid CRC.
        assert!(matches!(
            decode(&reframe(&[0xFF, 0xFF, 0xFF])),
            Err(Error::ModelDecode(_))
        ));
        assert!(matches!(decode(&reframe(&[])), Err(Error::ModelDecode(_))));
        // A payload cut short, reframed.
        assert_eq!(
            decode(&reframe(&payload[..payload.len() - 1])),
            Err(Error::ModelDecode("payload ends inside a field"))
        );
        // Extra bytes after the model inside the payload.
        let mut longer = payload.clone();
        longer.push(0);
        assert_eq!(
            decode(&reframe(&longer)),
            Err(Error::ModelDecode("bytes left over after the model"))
        );
        // A name longer than its capacity: model_name is the first field.
        let mut p = StdVec::new();
        p.push(40u8);
        p.extend_from_slice(&[b'a'; 40]);
        p.extend_from_slice(&payload[1 + payload[0] as usize..]);
        assert!(matches!(decode(&reframe(&p)), Err(Error::ModelDecode(_))));
        // Invalid UTF-8 in the model name.
        let mut p = payload.clone();
        p[1] = 0xFF;
        assert_eq!(
            decode(&reframe(&p)),
            Err(Error::ModelDecode("a name is not UTF-8"))
        );
    }

    #[test]
    fn largest_model_fits_the_bounds() {
        let mut m = ModelFile {
            model_name: name(&"m".repeat(TEXT_LEN)),
            created: name(&"c".repeat(TEXT_LEN)),
            dims: Dimensions {
                nodes: MAX_NODES as u16,
                features: FEATURE_DIM as u16,
                steps: MAX_STEPS as u16,
                gat_hidden: MAX_HIDDEN as u16,
                gru_hidden: MAX_HIDDEN as u16,
                heads: 1,
                classes: MAX_CLASSES as u16,
                indicators: MAX_INDICATORS as u16,
            },
            ..ModelFile::default()
        };
        for _ in 0..MAX_CLASSES {
            m.class_names.push(name(&"k".repeat(NAME_LEN))).unwrap();
        }
        for _ in 0..MAX_NODES {
            m.sensor_names.push(name(&"s".repeat(NAME_LEN))).unwrap();
        }
        m.graph = GraphParts {
            prior_weight: 0.5,
            tau_corr: 0.5,
            window_steps: MAX_STEPS as u16,
            prior: core::iter::repeat_n(1.0, MAX_PRIOR).collect(),
        };
        fn fill<const W: usize, const CH: usize>(l: &mut QLinearParts<W, CH>, out: usize) {
            l.input_scale = 0.01;
            l.output_scale = 0.01;
            l.weight_scales = core::iter::repeat_n(0.01, out).collect();
            l.bias = core::iter::repeat_n(-MAX_BIAS, out).collect();
            l.weights = core::iter::repeat_n(-127, W).collect();
        }
        fill(&mut m.embed, MAX_HIDDEN);
        fill(&mut m.gat.project, MAX_HIDDEN);
        fill(&mut m.indicator.head, MAX_INDICATORS);
        for _ in 0..MAX_INDICATORS {
            m.indicator.names.push(name(&"i".repeat(NAME_LEN))).unwrap();
            m.indicator.mean.push(-1.5).unwrap();
            m.indicator.std.push(2.5).unwrap();
        }
        for l in [
            &mut m.gru.w_z,
            &mut m.gru.u_z,
            &mut m.gru.w_r,
            &mut m.gru.u_r,
            &mut m.gru.w_n,
            &mut m.gru.u_n,
        ] {
            fill(l, MAX_HIDDEN);
        }
        fill(&mut m.pool, 1);
        fill(&mut m.classifier, MAX_CLASSES);
        fill(&mut m.sensor_head, MAX_CLASSES);
        m.gat.a_src = core::iter::repeat_n(1, MAX_HIDDEN).collect();
        m.gat.a_dst = core::iter::repeat_n(1, MAX_HIDDEN).collect();
        m.gat.bias = core::iter::repeat_n(-MAX_BIAS, MAX_HIDDEN).collect();
        m.gat.a_src_scale = 0.01;
        m.gat.a_dst_scale = 0.01;
        m.gat.logit_scale = 0.01;
        m.gat.output_scale = 0.01;
        m.physics = PhysicsParts::from(&BearingParams::default_housing());
        m.geometry = GeometryParts::from(&BearingGeometry::CWRU_6205_DE);
        let file = encode_vec(&m);
        assert!(
            file.len() <= MAX_ENCODED_LEN,
            "{} > {MAX_ENCODED_LEN}",
            file.len()
        );
        // The bound is exact but for the 9 u16 varints (dims, graph window), counted
        // at 3 bytes each: here 1 byte each, but 2 for T = w = 8192.
        assert_eq!(MAX_ENCODED_LEN - file.len(), 7 * 2 + 2);
        assert_eq!(decode(&file).unwrap(), m);
        std::println!("[model_file] largest model: {} bytes", file.len());
    }

    #[test]
    fn fuzz_random_bytes_never_panic() {
        let mut rng = Xoshiro128pp::seed_from_u64(0x5EED_F11E);
        let valid_payload_len = payload_of(&encode_vec(&test_model())).len();
        let mut ok = 0;
        for i in 0..5000 {
            let len = (rng.next_u32() as usize) % (2 * valid_payload_len);
            let bytes: StdVec<u8> = (0..len).map(|_| rng.next_u32() as u8).collect();
            // Half the cases get a valid frame around the random bytes, so postcard
            // and the semantic checks see them.
            let file = if i % 2 == 0 { reframe(&bytes) } else { bytes };
            if decode(&file).is_ok() {
                ok += 1;
            }
        }
        assert_eq!(ok, 0);
    }

    #[test]
    fn fuzz_mutations_never_panic() {
        let file = encode_vec(&test_model());
        let payload = payload_of(&file).to_vec();
        let mut rng = Xoshiro128pp::seed_from_u64(0x0BAD_F00D);
        let mut reframed_ok = 0;
        for _ in 0..5000 {
            // 1. Raw mutations of the file: the framing or the CRC must catch them.
            let mut f = file.clone();
            mutate(&mut rng, &mut f);
            if f != file {
                assert!(decode(&f).is_err());
            }
            // 2. The same kind of mutation of the payload, reframed with a valid CRC,
            //    reaches postcard and the semantic checks.
            let mut p = payload.clone();
            mutate(&mut rng, &mut p);
            if let Ok(m) = decode(&reframe(&p)) {
                m.validate().unwrap();
                let again = encode_vec(&m);
                assert_eq!(decode(&again).unwrap(), m);
                reframed_ok += 1;
            }
        }
        std::println!(
            "[model_file] reframed mutations accepted as valid models: {reframed_ok} / 5000"
        );
    }

    /// Flip, overwrite, insert or delete a few random bytes, or cut the tail.
    fn mutate(rng: &mut Xoshiro128pp, b: &mut StdVec<u8>) {
        let edits = 1 + rng.next_u32() % 4;
        for _ in 0..edits {
            let len = b.len();
            let at = if len == 0 {
                0
            } else {
                rng.next_u32() as usize % len
            };
            match rng.next_u32() % 6 {
                0 | 1 if len > 0 => b[at] ^= 1 << (rng.next_u32() % 8),
                2 if len > 0 => b[at] = rng.next_u32() as u8,
                3 => b.insert(at, rng.next_u32() as u8),
                4 if len > 0 => {
                    b.remove(at);
                }
                5 => b.truncate(at),
                _ => {}
            }
        }
    }

    #[test]
    fn indicator_names_come_back_whole() {
        for n in INDICATOR_NAMES {
            let stored: Name = Name::try_from(&n[..n.len().min(NAME_LEN)]).unwrap();
            assert_eq!(indicator_full_name(stored.as_str()), n);
        }
        assert_eq!(indicator_full_name("my_indicator"), "my_indicator");
    }
}
