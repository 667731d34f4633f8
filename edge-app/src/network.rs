//! The trained int8 DS-STGAT as a [`Diagnoser`] (`--model FILE`).
//!
//! ```text
//! FILE → model_file::decode_into (magic, version, CRC, dimensions, values: named errors)
//!      → InferenceModel (H = 16 or 32), FeatureNorm, GraphConfig, class/sensor/indicator names
//! per window, node i = the model's sensor name i, looked up among the window's channels:
//!      x[t][i] = FeatureNorm(rows[t])            computed channel
//!      mask[i] = false                           not in the sensor map, missing, failed
//!      A_t     = build_dynamic_graphs(x, mask)   eqs. 1–3, the core's (as in training)
//!      → int8 embedding → GAT → GRU → pooling → logits (i32) and indicators (i32)
//! ```
//!
//! The output (under `"diagnosis"` in the window's line):
//!
//! ```text
//! {"model": "dsstgat-cwru-tb", "status": "ok" | "degraded" | "no_signal",
//!  "class": "IR007" | null, "confidence": 0.98, "probabilities": {"normal": …, …},
//!  "masked_nodes": {"BA": "missing"}, "indicators": {"impact_intensity": …, …}}
//! ```
//!
//! A masked node is said so, with why; the model was trained with node dropout, so it
//! diagnoses from any subset of its sensors. A node the sensor map does not name is a
//! configuration (masked, status unaffected); a mapped channel that is missing or
//! failed, or a discontinuity, makes the diagnosis `"degraded"`, so a consumer can
//! weigh it. With no node present there is no class (`"no_signal"`), never a guess.

use std::path::Path;

use pumptwin_core::diagnosis::{Thresholds, DEFAULT_REVOLUTIONS};
use pumptwin_core::dsstgat::{
    probabilities_into, InferenceModel, InferenceScratch, Output, MODEL_CLASSES, MODEL_INDICATORS,
};
use pumptwin_core::features::{FeatureNorm, FEATURE_DIM};
use pumptwin_core::graph::{build_dynamic_graphs, Adjacency, GraphConfig, NodeMask};
use pumptwin_core::model_file::{self, ModelFile};
use serde_json::{json, Map, Value};

use crate::diagnosis::{DiagnoseError, Diagnoser};
use crate::explain::KinematicLine;
use crate::pipeline::{ChannelOutcome, Window, SEGMENTS};

/// Sensor nodes of the models this gateway runs (the core's layout).
pub const NODES: usize = pumptwin_core::layout::N_NODES;

/// Why a model file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ModelLoadError {
    /// The file cannot be read.
    #[error("cannot read model {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The core refused the file (magic, version, checksum, dimensions, values).
    #[error("model {path} is not a valid model file: {source}")]
    Invalid {
        /// The file.
        path: String,
        /// The core's error.
        source: pumptwin_core::Error,
    },
    /// A valid file this gateway cannot run.
    #[error("model {path}: {reason}")]
    Unsupported {
        /// The file.
        path: String,
        /// Why.
        reason: String,
    },
}

/// The int8 model as a diagnoser.
#[derive(Debug)]
pub struct ModelDiagnoser {
    file: Box<ModelFile>,
    model: InferenceModel,
    norm: FeatureNorm,
    graph: GraphConfig<NODES>,
    /// Model nodes that the sensor map does not name (always masked).
    unmapped: [bool; NODES],
    scratch: Box<InferenceScratch<SEGMENTS, NODES>>,
}

impl ModelDiagnoser {
    /// Load `path` for a gateway whose sensor map has `channels`.
    ///
    /// # Errors
    /// [`ModelLoadError`]: unreadable, invalid (the core's named error), or not a
    /// 3-node, 8-step, 20-feature model; a model none of whose sensors the map names.
    pub fn load<'a>(
        path: &Path,
        channels: impl IntoIterator<Item = &'a str>,
    ) -> Result<Self, ModelLoadError> {
        let shown = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| ModelLoadError::Io {
            path: shown.clone(),
            source,
        })?;
        let invalid = |source| ModelLoadError::Invalid {
            path: shown.clone(),
            source,
        };
        let mut file = Box::<ModelFile>::default();
        model_file::decode_into(&bytes, &mut file).map_err(invalid)?;
        let unsupported = |reason: String| ModelLoadError::Unsupported {
            path: shown.clone(),
            reason,
        };
        let d = file.dims;
        if usize::from(d.nodes) != NODES
            || usize::from(d.steps) != SEGMENTS
            || usize::from(d.features) != FEATURE_DIM
        {
            return Err(unsupported(format!(
                "the model has N = {}, T = {}, F = {}; this gateway runs N = {NODES}, \
                 T = {SEGMENTS}, F = {FEATURE_DIM}",
                d.nodes, d.steps, d.features
            )));
        }
        let model = InferenceModel::from_model_file(&file).map_err(invalid)?;
        let norm = file.feature_norm().map_err(invalid)?;
        let graph = file.graph_config::<NODES>().map_err(invalid)?;
        let channels: Vec<&str> = channels.into_iter().collect();
        let unmapped: [bool; NODES] =
            std::array::from_fn(|i| !channels.contains(&file.sensor_names()[i].as_str()));
        if unmapped.iter().all(|&u| u) {
            return Err(unsupported(format!(
                "none of the model's sensors {:?} is in the sensor map ({channels:?})",
                file.sensor_names()
            )));
        }
        Ok(Self {
            file,
            model,
            norm,
            graph,
            unmapped,
            scratch: Box::new((Default::default(), Default::default())),
        })
    }

    /// The model's name.
    pub fn name(&self) -> &str {
        &self.file.model_name
    }

    /// The model's class names.
    pub fn class_names(&self) -> impl Iterator<Item = &str> {
        self.file.class_names().iter().map(|s| s.as_str())
    }

    /// The physical diagnosis' thresholds and revolutions the model file ships with
    /// (checked when the file was decoded; the core's own where they would not be).
    pub fn diagnosis_settings(&self) -> (Thresholds, f32) {
        self.file
            .diagnosis_settings()
            .unwrap_or((Thresholds::DEFAULT, DEFAULT_REVOLUTIONS))
    }

    /// The model's sensor names that the sensor map does not name.
    pub fn unmapped(&self) -> impl Iterator<Item = &str> {
        self.file
            .sensor_names()
            .iter()
            .zip(self.unmapped)
            .filter(|(_, u)| *u)
            .map(|(s, _)| s.as_str())
    }
}

impl Diagnoser for ModelDiagnoser {
    fn diagnose(&mut self, window: &Window) -> Result<Value, DiagnoseError> {
        let fail = |reason: String| DiagnoseError {
            window: window.index,
            reason,
        };
        let mut x = [[[0.0f32; FEATURE_DIM]; NODES]; SEGMENTS];
        let mut mask = NodeMask([false; NODES]);
        let mut masked = Map::new();
        let mut dropout = false;
        for i in 0..NODES {
            let name = self.file.sensor_names()[i].as_str();
            let outcome = window
                .channels
                .iter()
                .find(|c| c.name == name)
                .map(|c| &c.outcome);
            match outcome {
                None => {
                    masked.insert(name.into(), "not in the sensor map".into());
                }
                Some(ChannelOutcome::Missing) => {
                    masked.insert(name.into(), "missing".into());
                    dropout = true;
                }
                Some(ChannelOutcome::Failed(e)) => {
                    masked.insert(name.into(), format!("failed: {e}").into());
                    dropout = true;
                }
                Some(ChannelOutcome::Computed { features, .. }) => {
                    for (t, row) in features.rows.iter().enumerate() {
                        let mut r = *row;
                        self.norm.apply(&mut r);
                        x[t][i] = r;
                    }
                    mask.0[i] = true;
                }
            }
        }
        let name = self.name().to_string();
        if mask.count() == 0 {
            return Ok(json!({
                "model": name, "status": "no_signal", "class": null,
                "masked_nodes": masked,
            }));
        }
        let mut adj = [Adjacency::<NODES>::ZERO; SEGMENTS];
        build_dynamic_graphs(&self.graph, &x, &mask, &mut adj)
            .map_err(|e| fail(format!("graph: {e}")))?;
        let mut out = Output::<MODEL_CLASSES, MODEL_INDICATORS>::default();
        self.model
            .forward(&x, &adj, &mask, &mut out, &mut self.scratch)
            .map_err(|e| fail(format!("inference: {e}")))?;
        let classes = self.model.classes();
        let mut p = vec![0.0f32; classes];
        probabilities_into(&out.logits[..classes], self.model.logit_scale(), &mut p);
        let mut probs = Map::new();
        for (c, pc) in self.class_names().zip(&p) {
            probs.insert(c.into(), json!(round4(*pc)));
        }
        let ind = &self.file.indicator;
        let s = self.model.indicator_scale().get();
        let mut indicators = Map::new();
        for k in 0..self.model.indicators() {
            let z = s * out.indicators[k] as f32;
            indicators.insert(
                model_file::indicator_full_name(ind.names[k].as_str()).into(),
                json!(round4(ind.mean[k] + ind.std[k] * z)),
            );
        }
        let degraded = dropout || window.is_degraded();
        Ok(json!({
            "model": name,
            "status": if degraded { "degraded" } else { "ok" },
            "class": self.file.class_name(out.class),
            "confidence": round4(p[out.class]),
            "probabilities": probs,
            "masked_nodes": masked,
            "indicators": indicators,
        }))
    }
}

fn round4(v: f32) -> f64 {
    (f64::from(v) * 1e4).round() / 1e4
}

/// The compact diagnosis frame of `--publish-id` (classic CAN, 8 bytes):
///
/// | byte | field |
/// |---|---|
/// | 0 | class index in the model's class list, `0xFF` = none (`no_signal`, no model) |
/// | 1 | confidence · 255, rounded |
/// | 2 | status: 0 ok, 1 degraded, 2 no_signal |
/// | 3 | masked model nodes, bit `i` = node `i` |
/// | 4–5 | window index, u16 little-endian (wraps) |
/// | 6 | envelope explanation: 0 none, 1 shaft, 2 BPFO, 3 BPFI, 4 BSF, 5 FTF |
/// | 7 | frame counter, u8 (wraps) |
#[derive(Debug, Clone)]
pub struct DiagnosisFrameEncoder {
    classes: Vec<String>,
    nodes: Vec<String>,
    counter: u8,
}

impl DiagnosisFrameEncoder {
    /// For a model's class and sensor names (empty for a gateway without a model).
    pub fn new(classes: Vec<String>, nodes: Vec<String>) -> Self {
        Self {
            classes,
            nodes,
            counter: 0,
        }
    }

    /// For the model a [`ModelDiagnoser`] runs.
    pub fn for_model(m: &ModelDiagnoser) -> Self {
        Self::new(
            m.class_names().map(str::to_string).collect(),
            m.file
                .sensor_names()
                .iter()
                .map(|s| s.to_string())
                .collect(),
        )
    }

    /// The frame of one window.
    pub fn encode(&mut self, window: &Window, diagnosis: Option<&Value>) -> [u8; 8] {
        let mut f = [0u8; 8];
        let d = diagnosis.unwrap_or(&Value::Null);
        f[0] = d["class"]
            .as_str()
            .and_then(|c| self.classes.iter().position(|k| k == c))
            .and_then(|i| u8::try_from(i).ok())
            .unwrap_or(0xFF);
        f[1] = (d["confidence"].as_f64().unwrap_or(0.0).clamp(0.0, 1.0) * 255.0).round() as u8;
        f[2] = match d["status"].as_str() {
            Some("ok") => 0,
            Some("degraded") => 1,
            Some(_) => 2,
            None => u8::from(window.is_degraded()),
        };
        if let Some(masked) = d["masked_nodes"].as_object() {
            for (i, n) in self.nodes.iter().enumerate().take(8) {
                if masked.contains_key(n) {
                    f[3] |= 1 << i;
                }
            }
        }
        f[4..6].copy_from_slice(&(window.index as u16).to_le_bytes());
        f[6] = match window.explanation.as_ref().map(|e| e.kinematic.line) {
            None => 0,
            Some(KinematicLine::Shaft) => 1,
            Some(KinematicLine::Bpfo) => 2,
            Some(KinematicLine::Bpfi) => 3,
            Some(KinematicLine::Bsf) => 4,
            Some(KinematicLine::Ftf) => 5,
        };
        f[7] = self.counter;
        self.counter = self.counter.wrapping_add(1);
        f
    }
}
