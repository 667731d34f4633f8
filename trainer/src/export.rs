//! Post-training quantization (`pumptwin export`) of a trained burn DS-STGAT into the
//! core's int8 network and the postcard model file, with the parity figures, the
//! golden vectors and the model card written beside it.
//!
//! ```text
//! model.bpk + config.json + normalization.json
//!   → DsStgatF32 (core float reference; burn [in, out] weights transposed to [out][in],
//!     the GRU's fused [z|r|n] columns split, W_c folded into W_o and W_f)
//!   → check: core float reference == burn on the test windows (max |Δlogit|)
//!   → calibrate: max-abs of every activation over the TRAINING windows
//!   → DsStgat::from_f32 (per-channel int8 weights, i32 biases, integer requantization)
//!   → ModelFile (v2) → encode → write FILE; decode FILE back
//!   → parity on the TEST windows: burn float vs int8 core from the decoded file
//!   → FILE.golden.json (inputs, burn logits, int8 codes), FILE.md (model card)
//! ```
//!
//! Calibration uses the training side only (the test side is never seen before the
//! parity figures). Rounding: half away from zero everywhere (see
//! `pumptwin_core::quant`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, ensure, Context, Result};
use burn::module::Module;
use burn::tensor::{Device, Tensor};
use pumptwin_core::bearing::BearingGeometry;
use pumptwin_core::dsstgat::{
    DsStgat, DsStgatF32, InferenceModel, InferenceScratch, Output, OutputF32, Ranges, ScratchF32,
    MODEL_CLASSES, MODEL_INDICATORS, SENSOR_HEAD_DIM, SENSOR_HEAD_INPUTS, SENSOR_HEAD_KINEMATIC,
    SENSOR_HEAD_NODES, SENSOR_HEAD_SPECTRAL,
};
use pumptwin_core::graph::{Adjacency, NodeMask};
use pumptwin_core::model_file::{self, GraphParts, ModelFile, Name, Text};
use pumptwin_core::quant::{AttentionPoolF32, GatLayerF32, GruCellF32, LinearF32};
use pumptwin_core::simulator::BearingParams;
use pumptwin_data::entry::sha256_hex;
use serde::{Deserialize, Serialize};

use crate::dataset::{
    Dataset, IndicatorNorm, ProtocolData, FEATURES, INDICATOR_NAMES, NODES, N_INDICATORS, N_NODES,
    STEPS,
};
use crate::model::DsStgat as BurnDsStgat;
use crate::training::artifacts::{load_trained_config, parse_protocol};
use crate::training::batch::Batch;
use crate::training::config::{TrainConfig, ARCH};
use crate::training::load::load_protocol;

/// The arch name of the int8 model in reports.
pub const ARCH_INT8: &str = "dsstgat-int8";

/// What to export and where: the trained weights (`config.json` and
/// `normalization.json` beside them), the model file to write (its golden vectors and
/// model card go beside it), the data directory for calibration (training side) and
/// parity (test side), and how many golden windows to ship.
#[derive(Debug, Clone)]
pub struct ExportSpec {
    /// The trained weights (`model.bpk`).
    pub model: PathBuf,
    /// The model file to write (`.ptm`); `.golden.json` and `.md` beside it.
    pub out: PathBuf,
    /// Data directory (MANIFEST.tsv).
    pub data: PathBuf,
    /// Golden windows to ship with the model.
    pub golden: usize,
}

/// A row-major `[rows, cols]` matrix read from a burn tensor.
struct Matrix {
    rows: usize,
    cols: usize,
    v: Vec<f32>,
}

impl Matrix {
    fn of(t: Tensor<2>) -> Result<Self> {
        let [rows, cols] = t.dims();
        let v = t
            .into_data()
            .try_into_vec::<f32>()
            .map_err(|e| anyhow::anyhow!("cannot read a weight tensor: {e:?}"))?;
        Ok(Self { rows, cols, v })
    }
    fn at(&self, r: usize, c: usize) -> f32 {
        self.v[r * self.cols + c]
    }
}

fn vector(t: Tensor<1>) -> Result<Vec<f32>> {
    t.into_data()
        .try_into_vec::<f32>()
        .map_err(|e| anyhow::anyhow!("cannot read a bias tensor: {e:?}"))
}

fn linear_parts(l: &burn::nn::Linear) -> Result<(Matrix, Vec<f32>)> {
    let w = Matrix::of(l.weight.val())?;
    let b = match &l.bias {
        Some(b) => vector(b.val())?,
        None => vec![0.0; w.cols],
    };
    Ok((w, b))
}

/// `[out][in]` block of a burn `[in, out]` weight: columns `col0..col0 + OUT`.
fn block<const IN: usize, const OUT: usize>(w: &Matrix, col0: usize) -> Result<[[f32; IN]; OUT]> {
    ensure!(
        w.rows == IN && w.cols >= col0 + OUT,
        "weight is [{}, {}], expected [{IN}, ≥ {}]",
        w.rows,
        w.cols,
        col0 + OUT
    );
    Ok(std::array::from_fn(|o| {
        std::array::from_fn(|k| w.at(k, col0 + o))
    }))
}

fn slice<const N: usize>(v: &[f32], from: usize) -> Result<[f32; N]> {
    v.get(from..from + N)
        .and_then(|s| s.try_into().ok())
        .context("bias shorter than its layer")
}

/// `(W_c W_h)ᵀ` and `W_hᵀ b_c + b_h` padded to `OUT` rows: a linear head after the
/// linear compression `Z = W_c g + b_c`, as one layer on `g`.
fn folded_head<const H: usize, const OUT: usize>(
    compress: &burn::nn::Linear,
    head: &burn::nn::Linear,
) -> Result<LinearF32<H, OUT>> {
    let (wc, bc) = linear_parts(compress)?;
    let (wh, bh) = linear_parts(head)?;
    ensure!(
        wc.rows == H && wc.cols == wh.rows,
        "compression/head shapes differ"
    );
    ensure!(
        wh.cols <= OUT,
        "head has {} outputs, at most {OUT} fit",
        wh.cols
    );
    let z = wc.cols;
    let mut w = [[0.0f32; H]; OUT];
    let mut b = [0.0f32; OUT];
    for o in 0..wh.cols {
        for (h, wo) in w[o].iter_mut().enumerate() {
            *wo = (0..z).map(|k| wc.at(h, k) * wh.at(k, o)).sum();
        }
        b[o] = bh[o] + (0..z).map(|k| bc[k] * wh.at(k, o)).sum::<f32>();
    }
    Ok(LinearF32 { w, b })
}

/// The core float reference of a burn DS-STGAT with hidden size `H` (heads padded to
/// the run-time capacities).
pub fn float_reference<const H: usize>(
    m: &BurnDsStgat,
) -> Result<DsStgatF32<FEATURES, H, MODEL_CLASSES, MODEL_INDICATORS>> {
    let (we, be) = linear_parts(&m.embed)?;
    let (wg, _) = linear_parts(&m.gat.w)?;
    let (wi, bi) = linear_parts(&m.gru.input)?;
    let (wzr, _) = linear_parts(&m.gru.hidden_zr)?;
    let (wn, _) = linear_parts(&m.gru.hidden_n)?;
    let (wp, bp) = linear_parts(&m.pool.score)?;
    let gate = |k: usize| -> Result<LinearF32<H, H>> {
        Ok(LinearF32 {
            w: block::<H, H>(&wi, k * H)?,
            b: slice::<H>(&bi, k * H)?,
        })
    };
    Ok(DsStgatF32 {
        embed: LinearF32 {
            w: block::<FEATURES, H>(&we, 0)?,
            b: slice::<H>(&be, 0)?,
        },
        gat: GatLayerF32 {
            w: block::<H, H>(&wg, 0)?,
            a_src: slice::<H>(&vector(m.gat.a_src.val())?, 0)?,
            a_dst: slice::<H>(&vector(m.gat.a_dst.val())?, 0)?,
            bias: slice::<H>(&vector(m.gat.bias.val())?, 0)?,
        },
        gru: GruCellF32 {
            w_z: gate(0)?,
            w_r: gate(1)?,
            w_n: gate(2)?,
            u_z: block::<H, H>(&wzr, 0)?,
            u_r: block::<H, H>(&wzr, H)?,
            u_n: block::<H, H>(&wn, 0)?,
        },
        pool: AttentionPoolF32 {
            w: block::<H, 1>(&wp, 0)?[0],
            b: bp[0],
        },
        classifier: folded_head::<H, MODEL_CLASSES>(&m.compress, &m.classifier)?,
        indicator: folded_head::<H, MODEL_INDICATORS>(&m.compress, &m.indicator)?,
        sensor: sensor_head::<MODEL_CLASSES>(&m.sensor, &m.kinematic)?,
        // The model file rebuilds the vote from its class names and normalization:
        // the reference must have the same one (`DsStgat::with_line_vote`).
        line_vote: m
            .line_vote
            .ok_or_else(|| anyhow::anyhow!("the burn model has no defect-line vote"))?,
    })
}

/// The sensor head as the core's layer: its two experts' burn weights (`[N·E_s, C]`
/// spectral, `[N·E_k, C]` kinematic) and biases, each times its weight `γ`
/// ([`crate::model::SENSOR_HEAD_WEIGHT`], [`crate::model::KINEMATIC_HEAD_WEIGHT`],
/// folded in so the core adds the logits as they are), interleaved into the core's
/// node-major slots (a slot: the spectral features, then the kinematic ones) in the
/// first `N` of its `SENSOR_HEAD_NODES` slots (the rest zero), padded to `OUT` rows.
/// A sum of two linear maps on disjoint inputs is one linear map on both.
fn sensor_head<const OUT: usize>(
    spectral: &burn::nn::Linear,
    kinematic: &burn::nn::Linear,
) -> Result<LinearF32<SENSOR_HEAD_INPUTS, OUT>> {
    let mut lw = [[0.0f32; SENSOR_HEAD_INPUTS]; OUT];
    let mut lb = [0.0f32; OUT];
    for (head, offset, dim, gamma, name) in [
        (
            spectral,
            0,
            SENSOR_HEAD_SPECTRAL,
            crate::model::SENSOR_HEAD_WEIGHT,
            "spectral",
        ),
        (
            kinematic,
            SENSOR_HEAD_SPECTRAL,
            SENSOR_HEAD_KINEMATIC,
            crate::model::KINEMATIC_HEAD_WEIGHT,
            "kinematic",
        ),
    ] {
        let (w, b) = linear_parts(head)?;
        ensure!(
            w.rows <= SENSOR_HEAD_NODES * dim && w.rows % dim == 0,
            "sensor head's {name} expert has {} inputs: not a whole number of nodes of \
             {dim} features within the core's {SENSOR_HEAD_NODES} slots",
            w.rows
        );
        ensure!(
            w.cols <= OUT,
            "sensor head's {name} expert has {} outputs, at most {OUT} fit",
            w.cols
        );
        for o in 0..w.cols {
            for k in 0..w.rows {
                let (node, f) = (k / dim, k % dim);
                lw[o][node * SENSOR_HEAD_DIM + offset + f] = gamma * w.at(k, o);
            }
            lb[o] += gamma * b[o];
        }
    }
    Ok(LinearF32 { w: lw, b: lb })
}

/// One window of a data set as the core's fixed-size arrays.
#[derive(Debug, Clone)]
pub struct CoreWindow {
    /// `[T][N][F]` normalized features.
    pub x: [[[f32; FEATURES]; N_NODES]; STEPS],
    /// `[T]` adjacencies.
    pub adj: [Adjacency<N_NODES>; STEPS],
    /// Present nodes.
    pub mask: NodeMask<N_NODES>,
}

impl CoreWindow {
    /// Window `k` of `ds`.
    pub fn of(ds: &Dataset, k: usize) -> Self {
        debug_assert_eq!(ds.nodes, N_NODES);
        let x0 = k * ds.x_per_window();
        let a0 = k * ds.adj_per_window();
        let x = std::array::from_fn(|t| {
            std::array::from_fn(|i| {
                std::array::from_fn(|f| ds.x[x0 + (t * N_NODES + i) * FEATURES + f])
            })
        });
        let adj = std::array::from_fn(|t| {
            Adjacency(std::array::from_fn(|i| {
                std::array::from_fn(|j| ds.adj[a0 + (t * N_NODES + i) * N_NODES + j])
            }))
        });
        let mask = NodeMask(std::array::from_fn(|i| ds.mask[k * N_NODES + i]));
        Self { x, adj, mask }
    }
}

/// The burn model's logits on every window of `ds`, `[W][C]`.
pub fn burn_logits(
    m: &BurnDsStgat,
    ds: &Dataset,
    batch: usize,
    device: &Device,
) -> Result<Vec<Vec<f32>>> {
    let idx: Vec<usize> = (0..ds.len()).collect();
    let mut out = Vec::with_capacity(ds.len());
    for chunk in idx.chunks(batch.max(1)) {
        let b = Batch::new(ds, chunk, device);
        let logits = m.forward(b.x, b.adj, b.mask).logits;
        let c = logits.dims()[1];
        let v = logits
            .into_data()
            .try_into_vec::<f32>()
            .map_err(|e| anyhow::anyhow!("cannot read logits: {e:?}"))?;
        out.extend(v.chunks(c).map(<[f32]>::to_vec));
    }
    Ok(out)
}

/// The int8 core's outputs on every window of `ds`.
pub fn int8_outputs(
    model: &InferenceModel,
    ds: &Dataset,
) -> Result<Vec<Output<MODEL_CLASSES, MODEL_INDICATORS>>> {
    let mut scratch: Box<InferenceScratch<STEPS, N_NODES>> =
        Box::new((Default::default(), Default::default()));
    (0..ds.len())
        .map(|k| {
            let w = CoreWindow::of(ds, k);
            let mut out = Output::default();
            model
                .forward(&w.x, &w.adj, &w.mask, &mut out, &mut scratch)
                .map_err(|e| anyhow::anyhow!("int8 inference failed on window {k}: {e}"))?;
            Ok(out)
        })
        .collect()
}

/// A decoded model file and its int8 network.
#[derive(Debug)]
pub struct LoadedModel {
    /// The decoded file.
    pub file: Box<ModelFile>,
    /// The int8 network.
    pub model: InferenceModel,
}

/// Whether `path` is to be read as an int8 model file: it starts with the model
/// file's magic, or it is not a burn record (`.bpk`, read with the `config.json`
/// beside it). So an empty, damaged or foreign file gets the model file's own error
/// ("not a valid model file: bad magic", ...), not a missing `config.json`.
pub fn is_model_file(path: &Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 8];
    let has_magic = std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .is_ok()
        && magic == model_file::MAGIC;
    has_magic || path.extension().and_then(|e| e.to_str()) != Some("bpk")
}

/// The model path names an existing file (checked before anything is read beside it).
pub fn check_model_path(path: &Path) -> Result<()> {
    anyhow::ensure!(
        path.is_file(),
        "model {}: no such file (an int8 model file `.ptm`, or a burn `model.bpk` with \
         its config.json beside it)",
        path.display()
    );
    Ok(())
}

/// Read, decode and build a model file.
pub fn load_model_file(path: &Path) -> Result<LoadedModel> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    decode_model_file(&bytes, &path.display().to_string())
}

/// Decode and build a model file's bytes (`name` in messages).
pub fn decode_model_file(bytes: &[u8], name: &str) -> Result<LoadedModel> {
    let mut file = Box::<ModelFile>::default();
    model_file::decode_into(bytes, &mut file)
        .with_context(|| format!("{name} is not a valid model file"))?;
    let model = InferenceModel::from_model_file(&file)
        .with_context(|| format!("cannot build the int8 network of {name}"))?;
    ensure!(
        usize::from(file.dims.nodes) == N_NODES && usize::from(file.dims.steps) == STEPS,
        "{name}: the model has N = {}, T = {}; this build runs N = {N_NODES}, T = {STEPS}",
        file.dims.nodes,
        file.dims.steps
    );
    Ok(LoadedModel { file, model })
}

impl LoadedModel {
    /// Class names, in logit order.
    pub fn classes(&self) -> Vec<String> {
        self.file
            .class_names()
            .iter()
            .map(|s| s.to_string())
            .collect()
    }

    /// The feature and indicator normalizations stored in the file.
    pub fn norms(&self) -> Result<(pumptwin_core::features::FeatureNorm, IndicatorNorm)> {
        let norm = self.file.feature_norm()?;
        let ind = &self.file.indicator;
        ensure!(
            ind.mean.len() == N_INDICATORS,
            "the model has {} indicators, this build {N_INDICATORS}",
            ind.mean.len()
        );
        let mut n = IndicatorNorm {
            mean: [0.0; N_INDICATORS],
            std: [1.0; N_INDICATORS],
        };
        n.mean.copy_from_slice(&ind.mean);
        n.std.copy_from_slice(&ind.std);
        Ok((norm, n))
    }
}

/// One golden window: inputs and expected outputs.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GoldenWindow {
    /// True class index.
    pub label: usize,
    /// `[T·N·F]` normalized features, row-major.
    pub x: Vec<f32>,
    /// `[T·N·N]` adjacency, row-major.
    pub adj: Vec<f32>,
    /// `[N]` present nodes.
    pub mask: Vec<bool>,
    /// The burn float model's logits `[C]`.
    pub float_logits: Vec<f32>,
    /// The int8 core's logit codes `[C]` (exact: integer arithmetic).
    pub int8_logits: Vec<i32>,
    /// The int8 core's class.
    pub int8_class: usize,
}

/// The golden-vector file shipped beside a model.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Golden {
    /// The model file these belong to.
    pub model: String,
    /// SHA-256 of the model file.
    pub model_sha256: String,
    /// The logits' scale (real logit = scale · code).
    pub logit_scale: f32,
    /// Stated tolerance: `|float − scale·code| ≤ tolerance · max(1, max|float|)` per window.
    pub relative_tolerance: f32,
    /// `T`, `N`, `F`.
    pub shape: [usize; 3],
    /// The windows.
    pub windows: Vec<GoldenWindow>,
}

/// The relative logit tolerance stated in the golden file (measured worst case on the
/// time-block test side: see the model card).
pub const GOLDEN_RELATIVE_TOLERANCE: f32 = 0.1;

/// Parity of the int8 model with the burn float model on one data set.
#[derive(Debug, Clone, Serialize)]
pub struct Parity {
    /// Windows compared.
    pub windows: usize,
    /// Burn float accuracy.
    pub float_accuracy: f64,
    /// Int8 core accuracy.
    pub int8_accuracy: f64,
    /// Share of windows where both predict the same class.
    pub agreement: f64,
    /// Max |burn logit − int8 logit| (logit units).
    pub max_logit_diff: f32,
    /// Max |burn logit − int8 logit| / max(1, max |burn logit|) of the window.
    pub max_relative_logit_diff: f32,
    /// Max |burn logit − core float reference logit| (the weight mapping's check).
    pub max_reference_diff: f32,
}

fn name(s: &str) -> Result<Name> {
    Name::try_from(s)
        .map_err(|_| anyhow::anyhow!("name {s:?} longer than {} bytes", model_file::NAME_LEN))
}

/// Quantize the trained DS-STGAT `spec.model` into the int8 model file `spec.out`,
/// with its golden vectors, parity figures and model card beside it.
pub fn export_model(args: &ExportSpec) -> Result<()> {
    let (cfg, norms) = load_trained_config(&args.model)?;
    let protocol = parse_protocol(&cfg.protocol)?;
    if cfg.arch != ARCH {
        anyhow::bail!(
            "only the DS-STGAT has an int8 network in the core; {} is a {} model",
            args.model.display(),
            cfg.arch
        );
    }
    if cfg.node_set()? != crate::dataset::NodeSet::Measured {
        anyhow::bail!(
            "{} uses the derived temperature/pressure nodes: that option is float only \
             (the core's int8 network and the edge run the measured DE, FE, BA nodes)",
            args.model.display()
        );
    }
    let (corpus, data) = load_protocol(&args.data, protocol, norms, cfg.graph_config(), NODES)?;
    ensure!(
        cfg.classes.is_empty() || cfg.classes == data.classes(),
        "the model's classes {:?} differ from the data's {:?}",
        cfg.classes,
        data.classes()
    );
    let _ = corpus;
    let device = Device::flex();
    let burn_model = cfg
        .model_config(data.classes().len())
        .init(&device)
        .try_load_file(&args.model)
        .with_context(|| format!("cannot load {}", args.model.display()))?
        .with_line_vote(&data.norm, data.classes())?;
    match cfg.hidden {
        16 => export_with::<16>(args, &cfg, &data, &burn_model, &device),
        32 => export_with::<32>(args, &cfg, &data, &burn_model, &device),
        h => bail!("int8 export supports hidden sizes 16 and 32, the model has {h}"),
    }
}

/// [`export_model`] for a network with hidden size `H`: calibrate, quantize and write
/// the model file, then measure parity through the file as written and write the
/// golden vectors, the model card and the parity figures beside it.
fn export_with<const H: usize>(
    args: &ExportSpec,
    cfg: &TrainConfig,
    data: &ProtocolData,
    burn_model: &BurnDsStgat,
    device: &Device,
) -> Result<()> {
    let classes = data.classes().len();
    let mut float = FloatRun::<H>::new(float_reference::<H>(burn_model)?);
    // Calibration on the training side.
    let ranges = float.calibrate(&data.train)?;
    let q = DsStgat::<FEATURES, H, MODEL_CLASSES, MODEL_INDICATORS>::from_f32(&float.net, &ranges)
        .map_err(|e| anyhow::anyhow!("quantization failed: {e}"))?;
    // The model file.
    let buf = encode_model_file(&q, &args.out, data)?;
    let len = buf.len();
    write_model_file(&args.out, &buf)?;
    let sha = sha256_hex(&buf);
    // Parity, through the file as written.
    let loaded = load_model_file(&args.out)?;
    let test = &data.test;
    let burn = burn_logits(burn_model, test, cfg.eval_batch_size, device)?;
    let int8 = int8_outputs(&loaded.model, test)?;
    let outs = TestOutputs {
        test,
        burn: &burn,
        int8: &int8,
        scale: loaded.model.logit_scale().get(),
        classes,
    };
    let parity = float.parity(&outs)?;
    let golden = golden_vectors(&args.out, args.golden, &outs, &sha);
    let golden_path = sibling(&args.out, "golden.json");
    std::fs::write(&golden_path, serde_json::to_string(&golden)? + "\n")
        .with_context(|| format!("cannot write {}", golden_path.display()))?;
    let card_path = sibling(&args.out, "md");
    std::fs::write(
        &card_path,
        model_card(args, cfg, data, &parity, &sha, len, &ranges),
    )
    .with_context(|| format!("cannot write {}", card_path.display()))?;
    eprintln!(
        "wrote {} ({len} bytes, sha256 {sha}), {}, {}",
        args.out.display(),
        golden_path.display(),
        card_path.display()
    );
    print_parity(&parity);
    let parity_path = sibling(&args.out, "parity.json");
    std::fs::write(&parity_path, serde_json::to_string_pretty(&parity)? + "\n")?;
    Ok(())
}

/// The core float reference with one set of run buffers, used by the calibration and
/// again by the parity check.
struct FloatRun<const H: usize> {
    /// The float network.
    net: DsStgatF32<FEATURES, H, MODEL_CLASSES, MODEL_INDICATORS>,
    /// Its scratch.
    scratch: Box<ScratchF32<STEPS, N_NODES, H>>,
    /// Its output (the last window's).
    out: OutputF32<MODEL_CLASSES, MODEL_INDICATORS>,
}

impl<const H: usize> FloatRun<H> {
    fn new(net: DsStgatF32<FEATURES, H, MODEL_CLASSES, MODEL_INDICATORS>) -> Self {
        Self {
            net,
            scratch: Box::new(ScratchF32::<STEPS, N_NODES, H>::new()),
            out: OutputF32::default(),
        }
    }

    /// The activation ranges over every window of `train` (the quantization's
    /// calibration).
    fn calibrate(&mut self, train: &Dataset) -> Result<Ranges> {
        let mut ranges = Ranges::default();
        for k in 0..train.len() {
            let w = CoreWindow::of(train, k);
            self.net
                .forward_observed(
                    &w.x,
                    &w.adj,
                    &w.mask,
                    &mut self.out,
                    &mut self.scratch,
                    &mut ranges,
                )
                .map_err(|e| anyhow::anyhow!("calibration window {k}: {e}"))?;
        }
        Ok(ranges)
    }

    /// Parity of the int8 core and of this float reference with the burn model on
    /// the test side.
    fn parity(&mut self, o: &TestOutputs<'_>) -> Result<Parity> {
        let test = o.test;
        let mut parity = Parity {
            windows: test.len(),
            float_accuracy: 0.0,
            int8_accuracy: 0.0,
            agreement: 0.0,
            max_logit_diff: 0.0,
            max_relative_logit_diff: 0.0,
            max_reference_diff: 0.0,
        };
        let (mut ok_f, mut ok_q, mut same) = (0usize, 0usize, 0usize);
        for k in 0..test.len() {
            let label = test.label[k] as usize;
            let bl = &o.burn[k];
            let fc = argmax(bl);
            let w = CoreWindow::of(test, k);
            self.net
                .forward(&w.x, &w.adj, &w.mask, &mut self.out, &mut self.scratch)
                .map_err(|e| anyhow::anyhow!("float reference on window {k}: {e}"))?;
            let range = bl.iter().fold(1.0f32, |m, v| m.max(v.abs()));
            for c in 0..o.classes {
                let d = (bl[c] - o.scale * o.int8[k].logits[c] as f32).abs();
                parity.max_logit_diff = parity.max_logit_diff.max(d);
                parity.max_relative_logit_diff = parity.max_relative_logit_diff.max(d / range);
                parity.max_reference_diff = parity
                    .max_reference_diff
                    .max((bl[c] - self.out.logits[c]).abs());
            }
            ok_f += usize::from(fc == label);
            ok_q += usize::from(o.int8[k].class == label);
            same += usize::from(fc == o.int8[k].class);
        }
        let n = test.len().max(1) as f64;
        parity.float_accuracy = ok_f as f64 / n;
        parity.int8_accuracy = ok_q as f64 / n;
        parity.agreement = same as f64 / n;
        Ok(parity)
    }
}

/// The test side with the burn model's and the written int8 model's outputs on it.
struct TestOutputs<'a> {
    /// The test windows.
    test: &'a Dataset,
    /// Burn float logits, `[W][C]`.
    burn: &'a [Vec<f32>],
    /// Int8 core outputs, per window.
    int8: &'a [Output<MODEL_CLASSES, MODEL_INDICATORS>],
    /// The int8 logits' scale (real logit = scale · code).
    scale: f32,
    /// The model's classes.
    classes: usize,
}

/// The model file of the quantized network `q` (named after `out`'s stem, today's
/// date, `data`'s classes, nodes, normalizations and graph), encoded.
fn encode_model_file<const H: usize>(
    q: &DsStgat<FEATURES, H, MODEL_CLASSES, MODEL_INDICATORS>,
    out: &Path,
    data: &ProtocolData,
) -> Result<Vec<u8>> {
    let mut file = Box::<ModelFile>::default();
    q.store(&mut file, data.classes().len(), N_INDICATORS)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let stem = out
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("dsstgat");
    let short: String = stem.chars().take(model_file::TEXT_LEN).collect();
    file.model_name = Text::try_from(short.as_str()).unwrap_or_default();
    file.created = Text::try_from(today().as_str()).unwrap_or_default();
    file.dims.nodes = N_NODES as u16;
    file.dims.steps = STEPS as u16;
    for c in data.classes() {
        file.class_names
            .push(name(c)?)
            .ok()
            .context("too many classes")?;
    }
    for s in NODES {
        file.sensor_names
            .push(name(s)?)
            .ok()
            .context("too many nodes")?;
    }
    for (k, n) in INDICATOR_NAMES.iter().enumerate() {
        let short: String = n.chars().take(model_file::NAME_LEN).collect();
        file.indicator
            .names
            .push(Name::try_from(short.as_str()).unwrap_or_default())
            .ok();
        file.indicator.mean.push(data.indicator_norm.mean[k]).ok();
        file.indicator.std.push(data.indicator_norm.std[k]).ok();
    }
    file.feature_norm = (&data.norm).into();
    file.graph = GraphParts::from_config(&data.graph)?;
    file.physics = (&BearingParams::default_housing()).into();
    file.geometry = (&BearingGeometry::CWRU_6205_DE).into();
    file.diagnosis = model_file::DiagnosisParts::new(
        &pumptwin_core::diagnosis::Thresholds::DEFAULT,
        pumptwin_core::diagnosis::DEFAULT_REVOLUTIONS,
    );
    let mut buf = vec![0u8; model_file::MAX_ENCODED_LEN];
    let len = model_file::encode(&file, &mut buf).map_err(|e| anyhow::anyhow!("encode: {e}"))?;
    buf.truncate(len);
    Ok(buf)
}

/// Write the encoded model file to `out`, creating its folder.
fn write_model_file(out: &Path, buf: &[u8]) -> Result<()> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    std::fs::write(out, buf).with_context(|| format!("cannot write {}", out.display()))
}

/// The golden windows' indices: spread over the test side, every class if possible;
/// `golden` of them, or one per class if that is more.
fn golden_picks(test: &Dataset, classes: usize, golden: usize) -> Vec<usize> {
    let mut picks: Vec<usize> = Vec::new();
    for c in 0..classes {
        if let Some(k) = (0..test.len()).find(|&k| test.label[k] as usize == c) {
            picks.push(k);
        }
    }
    let stride = (test.len() / golden.max(1)).max(1);
    let mut k = stride / 2;
    while picks.len() < golden && k < test.len() {
        if !picks.contains(&k) {
            picks.push(k);
        }
        k += stride;
    }
    picks.truncate(golden.max(classes));
    picks
}

/// The golden vectors of the model file `out` (SHA-256 `sha`): `golden` test windows
/// with their inputs, burn logits and int8 logit codes.
fn golden_vectors(out: &Path, golden: usize, o: &TestOutputs<'_>, sha: &str) -> Golden {
    let test = o.test;
    let picks = golden_picks(test, o.classes, golden);
    Golden {
        model: out
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        model_sha256: sha.to_string(),
        logit_scale: o.scale,
        relative_tolerance: GOLDEN_RELATIVE_TOLERANCE,
        shape: [STEPS, N_NODES, FEATURES],
        windows: picks
            .iter()
            .map(|&k| {
                let (xw, aw) = (test.x_per_window(), test.adj_per_window());
                let (x0, a0) = (k * xw, k * aw);
                GoldenWindow {
                    label: test.label[k] as usize,
                    x: test.x[x0..x0 + xw].to_vec(),
                    adj: test.adj[a0..a0 + aw].to_vec(),
                    mask: test.window_mask(k).to_vec(),
                    float_logits: o.burn[k].clone(),
                    int8_logits: o.int8[k].logits[..o.classes].to_vec(),
                    int8_class: o.int8[k].class,
                }
            })
            .collect(),
    }
}

/// The parity figures on standard error.
fn print_parity(parity: &Parity) {
    eprintln!(
        "parity on {} test windows: burn float {:.2} %, int8 core {:.2} %, agreement {:.2} %, \
         max |Δlogit| {:.4} ({:.2} % of the window's logit range); core float reference vs burn \
         max |Δlogit| {:.2e}",
        parity.windows,
        100.0 * parity.float_accuracy,
        100.0 * parity.int8_accuracy,
        100.0 * parity.agreement,
        parity.max_logit_diff,
        100.0 * parity.max_relative_logit_diff,
        parity.max_reference_diff
    );
}

fn argmax(v: &[f32]) -> usize {
    let mut best = 0;
    for (i, &x) in v.iter().enumerate() {
        if x > v[best] {
            best = i;
        }
    }
    best
}

/// `dir/stem.ext` beside `path`.
pub fn sibling(path: &Path, ext: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!("{stem}.{ext}"))
}

/// Today's date (UTC) as `YYYY-MM-DD`, from the system clock.
fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let days = (secs / 86_400) as i64;
    // Civil from days (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

fn model_card(
    args: &ExportSpec,
    cfg: &TrainConfig,
    data: &ProtocolData,
    p: &Parity,
    sha: &str,
    len: usize,
    ranges: &Ranges,
) -> String {
    let file = args
        .out
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut s = String::new();
    let _ = writeln!(s, "# Model card: `{file}`\n");
    let _ = writeln!(s, "| | |\n|---|---|");
    let _ = writeln!(
        s,
        "| file | `{file}`, {len} bytes, model file format v{} |",
        model_file::FORMAT_VERSION
    );
    let _ = writeln!(s, "| sha256 | `{sha}` |");
    let _ = writeln!(s, "| created | {} |", today());
    let _ = writeln!(s, "| architecture | DS-STGAT, int8 (`{ARCH_INT8}`): embedding → GAT (1 head) → GRU → attention pooling → class and indicator heads, H = {}, W_c folded into both heads; sensor head (one weight row per sensor on the window means: a spectral expert on the log band shares, γ = {}, and a kinematic expert on the envelope features, γ_k = {}, folded in) added to the class logits |", cfg.hidden, crate::model::SENSOR_HEAD_WEIGHT, crate::model::KINEMATIC_HEAD_WEIGHT);
    let _ = writeln!(
        s,
        "| nodes | {} (missing channels masked) |",
        NODES.join(", ")
    );
    let _ = writeln!(s, "| input | {STEPS} steps × {N_NODES} nodes × {FEATURES} core features per 2048-sample window at 12 kHz (5 kHz band limit, measurement-noise floor subtracted: `core::features::subtract_noise_floor`) |");
    let t = pumptwin_core::diagnosis::Thresholds::DEFAULT;
    let _ = writeln!(
        s,
        "| physical diagnosis | `core::diagnosis` on the first node over {} shaft revolutions per window: a line ≥ {} dB leading the next family by ≥ {} dB names the type, no line and spectral kurtosis < {} is normal; confidence σ({}·(lead − margin) + {}) for a type, σ({}) for normal (chosen on CWRU 0.007\" and 0.021\" only; `docs/evaluation-generalization.md`) |",
        pumptwin_core::diagnosis::DEFAULT_REVOLUTIONS,
        t.line_db,
        t.margin_db,
        t.impulsive_sk,
        t.typed_logistic.0,
        t.typed_logistic.1,
        t.normal_logistic.1
    );
    let g = &data.graph;
    let _ = writeln!(
        s,
        "| graph | {} (β = {}, window {} steps, τ_corr = {}), edge prior P = {:.3?} ({}) |",
        if g.prior_weight >= 1.0 {
            "static"
        } else {
            "dynamic, eqs. 1–3"
        },
        g.prior_weight,
        g.window_steps,
        g.tau_corr,
        g.prior,
        if cfg.graph_prior.is_empty() {
            "uniform"
        } else {
            "simulated spectral correlation between the nodes, eq. 9"
        }
    );
    let _ = writeln!(s, "| classes | {} |", data.classes().join(", "));
    let _ = writeln!(s, "| data | CWRU bearing data (`{}`), protocol `{}`: {} train windows from {} records, {} test windows from {} records; no window overlaps across the split |",
        args.data.display(), data.protocol.name(), data.train.len(), data.train.n_records(), data.test.len(), data.test.n_records());
    let _ = writeln!(
        s,
        "| training | burn 0.22.1, `{}`, seed {}, {} epochs, batch {}, Adam lr {} (cosine), node dropout {}; physics embedding (eq. 9: {} epochs of pre-training on simulated fault hypotheses): {}; co-adaptation (L_phy λ = {}, F_map on the closed loop's Θ λ = {}; heads not in this file): {} |",
        cfg.report_name(),
        cfg.seed,
        cfg.epochs,
        cfg.batch_size,
        cfg.learning_rate,
        cfg.node_dropout,
        cfg.pretrain_epochs,
        if cfg.uses_physics_embedding() { "yes" } else { "no" },
        cfg.lambda_phy,
        cfg.lambda_map,
        if cfg.uses_coadaptation() { "yes" } else { "no" }
    );
    let _ = writeln!(s, "| quantization | post-training, calibrated by max-abs on the {} training windows; per-output-channel symmetric int8 weights, i32 biases, int8 activations, integer requantization (multiplier + shift, round half away from zero); sigmoid/tanh/exp as LUTs |", data.train.len());
    let _ = writeln!(
        s,
        "| input scale | {:.5} per code (max |normalized feature| {:.2}) |",
        ranges.input.max_abs() / 127.0,
        ranges.input.max_abs()
    );
    let _ = writeln!(s, "\n## Parity on the test side ({} windows)\n", p.windows);
    let _ = writeln!(s, "| metric | value |\n|---|---|");
    let _ = writeln!(
        s,
        "| burn float accuracy | {:.2} % |",
        100.0 * p.float_accuracy
    );
    let _ = writeln!(
        s,
        "| int8 core accuracy | {:.2} % |",
        100.0 * p.int8_accuracy
    );
    let _ = writeln!(
        s,
        "| accuracy difference | {:+.2} points |",
        100.0 * (p.int8_accuracy - p.float_accuracy)
    );
    let _ = writeln!(s, "| class agreement | {:.2} % |", 100.0 * p.agreement);
    let _ = writeln!(
        s,
        "| max \\|Δlogit\\| burn vs int8 | {:.4} ({:.2} % of the window's logit range) |",
        p.max_logit_diff,
        100.0 * p.max_relative_logit_diff
    );
    let _ = writeln!(
        s,
        "| max \\|Δlogit\\| burn vs core float reference | {:.2e} (weight mapping check) |",
        p.max_reference_diff
    );
    let _ = writeln!(s, "\nGolden vectors: `{}` ({} windows; the int8 logit codes are exact, the burn logits within a relative tolerance of {}).", sibling(Path::new(&file), "golden.json").display(), args.golden.max(data.classes().len()), GOLDEN_RELATIVE_TOLERANCE);
    let _ = writeln!(s, "\n## Reproduce\n\n```sh\ncargo run --release -p pumptwin --bin pumptwin -- train --data {} --protocol {} --out out/train-{} --seed {} --epochs {}\ncargo run --release -p pumptwin --bin pumptwin -- export --model out/train-{}/model.bpk --data {} --out {}\ncargo run --release -p pumptwin --bin pumptwin -- eval --model {} --data {} --protocol {} --out out/eval-int8\n```",
        args.data.display(), data.protocol.name(), data.protocol.name(), cfg.seed, cfg.epochs,
        data.protocol.name(), args.data.display(), args.out.display(),
        args.out.display(), args.data.display(), data.protocol.name());
    let _ = writeln!(s, "\nLimits: trained and evaluated on one rig (CWRU, 6205 drive-end bearing, 1730–1797 rpm); see the trainer issue for cross-load and fault-size results. The normal class is a different recording (48 kHz, decimated) and separable by level alone; fault-only accuracy is in `metrics.json`.");
    s
}
