//! Arithmetic the int8 kernels share: the i8·i8 dot product and its length bound
//! [`MAX_DOT_LEN`], rounding half away from zero, and the f64 sigmoid and tanh of the
//! float references and lookup tables.

use crate::math;

/// Largest dot-product length for which an i8·i8 sum cannot overflow i32 even with
/// −128 codes: `65536 · 128² = 2^30`, leaving room for a bias of at most
/// [`MAX_BIAS`](super::linear::MAX_BIAS) `= 2^30 − 1`.
pub const MAX_DOT_LEN: usize = 1 << 16;

/// `Σ a[k]·b[k]` in i32; the length bound is checked at compile time.
#[inline]
pub(crate) fn dot_i8<const N: usize>(a: &[i8; N], b: &[i8; N]) -> i32 {
    const {
        assert!(
            N <= MAX_DOT_LEN,
            "int8 dot product too long for an i32 accumulator"
        )
    };
    let mut acc = 0i32;
    for k in 0..N {
        acc += i32::from(a[k]) * i32::from(b[k]);
    }
    acc
}

/// Round half away from zero in f64 (exact: no `x + 0.5` double rounding).
pub(crate) fn round_half_away(x: f64) -> f64 {
    let a = if x < 0.0 { -x } else { x };
    let f = math::floor(a);
    let r = if a - f >= 0.5 { f + 1.0 } else { f };
    if x < 0.0 {
        -r
    } else {
        r
    }
}

/// Logistic sigmoid `1 / (1 + e^−x)` through the libm shim.
pub(crate) fn sigmoid_f64(x: f64) -> f64 {
    1.0 / (1.0 + math::exp(-x))
}

/// `tanh x = 1 − 2 / (e^{2x} + 1)` through the libm shim (saturates cleanly at ±1).
pub(crate) fn tanh_f64(x: f64) -> f64 {
    1.0 - 2.0 / (math::exp(2.0 * x) + 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_half_away_ties_and_signs() {
        for (x, want) in [
            (0.5, 1.0),
            (-0.5, -1.0),
            (1.5, 2.0),
            (-1.5, -2.0),
            (2.5, 3.0),
            (0.499_999_999_999_999_94, 0.0),
            (-0.499_999_999_999_999_94, 0.0),
            (126.4, 126.0),
            (-126.6, -127.0),
            (0.0, 0.0),
        ] {
            assert_eq!(round_half_away(x), want, "{x}");
        }
    }

    #[test]
    fn sigmoid_tanh_match_std() {
        for i in -400..=400 {
            let x = f64::from(i) * 0.05;
            assert!((sigmoid_f64(x) - 1.0 / (1.0 + (-x).exp())).abs() < 1e-15);
            assert!((tanh_f64(x) - x.tanh()).abs() < 1e-15, "{x}");
        }
        assert_eq!(tanh_f64(1000.0), 1.0);
        assert_eq!(tanh_f64(-1000.0), -1.0);
    }

    #[test]
    fn dot_matches_wide_sum() {
        let a: [i8; 5] = [127, -127, 3, -128, 0];
        let b: [i8; 5] = [127, 127, -3, -128, 99];
        assert_eq!(dot_i8(&a, &b), 127 * 127 - 127 * 127 - 9 + 128 * 128);
    }
}
