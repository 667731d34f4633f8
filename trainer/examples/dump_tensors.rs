//! Dump a protocol's training tensors exactly as `pumptwin train` builds them, for
//! the PyTorch side of the epoch-time comparison (`benches/torch_epoch.py`).
//!
//! ```sh
//! cargo run --release -p pumptwin-trainer --example dump_tensors -- \
//!     ../shared/data/cwru out/tensors-tb
//! ```
//!
//! Writes little-endian raw arrays and `shapes.json`:
//! `x.f32` `[W, T, N, F]`, `adj.f32` `[W, T, N, N]`, `mask.f32` `[W, N]`,
//! `labels.i64` `[W]`, `indicators.f32` `[W, 4]`, `class_weights.f32` `[C]`.
use std::io::Write;
use std::path::PathBuf;

use pumptwin_data::windows::Protocol;
use pumptwin_trainer::dataset::{FEATURES, NODES, N_INDICATORS, N_NODES, STEPS};
use pumptwin_trainer::training::{class_weights, load_protocol, TrainConfig};

fn write_f32(path: PathBuf, v: &[f32]) -> anyhow::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    for x in v {
        f.write_all(&x.to_le_bytes())?;
    }
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    anyhow::ensure!(args.len() == 3, "usage: dump_tensors DATA_DIR OUT_DIR");
    let (data, out) = (PathBuf::from(&args[1]), PathBuf::from(&args[2]));
    // The same graph construction as a `--ablation no-physics` run (uniform prior);
    // the timing does not depend on the prior's values.
    let cfg = TrainConfig::new();
    let (_, pd) = load_protocol(&data, Protocol::TimeBlock, None, cfg.graph_config(), NODES)?;
    std::fs::create_dir_all(&out)?;
    let ds = &pd.train;
    write_f32(out.join("x.f32"), &ds.x)?;
    write_f32(out.join("adj.f32"), &ds.adj)?;
    let mask: Vec<f32> = ds.mask.iter().map(|&m| f32::from(u8::from(m))).collect();
    write_f32(out.join("mask.f32"), &mask)?;
    write_f32(out.join("indicators.f32"), &ds.indicators)?;
    let mut f = std::fs::File::create(out.join("labels.i64"))?;
    for l in &ds.label {
        f.write_all(&l.to_le_bytes())?;
    }
    let classes = pd.classes().len();
    write_f32(
        out.join("class_weights.f32"),
        &class_weights(&ds.label, classes),
    )?;
    let shapes = serde_json::json!({
        "windows": ds.len(), "steps": STEPS, "nodes": N_NODES, "features": FEATURES,
        "indicators": N_INDICATORS, "classes": classes,
        "hidden": cfg.hidden, "compressed": cfg.compressed, "batch_size": cfg.batch_size,
        "epochs": cfg.epochs, "learning_rate": cfg.learning_rate,
        "final_lr_fraction": cfg.final_lr_fraction, "lambda_indicator": cfg.lambda_indicator,
        "lambda_reg": cfg.lambda_reg, "node_dropout": cfg.node_dropout,
        "sensor_features": pumptwin_core::dsstgat::SENSOR_HEAD_FEATURES,
        "sensor_weight": pumptwin_trainer::model::SENSOR_HEAD_WEIGHT,
        "sensor_spectral": pumptwin_core::dsstgat::SENSOR_HEAD_SPECTRAL,
        "kinematic_weight": pumptwin_trainer::model::KINEMATIC_HEAD_WEIGHT,
    });
    std::fs::write(
        out.join("shapes.json"),
        serde_json::to_string_pretty(&shapes)?,
    )?;
    eprintln!("wrote {} training windows to {}", ds.len(), out.display());
    Ok(())
}
