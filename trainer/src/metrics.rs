//! Evaluation metrics (paper §6.3.3, Table 4) and the `metrics.json` report.
//!
//! ```text
//! accuracy            = Σ_c M_cc / Σ M                      (M: confusion, rows = true class)
//! precision_c         = M_cc / Σ_r M_rc      recall_c = M_cc / Σ_k M_ck
//! precision_macro     = mean_c precision_c   recall_macro = mean_c recall_c
//! f1_weighted         = Σ_c support_c · F1_c / Σ_c support_c,  F1_c = 2PR/(P+R)
//! fault_only_accuracy = accuracy over windows whose true class is not `normal`
//! ```
//!
//! The macro averages run over the classes that occur in the truth or in the
//! predictions (as scikit-learn does by default); a class never predicted has
//! precision 0, a class never true has recall 0.
//!
//! Noise robustness: white Gaussian noise is added to each RAW test window (per
//! channel, at the model rate, see [`crate::dataset::NoiseSpec`]) at
//! [`NOISE_SNR_DB`]; features, graphs and indicator targets are recomputed through
//! the core with the *training* normalization, and the clean-trained model is
//! evaluated on them.
//!
//! The physics-consistency keys of Table 4 (`spectral_consistency`, `response_mse`,
//! `parameter_drift`) are filled by `crate::training::evaluate_network` for a model
//! with co-adaptation heads (definitions there), and `null` for every other model.

use anyhow::{Context, Result};
use serde::Serialize;

use crate::dataset::{Corpus, Dataset, NoiseSpec, ProtocolData};

/// SNRs of the noise-robustness curve, in dB.
pub const NOISE_SNR_DB: [f32; 6] = [10.0, 6.0, 2.0, 0.0, -2.0, -4.0];

/// The noise of the `k`-th point of the noise curve ([`NOISE_SNR_DB`]`[k]`) for a run
/// seeded `seed`: each point draws its own stream, the same for every model of a run.
pub fn noise_spec(seed: u64, k: usize) -> NoiseSpec {
    NoiseSpec {
        snr_db: NOISE_SNR_DB[k],
        seed: seed.wrapping_add(1_000 + k as u64),
    }
}

/// Confusion-matrix based classification metrics.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Classification {
    /// Share of windows classified correctly.
    pub accuracy: f64,
    /// Mean per-class precision.
    pub precision_macro: f64,
    /// Mean per-class recall.
    pub recall_macro: f64,
    /// Support-weighted mean per-class F1.
    pub f1_weighted: f64,
    /// `confusion[true][predicted]`, window counts.
    pub confusion: Vec<Vec<usize>>,
}

/// The confusion matrix of `classes` classes, rows = true class.
///
/// # Panics
/// If a label or prediction is `>= classes`, or the slices differ in length.
pub fn confusion(truth: &[usize], predicted: &[usize], classes: usize) -> Vec<Vec<usize>> {
    assert_eq!(truth.len(), predicted.len(), "one prediction per window");
    let mut m = vec![vec![0usize; classes]; classes];
    for (&t, &p) in truth.iter().zip(predicted) {
        m[t][p] += 1;
    }
    m
}

/// Accuracy, macro precision and recall, weighted F1 and the confusion matrix.
///
/// # Panics
/// As [`confusion`].
pub fn classification(truth: &[usize], predicted: &[usize], classes: usize) -> Classification {
    let m = confusion(truth, predicted, classes);
    let total: usize = truth.len();
    let correct: usize = (0..classes).map(|c| m[c][c]).sum();
    let support: Vec<usize> = m.iter().map(|row| row.iter().sum()).collect();
    let predicted_n: Vec<usize> = (0..classes).map(|c| m.iter().map(|r| r[c]).sum()).collect();
    let ratio = |a: usize, b: usize| if b == 0 { 0.0 } else { a as f64 / b as f64 };
    let used: Vec<usize> = (0..classes)
        .filter(|&c| support[c] > 0 || predicted_n[c] > 0)
        .collect();
    let precision: Vec<f64> = (0..classes)
        .map(|c| ratio(m[c][c], predicted_n[c]))
        .collect();
    let recall: Vec<f64> = (0..classes).map(|c| ratio(m[c][c], support[c])).collect();
    let mean_over_used = |v: &[f64]| {
        if used.is_empty() {
            0.0
        } else {
            used.iter().map(|&c| v[c]).sum::<f64>() / used.len() as f64
        }
    };
    let f1_weighted = if total == 0 {
        0.0
    } else {
        (0..classes)
            .map(|c| {
                let (p, r) = (precision[c], recall[c]);
                let f1 = if p + r > 0.0 {
                    2.0 * p * r / (p + r)
                } else {
                    0.0
                };
                f1 * support[c] as f64
            })
            .sum::<f64>()
            / total as f64
    };
    Classification {
        accuracy: ratio(correct, total),
        precision_macro: mean_over_used(&precision),
        recall_macro: mean_over_used(&recall),
        f1_weighted,
        confusion: m,
    }
}

/// Accuracy over the windows whose true class is not `normal_class` (all windows when
/// `None`, e.g. protocols without a normal class).
pub fn fault_only_accuracy(
    truth: &[usize],
    predicted: &[usize],
    normal_class: Option<usize>,
) -> f64 {
    let (mut n, mut ok) = (0usize, 0usize);
    for (&t, &p) in truth.iter().zip(predicted) {
        if Some(t) == normal_class {
            continue;
        }
        n += 1;
        ok += usize::from(t == p);
    }
    if n == 0 {
        0.0
    } else {
        ok as f64 / n as f64
    }
}

/// Fault-only accuracy with one node masked.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NodeMaskedPoint {
    /// The masked node.
    pub node: String,
    /// Fault-only test accuracy with it masked.
    pub fault_only_accuracy: f64,
}

/// One point of the noise curve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoisePoint {
    /// SNR in dB.
    pub snr_db: f32,
    /// Test accuracy at that SNR.
    pub accuracy: f64,
}

/// The `metrics.json` report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MetricsReport {
    /// Protocol name (`time-block`, `cross-load`, `fault-size`).
    pub protocol: String,
    /// Architecture (`dsstgat`).
    pub arch: String,
    /// Class names, in label order.
    pub classes: Vec<String>,
    /// Test accuracy.
    pub accuracy: f64,
    /// Test macro precision.
    pub precision_macro: f64,
    /// Test macro recall.
    pub recall_macro: f64,
    /// Test weighted F1.
    pub f1_weighted: f64,
    /// Test confusion matrix, rows = true class.
    pub confusion: Vec<Vec<usize>>,
    /// Accuracy against SNR.
    pub noise: Vec<NoisePoint>,
    /// Fault-only accuracy with one sensor node masked in every test window (a failed
    /// channel): checks that the model does not read "channel missing" as a class
    /// (the normal record is the one without a BA channel).
    pub node_masked: Vec<NodeMaskedPoint>,
    /// Training windows.
    pub n_train_windows: usize,
    /// Test windows.
    pub n_test_windows: usize,
    /// Records with training windows.
    pub n_train_records: usize,
    /// Records with test windows.
    pub n_test_records: usize,
    /// Test accuracy without the normal class.
    pub fault_only_accuracy: f64,
    /// Wall time of the training loop, seconds (`null` for `eval`).
    pub train_seconds: Option<f64>,
    /// Spectral consistency loss (Table 4); `null` without co-adaptation heads.
    pub spectral_consistency: Option<f64>,
    /// Response MSE (Table 4), dB²; `null` without co-adaptation heads.
    pub response_mse: Option<f64>,
    /// Parameter drift (Table 4), z-units; `null` without co-adaptation heads.
    pub parameter_drift: Option<f64>,
}

/// Evaluate any classifier of windows (`predictor`: one class per window of a data
/// set) on the test side of `data`, clean and at every [`NOISE_SNR_DB`] (noise seeds
/// derived from `seed`), into the report.
pub fn evaluate_with<const N: usize>(
    predictor: &dyn Fn(&Dataset) -> Result<Vec<usize>>,
    arch: &str,
    data: &ProtocolData<N>,
    corpus: &Corpus,
    seed: u64,
    train_seconds: Option<f64>,
) -> Result<MetricsReport> {
    let classes = data.classes().len();
    let truth: Vec<usize> = data.test.label.iter().map(|&l| l as usize).collect();
    let pred = predictor(&data.test)?;
    let c = classification(&truth, &pred, classes);
    let normal = data.classes().iter().position(|c| c == "normal");
    let mut noise = Vec::with_capacity(NOISE_SNR_DB.len());
    for k in 0..NOISE_SNR_DB.len() {
        let spec = noise_spec(seed, k);
        let snr_db = spec.snr_db;
        let noisy = data
            .noisy_test(corpus, spec)
            .with_context(|| format!("cannot featurize the test side at {snr_db} dB"))?;
        let pred = predictor(&noisy)?;
        let ok = pred.iter().zip(&truth).filter(|(p, t)| p == t).count();
        noise.push(NoisePoint {
            snr_db,
            accuracy: ok as f64 / truth.len().max(1) as f64,
        });
    }
    let mut node_masked = Vec::new();
    for (i, name) in data.nodes.iter().enumerate() {
        let mut masked = data.test.clone();
        for k in 0..masked.len() {
            masked.mask[k * N + i] = false;
        }
        let keep: Vec<bool> = (0..masked.len())
            .map(|k| masked.window_mask(k).iter().any(|&m| m))
            .collect();
        let sub = masked.select(&keep);
        let pred = predictor(&sub)?;
        let truth: Vec<usize> = sub.label.iter().map(|&l| l as usize).collect();
        node_masked.push(NodeMaskedPoint {
            node: (*name).to_string(),
            fault_only_accuracy: fault_only_accuracy(&truth, &pred, normal),
        });
    }
    Ok(MetricsReport {
        protocol: data.protocol.name().to_string(),
        arch: arch.to_string(),
        classes: data.classes().to_vec(),
        accuracy: c.accuracy,
        precision_macro: c.precision_macro,
        recall_macro: c.recall_macro,
        f1_weighted: c.f1_weighted,
        confusion: c.confusion,
        noise,
        node_masked,
        n_train_windows: data.train.len(),
        n_test_windows: data.test.len(),
        n_train_records: data.train.n_records(),
        n_test_records: data.test.n_records(),
        fault_only_accuracy: fault_only_accuracy(&truth, &pred, normal),
        train_seconds,
        spectral_consistency: None,
        response_mse: None,
        parameter_drift: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_of_a_small_example() {
        // 3 classes; class 2 never predicted.
        let truth = [0, 0, 1, 1, 2, 2];
        let pred = [0, 1, 1, 1, 0, 1];
        let c = classification(&truth, &pred, 3);
        assert_eq!(
            c.confusion,
            vec![vec![1, 1, 0], vec![0, 2, 0], vec![1, 1, 0]]
        );
        assert!((c.accuracy - 0.5).abs() < 1e-12);
        // precision: 1/2, 2/4, 0 → 1/3; recall: 1/2, 1, 0 → 1/2.
        assert!((c.precision_macro - 1.0 / 3.0).abs() < 1e-12);
        assert!((c.recall_macro - 0.5).abs() < 1e-12);
        // F1: 0.5, 2/3, 0 weighted by 2, 2, 2.
        assert!((c.f1_weighted - (0.5 + 2.0 / 3.0) / 3.0).abs() < 1e-12);
        assert!((fault_only_accuracy(&truth, &pred, Some(0)) - 0.5).abs() < 1e-12);
        assert!((fault_only_accuracy(&truth, &pred, None) - 0.5).abs() < 1e-12);
    }
}
