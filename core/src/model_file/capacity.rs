//! The capacities of the model file's fixed-size buffers: the largest model a file can
//! hold (the "Capacities and memory" table of the module docs).

use crate::features::FEATURE_DIM;
use crate::layout::SENSOR_HEAD_INPUTS;
use crate::quant::pool::MAX_POOL_PAIRS;

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

const _: () = assert!(
    MAX_STEPS <= u16::MAX as usize,
    "dimensions (T the largest) are stored as u16"
);
const _: () = assert!(
    FEATURE_DIM <= 32,
    "serde (de)serializes fixed arrays of at most 32 elements"
);
