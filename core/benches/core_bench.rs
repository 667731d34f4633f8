//! Throughput of the core's hot paths, on one core, as a plain bench binary.
//!
//! ```text
//! cargo bench -p pumptwin-core --bench core_bench -- [--json PATH] [--dump PATH]
//! ```
//!
//! 1. RK4 on the 2-DOF model (f64 and f32): integration alone (force precomputed on
//!    the half-step grid) and end to end (rendering the eq. 18–20 force included).
//!    Same model, force and step as `benches/rk4_reference.py` (h = 1/192000 s, 1 s).
//! 2. Features (3 nodes × 2048 samples, T = 8) + dynamic graph, per window.
//!
//! `--dump PATH` writes x_r every 48th output sample of the h = 1/48000 grid as CSV,
//! for the trajectory comparison with the Python RK4 (`benches/rk4_compare.sh`).

use pumptwin_core::bearing::BearingGeometry;
use pumptwin_core::excitation::{
    CompositeExcitation, ImpactTrain, RandomExcitation, ShaftSinusoid, TimeGrid,
};
use pumptwin_core::features::{node_features, FeatureConfig, FeatureScratch, FEATURE_DIM};
use pumptwin_core::fft::{fft_walked, Complex32, Direction};
use pumptwin_core::graph::{build_dynamic_graphs, Adjacency, GraphConfig, NodeMask};
use pumptwin_core::rng::Xoshiro128pp;
use pumptwin_core::simulator::{Bearing2Dof, BearingParams, Real, State};
use std::hint::black_box;
use std::time::Instant;

const SUB: usize = 4;
const STEPS: usize = 48_000 * SUB;
const H: f64 = 1.0 / (48_000.0 * SUB as f64);

fn excitation() -> CompositeExcitation {
    CompositeExcitation {
        impact: ImpactTrain::periodic(400.0, 162.1, 2.0e-5),
        sinusoid: ShaftSinusoid {
            amplitude: 20.0,
            shaft_hz: 29.93,
            phase_rad: 0.0,
            drift_per_s: 0.0,
        },
        random: RandomExcitation {
            noise_std: 0.0,
            pulse_rate_hz: 0.0,
            pulse_amplitude: 0.0,
            pulse_sigma_s: 1e-5,
        },
        w_impact: 1.0,
        w_sin: 1.0,
        w_rand: 0.0,
        angular_share: 0.3,
    }
}

fn render_force() -> (Vec<f64>, Vec<f64>) {
    let mut fr = vec![0.0; 2 * STEPS + 1];
    let mut ft = vec![0.0; 2 * STEPS + 1];
    let mut rng = Xoshiro128pp::seed_from_u64(0);
    excitation()
        .render(
            TimeGrid {
                t0: 0.0,
                dt: H / 2.0,
            },
            &mut fr,
            &mut ft,
            &mut rng,
        )
        .expect("valid excitation");
    (fr, ft)
}

/// Best wall time of `f` over repeats until `min_total` seconds have been spent.
fn best_of<R>(min_total: f64, mut f: impl FnMut() -> R) -> f64 {
    let mut best = f64::INFINITY;
    let mut total = 0.0;
    let mut reps = 0;
    while total < min_total || reps < 3 {
        let t0 = Instant::now();
        black_box(f());
        let dt = t0.elapsed().as_secs_f64();
        best = best.min(dt);
        total += dt;
        reps += 1;
    }
    best
}

fn rk4_rate<T: Real>(fr: &[f64], ft: &[f64]) -> f64 {
    let model = Bearing2Dof::<T>::new(&BearingParams::default_housing()).expect("valid params");
    let fr: Vec<T> = fr.iter().map(|&v| T::from_f64(v)).collect();
    let ft: Vec<T> = ft.iter().map(|&v| T::from_f64(v)).collect();
    let mut ar = vec![T::ZERO; STEPS];
    let mut at = vec![T::ZERO; STEPS];
    let h = T::from_f64(H);
    let secs = best_of(1.0, || {
        model
            .simulate(
                State::REST,
                black_box(h),
                black_box(&fr),
                &ft,
                &mut ar,
                &mut at,
            )
            .expect("stable")
    });
    STEPS as f64 / secs
}

fn end_to_end_rate() -> f64 {
    let model = Bearing2Dof::<f64>::new(&BearingParams::default_housing()).expect("valid params");
    let mut fr = vec![0.0; 2 * STEPS + 1];
    let mut ft = vec![0.0; 2 * STEPS + 1];
    let mut ar = vec![0.0; STEPS];
    let mut at = vec![0.0; STEPS];
    let ex = excitation();
    let secs = best_of(1.0, || {
        let mut rng = Xoshiro128pp::seed_from_u64(0);
        ex.render(
            TimeGrid {
                t0: 0.0,
                dt: H / 2.0,
            },
            &mut fr,
            &mut ft,
            &mut rng,
        )
        .expect("valid");
        model
            .simulate(State::REST, H, &fr, &ft, &mut ar, &mut at)
            .expect("stable")
    });
    STEPS as f64 / secs
}

fn dump_trajectory(path: &str, fr: &[f64], ft: &[f64]) {
    let model = Bearing2Dof::<f64>::new(&BearingParams::default_housing()).expect("valid params");
    let mut s = State::REST;
    let mut out = String::from("step,t_s,x_r_m\n");
    for k in 0..STEPS {
        if k % (48 * SUB) == 0 {
            let step = k / SUB;
            out.push_str(&format!(
                "{},{:.17e},{:.17e}\n",
                step,
                step as f64 / 48_000.0,
                s.x_r
            ));
        }
        s = model.step(
            &s,
            H,
            (fr[2 * k], ft[2 * k]),
            (fr[2 * k + 1], ft[2 * k + 1]),
            (fr[2 * k + 2], ft[2 * k + 2]),
        );
    }
    std::fs::write(path, out).expect("write dump");
}

/// Seconds per window of features + dynamic graph, with the configuration the trainer
/// and the edge share ([`FeatureConfig::standard`]: measurement-noise compensation on)
/// or with the compensation off.
fn features_graph_window_seconds(noise_compensation: bool) -> f64 {
    const W: usize = 2048;
    const T: usize = 8;
    const N: usize = 3;
    let mut rng = Xoshiro128pp::seed_from_u64(3);
    let fs = 12_000.0f64;
    let mut x = [[0.0f32; W]; N];
    for (i, node) in x.iter_mut().enumerate() {
        for (k, v) in node.iter_mut().enumerate() {
            let t = k as f64 / fs;
            let since = t % (1.0 / 162.1);
            let ring = (-since * 900.0).exp() * (2.0 * std::f64::consts::PI * 3000.0 * since).sin();
            *v = (ring / (1.0 + i as f64) + 0.1 * rng.normal()) as f32;
        }
    }
    let cfg = FeatureConfig {
        noise_compensation,
        ..FeatureConfig::standard(12_000.0, 29.93, BearingGeometry::CWRU_6205_DE.orders())
    };
    let gcfg = GraphConfig::<N>::uniform();
    let mut scratch = Box::new(FeatureScratch::<W>::new());
    let mut feats = [[[0.0f32; FEATURE_DIM]; N]; T];
    let mut rows = [[0.0f32; FEATURE_DIM]; T];
    let mut graphs = [Adjacency::<N>::ZERO; T];
    let reps = 200;
    let secs = best_of(1.0, || {
        for _ in 0..reps {
            for (i, node) in x.iter().enumerate() {
                node_features(black_box(node), &cfg, &mut scratch, &mut rows).expect("features");
                for t in 0..T {
                    feats[t][i] = rows[t];
                }
            }
            build_dynamic_graphs(&gcfg, &feats, &NodeMask::ALL, &mut graphs).expect("graph");
        }
        graphs[T - 1].0[0][1]
    });
    secs / reps as f64
}

/// Seconds per physical diagnosis (`diagnosis::window_evidence` + `decide`) of a
/// stretch of `n` samples at 12 kHz (an outer-race impact train in noise, 1 797 rpm).
fn diagnosis_seconds(n: usize) -> f64 {
    use pumptwin_core::diagnosis::{decide, window_evidence, Buffers, Thresholds};
    let mut rng = Xoshiro128pp::seed_from_u64(5);
    let fs = 12_000.0f64;
    let x: Vec<f32> = (0..n)
        .map(|k| {
            let since = (k as f64 / fs) % (1.0 / 107.4);
            let ring = (-since * 900.0).exp() * (2.0 * std::f64::consts::PI * 3000.0 * since).sin();
            (ring + 0.3 * rng.normal()) as f32
        })
        .collect();
    let orders = BearingGeometry::CWRU_6205_DE.orders();
    let mut complex = vec![Complex32::ZERO; Buffers::complex_len(n)];
    let mut real = vec![0.0f32; Buffers::real_len(n)];
    let reps = (1 << 17) / n;
    let secs = best_of(1.0, || {
        let mut last = 0.0;
        for _ in 0..reps {
            let buf = Buffers::carve(&mut complex, &mut real, n).expect("buffers");
            let e =
                window_evidence(black_box(&x), 12_000.0, 29.95, &orders, buf).expect("evidence");
            last = decide(&e, &Thresholds::DEFAULT).confidence;
        }
        last
    });
    secs / reps as f64
}

/// Seconds per forward FFT of `n` points with each memory walk: `(by twiddle, by
/// block)` — the stages with 64 twiddles or more walking the buffer once per twiddle
/// (strided) or block by block with 64 twiddles held; the library blocks from 8192
/// points (`fft::fft_walked`).
fn fft_walks(n: usize) -> (f64, f64) {
    let mut rng = Xoshiro128pp::seed_from_u64(9);
    let x: Vec<Complex32> = (0..n)
        .map(|_| Complex32::new(rng.normal() as f32, 0.0))
        .collect();
    let reps = (1 << 22) / n;
    let mut buf = x.clone();
    let mut time = |blocked_from: usize| {
        best_of(0.3, || {
            for _ in 0..reps {
                buf.copy_from_slice(&x);
                fft_walked(&mut buf, Direction::Forward, blocked_from).expect("power of two");
            }
            buf[1].re
        }) / reps as f64
    };
    let strided = time(usize::MAX);
    let blocked = time(0);
    (strided, blocked)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let (fr, ft) = render_force();
    if let Some(path) = arg("--dump") {
        dump_trajectory(&path, &fr, &ft);
        eprintln!("wrote {path}");
    }
    let r64 = rk4_rate::<f64>(&fr, &ft);
    let r32 = rk4_rate::<f32>(&fr, &ft);
    let e2e = end_to_end_rate();
    let win = features_graph_window_seconds(true);
    let win_raw = features_graph_window_seconds(false);
    println!("| what | figure |");
    println!("|---|---:|");
    println!(
        "| RK4 2-DOF f64, integration only | {:.1} M steps/s |",
        r64 / 1e6
    );
    println!(
        "| RK4 2-DOF f32, integration only | {:.1} M steps/s |",
        r32 / 1e6
    );
    println!(
        "| RK4 2-DOF f64, force rendering + integration | {:.1} M steps/s |",
        e2e / 1e6
    );
    println!(
        "| features (3 nodes x 2048, T = 8) + dynamic graph | {:.1} us/window |",
        win * 1e6
    );
    println!(
        "| the same without the noise-floor compensation | {:.1} us/window |",
        win_raw * 1e6
    );
    for n in [2048usize, 8192, 16384] {
        println!(
            "| physical diagnosis of {n} samples (band search, lines, width) | {:.1} us |",
            diagnosis_seconds(n) * 1e6
        );
    }
    let walks: Vec<(usize, f64, f64)> = [2048usize, 4096, 8192, 32768]
        .iter()
        .map(|&n| {
            let (s, b) = fft_walks(n);
            (n, s, b)
        })
        .collect();
    for (n, s, b) in &walks {
        println!(
            "| FFT {n} points: by twiddle / by block (ratio) | {:.1} / {:.1} us ({:.2}x) |",
            s * 1e6,
            b * 1e6,
            b / s
        );
    }
    if let Some(path) = arg("--json") {
        let json = format!(
            "{{\n  \"rk4_f64_steps_per_s\": {r64:.0},\n  \"rk4_f32_steps_per_s\": {r32:.0},\n  \"rk4_f64_end_to_end_steps_per_s\": {e2e:.0},\n  \"features_graph_s_per_window\": {win:.9},\n  \"features_graph_no_compensation_s_per_window\": {win_raw:.9},\n  \"h_s\": {H:.12e},\n  \"steps\": {STEPS}\n}}\n"
        );
        std::fs::write(&path, json).expect("write json");
        eprintln!("wrote {path}");
    }
}
