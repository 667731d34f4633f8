//! Unit tests of the training loop, its losses and its batches.

use burn::module::Module;
use burn::optim::{GradientsAccumulator, GradientsParams};
use burn::tensor::{Device, Tensor, TensorData};
use pumptwin_core::features::FeatureNorm;
use pumptwin_core::rng::Xoshiro128pp;

use super::artifacts::{read_config, MODEL_FILE};
use super::batch::{Batch, BatchParts};
use super::config::TrainConfig;
use super::fit::{replica_step, train, ReplicaInput, TrainOutcome};
use super::inference::{infer, mean_loss, normalized_weights};
use super::loss::{class_weights, record_alignment, record_alignment_ops};
use super::net::Network;
use crate::dataset::{
    Dataset, IndicatorNorm, NodeSet, ProtocolData, FEATURES, NODES, N_INDICATORS, N_NODES, STEPS,
};
use crate::model::DsStgat;
use pumptwin_core::graph::GraphConfig;
use pumptwin_data::windows::Protocol;
use pumptwin_data::windows::Split;

/// A tiny synthetic two-class problem: class 1 has a larger feature 0 at node 0.
fn tiny_dataset(n: usize, seed: u64) -> Dataset {
    let mut rng = Xoshiro128pp::seed_from_u64(seed);
    let mut ds = Dataset::default();
    for k in 0..n {
        let label = k % 2;
        let mut x = [[[0.0f32; FEATURES]; N_NODES]; STEPS];
        for step in x.iter_mut() {
            for (i, row) in step.iter_mut().enumerate() {
                for v in row.iter_mut() {
                    *v = rng.normal() as f32;
                }
                if i == 0 {
                    row[0] += if label == 1 { 1.5 } else { -1.5 };
                }
            }
        }
        let mut a = [pumptwin_core::graph::Adjacency::<N_NODES>::ZERO; STEPS];
        for m in a.iter_mut() {
            m.0 = [[0.5, 0.3, 0.2], [0.3, 0.5, 0.2], [0.2, 0.2, 0.6]];
        }
        let mask = [true, true, k % 3 != 0];
        let ind = [label as f32, 0.0, 0.5, -0.5];
        ds.push(&x, &a, &mask, &ind, label, k % 4);
    }
    ds
}

/// Reference of the record-alignment ratio by plain loops.
fn alignment_by_loops(g: &[[f64; 3]], rec: &[usize], cls: &[i64]) -> f64 {
    let mean_of = |keep: &dyn Fn(usize) -> bool| {
        let mut m = [0.0f64; 3];
        let mut n = 0.0;
        for gj in (0..g.len()).filter(|&j| keep(j)).map(|j| g[j]) {
            for (md, gd) in m.iter_mut().zip(gj) {
                *md += gd;
            }
            n += 1.0;
        }
        m.map(|v| v / n)
    };
    let all = mean_of(&|_| true);
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..g.len() {
        let mr = mean_of(&|j| rec[j] == rec[i]);
        let mc = mean_of(&|j| cls[j] == cls[i]);
        for d in 0..3 {
            num += (mr[d] - mc[d]).powi(2);
            den += (g[i][d] - all[d]).powi(2);
        }
    }
    num / den
}

#[test]
fn record_alignment_is_the_between_record_share_of_the_scatter() {
    let device = Device::default();
    // Windows 0..10 of the tiny set: labels k % 2, records k % 4 (two per class).
    let ds = tiny_dataset(10, 3);
    let idx: Vec<usize> = (0..10).collect();
    let (between, total) = record_alignment_ops(&ds, &idx, &device);
    let ratio = |g: &[[f64; 3]]| {
        let flat: Vec<f32> = g.iter().flatten().map(|&v| v as f32).collect();
        let t = Tensor::<2>::from_data(TensorData::new(flat, [g.len(), 3]), &device);
        f64::from(record_alignment(t, between.clone(), total.clone()).into_scalar::<f32>())
    };
    let mut rng = Xoshiro128pp::seed_from_u64(5);
    let g: Vec<[f64; 3]> = (0..10)
        .map(|_| [rng.normal(), rng.normal(), rng.normal()])
        .collect();
    let want = alignment_by_loops(&g, &ds.record[..10], &ds.label[..10]);
    assert!(want > 0.01 && want < 1.0, "{want}");
    assert!((ratio(&g) - want).abs() < 1e-5, "{} vs {want}", ratio(&g));
    // Scale-free: a larger embedding cannot lower it.
    let g10: Vec<[f64; 3]> = g.iter().map(|v| v.map(|x| 10.0 * x)).collect();
    assert!((ratio(&g10) - want).abs() < 1e-5);
    // Records of a class that look alike: no record term, whatever the classes do.
    let alike: Vec<[f64; 3]> = (0..10)
        .map(|k| {
            if k % 2 == 0 {
                [1.0, 0.0, 2.0]
            } else {
                [0.0, 3.0, 0.0]
            }
        })
        .collect();
    assert!(ratio(&alike) < 1e-6);
    // Records of a class that differ and nothing else: all scatter is between records.
    let by_record: Vec<[f64; 3]> = (0..10).map(|k| [(k % 4) as f64, 0.0, 0.0]).collect();
    let r = ratio(&by_record);
    let want = alignment_by_loops(&by_record, &ds.record[..10], &ds.label[..10]);
    assert!((r - want).abs() < 1e-5 && r > 0.3, "{r} vs {want}");
    // One record for every window (the simulated pre-training set): the term is
    // the between-class share of the scatter.
    let mut one = tiny_dataset(10, 3);
    one.record.iter_mut().for_each(|r| *r = 0);
    let (between, total) = record_alignment_ops(&one, &idx, &device);
    let flat: Vec<f32> = g.iter().flatten().map(|&v| v as f32).collect();
    let t = Tensor::<2>::from_data(TensorData::new(flat, [10, 3]), &device);
    let got = f64::from(record_alignment(t, between, total).into_scalar::<f32>());
    let cls: Vec<usize> = one.label[..10].iter().map(|&l| l as usize).collect();
    let mut want_b = 0.0;
    let mut want_t = 0.0;
    let mean = |keep: &dyn Fn(usize) -> bool| {
        let n = (0..10).filter(|&j| keep(j)).count() as f64;
        let mut m = [0.0f64; 3];
        for j in (0..10).filter(|&j| keep(j)) {
            for d in 0..3 {
                m[d] += g[j][d] / n;
            }
        }
        m
    };
    let all = mean(&|_| true);
    for i in 0..10 {
        let mc = mean(&|j| cls[j] == cls[i]);
        for d in 0..3 {
            want_b += (mc[d] - all[d]).powi(2);
            want_t += (g[i][d] - all[d]).powi(2);
        }
    }
    assert!(
        (got - want_b / want_t).abs() < 1e-5,
        "{got} vs {}",
        want_b / want_t
    );
}

#[test]
fn a_config_without_the_node_layout_reads_as_measured() {
    let dir = std::env::temp_dir().join(format!("pumptwin-cfg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("config.json");
    let mut v = serde_json::to_value(TrainConfig::new().with_epochs(3)).unwrap();
    v.as_object_mut().unwrap().remove("nodes");
    std::fs::write(&path, v.to_string()).unwrap();
    let cfg = read_config(&path).unwrap();
    assert_eq!((cfg.nodes.as_str(), cfg.epochs), ("measured", 3));
    assert_eq!(cfg.node_set().unwrap(), NodeSet::Measured);
    // A derived-node config keeps its layout; a wrong file is an error.
    let derived = TrainConfig::new().with_nodes("derived".into());
    std::fs::write(&path, serde_json::to_string(&derived).unwrap()).unwrap();
    assert_eq!(
        read_config(&path).unwrap().node_set().unwrap(),
        NodeSet::Derived
    );
    std::fs::write(&path, "[1, 2]").unwrap();
    assert!(read_config(&path).is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

fn tiny_protocol() -> ProtocolData {
    ProtocolData {
        protocol: Protocol::TimeBlock,
        nodes: NODES,
        split: Split {
            protocol: Protocol::TimeBlock,
            classes: vec!["a".into(), "b".into()],
            train: Vec::new(),
            test: Vec::new(),
        },
        norm: FeatureNorm::IDENTITY,
        indicator_norm: IndicatorNorm {
            mean: [0.0; N_INDICATORS],
            std: [1.0; N_INDICATORS],
        },
        graph: GraphConfig::uniform(),
        train: tiny_dataset(48, 1),
        test: tiny_dataset(16, 2),
        mask_counts: Default::default(),
        featurize_seconds: 0.0,
    }
}

/// Two replicas (halves of a batch, each with its own parameter copy) give the
/// gradient and the loss of the whole batch (CE + indicator terms: exact up to f32
/// rounding).
#[test]
fn two_replicas_give_the_batch_gradient() {
    let _rng = crate::device_rng_lock();
    let data = tiny_protocol();
    let cfg = TrainConfig::new().with_hidden(8).with_compressed(4);
    let device = Device::flex().autodiff();
    device.seed(3);
    let model = cfg.model_config(2).init(&device);
    let ds = &data.train;
    let chunk: Vec<usize> = (0..16).collect();
    let w_all = normalized_weights(&chunk, ds, &class_weights(&ds.label, 2));
    let input = |idx: &[usize], off: usize| ReplicaInput {
        batch: Batch::new(ds, idx, &device),
        labels: idx.iter().map(|&k| ds.label[k]).collect(),
        weights: Tensor::from_data(
            TensorData::new(w_all[off..off + idx.len()].to_vec(), [idx.len()]),
            &device,
        ),
        share: idx.len() as f64 / chunk.len() as f64,
        // The record term is a ratio over each replica's own windows, not a sum:
        // not part of this identity.
        align: None,
    };
    let whole = replica_step(&model, None, input(&chunk, 0), &cfg);
    let a = replica_step(
        &model.clone().fork(&device),
        None,
        input(&chunk[..8], 0),
        &cfg,
    );
    let b = replica_step(
        &model.clone().fork(&device),
        None,
        input(&chunk[8..], 8),
        &cfg,
    );
    assert!((a.sums[0] + b.sums[0] - whole.sums[0]).abs() < 1e-5 * whole.sums[0].abs());
    assert_eq!(a.correct + b.correct, whole.correct);
    let mut acc = GradientsAccumulator::<DsStgat>::new();
    acc.accumulate(&model, a.model_grads);
    acc.accumulate(&model, b.model_grads);
    let split = acc.grads();
    for id in [model.embed.weight.id, model.gru.hidden_n.weight.id] {
        let g = |gp: &GradientsParams| -> Vec<f32> {
            gp.get::<2>(id).unwrap().into_data().try_into_vec().unwrap()
        };
        let (g1, g2) = (g(&whole.model_grads), g(&split));
        let scale = g1.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let diff = g1
            .iter()
            .zip(&g2)
            .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
        assert!(scale > 0.0 && diff <= 1e-4 * scale, "{diff} of {scale}");
    }
}

#[test]
fn class_weights_balance_the_classes() {
    let w = class_weights(&[0, 1, 1, 1], 3);
    assert_eq!(w, vec![2.0, 4.0 / 6.0, 0.0]);
}

#[test]
fn a_few_epochs_lower_the_loss() {
    let _rng = crate::device_rng_lock();
    let data = tiny_protocol();
    // Five epochs, not one: a single epoch of six steps from a random start moves
    // the loss by less than its step-to-step wobble (0.731 → 0.734 at F = 27).
    let cfg = TrainConfig::new()
        .with_epochs(5)
        .with_batch_size(8)
        .with_hidden(8)
        .with_compressed(4)
        .with_learning_rate(1e-2);
    let plain = Device::flex();
    plain.seed(cfg.seed);
    let fresh = cfg.model_config(2).init(&plain);
    let before = mean_loss(&fresh, &data.train, &cfg, 2, &plain);
    let mut log = Vec::new();
    let out = train(&cfg, &data, None, true, &mut |s| log.push(*s)).unwrap();
    assert_eq!(log.len(), 5);
    let Network::DsStgat(model) = out.network.valid() else {
        panic!("dsstgat expected")
    };
    let after = mean_loss(&model, &data.train, &cfg, 2, &plain);
    assert!(after < before, "loss {before} -> {after}");
    // Same seed, same run.
    let again = train(&cfg, &data, None, false, &mut |_| {}).unwrap();
    let Network::DsStgat(model2) = again.network.valid() else {
        panic!("dsstgat expected")
    };
    let classes =
        |m: &DsStgat| infer(&Network::DsStgat(m.clone()), None, &data.test, 5, &plain).classes;
    assert_eq!(classes(&model), classes(&model2));
    assert_eq!(mean_loss(&model2, &data.train, &cfg, 2, &plain), after);
    let out = TrainOutcome {
        network: Network::DsStgat(model),
        ..again
    };
    let Network::DsStgat(trained) = &out.network else {
        unreachable!()
    };
    // Weights survive a save/load round trip.
    let dir = std::env::temp_dir().join(format!("pumptwin-train-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(MODEL_FILE);
    trained.clone().save_file(&path).unwrap();
    let loaded = cfg
        .model_config(2)
        .init(&plain)
        .try_load_file(&path)
        .unwrap();
    assert_eq!(mean_loss(&loaded, &data.train, &cfg, 2, &plain), after);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A batch-norm network (WDCNN) gives the same logits after save → load →
/// `valid()` as the trained one after `valid()`.
#[test]
fn batch_norm_network_survives_save_and_load() {
    let _rng = crate::device_rng_lock();
    let mut data = tiny_protocol();
    let mut rng = Xoshiro128pp::seed_from_u64(9);
    for ds in [&mut data.train, &mut data.test] {
        ds.raw = (0..ds.len() * ds.raw_per_window())
            .map(|_| rng.normal() as f32)
            .collect();
        ds.spectra = vec![0.0; ds.len() * ds.spec_per_window()];
    }
    let mut cfg = TrainConfig::new().with_epochs(1).with_batch_size(8);
    cfg.arch = "wdcnn".into();
    let out = train(&cfg, &data, None, false, &mut |_| {}).unwrap();
    let plain = Device::flex();
    let live = out.network.valid();
    let dir = std::env::temp_dir().join(format!("pumptwin-bn-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(MODEL_FILE);
    out.network.save(&path).unwrap();
    let loaded = Network::init(&cfg, 2, &plain)
        .unwrap()
        .load(&path)
        .unwrap()
        .valid();
    let parts = BatchParts {
        raw: true,
        physics: false,
    };
    let idx: Vec<usize> = (0..data.test.len()).collect();
    let b = Batch::with_parts(&data.test, &idx, parts, &plain);
    let a: Vec<f32> = live.output(&b).logits.into_data().try_into_vec().unwrap();
    let c: Vec<f32> = loaded.output(&b).logits.into_data().try_into_vec().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let diff = a
        .iter()
        .zip(&c)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max);
    assert!(diff < 1e-4, "max |Δlogit| {diff}: {a:?} vs {c:?}");
}
