//! Forward passes over a dataset (classes, probabilities, the physics heads' outputs)
//! and the evaluation of a trained network (the figures of `metrics.json`).

use burn::tensor::{Device, Tensor, TensorData};

use super::batch::{Batch, BatchParts};
use super::config::TrainConfig;
use super::loss::{class_loss, class_weights};
use super::net::Network;
use crate::dataset::Dataset;
use crate::model::{DsStgat, PhysicsHeads};

/// Outputs of an inference network over a data set, in window order.
#[derive(Debug, Clone, Default)]
pub struct Inference {
    /// Predicted class per window.
    pub classes: Vec<usize>,
    /// Embedding per window.
    pub embeddings: Vec<Vec<f32>>,
    /// Predicted spectrum shapes `[W, N, K]` (with heads).
    pub spectra: Vec<f32>,
    /// Predicted Θ (z-scored) `[W, P]` (with heads).
    pub theta: Vec<f32>,
}

/// Run an inference network (and heads) over `ds` in batches on `device` (a device
/// without autodiff).
pub fn infer(
    net: &Network,
    heads: Option<&PhysicsHeads>,
    ds: &Dataset,
    batch_size: usize,
    device: &Device,
) -> Inference {
    let parts = BatchParts {
        raw: net.raw(),
        physics: false,
    };
    let idx: Vec<usize> = (0..ds.len()).collect();
    let mut out = Inference::default();
    for chunk in idx.chunks(batch_size.max(1)) {
        let b = Batch::with_parts(ds, chunk, parts, device);
        let o = net.output(&b);
        let pred = o.logits.clone().argmax(1).into_data();
        out.classes.extend(
            pred.iter::<i64>()
                .map(|p| usize::try_from(p).expect("argmax is non-negative")),
        );
        let d = o.embedding.dims()[1];
        let e = o
            .embedding
            .clone()
            .into_data()
            .try_into_vec::<f32>()
            .unwrap_or_default();
        out.embeddings
            .extend(e.chunks(d.max(1)).map(<[f32]>::to_vec));
        if let (Some(h), Some(states)) = (heads, o.node_states) {
            let (sp, th) = h.forward(o.embedding, states);
            out.spectra
                .extend(sp.into_data().try_into_vec::<f32>().unwrap_or_default());
            out.theta
                .extend(th.into_data().try_into_vec::<f32>().unwrap_or_default());
        }
    }
    out
}

/// Mean total loss (weighted CE of the network and of the sensor head + λ_ind·indicator
/// MSE) of a DS-STGAT inference model
/// over `ds`, with the class weights of `cfg` fitted on `ds`.
pub fn mean_loss(
    model: &DsStgat,
    ds: &Dataset,
    cfg: &TrainConfig,
    classes: usize,
    device: &Device,
) -> f64 {
    let weights = if cfg.class_weighted {
        class_weights(&ds.label, classes)
    } else {
        vec![1.0; classes]
    };
    let idx: Vec<usize> = (0..ds.len()).collect();
    let mut sum = 0.0f64;
    for chunk in idx.chunks(cfg.eval_batch_size.max(1)) {
        let b = Batch::new(ds, chunk, device);
        let w = normalized_weights(chunk, ds, &weights);
        let w = Tensor::from_data(TensorData::new(w, [chunk.len()]), device);
        let out = model.forward(b.x, b.adj, b.mask);
        let ce = class_loss(out.logits, Some(out.parts), b.labels, w);
        let mse = (out.indicators - b.indicators).square().mean(); // eq. 13 regression
        let loss = ce + mse.mul_scalar(cfg.lambda_indicator);
        sum += f64::from(loss.into_scalar::<f32>()) * chunk.len() as f64;
    }
    sum / ds.len().max(1) as f64
}

/// Class weights of the windows `chunk`, summing to 1.
pub(super) fn normalized_weights(chunk: &[usize], ds: &Dataset, weights: &[f32]) -> Vec<f32> {
    let w: Vec<f32> = chunk
        .iter()
        .map(|&k| weights[ds.label[k] as usize])
        .collect();
    let w_sum: f32 = w.iter().sum::<f32>().max(1e-12);
    w.iter().map(|v| v / w_sum).collect()
}

/// Share of `pred` equal to the labels.
pub fn accuracy(pred: &[usize], labels: &[i64]) -> f64 {
    if pred.is_empty() {
        return 0.0;
    }
    let ok = pred
        .iter()
        .zip(labels)
        .filter(|(p, l)| **p as i64 == **l)
        .count();
    ok as f64 / pred.len() as f64
}
