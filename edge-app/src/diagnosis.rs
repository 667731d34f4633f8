//! The extension point for the trained model (`--model FILE`, a later issue).
//!
//! A [`Diagnoser`] sees every window after the features and the physics explanation
//! are computed, and returns a JSON value that the gateway adds to the window's line
//! under `"diagnosis"`. The model will plug in here:
//!
//! ```text
//! --model FILE → decode with the core's model-file reader (magic, version, checksum,
//!                sensor names, feature normalization, int8 weights)
//!              → check its sensor names against the sensor map's channel names
//!              → impl Diagnoser: for each window, per segment t = 0..8:
//!                  x[t][i] = FeatureNorm::apply(window.channels[i] rows[t])   (absent → masked)
//!                  A_t     = dynamic graph (eqs. 1–3) over the present nodes
//!                → int8 GAT → GRU → pooling → class probabilities and Θ_phys
//!              → Gateway::with_diagnoser(Box::new(model))
//! ```
//!
//! Nothing in the pipeline or the output changes when a diagnoser is added; without
//! one, the line has no `"diagnosis"` field.

use crate::pipeline::Window;

/// Why a diagnoser could not diagnose a window (fatal for the run).
#[derive(Debug, thiserror::Error)]
#[error("diagnosing window {window}: {reason}")]
pub struct DiagnoseError {
    /// Window index.
    pub window: u64,
    /// What went wrong.
    pub reason: String,
}

/// Turns one window into a diagnosis. `window.channels[i]` follows the sensor map's
/// channel order; a missing or failed channel has no features and must be masked.
pub trait Diagnoser {
    /// The diagnosis of `window`, written to its JSON line under `"diagnosis"`.
    fn diagnose(&mut self, window: &Window) -> Result<serde_json::Value, DiagnoseError>;
}
