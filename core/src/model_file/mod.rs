//! The model file: one postcard-encoded file with everything the edge needs to run a
//! trained DS-STGAT, decoded without allocation into fixed-capacity buffers.
//!
//! # Layout (format version 9)
//!
//! | offset | bytes | field | encoding |
//! |---|---|---|---|
//! | 0 | 8 | magic [`MAGIC`] = `PTWINMDL` | ASCII |
//! | 8 | 2 | format version [`FORMAT_VERSION`] = 10 | u16, little-endian |
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
//! | `physics` | [`PhysicsParts`] | default [`BearingParams`](crate::simulator::BearingParams) (f64, SI) |
//! | `geometry` | [`GeometryParts`] | bearing `n`, `d`, `D`, contact angle |
//! | `diagnosis` | [`DiagnosisParts`] | the physical diagnosis' thresholds, confidence calibration and revolutions read (`crate::diagnosis`) |
//!
//! Every int8 layer is a [`QLinearParts`]: input and output scales (f32), per-output-
//! channel weight scales (f32), i32 biases, and the int8 weights row-major
//! (`[OUT][IN]`), exactly the parts of
//! [`QLinear::from_parts`](crate::quant::QLinear::from_parts).
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
//! panics: every malformed input is an [`Error`](crate::Error). [`encode`] runs steps
//! 7–8 before writing, so it never writes a file that [`decode`] would refuse. The
//! typed builders ([`ModelFile::gat_layer`], [`ModelFile::gru_cell`],
//! [`ModelFile::linear`], …) then check the compile-time sizes asked for against the
//! file's and assemble the [`crate::quant`] kernels.
//!
//! # Capacities and memory
//!
//! | const | value | bounds |
//! |---|---|---|
//! | [`MAX_NODES`] | 8 | `N` |
//! | [`MAX_CLASSES`] | 16 | `C` |
//! | [`MAX_HIDDEN`] | 32 | `H_gat`, `H_gru` |
//! | [`MAX_STEPS`] | 8192 | `T` (`T·N ≤` [`MAX_POOL_PAIRS`](crate::quant::pool::MAX_POOL_PAIRS)) |
//! | [`MAX_INDICATORS`] | 8 | `K` |
//! | [`MAX_EMBED_WEIGHTS`] | 896 | `H_gat·F` |
//! | [`MAX_GAT_WEIGHTS`] | 1024 | `H_gat·H_gat` |
//! | [`MAX_GRU_WEIGHTS`] | 1024 | each GRU matrix |
//! | [`MAX_CLASSIFIER_WEIGHTS`] | 512 | `C·H_gru` |
//! | [`MAX_SENSOR_HEAD_WEIGHTS`] | `16·SENSOR_HEAD_INPUTS` | `C·SENSOR_HEAD_INPUTS` |
//! | [`MAX_INDICATOR_WEIGHTS`] | 256 | `K·H_gru` |
//!
//! `F` must equal [`FEATURE_DIM`](crate::features::FEATURE_DIM) (the normalization has
//! that many entries).
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
//! hence the hand-written in-place decoding (`in_place.rs`).
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
//! figures are no longer what the network computes from it. Version 10: the physical
//! diagnosis' settings joined the payload ([`DiagnosisParts`]: its thresholds,
//! confidence calibration and the shaft revolutions a window is read over), so that
//! predict and the edge decide as the evaluation did; a version-9 file lacks them.
//!
//! # Source files
//!
//! | file | what |
//! |---|---|
//! | `mod.rs` | this documentation and the re-exports (it defines nothing) |
//! | `capacity.rs` | the capacities of the fixed-size buffers ([`MAX_NODES`], …, [`DECODED_SIZE_BUDGET`]) |
//! | `crc.rs` | [`crc32`] |
//! | `parts.rs` | the payload: [`ModelFile`] and its parts ([`Dimensions`], [`LayerId`], [`QLinearParts`], …) |
//! | `in_place.rs` | the `Deserialize` impls, decoding in place |
//! | `frame.rs` | the header constants ([`MAGIC`], [`FORMAT_VERSION`], …), [`encode`], [`decode`], [`decode_into`], [`file_len`] |
//! | `validate.rs` | [`ModelFile::validate`] and the checked conversions ([`ModelFile::feature_norm`], …) |
//! | `kernels.rs` | the typed builders ([`ModelFile::linear`], [`ModelFile::gat_layer`], …) |
//! | `testkit.rs` | test-only fixtures: a small random model's kernels and its [`ModelFile`] |
//!
//! Imports run one way: `capacity` and `crc` are leaves; `parts` imports `capacity`;
//! `in_place` imports `parts`; `frame` imports `capacity`, `crc`, `in_place` and
//! `parts`; `validate` imports `capacity` and `parts`; `kernels` imports `parts` and
//! `validate`; the test-only `testkit` imports `parts`. No file imports from `mod.rs`,
//! which defines nothing and only re-exports.

mod capacity;
mod crc;
mod frame;
mod in_place;
mod kernels;
mod parts;
#[cfg(test)]
mod testkit;
mod validate;

pub use capacity::{
    DECODED_SIZE_BUDGET, MAX_CLASSES, MAX_CLASSIFIER_WEIGHTS, MAX_EMBED_WEIGHTS, MAX_GAT_WEIGHTS,
    MAX_GRU_WEIGHTS, MAX_HIDDEN, MAX_INDICATORS, MAX_INDICATOR_WEIGHTS, MAX_NODES, MAX_PRIOR,
    MAX_SENSOR_HEAD_WEIGHTS, MAX_STEPS, NAME_LEN, TEXT_LEN,
};
pub use crc::crc32;
pub use frame::{
    decode, decode_into, encode, file_len, CRC_LEN, FORMAT_VERSION, HEADER_LEN, MAGIC,
    MAX_ENCODED_LEN,
};
pub use parts::{
    indicator_full_name, ClassifierParts, DiagnosisParts, Dimensions, EmbedParts, GatParts,
    GatProjectParts, GeometryParts, GraphParts, GruMatrixParts, GruParts, IndicatorHeadParts,
    IndicatorParts, LayerId, LayerView, ModelFile, Name, NormParts, PhysicsParts, PoolScoreParts,
    QLinearParts, SensorHeadParts, Text, INDICATOR_NAMES,
};
