//! The files of a training run's output directory: their names, `config.json` and
//! `normalization.json`, and their readers.

use std::path::Path;

use anyhow::{bail, Context, Result};
use pumptwin_core::features::{FeatureNorm, FEATURE_DIM};
use serde::Serialize;

use super::config::TrainConfig;
use crate::dataset::{IndicatorNorm, N_INDICATORS};
use crate::physics::N_THETA;
use pumptwin_data::windows::Protocol;

/// Feature and indicator normalization as saved in `normalization.json`.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct SavedNorms {
    /// Feature means, `[F]`.
    pub feature_mean: Vec<f32>,
    /// Feature standard deviations, `[F]`.
    pub feature_std: Vec<f32>,
    /// Indicator names, in output order.
    pub indicator_names: Vec<String>,
    /// Indicator means, `[4]`.
    pub indicator_mean: Vec<f32>,
    /// Indicator standard deviations, `[4]`.
    pub indicator_std: Vec<f32>,
    /// Θ_phys names (F_map's outputs), empty without co-adaptation.
    #[serde(default)]
    pub theta_names: Vec<String>,
    /// Θ_phys means over the training records (F_map's z-scoring).
    #[serde(default)]
    pub theta_mean: Vec<f32>,
    /// Θ_phys standard deviations.
    #[serde(default)]
    pub theta_std: Vec<f32>,
}

impl SavedNorms {
    /// From the fitted normalizations.
    pub fn new(norm: &FeatureNorm, ind: &IndicatorNorm) -> Self {
        Self {
            feature_mean: norm.mean.to_vec(),
            feature_std: norm.std.to_vec(),
            indicator_names: crate::dataset::INDICATOR_NAMES
                .iter()
                .map(|s| s.to_string())
                .collect(),
            indicator_mean: ind.mean.to_vec(),
            indicator_std: ind.std.to_vec(),
            theta_names: Vec::new(),
            theta_mean: Vec::new(),
            theta_std: Vec::new(),
        }
    }

    /// The Θ normalization, if saved.
    pub fn theta(&self) -> Option<([f32; N_THETA], [f32; N_THETA])> {
        let m: [f32; N_THETA] = self.theta_mean.as_slice().try_into().ok()?;
        let s: [f32; N_THETA] = self.theta_std.as_slice().try_into().ok()?;
        Some((m, s))
    }

    /// Back to the typed normalizations.
    pub fn to_norms(&self) -> Result<(FeatureNorm, IndicatorNorm)> {
        let arr = |v: &[f32], what: &str| -> Result<[f32; FEATURE_DIM]> {
            v.try_into()
                .with_context(|| format!("{what}: expected {FEATURE_DIM} values"))
        };
        let ind = |v: &[f32], what: &str| -> Result<[f32; N_INDICATORS]> {
            v.try_into()
                .with_context(|| format!("{what}: expected {N_INDICATORS} values"))
        };
        let norm = FeatureNorm::new(
            arr(&self.feature_mean, "feature_mean")?,
            arr(&self.feature_std, "feature_std")?,
        )
        .map_err(|e| anyhow::anyhow!("bad feature normalization: {e:?}"))?;
        Ok((
            norm,
            IndicatorNorm {
                mean: ind(&self.indicator_mean, "indicator_mean")?,
                std: ind(&self.indicator_std, "indicator_std")?,
            },
        ))
    }
}

/// File names in a model directory.
pub const CONFIG_FILE: &str = "config.json";
/// Weights.
pub const MODEL_FILE: &str = "model.bpk";
/// Normalizations.
pub const NORMS_FILE: &str = "normalization.json";
/// The co-adaptation heads (spectral head and F_map).
pub const HEADS_FILE: &str = "physics_heads.bpk";
/// Per-epoch history.
pub const HISTORY_FILE: &str = "history.json";
/// Metrics.
pub const METRICS_FILE: &str = "metrics.json";

/// A protocol from its name (`time-block`, `cross-load`, `fault-size`).
pub fn parse_protocol(name: &str) -> Result<Protocol> {
    <Protocol as clap::ValueEnum>::from_str(name, true)
        .map_err(|e| anyhow::anyhow!("unknown protocol {name:?}: {e}"))
}

/// A `config.json`, read over the defaults: a key the file lacks (it was written
/// before that setting existed) takes its default, which reproduces such a run
/// (`nodes` = `measured`).
pub fn read_config(path: &Path) -> Result<TrainConfig> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{} is not JSON", path.display()))?;
    let serde_json::Value::Object(file) = value else {
        bail!(
            "{} is not a training config (not a JSON object)",
            path.display()
        );
    };
    let mut merged = serde_json::to_value(TrainConfig::new())?;
    if let Some(obj) = merged.as_object_mut() {
        obj.extend(file);
    }
    serde_json::from_value(merged)
        .with_context(|| format!("{} is not a training config", path.display()))
}

/// The `config.json` beside a trained model, and its `normalization.json` if present.
pub fn load_trained_config(
    model: &Path,
) -> Result<(TrainConfig, Option<(FeatureNorm, IndicatorNorm)>)> {
    let dir = model.parent().unwrap_or(Path::new("."));
    let cfg = read_config(&dir.join(CONFIG_FILE))?;
    let norms_path = dir.join(NORMS_FILE);
    let norms = if norms_path.is_file() {
        let text = std::fs::read_to_string(&norms_path)?;
        let saved: SavedNorms = serde_json::from_str(&text)
            .with_context(|| format!("cannot parse {}", norms_path.display()))?;
        Some(saved.to_norms()?)
    } else {
        None
    };
    Ok((cfg, norms))
}

/// Write `value` as pretty JSON with a final newline.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    std::fs::write(path, text + "\n").with_context(|| format!("cannot write {}", path.display()))
}
