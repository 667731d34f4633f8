//! The layout that training, `predict`, the edge gateway, the firmware and the model
//! file agree on: the window, its hop and its graph steps, the sensor nodes, and what
//! the sensor head reads. One place, so that no side can drift from the others.
//!
//! Depends on [`crate::features`] (the feature rows these indices point into) and
//! nothing else of the crate; [`crate::model_file`] and [`crate::dsstgat`] both read it.

/// Samples per diagnosed window at the model rate (12 kHz: 171 ms).
pub const WINDOW: usize = 2048;
/// Samples between window starts (50 % overlap).
pub const HOP: usize = WINDOW / 2;
/// Segments (graph steps) per window.
pub const SEGMENTS: usize = crate::features::STANDARD_SEGMENTS;
/// The sensor nodes of every int8 model the project makes, in node order: node 0 is
/// the sensor on the monitored bearing (drive end).
pub const NODE_NAMES: [&str; N_NODES] = ["DE", "FE", "BA"];
/// Number of [`NODE_NAMES`].
pub const N_NODES: usize = 3;

/// The node features the sensor head reads (indices into
/// [`crate::features::FEATURE_NAMES`]), each averaged over the window's steps: first
/// the sixteen log band shares ([`SENSOR_HEAD_SPECTRAL`] of them: the spectral shape,
/// which tells the sensors' transfer paths apart), then the five envelope features
/// ([`SENSOR_HEAD_KINEMATIC`]: the lines at the defect frequencies and the envelope's
/// kurtosis, evidence of where the defect is that does not scale with its size). The
/// trainer trains the two parts as two experts, each on a cross-entropy of its own, and
/// folds their weights into this one head (its `SENSOR_HEAD_WEIGHT` and
/// `KINEMATIC_HEAD_WEIGHT` say why and what they measured).
pub const SENSOR_HEAD_FEATURES: [usize; SENSOR_HEAD_DIM] = {
    let bands = crate::features::feature_index("band_db_01");
    let envelope = crate::features::feature_index("env_shaft_db");
    let mut list = [0; SENSOR_HEAD_DIM];
    let mut i = 0;
    while i < SENSOR_HEAD_DIM {
        list[i] = if i < SENSOR_HEAD_SPECTRAL {
            bands + i
        } else {
            envelope + i - SENSOR_HEAD_SPECTRAL
        };
        i += 1;
    }
    list
};
/// The sensor head's spectral features per node: the log band shares, first in a slot.
pub const SENSOR_HEAD_SPECTRAL: usize = crate::features::SPECTRAL_BANDS;
/// The sensor head's kinematic features per node: the envelope features, after the
/// band shares in a slot.
pub const SENSOR_HEAD_KINEMATIC: usize = crate::features::ENVELOPE_FEATURES;
/// Features per node of the sensor head.
pub const SENSOR_HEAD_DIM: usize = SENSOR_HEAD_SPECTRAL + SENSOR_HEAD_KINEMATIC;
/// Node slots of the sensor head: a model's nodes fill the first slots, the rest read
/// zero. Three, the nodes of every int8 model the project makes (DE, FE, BA): each
/// slot costs `C·SENSOR_HEAD_DIM` bytes twice on an MCU (decoded file and network).
pub const SENSOR_HEAD_NODES: usize = 3;
/// Inputs of the sensor head, `SENSOR_HEAD_NODES · SENSOR_HEAD_DIM`, node-major.
pub const SENSOR_HEAD_INPUTS: usize = SENSOR_HEAD_NODES * SENSOR_HEAD_DIM;
