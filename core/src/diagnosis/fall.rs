//! A defect's width read from how fast its lines fall with the harmonic (module docs
//! of `crate::diagnosis`): an element dwelling `τ` in the spall scales the `h`-th line's
//! power by `sinc²(h·x)`, `x = π·f_d·τ`, and the band's own pulse — the ring-down of
//! what the impacts excite and the band's width — by `t_h` (`bands::pulse_transfer_of`, `t_1 = 1`),
//! so the fall of the second and third lines below the first is
//!
//! ```text
//! F(x) = 10·log10( sinc²(x) / ½(t₂·sinc²(2x) + t₃·sinc²(3x)) )      dB
//! ```
//!
//! rising from `F(0)`, the pulse's own fall, to `12.55 dB − 10·log10(t₃)` at
//! `x = π/2` (the second line's first zero), monotone on that span for
//! `1 ≥ t₂ ≥ t₃ > 0` and not beyond it. The width is `w = 360°·τ·f_rel` with
//! `f_rel` the elements' rate over the damaged part, so `w = 360°·x·f_rel/(π·f_d)`.
//! The `x` that explains the measured fall by the dwell through the band's pulse
//! gives the width, biased high by every other cause of fall (slip jitter, a noise
//! floor the pulse is read through) and low where the spall's entry is a much weaker
//! event than its exit (module docs of `crate::diagnosis`).

use crate::math;

/// The largest `x` the fall is read at: beyond `π/2` the model's fall is no longer
/// monotone, and a measured fall beyond the model's there reads no width.
const X_MAX: f64 = core::f64::consts::FRAC_PI_2;

/// The smallest `x` a width is read at: the resolution the module docs of
/// `crate::diagnosis` give the fall (there the dwell adds 0.3 dB through a flat
/// pulse, of the order of what the pulse's reading leaves out: slip jitter, a pulse
/// that is not two exponentials), so a smaller `x` is reported as a width under the
/// one at `X_RESOLVED`: `23°/Z` of the race for `Z` elements.
pub const X_RESOLVED: f64 = 0.2;

/// `sinc²(x)`.
fn sinc2(x: f64) -> f64 {
    if x.abs() < 1e-9 {
        1.0
    } else {
        let s = math::sin(x) / x;
        s * s
    }
}

/// The fall, dB, of a rectangular dwell at `x = π·f_d·τ` through a pulse whose
/// second and third harmonics carry `pulse` of the first's power.
pub fn dwell_fall_db(x: f64, pulse: [f32; 2]) -> f64 {
    let [t2, t3] = pulse.map(f64::from);
    let next = 0.5 * (t2 * sinc2(2.0 * x) + t3 * sinc2(3.0 * x));
    10.0 * math::ln(sinc2(x) / next) / core::f64::consts::LN_10
}

/// The `x` whose dwell fall through `pulse` is `fall_db` (0 for a fall the pulse
/// alone makes); `None` beyond the model's span or for a fall or pulse that is not
/// a number or not `1 ≥ t₂ ≥ t₃ > 0` (where the model is monotone).
pub fn dwell_x(fall_db: f32, pulse: [f32; 2]) -> Option<f64> {
    let fall = f64::from(fall_db);
    let [t2, t3] = pulse;
    let pulse_ok = t3 > 0.0 && t3 <= t2 && t2 <= 1.0;
    if !pulse_ok || !fall.is_finite() || fall > dwell_fall_db(X_MAX, pulse) {
        return None;
    }
    let (mut lo, mut hi) = (0.0f64, X_MAX);
    for _ in 0..48 {
        let mid = 0.5 * (lo + hi);
        if dwell_fall_db(mid, pulse) < fall {
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

    const FLAT: [f32; 2] = [1.0, 1.0];

    /// The fall rises monotonically over the span, through any pulse that does not
    /// grow with frequency, and inverts to its `x`.
    #[test]
    fn the_dwell_fall_inverts_on_its_span() {
        for pulse in [FLAT, [0.8, 0.5], [0.3, 0.1], [0.1, 0.01], [0.01, 0.001]] {
            let mut last = f64::MIN;
            for k in 0..=157 {
                let x = f64::from(k) / 100.0;
                let f = dwell_fall_db(x, pulse);
                assert!(f > last, "{pulse:?} x {x}: {f} after {last}");
                last = f;
                let back = dwell_x(f as f32, pulse).unwrap();
                assert!((back - x).abs() < 2e-3 || x > 1.5, "x {x} read back {back}");
            }
        }
        assert!((dwell_fall_db(X_MAX, FLAT) - 12.55).abs() < 0.01);
        assert_eq!(dwell_x(-3.0, FLAT), Some(0.0));
        assert_eq!(dwell_x(13.0, FLAT), None);
        assert_eq!(dwell_x(f32::NAN, FLAT), None);
    }

    /// What the pulse alone makes reads no width; the dwell reads the rest.
    #[test]
    fn the_pulses_own_fall_reads_no_width() {
        let pulse = [0.5, 0.25];
        let own = dwell_fall_db(0.0, pulse) as f32;
        assert!((own - 10.0 * (1.0f32 / 0.375).log10()).abs() < 1e-4);
        assert_eq!(dwell_x(own - 1.0, pulse), Some(0.0));
        let x = dwell_x(dwell_fall_db(0.6, pulse) as f32, pulse).unwrap();
        assert!((x - 0.6).abs() < 1e-3, "{x}");
        // Read without the pulse, the same fall is a wider dwell.
        let flat = dwell_x(dwell_fall_db(0.6, pulse) as f32, FLAT).unwrap();
        assert!(flat > 0.8, "{flat}");
        for bad in [[1.5, 0.5], [0.5, 0.6], [0.5, 0.0], [f32::NAN, 0.5]] {
            assert_eq!(dwell_x(3.0, bad), None, "{bad:?}");
        }
    }
}
