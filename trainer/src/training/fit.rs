//! The fit loop: physics pre-training (eq. 9's initialization of H₀), then the
//! protocol's training side in two replicas per batch, Adam on a half-cosine schedule
//! (the module docs of [`crate::training`] say why each choice).

use std::time::Instant;

use anyhow::Result;
use burn::module::Module;
use burn::optim::decay::WeightDecayConfig;
use burn::optim::{AdamConfig, GradientsAccumulator, GradientsParams};
use burn::tensor::{Device, Tensor, TensorData};
use pumptwin_core::rng::Xoshiro128pp;
use serde::Serialize;

use super::batch::{Batch, BatchParts};
use super::config::TrainConfig;
use super::inference::{accuracy, infer, normalized_weights};
use super::loss::{
    class_loss, class_weights, record_alignment, record_alignment_ops, spectral_loss, theta_loss,
};
use super::net::{Net, Network};
use crate::dataset::{Dataset, ProtocolData};
use crate::model::{DsStgat, PhysicsHeads};
use crate::physics::{PhysicsEmbedding, SIM_CLASSES};
use crate::targets::{N_THETA, SPEC_BANDS};
use pumptwin_data::featurize::WINDOW;

/// Figures of one epoch.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct EpochStats {
    /// 1-based epoch.
    pub epoch: usize,
    /// Mean total loss over the batches.
    pub loss: f64,
    /// Mean weighted cross-entropy.
    pub cross_entropy: f64,
    /// Mean indicator MSE.
    pub indicator_mse: f64,
    /// Mean `L_phy` (0 without physics heads).
    pub spectral_loss: f64,
    /// Mean F_map loss (0 without physics heads).
    pub theta_loss: f64,
    /// Mean record-alignment ratio ([`record_alignment`]; 0 when off).
    #[serde(default)]
    pub record_alignment: f64,
    /// Training accuracy over the epoch's batches (as they were predicted).
    pub train_accuracy: f64,
    /// Test accuracy after the epoch (monitoring only).
    pub test_accuracy: Option<f64>,
    /// Wall time of the epoch's optimizer steps, seconds.
    pub seconds: f64,
}

/// A trained model and how it got there.
#[derive(Debug)]
pub struct TrainOutcome {
    /// The network after the last epoch (autodiff device; `.valid()` to infer).
    pub network: Network,
    /// The co-adaptation heads (DS-STGAT without `no-coadapt`).
    pub heads: Option<PhysicsHeads>,
    /// Per-epoch figures.
    pub history: Vec<EpochStats>,
    /// Wall time of the whole loop (pre-training, steps and monitoring), seconds.
    pub train_seconds: f64,
}

/// The node mask of the windows `idx` with each present node dropped with
/// probability `p` (one present node, drawn at random, is kept if all would go).
fn dropout_mask(
    ds: &Dataset,
    idx: &[usize],
    p: f64,
    rng: &mut Xoshiro128pp,
    device: &Device,
) -> Tensor<2> {
    let mut mask = Vec::with_capacity(idx.len() * ds.nodes);
    for &k in idx {
        let present = ds.window_mask(k);
        let mut keep: Vec<bool> = present.iter().map(|&m| m && rng.uniform() >= p).collect();
        if !keep.iter().any(|&m| m) {
            let nodes: Vec<usize> = (0..ds.nodes).filter(|&i| present[i]).collect();
            if !nodes.is_empty() {
                let pick = ((rng.uniform() * nodes.len() as f64) as usize).min(nodes.len() - 1);
                keep[nodes[pick]] = true;
            }
        }
        mask.extend(keep.iter().map(|&m| if m { 1.0f32 } else { 0.0 }));
    }
    Tensor::from_data(TensorData::new(mask, [idx.len(), ds.nodes]), device)
}

/// Fisher–Yates shuffle from the seeded stream.
fn shuffle(v: &mut [usize], rng: &mut Xoshiro128pp) {
    for i in (1..v.len()).rev() {
        let j = ((u64::from(rng.next_u32()) * (i as u64 + 1)) >> 32) as usize;
        v.swap(i, j);
    }
}

/// The generic training loop: `cfg.epochs` of Adam with the cosine schedule over
/// `train`, on the autodiff `device`. With `heads`, the loss adds
/// `λ_phy·L_phy + λ_map·L_map` (eqs. 11, 23–24). `monitor` gets a test accuracy after
/// each epoch (monitoring only).
/// One replica's share of an optimizer step.
pub(super) struct ReplicaInput {
    /// Its windows as tensors (node dropout applied).
    pub(super) batch: Batch,
    /// Its windows' labels.
    pub(super) labels: Vec<i64>,
    /// Its windows' class weights, normalized over the whole batch.
    pub(super) weights: Tensor<1>,
    /// Its windows / the batch's.
    pub(super) share: f64,
    /// The record-alignment operators `(A_rec − A_cls, I − A_all)`, `[b, b]` each
    /// (see [`record_alignment_ops`]), when the term is on.
    pub(super) align: Option<(Tensor<2>, Tensor<2>)>,
}

/// What a replica gives back.
pub(super) struct ReplicaResult {
    /// Gradients of the network's parameters.
    pub(super) model_grads: GradientsParams,
    /// Gradients of the physics heads' parameters.
    pub(super) heads_grads: Option<GradientsParams>,
    /// Its part of the batch's loss terms (total, CE, indicator, spectral, Θ, record
    /// alignment).
    pub(super) sums: [f64; 6],
    /// Its correctly classified windows.
    pub(super) correct: usize,
}

/// Forward and backward of one replica. Its loss is its part of the batch's loss: the
/// CE with the batch-normalized weights as it is, the mean-type terms scaled by the
/// replica's share of the windows, so that the replicas' gradients add up to the
/// batch's (exactly for the CE and indicator terms; the spectral and Θ terms are
/// means over each replica's present nodes / known targets).
pub(super) fn replica_step<M: Net>(
    model: &M,
    heads: Option<&PhysicsHeads>,
    input: ReplicaInput,
    cfg: &TrainConfig,
) -> ReplicaResult {
    let ReplicaInput {
        batch,
        labels,
        weights,
        share,
        align,
    } = input;
    let out = model.output(&batch);
    let pred = out.logits.clone().argmax(1).into_data();
    let correct = pred
        .iter::<i64>()
        .zip(&labels)
        .filter(|(p, l)| p == *l)
        .count();
    let mut sums = [0.0f64; 6];
    let ce = class_loss(out.logits, out.parts, batch.labels.clone(), weights);
    let mut loss = ce.clone();
    sums[1] = f64::from(ce.into_scalar::<f32>());
    if let Some((between, total)) = align {
        let l_rec = record_alignment(out.embedding.clone(), between, total).mul_scalar(share);
        sums[5] = f64::from(l_rec.clone().into_scalar::<f32>());
        loss = loss + l_rec.mul_scalar(cfg.lambda_record);
    }
    if let Some(ind) = out.indicators {
        let mse = (ind - batch.indicators.clone())
            .square()
            .mean()
            .mul_scalar(share);
        sums[2] = f64::from(mse.clone().into_scalar::<f32>());
        loss = loss + mse.mul_scalar(cfg.lambda_indicator);
    }
    if let (Some(h), Some(states)) = (heads, out.node_states) {
        let (sp, th) = h.forward(out.embedding, states);
        let l_phy = spectral_loss(
            sp,
            batch.spectra.clone().expect("physics batch"),
            batch.mask.clone(),
        )
        .mul_scalar(share);
        let l_map = theta_loss(
            th,
            batch.theta.clone().expect("physics batch"),
            batch.theta_known.clone().expect("physics batch"),
        )
        .mul_scalar(share);
        sums[3] = f64::from(l_phy.clone().into_scalar::<f32>());
        sums[4] = f64::from(l_map.clone().into_scalar::<f32>());
        loss = loss + l_phy.mul_scalar(cfg.lambda_phy) + l_map.mul_scalar(cfg.lambda_map);
    }
    sums[0] = f64::from(loss.clone().into_scalar::<f32>());
    let mut grads = loss.backward();
    ReplicaResult {
        model_grads: GradientsParams::from_module(&mut grads, model),
        heads_grads: heads.map(|h| GradientsParams::from_module(&mut grads, h)),
        sums,
        correct,
    }
}

fn fit_net<M: Net>(
    mut model: M,
    mut heads: Option<PhysicsHeads>,
    cfg: &TrainConfig,
    train: &Dataset,
    classes: usize,
    device: &Device,
    monitor: &mut dyn FnMut(&M, &Option<PhysicsHeads>) -> Option<f64>,
    progress: &mut dyn FnMut(&EpochStats),
) -> (M, Option<PhysicsHeads>, Vec<EpochStats>) {
    let mut optim = AdamConfig::new()
        .with_weight_decay(Some(WeightDecayConfig::new((2.0 * cfg.lambda_reg) as f32)))
        .init();
    let weights = if cfg.class_weighted {
        class_weights(&train.label, classes)
    } else {
        vec![1.0; classes]
    };
    let parts = BatchParts {
        raw: M::RAW,
        physics: heads.is_some(),
    };
    let mut rng = Xoshiro128pp::seed_from_u64(cfg.seed);
    let mut order: Vec<usize> = (0..train.len()).collect();
    let mut history = Vec::with_capacity(cfg.epochs);
    let steps_per_epoch = train.len().div_ceil(cfg.batch_size.max(1));
    let total_steps = steps_per_epoch * cfg.epochs;
    let mut global_step = 0usize;
    for epoch in 1..=cfg.epochs {
        let t0 = Instant::now();
        shuffle(&mut order, &mut rng);
        let mut sums = [0.0f64; 6];
        let (mut steps, mut correct) = (0usize, 0usize);
        for chunk in order.chunks(cfg.batch_size.max(1)) {
            // The batch's replicas: its halves, or the whole batch (see `Net::DATA_PARALLEL`).
            let shares: Vec<&[usize]> = if !M::DATA_PARALLEL || chunk.len() < 2 {
                vec![chunk]
            } else {
                let (a, b) = chunk.split_at(chunk.len().div_ceil(2));
                vec![a, b]
            };
            // Class weights normalized over the whole batch; the node dropout drawn in
            // window order: both as for one replica.
            let w_all = normalized_weights(chunk, train, &weights);
            let mut offset = 0;
            let inputs: Vec<ReplicaInput> = shares
                .iter()
                .map(|idx| {
                    let mut batch = Batch::with_parts(train, idx, parts, device);
                    if cfg.node_dropout > 0.0 {
                        batch.mask = dropout_mask(train, idx, cfg.node_dropout, &mut rng, device);
                    }
                    let w = w_all[offset..offset + idx.len()].to_vec();
                    offset += idx.len();
                    ReplicaInput {
                        labels: idx.iter().map(|&k| train.label[k]).collect(),
                        batch,
                        weights: Tensor::from_data(TensorData::new(w, [idx.len()]), device),
                        share: idx.len() as f64 / chunk.len() as f64,
                        align: (cfg.lambda_record > 0.0 && M::RECORD_ALIGNED)
                            .then(|| record_alignment_ops(train, idx, device)),
                    }
                })
                .collect();
            let mut inputs = inputs.into_iter();
            let first = inputs.next().expect("a batch has a replica");
            let rest: Vec<ReplicaInput> = inputs.collect();
            let results: Vec<ReplicaResult> = std::thread::scope(|scope| {
                // Every further replica on its own thread with its own copy of the
                // parameters (`fork`: same parameter ids, a separate autodiff graph, so
                // the backward passes run in parallel).
                let handles: Vec<_> = rest
                    .into_iter()
                    .map(|input| {
                        let m = model.clone().fork(device);
                        let h = heads.clone().map(|h| h.fork(device));
                        scope.spawn(move || replica_step(&m, h.as_ref(), input, cfg))
                    })
                    .collect();
                let mut out = vec![replica_step(&model, heads.as_ref(), first, cfg)];
                out.extend(
                    handles
                        .into_iter()
                        .map(|h| h.join().expect("a replica thread panicked")),
                );
                out
            });
            let mut acc_model = GradientsAccumulator::<M>::new();
            let mut acc_heads = GradientsAccumulator::<PhysicsHeads>::new();
            for r in results {
                for (s, v) in sums.iter_mut().zip(r.sums) {
                    *s += v;
                }
                correct += r.correct;
                acc_model.accumulate(&model, r.model_grads);
                if let (Some(h), Some(g)) = (&heads, r.heads_grads) {
                    acc_heads.accumulate(h, g);
                }
            }
            steps += 1;
            let lr = cfg.learning_rate_at(global_step, total_steps);
            model = optim.step(lr, model, acc_model.grads());
            if let Some(h) = heads.take() {
                heads = Some(optim.step(lr, h, acc_heads.grads()));
            }
            global_step += 1;
        }
        let seconds = t0.elapsed().as_secs_f64();
        let test_accuracy = monitor(&model, &heads);
        let steps_f = steps.max(1) as f64;
        let stats = EpochStats {
            epoch,
            loss: sums[0] / steps_f,
            cross_entropy: sums[1] / steps_f,
            indicator_mse: sums[2] / steps_f,
            spectral_loss: sums[3] / steps_f,
            theta_loss: sums[4] / steps_f,
            record_alignment: sums[5] / steps_f,
            train_accuracy: correct as f64 / train.len().max(1) as f64,
            test_accuracy,
            seconds,
        };
        progress(&stats);
        history.push(stats);
    }
    (model, heads, history)
}

/// What the physics embedding (eq. 9) gives a training run.
#[derive(Debug, Clone)]
pub struct PhysicsInit {
    /// Simulated windows, featurized, normalized with the measured training
    /// normalization, graphs on the physics prior; labels index [`SIM_CLASSES`].
    pub sim: Dataset,
}

/// Build the simulated pre-training set of eq. 9 with the measured normalization.
pub fn physics_init<const N: usize>(
    emb: &PhysicsEmbedding<N>,
    data: &ProtocolData<N>,
) -> Result<PhysicsInit, crate::dataset::DatasetError> {
    let feats: Vec<_> = emb.windows.iter().map(|(w, _)| w.clone()).collect();
    let refs: Vec<(pumptwin_data::WindowRef, usize)> = emb
        .windows
        .iter()
        .map(|(w, l)| {
            (
                pumptwin_data::WindowRef {
                    record: 0,
                    start: w.start,
                    len: WINDOW,
                },
                *l,
            )
        })
        .collect();
    // Every simulated window is "record 0": the simulation has no recording sessions,
    // and the record term of the pre-training is then the between-class share
    // (`LAMBDA_RECORD`).
    let (sim, _) = crate::dataset::assemble(
        &feats,
        &[],
        &refs,
        &data.norm,
        Some(&data.indicator_norm),
        &data.graph,
    )?;
    Ok(PhysicsInit { sim })
}

/// Train `cfg.arch` on `data.train`; after each epoch `progress` gets the epoch's
/// figures (with the test accuracy when `monitor_test`). For the DS-STGAT, `physics`
/// (eq. 9) pre-trains the network on the simulated windows first, and the
/// co-adaptation heads are trained alongside unless the ablation is `no-coadapt`.
pub fn train<const N: usize>(
    cfg: &TrainConfig,
    data: &ProtocolData<N>,
    physics: Option<&PhysicsInit>,
    monitor_test: bool,
    progress: &mut dyn FnMut(&EpochStats),
) -> Result<TrainOutcome> {
    let device = Device::flex().autodiff();
    let plain = device.clone().without_autodiff();
    device.seed(cfg.seed);
    let classes = data.classes().len();
    let t_total = Instant::now();
    // No defect-line vote here: it has no weights and enters no loss, so training
    // leaves it out (it would only add a host round trip per batch); the monitored
    // accuracies are those of the trained parts, and every evaluation adds the vote
    // (`Network::with_line_vote`).
    let net = Network::init(cfg, classes, &device)?;
    let test = &data.test;
    let batch = cfg.eval_batch_size;
    macro_rules! run {
        ($model:expr, $heads:expr, $variant:ident) => {{
            let mut monitor = |m: &_, h: &Option<PhysicsHeads>| {
                monitor_test.then(|| {
                    let net = Network::$variant(Module::valid(m));
                    let hv = h.as_ref().map(Module::valid);
                    accuracy(
                        &infer(&net, hv.as_ref(), test, batch, &plain).classes,
                        &test.label,
                    )
                })
            };
            let (m, h, hist) = fit_net(
                $model,
                $heads,
                cfg,
                &data.train,
                classes,
                &device,
                &mut monitor,
                progress,
            );
            (Network::$variant(m), h, hist)
        }};
    }
    let (network, heads, history) = match net {
        Network::DsStgat(mut model) => {
            if let Some(p) = physics.filter(|_| cfg.uses_physics_embedding()) {
                // Eq. 9: H_0 from the simulated responses — the body learns to name the
                // fault hypothesis on simulated windows first.
                // The simulated windows are one record (`physics_init`), so here the
                // record term is the between-class share of the scatter: it keeps the
                // body from collapsing the windows onto the four hypotheses
                // (`LAMBDA_RECORD` has the evidence).
                let pre_cfg = TrainConfig {
                    epochs: cfg.pretrain_epochs,
                    class_weighted: false,
                    node_dropout: cfg.node_dropout,
                    ..cfg.clone()
                };
                // Its sensor head (both experts) learns the simulated hypotheses too and
                // is dropped with the classifier (the printed accuracy is of the combined
                // logits).
                let pre = pre_cfg.model_config(SIM_CLASSES.len()).init(&device);
                let mut quiet = |_: &EpochStats| {};
                let mut none = |_: &DsStgat, _: &Option<PhysicsHeads>| None;
                let (pre, _, hist) = fit_net(
                    pre,
                    None,
                    &pre_cfg,
                    &p.sim,
                    SIM_CLASSES.len(),
                    &device,
                    &mut none,
                    &mut quiet,
                );
                if let Some(last) = hist.last() {
                    eprintln!(
                        "physics embedding: pre-trained on {} simulated windows for {} epochs \
                         (fault-type accuracy {:.1} %)",
                        p.sim.len(),
                        hist.len(),
                        100.0 * last.train_accuracy
                    );
                }
                model.embed = pre.embed;
                model.gat = pre.gat;
                model.gru = pre.gru;
                model.pool = pre.pool;
                model.compress = pre.compress;
            }
            let heads = cfg
                .uses_coadaptation()
                .then(|| PhysicsHeads::new(cfg.hidden, SPEC_BANDS, N_THETA, &device));
            run!(model, heads, DsStgat)
        }
        Network::GcnGru(m) => run!(m, None, GcnGru),
        Network::Wdcnn(m) => run!(m, None, Wdcnn),
        Network::CoFusionCnn(m) => run!(m, None, CoFusionCnn),
        Network::Tst(m) => run!(m, None, Tst),
    };
    Ok(TrainOutcome {
        network,
        heads,
        history,
        train_seconds: t_total.elapsed().as_secs_f64(),
    })
}
