//! A defect's width read from how fast its lines fall with the harmonic (module docs
//! of `crate::diagnosis`): an element dwelling `τ` in the spall scales the `h`-th line's
//! power by `sinc²(h·x)`, `x = π·f_d·τ`, so the fall of the second and third lines
//! below the first is
//!
//! ```text
//! F(x) = 10·log10( sinc²(x) / ½(sinc²(2x) + sinc²(3x)) )      dB
//! ```
//!
//! rising from 0 at `x = 0` to 12.55 dB at `x = π/2` (the second line's first zero),
//! monotone on that span and not beyond it. The width is `w = 360°·τ·f_rel` with
//! `f_rel` the elements' rate over the damaged part, so `w = 360°·x·f_rel/(π·f_d)`.
//! The `x` that explains the measured fall by the dwell alone gives the width, biased
//! high by every other cause of fall and low where the spall's entry is a much weaker
//! event than its exit (module docs of `crate::diagnosis`).

use crate::math;

/// The largest `x` the fall is read at: beyond `π/2` the model's fall is no longer
/// monotone, and a measured fall beyond 12.55 dB reads no width.
const X_MAX: f64 = core::f64::consts::FRAC_PI_2;

/// `sinc²(x)`.
fn sinc2(x: f64) -> f64 {
    if x.abs() < 1e-9 {
        1.0
    } else {
        let s = math::sin(x) / x;
        s * s
    }
}

/// The rectangular dwell's fall, dB, at `x = π·f_d·τ`.
pub fn dwell_fall_db(x: f64) -> f64 {
    let next = 0.5 * (sinc2(2.0 * x) + sinc2(3.0 * x));
    10.0 * math::ln(sinc2(x) / next) / core::f64::consts::LN_10
}

/// The `x` whose dwell fall is `fall_db` (0 for a fall of 0 dB or less); `None` beyond
/// the model's span (a fall over 12.55 dB) or for a fall that is not a number.
pub fn dwell_x(fall_db: f32) -> Option<f64> {
    let fall = f64::from(fall_db);
    if !fall.is_finite() || fall > dwell_fall_db(X_MAX) {
        return None;
    }
    let (mut lo, mut hi) = (0.0f64, X_MAX);
    for _ in 0..48 {
        let mid = 0.5 * (lo + hi);
        if dwell_fall_db(mid) < fall {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fall rises monotonically to 12.55 dB at π/2 and inverts to its `x`.
    #[test]
    fn the_dwell_fall_inverts_on_its_span() {
        let mut last = -1.0;
        for k in 0..=157 {
            let x = f64::from(k) / 100.0;
            let f = dwell_fall_db(x);
            assert!(f > last, "x {x}: {f} after {last}");
            last = f;
            let back = dwell_x(f as f32).unwrap();
            assert!((back - x).abs() < 2e-3 || x > 1.5, "x {x} read back {back}");
        }
        assert!((dwell_fall_db(X_MAX) - 12.55).abs() < 0.01);
        assert_eq!(dwell_x(-3.0), Some(0.0));
        assert_eq!(dwell_x(13.0), None);
        assert_eq!(dwell_x(f32::NAN), None);
    }
}
