//! Validation: [`ModelFile::validate`] (the dimension and value checks, steps 7–8 of
//! the `model_file` module docs) and the checked conversions of the stored parts into
//! the core's types ([`ModelFile::feature_norm`], [`ModelFile::graph_config`],
//! [`ModelFile::bearing_params`], [`ModelFile::bearing_geometry`]).

use crate::bearing::BearingGeometry;
use crate::diagnosis::Thresholds;
use crate::error::{Error, Result};
use crate::features::{FeatureNorm, FEATURE_DIM};
use crate::graph::GraphConfig;
use crate::quant::linear::MAX_BIAS;
use crate::quant::{QMultiplier, QScale};
use crate::simulator::BearingParams;

use super::capacity::{MAX_CLASSES, MAX_HIDDEN, MAX_INDICATORS, MAX_NODES, MAX_STEPS};
use super::parts::{layer_msg, Dimensions, LayerId, LayerView, ModelFile};

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
pub(super) fn scale(s: f32, what: &'static str) -> Result<QScale> {
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

/// `Err(ModelDimensions)` unless layer `id`'s buffers have its shape under `dims`.
pub(super) fn check_layer_shape(dims: &Dimensions, id: LayerId, l: LayerView<'_>) -> Result<()> {
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

/// `Err(ModelValue)` for a bad scale, requantization ratio, bias or code of layer `id`.
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
    /// what [`decode`](super::decode) checks after postcard, and [`encode`](super::encode)
    /// before writing.
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
        self.diagnosis_settings()?;
        Ok(())
    }

    /// The physical diagnosis' thresholds and the shaft revolutions each window is
    /// read over, checked: finite, thresholds > 0 (the margin ≥ 0), revolutions ≥ 1.
    pub fn diagnosis_settings(&self) -> Result<(Thresholds, f32)> {
        let d = self.diagnosis;
        let all = [
            d.line_db,
            d.margin_db,
            d.impulsive_sk,
            d.typed_logistic[0],
            d.typed_logistic[1],
            d.normal_logistic[0],
            d.normal_logistic[1],
            d.revolutions,
        ];
        if all.iter().any(|v| !v.is_finite())
            || d.line_db <= 0.0
            || d.margin_db < 0.0
            || d.impulsive_sk <= 0.0
            || d.revolutions < 1.0
        {
            return Err(Error::ModelValue(
                "diagnosis: a setting is not finite, a threshold not > 0 or revolutions < 1",
            ));
        }
        Ok((d.thresholds(), d.revolutions))
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
    // Checked conversions
    // -----------------------------------------------------------------------------

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
}
