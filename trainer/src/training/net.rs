//! The networks one training loop drives: the DS-STGAT and the baselines behind one
//! [`Net`] trait, and [`Network`], whichever of them a run trains.

use std::path::Path;

use anyhow::{Context, Result};
use burn::module::Module;
use burn::tensor::{Device, Tensor};
use pumptwin_core::features::FeatureNorm;

use super::batch::Batch;
use super::config::{Arch, TrainConfig};
use crate::baselines::{CoFusionCnn, GcnGru, Tst, Wdcnn};
use crate::dataset::FEATURES;
use crate::model::DsStgat;

/// What any classifier of the comparison returns for a batch.
#[derive(Debug, Clone)]
pub struct NetOutput {
    /// Class logits `[B, C]`.
    pub logits: Tensor<2>,
    /// Indicator predictions `[B, 4]` (DS-STGAT only).
    pub indicators: Option<Tensor<2>>,
    /// The state embedding `[B, H]` (t-SNE map, F_map input).
    pub embedding: Tensor<2>,
    /// Final node states `[B, N, H]` (DS-STGAT only; the spectral head's input).
    pub node_states: Option<Tensor<3>>,
    /// The DS-STGAT's network logits and its sensor head's two experts', each trained
    /// on its own cross-entropy (`logits` is their weighted sum); `None` for the
    /// baselines.
    pub parts: Option<(Tensor<2>, Tensor<2>, Tensor<2>)>,
}

impl NetOutput {
    /// The output of a network with only a class head (the baselines).
    pub fn class_only(logits: Tensor<2>, embedding: Tensor<2>) -> Self {
        Self {
            logits,
            indicators: None,
            embedding,
            node_states: None,
            parts: None,
        }
    }
}

/// A classifier of windows that the generic training loop can train.
pub trait Net: Module + Send + Sync {
    /// Whether it reads `Batch::raw`.
    const RAW: bool;
    /// Whether a batch may be split into two replicas on two threads (see `fit_net`):
    /// not for a net with batch norm (its statistics are the whole batch's) or with
    /// dropout (it draws from the device's random stream, whose order two threads
    /// would make non-deterministic).
    const DATA_PARALLEL: bool;
    /// Whether the record-alignment term ([`record_alignment`]) applies to it: the
    /// DS-STGAT's objective only; the baselines train as published.
    const RECORD_ALIGNED: bool = false;
    /// Forward pass on a batch.
    fn output(&self, b: &Batch) -> NetOutput;
}

impl Net for DsStgat {
    const RAW: bool = false;
    const DATA_PARALLEL: bool = true;
    const RECORD_ALIGNED: bool = true;
    fn output(&self, b: &Batch) -> NetOutput {
        let o = self.forward(b.x.clone(), b.adj.clone(), b.mask.clone());
        NetOutput {
            logits: o.logits,
            indicators: Some(o.indicators),
            embedding: o.embedding,
            node_states: Some(o.node_states),
            parts: Some(o.parts),
        }
    }
}

impl Net for GcnGru {
    const RAW: bool = false;
    const DATA_PARALLEL: bool = true;
    fn output(&self, b: &Batch) -> NetOutput {
        let (logits, embedding) = self.forward(b.x.clone(), b.mask.clone());
        NetOutput::class_only(logits, embedding)
    }
}

/// The raw samples of a batch with absent (or dropped) nodes zeroed.
fn masked_raw(b: &Batch) -> Tensor<3> {
    let raw = b
        .raw
        .clone()
        .expect("raw-signal models are given batches with raw samples");
    let [n_b, n, _] = raw.dims();
    raw * b.mask.clone().reshape([n_b, n, 1])
}

impl Net for Wdcnn {
    const RAW: bool = true;
    const DATA_PARALLEL: bool = false;
    fn output(&self, b: &Batch) -> NetOutput {
        let (logits, embedding) = self.forward(masked_raw(b));
        NetOutput::class_only(logits, embedding)
    }
}

impl Net for CoFusionCnn {
    const RAW: bool = true;
    const DATA_PARALLEL: bool = false;
    fn output(&self, b: &Batch) -> NetOutput {
        let (logits, embedding) = self.forward(masked_raw(b), b.mask.clone());
        NetOutput::class_only(logits, embedding)
    }
}

impl Net for Tst {
    const RAW: bool = true;
    const DATA_PARALLEL: bool = false;
    fn output(&self, b: &Batch) -> NetOutput {
        let (logits, embedding) = self.forward(masked_raw(b));
        NetOutput::class_only(logits, embedding)
    }
}

/// A trained (or loaded) network of any architecture.
// One or two of these exist per run; boxing the largest would only add indirection.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub enum Network {
    /// DS-STGAT (any ablation).
    DsStgat(DsStgat),
    /// GCN-GRU baseline.
    GcnGru(GcnGru),
    /// WDCNN baseline.
    Wdcnn(Wdcnn),
    /// CoFusion-CNN baseline.
    CoFusionCnn(CoFusionCnn),
    /// Time-series transformer baseline.
    Tst(Tst),
}

/// Call `$body` with `$m` bound to the network inside `$net`.
macro_rules! with_net {
    ($net:expr, $m:ident => $body:expr) => {
        match $net {
            Network::DsStgat($m) => $body,
            Network::GcnGru($m) => $body,
            Network::Wdcnn($m) => $body,
            Network::CoFusionCnn($m) => $body,
            Network::Tst($m) => $body,
        }
    };
}

impl Network {
    /// A fresh network of `cfg.arch` for `classes` classes on `device`.
    pub fn init(cfg: &TrainConfig, classes: usize, device: &Device) -> Result<Self> {
        let n = cfg.node_set()?.count();
        Ok(match cfg.arch()? {
            Arch::DsStgat => Self::DsStgat(cfg.model_config(classes).init(device)),
            Arch::GcnGru => Self::GcnGru(GcnGru::new(FEATURES, cfg.hidden, classes, device)),
            Arch::Wdcnn => Self::Wdcnn(Wdcnn::new(n, classes, device)),
            Arch::CoFusionCnn => Self::CoFusionCnn(CoFusionCnn::new(n, classes, device)),
            Arch::Tst => Self::Tst(Tst::new(n, classes, device)),
        })
    }

    /// The network with the DS-STGAT's defect-line vote for `classes` under the
    /// feature normalization `norm` ([`DsStgat::with_line_vote`]); the baselines have
    /// none.
    ///
    /// # Errors
    /// More classes than the vote holds.
    pub fn with_line_vote(self, norm: &FeatureNorm, classes: &[String]) -> Result<Self> {
        Ok(match self {
            Self::DsStgat(m) => Self::DsStgat(m.with_line_vote(norm, classes)?),
            other => other,
        })
    }

    /// Whether the network reads raw samples.
    pub fn raw(&self) -> bool {
        fn raw_of<M: Net>(_: &M) -> bool {
            M::RAW
        }
        with_net!(self, m => raw_of(m))
    }

    /// Inference copy (`Module::valid`).
    pub fn valid(&self) -> Self {
        match self {
            Self::DsStgat(m) => Self::DsStgat(m.valid()),
            Self::GcnGru(m) => Self::GcnGru(m.valid()),
            Self::Wdcnn(m) => Self::Wdcnn(m.valid()),
            Self::CoFusionCnn(m) => Self::CoFusionCnn(m.valid()),
            Self::Tst(m) => Self::Tst(m.valid()),
        }
    }

    /// Forward pass.
    pub fn output(&self, b: &Batch) -> NetOutput {
        with_net!(self, m => m.output(b))
    }

    /// Parameters.
    pub fn num_params(&self) -> usize {
        with_net!(self, m => m.num_params())
    }

    /// Save the weights (burnpack).
    pub fn save(&self, path: &Path) -> Result<()> {
        with_net!(self, m => m.clone().save_file(path))
            .with_context(|| format!("cannot write {}", path.display()))
    }

    /// Load weights saved by [`Network::save`] into this (freshly initialized) network.
    pub fn load(self, path: &Path) -> Result<Self> {
        let ctx = || format!("cannot load {}", path.display());
        Ok(match self {
            Self::DsStgat(m) => Self::DsStgat(m.try_load_file(path).with_context(ctx)?),
            Self::GcnGru(m) => Self::GcnGru(m.try_load_file(path).with_context(ctx)?),
            Self::Wdcnn(m) => Self::Wdcnn(m.try_load_file(path).with_context(ctx)?),
            Self::CoFusionCnn(m) => Self::CoFusionCnn(m.try_load_file(path).with_context(ctx)?),
            Self::Tst(m) => Self::Tst(m.try_load_file(path).with_context(ctx)?),
        })
    }
}
