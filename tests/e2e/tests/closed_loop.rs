//! The closed loop on records with an undeclared effect in them. Each record comes from
//! the project's multi-node simulator with one effect term added; the loop is handed
//! only the signal, the sampling rate, the nominal speed and the bearing geometry.
//!
//! - realistic strength: the loop must attribute the record to the injected effect
//!   (the first effect it adds), with a lower error after adding it, and claim no
//!   other named effect;
//! - weak strength: whatever it claims must be the injected effect (claiming nothing
//!   is allowed near the detection limit);
//! - clean control: no effect claimed, and the residual is noise-like.

use pumptwin_core::bearing::BearingGeometry;
use pumptwin_trainer::twin::closed_loop::{run, LoopConfig, LoopInput, LoopReport};
use pumptwin_trainer::twin::generate::{generate, Injected, Strength, FS_HZ, RPM};

fn loop_on(effect: Injected, strength: Strength, seed: u64) -> LoopReport {
    let x = generate(effect, strength, 4.0, seed).expect("generator");
    let input = LoopInput {
        signal: x,
        fs_hz: FS_HZ,
        rpm: RPM,
        bearing: BearingGeometry::CWRU_6205_DE,
    };
    run(&input, &LoopConfig::default()).expect("loop").0
}

fn check_realistic(effect: Injected) {
    let report = loop_on(effect, Strength::Realistic, 21);
    let want = effect.expected_effect().expect("an effect");
    assert_eq!(
        report.effects.first().map(String::as_str),
        Some(want),
        "{effect:?}: effects {:?}",
        report.effects
    );
    let step = &report.steps[0];
    assert!(
        step.cost_after < step.cost_before,
        "{effect:?}: cost {} -> {}",
        step.cost_before,
        step.cost_after
    );
    assert!(
        step.error_after.psd_log_rmse_db <= step.error_before.psd_log_rmse_db + 0.05
            || step.error_after.envelope_rmse < step.error_before.envelope_rmse,
        "{effect:?}: neither error fell"
    );
    for other in &report.effects[1..] {
        assert!(
            other.starts_with("unexplained_"),
            "{effect:?}: also claimed {other}"
        );
    }
}

fn check_weak(effect: Injected) {
    let report = loop_on(effect, Strength::Weak, 22);
    let want = effect.expected_effect().expect("an effect");
    for claimed in &report.effects {
        assert_eq!(
            claimed, want,
            "{effect:?} (weak): claimed {:?}",
            report.effects
        );
    }
}

#[test]
fn clean_control_claims_nothing() {
    for seed in [31, 32] {
        let report = loop_on(Injected::None, Strength::Realistic, seed);
        assert!(
            report.effects.is_empty(),
            "control (seed {seed}) claimed {:?}",
            report.effects
        );
        assert!(
            report.residual_noise_like,
            "control (seed {seed}): {}",
            report.stop_reason
        );
        assert_eq!(report.fault, "outer_race");
    }
}

macro_rules! effect_tests {
    ($($name:ident: $effect:expr,)*) => {
        mod realistic {
            use super::*;
            $(#[test] fn $name() { check_realistic($effect) })*
        }
        mod weak {
            use super::*;
            $(#[test] fn $name() { check_weak($effect) })*
        }
    };
}

effect_tests! {
    shaft_harmonics: Injected::ShaftHarmonics,
    load_zone_modulation: Injected::LoadZoneModulation,
    slip: Injected::Slip,
    extra_resonance: Injected::ExtraResonance,
    line_interference: Injected::LineInterference,
    speed_drift: Injected::SpeedDrift,
    nonlinear_stiffness: Injected::NonlinearStiffness,
    unknown_periodic: Injected::UnknownPeriodic,
}
