//! `pumptwin train`, `eval`, `predict` and `compare` end to end on the measured CWRU
//! records: the full DS-STGAT (physics embedding, co-adaptation heads) and a raw-signal
//! baseline (WDCNN), one epoch each on `time-block`, and the DS-STGAT with the derived
//! temperature/pressure nodes. Checks the files and the `metrics.json` keys downstream
//! tools read, that `eval` of the saved model gives the training run's figures back,
//! that `predict` runs a baseline and a derived-node model, and that `compare`
//! tabulates the runs (the derived-node one apart). Skips with a notice when
//! `../shared/data/cwru` is absent.

use std::path::{Path, PathBuf};

use pumptwin::commands::RecordArgs;
use pumptwin::compare::{run_compare, CompareArgs};
use pumptwin::eval::{run_eval, EvalArgs};
use pumptwin::predict::{run_predict, PredictArgs};
use pumptwin::train::{run_train, TrainArgs};
use pumptwin_data::windows::Protocol;
use pumptwin_trainer::dataset::NodeSet;
use pumptwin_trainer::training::{Ablation, Arch};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn train_eval_predict_compare_on_cwru() {
    let data = root().join("../shared/data/cwru");
    if !data.join("MANIFEST.tsv").is_file() {
        eprintln!("skipped: {} not present", data.display());
        return;
    }
    let tmp = std::env::temp_dir().join(format!("pumptwin-train-e2e-{}", std::process::id()));
    let runs = tmp.join("runs");
    for (arch, nodes, name) in [
        (Arch::DsStgat, NodeSet::Measured, "dsstgat"),
        (Arch::Wdcnn, NodeSet::Measured, "wdcnn"),
        (Arch::DsStgat, NodeSet::Derived, "dsstgat+derived-nodes"),
    ] {
        let out = runs.join("time-block").join(name);
        run_train(&TrainArgs {
            data: data.clone(),
            protocol: Protocol::TimeBlock,
            out: out.clone(),
            config: None,
            epochs: Some(1),
            seed: Some(42),
            no_monitor: true,
            arch,
            ablation: Ablation::None,
            nodes,
            theta_cache: tmp.join("theta"),
            no_figures: false,
        })
        .unwrap();
        let m = json(&out.join("metrics.json"));
        for key in [
            "protocol",
            "arch",
            "classes",
            "accuracy",
            "precision_macro",
            "recall_macro",
            "f1_weighted",
            "confusion",
            "noise",
            "n_train_windows",
            "n_test_windows",
            "spectral_consistency",
            "response_mse",
            "parameter_drift",
        ] {
            assert!(m.get(key).is_some(), "{name}: metrics.json lacks {key}");
        }
        assert_eq!(m["arch"], name);
        assert_eq!(m["n_train_windows"], 2903);
        assert_eq!(m["n_test_windows"], 1278);
        assert_eq!(m["noise"].as_array().unwrap().len(), 6);
        let acc = m["accuracy"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&acc));
        // Physics metrics exactly where the physics heads are.
        let physics = m["spectral_consistency"].as_f64();
        assert_eq!(
            physics.is_some(),
            arch == Arch::DsStgat,
            "{name}: {physics:?}"
        );
        if arch == Arch::DsStgat {
            assert!(m["response_mse"].as_f64().unwrap() > 0.0);
            assert!(out.join("physics_heads.bpk").is_file());
            let cfg = json(&out.join("config.json"));
            let n = if nodes == NodeSet::Derived { 5 } else { 3 };
            assert_eq!(cfg["graph_prior"].as_array().unwrap().len(), n * n);
            // One fault-only figure per node with that node masked.
            assert_eq!(m["node_masked"].as_array().unwrap().len(), n, "{name}");
        }
        for png in [
            "confusion.png",
            "noise.png",
            "loss.png",
            "embedding_tsne.png",
            "feature_correlation.png",
        ] {
            let bytes = std::fs::read(out.join(png)).unwrap();
            assert_eq!(&bytes[1..4], b"PNG", "{name}/{png}");
        }
        // eval of the saved weights gives the run's own figures back.
        let eval_out = tmp.join(format!("eval-{name}"));
        run_eval(&EvalArgs {
            model: out.join("model.bpk"),
            data: data.clone(),
            protocol: Protocol::TimeBlock,
            out: eval_out.clone(),
            no_figures: true,
            experts: (arch == Arch::DsStgat).then(|| eval_out.join("experts.json")),
        })
        .unwrap();
        let e = json(&eval_out.join("metrics.json"));
        assert_eq!(e["accuracy"], m["accuracy"], "{name}");
        assert_eq!(e["confusion"], m["confusion"], "{name}");
        if arch == Arch::DsStgat {
            experts_agree_with_metrics(&json(&eval_out.join("experts.json")), &e, name);
        }
    }
    // predict runs a raw-signal baseline too, and a derived-node model (its extra nodes
    // computed from the record's DE).
    let p_out = tmp.join("predict.json");
    let predict = |model: &str| {
        run_predict(&PredictArgs {
            record: RecordArgs {
                input: root().join("tests/data/cwru105_1s.csv"),
                fs: Some(12_000.0),
                rpm: Some(1797.0),
                bearing: "cwru-6205-de".into(),
                var: Vec::new(),
            },
            model: runs.join("time-block").join(model).join("model.bpk"),
            out: Some(p_out.clone()),
            json: false,
        })
        .unwrap();
        json(&p_out)
    };
    let p = predict("wdcnn");
    assert_eq!(p["arch"], "wdcnn");
    assert!(!p["windows"].as_array().unwrap().is_empty());
    let p = predict("dsstgat+derived-nodes");
    assert_eq!(p["arch"], "dsstgat+derived-nodes");
    let windows = p["windows"].as_array().unwrap();
    assert!(!windows.is_empty());
    assert!(windows
        .iter()
        .all(|w| !w["masked_nodes"].to_string().contains("TEMP")));
    // compare tabulates what exists and trains nothing.
    let cmp_out = tmp.join("compare");
    run_compare(&CompareArgs {
        data,
        runs: runs.clone(),
        out: cmp_out.clone(),
        protocols: vec![Protocol::TimeBlock],
        epochs: None,
        seed: 42,
        no_train: true,
    })
    .unwrap();
    let c = json(&cmp_out.join("compare.json"));
    let rows = c["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 8);
    let have: Vec<&str> = rows
        .iter()
        .filter(|r| r["accuracy"][0].is_number())
        .map(|r| r["model"].as_str().unwrap())
        .collect();
    assert_eq!(have, ["dsstgat", "wdcnn"]);
    let separate = c["separate"].as_array().unwrap();
    assert_eq!(separate.len(), 1);
    assert_eq!(separate[0]["model"], "dsstgat+derived-nodes");
    assert!(separate[0]["accuracy"][0].is_number());
    assert!(std::fs::read_to_string(cmp_out.join("compare.md"))
        .unwrap()
        .contains("| dsstgat |"));
    for png in ["radar.png", "ablation.png"] {
        assert!(cmp_out.join(png).is_file());
    }
    let _ = std::fs::remove_dir_all(&tmp);
}

/// The parts `pumptwin eval --experts` writes, weighed as the model weighs them and
/// with the defect-line vote, give the clean accuracy and the noise curve of
/// `metrics.json`.
fn experts_agree_with_metrics(x: &serde_json::Value, m: &serde_json::Value, name: &str) {
    let numbers = |v: &serde_json::Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|n| n.as_f64().unwrap())
            .collect()
    };
    let label: Vec<usize> = numbers(&x["label"]).iter().map(|&l| l as usize).collect();
    let w = numbers(&x["weights"]);
    let conditions = x["conditions"].as_array().unwrap();
    let noise = m["noise"].as_array().unwrap();
    assert_eq!(conditions.len(), 1 + noise.len(), "{name}");
    for (k, c) in conditions.iter().enumerate() {
        let part = |key: &str| c[key].as_array().unwrap().clone();
        let (a, s, kin, vote) = (
            part("network"),
            part("spectral"),
            part("kinematic"),
            part("line_vote"),
        );
        assert_eq!(vote.len(), label.len(), "{name}: the DS-STGAT has a vote");
        assert_eq!(a.len(), label.len(), "{name}");
        let mut correct = 0;
        for (j, &y) in label.iter().enumerate() {
            let row = |p: &[serde_json::Value]| numbers(&p[j]);
            let (ra, rs, rk, rv) = (row(&a), row(&s), row(&kin), row(&vote));
            let logit = |i: usize| w[0] * ra[i] + w[1] * rs[i] + w[2] * rk[i] + rv[i];
            let best = (0..ra.len())
                .max_by(|&p, &q| logit(p).total_cmp(&logit(q)))
                .unwrap();
            correct += usize::from(best == y);
        }
        let acc = correct as f64 / label.len() as f64;
        let want = if k == 0 {
            assert!(c["snr_db"].is_null(), "{name}");
            m["accuracy"].as_f64().unwrap()
        } else {
            assert_eq!(c["snr_db"], noise[k - 1]["snr_db"], "{name}");
            noise[k - 1]["accuracy"].as_f64().unwrap()
        };
        // The parts summed in f64 here, in f32 by the model: a near-tie may fall
        // either way.
        assert!(
            (acc - want).abs() <= 2.0 / label.len() as f64,
            "{name} condition {k}: {acc} vs {want}"
        );
    }
}
