//! `pumptwin train`: train a network on a protocol's split, evaluate it, and write
//! the run's files (config, weights, normalization, history, metrics, figures).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use burn::config::Config;
use burn::module::Module;
use burn::tensor::Device;

use pumptwin_data::windows::{Protocol, WindowConfig};
use pumptwin_trainer::dataset::{Corpus, NodeSet, DERIVED_NODES, NODES};
use pumptwin_trainer::metrics::MetricsReport;
use pumptwin_trainer::physics::PhysicsEmbedding;
use pumptwin_trainer::training::{
    build_protocol, evaluate_network, load_corpus, physics_init, read_config, train, value_name,
    write_json, Ablation, Arch, Network, SavedNorms, TrainConfig, ARCH, CONFIG_FILE, HEADS_FILE,
    HISTORY_FILE, METRICS_FILE, MODEL_FILE, NORMS_FILE,
};

/// `pumptwin train`: train the DS-STGAT on a protocol and evaluate it.
#[derive(Debug, Clone, clap::Args)]
pub struct TrainArgs {
    /// Data directory holding MANIFEST.tsv (e.g. the CWRU set).
    #[arg(long)]
    pub data: PathBuf,
    /// Evaluation protocol.
    #[arg(long, value_enum, default_value = "time-block")]
    pub protocol: Protocol,
    /// Output directory (config.json, model.bpk, normalization.json, history.json,
    /// metrics.json).
    #[arg(long)]
    pub out: PathBuf,
    /// Start from this config.json instead of the defaults (flags override it).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Epochs (default: the config's).
    #[arg(long)]
    pub epochs: Option<usize>,
    /// Seed (default: the config's, 42).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Skip the per-epoch test accuracy (saves a forward pass over the test side).
    #[arg(long)]
    pub no_monitor: bool,
    /// Architecture.
    #[arg(long, value_enum, default_value = "dsstgat")]
    pub arch: Arch,
    /// DS-STGAT ablation.
    #[arg(long, value_enum, default_value = "none")]
    pub ablation: Ablation,
    /// Node layout: the measured DE/FE/BA sensors, or those plus the paper's derived
    /// temperature and pressure nodes (section 6.2; float models only, reported
    /// separately).
    #[arg(long, value_enum, default_value = "measured")]
    pub nodes: NodeSet,
    /// Cache of the closed loop's per-record Θ fits (F_map's targets).
    #[arg(long, default_value = "out/cache/theta")]
    pub theta_cache: PathBuf,
    /// Skip the PNG figures.
    #[arg(long)]
    pub no_figures: bool,
}

pub(crate) fn print_report(report: &MetricsReport) {
    eprintln!(
        "test: accuracy {:.2} %, fault-only {:.2} %, precision_macro {:.4}, \
         recall_macro {:.4}, f1_weighted {:.4}",
        100.0 * report.accuracy,
        100.0 * report.fault_only_accuracy,
        report.precision_macro,
        report.recall_macro,
        report.f1_weighted
    );
    eprintln!("confusion (rows = true): {:?}", report.confusion);
    let curve: Vec<String> = report
        .noise
        .iter()
        .map(|p| format!("{} dB {:.1} %", p.snr_db, 100.0 * p.accuracy))
        .collect();
    eprintln!("noise: {}", curve.join(", "));
    let masked: Vec<String> = report
        .node_masked
        .iter()
        .map(|p| format!("{} {:.1} %", p.node, 100.0 * p.fault_only_accuracy))
        .collect();
    eprintln!(
        "fault-only accuracy with one node masked: {}",
        masked.join(", ")
    );
}

/// The shaft speeds (rpm) of the records with training windows in `data`'s split.
fn training_rpms(corpus: &Corpus, protocol: Protocol) -> Result<Vec<f32>> {
    let split = corpus.split(protocol, &WindowConfig::default())?;
    let mut rpms: Vec<f32> = split
        .train
        .iter()
        .map(|(w, _)| corpus.records[w.record].shaft_hz * 60.0)
        .collect();
    rpms.sort_by(f32::total_cmp);
    rpms.dedup_by(|a, b| (*a - *b).abs() < 20.0);
    Ok(rpms)
}

/// Run `pumptwin train`.
pub fn run_train(args: &TrainArgs) -> Result<()> {
    let mut cfg = match &args.config {
        Some(path) => read_config(path)?,
        None => TrainConfig::new(),
    };
    if let Some(e) = args.epochs {
        cfg.epochs = e;
    }
    if let Some(s) = args.seed {
        cfg.seed = s;
    }
    cfg.arch = value_name(&args.arch);
    cfg.ablation = value_name(&args.ablation);
    cfg.nodes = value_name(&args.nodes);
    if cfg.arch != ARCH && cfg.ablation != "none" {
        bail!(
            "ablations apply to the DS-STGAT only (got --arch {})",
            cfg.arch
        );
    }
    match args.nodes {
        NodeSet::Measured => train_with(args, cfg, NODES),
        NodeSet::Derived => train_with(args, cfg, DERIVED_NODES),
    }
}

/// `pumptwin train` for the nodes `nodes`.
fn train_with<const N: usize>(
    args: &TrainArgs,
    mut cfg: TrainConfig,
    nodes: [&'static str; N],
) -> Result<()> {
    let corpus = load_corpus(&args.data)?;
    // Eq. 9: the simulated responses at the training records' speeds give the edge
    // prior (and, below, the pre-training set).
    let embedding = if cfg.uses_physics_embedding() {
        let t0 = Instant::now();
        let rpms = training_rpms(&corpus, args.protocol)?;
        let emb = PhysicsEmbedding::build_for(&rpms, cfg.seed, &nodes)?;
        eprintln!(
            "physics embedding: {} simulated windows at {} speeds in {:.1} s; \
             edge prior P ({}) = {:.3?}",
            emb.windows.len(),
            rpms.len(),
            t0.elapsed().as_secs_f64(),
            nodes.join(", "),
            emb.prior
        );
        cfg.graph_prior = emb.prior.iter().flatten().copied().collect();
        Some(emb)
    } else {
        cfg.graph_prior.clear();
        None
    };
    cfg.graph_static = cfg.ablation == "static-graph";
    let mut data = build_protocol(&corpus, args.protocol, None, cfg.graph_config(), nodes)?;
    cfg.protocol = args.protocol.name().to_string();
    cfg.classes = data.classes().to_vec();
    let mut norms = SavedNorms::new(&data.norm, &data.indicator_norm);
    if cfg.uses_coadaptation() {
        // The closed loop's Θ per training record: F_map's targets (eq. 10 → 23–24).
        let t0 = Instant::now();
        let thetas =
            pumptwin_trainer::physics::record_thetas(&corpus, &data.split, &args.theta_cache)?;
        let (mean, std) = pumptwin_trainer::physics::theta_norm(&thetas);
        data.train.attach_theta(&thetas, &mean, &std);
        eprintln!(
            "co-adaptation: Θ fitted by the closed loop for {} training records in {:.1} s \
             (cache {}); mean Θ = {:.3?}",
            thetas.len(),
            t0.elapsed().as_secs_f64(),
            args.theta_cache.display(),
            mean
        );
        norms.theta_names = pumptwin_trainer::physics::THETA_NAMES
            .iter()
            .map(|s| s.to_string())
            .collect();
        norms.theta_mean = mean.to_vec();
        norms.theta_std = std.to_vec();
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    cfg.save(args.out.join(CONFIG_FILE))
        .context("cannot write config.json")?;
    write_json(&args.out.join(NORMS_FILE), &norms)?;
    let n_params = Network::init(&cfg, cfg.classes.len(), &Device::flex())?.num_params();
    let lr_end = cfg.learning_rate * cfg.final_lr_fraction;
    eprintln!(
        "training {} ({n_params} parameters) for {} epochs, batch {}, \
         lr {} -> {lr_end} (cosine), seed {}",
        cfg.report_name(),
        cfg.epochs,
        cfg.batch_size,
        cfg.learning_rate,
        cfg.seed
    );
    let physics = match &embedding {
        Some(emb) => Some(physics_init(emb, &data)?),
        None => None,
    };
    let outcome = train(&cfg, &data, physics.as_ref(), !args.no_monitor, &mut |s| {
        let test = s
            .test_accuracy
            .map_or_else(String::new, |a| format!("  test acc {:6.2} %", 100.0 * a));
        eprintln!(
            "epoch {:>3}/{}  loss {:.4} (ce {:.4}, ind {:.4}, phy {:.4}, map {:.4}, \
             rec {:.4})  train acc {:6.2} %{test}  {:.2} s",
            s.epoch,
            cfg.epochs,
            s.loss,
            s.cross_entropy,
            s.indicator_mse,
            s.spectral_loss,
            s.theta_loss,
            s.record_alignment,
            100.0 * s.train_accuracy,
            s.seconds
        );
    })?;
    let epoch_mean = outcome.history.iter().map(|s| s.seconds).sum::<f64>()
        / outcome.history.len().max(1) as f64;
    eprintln!(
        "trained in {:.1} s ({:.2} s per epoch of optimizer steps)",
        outcome.train_seconds, epoch_mean
    );
    outcome.network.save(&args.out.join(MODEL_FILE))?;
    if let Some(h) = &outcome.heads {
        h.clone()
            .save_file(args.out.join(HEADS_FILE))
            .context("cannot write physics_heads.bpk")?;
    }
    write_json(&args.out.join(HISTORY_FILE), &outcome.history)?;
    let plain = Device::flex();
    // The figures are those of the saved weights as `eval` and `predict` load them
    // (for batch-norm baselines the live module after `valid()` and the reloaded one
    // differ slightly: burn keeps running statistics per thread).
    let net = Network::init(&cfg, cfg.classes.len(), &plain)?
        .load(&args.out.join(MODEL_FILE))?
        .valid()
        .with_line_vote(&data.norm, data.classes())?;
    let heads = outcome.heads.as_ref().map(Module::valid);
    let (report, inference) = evaluate_network(
        &net,
        heads.as_ref(),
        &cfg,
        norms.theta(),
        &data,
        &corpus,
        Some(outcome.train_seconds),
        &plain,
    )?;
    write_json(&args.out.join(METRICS_FILE), &report)?;
    print_report(&report);
    if !args.no_figures {
        pumptwin_trainer::figures::run_figures(
            &args.out,
            &report,
            &outcome.history,
            &inference,
            &data,
        )?;
    }
    eprintln!("wrote {}", args.out.display());
    Ok(())
}
