//! The training configuration (`config.json`): architecture, ablation, node set and
//! hyper-parameters, and the run names reports use.

use anyhow::Result;
use burn::config::Config;

use super::loss::LAMBDA_RECORD;
use crate::dataset::{NodeSet, FEATURES, N_INDICATORS, N_NODES};
use crate::model::DsStgatConfig;
use pumptwin_core::graph::GraphConfig;

/// Architecture name of the DS-STGAT in reports.
pub const ARCH: &str = "dsstgat";

/// The name of a run in reports and in `compare`'s run folders: the architecture, with
/// the ablation if any (`dsstgat-no-coadapt`), and `+derived-nodes` with the
/// derived-node layout.
pub fn run_name(arch: &str, ablation: &str, nodes: &str) -> String {
    let mut name = if ablation == "none" {
        arch.to_string()
    } else {
        format!("{arch}-{ablation}")
    };
    if nodes == "derived" {
        name.push_str("+derived-nodes");
    }
    name
}

/// Default of [`TrainConfig::node_dropout`].
///
/// Checked on the development protocols (`SRC=trainer/src/training.rs
/// PROTOCOLS="time-block-dev cross-load-dev0" bash scripts/dev-sweep.sh NODE_DROPOUT
/// "0.4" "42 7 1 3"`, four seeds, score = mean of clean, 0 dB and −4 dB): 0.4 → 87.5
/// against 89.9 at 0.2 (clean `cross-load-dev0` 88.9 against 93.3) with the pooling
/// over every node, and 90.9 against 91.8 with the readout at the source node
/// (`out/dev-sweep/NODE_DROPOUT/{allnodes,readout}/`). Masking more often does not make
/// the network lean less on the node whose response moves with load; it stays at 0.2,
/// which is enough to break the "BA missing ⇒ normal" shortcut.
pub const NODE_DROPOUT: f64 = 0.2;

/// Default of [`TrainConfig::pretrain_epochs`].
pub const PRETRAIN_EPOCHS: usize = 15;

/// The architectures `pumptwin train --arch` builds (paper §6.3.1 and WDCNN).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Arch {
    /// DS-STGAT (this paper).
    #[value(name = "dsstgat")]
    DsStgat,
    /// GCN + GRU on a static graph.
    #[value(name = "gcn-gru")]
    GcnGru,
    /// Multi-branch 1-D CNN with weighted fusion.
    #[value(name = "cofusion-cnn")]
    CoFusionCnn,
    /// Time-series transformer.
    #[value(name = "tst")]
    Tst,
    /// Wide first-layer kernel CNN (Zhang et al. 2017).
    #[value(name = "wdcnn")]
    Wdcnn,
}

/// The DS-STGAT ablations (paper §6.3.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Ablation {
    /// The full model: physics embedding, co-adaptation, dynamic graph.
    #[value(name = "none")]
    None,
    /// No `L_phy` and no F_map (eqs. 10–11, 23–24 switched off).
    #[value(name = "no-coadapt")]
    NoCoadapt,
    /// No simulated pre-training and a uniform edge prior (eq. 9 switched off).
    #[value(name = "no-physics")]
    NoPhysics,
    /// A fixed adjacency (the physics prior alone, β = 1) instead of eqs. 1–2.
    #[value(name = "static-graph")]
    StaticGraph,
}

/// The name of a clap value (`Arch`, `Ablation`).
pub fn value_name<T: clap::ValueEnum>(v: &T) -> String {
    v.to_possible_value()
        .map_or_else(String::new, |p| p.get_name().to_string())
}

/// Hyper-parameters of a training run; saved as `config.json` beside the weights.
#[derive(Config, Debug)]
pub struct TrainConfig {
    /// Seed of the initialization, the shuffles and the evaluation noise.
    #[config(default = 42)]
    pub seed: u64,
    /// Passes over the training windows.
    #[config(default = 60)]
    pub epochs: usize,
    /// Windows per optimizer step.
    #[config(default = 64)]
    pub batch_size: usize,
    /// Windows per forward pass at evaluation.
    #[config(default = 256)]
    pub eval_batch_size: usize,
    /// Adam learning rate at the start (cosine decay, see `final_lr_fraction`).
    #[config(default = 1e-3)]
    pub learning_rate: f64,
    /// Learning rate at the last step as a fraction of `learning_rate`: the rate
    /// follows a half cosine from `learning_rate` down to this (1.0 = constant).
    #[config(default = 0.05)]
    pub final_lr_fraction: f64,
    /// Hidden width `H` of the embedding, GAT and GRU.
    #[config(default = 32)]
    pub hidden: usize,
    /// Width of `Z` (eq. 12).
    #[config(default = 16)]
    pub compressed: usize,
    /// Weight `λ_ind` of the indicator MSE.
    #[config(default = 0.1)]
    pub lambda_indicator: f64,
    /// Weight `λ_reg` of `‖θ‖²` (eq. 15).
    #[config(default = 5e-5)]
    pub lambda_reg: f64,
    /// Class-weighted cross-entropy (`w_c = n / (C·n_c)`); plain CE when false.
    #[config(default = true)]
    pub class_weighted: bool,
    /// Node dropout during training: each present node of a training window is masked
    /// with this probability (at least one node is kept). It breaks the acquisition
    /// shortcut "BA channel missing ⇒ normal" (only the normal record lacks BA) and
    /// teaches the model to diagnose from any subset of its sensors, as a gateway
    /// with a failed channel must.
    #[config(default = "NODE_DROPOUT")]
    pub node_dropout: f64,
    /// Architecture (`dsstgat`, `gcn-gru`, `cofusion-cnn`, `tst`, `wdcnn`).
    #[config(default = "String::from(\"dsstgat\")")]
    pub arch: String,
    /// DS-STGAT ablation (`none`, `no-coadapt`, `no-physics`, `static-graph`).
    #[config(default = "String::from(\"none\")")]
    pub ablation: String,
    /// Weight `λ_phy` of the spectral consistency loss (eq. 11).
    #[config(default = 0.1)]
    pub lambda_phy: f64,
    /// Weight of F_map's Θ loss (eqs. 23–24).
    #[config(default = 0.1)]
    pub lambda_map: f64,
    /// Weight `λ_rec` of the record-alignment term ([`record_alignment`]; DS-STGAT
    /// only, 0 = off).
    #[config(default = "LAMBDA_RECORD")]
    pub lambda_record: f64,
    /// Epochs of pre-training on the simulated windows (eq. 9).
    #[config(default = "PRETRAIN_EPOCHS")]
    pub pretrain_epochs: usize,
    /// Graph prior `P`, `N·N` row-major (empty: the uniform prior). Filled in by
    /// `train` from the physics embedding.
    #[config(default = "Vec::new()")]
    pub graph_prior: Vec<f32>,
    /// Static graph (`β = 1`: the prior alone).
    #[config(default = false)]
    pub graph_static: bool,
    /// Protocol trained on (filled in by `train`).
    #[config(default = "String::from(\"time-block\")")]
    pub protocol: String,
    /// Class names in label order (filled in by `train`).
    #[config(default = "Vec::new()")]
    pub classes: Vec<String>,
    /// Node layout (`measured`: DE, FE, BA; `derived`: plus the paper's derived
    /// temperature and pressure nodes, [`pumptwin_data::derived`]).
    #[config(default = "String::from(\"measured\")")]
    pub nodes: String,
}

impl TrainConfig {
    /// The learning rate at optimizer step `step` of `total` (cosine decay).
    pub fn learning_rate_at(&self, step: usize, total: usize) -> f64 {
        let lo = self.learning_rate * self.final_lr_fraction;
        let progress = if total > 1 {
            step as f64 / (total - 1) as f64
        } else {
            0.0
        };
        lo + 0.5 * (self.learning_rate - lo) * (1.0 + (std::f64::consts::PI * progress).cos())
    }

    /// The architecture.
    pub fn arch(&self) -> Result<Arch> {
        <Arch as clap::ValueEnum>::from_str(&self.arch, false)
            .map_err(|_| anyhow::anyhow!("unknown architecture {:?}", self.arch))
    }

    /// The ablation.
    pub fn ablation(&self) -> Result<Ablation> {
        <Ablation as clap::ValueEnum>::from_str(&self.ablation, false)
            .map_err(|_| anyhow::anyhow!("unknown ablation {:?}", self.ablation))
    }

    /// The node layout.
    pub fn node_set(&self) -> Result<NodeSet> {
        <NodeSet as clap::ValueEnum>::from_str(&self.nodes, false)
            .map_err(|_| anyhow::anyhow!("unknown node layout {:?}", self.nodes))
    }

    /// The name written to reports ([`run_name`]).
    pub fn report_name(&self) -> String {
        run_name(&self.arch, &self.ablation, &self.nodes)
    }

    /// Whether eq. 9 applies (DS-STGAT, not `no-physics`).
    pub fn uses_physics_embedding(&self) -> bool {
        self.arch == ARCH && self.ablation != "no-physics"
    }

    /// Whether the co-adaptation heads apply (DS-STGAT, not `no-coadapt`).
    pub fn uses_coadaptation(&self) -> bool {
        self.arch == ARCH && self.ablation != "no-coadapt"
    }

    /// The graph construction of this run (dynamic on the stored prior, or static).
    pub fn graph_config<const N: usize>(&self) -> GraphConfig<N> {
        let mut prior = [[1.0f32; N]; N];
        if self.graph_prior.len() == N * N {
            for (k, v) in self.graph_prior.iter().enumerate() {
                prior[k / N][k % N] = *v;
            }
        }
        if self.graph_static {
            GraphConfig::static_prior(prior)
        } else {
            GraphConfig {
                prior,
                ..GraphConfig::uniform()
            }
        }
    }

    /// The model's dimensions for `classes` classes.
    pub fn model_config(&self, classes: usize) -> DsStgatConfig {
        DsStgatConfig::new(FEATURES, classes)
            .with_hidden(self.hidden)
            .with_compressed(self.compressed)
            .with_indicators(N_INDICATORS)
            .with_nodes(self.node_set().map_or(N_NODES, NodeSet::count))
    }
}
