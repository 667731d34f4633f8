//! Parity of the shipped int8 model (run by the core) with the shipped burn float
//! model on the real CWRU time-block test side: accuracy within 0.3 points, and the
//! agreement rate and max logit difference printed. Skips with a notice when
//! `../shared/data/cwru` is absent.

use std::path::{Path, PathBuf};

use burn::module::Module;
use burn::tensor::Device;
use pumptwin_data::windows::Protocol;
use pumptwin_trainer::dataset::NODES;
use pumptwin_trainer::export::{burn_logits, int8_outputs, load_model_file};
use pumptwin_trainer::training::{load_protocol, load_trained_config};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn shipped_int8_model_agrees_with_the_float_model_on_cwru() {
    let data = root().join("../shared/data/cwru");
    if !data.join("MANIFEST.tsv").is_file() {
        println!("SKIP: {} not found (CWRU data absent)", data.display());
        return;
    }
    let float_path = root().join("models/dsstgat-cwru-tb.float/model.bpk");
    let int8 = load_model_file(&root().join("models/dsstgat-cwru-tb.ptm")).unwrap();
    let (cfg, norms) = load_trained_config(&float_path).unwrap();
    let (_, pd) =
        load_protocol(&data, Protocol::TimeBlock, norms, cfg.graph_config(), NODES).unwrap();
    assert_eq!(int8.classes(), pd.classes());
    let device = Device::flex();
    let burn = cfg
        .model_config(pd.classes().len())
        .init(&device)
        .try_load_file(&float_path)
        .unwrap()
        .with_line_vote(&pd.norm, pd.classes())
        .unwrap();
    let fl = burn_logits(&burn, &pd.test, 256, &device).unwrap();
    let q = int8_outputs(&int8.model, &pd.test).unwrap();
    let scale = int8.model.logit_scale().get();
    let n = pd.test.len();
    let (mut ok_f, mut ok_q, mut same) = (0, 0, 0);
    let mut max_diff = 0.0f32;
    for k in 0..n {
        let label = pd.test.label[k] as usize;
        let f = &fl[k];
        let fc = (0..f.len()).fold(0, |b, c| if f[c] > f[b] { c } else { b });
        ok_f += usize::from(fc == label);
        ok_q += usize::from(q[k].class == label);
        same += usize::from(fc == q[k].class);
        for c in 0..f.len() {
            max_diff = max_diff.max((f[c] - scale * q[k].logits[c] as f32).abs());
        }
    }
    let (af, aq) = (ok_f as f64 / n as f64, ok_q as f64 / n as f64);
    println!(
        "time-block test side, {n} windows: burn float {:.2} %, int8 core {:.2} %, \
         agreement {:.2} %, max |Δlogit| {max_diff:.4}",
        100.0 * af,
        100.0 * aq,
        100.0 * same as f64 / n as f64
    );
    assert!(aq >= af - 0.003, "int8 {aq} vs float {af}");
    assert!(same as f64 / n as f64 >= 0.99);
}
