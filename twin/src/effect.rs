//! The effects the loop can add to the twin (the table in [`crate::twin`]'s docs):
//! what each is, its kind and name in reports, and where its parameters start.

use pumptwin_core::bearing::{DefectFrequencies, DefectLocation};

/// Reference displacement for the cubic stiffness parameter, m.
pub(crate) const X_REF_M: f64 = 1.0e-6;

/// Mean burst rate a [`Effect::RandomBursts`] fit starts from, per second.
pub const BURST_START_RATE_HZ: f64 = 50.0;

/// Spread (σ of the logarithm) of the burst amplitudes about their level.
pub const BURST_LOG_SIGMA: f64 = 0.5;

/// An effect the loop can add to the model.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "effect", rename_all = "snake_case")]
pub enum Effect {
    /// Force sinusoids at these shaft orders.
    ShaftHarmonics {
        /// Orders k of k·f_r.
        orders: Vec<u32>,
    },
    /// Force sinusoids at half orders of the shaft rate (0.5×, 1.5×, 2.5×, …): mechanical
    /// looseness of the bearing's seat or mount, or a rub — the rotor lifts and settles,
    /// or strikes, once every two turns, so the force repeats every second turn. It
    /// acts through the bearing, like [`Effect::ShaftHarmonics`].
    HalfOrders {
        /// Orders k + ½ of (k + ½)·f_r.
        orders: Vec<f64>,
    },
    /// Output-side sinusoids at these shaft orders: tones locked to the shaft that reach
    /// the sensor by another path than the bearing's rolling contact (a pump impeller's
    /// vane pass, a coupling's or a gear's mesh), so they do not load the rolling
    /// elements and leave the impacts unmodulated. The force-side
    /// [`Effect::ShaftHarmonics`] puts a large low-order force through the contact's
    /// Hertzian stiffness and modulates the impacts at its rate; a measurement whose
    /// envelope carries no such modulation rejects it, and these tones are the
    /// alternative the loop then tries.
    ShaftOrderTones {
        /// Orders k of k·f_r.
        orders: Vec<u32>,
    },
    /// Amplitude modulation of the impacts at `mod_hz`.
    LoadZoneModulation {
        /// Modulation frequency, Hz (shaft rate for inner race, cage rate for balls).
        mod_hz: f64,
    },
    /// The radial load zone a rotating race or rolling element passes through (Harris):
    /// each impact × `q(θ) = (1 − (1 − cos θ)/(2ε))^{3/2}` where positive, 0 outside,
    /// θ the defect's angle from the load's direction, turning at `mod_hz` (the shaft's
    /// rate for an inner race, the cage's for a ball). A zone narrower than a turn
    /// modulates the impacts at the harmonics of its rate too, which a cosine
    /// modulation ([`Effect::LoadZoneModulation`]) lacks. A term of the base (the first
    /// fit adds it), never traced.
    LoadZone {
        /// The rate the defect turns through the zone at, Hz.
        mod_hz: f64,
    },
    /// Random impact timing.
    Slip,
    /// A spread of the impact strengths (σ of each impact's amplitude relative to the
    /// mean): what every real bearing's impacts have (Randall & Antoni 2011, §2). A
    /// term of the base (the first fit adds it), never traced as an effect: read as
    /// anything else it becomes random bursts or band noise nobody has.
    StrengthSpread,
    /// Linear speed drift over the record.
    SpeedDrift {
        /// Starting value of the drift (fraction per second), from the evidence.
        initial_per_s: f64,
        /// Starting mean-rate factor (`mean rate / kinematic − 1`), from the evidence.
        initial_rate_factor: f64,
    },
    /// A second structural mode near `f_hz`.
    ExtraResonance {
        /// Natural frequency, Hz: the start its evidence gave (a report's step
        /// names it as fitted, [`crate::twin::TwinModel::fitted_effect`]).
        f_hz: f64,
    },
    /// Cubic (hardening) stiffness.
    NonlinearStiffness {
        /// Measured excess of the ring-down start frequency over its end (fraction).
        initial_rel_shift: f64,
    },
    /// Electrical lines at these frequencies (output side).
    LineInterference {
        /// Line frequencies, Hz.
        freqs: Vec<f64>,
    },
    /// An output-side sinusoid nobody declared.
    UnexplainedPeriodic {
        /// Frequency, Hz.
        f_hz: f64,
        /// `f_hz / f_r`.
        order: f64,
    },
    /// A second train of impacts in the radial force at `rate_hz`: a compound fault
    /// (the bearing's other defect rates), impacts once per turn (a rub) or from a
    /// source the bearing's kinematics do not name. It excites the same structure as
    /// the modelled defect, so it is a force term, not an output-side one.
    SecondImpactTrain {
        /// Impact rate, Hz (from the residual's envelope lines, refined on the PSD comb).
        rate_hz: f64,
        /// What the rate matches: `inner_race`, `outer_race`, `ball`, `shaft` (once per
        /// turn), `shaft_synchronous` (k impacts per turn) or `unexplained`.
        source: String,
    },
    /// Output-side band noise nobody declared.
    UnexplainedBand {
        /// Centre, Hz.
        f_hz: f64,
        /// −3 dB bandwidth, Hz.
        bandwidth_hz: f64,
    },
    /// Ring-downs at random times added at the sensor: impacts at no rate of the
    /// machine — the collapse of vapour bubbles in a cavitating pump, debris carried
    /// through it, a loose part struck at random — each ringing a casing mode of its
    /// own, not the bearing's structure. A Poisson process of bursts
    /// `a_i·e^{−π·B·t}·sin 2π f t` (mean rate λ, amplitudes log-normal about `a`, σ = 0.5).
    /// Its spectrum is a band like [`Effect::UnexplainedBand`]'s (shot noise tends to
    /// Gaussian noise as λ grows); what sets it apart is impulsiveness: at a rate of
    /// tens per second the band is carried by isolated bursts, and the fit reads λ from
    /// the record's kurtosis and envelope as much as from its spectrum.
    RandomBursts {
        /// Initial ring frequency, Hz.
        f_hz: f64,
        /// Initial −3 dB bandwidth, Hz.
        bandwidth_hz: f64,
    },
}

/// What kind of effect an [`Effect`] is: its name in reports, and the key the loop
/// counts and looks effects up by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EffectKind {
    /// `shaft_harmonics`.
    ShaftHarmonics,
    /// `shaft_order_tones`.
    ShaftOrderTones,
    /// `half_orders`.
    HalfOrders,
    /// `load_zone_modulation`.
    LoadZoneModulation,
    /// `load_zone`.
    LoadZone,
    /// `slip`.
    Slip,
    /// `strength_spread`.
    StrengthSpread,
    /// `speed_drift`.
    SpeedDrift,
    /// `extra_resonance`.
    ExtraResonance,
    /// `nonlinear_stiffness`.
    NonlinearStiffness,
    /// `line_interference`.
    LineInterference,
    /// `unexplained_periodic`.
    UnexplainedPeriodic,
    /// `unexplained_band`.
    UnexplainedBand,
    /// `second_impact_train`.
    SecondImpactTrain,
    /// `random_bursts`.
    RandomBursts,
}

impl EffectKind {
    /// The name in reports.
    pub fn name(self) -> &'static str {
        match self {
            EffectKind::ShaftHarmonics => "shaft_harmonics",
            EffectKind::ShaftOrderTones => "shaft_order_tones",
            EffectKind::HalfOrders => "half_orders",
            EffectKind::LoadZoneModulation => "load_zone_modulation",
            EffectKind::LoadZone => "load_zone",
            EffectKind::Slip => "slip",
            EffectKind::StrengthSpread => "strength_spread",
            EffectKind::SpeedDrift => "speed_drift",
            EffectKind::ExtraResonance => "extra_resonance",
            EffectKind::NonlinearStiffness => "nonlinear_stiffness",
            EffectKind::LineInterference => "line_interference",
            EffectKind::UnexplainedPeriodic => "unexplained_periodic",
            EffectKind::UnexplainedBand => "unexplained_band",
            EffectKind::SecondImpactTrain => "second_impact_train",
            EffectKind::RandomBursts => "random_bursts",
        }
    }
}

impl Effect {
    /// The kind of effect.
    pub fn kind(&self) -> EffectKind {
        match self {
            Effect::ShaftHarmonics { .. } => EffectKind::ShaftHarmonics,
            Effect::ShaftOrderTones { .. } => EffectKind::ShaftOrderTones,
            Effect::HalfOrders { .. } => EffectKind::HalfOrders,
            Effect::LoadZoneModulation { .. } => EffectKind::LoadZoneModulation,
            Effect::LoadZone { .. } => EffectKind::LoadZone,
            Effect::Slip => EffectKind::Slip,
            Effect::StrengthSpread => EffectKind::StrengthSpread,
            Effect::SpeedDrift { .. } => EffectKind::SpeedDrift,
            Effect::ExtraResonance { .. } => EffectKind::ExtraResonance,
            Effect::NonlinearStiffness { .. } => EffectKind::NonlinearStiffness,
            Effect::LineInterference { .. } => EffectKind::LineInterference,
            Effect::UnexplainedPeriodic { .. } => EffectKind::UnexplainedPeriodic,
            Effect::UnexplainedBand { .. } => EffectKind::UnexplainedBand,
            Effect::SecondImpactTrain { .. } => EffectKind::SecondImpactTrain,
            Effect::RandomBursts { .. } => EffectKind::RandomBursts,
        }
    }

    /// The effect's name in reports.
    pub fn name(&self) -> &'static str {
        self.kind().name()
    }

    /// The shaft orders of a force at the shaft's orders through the bearing
    /// (`shaft_harmonics`: k; `half_orders`: k + ½), with the prefix of its amplitude
    /// parameters; `None` for any other effect.
    pub(crate) fn force_orders(&self) -> Option<(Vec<f64>, &'static str)> {
        match self {
            Effect::ShaftHarmonics { orders } => Some((
                orders.iter().map(|&k| f64::from(k)).collect(),
                "ln_shaft_amp_",
            )),
            Effect::HalfOrders { orders } => Some((orders.clone(), "ln_half_order_amp_")),
            _ => None,
        }
    }

    /// Whether the effect is a term added at the sensor, after the structure (mains
    /// lines, tones by another path, an unexplained tone or band): it has nothing to
    /// trade with the structure's parameters but the measurement noise.
    pub fn is_output_side(&self) -> bool {
        matches!(
            self,
            Effect::ShaftOrderTones { .. }
                | Effect::LineInterference { .. }
                | Effect::UnexplainedPeriodic { .. }
                | Effect::UnexplainedBand { .. }
                | Effect::RandomBursts { .. }
        )
    }

    /// The bearing defect a second impact train's rate was named for (`None` for any
    /// other effect, and for a train from elsewhere: a rub, a struck part). Its load
    /// zone modulates it as it does that defect: at the core's
    /// [`DefectFrequencies::modulation_rate`] (shaft for an inner race, cage for a ball,
    /// none for a stationary outer race).
    pub fn second_train_location(&self) -> Option<DefectLocation> {
        let Effect::SecondImpactTrain { source, .. } = self else {
            return None;
        };
        location_named(source)
    }

    /// Names and initial unconstrained values of the parameters it adds, from what the
    /// current model and the measurement say (`Start`).
    pub(crate) fn initial(&self, st: &Start<'_>) -> Vec<(String, f64)> {
        let Start {
            noise,
            excess_power,
            force_gain,
            freqs,
            peak_displacement,
            impact_amp,
            background,
        } = *st;
        let shaft = f64::from(freqs.shaft);
        // A sinusoid carrying the excess power at `f` (a one-sided PSD line of
        // amplitude A holds A²/2).
        let line_amp = |f: f64| excess_power(f, 0.0).map(|p| (2.0 * p).sqrt());
        let amp_or = |f: f64| line_amp(f).unwrap_or(3.0 * noise).max(1e-9).ln();
        match self {
            Effect::ShaftHarmonics { .. } | Effect::HalfOrders { .. } => {
                let (orders, prefix) = self.force_orders().unwrap_or_default();
                orders
                    .iter()
                    .map(|h| {
                        let f = shaft * h;
                        let amp = line_amp(f).map_or(1.0, |a| a / force_gain(f).max(1e-30));
                        (format!("{prefix}{h}x"), amp.max(1e-6).ln())
                    })
                    .collect()
            }
            Effect::ShaftOrderTones { orders } => orders
                .iter()
                .map(|k| (format!("ln_tone_amp_{k}x"), amp_or(shaft * f64::from(*k))))
                .collect(),
            Effect::LoadZoneModulation { .. } => vec![("logit_modulation_depth".into(), 0.0)],
            // ε = ½ (a zone of ±90°, zero clearance) to start; above 1 every angle
            // carries load (a preload, a heavy rotor), the zone a partial modulation.
            Effect::LoadZone { .. } => vec![("ln_zone_eps".into(), 0.5f64.ln())],
            Effect::Slip => vec![
                ("ln_jitter".into(), (0.005f64).ln()),
                ("ln_walk".into(), crate::slip::WALK_NONE.ln()),
            ],
            Effect::StrengthSpread => vec![("ln_spread".into(), (0.15f64).ln())],
            Effect::SpeedDrift { initial_per_s, .. } => {
                vec![("drift_per_s".into(), *initial_per_s)]
            }
            Effect::ExtraResonance { f_hz } => vec![
                ("ln_fn2_hz".into(), f_hz.ln()),
                ("ln_zeta2".into(), (0.03f64).ln()),
                ("ln_share2".into(), (0.5f64).ln()),
            ],
            Effect::NonlinearStiffness { initial_rel_shift } => {
                // Duffing: Δf/f ≈ (3/8)·k_NL·A²/k_r at amplitude A; the early ring-down
                // window averages over the decay, so the peak shift is about twice the
                // measured one. ρ = k_NL·x_ref²/k_r.
                let a = peak_displacement.max(1e-12);
                let rho = (8.0 / 3.0) * 2.0 * initial_rel_shift.max(1e-4) * (X_REF_M / a).powi(2);
                vec![("ln_knl_rel".into(), rho.ln())]
            }
            Effect::LineInterference { freqs } => freqs
                .iter()
                .map(|f| (format!("ln_line_amp_{f:.1}hz"), amp_or(*f)))
                .collect(),
            Effect::UnexplainedPeriodic { f_hz, .. } => {
                vec![("ln_periodic_amp".into(), amp_or(*f_hz))]
            }
            // Band noise whose RMS carries the excess power over the band (started at
            // the measurement noise σ_y, a band a few dB over the model adds nothing
            // the log spectrum can feel, and the refit never moves it), with its centre
            // and width fitted too: the band is read off a residual smoothed over
            // ±100 Hz, which widens its run.
            Effect::UnexplainedBand { f_hz, bandwidth_hz } => vec![
                (
                    "ln_band_level".into(),
                    excess_power(*f_hz, 0.5 * bandwidth_hz)
                        .map_or(noise, f64::sqrt)
                        .max(1e-9)
                        .ln(),
                ),
                ("ln_band_centre_hz".into(), f_hz.ln()),
                ("ln_band_width_hz".into(), bandwidth_hz.max(1.0).ln()),
            ],
            // Bursts carrying the band's excess power at a start of 50 per second: the
            // power of shot noise of rate λ whose bursts ring `a·e^{−πBt}·sin 2πft` is
            // λ·E[a²]/(4πB); E[a²] = a²·e^{σ²} with log-normal amplitudes (σ = 0.5).
            Effect::RandomBursts { f_hz, bandwidth_hz } => {
                let rate = BURST_START_RATE_HZ;
                let power = excess_power(*f_hz, 0.5 * bandwidth_hz).unwrap_or(noise * noise);
                let amp = (power * 4.0 * std::f64::consts::PI * bandwidth_hz
                    / (rate * (BURST_LOG_SIGMA * BURST_LOG_SIGMA).exp()))
                .sqrt();
                vec![
                    ("ln_burst_amp".into(), amp.max(1e-9).ln()),
                    ("ln_burst_rate_hz".into(), rate.ln()),
                    ("ln_burst_ring_hz".into(), f_hz.ln()),
                    ("ln_burst_width_hz".into(), bandwidth_hz.max(10.0).ln()),
                ]
            }
            // Half the modelled defect's impact level, or (healthy model) twenty times
            // the background force; the refit's second start tries a twentieth of it.
            // A defect its load zone modulates gets the zone's ε, from ½ (±90°), as
            // the base's: Harris's zone, not a cosine, because a bearing with
            // clearance loads under half its turn and a cosine cannot leave the
            // impacts out of the rest (on `--seed 7` case 174, an inner race read
            // second with a cosine needed random bursts beside it to fit).
            Effect::SecondImpactTrain { .. } => {
                let start = if impact_amp > 0.0 {
                    0.5 * impact_amp
                } else {
                    20.0 * background
                };
                let mut v = vec![("ln_impact2_amp".into(), start.max(1e-9).ln())];
                if self
                    .second_train_location()
                    .is_some_and(|loc| freqs.modulation_rate(loc) > 0.0)
                {
                    v.push(("ln_zone2_eps".into(), 0.5f64.ln()));
                }
                v
            }
        }
    }
}

/// What an effect's starting values are taken from.
#[derive(Clone, Copy)]
pub(crate) struct Start<'a> {
    /// Measurement noise σ_y of the current model (output units).
    pub(crate) noise: f64,
    /// Power (output units²) of the measured excess over the model within `f ± half`
    /// Hz (at least the PSD's ±2 bins): `excess_power(f, half)`.
    pub(crate) excess_power: &'a dyn Fn(f64, f64) -> Option<f64>,
    /// The model's output amplitude per newton of force at a frequency.
    pub(crate) force_gain: &'a dyn Fn(f64) -> f64,
    /// Kinematic frequencies at the nominal speed.
    pub(crate) freqs: DefectFrequencies,
    /// Peak displacement of one impact's ring-down, m.
    pub(crate) peak_displacement: f64,
    /// The modelled defect's impact level, N (0 for a healthy model).
    pub(crate) impact_amp: f64,
    /// Background force σ_F, N.
    pub(crate) background: f64,
}

/// Harris's radial load distribution over a rolling bearing's circumference, relative
/// to the load's direction: `(1 − (1 − cos θ)/(2ε))^{3/2}` where positive (ball
/// bearings' exponent 3/2), 0 outside; ε is the load-distribution factor (½: the zone
/// spans ±90°, zero clearance; smaller: a narrower zone, a bearing with clearance).
pub fn harris_zone(theta: f64, eps: f64) -> f64 {
    let q = 1.0 - (1.0 - theta.cos()) / (2.0 * eps.max(1e-3));
    if q > 0.0 {
        q.powf(1.5)
    } else {
        0.0
    }
}

/// Which defect the frequencies point at, by name (`outer_race` …) for reports.
pub fn fault_name(fault: Option<DefectLocation>) -> &'static str {
    match fault {
        None => "none",
        Some(DefectLocation::OuterRace) => "outer_race",
        Some(DefectLocation::InnerRace) => "inner_race",
        Some(DefectLocation::Ball) => "ball",
    }
}

/// The bearing defect [`fault_name`] names `source`, if it names one.
pub fn location_named(source: &str) -> Option<DefectLocation> {
    [
        DefectLocation::OuterRace,
        DefectLocation::InnerRace,
        DefectLocation::Ball,
    ]
    .into_iter()
    .find(|loc| fault_name(Some(*loc)) == source)
}

#[cfg(test)]
mod tests {
    use super::harris_zone;
    use std::f64::consts::PI;

    /// Full load under the load, none from ±90° on for ε = ½, (½)^{3/2} at ±60°; a
    /// narrower zone (ε = 0.3) ends at ±66.4° (cos θ = 1 − 2ε).
    #[test]
    fn the_harris_zone_has_its_textbook_shape() {
        assert!((harris_zone(0.0, 0.5) - 1.0).abs() < 1e-12);
        assert!((harris_zone(PI / 3.0, 0.5) - 0.5f64.powf(1.5)).abs() < 1e-12);
        assert!(harris_zone(PI / 2.0, 0.5) < 1e-12);
        assert_eq!(harris_zone(PI, 0.5), 0.0);
        let edge = (1.0f64 - 2.0 * 0.3).acos();
        assert!(harris_zone(edge - 0.01, 0.3) > 0.0);
        assert_eq!(harris_zone(edge + 0.01, 0.3), 0.0);
    }

    /// A wide zone (ε > ½, every element loaded) is the cosine modulation of depth
    /// 1.5/ε: ε = 5 leaves 1 − 0.3 at the far side and follows the cosine between.
    #[test]
    fn a_wide_harris_zone_is_a_cosine_modulation() {
        let eps = 5.0;
        let depth = 1.5 / eps;
        for k in 0..=12 {
            let theta = PI * f64::from(k) / 12.0;
            let cosine = 1.0 - 0.5 * depth * (1.0 - theta.cos());
            assert!((harris_zone(theta, eps) - cosine).abs() < 0.02, "θ {theta}");
        }
    }
}
