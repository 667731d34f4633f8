//! Quantization parameters: checked scales, integer requantization multipliers, and the
//! float ↔ int8 conversions the constructors use.
//!
//! ```text
//! quantize     q = clamp(round_half_away(x / s), −127, 127)          (QScale s)
//! dequantize   x̂ = s · q
//! multiplier   real ≈ mult · 2^−shift,  mult ∈ [2^30, 2^31), shift ∈ [0, 62]
//!              |real − mult·2^−shift| ≤ 2^−31 · real
//! requantize   y = clamp(round_half_away(acc · mult / 2^shift), −127, 127)
//!              computed as  p = acc·mult (i64),  |y| = (|p| + 2^(shift−1)) >> shift
//! ```
//!
//! Accuracy of [`QMultiplier::apply`], stated and tested:
//! - **exact** against the rational reference `round_half_away(acc · mult / 2^shift)`
//!   (i128 arithmetic), for every `acc`;
//! - **within 1 LSB** of the float reference `round_half_away(acc · real)`. The two
//!   differ only when `acc · real` lies within `|acc · real| · 2^−31` of a half-integer
//!   (the multiplier's own rounding); inside the int8 range that is `≤ 127.5 · 2^−31
//!   ≈ 6·10^−8`, so mismatches are rare ties and never more than one step.

use crate::error::{expect_len, Error, Result};

use super::arith::round_half_away;

/// Largest int8 code magnitude: codes live in `[−Q_MAX, Q_MAX] = [−127, 127]`.
pub const Q_MAX: i32 = 127;

/// Saturate an integer to the int8 code range `[−127, 127]`.
#[inline]
pub(crate) const fn saturate_i8(x: i64) -> i8 {
    if x > Q_MAX as i64 {
        Q_MAX as i8
    } else if x < -(Q_MAX as i64) {
        -(Q_MAX as i8)
    } else {
        x as i8
    }
}

/// The rounding policy of every quantizer and requantizer in [`crate::quant`].
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rounding {
    /// Ties go away from zero: `0.5 → 1`, `−0.5 → −1`, `2.5 → 3`. Symmetric under
    /// negation; the convention of C `round`, gemmlowp and TFLite's reference kernels.
    HalfAwayFromZero,
}

/// `round_half_away(x / 2^shift)` in integers, for any `x` and `shift ≤ 63`.
#[inline]
pub const fn shift_round_half_away(x: i64, shift: u32) -> i64 {
    if shift == 0 {
        return x;
    }
    if shift > 63 {
        return 0; // |x| / 2^64 < 1/2
    }
    let half = 1u64 << (shift - 1);
    let mag = (x.unsigned_abs() + half) >> shift; // ≤ (2^63 + 2^62) >> 1 < 2^63
    let mag = mag as i64;
    if x < 0 {
        -mag
    } else {
        mag
    }
}

/// `round_half_away(num / den)` in integers, `den > 0` (returns 0 for `den ≤ 0`).
#[inline]
pub const fn div_round_half_away(num: i64, den: i64) -> i64 {
    if den <= 0 {
        return 0;
    }
    let d = den as u64;
    let mag = (num.unsigned_abs() + d / 2) / d;
    let mag = if mag > i64::MAX as u64 {
        i64::MAX
    } else {
        mag as i64
    };
    if num < 0 {
        -mag
    } else {
        mag
    }
}

/// A quantization scale: finite and strictly positive. `real ≈ scale · code`.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
pub struct QScale(f32);

/// Never NaN (checked at construction), so equality is total.
impl Eq for QScale {}

impl QScale {
    /// Scale 1.
    pub const ONE: Self = Self(1.0);
    /// `1/127`: maps `[−1, 1]` onto the full code range. The fixed scale of the GRU
    /// hidden state, of sigmoid/tanh outputs and of the quantized adjacency.
    pub const UNIT: Self = Self(1.0 / 127.0);

    /// A scale, if `s` is finite and `> 0`.
    pub const fn new(s: f32) -> Option<Self> {
        if s.is_finite() && s > 0.0 {
            Some(Self(s))
        } else {
            None
        }
    }

    /// The scale for values of magnitude up to `max_abs`: `max_abs / 127`.
    /// An all-zero tensor (`max_abs == 0`) gets [`QScale::UNIT`] (any positive scale
    /// represents zeros exactly).
    ///
    /// # Errors
    /// [`Error::NonFinite`] for NaN or infinity, [`Error::InvalidParameter`] for a
    /// negative value or a scale that underflows to zero.
    pub fn from_max_abs(max_abs: f32) -> Result<Self> {
        if !max_abs.is_finite() {
            return Err(Error::NonFinite);
        }
        if max_abs < 0.0 {
            return Err(Error::InvalidParameter("max_abs must be >= 0"));
        }
        if max_abs == 0.0 {
            return Ok(Self::UNIT);
        }
        Self::new(max_abs / Q_MAX as f32).ok_or(Error::InvalidParameter("scale underflows"))
    }

    /// The value of the scale.
    pub const fn get(self) -> f32 {
        self.0
    }

    /// `scale · q` as f32.
    pub fn dequantize(self, q: i32) -> f32 {
        (f64::from(self.0) * f64::from(q)) as f32
    }
}

/// An integer multiplier `real ≈ mult · 2^−shift` that requantizes an i32 accumulator
/// with [`Rounding::HalfAwayFromZero`] and saturation to `[−127, 127]`.
///
/// Representable ratios: `real ∈ [2^−32, 2^31)`; `mult ∈ [2^30, 2^31)` when built by
/// [`QMultiplier::from_f64`], relative error `≤ 2^−31`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QMultiplier {
    mult: i32,
    shift: i8,
}

impl QMultiplier {
    /// The rounding policy of [`QMultiplier::apply`].
    pub const ROUNDING: Rounding = Rounding::HalfAwayFromZero;
    /// Largest right shift (keeps `|acc · mult| < 2^62` shiftable in i64).
    pub const MAX_SHIFT: i8 = 62;
    /// The multiplier for `1/127` (products of two unit-scale codes back to unit scale).
    pub const INV_127: Self = match Self::from_f64(1.0 / 127.0) {
        Some(m) => m,
        None => panic!("1/127 is representable"),
    };

    /// The multiplier nearest to `real`, or `None` unless `real` is finite and in
    /// `[2^−32, 2^31)`. Exact bit manipulation, no float rounding beyond the f64 input.
    pub const fn from_f64(real: f64) -> Option<Self> {
        if !(real.is_finite() && real > 0.0) {
            return None;
        }
        let bits = real.to_bits();
        let exp = ((bits >> 52) & 0x7ff) as i32;
        if exp == 0 {
            return None; // subnormal: far below 2^−32
        }
        // real = m53 · 2^(exp − 1075), m53 ∈ [2^52, 2^53).
        let m53 = (bits & ((1u64 << 52) - 1)) | (1u64 << 52);
        let mut mult = (m53 + (1u64 << 21)) >> 22; // ∈ [2^30, 2^31]
        let mut shift = 1053 - exp; // real ≈ mult · 2^−shift
        if mult == 1u64 << 31 {
            mult = 1u64 << 30;
            shift -= 1;
        }
        if shift < 0 || shift > Self::MAX_SHIFT as i32 {
            return None;
        }
        Some(Self {
            mult: mult as i32,
            shift: shift as i8,
        })
    }

    /// [`QMultiplier::from_f64`] of an f32 ratio.
    pub const fn from_f32(real: f32) -> Option<Self> {
        Self::from_f64(real as f64)
    }

    /// The multiplier `in_scale · weight_scale / out_scale` (computed in f64), the usual
    /// accumulator-to-output ratio.
    pub fn from_scales(in_scale: QScale, weight_scale: QScale, out_scale: QScale) -> Option<Self> {
        Self::from_f64(f64::from(in_scale.0) * f64::from(weight_scale.0) / f64::from(out_scale.0))
    }

    /// Rebuild from stored parts (a model file): `mult ≥ 0`, `0 ≤ shift ≤ 62`.
    pub const fn from_raw(mult: i32, shift: i8) -> Option<Self> {
        if mult < 0 || shift < 0 || shift > Self::MAX_SHIFT {
            None
        } else {
            Some(Self { mult, shift })
        }
    }

    /// The integer mantissa.
    pub const fn mult(self) -> i32 {
        self.mult
    }

    /// The right shift.
    pub const fn shift(self) -> i8 {
        self.shift
    }

    /// The ratio this multiplier represents, `mult · 2^−shift`.
    pub fn to_f64(self) -> f64 {
        f64::from(self.mult) / (1u64 << self.shift) as f64
    }

    /// `round_half_away(acc · mult / 2^shift)` in i64, unsaturated.
    #[inline]
    pub const fn apply_i64(self, acc: i32) -> i64 {
        // |acc · mult| < 2^31 · 2^31 = 2^62: no overflow.
        shift_round_half_away(acc as i64 * self.mult as i64, self.shift as u32)
    }

    /// Requantize to an int8 code: rounded half away from zero, saturated to `[−127, 127]`.
    #[inline]
    pub const fn apply(self, acc: i32) -> i8 {
        saturate_i8(self.apply_i64(acc))
    }

    /// Rescale an accumulator onto another i32 scale: rounded half away from zero,
    /// saturated to the i32 range.
    #[inline]
    pub const fn apply_i32(self, acc: i32) -> i32 {
        let y = self.apply_i64(acc);
        if y > i32::MAX as i64 {
            i32::MAX
        } else if y < i32::MIN as i64 {
            i32::MIN
        } else {
            y as i32
        }
    }
}

/// Quantize one value: `clamp(round_half_away(x / scale), −127, 127)`.
///
/// # Errors
/// [`Error::NonFinite`] for NaN or infinity.
pub fn quantize_value(x: f32, scale: QScale) -> Result<i8> {
    if !x.is_finite() {
        return Err(Error::NonFinite);
    }
    let q = round_half_away(f64::from(x) / f64::from(scale.0));
    Ok(if q >= f64::from(Q_MAX) {
        Q_MAX as i8
    } else if q <= -f64::from(Q_MAX) {
        -(Q_MAX as i8)
    } else {
        q as i8
    })
}

/// Quantize a tensor with one symmetric scale (zero point 0) into `out`.
///
/// # Errors
/// [`Error::BufferSize`] if `out.len() != x.len()`, [`Error::NonFinite`] on NaN/∞.
pub fn quantize_symmetric(x: &[f32], scale: QScale, out: &mut [i8]) -> Result<()> {
    expect_len(out.len(), x.len())?;
    for (q, &v) in out.iter_mut().zip(x) {
        *q = quantize_value(v, scale)?;
    }
    Ok(())
}

/// `out[k] = scale · q[k]`.
///
/// # Errors
/// [`Error::BufferSize`] if the lengths differ.
pub fn dequantize(q: &[i8], scale: QScale, out: &mut [f32]) -> Result<()> {
    expect_len(out.len(), q.len())?;
    for (x, &v) in out.iter_mut().zip(q) {
        *x = scale.dequantize(i32::from(v));
    }
    Ok(())
}

/// Per-output-channel weight scales `s_w[o] = max_k |W[o][k]| / 127` (rows are output
/// channels). An all-zero row gets [`QScale::UNIT`].
///
/// # Errors
/// [`Error::NonFinite`] if a weight is NaN or infinite.
pub fn per_channel_scales<const IN: usize, const OUT: usize>(
    w: &[[f32; IN]; OUT],
) -> Result<[QScale; OUT]> {
    let mut scales = [QScale::UNIT; OUT];
    for (s, row) in scales.iter_mut().zip(w) {
        let mut m = MaxAbs::new();
        m.observe_all(row);
        *s = m.scale()?;
    }
    Ok(scales)
}

/// A running max-abs observer for calibrating activation scales.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MaxAbs {
    max: f32,
    non_finite: bool,
}

impl MaxAbs {
    /// Nothing observed yet.
    pub const fn new() -> Self {
        Self {
            max: 0.0,
            non_finite: false,
        }
    }

    /// Observe one value.
    pub fn observe(&mut self, x: f32) {
        if !x.is_finite() {
            self.non_finite = true;
        } else {
            let a = if x < 0.0 { -x } else { x };
            if a > self.max {
                self.max = a;
            }
        }
    }

    /// Observe every value of a slice.
    pub fn observe_all(&mut self, xs: &[f32]) {
        for &x in xs {
            self.observe(x);
        }
    }

    /// The largest magnitude seen.
    pub const fn max_abs(&self) -> f32 {
        self.max
    }

    /// `max_abs / 127` ([`QScale::from_max_abs`]).
    ///
    /// # Errors
    /// [`Error::NonFinite`] if a NaN or infinity was observed.
    pub fn scale(&self) -> Result<QScale> {
        if self.non_finite {
            return Err(Error::NonFinite);
        }
        QScale::from_max_abs(self.max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quant::testkit::{kernel_pair_tests, KernelPair, Sample};
    use crate::rng::Xoshiro128pp;
    use std::vec::Vec;

    /// Exact rational reference: `round_half_away(acc · mult / 2^shift)` in i128.
    fn rational(m: QMultiplier, acc: i32) -> i64 {
        let p = i128::from(acc) * i128::from(m.mult());
        let d = 1i128 << m.shift();
        let mag = (p.abs() + d / 2) / d;
        let y = if p < 0 { -mag } else { mag };
        y.clamp(-127, 127) as i64
    }

    /// Log-uniform ratio in [1e-6, 1); one in eight an exact power of two, so that
    /// exact ties (`acc·real = k + ½`) are exercised too.
    fn random_ratio(rng: &mut Xoshiro128pp) -> f64 {
        if rng.next_u32() % 8 == 0 {
            return 1.0 / f64::from(1u32 << (1 + rng.next_u32() % 19));
        }
        let lo = crate::math::ln(1e-6);
        crate::math::exp(lo * (1.0 - rng.uniform()))
    }

    /// Accumulators whose result lands in and around the int8 range, plus wild ones.
    fn random_acc(rng: &mut Xoshiro128pp, real: f64) -> i32 {
        match rng.next_u32() % 4 {
            0 => rng.next_u32() as i32,
            _ => {
                let y = (rng.uniform() - 0.5) * 300.0; // target output in ±150
                let a = (y / real).clamp(-2.1e9, 2.1e9);
                a as i32
            }
        }
    }

    /// The requantizer against the float `round(acc · real)`: within 1 LSB.
    struct Requantize;
    impl KernelPair for Requantize {
        const NAME: &'static str = "QMultiplier::apply vs round(acc·real)";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            let real = random_ratio(rng);
            let m = QMultiplier::from_f64(real).unwrap();
            for _ in 0..64 {
                let acc = random_acc(rng, real);
                let want = round_half_away(f64::from(acc) * real).clamp(-127.0, 127.0);
                let got = f64::from(m.apply(acc));
                out.push(Sample::new(got, want, 1.0, 1.0));
            }
        }
    }

    kernel_pair_tests! {
        requantize_within_one_lsb_of_float: Requantize, seed 11, cases 4000;
    }

    #[test]
    fn requantize_exact_vs_rational_and_rarely_off_float() {
        let mut rng = Xoshiro128pp::seed_from_u64(12);
        let (mut n, mut off, mut ties) = (0usize, 0usize, 0usize);
        for _ in 0..20_000 {
            let real = random_ratio(&mut rng);
            let m = QMultiplier::from_f64(real).unwrap();
            assert!((m.to_f64() - real).abs() <= real * 2f64.powi(-31), "{real}");
            for _ in 0..16 {
                let acc = random_acc(&mut rng, real);
                let got = i64::from(m.apply(acc));
                assert_eq!(got, rational(m, acc), "acc {acc} real {real}");
                let exact = f64::from(acc) * real;
                let want = round_half_away(exact).clamp(-127.0, 127.0) as i64;
                n += 1;
                if exact.abs() < 127.0 && exact - crate::math::floor(exact) == 0.5 {
                    ties += 1;
                }
                if got != want {
                    off += 1;
                    // Only at a near-tie, and by one step.
                    let frac = exact.abs() - crate::math::floor(exact.abs());
                    assert!((frac - 0.5).abs() < 1e-6, "{acc} {real}");
                    assert_eq!((got - want).abs(), 1);
                }
            }
        }
        std::println!(
            "[quant] requantize: {off} of {n} differ from float round (near ties); {ties} exact ties"
        );
        assert!(ties > 100);
        assert!(off * 10_000 < n);
    }

    #[test]
    fn requantize_rounding_policy_and_saturation() {
        let half = QMultiplier::from_f64(0.5).unwrap();
        assert_eq!((half.mult(), half.shift()), (1 << 30, 31));
        assert_eq!(QMultiplier::ROUNDING, Rounding::HalfAwayFromZero);
        for (acc, want) in [
            (1, 1),
            (-1, -1),
            (3, 2),
            (-3, -2),
            (5, 3),
            (-5, -3),
            (2, 1),
            (0, 0),
            (253, 127),   // 126.5 → 127
            (-253, -127), // −126.5 → −127
            (255, 127),   // 127.5 saturates
            (-255, -127), // never −128
            (i32::MAX, 127),
            (i32::MIN, -127),
        ] {
            assert_eq!(half.apply(acc), want, "acc {acc}");
        }
        // Non-power-of-two ratio, negative values.
        let tenth = QMultiplier::from_f64(0.1).unwrap();
        assert_eq!(tenth.apply(-14), -1);
        assert_eq!(tenth.apply(-16), -2);
        // 0.1's 31-bit mantissa lies just below 0.1, so −15·M = −1.4999999… → −1: the
        // one-LSB near-tie case of the float comparison (exact vs the rational one).
        assert!(tenth.to_f64() < 0.1);
        assert_eq!(tenth.apply(-15), -1);
        let three_eighths = QMultiplier::from_f64(0.375).unwrap();
        assert_eq!(three_eighths.apply(-4), -2); // −1.5 exactly
        assert_eq!(three_eighths.apply(-12), -5); // −4.5 exactly
        assert_eq!(three_eighths.apply(12), 5);
        assert_eq!(tenth.apply(-1275), -127);
        assert_eq!(tenth.apply(-1276), -127);
        assert_eq!(tenth.apply_i32(-10_000_006), -1_000_001);
        // apply_i32 saturates at the i32 range, not at ±127.
        let big = QMultiplier::from_f64(4.0).unwrap();
        assert_eq!(big.apply_i32(i32::MAX), i32::MAX);
        assert_eq!(big.apply_i32(i32::MIN), i32::MIN);
        assert_eq!(big.apply_i32(-300), -1200);
    }

    #[test]
    fn multiplier_domain() {
        assert!(QMultiplier::from_f64(0.0).is_none());
        assert!(QMultiplier::from_f64(-0.5).is_none());
        assert!(QMultiplier::from_f64(f64::NAN).is_none());
        assert!(QMultiplier::from_f64(f64::INFINITY).is_none());
        assert!(QMultiplier::from_f64(2f64.powi(-33)).is_none());
        assert!(QMultiplier::from_f64(2f64.powi(31)).is_none());
        let tiny = QMultiplier::from_f64(2f64.powi(-32)).unwrap();
        assert_eq!(tiny.shift(), 62);
        assert_eq!(tiny.apply(i32::MAX), 0);
        let one = QMultiplier::from_f64(1.0).unwrap();
        assert_eq!(one.apply(-77), -77);
        // Rounding the mantissa up to 2^31 renormalizes.
        let almost_one = QMultiplier::from_f64(1.0 - 1e-12).unwrap();
        assert_eq!((almost_one.mult(), almost_one.shift()), (1 << 30, 30));
        assert_eq!(QMultiplier::from_raw(-1, 3), None);
        assert_eq!(QMultiplier::from_raw(5, 63), None);
        assert_eq!(QMultiplier::from_raw(5, 0).unwrap().apply(3), 15);
        assert_eq!(QMultiplier::INV_127.apply(127 * 127), 127);
    }

    #[test]
    fn scales_and_quantizers() {
        assert!(QScale::new(0.0).is_none());
        assert!(QScale::new(-1.0).is_none());
        assert!(QScale::new(f32::NAN).is_none());
        assert!(QScale::new(f32::INFINITY).is_none());
        assert_eq!(QScale::new(0.25).unwrap().get(), 0.25);
        let s = QScale::from_max_abs(12.7).unwrap();
        assert!((s.get() - 0.1).abs() < 1e-7);
        assert_eq!(QScale::from_max_abs(0.0).unwrap(), QScale::UNIT);
        assert_eq!(QScale::from_max_abs(f32::NAN), Err(Error::NonFinite));

        let x = [
            0.125f32, -0.125, 0.375, -0.625, 31.75, -31.75, 100.0, -100.0, 0.1,
        ];
        let mut q = [0i8; 9];
        let quarter = QScale::new(0.25).unwrap();
        quantize_symmetric(&x, quarter, &mut q).unwrap();
        // Exact ties 0.5, 1.5, −2.5 go away from zero; out-of-range saturates at ±127.
        assert_eq!(q, [1, -1, 2, -3, 127, -127, 127, -127, 0]);
        let mut back = [0f32; 9];
        dequantize(&q, quarter, &mut back).unwrap();
        assert_eq!(back[3], -0.75);
        assert_eq!(
            quantize_symmetric(&[f32::NAN], QScale::ONE, &mut [0]),
            Err(Error::NonFinite)
        );
        assert!(quantize_symmetric(&x, QScale::ONE, &mut q[..3]).is_err());

        let w = [[0.5f32, -1.27], [0.0, 0.0], [2.54, 0.1]];
        let sc = per_channel_scales(&w).unwrap();
        assert!((sc[0].get() - 0.01).abs() < 1e-8);
        assert_eq!(sc[1], QScale::UNIT);
        assert!((sc[2].get() - 0.02).abs() < 1e-8);
        assert_eq!(
            per_channel_scales(&[[f32::INFINITY]]),
            Err(Error::NonFinite)
        );
    }

    #[test]
    fn integer_rounding_helpers() {
        assert_eq!(shift_round_half_away(3, 1), 2);
        assert_eq!(shift_round_half_away(-3, 1), -2);
        assert_eq!(shift_round_half_away(-5, 2), -1);
        assert_eq!(shift_round_half_away(-6, 2), -2);
        assert_eq!(shift_round_half_away(i64::MIN, 63), -1);
        assert_eq!(shift_round_half_away(i64::MAX, 64), 0);
        assert_eq!(div_round_half_away(7, 2), 4);
        assert_eq!(div_round_half_away(-7, 2), -4);
        assert_eq!(div_round_half_away(-7, 3), -2);
        assert_eq!(div_round_half_away(5, 0), 0);
    }
}
