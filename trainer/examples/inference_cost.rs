//! Cost of one DS-STGAT window: the int8 core network vs the burn float model, on the
//! same golden window (`models/dsstgat-cwru-tb.golden.json`, window 0).
//!
//! `inference_cost MODE REPS` runs the model REPS times after loading it (MODE `int8`
//! or `burn`) and prints the mean time per window. `benches/inference_cost.sh` runs it
//! under callgrind with two REPS values; the difference divided by the extra reps is
//! the instructions per window without the loading.

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use burn::module::Module;
use burn::tensor::{Device, Tensor, TensorData};
use pumptwin_core::dsstgat::Output;
use pumptwin_core::features::FEATURE_DIM;
use pumptwin_core::graph::{Adjacency, NodeMask};
use pumptwin_trainer::export::{load_model_file, Golden};
use pumptwin_trainer::training::load_trained_config;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let mode = args.next().unwrap_or_else(|| "int8".into());
    let reps: usize = args.next().map_or(Ok(1000), |s| s.parse())?;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let golden: Golden = serde_json::from_str(&std::fs::read_to_string(
        root.join("models/dsstgat-cwru-tb.golden.json"),
    )?)?;
    let w = &golden.windows[0];
    let t0;
    let mut sink = 0i64;
    match mode.as_str() {
        "int8" => {
            let loaded = load_model_file(&root.join("models/dsstgat-cwru-tb.ptm"))?;
            let x: [[[f32; FEATURE_DIM]; 3]; 8] = std::array::from_fn(|t| {
                std::array::from_fn(|i| std::array::from_fn(|f| w.x[(t * 3 + i) * FEATURE_DIM + f]))
            });
            let adj: [Adjacency<3>; 8] = std::array::from_fn(|t| {
                Adjacency(std::array::from_fn(|i| {
                    std::array::from_fn(|j| w.adj[(t * 3 + i) * 3 + j])
                }))
            });
            let mask = NodeMask(std::array::from_fn(|i| w.mask[i]));
            let mut scratch = Box::new((Default::default(), Default::default()));
            let mut out = Output::default();
            t0 = Instant::now();
            for _ in 0..reps {
                loaded
                    .model
                    .forward(black_box(&x), &adj, &mask, &mut out, &mut scratch)
                    .map_err(|e| anyhow::anyhow!("{e}"))?;
                sink += i64::from(black_box(out.logits[0]));
            }
        }
        "burn" => {
            let path = root.join("models/dsstgat-cwru-tb.float/model.bpk");
            let (cfg, norms) = load_trained_config(&path)?;
            let (norm, _) = norms.ok_or_else(|| anyhow::anyhow!("no normalization.json"))?;
            let device = Device::flex();
            let model = cfg
                .model_config(cfg.classes.len())
                .init(&device)
                .try_load_file(&path)?
                .with_line_vote(&norm, &cfg.classes)?;
            let x = Tensor::<4>::from_data(
                TensorData::new(w.x.clone(), [1, 8, 3, FEATURE_DIM]),
                &device,
            );
            let adj = Tensor::<4>::from_data(TensorData::new(w.adj.clone(), [1, 8, 3, 3]), &device);
            let mask: Vec<f32> = w.mask.iter().map(|&m| if m { 1.0 } else { 0.0 }).collect();
            let mask = Tensor::<2>::from_data(TensorData::new(mask, [1, 3]), &device);
            t0 = Instant::now();
            for _ in 0..reps {
                let out = model.forward(x.clone(), adj.clone(), mask.clone());
                let v = out
                    .logits
                    .into_data()
                    .try_into_vec::<f32>()
                    .unwrap_or_default();
                sink += black_box(v[0]) as i64;
            }
        }
        other => anyhow::bail!("mode must be int8 or burn, not {other:?}"),
    }
    let dt = t0.elapsed().as_secs_f64();
    println!(
        "{mode}: {reps} windows in {dt:.4} s, {:.2} µs per window (sink {sink})",
        1e6 * dt / reps.max(1) as f64
    );
    Ok(())
}
