//! Two inference-time fusion rules checked on a trained DS-STGAT, on its protocol's
//! test side (clean and at the metrics' 0 dB and −4 dB noise), both **not adopted**
//! (`docs/evaluation-cwru.md`, "Tried in the seventh round"):
//!
//! - **leave-one-node-out committee**: the class posterior averaged over the graphs
//!   that each drop one sensor (`loo`), with the full graph too (`full+loo`), so that
//!   no single sensor whose spectrum moved decides alone;
//! - **kinematic expert**: a softmax regression over fault types (normal, IR, B, OR)
//!   on the envelope lines at BPFO, BPFI and BSF of every node (normalized features,
//!   fitted on the training side), multiplied into the network's posterior,
//!   `log p(c) + γ·log p_kin(type(c))` (`kin^γ`). The lines are kinematic, so they do
//!   not move with load as amplitude and band shares do.
//!
//! ```sh
//! cargo run --release -p pumptwin-trainer --example fusion_check -- out/seeds/none-cross-load-7/model.bpk cross-load
//! ```
//!
//! prints one line per condition and rule (accuracy %), and on stderr the clean
//! test windows that the network or the product with γ = 1 gets wrong, grouped by
//! (truth, network, product), with the network's log-probability margin and the
//! expert's mean type probabilities.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use burn::tensor::activation::log_softmax;
use burn::tensor::Device;
use pumptwin_core::features::{feature_index, FEATURE_DIM};
use pumptwin_data::featurize::SEGMENTS;
use pumptwin_trainer::dataset::{Dataset, NODES};
use pumptwin_trainer::metrics::{noise_spec, NOISE_SNR_DB};
use pumptwin_trainer::training::{
    load_protocol, load_trained_config, parse_protocol, Batch, BatchParts, Network,
};

/// The envelope lines the kinematic expert reads.
const LINES: [usize; 3] = [
    feature_index("env_bpfo_db"),
    feature_index("env_bpfi_db"),
    feature_index("env_bsf_db"),
];
/// Fault types: normal, inner race, ball, outer race.
const TYPES: usize = 4;
/// L2 weight and step of the expert's gradient descent.
const L2: f32 = 1e-3;
const STEP: f32 = 0.5;
const ITERATIONS: usize = 800;
/// Exponents of the expert in the product.
const GAMMAS: [f32; 3] = [0.25, 0.5, 1.0];

/// (truth, network's class, product's class).
type ErrorKey = (usize, usize, usize);
/// (windows, summed log-probability margin, summed expert type probabilities).
type ErrorGroup = (usize, f32, [f32; TYPES]);

fn fault_type(class: &str) -> usize {
    if class.starts_with("IR") {
        1
    } else if class.starts_with("OR") {
        3
    } else if class.starts_with('B') {
        2
    } else {
        0
    }
}

fn argmax(v: &[f32]) -> usize {
    v.iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0, |(i, _)| i)
}

/// Log-posteriors `[W][C]` of `ds`.
fn log_posteriors(net: &Network, ds: &Dataset, dev: &Device) -> Result<Vec<Vec<f32>>> {
    let idx: Vec<usize> = (0..ds.len()).collect();
    let parts = BatchParts {
        raw: false,
        physics: false,
    };
    let mut out = Vec::with_capacity(ds.len());
    for chunk in idx.chunks(256) {
        let o = net.output(&Batch::with_parts(ds, chunk, parts, dev));
        let classes = o.logits.dims()[1];
        let v = log_softmax(o.logits, 1)
            .into_data()
            .try_to_vec::<f32>()
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        out.extend(v.chunks(classes).map(<[f32]>::to_vec));
    }
    Ok(out)
}

/// The expert's inputs of window `w`: the lines of every present node (0, the
/// training mean, where masked) and a bias.
fn expert_inputs(ds: &Dataset, w: usize) -> Vec<f32> {
    let n = ds.nodes;
    let mut v = Vec::with_capacity(n * LINES.len() + 1);
    for i in 0..n {
        for &j in &LINES {
            // Envelope rows are per window: segment 0 carries them.
            let at = (w * SEGMENTS * n + i) * FEATURE_DIM + j;
            v.push(if ds.mask[w * n + i] { ds.x[at] } else { 0.0 });
        }
    }
    v.push(1.0);
    v
}

/// Softmax regression over the fault types present in the protocol.
struct Expert {
    w: Vec<Vec<f32>>,
    present: [bool; TYPES],
}

impl Expert {
    fn log_probs(&self, x: &[f32]) -> [f32; TYPES] {
        let mut z = [f32::NEG_INFINITY; TYPES];
        for t in 0..TYPES {
            if self.present[t] {
                z[t] = self.w[t].iter().zip(x).map(|(a, b)| a * b).sum();
            }
        }
        let m = z.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        let s: f32 = z.iter().map(|v| (v - m).exp()).sum();
        z.map(|v| v - m - s.ln())
    }

    fn fit(x: &[Vec<f32>], y: &[usize]) -> Self {
        let dim = x.first().map_or(1, Vec::len);
        let mut present = [false; TYPES];
        for &t in y {
            present[t] = true;
        }
        let mut e = Self {
            w: vec![vec![0.0; dim]; TYPES],
            present,
        };
        for _ in 0..ITERATIONS {
            let mut g = vec![vec![0.0f32; dim]; TYPES];
            for (xi, &yi) in x.iter().zip(y) {
                let lp = e.log_probs(xi);
                for t in (0..TYPES).filter(|&t| present[t]) {
                    let r = lp[t].exp() - f32::from(u8::from(t == yi));
                    for (gk, xk) in g[t].iter_mut().zip(xi) {
                        *gk += r * xk;
                    }
                }
            }
            let n = x.len().max(1) as f32;
            for (wt, gt) in e.w.iter_mut().zip(&g) {
                for (wk, gk) in wt.iter_mut().zip(gt) {
                    *wk -= STEP * (gk / n + L2 * *wk);
                }
            }
        }
        e
    }
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let model = PathBuf::from(
        args.next()
            .context("usage: fusion_check MODEL PROTOCOL [DATA]")?,
    );
    let protocol = parse_protocol(&args.next().context("no protocol")?)?;
    let data = args.next().unwrap_or_else(|| "../shared/data/cwru".into());
    let (cfg, norms) = load_trained_config(&model)?;
    let (corpus, d) = load_protocol(Path::new(&data), protocol, norms, cfg.graph_config(), NODES)?;
    let dev = Device::flex();
    let net = Network::init(&cfg, d.classes().len(), &dev)?
        .load(&model)?
        .valid();
    let n = NODES.len();
    let types: Vec<usize> = d.classes().iter().map(|c| fault_type(c)).collect();

    let xtr: Vec<Vec<f32>> = (0..d.train.len())
        .map(|w| expert_inputs(&d.train, w))
        .collect();
    let ytr: Vec<usize> = d.train.label.iter().map(|&l| types[l as usize]).collect();
    let expert = Expert::fit(&xtr, &ytr);

    let truth: Vec<usize> = d.test.label.iter().map(|&l| l as usize).collect();
    let pct = |ok: usize| 100.0 * ok as f64 / truth.len().max(1) as f64;
    // Subsets: the full graph, then each node dropped.
    let subsets: Vec<Option<usize>> = std::iter::once(None).chain((0..n).map(Some)).collect();
    // Clean, then the metrics' 0 dB and −4 dB points (the same noise as `metrics.json`).
    let point = |snr: f32| NOISE_SNR_DB.iter().position(|&s| s == snr);
    let conditions = [(None, "clean"), (point(0.0), "0dB"), (point(-4.0), "-4dB")];
    for (k, label) in conditions {
        let side = match k {
            None => d.test.clone(),
            Some(k) => d.noisy_test(&corpus, noise_spec(cfg.seed, k))?,
        };
        let mut lps = Vec::with_capacity(subsets.len());
        for s in &subsets {
            let mut m = side.clone();
            if let Some(i) = *s {
                for w in 0..m.len() {
                    m.mask[w * n + i] = false;
                }
            }
            lps.push(log_posteriors(&net, &m, &dev)?);
        }
        let committee = |sel: &[usize]| {
            (0..truth.len())
                .filter(|&w| {
                    let p: Vec<f32> = (0..lps[0][w].len())
                        .map(|c| sel.iter().map(|&j| lps[j][w][c].exp()).sum())
                        .collect();
                    argmax(&p) == truth[w]
                })
                .count()
        };
        let all: Vec<usize> = (0..subsets.len()).collect();
        println!("{label} full {:.2}", pct(committee(&[0])));
        println!("{label} full+loo {:.2}", pct(committee(&all)));
        println!("{label} loo {:.2}", pct(committee(&all[1..])));
        let kin: Vec<[f32; TYPES]> = (0..side.len())
            .map(|w| expert.log_probs(&expert_inputs(&side, w)))
            .collect();
        let fused = |w: usize, gamma: f32| {
            let v: Vec<f32> = (0..lps[0][w].len())
                .map(|c| lps[0][w][c] + gamma * kin[w][types[c]])
                .collect();
            argmax(&v)
        };
        let expert_ok = (0..truth.len())
            .filter(|&w| argmax(&kin[w]) == types[truth[w]])
            .count();
        println!("{label} kin-type {:.2}", pct(expert_ok));
        for gamma in GAMMAS {
            let ok = (0..truth.len())
                .filter(|&w| fused(w, gamma) == truth[w])
                .count();
            println!("{label} full*kin^{gamma} {:.2}", pct(ok));
        }
        if k.is_none() {
            let mut groups: BTreeMap<ErrorKey, ErrorGroup> = BTreeMap::new();
            for w in 0..truth.len() {
                let (pf, pk) = (argmax(&lps[0][w]), fused(w, 1.0));
                if pf != truth[w] || pk != truth[w] {
                    let g = groups.entry((truth[w], pf, pk)).or_default();
                    g.0 += 1;
                    g.1 += lps[0][w][pf] - lps[0][w][truth[w]];
                    for t in 0..TYPES {
                        g.2[t] += kin[w][t].exp();
                    }
                }
            }
            let cls = d.classes();
            for ((t, pf, pk), (count, margin, kp)) in groups {
                let c = count as f32;
                eprintln!(
                    "{} -> network {} / product {}: {count} windows, margin {:.2} nats, expert N/IR/B/OR {:.2}/{:.2}/{:.2}/{:.2}",
                    cls[t], cls[pf], cls[pk], margin / c, kp[0] / c, kp[1] / c, kp[2] / c, kp[3] / c
                );
            }
        }
    }
    Ok(())
}
