//! `pumptwin eval`: evaluate a trained burn model or an int8 model file on a
//! protocol's test side (and, for a burn DS-STGAT, write its parts' logits).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use burn::module::Module;
use burn::tensor::{Device, Tensor};
use pumptwin_core::dsstgat::{LineVote, MODEL_CLASSES};
use pumptwin_core::features::FeatureNorm;
use serde::Serialize;

use crate::train::print_report;
use pumptwin_data::windows::Protocol;
use pumptwin_trainer::dataset::{
    Corpus, Dataset, IndicatorNorm, NodeSet, ProtocolData, DERIVED_NODES, NODES, N_NODES,
};
use pumptwin_trainer::model::{DsStgat, PhysicsHeads};
use pumptwin_trainer::physics::{N_THETA, SPEC_BANDS};
use pumptwin_trainer::training::{
    evaluate_network, load_protocol, load_trained_config, write_json, Batch, EpochStats, Network,
    SavedNorms, TrainConfig, HEADS_FILE, HISTORY_FILE, METRICS_FILE, NORMS_FILE,
};

/// The DS-STGAT's parts on one copy of a test side: `[W][C]` logits of each.
#[derive(Debug, Clone, Serialize)]
pub struct ExpertCondition {
    /// `null` for the clean test side, else the SNR of the added noise.
    pub snr_db: Option<f32>,
    /// `W_o Z + b_o`, the network's logits.
    pub network: Vec<Vec<f32>>,
    /// The sensor head's spectral expert (before its weight `γ`).
    pub spectral: Vec<Vec<f32>>,
    /// The sensor head's kinematic expert (before its weight `γ_k`).
    pub kinematic: Vec<Vec<f32>>,
    /// The defect-line vote, added with weight 1 (empty for a model without one).
    pub line_vote: Vec<Vec<f32>>,
    /// Node 0's window-mean envelope lines in dB over the envelope median (BPFO, BPFI,
    /// BSF: the vote's inputs, `pumptwin_core::dsstgat::LINE_VOTE_FEATURES`), `null`
    /// where node 0 is absent: what a study of the vote's threshold and weight reads.
    pub node0_lines_db: Vec<Option<[f32; 3]>>,
}

/// `pumptwin eval --experts`: what each of the DS-STGAT's parts says about every test
/// window, the data of a study of how they are weighed (`logits = network +
/// γ·spectral + γ_k·kinematic + vote`, [`pumptwin_trainer::model::SENSOR_HEAD_WEIGHT`],
/// [`pumptwin_trainer::model::KINEMATIC_HEAD_WEIGHT`], the core's `LineVote`).
#[derive(Debug, Clone, Serialize)]
pub struct ExpertLogits {
    /// Protocol of the test side.
    pub protocol: String,
    /// Class names, the logits' column order.
    pub classes: Vec<String>,
    /// True class per test window.
    pub label: Vec<usize>,
    /// The weights the model was built with: `[1, γ, γ_k]` (the vote adds with 1).
    pub weights: [f32; 3],
    /// The clean test side, then one copy per SNR of the noise curve (the noise of
    /// `metrics.json`: same seeds).
    pub conditions: Vec<ExpertCondition>,
}

/// The three parts' logits of `model` over `ds` (see [`ExpertLogits`]), with the
/// vote `line_vote` (the model's) and its inputs.
fn expert_condition(
    model: &DsStgat,
    line_vote: &LineVote<MODEL_CLASSES>,
    ds: &Dataset,
    snr_db: Option<f32>,
    batch_size: usize,
    device: &Device,
) -> ExpertCondition {
    let rows = |t: Tensor<2>| -> Vec<Vec<f32>> {
        let c = t.dims()[1];
        let v = t.into_data().try_into_vec::<f32>().unwrap_or_default();
        v.chunks(c.max(1)).map(<[f32]>::to_vec).collect()
    };
    let mut out = ExpertCondition {
        snr_db,
        network: Vec::new(),
        spectral: Vec::new(),
        kinematic: Vec::new(),
        line_vote: Vec::new(),
        node0_lines_db: Vec::new(),
    };
    let idx: Vec<usize> = (0..ds.len()).collect();
    for chunk in idx.chunks(batch_size.max(1)) {
        let b = Batch::new(ds, chunk, device);
        let head = rows(pumptwin_trainer::model::sensor_head_input(
            b.x.clone(),
            b.mask.clone(),
        ));
        let o = model.forward(b.x, b.adj, b.mask);
        let (network, spectral, kinematic) = o.parts;
        out.network.extend(rows(network));
        out.spectral.extend(rows(spectral));
        out.kinematic.extend(rows(kinematic));
        if let Some(v) = o.vote {
            out.line_vote.extend(rows(v));
        }
        for (row, &w) in head.iter().zip(chunk) {
            out.node0_lines_db
                .push(ds.mask[w * ds.nodes].then(|| line_vote.lines_db(row)));
        }
    }
    out
}

/// Write [`ExpertLogits`] of a burn DS-STGAT on `data`'s test side to `path`.
fn write_experts<const N: usize>(
    path: &Path,
    net: &Network,
    cfg: &TrainConfig,
    data: &ProtocolData<N>,
    corpus: &Corpus,
    device: &Device,
) -> Result<()> {
    let Network::DsStgat(model) = net else {
        bail!(
            "--experts needs a DS-STGAT model (this one is {})",
            cfg.report_name()
        );
    };
    let line_vote = model
        .line_vote
        .as_ref()
        .context("--experts needs the model's defect-line vote (DsStgat::with_line_vote)")?;
    let batch = cfg.eval_batch_size;
    let mut conditions = vec![expert_condition(
        model, line_vote, &data.test, None, batch, device,
    )];
    for k in 0..pumptwin_trainer::metrics::NOISE_SNR_DB.len() {
        let spec = pumptwin_trainer::metrics::noise_spec(cfg.seed, k);
        let noisy = data
            .noisy_test(corpus, spec)
            .with_context(|| format!("cannot featurize the test side at {} dB", spec.snr_db))?;
        conditions.push(expert_condition(
            model,
            line_vote,
            &noisy,
            Some(spec.snr_db),
            batch,
            device,
        ));
    }
    let report = ExpertLogits {
        protocol: data.protocol.name().to_string(),
        classes: data.classes().to_vec(),
        label: data.test.label.iter().map(|&l| l as usize).collect(),
        weights: [
            1.0,
            pumptwin_trainer::model::SENSOR_HEAD_WEIGHT,
            pumptwin_trainer::model::KINEMATIC_HEAD_WEIGHT,
        ],
        conditions,
    };
    let text = serde_json::to_string(&report)?;
    std::fs::write(path, text + "\n")
        .with_context(|| format!("cannot write {}", path.display()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

/// `pumptwin eval`: evaluate a trained model on a protocol's test side.
#[derive(Debug, Clone, clap::Args)]
pub struct EvalArgs {
    /// The weights (`model.bpk`); `config.json` (and `normalization.json`, if
    /// present) are read from the same directory.
    #[arg(long)]
    pub model: PathBuf,
    /// Data directory holding MANIFEST.tsv.
    #[arg(long)]
    pub data: PathBuf,
    /// Evaluation protocol.
    #[arg(long, value_enum)]
    pub protocol: Protocol,
    /// Output directory for metrics.json and the figures.
    #[arg(long)]
    pub out: PathBuf,
    /// Skip the PNG figures.
    #[arg(long)]
    pub no_figures: bool,
    /// Also write the DS-STGAT's three parts' logits (network, spectral expert,
    /// kinematic expert), its defect-line vote and node 0's defect lines per test
    /// window, clean and at every SNR of the noise curve, to this JSON file
    /// (`ExpertLogits`; read by `scripts/expert_fusion.py`). Burn DS-STGAT models
    /// only.
    #[arg(long)]
    pub experts: Option<PathBuf>,
}

/// Run `pumptwin eval`: a burn model (`model.bpk`, any architecture) or an int8 model
/// file.
pub fn run_eval(args: &EvalArgs) -> Result<()> {
    pumptwin_trainer::export::check_model_path(&args.model)?;
    if pumptwin_trainer::export::is_model_file(&args.model) {
        return run_eval_int8(args);
    }
    let (cfg, norms) = load_trained_config(&args.model)?;
    if norms.is_none() {
        eprintln!(
            "no {NORMS_FILE} beside the model: refitting the normalization \
             on the {} training windows",
            args.protocol
        );
    }
    match cfg.node_set()? {
        NodeSet::Measured => eval_with(args, &cfg, norms, NODES),
        NodeSet::Derived => eval_with(args, &cfg, norms, DERIVED_NODES),
    }
}

/// `pumptwin eval` of a burn model whose nodes are `nodes`.
fn eval_with<const N: usize>(
    args: &EvalArgs,
    cfg: &TrainConfig,
    norms: Option<(FeatureNorm, IndicatorNorm)>,
    nodes: [&'static str; N],
) -> Result<()> {
    let saved = read_saved_norms(&args.model);
    let (corpus, data) =
        load_protocol(&args.data, args.protocol, norms, cfg.graph_config(), nodes)?;
    if !cfg.classes.is_empty() && cfg.classes != data.classes() {
        bail!(
            "the model was trained on classes {:?} ({}), protocol {} has {:?}",
            cfg.classes,
            cfg.protocol,
            args.protocol,
            data.classes()
        );
    }
    let plain = Device::flex();
    // `valid()`: inference mode (batch norm on its running statistics, no dropout).
    let net = Network::init(cfg, data.classes().len(), &plain)?
        .load(&args.model)?
        .valid()
        .with_line_vote(&data.norm, data.classes())?;
    let heads_path = args
        .model
        .parent()
        .unwrap_or(Path::new("."))
        .join(HEADS_FILE);
    let heads = if heads_path.is_file() {
        Some(
            PhysicsHeads::new(cfg.hidden, SPEC_BANDS, N_THETA, &plain)
                .try_load_file(&heads_path)
                .with_context(|| format!("cannot load {}", heads_path.display()))?,
        )
    } else {
        None
    };
    let (report, inference) = evaluate_network(
        &net,
        heads.as_ref(),
        cfg,
        saved.as_ref().and_then(SavedNorms::theta),
        &data,
        &corpus,
        None,
        &plain,
    )?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    write_json(&args.out.join(METRICS_FILE), &report)?;
    print_report(&report);
    if !args.no_figures {
        let dir = args.model.parent().unwrap_or(Path::new("."));
        let history: Vec<EpochStats> = std::fs::read_to_string(dir.join(HISTORY_FILE))
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .unwrap_or_default();
        pumptwin_trainer::figures::run_figures(&args.out, &report, &history, &inference, &data)?;
    }
    eprintln!("wrote {}", args.out.join(METRICS_FILE).display());
    if let Some(path) = &args.experts {
        write_experts(path, &net, cfg, &data, &corpus, &plain)?;
    }
    Ok(())
}

/// `normalization.json` beside a model, if readable.
fn read_saved_norms(model: &Path) -> Option<SavedNorms> {
    let dir = model.parent().unwrap_or(Path::new("."));
    let text = std::fs::read_to_string(dir.join(NORMS_FILE)).ok()?;
    serde_json::from_str(&text).ok()
}

/// `pumptwin eval` of an int8 model file: every window through the core's integer
/// network, with the file's own normalization.
fn run_eval_int8(args: &EvalArgs) -> Result<()> {
    if args.experts.is_some() {
        bail!(
            "--experts reads the parts of a burn DS-STGAT (model.bpk); an int8 model file \
             folds them into one sensor head"
        );
    }
    let loaded = pumptwin_trainer::export::load_model_file(&args.model)?;
    let graph = loaded.file.graph_config::<N_NODES>()?;
    let (corpus, data) = load_protocol(
        &args.data,
        args.protocol,
        Some(loaded.norms()?),
        graph,
        NODES,
    )?;
    if loaded.classes() != data.classes() {
        bail!(
            "the model's classes {:?} differ from protocol {}'s {:?}",
            loaded.classes(),
            args.protocol,
            data.classes()
        );
    }
    let predictor = |ds: &Dataset| -> Result<Vec<usize>> {
        Ok(pumptwin_trainer::export::int8_outputs(&loaded.model, ds)?
            .iter()
            .map(|o| o.class)
            .collect())
    };
    let t0 = std::time::Instant::now();
    let report = pumptwin_trainer::metrics::evaluate_with(
        &predictor,
        pumptwin_trainer::export::ARCH_INT8,
        &data,
        &corpus,
        TrainConfig::new().seed,
        None,
    )?;
    eprintln!(
        "int8 inference of {} windows (clean + {} noise levels) in {:.2} s",
        data.test.len() * (1 + pumptwin_trainer::metrics::NOISE_SNR_DB.len()),
        pumptwin_trainer::metrics::NOISE_SNR_DB.len(),
        t0.elapsed().as_secs_f64()
    );
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    write_json(&args.out.join(METRICS_FILE), &report)?;
    print_report(&report);
    eprintln!("wrote {}", args.out.join(METRICS_FILE).display());
    Ok(())
}
