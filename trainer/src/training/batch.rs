//! A batch of windows as burn tensors: features, graphs, masks, labels and the physics
//! targets.

use burn::tensor::{Device, Int, Tensor, TensorData};

use crate::dataset::{Dataset, FEATURES, N_INDICATORS, STEPS};
use crate::targets::{N_THETA, SPEC_BANDS};
use pumptwin_data::featurize::WINDOW;

/// One batch as tensors.
///
/// # Shapes
/// - `x`: `[B, T, N, F]`; `adj`: `[B, T, N, N]`; `mask`: `[B, N]` (1.0 present)
/// - `labels`: `[B]`; `indicators`: `[B, 4]`
/// - `raw`: `[B, N, 2048]` (raw-signal models only); `spectra`: `[B, N, K]` and
///   `theta`, `theta_known`: `[B, P]` (physics heads only)
#[derive(Debug, Clone)]
pub struct Batch {
    /// Node features.
    pub x: Tensor<4>,
    /// Adjacency.
    pub adj: Tensor<4>,
    /// Node mask.
    pub mask: Tensor<2>,
    /// Class labels.
    pub labels: Tensor<1, Int>,
    /// Indicator targets (z-scored).
    pub indicators: Tensor<2>,
    /// Raw samples, when asked for.
    pub raw: Option<Tensor<3>>,
    /// Node spectrum shapes, when asked for.
    pub spectra: Option<Tensor<3>>,
    /// Θ targets (z-scored, 0 where unknown), when asked for.
    pub theta: Option<Tensor<2>>,
    /// 1.0 where the Θ target is known.
    pub theta_known: Option<Tensor<2>>,
}

/// Which optional parts a [`Batch`] carries.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BatchParts {
    /// Raw samples (raw-signal baselines).
    pub raw: bool,
    /// Spectra and Θ targets (physics heads).
    pub physics: bool,
}

impl Batch {
    /// The windows `idx` of `ds` on `device` (features, graphs, labels, indicators).
    pub fn new(ds: &Dataset, idx: &[usize], device: &Device) -> Self {
        Self::with_parts(ds, idx, BatchParts::default(), device)
    }

    /// As [`Batch::new`], with the optional parts in `parts` (zeros where `ds` lacks
    /// them).
    pub fn with_parts(ds: &Dataset, idx: &[usize], parts: BatchParts, device: &Device) -> Self {
        let b = idx.len();
        let n = ds.nodes;
        let (xw, aw) = (ds.x_per_window(), ds.adj_per_window());
        let mut x = Vec::with_capacity(b * xw);
        let mut adj = Vec::with_capacity(b * aw);
        let mut mask = Vec::with_capacity(b * n);
        let mut labels = Vec::with_capacity(b);
        let mut ind = Vec::with_capacity(b * N_INDICATORS);
        for &k in idx {
            x.extend_from_slice(&ds.x[k * xw..(k + 1) * xw]);
            adj.extend_from_slice(&ds.adj[k * aw..(k + 1) * aw]);
            mask.extend(
                ds.window_mask(k)
                    .iter()
                    .map(|&m| if m { 1.0f32 } else { 0.0 }),
            );
            labels.push(ds.label[k]);
            ind.extend_from_slice(&ds.indicators[k * N_INDICATORS..(k + 1) * N_INDICATORS]);
        }
        let gather = |src: &[f32], per: usize| -> Vec<f32> {
            let mut v = Vec::with_capacity(b * per);
            for &k in idx {
                match src.get(k * per..(k + 1) * per) {
                    Some(s) => v.extend_from_slice(s),
                    None => v.extend(std::iter::repeat_n(0.0, per)),
                }
            }
            v
        };
        let raw = parts.raw.then(|| {
            let v = gather(&ds.raw, ds.raw_per_window());
            Tensor::from_data(TensorData::new(v, [b, n, WINDOW]), device)
        });
        let (spectra, theta, theta_known) = if parts.physics {
            let sp = gather(&ds.spectra, ds.spec_per_window());
            let th = gather(&ds.theta, N_THETA);
            let known: Vec<f32> = th
                .iter()
                .map(|v| if v.is_finite() { 1.0 } else { 0.0 })
                .collect();
            let th: Vec<f32> = th
                .iter()
                .map(|v| if v.is_finite() { *v } else { 0.0 })
                .collect();
            (
                Some(Tensor::from_data(
                    TensorData::new(sp, [b, n, SPEC_BANDS]),
                    device,
                )),
                Some(Tensor::from_data(TensorData::new(th, [b, N_THETA]), device)),
                Some(Tensor::from_data(
                    TensorData::new(known, [b, N_THETA]),
                    device,
                )),
            )
        } else {
            (None, None, None)
        };
        Self {
            x: Tensor::from_data(TensorData::new(x, [b, STEPS, n, FEATURES]), device),
            adj: Tensor::from_data(TensorData::new(adj, [b, STEPS, n, n]), device),
            mask: Tensor::from_data(TensorData::new(mask, [b, n]), device),
            labels: Tensor::from_data(TensorData::new(labels, [b]), device),
            indicators: Tensor::from_data(TensorData::new(ind, [b, N_INDICATORS]), device),
            raw,
            spectra,
            theta,
            theta_known,
        }
    }
}
