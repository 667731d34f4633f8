//! Integer nonlinearities for int8 inputs: sigmoid and tanh (eq. 7's gates) as
//! 256-entry tables, `exp` for the attention softmax (eq. 5) as a table over
//! `x − max`, and the attention's LeakyReLU (eq. 4) as an integer multiply-shift.
//!
//! ```text
//! Lut8:       table[q + 128] = clamp(round_half_away(f(s_in·q) / s_out), −127, 127)
//!             lookup(q)      = table[q + 128]                          (q: i8)
//! ExpLut:     table[d]       = round_half_away(exp(−s_in·d) · 2^15)    d = max − x ∈ [0, 255]
//!             (u16, Q0.15: 32768 = 1.0, so table[0] = 32768 exactly)
//! LeakyRelu:  y = x                                  x ≥ 0
//!             y = round_half_away(x · slope)         x < 0, slope ≈ mult·2^−shift (0.2 in eq. 4)
//! ```
//!
//! The tables are built with floats (through the libm shim `crate::math`) once, at construction;
//! every lookup is integer only.
//!
//! # Max error (stated, tested over all 256 inputs and random scales)
//!
//! | function | bound vs the f64 function at the dequantized input `s_in·q` |
//! |---|---|
//! | [`Lut8`] (sigmoid, tanh, any `f` with `|f/s_out| ≤ 127.5`) | [`Lut8::MAX_ERROR_LSB`] = 0.5 output LSB |
//! | [`ExpLut`] | [`ExpLut::MAX_ERROR_LSB`] = 0.5 LSB of Q0.15 (`2^−16`) |
//! | [`LeakyRelu`] | [`LeakyRelu::MAX_ERROR_LSB`] = 0.5 LSB (ties impossible for slope 0.2: exact) |
//!
//! For the GRU gate tables ([`Lut8::gate_sigmoid`], [`Lut8::gate_tanh`]), which see an
//! *unquantized* pre-activation rounded onto their input grid and clamped to
//! `±range`, the error vs `f(x)` for any real `x` adds the input rounding
//! `max|f'| · s_in/2` and the clamp tail `1 − f(range)`:
//!
//! ```text
//! sigmoid, range 6:  0.5 + 0.25 · (6/254)·127 = 1.25 LSB   (tail 1 − σ(6)    = 0.31 LSB)
//! tanh,    range 3:  0.5 + 1    · (3/254)·127 = 2.00 LSB   (tail 1 − tanh(3) = 0.63 LSB)
//! ```
//! ([`SIGMOID_GATE_MAX_ERROR_LSB`], [`TANH_GATE_MAX_ERROR_LSB`]; the ranges balance the
//! two terms.)
//!
//! Measured (200 random scale pairs × 256 codes each): sigmoid, tanh and exp tables
//! reach exactly their 0.5 LSB (rounding ties); LeakyReLU 0.4998 LSB (no ties for
//! slope 0.2: exact rounding); the gate tables at continuous inputs 1.84 LSB (tanh,
//! bound 2.0).

use crate::error::{Error, Result};
use crate::math;

use super::arith::{round_half_away, sigmoid_f64, tanh_f64};
use super::qparams::{saturate_i8, QMultiplier, QScale, Q_MAX};

/// Input range of the GRU's sigmoid gate table: pre-activations clamp to `±6`.
pub const SIGMOID_GATE_RANGE: f32 = 6.0;
/// Input range of the GRU's tanh candidate table: pre-activations clamp to `±3`.
pub const TANH_GATE_RANGE: f32 = 3.0;
/// Input scale of the sigmoid gate table, `6/127`.
pub const SIGMOID_GATE_INPUT_SCALE: QScale = match QScale::new(SIGMOID_GATE_RANGE / 127.0) {
    Some(s) => s,
    None => panic!("positive"),
};
/// Input scale of the tanh gate table, `3/127`.
pub const TANH_GATE_INPUT_SCALE: QScale = match QScale::new(TANH_GATE_RANGE / 127.0) {
    Some(s) => s,
    None => panic!("positive"),
};
/// Error bound of [`Lut8::gate_sigmoid`] vs `σ(x)` for any real `x`, in output LSBs.
pub const SIGMOID_GATE_MAX_ERROR_LSB: f64 = 1.25;
/// Error bound of [`Lut8::gate_tanh`] vs `tanh(x)` for any real `x`, in output LSBs.
pub const TANH_GATE_MAX_ERROR_LSB: f64 = 2.0;

/// Quantize a float value, NaN → 0 (only for functions that are finite anyway).
fn quantize_clamped(v: f64, scale: f64) -> i8 {
    let q = round_half_away(v / scale);
    if q.is_nan() {
        0
    } else if q >= f64::from(Q_MAX) {
        Q_MAX as i8
    } else if q <= -f64::from(Q_MAX) {
        -(Q_MAX as i8)
    } else {
        q as i8
    }
}

/// Table index of an int8 code: `q + 128` (an in-range `u8`, so no bounds failure).
#[inline]
fn index(q: i8) -> usize {
    usize::from((q as u8) ^ 0x80)
}

/// A 256-entry int8 → int8 function table.
///
/// # Shapes
/// `table`: `[256]`, entry `i` is the output code for input code `i − 128`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Lut8 {
    table: [i8; 256],
    input_scale: QScale,
    output_scale: QScale,
}

impl Lut8 {
    /// Stated max error vs the f64 function at the dequantized input, in output LSBs.
    pub const MAX_ERROR_LSB: f64 = 0.5;

    /// An all-zero table (scales 1/127): a placeholder until the real table is set.
    pub const EMPTY: Self = Self {
        table: [0; 256],
        input_scale: QScale::UNIT,
        output_scale: QScale::UNIT,
    };

    /// Tabulate `f` for input codes at `input_scale`, outputs at `output_scale`.
    ///
    /// # Errors
    /// [`Error::NonFinite`] if `f` returns NaN or ∞ for some input code.
    pub fn build(f: fn(f64) -> f64, input_scale: QScale, output_scale: QScale) -> Result<Self> {
        let (si, so) = (f64::from(input_scale.get()), f64::from(output_scale.get()));
        let mut table = [0i8; 256];
        for (i, t) in table.iter_mut().enumerate() {
            let y = f(si * (i as f64 - 128.0));
            if !y.is_finite() {
                return Err(Error::NonFinite);
            }
            *t = quantize_clamped(y, so);
        }
        Ok(Self {
            table,
            input_scale,
            output_scale,
        })
    }

    /// Infallible build for functions that are finite everywhere.
    fn build_finite(f: fn(f64) -> f64, input_scale: QScale, output_scale: QScale) -> Self {
        let (si, so) = (f64::from(input_scale.get()), f64::from(output_scale.get()));
        Self {
            table: core::array::from_fn(|i| quantize_clamped(f(si * (i as f64 - 128.0)), so)),
            input_scale,
            output_scale,
        }
    }

    /// Logistic sigmoid table.
    pub fn sigmoid(input_scale: QScale, output_scale: QScale) -> Self {
        Self::build_finite(sigmoid_f64, input_scale, output_scale)
    }

    /// Hyperbolic tangent table.
    pub fn tanh(input_scale: QScale, output_scale: QScale) -> Self {
        Self::build_finite(tanh_f64, input_scale, output_scale)
    }

    /// The GRU gate sigmoid: input scale 6/127, output scale 1/127 (`z, r ∈ [0, 127]`).
    pub fn gate_sigmoid() -> Self {
        Self::sigmoid(SIGMOID_GATE_INPUT_SCALE, QScale::UNIT)
    }

    /// The GRU candidate tanh: input scale 3/127, output scale 1/127.
    pub fn gate_tanh() -> Self {
        Self::tanh(TANH_GATE_INPUT_SCALE, QScale::UNIT)
    }

    /// Rebuild from a stored table (a model file).
    pub fn from_table(table: [i8; 256], input_scale: QScale, output_scale: QScale) -> Self {
        Self {
            table,
            input_scale,
            output_scale,
        }
    }

    /// `f(q)` as an output code. Integer only.
    #[inline]
    pub fn lookup(&self, q: i8) -> i8 {
        self.table[index(q)]
    }

    /// The table, entry `i` for input code `i − 128`.
    pub fn table(&self) -> &[i8; 256] {
        &self.table
    }
    /// The input scale.
    pub fn input_scale(&self) -> QScale {
        self.input_scale
    }
    /// The output scale.
    pub fn output_scale(&self) -> QScale {
        self.output_scale
    }
}

/// `exp(−s_in·d)` for `d = max − x ∈ [0, 255]` in Q0.15 (`32768 = 1.0`): the
/// unnormalized softmax weights of eq. 5.
///
/// # Shapes
/// `table`: `[256]`, entry `d` for a logit `d` input steps below the row maximum.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExpLut {
    table: [u16; 256],
    input_scale: QScale,
}

impl ExpLut {
    /// 1.0 in Q0.15.
    pub const ONE: u16 = 1 << 15;
    /// Fraction bits of the table entries.
    pub const FRAC_BITS: u32 = 15;
    /// Stated max error vs `exp(−s_in·d)`, in Q0.15 LSBs.
    pub const MAX_ERROR_LSB: f64 = 0.5;

    /// An all-zero table (scale 1/127): a placeholder until the real table is set.
    pub const EMPTY: Self = Self {
        table: [0; 256],
        input_scale: QScale::UNIT,
    };

    /// Tabulate for logits at `input_scale`.
    pub fn new(input_scale: QScale) -> Self {
        let s = f64::from(input_scale.get());
        Self {
            table: core::array::from_fn(|d| {
                round_half_away(math::exp(-s * d as f64) * f64::from(Self::ONE)) as u16
            }),
            input_scale,
        }
    }

    /// Rebuild from a stored table (a model file).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] unless `table[0] == 32768` (exp 0 = 1) and the table
    /// is non-increasing; the softmax relies on the row maximum weighing exactly 1.
    pub fn from_table(table: [u16; 256], input_scale: QScale) -> Result<Self> {
        if table[0] != Self::ONE || table.windows(2).any(|w| w[1] > w[0]) {
            return Err(Error::InvalidParameter(
                "exp table must start at 32768 and not increase",
            ));
        }
        Ok(Self { table, input_scale })
    }

    /// `exp(−s_in·d)` in Q0.15. Integer only.
    #[inline]
    pub fn lookup(&self, d: u8) -> u16 {
        self.table[usize::from(d)]
    }

    /// The table.
    pub fn table(&self) -> &[u16; 256] {
        &self.table
    }
    /// The logit scale the table was built for.
    pub fn input_scale(&self) -> QScale {
        self.input_scale
    }
}

/// LeakyReLU on int8 or i32 codes (same scale in and out): the negative slope is an
/// integer multiply-shift with [`super::Rounding::HalfAwayFromZero`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LeakyRelu {
    slope: QMultiplier,
}

impl LeakyRelu {
    /// Negative slope 0.2, the GAT convention used for eq. 4.
    pub const GAT: Self = match Self::new(0.2) {
        Some(l) => l,
        None => panic!("0.2 is a valid slope"),
    };
    /// Stated max error vs `x·slope` (x < 0) in LSBs.
    pub const MAX_ERROR_LSB: f64 = 0.5;

    /// A LeakyReLU with `slope ∈ (0, 1]`.
    pub const fn new(slope: f64) -> Option<Self> {
        if !(slope > 0.0 && slope <= 1.0) {
            return None;
        }
        match QMultiplier::from_f64(slope) {
            Some(m) => Some(Self { slope: m }),
            None => None,
        }
    }

    /// The slope multiplier.
    pub const fn slope(self) -> QMultiplier {
        self.slope
    }

    /// On an int8 code; the result stays in `[−127, 127]`.
    #[inline]
    pub const fn apply_i8(self, x: i8) -> i8 {
        if x >= 0 {
            x
        } else {
            saturate_i8(self.slope.apply_i64(x as i32))
        }
    }

    /// On an i32 accumulator.
    #[inline]
    pub const fn apply_i32(self, x: i32) -> i32 {
        if x >= 0 {
            x
        } else {
            // |x·slope| ≤ |x|: fits.
            self.slope.apply_i64(x) as i32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quant::testkit::{kernel_pair_tests, uniform, KernelPair, Sample};
    use crate::rng::Xoshiro128pp;
    use std::vec::Vec;

    /// (input code, output code) at input scale 6/127, output 1/127; from Python's
    /// `math.exp` with round-half-away.
    const SIGMOID_TEST_VECTORS: [(i8, i8); 10] = [
        (-128, 0),
        (-127, 0),
        (-60, 7),
        (-20, 36),
        (-1, 62),
        (0, 64), // 63.5 exactly: the tie goes away from zero
        (1, 65),
        (20, 91),
        (60, 120),
        (127, 127),
    ];
    /// Input scale 3/127, output 1/127; from Python's `math.tanh`.
    const TANH_TEST_VECTORS: [(i8, i8); 10] = [
        (-128, -126),
        (-127, -126),
        (-60, -113),
        (-20, -56),
        (-1, -3),
        (0, 0),
        (1, 3),
        (20, 56),
        (60, 113),
        (127, 126),
    ];
    /// (d, Q0.15) at input scale ln2/8: every 8 steps halve the weight.
    const EXP_TEST_VECTORS: [(u8, u16); 10] = [
        (0, 32768),
        (1, 30048),
        (4, 23170),
        (8, 16384),
        (16, 8192),
        (24, 4096),
        (64, 128),
        (120, 1),
        (200, 0),
        (255, 0),
    ];
    /// Slope 0.2.
    const LEAKY_TEST_VECTORS: [(i8, i8); 12] = [
        (-128, -26),
        (-127, -25),
        (-13, -3),
        (-12, -2),
        (-8, -2),
        (-7, -1),
        (-5, -1),
        (-3, -1),
        (-2, 0),
        (0, 0),
        (1, 1),
        (127, 127),
    ];

    #[test]
    fn test_vectors() {
        let sig = Lut8::gate_sigmoid();
        for (x, y) in SIGMOID_TEST_VECTORS {
            assert_eq!(sig.lookup(x), y, "sigmoid({x})");
        }
        let tanh = Lut8::gate_tanh();
        for (x, y) in TANH_TEST_VECTORS {
            assert_eq!(tanh.lookup(x), y, "tanh({x})");
        }
        let exp = ExpLut::new(QScale::new(core::f32::consts::LN_2 / 8.0).unwrap());
        for (d, y) in EXP_TEST_VECTORS {
            assert_eq!(exp.lookup(d), y, "exp(-{d})");
        }
        for (x, y) in LEAKY_TEST_VECTORS {
            assert_eq!(LeakyRelu::GAT.apply_i8(x), y, "leaky({x})");
            assert_eq!(LeakyRelu::GAT.apply_i32(i32::from(x)), i32::from(y));
        }
        assert_eq!(LeakyRelu::GAT.apply_i32(-1_000_000_003), -200_000_001);
    }

    /// All 256 codes of a table at random scales vs the f64 function.
    fn check_lut(
        rng: &mut Xoshiro128pp,
        out: &mut Vec<Sample>,
        f: fn(f64) -> f64,
        build: fn(QScale, QScale) -> Lut8,
        in_range: (f64, f64),
    ) {
        let s_in = QScale::new(uniform(rng, in_range.0, in_range.1) / 127.0).unwrap();
        let s_out = QScale::new(uniform(rng, 1.0, 2.5) / 127.0).unwrap();
        let lut = build(s_in, s_out);
        let so = f64::from(s_out.get());
        for q in i8::MIN..=i8::MAX {
            let want = f(f64::from(s_in.get()) * f64::from(q));
            let got = f64::from(lut.lookup(q)) * so;
            out.push(Sample::new(
                got,
                want,
                Lut8::MAX_ERROR_LSB * so * (1.0 + 1e-9),
                so,
            ));
        }
    }

    struct Sigmoid;
    impl KernelPair for Sigmoid {
        const NAME: &'static str = "sigmoid Lut8, all 256 codes";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            check_lut(rng, out, sigmoid_f64, Lut8::sigmoid, (1.0, 12.0));
        }
    }
    struct Tanh;
    impl KernelPair for Tanh {
        const NAME: &'static str = "tanh Lut8, all 256 codes";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            check_lut(rng, out, tanh_f64, Lut8::tanh, (0.5, 6.0));
        }
    }
    struct Exp;
    impl KernelPair for Exp {
        const NAME: &'static str = "exp ExpLut (Q0.15), all 256 steps";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            let s = QScale::new(uniform(rng, 0.002, 0.2)).unwrap();
            let lut = ExpLut::new(s);
            let lsb = 1.0 / 32768.0;
            for d in 0..=255u8 {
                let want = math::exp(-f64::from(s.get()) * f64::from(d));
                let got = f64::from(lut.lookup(d)) * lsb;
                out.push(Sample::new(
                    got,
                    want,
                    ExpLut::MAX_ERROR_LSB * lsb * (1.0 + 1e-9),
                    lsb,
                ));
            }
        }
    }
    struct Leaky;
    impl KernelPair for Leaky {
        const NAME: &'static str = "LeakyRelu, all 256 codes";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            let slope = f64::from(uniform(rng, 0.01, 1.0));
            let l = if rng.next_u32() % 2 == 0 {
                LeakyRelu::GAT
            } else {
                LeakyRelu::new(slope).unwrap()
            };
            let slope = l.slope().to_f64();
            for q in i8::MIN..=i8::MAX {
                let x = f64::from(q);
                let want = if x >= 0.0 { x } else { (x * slope).max(-127.0) };
                out.push(Sample::new(f64::from(l.apply_i8(q)), want, 0.5 + 1e-9, 1.0));
            }
        }
    }
    /// Gate tables vs the function at *continuous* inputs rounded onto their grid.
    struct GateContinuous;
    impl KernelPair for GateContinuous {
        const NAME: &'static str = "gate sigmoid/tanh at continuous inputs (incl. input rounding)";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            let sig = Lut8::gate_sigmoid();
            let tanh = Lut8::gate_tanh();
            let lsb = 1.0 / 127.0;
            for _ in 0..256 {
                let x = uniform(rng, -10.0, 10.0);
                let qs = crate::quant::qparams::quantize_value(x, sig.input_scale()).unwrap();
                let qt = crate::quant::qparams::quantize_value(x, tanh.input_scale()).unwrap();
                let x = f64::from(x);
                out.push(Sample::new(
                    f64::from(sig.lookup(qs)) * lsb,
                    sigmoid_f64(x),
                    SIGMOID_GATE_MAX_ERROR_LSB * lsb,
                    lsb,
                ));
                out.push(Sample::new(
                    f64::from(tanh.lookup(qt)) * lsb,
                    tanh_f64(x),
                    TANH_GATE_MAX_ERROR_LSB * lsb,
                    lsb,
                ));
            }
        }
    }

    kernel_pair_tests! {
        sigmoid_lut_all_codes: Sigmoid, seed 31, cases 200;
        tanh_lut_all_codes: Tanh, seed 32, cases 200;
        exp_lut_all_steps: Exp, seed 33, cases 200;
        leaky_relu_all_codes: Leaky, seed 34, cases 50;
        gate_tables_continuous_inputs: GateContinuous, seed 35, cases 200;
    }

    #[test]
    fn lut_constructors_and_symmetry() {
        let tanh = Lut8::gate_tanh();
        for q in -127..=127i8 {
            assert_eq!(tanh.lookup(-q), -tanh.lookup(q), "odd symmetry at {q}");
        }
        let sig = Lut8::gate_sigmoid();
        assert!(sig.table().windows(2).all(|w| w[0] <= w[1]));
        assert!(sig.table().iter().all(|&v| v >= 0));
        assert_eq!(
            Lut8::build(|x| 1.0 / x, QScale::ONE, QScale::ONE),
            Err(Error::NonFinite)
        );
        let rebuilt = Lut8::from_table(*sig.table(), sig.input_scale(), sig.output_scale());
        assert_eq!(rebuilt, sig);
        let exp = ExpLut::new(QScale::new(0.05).unwrap());
        assert_eq!(
            ExpLut::from_table(*exp.table(), exp.input_scale()).unwrap(),
            exp
        );
        let mut bad = *exp.table();
        bad[0] = 32767;
        assert!(ExpLut::from_table(bad, exp.input_scale()).is_err());
        assert!(LeakyRelu::new(0.0).is_none());
        assert!(LeakyRelu::new(1.5).is_none());
        assert!(LeakyRelu::new(f64::NAN).is_none());
    }
}
