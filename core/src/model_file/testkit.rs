//! Test fixtures of the model file's tests: the quantized kernels of a small random
//! model and the [`ModelFile`] built from them.

use heapless::{String, Vec};

use crate::bearing::BearingGeometry;
use crate::features::{FeatureNorm, FEATURE_DIM};
use crate::graph::GraphConfig;
use crate::layout::SENSOR_HEAD_INPUTS;
use crate::quant::{
    AttentionPool, AttentionPoolF32, Classifier, GatLayer, GatLayerF32, GatScales, GruCell,
    GruCellF32, LinearF32, QLinear, QScale,
};
use crate::rng::Xoshiro128pp;
use crate::simulator::BearingParams;

use super::parts::{
    DiagnosisParts, Dimensions, GatParts, GeometryParts, GraphParts, GruParts, IndicatorParts,
    ModelFile, NormParts, PhysicsParts, QLinearParts,
};

pub(super) const N: usize = 3;
pub(super) const F: usize = FEATURE_DIM;
pub(super) const T: usize = 4;
pub(super) const HG: usize = 8;
pub(super) const HR: usize = 8;
pub(super) const C: usize = 4;
pub(super) const K: usize = 2;

fn uniform(rng: &mut Xoshiro128pp, amp: f64) -> f32 {
    ((rng.uniform() * 2.0 - 1.0) * amp) as f32
}

fn matrix<const R: usize, const K: usize>(rng: &mut Xoshiro128pp, amp: f64) -> [[f32; K]; R] {
    core::array::from_fn(|_| core::array::from_fn(|_| uniform(rng, amp)))
}

fn vector<const K: usize>(rng: &mut Xoshiro128pp, amp: f64) -> [f32; K] {
    core::array::from_fn(|_| uniform(rng, amp))
}

pub(super) fn name<const L: usize>(s: &str) -> String<L> {
    String::try_from(s).unwrap()
}

/// The quantized kernels of a small random model.
pub(super) struct Kernels {
    pub(super) embed: QLinear<F, HG>,
    pub(super) gat: GatLayer<HG, HG>,
    pub(super) gru: GruCell<HG, HR>,
    pub(super) pool: AttentionPool<HR>,
    pub(super) classifier: Classifier<HR, C>,
    pub(super) indicator: QLinear<HR, K>,
    pub(super) sensor: QLinear<SENSOR_HEAD_INPUTS, C>,
}

pub(super) fn kernels(seed: u64) -> Kernels {
    let mut rng = Xoshiro128pp::seed_from_u64(seed);
    let embed = QLinear::from_f32(
        &LinearF32::<F, HG> {
            w: matrix(&mut rng, 0.4),
            b: vector(&mut rng, 0.1),
        },
        QScale::new(5.0 / 127.0).unwrap(),
        QScale::new(3.0 / 127.0).unwrap(),
    )
    .unwrap();
    let gat_f = GatLayerF32::<HG, HG> {
        w: matrix(&mut rng, 0.4),
        a_src: vector(&mut rng, 1.0),
        a_dst: vector(&mut rng, 1.0),
        bias: vector(&mut rng, 0.1),
    };
    let gat_scales = GatScales {
        input: QScale::new(3.0 / 127.0).unwrap(),
        projected: QScale::new(4.0 / 127.0).unwrap(),
        logit: QScale::new(6.0 / 127.0).unwrap(),
        output: QScale::new(2.0 / 127.0).unwrap(),
    };
    let gat = GatLayer::from_f32(&gat_f, gat_scales).unwrap();
    let lin = |rng: &mut Xoshiro128pp| LinearF32::<HG, HR> {
        w: matrix(rng, 0.3),
        b: vector(rng, 0.1),
    };
    let gru_f = GruCellF32::<HG, HR> {
        w_z: lin(&mut rng),
        w_r: lin(&mut rng),
        w_n: lin(&mut rng),
        u_z: matrix(&mut rng, 0.3),
        u_r: matrix(&mut rng, 0.3),
        u_n: matrix(&mut rng, 0.3),
    };
    let gru = GruCell::from_f32(&gru_f, gat_scales.output).unwrap();
    let pool_f = AttentionPoolF32::<HR> {
        w: vector(&mut rng, 0.5),
        b: 0.1,
    };
    let pool =
        AttentionPool::from_f32(&pool_f, QScale::UNIT, QScale::new(4.0 / 127.0).unwrap()).unwrap();
    let cls_f = LinearF32::<HR, C> {
        w: matrix(&mut rng, 0.5),
        b: vector(&mut rng, 0.2),
    };
    let classifier =
        Classifier::from_f32(&cls_f, QScale::UNIT, QScale::new(1e-4).unwrap()).unwrap();
    let indicator = QLinear::from_f32(
        &LinearF32::<HR, K> {
            w: matrix(&mut rng, 0.5),
            b: vector(&mut rng, 0.2),
        },
        QScale::UNIT,
        QScale::new(1e-4).unwrap(),
    )
    .unwrap();
    let sensor = QLinear::from_f32(
        &LinearF32::<SENSOR_HEAD_INPUTS, C> {
            w: matrix(&mut rng, 0.3),
            b: vector(&mut rng, 0.2),
        },
        QScale::new(2.0 / 127.0).unwrap(),
        QScale::new(1e-4).unwrap(),
    )
    .unwrap();
    Kernels {
        embed,
        gat,
        gru,
        pool,
        classifier,
        indicator,
        sensor,
    }
}

pub(super) fn model_from(k: &Kernels) -> ModelFile {
    let mut mean = [0.0f32; FEATURE_DIM];
    let mut std = [1.0f32; FEATURE_DIM];
    for (i, (m, s)) in mean.iter_mut().zip(std.iter_mut()).enumerate() {
        *m = i as f32 * 0.25 - 1.0;
        *s = 0.5 + i as f32 * 0.125;
    }
    let mut prior = [[0.5f32; N]; N];
    prior[0][2] = 0.25;
    prior[2][0] = 0.25;
    ModelFile {
        model_name: name("ds-stgat-cwru-test"),
        created: name("2025-01-31"),
        dims: Dimensions {
            nodes: N as u16,
            features: F as u16,
            steps: T as u16,
            gat_hidden: HG as u16,
            gru_hidden: HR as u16,
            heads: 1,
            classes: C as u16,
            indicators: K as u16,
        },
        class_names: ["normal", "IR", "B", "OR"]
            .iter()
            .map(|s| name(s))
            .collect(),
        sensor_names: ["DE", "FE", "BA"].iter().map(|s| name(s)).collect(),
        feature_norm: NormParts::from(&FeatureNorm::new(mean, std).unwrap()),
        graph: GraphParts::from_config(&GraphConfig::<N> {
            prior,
            prior_weight: 0.3,
            window_steps: 3,
            tau_corr: 0.3,
        })
        .unwrap(),
        embed: QLinearParts::from_qlinear(&k.embed).unwrap(),
        gat: GatParts::from_layer(&k.gat).unwrap(),
        gru: GruParts::from_cell(&k.gru).unwrap(),
        pool: QLinearParts::from_qlinear(k.pool.score()).unwrap(),
        classifier: QLinearParts::from_qlinear(k.classifier.linear()).unwrap(),
        sensor_head: QLinearParts::from_qlinear(&k.sensor).unwrap(),
        indicator: IndicatorParts {
            names: ["impact", "band_ratio"].iter().map(|s| name(s)).collect(),
            mean: Vec::from_slice(&[0.5, -1.0]).unwrap(),
            std: Vec::from_slice(&[2.0, 0.25]).unwrap(),
            head: QLinearParts::from_qlinear(&k.indicator).unwrap(),
        },
        physics: PhysicsParts::from(&BearingParams::default_housing()),
        geometry: GeometryParts::from(&BearingGeometry::CWRU_6205_DE),
        diagnosis: DiagnosisParts::default(),
    }
}

pub(super) fn test_model() -> ModelFile {
    model_from(&kernels(7))
}
