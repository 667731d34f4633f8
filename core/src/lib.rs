//! # pumptwin-core
//!
//! The `no_std`, heap-free core of pumptwin: everything that must agree bit for bit
//! between the host trainer, the Linux edge gateway and MCU firmware.
//!
//! | module | what | paper |
//! |---|---|---|
//! | [`bearing`] | bearing geometry, defect frequencies (BPFO, BPFI, BSF, FTF) | §5.2, eq. 18 (T_impact) |
//! | [`excitation`] | impact trains, shaft sinusoid, random pulses, composite force | eqs. 18–20 |
//! | [`simulator`] | 2-DOF mass–damper–stiffness model with cubic stiffness, fixed-step RK4, sensor nodes | eqs. 16–17, 21–22 |
//! | [`fft`] | radix-2 FFT (no plan: twiddles from a recurrence, in place) | §4.3, §5.3 |
//! | [`fir`] | windowed-sinc low-pass, the common band limit and anti-alias filter | — |
//! | [`diagnosis`] | the physical diagnosis of a window: the most impulsive band (spectral kurtosis), defect-line levels in orders of the told geometry, type, confidence and severity as ratios (no gain enters) | §5.2 (defect rates) |
//! | [`dsp`] | general-purpose DSP under the features: Hilbert envelope and its spectrum, spectral peaks and harmonic levels, quickselect / median, segment time statistics | — |
//! | [`features`] | time, spectral and envelope-spectrum node features | eq. 9, Table 3 |
//! | [`tracking`] | on-edge tracking of radial stiffness and damping Θ by eq. 10 steps on a feature-space loss against the RK4 model | §4.3 eq. 10, eqs. 16–22 |
//! | [`graph`] | dynamic sparse sensor graph: prior ⊕ Pearson, threshold, normalization | eqs. 1–3 |
//! | [`quant`] | int8 DS-STGAT kernels (linear, LUTs, softmax, GAT, GRU, pooling, classifier) with float references | eqs. 4–8 |
//! | [`layout`] | the window, hop, steps, sensor nodes and sensor-head inputs every side agrees on | — |
//! | [`dsstgat`] | the whole int8 DS-STGAT on one window (embedding → GAT → GRU → pooling → class and indicator heads, and the sensor head on the window-mean features) and its float reference | eqs. 4–9, 12–13 |
//! | [`model_file`] | the postcard model file: header, CRC-32, fixed-capacity payload, checked decoding into the [`quant`] kernels | §4.2 (the trained DS-STGAT) |
//! | [`rng`] | seeded PRNG (xoshiro128++), Gaussian and Poisson draws | §5.2 random excitation |
//!
//! Memory: every function writes into buffers the caller owns; nothing allocates.
//! Errors: every fallible function returns [`Result`] with the flat [`Error`] enum.
//! Math: all transcendental functions go through the private `math` module, which
//! calls `libm` explicitly, so host tests exercise exactly the code the MCU runs.
//!
//! **Depends on** no crate of the workspace; outside it only on `libm`, and on
//! `heapless`, `postcard` and `serde` without default features (the model file). Every
//! other crate of the workspace depends on this one. **Invariant:** `no_std`, no
//! `alloc` (`tests/nostd-probe` fails to link if anything allocates), no `unsafe`, and
//! no reachable panic on the inference path (`tests/nopanic-probe`).
//!
//! Not used, on purpose: `nalgebra` (the tracker's 2 × 2 normal equations and the
//! twin's Levenberg–Marquardt solve are a few lines each, and rewriting them on another
//! library's kernels would change their rounding, so the edge's tracking figures and
//! the closed loop's reports would no longer reproduce bit for bit) and `micromath`
//! (see `math`: its approximations are too coarse for the FFT twiddles and the RK4
//! checks). Neither is declared.
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

#[cfg(test)]
extern crate std;

pub mod bearing;
pub mod diagnosis;
pub mod dsp;
pub mod dsstgat;
mod error;
pub mod excitation;
pub mod features;
pub mod fft;
pub mod fir;
pub mod graph;
pub mod layout;
mod math;
pub mod model_file;
pub mod quant;
pub mod rng;
pub mod simulator;
pub mod tracking;
pub mod units;

pub use error::{Error, Result};

/// Negative control for the no-alloc proof (feature `_alloc_canary`, never for real use).
#[cfg(feature = "_alloc_canary")]
#[doc(hidden)]
pub fn alloc_canary() -> usize {
    extern crate alloc;
    alloc::vec![1u8; 3].len()
}
