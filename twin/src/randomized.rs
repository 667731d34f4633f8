//! Simulated records with the conditions randomized: the development set of the
//! `sim-only` protocol (`pumptwin eval-generalization --sim-records N`), on which the
//! physical diagnosis' settings can be chosen without any measured fault record.
//!
//! Each record draws, independently and uniformly (log-uniformly for scales):
//!
//! | what | range | why |
//! |---|---|---|
//! | fault | none, outer race, inner race, ball (in turn) | the four states |
//! | rolling elements `n` | 7–13 | deep-groove and angular-contact bearings of pumps |
//! | `d / D` | 0.15–0.30 | the same |
//! | contact angle | 0–15° | the same |
//! | speed | 600–3 600 rpm | a pump's range |
//! | structural resonance | 1.5–4.5 kHz, ζ 0.02–0.10 | where impacts ring below the 5 kHz band limit |
//! | impact force | 5–80 N (log) | barely visible to strong |
//! | slip (timing jitter) | 0.5–2 % of the period | real bearings |
//! | a ball's wandering strikes (interval walk) | 1–30 % of the period (log) | a spalled ball spins about an axis that wanders in its pocket, so its spot meets the races at irregular times; the cage still carries it through the load zone once per turn (`pumptwin_core::diagnosis`, the cage line) |
//! | load-zone modulation depth | 0–0.9 | rotating-race and ball defects |
//! | background force | 0.5–3 N (log) | the machine's broadband |
//! | random pulses | 0–5 per s | debris, cavitation |
//! | sensor noise | 0.005–0.05 g (log) | the acquisition |
//! | sensor gain | 0.1–10 (log) | any sensor, any unit |
//!
//! The drive-end channel only (the monitored bearing's sensor), 12 kHz, 3 s.

use pumptwin_core::bearing::{BearingGeometry, DefectLocation};
use pumptwin_core::rng::Xoshiro128pp;

use crate::sim::{SimError, SimulationSpec};

/// Duration of a randomized record, s.
pub const DURATION_S: f64 = 3.0;

/// One randomized record's spec (truth: `spec.fault`).
pub fn random_spec(index: u64, seed: u64) -> Result<SimulationSpec, SimError> {
    let mut r = Xoshiro128pp::seed_from_u64(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ index);
    let mut uniform = |lo: f64, hi: f64| lo + (hi - lo) * r.uniform();
    let fault = match index % 4 {
        0 => None,
        1 => Some(DefectLocation::OuterRace),
        2 => Some(DefectLocation::InnerRace),
        _ => Some(DefectLocation::Ball),
    };
    let n = uniform(7.0, 14.0).floor() as u8;
    let pitch = 40.0;
    let ratio = uniform(0.15, 0.30);
    let angle = uniform(0.0, 15.0);
    let rpm = uniform(600.0, 3_600.0) as f32;
    let log = |u: f64, lo: f64, hi: f64| (lo.ln() + (hi.ln() - lo.ln()) * u).exp();
    let (u_imp, u_bg, u_noise, u_gain) = (
        uniform(0.0, 1.0),
        uniform(0.0, 1.0),
        uniform(0.0, 1.0),
        uniform(0.0, 1.0),
    );
    let fn_hz = uniform(1_500.0, 4_500.0);
    let zeta = uniform(0.02, 0.10);
    let jitter = uniform(0.005, 0.02);
    let depth = uniform(0.0, 0.9);
    let pulses = uniform(0.0, 5.0);
    let mut spec = SimulationSpec::cwru_like(fault, rpm, DURATION_S, seed ^ index);
    spec.name = format!("sim-{index}");
    spec.bearing = BearingGeometry::new(n, (ratio * pitch) as f32, pitch as f32, angle as f32)?;
    let w = 2.0 * std::f64::consts::PI * fn_hz;
    spec.params.stiffness_radial = spec.params.mass * w * w;
    spec.params.damping_radial = 2.0 * zeta * spec.params.mass * w;
    spec.impact_amplitude_n = log(u_imp, 5.0, 80.0);
    spec.jitter = jitter;
    spec.modulation_depth = depth;
    spec.background_n = log(u_bg, 0.5, 3.0);
    spec.pulse_rate_hz = pulses;
    spec.measurement_noise = log(u_noise, 0.005, 0.05) as f32;
    let gain = log(u_gain, 0.1, 10.0) as f32;
    spec.sensors.truncate(1);
    if let Some(s) = spec.sensors.first_mut() {
        s.transfer.gain_radial *= gain;
        s.transfer.gain_angular *= gain;
    }
    spec.measurement_noise *= gain;
    // Drawn last, for every record, so that the other conditions of every record are
    // those drawn before the walk was added.
    let u_walk = uniform(0.0, 1.0);
    if fault == Some(DefectLocation::Ball) {
        spec.walk = log(u_walk, 0.01, 0.30);
    }
    Ok(spec)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_are_reproducible_and_cover_the_four_states() {
        let a: Vec<SimulationSpec> = (0..8).map(|i| random_spec(i, 7).unwrap()).collect();
        let b: Vec<SimulationSpec> = (0..8).map(|i| random_spec(i, 7).unwrap()).collect();
        assert_eq!(a, b);
        assert_eq!(a[0].fault, None);
        assert_eq!(a[1].fault, Some(DefectLocation::OuterRace));
        assert_eq!(a[2].fault, Some(DefectLocation::InnerRace));
        assert_eq!(a[3].fault, Some(DefectLocation::Ball));
        assert_ne!(a[0].rpm, a[4].rpm);
        for s in &a {
            assert!((600.0..=3_600.0).contains(&s.rpm));
            assert_eq!(s.sensors.len(), 1);
            s.bearing.validate().unwrap();
            let ball = s.fault == Some(DefectLocation::Ball);
            assert_eq!(ball, s.walk > 0.0, "{:?}: walk {}", s.fault, s.walk);
            assert!(s.walk <= 0.30);
        }
    }

    /// The simulator's wandering ball: its strikes' intervals walk by 30 % of the
    /// period, so the 2·BSF family stands under a line's threshold, while the load
    /// zone still modulates them once per cage turn: the core's diagnosis types it by
    /// its cage line. The same ball keeping its rhythm is typed by its own family.
    #[test]
    fn a_wandering_simulated_ball_is_typed_by_its_cage_line() {
        use pumptwin_core::diagnosis::{
            decide, window_evidence, Buffers, Defect, FaultType, Thresholds,
        };
        use pumptwin_core::fft::Complex32;
        let typed = |walk: f64, seed: u64| {
            let mut spec =
                SimulationSpec::cwru_like(Some(DefectLocation::Ball), 1_750.0, 0.8, seed);
            spec.walk = walk;
            spec.modulation_depth = 0.9;
            spec.pulse_rate_hz = 0.0;
            let rec = crate::sim::simulate(&spec).unwrap();
            let x = &rec.channel("DE").unwrap().samples[..8_192];
            let (mut c, mut r) = (
                vec![Complex32::ZERO; Buffers::complex_len(8_192)],
                vec![0.0; Buffers::real_len(8_192)],
            );
            let buf = Buffers::carve(&mut c, &mut r, 8_192).unwrap();
            let shaft = 1_750.0 / 60.0;
            let e = window_evidence(x, rec.fs_hz, shaft, &spec.bearing.orders(), buf).unwrap();
            (decide(&e, &Thresholds::DEFAULT).fault, e)
        };
        for seed in 1..=3 {
            let (fault, e) = typed(0.30, seed);
            assert!(
                e.line(Defect::Ball).level_db < Thresholds::DEFAULT.line_db,
                "{e:?}"
            );
            assert_eq!(fault, FaultType::Ball, "seed {seed}: {e:?}");
            let (fault, e) = typed(0.0, seed);
            assert!(
                e.line(Defect::Ball).level_db >= Thresholds::DEFAULT.line_db,
                "{e:?}"
            );
            assert_eq!(fault, FaultType::Ball, "seed {seed}: {e:?}");
        }
    }
}
