//! The payload: [`ModelFile`] and the serde structs it is made of (dimensions, one
//! [`QLinearParts`] per int8 layer, normalization, graph, physics and geometry), their
//! conversions from the core's types, the plain accessors, and the indicator names.

use heapless::{String, Vec};
use serde::{Deserialize, Serialize};

use crate::bearing::BearingGeometry;
use crate::diagnosis::Thresholds;
use crate::error::{Error, Result};
use crate::features::{FeatureNorm, FEATURE_DIM};
use crate::graph::GraphConfig;
use crate::layout::SENSOR_HEAD_INPUTS;
use crate::quant::{GatLayer, GruCell, QLinear};
use crate::simulator::BearingParams;

use super::capacity::{
    DECODED_SIZE_BUDGET, MAX_CLASSES, MAX_CLASSIFIER_WEIGHTS, MAX_EMBED_WEIGHTS, MAX_GAT_WEIGHTS,
    MAX_GRU_WEIGHTS, MAX_HIDDEN, MAX_INDICATORS, MAX_INDICATOR_WEIGHTS, MAX_NODES, MAX_PRIOR,
    MAX_SENSOR_HEAD_WEIGHTS, NAME_LEN, TEXT_LEN,
};

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
    core::mem::size_of::<ModelFile>() <= DECODED_SIZE_BUDGET,
    "the decoded model outgrew its MCU memory budget"
);

/// Architecture dimensions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Dimensions {
    /// Sensor nodes `N`, `1..=`[`MAX_NODES`].
    pub nodes: u16,
    /// Node features `F`, equal to [`FEATURE_DIM`].
    pub features: u16,
    /// Time steps `T` per window, `1..=`[`MAX_STEPS`](super::MAX_STEPS).
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
pub(super) use layer_msg;

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
    /// The stored parameters as [`BearingParams`] (unchecked).
    pub(super) fn to_params(self) -> BearingParams {
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

/// The physical diagnosis' settings the model ships with (`crate::diagnosis`):
/// its thresholds, the calibration of its confidence and the revolutions each window
/// is read over, so that every reader of the file decides as the evaluation did.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DiagnosisParts {
    /// `Thresholds::line_db`, dB.
    pub line_db: f32,
    /// `Thresholds::margin_db`, dB.
    pub margin_db: f32,
    /// `Thresholds::impulsive_sk`.
    pub impulsive_sk: f32,
    /// `Thresholds::typed_logistic`.
    pub typed_logistic: [f32; 2],
    /// `Thresholds::normal_logistic`.
    pub normal_logistic: [f32; 2],
    /// Shaft revolutions each window is read over.
    pub revolutions: f32,
}

impl Default for DiagnosisParts {
    /// The core's shipped settings (`Thresholds::DEFAULT`, `DEFAULT_REVOLUTIONS`).
    fn default() -> Self {
        Self::new(&Thresholds::DEFAULT, crate::diagnosis::DEFAULT_REVOLUTIONS)
    }
}

impl DiagnosisParts {
    /// The settings of `t`, reading `revolutions`.
    pub fn new(t: &Thresholds, revolutions: f32) -> Self {
        Self {
            line_db: t.line_db,
            margin_db: t.margin_db,
            impulsive_sk: t.impulsive_sk,
            typed_logistic: [t.typed_logistic.0, t.typed_logistic.1],
            normal_logistic: [t.normal_logistic.0, t.normal_logistic.1],
            revolutions,
        }
    }

    /// The stored thresholds (unchecked).
    pub(super) fn thresholds(self) -> Thresholds {
        Thresholds {
            line_db: self.line_db,
            margin_db: self.margin_db,
            impulsive_sk: self.impulsive_sk,
            typed_logistic: (self.typed_logistic[0], self.typed_logistic[1]),
            normal_logistic: (self.normal_logistic[0], self.normal_logistic[1]),
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
    /// The stored geometry as [`BearingGeometry`] (unchecked).
    pub(super) fn to_geometry(self) -> BearingGeometry {
        BearingGeometry {
            n_elements: self.n_elements,
            element_diameter: self.element_diameter,
            pitch_diameter: self.pitch_diameter,
            contact_angle_deg: self.contact_angle_deg,
        }
    }
}

/// A decoded model file: plain data in fixed-capacity buffers (the payload, in
/// payload order). [`decode`](super::decode) returns only values that pass
/// [`ModelFile::validate`]; [`encode`](super::encode) writes only such values.
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
    /// The physical diagnosis' settings.
    pub diagnosis: DiagnosisParts,
}

impl ModelFile {
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indicator_names_come_back_whole() {
        for n in INDICATOR_NAMES {
            let stored: Name = Name::try_from(&n[..n.len().min(NAME_LEN)]).unwrap();
            assert_eq!(indicator_full_name(stored.as_str()), n);
        }
        assert_eq!(indicator_full_name("my_indicator"), "my_indicator");
    }
}
