//! `pumptwin predict`: diagnose one recording with any model the project makes (the
//! int8 model file through the core, or a burn `model.bpk`).
//!
//! ```text
//! FILE (.mat / .csv) → channels DE, FE, BA by name (.mat variables by channel suffix)
//!   → model rate (12 kHz): integer-ratio rates anti-aliased and decimated, other
//!     rates (25.6, 44.1, 64, 97.656 kHz, ...) resampled by the same windowed sinc,
//!     the common 5 kHz band limit (data::preprocess, as in training); a speed whose
//!     defect lines the envelope cannot read refused (FeatureConfig::check_speed)
//!   → columns named DE/FE/BA in any case or as a token (`de`, `X105_DE_time`)
//!   → windows 2048 / hop 1024 → core features; a channel the file lacks is masked
//!   → the model's normalization → dynamic graphs (core, eqs. 1–3) → model
//!   → per-window class and probabilities, the record's majority class; a window
//!     with no usable sensor is `no_signal`, counted and left out of the majority
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use burn::tensor::activation::softmax;
use burn::tensor::Device;
use pumptwin_core::dsstgat::{probabilities_into, Output};
use pumptwin_core::features::FeatureNorm;
use pumptwin_core::graph::GraphConfig;

use crate::commands::{LoadedRecord, RecordArgs};
pub use crate::predict_report::{
    PhysicsWindow, Prediction, RecordDiagnosisReport, SeverityReport, WidthReport, WindowPrediction,
};
use pumptwin_core::diagnosis::{Disagreement, FaultType, Thresholds};
use pumptwin_data::diagnose::{
    diagnose_windows, segment_len, summarize_record, WindowDiagnosis, DEFAULT_REVOLUTIONS,
};
use pumptwin_data::featurize::{
    feature_config, window_features, window_graphs, MaskCounts, WindowFeatures, WINDOW,
};
use pumptwin_trainer::dataset::{
    copy_window_samples, windows_end_to_end, Dataset, NodeSet, DERIVED_NODES, NODES, N_INDICATORS,
};
use pumptwin_trainer::export::{is_model_file, load_model_file, ARCH_INT8};
use pumptwin_trainer::training::{load_trained_config, Batch, BatchParts, Network};

/// The model `predict` runs.
// One per command; boxing the burn network would only add indirection.
#[allow(clippy::large_enum_variant)]
pub enum PredictModel {
    /// An int8 model file, through the core.
    Int8(pumptwin_trainer::export::LoadedModel),
    /// A burn model (any architecture) with its config and normalization.
    Burn {
        cfg: pumptwin_trainer::training::TrainConfig,
        norm: pumptwin_core::features::FeatureNorm,
        net: Network,
    },
}

impl std::fmt::Debug for PredictModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Int8(m) => write!(f, "PredictModel::Int8({} classes)", m.classes().len()),
            Self::Burn { cfg, .. } => write!(f, "PredictModel::Burn({})", cfg.report_name()),
        }
    }
}

/// The class of a window with no usable sensor.
pub const NO_SIGNAL: &str = "no_signal";

/// Samples between window starts: the core's layout, as on the edge.
pub use pumptwin_core::layout::HOP;

/// `pumptwin predict`.
#[derive(Debug, Clone, clap::Args)]
pub struct PredictArgs {
    /// The recording.
    #[command(flatten)]
    pub record: RecordArgs,
    /// The model: an int8 model file (`.ptm`) or a burn `model.bpk` (with its
    /// `config.json` and `normalization.json` beside it).
    #[arg(long)]
    pub model: PathBuf,
    /// Write the JSON report here (default: standard output).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The JSON report on standard output even on a terminal (where the default is a
    /// table for people; piped, the output is always JSON).
    #[arg(long)]
    pub json: bool,
}

/// Run `pumptwin predict`.
pub fn run_predict(args: &PredictArgs) -> Result<()> {
    pumptwin_trainer::export::check_model_path(&args.model)?;
    let loaded = args.record.load()?;
    let model = load_model(&args.model)?;
    let report = predict(
        &loaded,
        &args.record.input.display().to_string(),
        &model,
        &args.model.display().to_string(),
    )?;
    use std::io::IsTerminal;
    if args.out.is_none() && !args.json && std::io::stdout().is_terminal() {
        print!("{}", crate::predict_text::table(&report));
    } else {
        write_report(&report, args.out.as_deref())?;
    }
    print_summary(&report);
    Ok(())
}

/// Diagnose a loaded record (`input` names it in messages and the report) with
/// `model` (`model_name` in the report): what `pumptwin predict` prints, for a
/// library caller (the Python package) too.
pub fn predict(
    loaded: &LoadedRecord,
    input: &str,
    model: &PredictModel,
    model_name: &str,
) -> Result<Prediction> {
    let LoadedRecord {
        raw,
        rec,
        rpm,
        bearing,
    } = loaded;
    let rpm = *rpm;
    let cfg = feature_config(rec.fs_hz, rpm / 60.0, bearing.orders());
    let starts: Vec<usize> = (0..)
        .map(|k| k * HOP)
        .take_while(|s| s + WINDOW <= rec.len())
        .collect();
    anyhow::ensure!(
        !starts.is_empty(),
        "{input}: {} samples at {} Hz is shorter than one window ({WINDOW})",
        rec.len(),
        rec.fs_hz
    );
    // The physics on the drive-end sensor, each window read with the shaft
    // revolutions before its end (pumptwin_data::diagnose), with the settings an int8
    // model file ships with (the core's for a burn model).
    let (thresholds, revolutions) = match model {
        PredictModel::Int8(m) => m.file.diagnosis_settings()?,
        PredictModel::Burn { .. } => (Thresholds::DEFAULT, DEFAULT_REVOLUTIONS),
    };
    let shaft_hz = rpm / 60.0;
    let segment = segment_len(rec.fs_hz, shaft_hz, revolutions, WINDOW);
    let physics = diagnose_windows(
        rec,
        "DE",
        &starts,
        WINDOW,
        segment,
        shaft_hz,
        &bearing.orders(),
        &thresholds,
    );
    let input = Input {
        input,
        model_name,
        fs_hz_input: raw.fs_hz,
        rec,
        cfg: &cfg,
        starts: &starts,
        physics: physics.as_deref(),
    };
    let device = Device::flex();
    match model {
        PredictModel::Burn { cfg, .. } if cfg.node_set()? == NodeSet::Derived => {
            predict_with(&input, model, &device, DERIVED_NODES)
        }
        _ => predict_with(&input, model, &device, NODES),
    }
}

/// The int8 model of a model file's bytes (`name` in messages).
pub fn int8_model(bytes: &[u8], name: &str) -> Result<PredictModel> {
    Ok(PredictModel::Int8(
        pumptwin_trainer::export::decode_model_file(bytes, name)?,
    ))
}

/// The int8 model file or burn model at `path`. A burn model's config (classes,
/// graph, architecture, nodes) is read once and its network loaded in inference mode
/// (batch norm on its running statistics, no dropout).
pub fn load_model(path: &Path) -> Result<PredictModel> {
    let device = &Device::flex();
    Ok(if is_model_file(path) {
        PredictModel::Int8(load_model_file(path)?)
    } else {
        let (cfg, norms) = load_trained_config(path)?;
        let (norm, _) = norms.context("no normalization.json beside the burn model")?;
        let net = Network::init(&cfg, cfg.classes.len(), device)?
            .load(path)?
            .valid()
            .with_line_vote(&norm, &cfg.classes)?;
        PredictModel::Burn { cfg, norm, net }
    })
}

/// The recording and its windows, as `predict` prepared them.
struct Input<'a> {
    /// The record's name in messages and the report.
    input: &'a str,
    /// The model's name in the report.
    model_name: &'a str,
    fs_hz_input: f32,
    rec: &'a pumptwin_data::record::Recording,
    cfg: &'a pumptwin_core::features::FeatureConfig,
    starts: &'a [usize],
    /// The physics per window start, `None` without a drive-end channel.
    physics: Option<&'a [WindowDiagnosis]>,
}

/// `predict` for a model whose nodes are `nodes`.
fn predict_with<const N: usize>(
    input: &Input<'_>,
    model: &PredictModel,
    device: &Device,
    nodes: [&'static str; N],
) -> Result<Prediction> {
    let Input {
        input,
        model_name,
        fs_hz_input,
        rec,
        cfg,
        starts,
        physics,
    } = *input;
    // Derived nodes come from each window's own samples: the windows end to end.
    let (scratch, src_starts) = feature_source(rec, starts, &nodes);
    let src = Source {
        rec: scratch.as_ref().unwrap_or(rec),
        starts: &src_starts,
    };
    let feats = featurize(&src, &nodes, cfg, starts, Path::new(input))?;
    let (classes, norm, graph) = normalization_and_graph::<N>(model)?;
    // The raw samples too, for a raw-signal baseline.
    let with_raw = matches!(model, PredictModel::Burn { net, .. } if net.raw());
    let ds = model_dataset(&feats, &norm, &graph, &src, &nodes, with_raw)?;
    let probs = class_probabilities(model, &ds, with_raw, &classes, device)?;
    let (windows, class_counts) =
        window_predictions(&feats, &probs, &classes, &nodes, rec.fs_hz, physics);
    let majority = majority_class(&class_counts);
    let diagnosis = physics.and_then(|p| record_diagnosis(p, &majority, &class_counts));
    let warnings = warnings(physics, &majority, diagnosis.as_ref());
    Ok(Prediction {
        input: input.to_string(),
        model: model_name.to_string(),
        arch: match model {
            PredictModel::Int8(_) => ARCH_INT8.to_string(),
            PredictModel::Burn { cfg, .. } => cfg.report_name(),
        },
        fs_hz_input,
        fs_hz_model: rec.fs_hz,
        resampled: (fs_hz_input - rec.fs_hz).abs() > 1e-3,
        missing_nodes: feats.missing,
        no_signal_windows: feats.no_signal,
        samples_after_last_window: starts.last().map_or(0, |s| rec.len() - (s + WINDOW)),
        windows,
        majority_class: majority,
        class_counts,
        diagnosis,
        warnings,
    })
}

/// The recording the features are read from and its window starts.
struct Source<'a> {
    /// The recording, or its windows laid end to end (derived nodes).
    rec: &'a pumptwin_data::record::Recording,
    /// Window starts in `rec`.
    starts: &'a [usize],
}

/// The windows' samples for `nodes`: with derived nodes, the windows laid end to end
/// (returned, with their starts in it), else the recording itself (`None`) at `starts`.
fn feature_source<const N: usize>(
    rec: &pumptwin_data::record::Recording,
    starts: &[usize],
    nodes: &[&'static str; N],
) -> (Option<pumptwin_data::record::Recording>, Vec<usize>) {
    if pumptwin_data::derived::any_derived(nodes) {
        (
            Some(windows_end_to_end(rec, starts, true)),
            (0..starts.len()).map(|k| k * WINDOW).collect(),
        )
    } else {
        (None, starts.to_vec())
    }
}

/// Every window's core features and which windows have a usable sensor.
struct Featurized<const N: usize> {
    /// Per window, its `start` the one in the recording.
    windows: Vec<WindowFeatures<N>>,
    /// Per window: some sensor is usable there (else it is `no_signal`).
    usable: Vec<bool>,
    /// Windows with no usable sensor.
    no_signal: usize,
    /// Model nodes the recording has no channel for.
    missing: Vec<String>,
}

/// Features of every window of `src`, with starts `starts` in the recording; refuses a
/// recording without a node channel or without a window that has a usable sensor.
fn featurize<const N: usize>(
    src: &Source<'_>,
    nodes: &[&'static str; N],
    cfg: &pumptwin_core::features::FeatureConfig,
    starts: &[usize],
    input: &Path,
) -> Result<Featurized<N>> {
    let mut counts = MaskCounts::default();
    let mut wf = window_features(src.rec, nodes, cfg, src.starts, &mut counts);
    for (w, &s) in wf.iter_mut().zip(starts) {
        w.start = s;
    }
    let missing: Vec<String> = nodes
        .iter()
        .filter(|n| src.rec.channel(n).is_none())
        .map(|n| (*n).to_string())
        .collect();
    crate::commands::ensure_a_node_channel(src.rec, nodes, input)?;
    // A window with no usable sensor (every channel missing, dead or non-finite
    // there) has nothing to diagnose: it is reported as `no_signal`, counted, and
    // left out of the model and the majority, never given a class.
    let usable: Vec<bool> = wf.iter().map(|w| w.mask.0.iter().any(|&m| m)).collect();
    let no_signal = usable.iter().filter(|&&u| !u).count();
    anyhow::ensure!(
        no_signal < wf.len(),
        "{}: no window has a usable sensor ({} windows; masked node-windows: {} missing \
         channel, {} dead or non-finite signal)",
        input.display(),
        wf.len(),
        counts.missing_channel,
        counts.rejected_signal
    );
    Ok(Featurized {
        windows: wf,
        usable,
        no_signal,
        missing,
    })
}

/// The model's classes, feature normalization and graph configuration.
fn normalization_and_graph<const N: usize>(
    model: &PredictModel,
) -> Result<(Vec<String>, FeatureNorm, GraphConfig<N>)> {
    Ok(match model {
        PredictModel::Int8(m) => {
            let (norm, _) = m.norms()?;
            (m.classes(), norm, m.file.graph_config::<N>()?)
        }
        PredictModel::Burn { cfg, norm, .. } => (cfg.classes.clone(), *norm, cfg.graph_config()),
    })
}

/// The model's input: the normalized features and dynamic graphs of the usable
/// windows (with their raw samples when `with_raw`), in window order.
fn model_dataset<const N: usize>(
    feats: &Featurized<N>,
    norm: &FeatureNorm,
    graph: &GraphConfig<N>,
    src: &Source<'_>,
    nodes: &[&'static str; N],
    with_raw: bool,
) -> Result<Dataset> {
    let mut ds = Dataset::new(N);
    for (k, w) in feats
        .windows
        .iter()
        .enumerate()
        .filter(|&(k, _)| feats.usable[k])
    {
        let (x, a) = window_graphs(w, norm, graph)
            .map_err(|e| anyhow::anyhow!("window at sample {}: {e}", w.start))?;
        ds.push(&x, &a, &w.mask.0, &[0.0; N_INDICATORS], 0, 0);
        if with_raw {
            let o = ds.raw.len();
            ds.raw.resize(o + ds.raw_per_window(), 0.0);
            copy_window_samples(src.rec, nodes, src.starts[k], &mut ds.raw[o..]);
        }
    }
    Ok(ds)
}

/// The model's class probabilities for every window of `ds`, in order.
fn class_probabilities(
    model: &PredictModel,
    ds: &Dataset,
    with_raw: bool,
    classes: &[String],
    device: &Device,
) -> Result<Vec<Vec<f32>>> {
    Ok(match model {
        PredictModel::Int8(m) => {
            let outs: Vec<Output<16, 8>> = pumptwin_trainer::export::int8_outputs(&m.model, ds)?;
            let c = m.model.classes();
            outs.iter()
                .map(|o| {
                    let mut p = vec![0.0f32; c];
                    probabilities_into(&o.logits[..c], m.model.logit_scale(), &mut p);
                    p
                })
                .collect()
        }
        PredictModel::Burn { net, .. } => {
            let parts = BatchParts {
                raw: with_raw,
                physics: false,
            };
            let idx: Vec<usize> = (0..ds.len()).collect();
            let mut out = Vec::with_capacity(ds.len());
            for chunk in idx.chunks(256) {
                let b = Batch::with_parts(ds, chunk, parts, device);
                let p = softmax(net.output(&b).logits, 1);
                let v = p
                    .into_data()
                    .try_into_vec::<f32>()
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
                out.extend(v.chunks(classes.len()).map(<[f32]>::to_vec));
            }
            out
        }
    })
}

/// Per window its class, probabilities and masked nodes (a window with no usable
/// sensor is [`NO_SIGNAL`]), and the windows per class. `probs` are the diagnosed
/// windows' probabilities in window order; `fs_hz` the recording's rate.
fn window_predictions<const N: usize>(
    feats: &Featurized<N>,
    probs: &[Vec<f32>],
    classes: &[String],
    nodes: &[&'static str; N],
    fs_hz: f32,
    physics: Option<&[WindowDiagnosis]>,
) -> (Vec<WindowPrediction>, BTreeMap<String, usize>) {
    let mut windows = Vec::with_capacity(feats.windows.len());
    let mut class_counts: BTreeMap<String, usize> = BTreeMap::new();
    let mut probs = probs.iter();
    for (k, (w, &ok)) in feats.windows.iter().zip(&feats.usable).enumerate() {
        // The diagnosed windows' probabilities come in window order.
        let (class, probabilities) = match ok.then(|| probs.next()).flatten() {
            Some(p) => {
                let best = (0..p.len()).fold(0, |b, c| if p[c] > p[b] { c } else { b });
                let class = classes.get(best).cloned().unwrap_or_default();
                *class_counts.entry(class.clone()).or_default() += 1;
                (
                    class,
                    classes.iter().cloned().zip(p.iter().copied()).collect(),
                )
            }
            _ => (NO_SIGNAL.to_string(), BTreeMap::new()),
        };
        windows.push(WindowPrediction {
            start_s: w.start as f64 / f64::from(fs_hz),
            class,
            probabilities,
            masked_nodes: nodes
                .iter()
                .zip(w.mask.0)
                .filter(|(_, m)| !m)
                .map(|(n, _)| (*n).to_string())
                .collect(),
            physics: match physics.and_then(|p| p.get(k)) {
                Some(d) => PhysicsWindow::of(d),
                None => PhysicsWindow::Failed {
                    error: "no drive-end (DE) channel".to_string(),
                },
            },
        });
    }
    (windows, class_counts)
}

/// The record's diagnosis: the physics' majority type where it is decisive (typed
/// or normal), else the network's majority class's type; `None` when the physics
/// diagnosed no window.
fn record_diagnosis(
    physics: &[WindowDiagnosis],
    majority: &str,
    class_counts: &BTreeMap<String, usize>,
) -> Option<RecordDiagnosisReport> {
    let r = summarize_record(physics)?;
    let decisive = r.fault != FaultType::NoClearSignature;
    let network = FaultType::of_class(majority);
    let (fault, decided_by, confidence) = match network {
        Some(t) if !decisive => {
            let total: usize = class_counts.values().sum();
            let share = class_counts.get(majority).copied().unwrap_or(0) as f32;
            (t, "network", share / total.max(1) as f32)
        }
        _ => (r.fault, "physics", r.confidence),
    };
    Some(RecordDiagnosisReport {
        fault_type: fault.name(),
        decided_by,
        confidence,
        severity: SeverityReport {
            impact_to_background_db: r.severity.impact_to_background_db,
            uncertainty_db: r.severity.uncertainty_db,
            unit: "dB",
            harmonic_fall_db: r.severity.harmonic_fall_db,
            harmonic_fall_uncertainty_db: r.severity.fall_uncertainty_db,
            width: (decided_by == "physics")
                .then_some(r.severity.width)
                .flatten()
                .map(WidthReport::of),
            fall_width: (decided_by == "physics")
                .then_some(r.severity.fall_width)
                .flatten()
                .map(WidthReport::of),
        },
        physics_windows: FaultType::ALL
            .iter()
            .zip(r.counts)
            .map(|(t, n)| (t.name(), n))
            .collect(),
        physics_failed_windows: r.failed,
    })
}

/// The warnings of a report (see [`Prediction::warnings`]).
fn warnings(
    physics: Option<&[WindowDiagnosis]>,
    majority: &str,
    diagnosis: Option<&RecordDiagnosisReport>,
) -> Vec<String> {
    let mut w = Vec::new();
    let Some(physics) = physics else {
        w.push(
            "no drive-end (DE) channel: no physical diagnosis, the network's class stands alone"
                .into(),
        );
        return w;
    };
    let failed = physics.iter().filter(|d| d.is_err()).count();
    if 2 * failed > physics.len() {
        w.push(format!(
            "the physics could not read {failed} of {} windows (a flat or broken drive-end sensor?)",
            physics.len()
        ));
    }
    let network = FaultType::of_class(majority);
    if let (Some(net), Some(d)) = (network, diagnosis) {
        let physics = FaultType::from_name(d.fault_type);
        match physics.and_then(|p| Disagreement::of(net, p)) {
            Some(Disagreement::Unsupported) if d.decided_by == "physics" => w.push(format!(
                "the network names {majority}, but the drive end shows no defect line and no \
                 impulsiveness: its class is not supported (a machine, speed or noise outside \
                 its training conditions?)"
            )),
            Some(Disagreement::Different) if d.decided_by == "physics" => w.push(format!(
                "the network names {majority} ({}), the physics {}: the physics' lines decide",
                net.name(),
                d.fault_type
            )),
            _ => {}
        }
    }
    w
}

/// The most frequent class (empty when no window was diagnosed).
fn majority_class(class_counts: &BTreeMap<String, usize>) -> String {
    class_counts
        .iter()
        .max_by_key(|(_, n)| **n)
        .map(|(c, _)| c.clone())
        .unwrap_or_default()
}

/// Write the JSON report to `out`, or to standard output.
fn write_report(report: &Prediction, out: Option<&Path>) -> Result<()> {
    let text = serde_json::to_string_pretty(report)? + "\n";
    match out {
        Some(path) => std::fs::write(path, &text)
            .with_context(|| format!("cannot write {}", path.display()))?,
        None => {
            use std::io::Write;
            std::io::stdout().lock().write_all(text.as_bytes())?;
        }
    }
    Ok(())
}

/// The one-line summary on standard error.
fn print_summary(report: &Prediction) {
    eprintln!(
        "{}: {} windows at {} Hz{}; majority class {} ({} of {}){}{}{}",
        report.input,
        report.windows.len(),
        report.fs_hz_model,
        if report.resampled {
            format!(" (resampled from {} Hz)", report.fs_hz_input)
        } else {
            String::new()
        },
        report.majority_class,
        report
            .class_counts
            .get(&report.majority_class)
            .unwrap_or(&0),
        report.windows.len() - report.no_signal_windows,
        if report.no_signal_windows > 0 {
            format!(
                "; {} windows with no usable sensor (no_signal, not diagnosed)",
                report.no_signal_windows
            )
        } else {
            String::new()
        },
        if report.missing_nodes.is_empty() {
            String::new()
        } else {
            format!(
                "; nodes {:?} not in the recording: masked",
                report.missing_nodes
            )
        },
        match &report.diagnosis {
            Some(d) => format!(
                "; diagnosis {} (confidence {:.2}, by {}), severity {:.1} ± {:.1} dB impact over background, harmonic fall {:.1} ± {:.1} dB{}",
                d.fault_type,
                d.confidence,
                d.decided_by,
                d.severity.impact_to_background_db,
                d.severity.uncertainty_db,
                d.severity.harmonic_fall_db,
                d.severity.harmonic_fall_uncertainty_db,
                d.severity.fall_width.map_or(String::new(), |w| format!(
                    ", width from the fall ≈ {:.1}° (an estimate biased high)",
                    w.degrees
                ))
            ),
            None => "; no physical diagnosis (no usable drive-end channel)".to_string(),
        }
    );
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
}

/// A model `predict` can run, loaded once: an int8 model file or a burn model.
pub struct LoadedPredictModel {
    model: PredictModel,
    device: Device,
}

impl std::fmt::Debug for LoadedPredictModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let kind = match &self.model {
            PredictModel::Int8(_) => ARCH_INT8.to_string(),
            PredictModel::Burn { cfg, .. } => cfg.report_name(),
        };
        f.debug_struct("LoadedPredictModel")
            .field("arch", &kind)
            .finish_non_exhaustive()
    }
}

impl LoadedPredictModel {
    /// Load the int8 model file or burn `model.bpk` at `path`.
    pub fn load(path: &Path) -> Result<Self> {
        pumptwin_trainer::export::check_model_path(path)?;
        let device = Device::flex();
        let model = load_model(path)?;
        Ok(Self { model, device })
    }

    /// The model's class per window of `rec` (at the model rate) starting at
    /// `starts`: `None` for a window with no usable sensor. Exactly `predict`'s path
    /// (three-node models only).
    pub fn window_classes(
        &self,
        rec: &pumptwin_data::record::Recording,
        cfg: &pumptwin_core::features::FeatureConfig,
        starts: &[usize],
        input: &Path,
    ) -> Result<Vec<Option<String>>> {
        if let PredictModel::Burn { cfg, .. } = &self.model {
            anyhow::ensure!(
                cfg.node_set()? != NodeSet::Derived,
                "a model with derived nodes is not scored here"
            );
        }
        let src = Source { rec, starts };
        let feats = featurize(&src, &NODES, cfg, starts, input)?;
        let (classes, norm, graph) = normalization_and_graph::<{ NODES.len() }>(&self.model)?;
        let with_raw = matches!(&self.model, PredictModel::Burn { net, .. } if net.raw());
        let ds = model_dataset(&feats, &norm, &graph, &src, &NODES, with_raw)?;
        let probs = class_probabilities(&self.model, &ds, with_raw, &classes, &self.device)?;
        let mut probs = probs.iter();
        Ok(feats
            .usable
            .iter()
            .map(|&ok| {
                let p = ok.then(|| probs.next()).flatten()?;
                let best = (0..p.len()).fold(0, |b, c| if p[c] > p[b] { c } else { b });
                classes.get(best).cloned()
            })
            .collect())
    }
}
