//! The one place where the core does transcendental math.
//!
//! `micromath::F32Ext` and the inherent `f32` methods resolve to std's implementations
//! whenever std is linked (host tests), so a host test would not test what the MCU runs.
//! Every function here calls `libm` explicitly instead: the same code on host and target.
//! `libm` is a pure-Rust port of musl's libm (≤ 1 ulp for the functions used here);
//! micromath's approximations (sqrt ≈ 5 % worst case, sin/cos ≈ 1e-3) are too coarse
//! for FFT twiddles and for checking RK4 against analytic solutions, so the core does
//! not use them for this.

#[inline]
pub(crate) fn sqrtf(x: f32) -> f32 {
    libm::sqrtf(x)
}
#[inline]
pub(crate) fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}
#[inline]
pub(crate) fn exp(x: f64) -> f64 {
    libm::exp(x)
}
#[inline]
pub(crate) fn ln(x: f64) -> f64 {
    libm::log(x)
}
#[inline]
pub(crate) fn sin(x: f64) -> f64 {
    libm::sin(x)
}
#[inline]
pub(crate) fn cos(x: f64) -> f64 {
    libm::cos(x)
}
#[inline]
pub(crate) fn log10f(x: f32) -> f32 {
    libm::log10f(x)
}
#[inline]
pub(crate) fn floor(x: f64) -> f64 {
    libm::floor(x)
}
#[inline]
pub(crate) fn ceil(x: f64) -> f64 {
    libm::ceil(x)
}

/// π in f64.
pub(crate) const PI: f64 = core::f64::consts::PI;

#[cfg(test)]
mod tests {
    use super::*;

    /// Test vectors with a stated bound: libm must agree with the closed forms.
    #[test]
    fn test_vectors() {
        const MAX_ERROR: f64 = 1e-15;
        assert!((sqrt(2.0) - core::f64::consts::SQRT_2).abs() < MAX_ERROR);
        assert!((exp(1.0) - core::f64::consts::E).abs() < 4.0 * MAX_ERROR);
        assert!((ln(core::f64::consts::E) - 1.0).abs() < MAX_ERROR);
        assert!((sin(PI / 6.0) - 0.5).abs() < MAX_ERROR);
        assert!((cos(PI / 3.0) - 0.5).abs() < MAX_ERROR);
        assert!((sqrtf(4.0) - 2.0).abs() < 1e-7);
        assert!((log10f(100.0) - 2.0).abs() < 1e-6);
        assert_eq!(floor(-0.5), -1.0);
    }
}
