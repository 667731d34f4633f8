//! Records with one undeclared effect each, for testing the loop where the truth is
//! known. They come from [`crate::sim`] (the multi-node simulator with its own effect
//! terms), not from the twin's model, and the loop is handed only the signal, the
//! sampling rate, the nominal speed and the bearing: it never sees these settings.

use crate::sim::{simulate, ExtraTerms, OutputBursts, SensorSpec, SimError, SimulationSpec, G};
use crate::twin::EffectKind;
use pumptwin_core::bearing::DefectLocation;
use pumptwin_core::excitation::ImpactTrain;
use pumptwin_core::simulator::SensorTransfer;

/// The effect a generated record carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Injected {
    /// Clean control: an outer-race fault exactly as the base model describes it.
    None,
    /// 1× and 2× shaft-rate force (unbalance, misalignment).
    ShaftHarmonics,
    /// Inner-race fault whose impacts are modulated by the rotating load zone.
    LoadZoneModulation,
    /// Random impact timing (rolling-element slip).
    Slip,
    /// A second structural mode at 1.8 kHz driven by the same impacts.
    ExtraResonance,
    /// 50 Hz mains and harmonics on the sensor line.
    LineInterference,
    /// Speed drifting linearly through the record.
    SpeedDrift,
    /// Hardening cubic stiffness.
    NonlinearStiffness,
    /// A sinusoid at 437.3 Hz nobody declared (not a shaft order, mains line or defect rate).
    UnknownPeriodic,
    /// A second defect: inner-race impacts at BPFI (modulated by the shaft's turn) on
    /// top of the outer-race fault, a compound fault.
    SecondDefect,
    /// Impacts at 4.37 x the shaft rate, no rate of the bearing (a neighbouring machine,
    /// a loose part struck at a fixed rate).
    UnknownImpacts,
    /// A pump's vane pass: tones at 7× and 14× the shaft rate (a seven-vane impeller)
    /// that reach the sensor through the casing, not through the bearing's contact.
    VanePass,
    /// Mechanical looseness: a force at the half orders 0.5×, 1.5×, 2.5× and 3.5× of the
    /// shaft rate (the rotor lifts and settles once every two turns).
    Looseness,
    /// Band noise at the sensor, 1.8–2.4 kHz (a pump's flow noise or cavitation, a
    /// neighbour's broadband): it excites nothing and carries no impact rhythm.
    NoiseBand,
    /// Random bursts at the sensor: ring-downs at Poisson times (80 per second), each
    /// ringing a casing mode at 4.0 kHz, 500 Hz wide — a pump's cavitation (vapour
    /// bubbles collapsing), debris in the flow; no rate of the machine.
    Cavitation,
}

impl Injected {
    /// Every injectable effect except the control.
    pub const EFFECTS: [Injected; 14] = [
        Injected::ShaftHarmonics,
        Injected::LoadZoneModulation,
        Injected::Slip,
        Injected::ExtraResonance,
        Injected::LineInterference,
        Injected::SpeedDrift,
        Injected::NonlinearStiffness,
        Injected::UnknownPeriodic,
        Injected::SecondDefect,
        Injected::UnknownImpacts,
        Injected::VanePass,
        Injected::Looseness,
        Injected::NoiseBand,
        Injected::Cavitation,
    ];

    /// The effect the loop should report.
    pub fn expected_effect(self) -> Option<EffectKind> {
        match self {
            Injected::None => None,
            Injected::ShaftHarmonics => Some(EffectKind::ShaftHarmonics),
            Injected::LoadZoneModulation => Some(EffectKind::LoadZoneModulation),
            Injected::Slip => Some(EffectKind::Slip),
            Injected::ExtraResonance => Some(EffectKind::ExtraResonance),
            Injected::LineInterference => Some(EffectKind::LineInterference),
            Injected::SpeedDrift => Some(EffectKind::SpeedDrift),
            Injected::NonlinearStiffness => Some(EffectKind::NonlinearStiffness),
            Injected::UnknownPeriodic => Some(EffectKind::UnexplainedPeriodic),
            Injected::SecondDefect | Injected::UnknownImpacts => {
                Some(EffectKind::SecondImpactTrain)
            }
            Injected::VanePass => Some(EffectKind::ShaftOrderTones),
            Injected::Looseness => Some(EffectKind::HalfOrders),
            Injected::NoiseBand => Some(EffectKind::UnexplainedBand),
            Injected::Cavitation => Some(EffectKind::RandomBursts),
        }
    }
}

/// How strong the injected effect is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Strength {
    /// A level typical of real machines.
    Realistic,
    /// About a third of it, near the detection limit.
    Weak,
}

/// Nominal speed of the generated records, rpm.
pub const RPM: f32 = 1797.0;
/// Sampling rate, Hz.
pub const FS_HZ: f32 = 12_000.0;

/// A single-channel (drive-end) record carrying `effect` at `strength`.
pub fn generate(
    effect: Injected,
    strength: Strength,
    duration_s: f64,
    seed: u64,
) -> Result<Vec<f32>, SimError> {
    let s = if strength == Strength::Realistic {
        1.0
    } else {
        0.35
    };
    let fault = if effect == Injected::LoadZoneModulation {
        DefectLocation::InnerRace
    } else {
        DefectLocation::OuterRace
    };
    let mut spec = SimulationSpec::cwru_like(Some(fault), RPM, duration_s, seed);
    // The clean base: what the twin's base model can represent exactly.
    spec.jitter = 0.0;
    spec.modulation_depth = 0.0;
    spec.unbalance_n = 0.0;
    spec.pulse_rate_hz = 0.0;
    spec.params.stiffness_nl_radial = 0.0;
    spec.params.stiffness_nl_angular = 0.0;
    spec.angular_share = 0.0;
    spec.fs_hz = FS_HZ;
    spec.sensors = vec![SensorSpec {
        name: "DE".into(),
        transfer: SensorTransfer {
            gain_radial: 1.0 / G,
            gain_angular: 0.0,
            delay_samples: 0,
        },
    }];
    spec.extra = ExtraTerms::default();
    match effect {
        Injected::None => {}
        Injected::ShaftHarmonics => {
            spec.extra.shaft_harmonics = vec![(1.0, 400.0 * s), (2.0, 250.0 * s)];
        }
        Injected::LoadZoneModulation => spec.modulation_depth = 0.8 * s,
        Injected::Slip => spec.jitter = 0.012 * s,
        Injected::ExtraResonance => {
            let w = 2.0 * std::f64::consts::PI * 1800.0;
            spec.params.stiffness_angular = w * w;
            spec.params.damping_angular = 2.0 * 0.03 * w;
            spec.angular_share = 0.6 * s;
            spec.sensors[0].transfer.gain_angular = 1.0 / G;
        }
        Injected::LineInterference => {
            let a = 0.04 * s as f32;
            spec.extra.output_lines = vec![(50.0, a), (150.0, 0.5 * a), (250.0, 0.3 * a)];
        }
        Injected::SpeedDrift => spec.extra.speed_drift_per_s = 0.01 * s,
        Injected::NonlinearStiffness => {
            // ≈ 12 % (realistic) / 4 % (weak) frequency rise at the impact response peak
            // (≈ 0.1 µm): k_NL·x² = 0.16·s·k_r at x = 0.1 µm.
            spec.params.stiffness_nl_radial = 0.16 * s * spec.params.stiffness_radial / 1e-14;
        }
        Injected::UnknownPeriodic => spec.extra.output_lines = vec![(437.3, 0.05 * s as f32)],
        Injected::NoiseBand => spec.extra.output_band = Some((1800.0, 2400.0, 0.1 * s as f32)),
        Injected::Cavitation => {
            spec.extra.output_bursts = Some(OutputBursts {
                rate_hz: 80.0,
                f_hz: 4000.0,
                bandwidth_hz: 500.0,
                amplitude: 0.6 * s as f32,
            });
        }
        Injected::Looseness => {
            spec.extra.shaft_harmonics = [(0.5, 300.0), (1.5, 250.0), (2.5, 200.0), (3.5, 150.0)]
                .map(|(h, a)| (h, a * s))
                .to_vec();
        }
        Injected::VanePass => {
            let vpf = 7.0 * f64::from(RPM) / 60.0;
            let a = 0.08 * s as f32;
            spec.extra.output_lines = vec![(vpf, a), (2.0 * vpf, 0.4 * a)];
        }
        Injected::SecondDefect | Injected::UnknownImpacts => {
            let shaft = f64::from(RPM) / 60.0;
            let (rate, depth) = if effect == Injected::SecondDefect {
                let f = spec.bearing.frequencies(RPM / 60.0);
                (f64::from(f.bpfi), 0.3)
            } else {
                (4.37 * shaft, 0.0)
            };
            spec.extra.impact_trains = vec![ImpactTrain {
                amplitude: 0.6 * s * spec.impact_amplitude_n,
                rate_hz: rate,
                sigma_s: spec.impact_sigma_s,
                first_impact_s: 0.21 / rate,
                modulation_depth: depth,
                modulation_hz: shaft,
                jitter: 0.0,
                walk: 0.0,
                amplitude_spread: 0.0,
                rate_drift_per_s: 0.0,
            }];
        }
    }
    let rec = simulate(&spec)?;
    Ok(rec
        .channels
        .into_iter()
        .next()
        .map(|c| c.samples)
        .unwrap_or_default())
}
