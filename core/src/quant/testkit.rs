//! The one shared test suite of the int8 kernels (test-only).
//!
//! A [`KernelPair`] draws one random instance (weights, scales, inputs) from a seeded
//! [`Xoshiro128pp`], runs the int8 kernel and its float reference on the same inputs
//! (the reference sees the int8 inputs dequantized) and pushes one [`Sample`] per
//! compared output, each with its stated tolerance. [`check_against_reference`] runs
//! many cases, asserts every sample is within tolerance and prints the measured
//! maximum error (run with `--nocapture` to see the table).

use crate::rng::Xoshiro128pp;
use std::vec::Vec;

/// One compared output.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sample {
    /// The int8 kernel's output, dequantized.
    pub got: f64,
    /// The float reference's output.
    pub want: f64,
    /// The stated tolerance for `|got − want|` (real units).
    pub tol: f64,
    /// One output LSB (real units), for reporting errors in LSBs.
    pub lsb: f64,
}

impl Sample {
    pub(crate) fn new(got: f64, want: f64, tol: f64, lsb: f64) -> Self {
        Self {
            got,
            want,
            tol,
            lsb,
        }
    }
}

/// An int8 kernel and its float reference, run on the same seeded random inputs.
pub(crate) trait KernelPair {
    /// Shown in the report.
    const NAME: &'static str;
    /// Draw one instance and push one sample per compared output.
    fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>);
}

/// What one run of the suite measured.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Report {
    /// Largest `|got − want|`.
    pub max_err: f64,
    /// Largest `|got − want| / lsb`.
    pub max_err_lsb: f64,
    /// Largest `|got − want| / tol` (≤ 1 when the test passes).
    pub worst_tol_use: f64,
    /// Number of compared outputs.
    pub count: usize,
}

/// Run `cases` random instances of `K` from `seed`; panic (test failure) on the first
/// output outside its tolerance.
pub(crate) fn check_against_reference<K: KernelPair>(seed: u64, cases: usize) -> Report {
    let mut rng = Xoshiro128pp::seed_from_u64(seed);
    let mut samples = Vec::new();
    for _ in 0..cases {
        K::run_case(&mut rng, &mut samples);
    }
    assert!(!samples.is_empty(), "{}: no samples", K::NAME);
    let mut report = Report {
        max_err: 0.0,
        max_err_lsb: 0.0,
        worst_tol_use: 0.0,
        count: samples.len(),
    };
    for (i, s) in samples.iter().enumerate() {
        let err = (s.got - s.want).abs();
        assert!(
            err <= s.tol,
            "{}: sample {i}: int8 {} vs float {} (|err| {err:.3e} = {:.3} LSB) exceeds tolerance {:.3e}",
            K::NAME,
            s.got,
            s.want,
            err / s.lsb,
            s.tol
        );
        report.max_err = report.max_err.max(err);
        report.max_err_lsb = report.max_err_lsb.max(err / s.lsb);
        report.worst_tol_use = report.worst_tol_use.max(err / s.tol);
    }
    std::println!(
        "[quant] {}: {} outputs, max |err| = {:.4e} = {:.3} LSB, worst err/tolerance = {:.3}",
        K::NAME,
        report.count,
        report.max_err,
        report.max_err_lsb,
        report.worst_tol_use
    );
    report
}

/// `kernel_pair_tests! { test_name: KernelPairType, seed 1, cases 100; … }` — one
/// `#[test]` per line, each running [`check_against_reference`].
macro_rules! kernel_pair_tests {
    ($($test:ident: $kernel:ty, seed $seed:expr, cases $cases:expr;)*) => {
        $(
            #[test]
            fn $test() {
                $crate::quant::testkit::check_against_reference::<$kernel>($seed, $cases);
            }
        )*
    };
}
pub(crate) use kernel_pair_tests;

/// Uniform in `[lo, hi)`.
pub(crate) fn uniform(rng: &mut Xoshiro128pp, lo: f64, hi: f64) -> f32 {
    (lo + (hi - lo) * rng.uniform()) as f32
}

/// A `[[f32; C]; R]` of uniform draws in `±amp`.
pub(crate) fn random_matrix<const R: usize, const C: usize>(
    rng: &mut Xoshiro128pp,
    amp: f64,
) -> [[f32; C]; R] {
    core::array::from_fn(|_| core::array::from_fn(|_| uniform(rng, -amp, amp)))
}

/// A `[f32; C]` of uniform draws in `±amp`.
pub(crate) fn random_vector<const C: usize>(rng: &mut Xoshiro128pp, amp: f64) -> [f32; C] {
    core::array::from_fn(|_| uniform(rng, -amp, amp))
}
