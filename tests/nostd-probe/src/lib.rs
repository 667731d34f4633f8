//! no_std / no-alloc proof for `pumptwin-core`.
//!
//! Built as a `staticlib` for a bare-metal target with `panic = "abort"` (profile
//! `probe`), this crate has its own `#[panic_handler]` and **no global allocator**.
//! If anything in the core's dependency graph used `alloc`, rustc would refuse to
//! produce the library ("no global memory allocator found but one is required").
//! Every public entry point of the core is called from an exported `extern "C"`
//! function so none of it can be discarded before that check.
//!
//! ```text
//! cargo build -p pumptwin-nostd-probe --target thumbv7em-none-eabihf --profile probe
//! ```
// On the bare-metal target (the proof) there is no std; on the host the crate links std
// only so that `cargo clippy --workspace` can check it.
#![cfg_attr(target_os = "none", no_std)]
// `#[no_mangle]` is the only "unsafe" attribute here: it exports the entry points so
// the linker cannot drop them. The crate contains no unsafe code otherwise.
#![allow(unsafe_code)]

#[cfg(target_os = "none")]
use core::panic::PanicInfo;
use pumptwin_core::bearing::{BearingGeometry, DefectLocation};
use pumptwin_core::excitation::{
    CompositeExcitation, ImpactTrain, RandomExcitation, ShaftSinusoid, TimeGrid,
};
use pumptwin_core::features::{
    node_features, EnvelopeBand, FeatureConfig, FeatureScratch, FEATURE_DIM,
};
use pumptwin_core::fft::{fft_in_place, Complex32, Direction};
use pumptwin_core::fir::FirLowpass;
use pumptwin_core::graph::{build_dynamic_graphs, Adjacency, GraphConfig, NodeMask};
use pumptwin_core::rng::Xoshiro128pp;
use pumptwin_core::simulator::{Bearing2Dof, BearingParams, SensorTransfer, State};

const W: usize = 256;
const T: usize = 4;
const N: usize = 3;
const STEPS: usize = 64;

#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_info: &PanicInfo<'_>) -> ! {
    loop {}
}

/// Simulate a short impact response and return its last radial acceleration sample
/// (0.0 on error).
#[no_mangle]
pub extern "C" fn probe_simulate(seed: u64) -> f32 {
    let geometry = BearingGeometry::CWRU_6205_DE;
    let f = geometry.frequencies(29.95);
    let ex = CompositeExcitation {
        impact: ImpactTrain::periodic(
            400.0,
            f64::from(f.impact_rate(DefectLocation::InnerRace)),
            2e-5,
        ),
        sinusoid: ShaftSinusoid {
            amplitude: 20.0,
            shaft_hz: 29.95,
            phase_rad: 0.0,
            drift_per_s: 0.0,
        },
        random: RandomExcitation {
            noise_std: 1.0,
            pulse_rate_hz: 5.0,
            pulse_amplitude: 50.0,
            pulse_sigma_s: 2e-5,
        },
        w_impact: 1.0,
        w_sin: 1.0,
        w_rand: 1.0,
        angular_share: 0.3,
    };
    let h = 1.0 / 192_000.0;
    let mut fr = [0.0f64; 2 * STEPS + 1];
    let mut ft = [0.0f64; 2 * STEPS + 1];
    let mut rng = Xoshiro128pp::seed_from_u64(seed);
    if ex
        .render(
            TimeGrid {
                t0: 0.0,
                dt: h / 2.0,
            },
            &mut fr,
            &mut ft,
            &mut rng,
        )
        .is_err()
    {
        return 0.0;
    }
    let fr32: [f32; 2 * STEPS + 1] = core::array::from_fn(|i| fr[i] as f32);
    let ft32: [f32; 2 * STEPS + 1] = core::array::from_fn(|i| ft[i] as f32);
    let Ok(model) = Bearing2Dof::<f32>::new(&BearingParams::default_housing()) else {
        return 0.0;
    };
    let mut ar = [0.0f32; STEPS];
    let mut at = [0.0f32; STEPS];
    if model
        .simulate(State::REST, h as f32, &fr32, &ft32, &mut ar, &mut at)
        .is_err()
    {
        return 0.0;
    }
    let mut y = [0.0f32; STEPS];
    let tr = SensorTransfer {
        gain_radial: 1.0 / 9.81,
        gain_angular: 0.1,
        delay_samples: 2,
    };
    if tr.apply(&ar, &at, &mut y).is_err() {
        return 0.0;
    }
    let mut lp = match FirLowpass::<31>::new(5000.0, 12_000.0) {
        Ok(lp) => lp,
        Err(_) => return 0.0,
    };
    let mut last = 0.0;
    for v in y {
        last = lp.push(v);
    }
    last
}

/// Features of `N` nodes over one window and their dynamic graph; returns Â(T−1)[0][1].
#[no_mangle]
pub extern "C" fn probe_features_graph(samples: &[[f32; W]; N], shaft_hz: f32) -> f32 {
    let cfg = FeatureConfig {
        fs_hz: 12_000.0,
        shaft_hz,
        orders: BearingGeometry::CWRU_6205_DE.orders(),
        envelope_band: EnvelopeBand::DEFAULT,
        band_limit_hz: 5_000.0,
        segments: T,
        noise_compensation: false,
    };
    let mut scratch = FeatureScratch::<W>::new();
    let mut x = [[[0.0f32; FEATURE_DIM]; N]; T];
    let mut rows = [[0.0f32; FEATURE_DIM]; T];
    let mut mask = NodeMask::<N>::ALL;
    for (i, s) in samples.iter().enumerate() {
        if node_features(s, &cfg, &mut scratch, &mut rows).is_err() {
            mask.0[i] = false;
            continue;
        }
        for t in 0..T {
            x[t][i] = rows[t];
        }
    }
    let mut graphs = [Adjacency::<N>::ZERO; T];
    if build_dynamic_graphs(&GraphConfig::<N>::uniform(), &x, &mask, &mut graphs).is_err() {
        return -1.0;
    }
    graphs[T - 1].0[0][1]
}

/// Reaches the negative-control allocation when the canary feature is on.
#[cfg(feature = "_alloc_canary")]
#[no_mangle]
pub extern "C" fn probe_alloc_canary() -> usize {
    pumptwin_core::alloc_canary()
}

/// Decode a model file into a caller-owned model (no allocation, no panic on bad bytes);
/// returns the number of classes, or 0 for a rejected file.
#[no_mangle]
pub extern "C" fn probe_model_file(
    bytes: &[u8; 1024],
    model: &mut pumptwin_core::model_file::ModelFile,
) -> u32 {
    match pumptwin_core::model_file::decode_into(bytes, model) {
        Ok(()) => u32::from(model.dims.classes),
        Err(_) => 0,
    }
}

/// In-place FFT of a caller buffer; returns the DC magnitude (−1 on error).
#[no_mangle]
pub extern "C" fn probe_fft(buf: &mut [Complex32; 64]) -> f32 {
    match fft_in_place(buf, Direction::Forward) {
        Ok(()) => buf[0].norm(),
        Err(_) => -1.0,
    }
}
