//! Property tests of the core (proptest; RELIABILITY.md):
//!
//! - the int8 kernels against their float references, within the bounds the kernels'
//!   own test suite states, for random layers, scales and inputs;
//! - the dynamic graph's invariants (eq. 3): symmetric, entries in [0, 1], self-loops,
//!   `D̃^−1/2 Ã D̃^−1/2` normalization, masked nodes isolated;
//! - node features finite for any finite window;
//! - NaN, ±∞ and saturated inputs give an error (or, saturated, finite numbers), never
//!   a panic, through features, graph and the shipped int8 model.
//!
//! Cases per property: proptest's default (256), or `PROPTEST_CASES`.
#![cfg(not(miri))] // thousands of random cases: far too slow under the interpreter

use proptest::prelude::*;
use pumptwin_core::bearing::BearingGeometry;
use pumptwin_core::dsstgat::{DsStgat, Output, Scratch};
use pumptwin_core::features::{node_features, FeatureConfig, FeatureScratch, FEATURE_DIM};
use pumptwin_core::graph::{build_dynamic_graphs, Adjacency, GraphConfig, NodeMask};
use pumptwin_core::model_file::{self, ModelFile};
use pumptwin_core::quant::{
    dequantize, quantize_symmetric, softmax_f32, softmax_q15, ExpLut, LinearF32, MaxAbs, QLinear,
    QScale,
};
use pumptwin_core::Error;

const IN: usize = 12;
const OUT: usize = 6;

fn linear_strategy() -> impl Strategy<Value = LinearF32<IN, OUT>> {
    (
        prop::array::uniform6(prop::array::uniform12(-2.0f32..2.0)),
        prop::array::uniform6(-1.0f32..1.0),
    )
        .prop_map(|(w, b)| LinearF32 { w, b })
}

proptest! {
    /// `QLinear` (int8 weights, i32 accumulator, integer requantization) against
    /// `LinearF32` on the dequantized inputs: `|y_q − y| ≤ s_y/2 + s_w·‖x̂‖₁/2 +
    /// s_x·s_w/2` (output rounding, weight rounding, bias rounding) per output.
    #[test]
    fn qlinear_is_within_its_bound_of_the_float_layer(
        float in linear_strategy(),
        xs in prop::collection::vec(prop::array::uniform12(-1.0f32..1.0), 1..6),
        amp in 0.01f32..100.0,
    ) {
        let xs: Vec<[f32; IN]> = xs.iter().map(|x| x.map(|v| v * amp)).collect();
        let mut in_range = MaxAbs::new();
        xs.iter().for_each(|x| in_range.observe_all(x));
        let s_x = in_range.scale().unwrap();
        let mut xq = vec![[0i8; IN]; xs.len()];
        let mut xhat = vec![[0f32; IN]; xs.len()];
        let mut yf = vec![[0f32; OUT]; xs.len()];
        let mut out_range = MaxAbs::new();
        for n in 0..xs.len() {
            quantize_symmetric(&xs[n], s_x, &mut xq[n]).unwrap();
            dequantize(&xq[n], s_x, &mut xhat[n]).unwrap();
            float.forward(&xhat[n], &mut yf[n]);
            out_range.observe_all(&yf[n]);
        }
        let Ok(s_y) = out_range.scale() else {
            return Ok(()); // every output exactly 0: nothing to compare
        };
        let q = match QLinear::from_f32(&float, s_x, s_y) {
            Ok(q) => q,
            // A requantization ratio outside [2^-32, 2^31) is a named error, not a panic.
            Err(Error::InvalidParameter(_)) => return Ok(()),
            Err(e) => panic!("{e:?}"),
        };
        for n in 0..xs.len() {
            let mut yq = [0i8; OUT];
            q.forward(&xq[n], &mut yq);
            let l1: f64 = xhat[n].iter().map(|v| f64::from(v.abs())).sum();
            for o in 0..OUT {
                let sw = f64::from(q.weight_scales()[o].get());
                let (sx, sy) = (f64::from(s_x.get()), f64::from(s_y.get()));
                let want = f64::from(yf[n][o]);
                let tol = 0.5 * sy + 0.5 * sw * l1 + 0.5 * sx * sw + 1e-6 * (1.0 + want.abs());
                let got = f64::from(yq[o]) * sy;
                prop_assert!((got - want).abs() <= tol, "o {o}: {got} vs {want}, tol {tol}");
            }
        }
    }

    /// The Q0.15 softmax against the float one on the same (dequantized) logits: the
    /// row sums to 2^15 within n/2 LSB, masked entries are exactly 0, and every
    /// probability is within 2^-7 of the float value (the LUT's 8-bit input steps).
    #[test]
    fn softmax_q15_follows_the_float_softmax(
        row in prop::collection::vec((any::<i8>(), any::<bool>()), 1..16),
        scale in 0.005f32..0.5,
    ) {
        let logits: Vec<i8> = row.iter().map(|r| r.0.max(-127)).collect();
        let mut mask: Vec<bool> = row.iter().map(|r| r.1).collect();
        mask[0] = true;
        let s = QScale::new(scale).unwrap();
        let exp = ExpLut::new(s);
        let mut p = vec![0u16; logits.len()];
        softmax_q15(&logits, &mask, &exp, &mut p).unwrap();
        let lf: Vec<f32> = logits.iter().map(|&q| s.dequantize(i32::from(q))).collect();
        let mut pf = vec![0f32; logits.len()];
        softmax_f32(&lf, &mask, &mut pf).unwrap();
        let n = mask.iter().filter(|&&m| m).count();
        let total: u32 = p.iter().map(|&v| u32::from(v)).sum();
        prop_assert!((f64::from(total) - 32768.0).abs() <= n as f64 / 2.0, "sum {total}");
        for j in 0..p.len() {
            if !mask[j] {
                prop_assert_eq!(p[j], 0);
            }
            let got = f64::from(p[j]) / 32768.0;
            prop_assert!((got - f64::from(pf[j])).abs() <= 1.0 / 128.0, "{j}: {got} vs {}", pf[j]);
        }
    }
}

const N: usize = 4;
const T: usize = 6;
const D: usize = 5;

fn prior_strategy() -> impl Strategy<Value = [[f32; N]; N]> {
    prop::array::uniform4(prop::array::uniform4(0.0f32..=1.0)).prop_map(|mut p| {
        for i in 0..N {
            for j in 0..i {
                p[i][j] = p[j][i];
            }
        }
        p
    })
}

fn features_strategy() -> impl Strategy<Value = Vec<[[f32; D]; N]>> {
    prop::collection::vec(
        prop::array::uniform4(prop::array::uniform5(-1e3f32..1e3)),
        T..=T,
    )
}

proptest! {
    /// Eq. 3 for any finite features, mask, prior, β, τ and window: every `Â(t)` is
    /// symmetric with entries in [0, 1] and a positive diagonal (self-loops); undoing
    /// the normalization with `d_i = 1/Â_ii` gives `Ã` with `Ã_ii = 1` and row sums
    /// `d_i`; a masked node keeps only its self-loop.
    #[test]
    fn dynamic_graphs_are_symmetric_normalized_with_self_loops(
        x in features_strategy(),
        mask in prop::array::uniform4(any::<bool>()),
        prior in prior_strategy(),
        beta in 0.0f32..=1.0,
        tau in -1.0f32..=1.0,
        window in 1usize..=T,
    ) {
        let cfg = GraphConfig { prior, prior_weight: beta, window_steps: window, tau_corr: tau };
        let mask = NodeMask(mask);
        let mut out = [Adjacency::<N>::ZERO; T];
        build_dynamic_graphs(&cfg, &x, &mask, &mut out).unwrap();
        for a in &out {
            let a = &a.0;
            let d: [f64; N] = core::array::from_fn(|i| 1.0 / f64::from(a[i][i]));
            for i in 0..N {
                prop_assert!(a[i][i] > 0.0 && a[i][i] <= 1.0, "diag {}", a[i][i]);
                let mut row = 0.0f64;
                for j in 0..N {
                    prop_assert!(a[i][j].is_finite() && (0.0..=1.0 + 1e-6).contains(&a[i][j]));
                    prop_assert!((a[i][j] - a[j][i]).abs() <= 1e-6, "not symmetric");
                    row += f64::from(a[i][j]) * (d[i] * d[j]).sqrt();
                    if i != j && !(mask.0[i] && mask.0[j]) {
                        prop_assert_eq!(a[i][j], 0.0, "masked node {} or {} has an edge", i, j);
                    }
                }
                prop_assert!((row - d[i]).abs() <= 1e-4 * d[i], "row {i}: {row} vs degree {}", d[i]);
            }
        }
    }

    /// A NaN or ±∞ in a present node's features is `NonFinite`; in a masked node it is
    /// ignored.
    #[test]
    fn non_finite_graph_features_are_an_error(
        x in features_strategy(),
        at in (0..T, 0..N, 0..D),
        bad in prop::sample::select(vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY]),
        present in any::<bool>(),
    ) {
        let mut x = x;
        x[at.0][at.1][at.2] = bad;
        let mut mask = NodeMask([true; N]);
        mask.0[at.1] = present;
        let mut out = [Adjacency::<N>::ZERO; T];
        let r = build_dynamic_graphs(&GraphConfig::<N>::uniform(), &x, &mask, &mut out);
        if present {
            prop_assert_eq!(r, Err(Error::NonFinite));
        } else {
            prop_assert!(r.is_ok());
        }
    }
}

const W: usize = 512;
const SEG: usize = 4;

fn feature_config(shaft_hz: f32) -> FeatureConfig {
    let mut cfg =
        FeatureConfig::standard(12_000.0, shaft_hz, BearingGeometry::CWRU_6205_DE.orders());
    cfg.segments = SEG;
    cfg
}

fn window_strategy() -> impl Strategy<Value = [f32; W]> {
    prop::collection::vec(-1.0f32..1.0, W).prop_map(|v| core::array::from_fn(|i| v[i]))
}

proptest! {
    /// Any finite window, at amplitudes from 1e-6 to 1e6 g and any shaft rate from
    /// 1 Hz up: the features are all finite, or the window is `Degenerate` (a constant
    /// segment).
    #[test]
    fn features_are_finite_for_any_finite_window(
        x in window_strategy(),
        exp10 in -6i32..=6,
        shaft_hz in prop_oneof![1.0f32..500.0, 500.0f32..1e30],
        constant_tail in any::<bool>(),
    ) {
        let amp = 10f32.powi(exp10);
        let mut x = x.map(|v| v * amp);
        if constant_tail {
            x[W / 2..].fill(0.25 * amp);
        }
        let mut scratch = FeatureScratch::<W>::new();
        let mut rows = [[0.0f32; FEATURE_DIM]; SEG];
        match node_features(&x, &feature_config(shaft_hz), &mut scratch, &mut rows) {
            Ok(()) => {
                for (t, r) in rows.iter().enumerate() {
                    prop_assert!(r.iter().all(|v| v.is_finite()), "row {t}: {r:?}");
                }
            }
            Err(Error::Degenerate) => prop_assert!(constant_tail),
            Err(e) => prop_assert!(false, "{e:?}"),
        }
    }

    /// NaN, ±∞ anywhere in the window is `NonFinite`; a saturated (clipped) sensor,
    /// every sample at ±full scale, gives finite features or `Degenerate`. Extreme
    /// finite values (up to f32::MAX) give finite features or an error: never a panic.
    #[test]
    fn bad_samples_are_an_error_never_a_panic(
        x in window_strategy(),
        at in 0..W,
        bad in prop::sample::select(vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY]),
        full_scale in prop::sample::select(vec![16.0f32, 1e20, f32::MAX]),
    ) {
        let cfg = feature_config(29.95);
        let mut scratch = FeatureScratch::<W>::new();
        let mut rows = [[0.0f32; FEATURE_DIM]; SEG];
        let mut with_bad = x;
        with_bad[at] = bad;
        prop_assert_eq!(
            node_features(&with_bad, &cfg, &mut scratch, &mut rows),
            Err(Error::NonFinite)
        );
        let clipped = x.map(|v| if v >= 0.0 { full_scale } else { -full_scale });
        match node_features(&clipped, &cfg, &mut scratch, &mut rows) {
            Ok(()) => prop_assert!(rows.iter().flatten().all(|v| v.is_finite())),
            Err(Error::Degenerate | Error::NonFinite) => {}
            Err(e) => prop_assert!(false, "{e:?}"),
        }
    }
}

type Net = DsStgat<FEATURE_DIM, 32, 16, 8>;

fn shipped() -> (Box<Net>, GraphConfig<3>) {
    let bytes = include_bytes!("../../models/dsstgat-cwru-tb.ptm");
    let mut file = Box::<ModelFile>::default();
    model_file::decode_into(bytes, &mut file).unwrap();
    let mut net = Box::new(Net::EMPTY);
    net.load(&file).unwrap();
    (net, file.graph_config::<3>().unwrap())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The shipped int8 model on any finite normalized features (±1e30 included: the
    /// input quantizer saturates), any mask with a present node: a class among the
    /// model's; a NaN/∞ in a present node: `NonFinite`, `out` untouched; no node
    /// present: `NothingPresent`.
    #[test]
    fn the_int8_model_answers_or_errs_for_any_input(
        x in prop::collection::vec(prop::array::uniform3(prop::array::uniform::<_, FEATURE_DIM>(
            prop_oneof![-8.0f32..8.0, Just(1e30f32), Just(-1e30f32)])), 8..=8),
        mask in prop::array::uniform3(any::<bool>()),
        bad_at in (0usize..8, 0usize..3, 0..FEATURE_DIM),
        bad in prop::sample::select(vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY]),
    ) {
        let (net, graph) = shipped();
        let mut x8 = [[[0.0f32; FEATURE_DIM]; 3]; 8];
        x8.copy_from_slice(&x[..8]);
        let mask = NodeMask(mask);
        let mut adj = [Adjacency::<3>::ZERO; 8];
        let mut out = Output::<16, 8>::default();
        let mut scratch = Box::new(Scratch::<8, 3, FEATURE_DIM, 32>::new());
        let clipped = x8.map(|s| s.map(|n| n.map(|v| v.clamp(-1e3, 1e3))));
        build_dynamic_graphs(&graph, &clipped, &mask, &mut adj).unwrap();
        let r = net.forward(&x8, &adj, &mask, &mut out, &mut scratch);
        if mask.count() == 0 {
            prop_assert_eq!(r, Err(Error::NothingPresent));
            return Ok(());
        }
        prop_assert!(r.is_ok(), "{r:?}");
        prop_assert!(out.class < net.classes());
        let before = out;
        x8[bad_at.0][bad_at.1][bad_at.2] = bad;
        let r = net.forward(&x8, &adj, &mask, &mut out, &mut scratch);
        if mask.0[bad_at.1] {
            prop_assert_eq!(r, Err(Error::NonFinite));
            prop_assert_eq!(out, before);
        } else {
            prop_assert!(r.is_ok());
        }
    }
}
