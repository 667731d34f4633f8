//! The evaluation of a trained network: the classification report of
//! [`evaluate_with`] on the protocol's test side (clean, noisy, one node masked) and,
//! with the co-adaptation heads, the physics figures of Table 4.

use anyhow::Result;
use burn::tensor::Device;

use super::config::TrainConfig;
use super::inference::{infer, Inference};
use super::net::Network;
use crate::dataset::{Corpus, Dataset, ProtocolData};
use crate::metrics::{evaluate_with, MetricsReport};
use crate::model::PhysicsHeads;
use crate::targets::{N_THETA, SPEC_BANDS};

/// Evaluate an inference network (any architecture) with its heads: the classification
/// report of [`evaluate_with`] plus the physics metrics of Table 4 (with heads), and
/// the clean test-side inference (for the figures).
///
/// ```text
/// spectral_consistency = L_phy on the test side (mean squared error of the predicted
///                        node spectrum shapes, log10 units², present nodes)
/// response_mse         = mean over test records of the mean squared log-PSD difference
///                        (dB²) between the record's test-side DE signal and the 2-DOF
///                        model rendered at F_map's Θ̂ (mean over the record's windows)
///                        with the fault type of the record's majority class
/// parameter_drift      = mean over test records of the standard deviation of Θ̂ across
///                        the record's windows (z-units, mean over components): a record
///                        is one bearing state, so Θ̂ should not move within it
/// ```
pub fn evaluate_network<const N: usize>(
    net: &Network,
    heads: Option<&PhysicsHeads>,
    cfg: &TrainConfig,
    theta_norm: Option<([f32; N_THETA], [f32; N_THETA])>,
    data: &ProtocolData<N>,
    corpus: &Corpus,
    train_seconds: Option<f64>,
    device: &Device,
) -> Result<(MetricsReport, Inference)> {
    let batch = cfg.eval_batch_size;
    // The clean test side once, with the physics heads; the noisy and node-masked
    // copies without them.
    let inference = infer(net, heads, &data.test, batch, device);
    let predictor = |ds: &Dataset| {
        Ok(if std::ptr::eq(ds, &data.test) {
            inference.classes.clone()
        } else {
            infer(net, None, ds, batch, device).classes
        })
    };
    let mut report = evaluate_with(
        &predictor,
        &cfg.report_name(),
        data,
        corpus,
        cfg.seed,
        train_seconds,
    )?;
    if heads.is_some() && !inference.spectra.is_empty() && data.test.has_signals() {
        let (mut sum, mut n) = (0.0f64, 0usize);
        for (k, (p, t)) in inference
            .spectra
            .chunks(SPEC_BANDS)
            .zip(data.test.spectra.chunks(SPEC_BANDS))
            .enumerate()
        {
            if data.test.mask[k] {
                sum += p
                    .iter()
                    .zip(t)
                    .map(|(a, b)| f64::from(a - b).powi(2))
                    .sum::<f64>();
                n += SPEC_BANDS;
            }
        }
        report.spectral_consistency = Some(sum / n.max(1) as f64);
        report.parameter_drift = Some(crate::physics::parameter_drift(
            &inference.theta,
            &data.test.record,
        ));
        if let Some((mean, std)) = theta_norm {
            report.response_mse = crate::physics::response_mse(
                corpus,
                &data.split.test,
                &inference,
                data.classes(),
                &mean,
                &std,
            );
        }
    }
    Ok((report, inference))
}
