//! Host-side orchestration of the core's bearing simulator: a fault hypothesis and an
//! operating condition in, a multi-node [`Recording`] out, with the same node
//! structure and sampling rate as a measured record.
//!
//! Pipeline (all physics in `pumptwin_core`):
//! 1. excitation (eqs. 18–20) rendered on the half-step grid of the RK4 rate
//!    `fs · oversample` (default 16 × 12 kHz = 192 kHz: at this step RK4 is as accurate
//!    as scipy's RK45 at rtol 1e-6 on the 3 kHz mode with 20 µs impacts — see
//!    `benches/rk4_reference.py --convergence`);
//! 2. 2-DOF RK4 (eqs. 16–17, 21–22) → radial and angular acceleration;
//! 3. per-node [`SensorTransfer`] (gain on each DOF, transport delay);
//! 4. anti-alias low-pass and decimation to `fs` (the core's FIR);
//! 5. additive white measurement noise.

use pumptwin_core::bearing::{BearingGeometry, DefectLocation};
use pumptwin_core::excitation::{
    CompositeExcitation, ImpactTrain, RandomExcitation, ShaftSinusoid, TimeGrid,
};
use pumptwin_core::fir::{decimated_len, design_lowpass, filter_decimate, BAND_LIMIT_HZ};
use pumptwin_core::rng::Xoshiro128pp;
use pumptwin_core::simulator::{Bearing2Dof, BearingParams, SensorTransfer, State};
use pumptwin_data::record::{Channel, Recording};

/// Simulated and dropped before every record, s (5 time constants of a 3 kHz mode at
/// ζ = 0.01 take 27 ms; 0.25 s also covers the slowest shaft-rate start-up).
pub const WARMUP_S: f64 = 0.25;

/// Standard gravity, m/s² per g (outputs are in g, like CWRU's accelerometers).
pub const G: f32 = 9.806_65;

/// One simulated sensor node.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorSpec {
    /// Channel name (`DE`, `FE`, `BA`, …).
    pub name: String,
    /// Gains (m/s² → output units) and delay, the delay in *output* samples.
    pub transfer: SensorTransfer,
}

/// Everything a simulated record depends on.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationSpec {
    /// Record name.
    pub name: String,
    /// Output sampling rate, Hz.
    pub fs_hz: f32,
    /// RK4 steps per output sample.
    pub oversample: usize,
    /// Duration, s.
    pub duration_s: f64,
    /// Shaft speed, rpm.
    pub rpm: f32,
    /// Bearing geometry (sets the defect frequencies).
    pub bearing: BearingGeometry,
    /// Localized defect, or `None` for a healthy bearing.
    pub fault: Option<DefectLocation>,
    /// Θ_phys: mass, damping, stiffness, cubic stiffness.
    pub params: BearingParams,
    /// Peak impact force `A_impact`, N.
    pub impact_amplitude_n: f64,
    /// Impact width σ, s.
    pub impact_sigma_s: f64,
    /// Load-zone modulation depth for inner-race and ball defects (0..1).
    pub modulation_depth: f64,
    /// Impact timing jitter about the grid as a fraction of the period (slip).
    pub jitter: f64,
    /// Random walk of the impacts' intervals, a fraction of the period
    /// ([`ImpactTrain::walk`]; 0: the train keeps its grid): a ball whose spalled spot
    /// wanders as it spins about a moving axis strikes at irregular times, while the
    /// cage still carries it through the load zone at FTF.
    pub walk: f64,
    /// Unbalance force at the shaft rate, N.
    pub unbalance_n: f64,
    /// White background force, N per RK4 half-step sample.
    pub background_n: f64,
    /// Random (Poisson) pulse rate, Hz.
    pub pulse_rate_hz: f64,
    /// Mean random pulse amplitude, N.
    pub pulse_amplitude_n: f64,
    /// Share of the force on the angular DOF.
    pub angular_share: f64,
    /// Sensor nodes.
    pub sensors: Vec<SensorSpec>,
    /// Additive white measurement noise (std, output units).
    pub measurement_noise: f32,
    /// PRNG seed (impact jitter, random excitation, measurement noise).
    pub seed: u64,
    /// Terms beyond the base model (ground truth for closed-loop tests).
    pub extra: ExtraTerms,
}

/// Terms a generated record may carry beyond eqs. 18–20 as configured above: what the
/// closed-loop tests inject without telling the loop.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExtraTerms {
    /// Force sinusoids `(shaft order, amplitude N)` besides the 1× unbalance; an order
    /// may be fractional (the half orders of a loose mount or a rub).
    pub shaft_harmonics: Vec<(f64, f64)>,
    /// Output-side sinusoids `(Hz, amplitude in output units)` on every node.
    pub output_lines: Vec<(f64, f32)>,
    /// Output-side band noise `(low Hz, high Hz, RMS in output units)` on every node
    /// (flow noise, cavitation, a neighbour's broadband): a sum of sinusoids 1 Hz
    /// apart across the band with random phases, independent per node.
    pub output_band: Option<(f64, f64, f32)>,
    /// Output-side random bursts on every node (a pump's cavitation, debris struck
    /// through the flow): ring-downs at Poisson times, independent per node.
    pub output_bursts: Option<OutputBursts>,
    /// Linear speed drift (fraction per second) of impacts and shaft terms.
    pub speed_drift_per_s: f64,
    /// Further impact trains in the radial force (a second defect, a rub, impacts from
    /// a neighbouring machine), each with its own rate, level and modulation.
    pub impact_trains: Vec<ImpactTrain>,
}

/// Ring-downs at random (Poisson) times added at the sensor: the collapse of vapour
/// bubbles in a cavitating pump, or debris carried through it, strike the casing at no
/// rate of the machine, each ringing a casing mode of its own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutputBursts {
    /// Mean burst rate, per second.
    pub rate_hz: f64,
    /// Ring frequency, Hz.
    pub f_hz: f64,
    /// −3 dB bandwidth of the ring (decay time `1 / (π·bandwidth)`), Hz.
    pub bandwidth_hz: f64,
    /// Mean peak amplitude, output units (each burst's is uniform in 0.5–1.5 × it).
    pub amplitude: f32,
}

/// Errors from a simulation.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A parameter is out of range.
    #[error("invalid simulation setting: {0}")]
    Invalid(String),
    /// The core rejected a parameter or the integration diverged.
    #[error("simulator: {0}")]
    Core(#[from] pumptwin_core::Error),
}

impl SimulationSpec {
    /// A CWRU-like test rig: DE/FE/BA accelerometers, 12 kHz, 6205 drive-end bearing;
    /// force levels chosen so a drive-end defect gives peaks of a few g, as in CWRU's
    /// 0.007" records.
    pub fn cwru_like(fault: Option<DefectLocation>, rpm: f32, duration_s: f64, seed: u64) -> Self {
        let s = |name: &str, gr: f32, gt: f32, d: u16| SensorSpec {
            name: name.to_string(),
            transfer: SensorTransfer {
                gain_radial: gr / G,
                gain_angular: gt / G,
                delay_samples: d,
            },
        };
        Self {
            name: format!("sim-{}", fault.map_or("normal", location_name)),
            fs_hz: 12_000.0,
            oversample: 16,
            duration_s,
            rpm,
            bearing: BearingGeometry::CWRU_6205_DE,
            fault,
            params: BearingParams::default_housing(),
            impact_amplitude_n: 40.0,
            impact_sigma_s: 2.0e-5,
            modulation_depth: 0.5,
            jitter: 0.005,
            walk: 0.0,
            unbalance_n: 2.0,
            background_n: 1.0,
            pulse_rate_hz: 2.0,
            pulse_amplitude_n: 10.0,
            angular_share: 0.3,
            sensors: vec![
                s("DE", 1.0, 0.3, 0),
                s("FE", 0.35, 0.35, 2),
                s("BA", 0.12, 0.05, 4),
            ],
            measurement_noise: 0.02,
            seed,
            extra: ExtraTerms::default(),
        }
    }

    /// The composite excitation of this spec (eq. 20).
    pub fn excitation(&self) -> CompositeExcitation {
        let shaft_hz = f64::from(self.rpm) / 60.0;
        let f = self.bearing.frequencies(shaft_hz as f32);
        let (rate, mod_hz, w_impact) = match self.fault {
            Some(loc) => (
                f64::from(f.impact_rate(loc)),
                f64::from(f.modulation_rate(loc)),
                1.0,
            ),
            None => (1.0, 0.0, 0.0),
        };
        let depth = if mod_hz > 0.0 {
            self.modulation_depth
        } else {
            0.0
        };
        CompositeExcitation {
            impact: ImpactTrain {
                amplitude: self.impact_amplitude_n,
                rate_hz: rate,
                sigma_s: self.impact_sigma_s,
                first_impact_s: 0.5 / rate,
                modulation_depth: depth,
                modulation_hz: mod_hz,
                jitter: self.jitter,
                walk: self.walk,
                amplitude_spread: 0.0,
                rate_drift_per_s: self.extra.speed_drift_per_s,
            },
            sinusoid: ShaftSinusoid {
                amplitude: self.unbalance_n,
                shaft_hz,
                phase_rad: 0.0,
                drift_per_s: self.extra.speed_drift_per_s,
            },
            random: RandomExcitation {
                noise_std: self.background_n,
                pulse_rate_hz: self.pulse_rate_hz,
                pulse_amplitude: self.pulse_amplitude_n,
                pulse_sigma_s: self.impact_sigma_s,
            },
            w_impact,
            w_sin: 1.0,
            w_rand: 1.0,
            angular_share: self.angular_share,
        }
    }
}

/// Short name of a defect location (`OR`, `IR`, `B`), as in CWRU labels.
pub fn location_name(loc: DefectLocation) -> &'static str {
    match loc {
        DefectLocation::OuterRace => "OR",
        DefectLocation::InnerRace => "IR",
        DefectLocation::Ball => "B",
    }
}

/// Run the simulation described by `spec`.
pub fn simulate(spec: &SimulationSpec) -> Result<Recording, SimError> {
    if !(spec.fs_hz.is_finite() && spec.fs_hz > 0.0) || spec.oversample == 0 {
        return Err(SimError::Invalid(
            "fs must be > 0 and oversample >= 1".into(),
        ));
    }
    if !(spec.duration_s.is_finite() && spec.duration_s > 0.0 && spec.duration_s <= 600.0) {
        return Err(SimError::Invalid("duration must be in (0, 600] s".into()));
    }
    if !(spec.rpm.is_finite() && spec.rpm > 0.0) {
        return Err(SimError::Invalid("rpm must be > 0".into()));
    }
    if spec.sensors.is_empty() {
        return Err(SimError::Invalid(
            "at least one sensor node is needed".into(),
        ));
    }
    spec.bearing.validate()?;
    // A warm-up, simulated and dropped, so no record starts with the transient of
    // forces switched on at t = 0.
    let n_warm = (WARMUP_S * f64::from(spec.fs_hz)).round() as usize;
    let n_keep = (spec.duration_s * f64::from(spec.fs_hz)).round() as usize;
    let n_out = n_keep + n_warm;
    let n_sim = n_out * spec.oversample;
    let fs_sim = f64::from(spec.fs_hz) * spec.oversample as f64;
    let h = 1.0 / fs_sim;

    let mut rng = Xoshiro128pp::seed_from_u64(spec.seed);
    let mut force_r = vec![0.0f64; 2 * n_sim + 1];
    let mut force_t = vec![0.0f64; 2 * n_sim + 1];
    let grid = TimeGrid {
        t0: 0.0,
        dt: 0.5 * h,
    };
    spec.excitation()
        .render(grid, &mut force_r, &mut force_t, &mut rng)?;
    let shaft_hz = f64::from(spec.rpm) / 60.0;
    for &(order, amplitude) in &spec.extra.shaft_harmonics {
        let s = ShaftSinusoid {
            amplitude,
            shaft_hz: shaft_hz * order,
            phase_rad: 1.1 * order,
            drift_per_s: spec.extra.speed_drift_per_s,
        };
        s.add_to(grid, 1.0, &mut force_r)?;
    }
    for train in &spec.extra.impact_trains {
        train.add_to(grid, 1.0, &mut force_r, &mut rng)?;
    }
    if !spec.extra.shaft_harmonics.is_empty() || !spec.extra.impact_trains.is_empty() {
        for (t, r) in force_t.iter_mut().zip(force_r.iter()) {
            *t = spec.angular_share * r;
        }
    }

    let model = Bearing2Dof::<f64>::new(&spec.params)?;
    let mut acc_r = vec![0.0f64; n_sim];
    let mut acc_t = vec![0.0f64; n_sim];
    model.simulate(State::REST, h, &force_r, &force_t, &mut acc_r, &mut acc_t)?;
    drop((force_r, force_t));

    let cutoff = BAND_LIMIT_HZ.min(0.45 * spec.fs_hz);
    let taps_len = if spec.oversample == 1 {
        1
    } else {
        40 * spec.oversample + 1
    };
    let mut taps = vec![0.0f32; taps_len];
    if spec.oversample > 1 {
        design_lowpass(cutoff, fs_sim as f32, &mut taps)?;
    } else {
        taps[0] = 1.0;
    }
    let mut node_sim = vec![0.0f32; n_sim];
    let mut channels = Vec::with_capacity(spec.sensors.len());
    for sensor in &spec.sensors {
        let delay = usize::from(sensor.transfer.delay_samples) * spec.oversample;
        let transfer = SensorTransfer {
            delay_samples: u16::try_from(delay)
                .map_err(|_| SimError::Invalid(format!("delay of {} too long", sensor.name)))?,
            ..sensor.transfer
        };
        transfer.apply(&acc_r, &acc_t, &mut node_sim)?;
        let mut out = vec![0.0f32; decimated_len(n_sim, spec.oversample)];
        filter_decimate(&node_sim, &taps, spec.oversample, &mut out)?;
        for &(hz, amp) in &spec.extra.output_lines {
            for (j, v) in out.iter_mut().enumerate() {
                let t = j as f64 / f64::from(spec.fs_hz);
                *v += amp * (2.0 * std::f64::consts::PI * hz * t + 0.4).sin() as f32;
            }
        }
        if let Some((lo, hi, rms)) = spec.extra.output_band {
            add_multisine_band(&mut out, f64::from(spec.fs_hz), lo, hi, rms, &mut rng)?;
        }
        if let Some(bursts) = spec.extra.output_bursts {
            add_bursts(&mut out, f64::from(spec.fs_hz), bursts, &mut rng)?;
        }
        if spec.measurement_noise > 0.0 {
            for v in out.iter_mut() {
                *v += spec.measurement_noise * rng.normal() as f32;
            }
        }
        out.truncate(n_out);
        out.drain(..n_warm);
        channels.push(Channel {
            name: sensor.name.clone(),
            samples: out,
        });
    }
    Ok(Recording {
        name: spec.name.clone(),
        fs_hz: spec.fs_hz,
        rpm: Some(spec.rpm),
        channels,
    })
}

/// Add band noise of RMS `rms` over `[lo, hi]` Hz: equal-amplitude sinusoids every
/// 1 Hz with random phases (a flat band, nearly Gaussian for hundreds of components).
fn add_multisine_band(
    out: &mut [f32],
    fs: f64,
    lo: f64,
    hi: f64,
    rms: f32,
    rng: &mut Xoshiro128pp,
) -> Result<(), SimError> {
    if !(lo > 0.0 && hi > lo + 1.0 && hi < 0.5 * fs && rms >= 0.0) {
        return Err(SimError::Invalid(format!(
            "output band {lo}–{hi} Hz, RMS {rms}: need 0 < low < high − 1 Hz < fs/2, RMS ≥ 0"
        )));
    }
    let count = (hi - lo).floor() as usize + 1;
    let amp = f64::from(rms) * (2.0 / count as f64).sqrt();
    let w = 2.0 * std::f64::consts::PI / fs;
    for i in 0..count {
        let f = lo + i as f64;
        let phase = 2.0 * std::f64::consts::PI * rng.uniform();
        // The sinusoid by its rotation recurrence: one complex multiply per sample.
        let (step_re, step_im) = ((w * f).cos(), (w * f).sin());
        let (mut re, mut im) = (phase.cos(), phase.sin());
        for v in out.iter_mut() {
            *v += (amp * im) as f32;
            (re, im) = (re * step_re - im * step_im, re * step_im + im * step_re);
        }
    }
    Ok(())
}

/// Add ring-downs `a·e^{−π·B·t}·sin 2π f t` at Poisson times of mean rate `bursts.rate_hz`.
fn add_bursts(
    out: &mut [f32],
    fs: f64,
    bursts: OutputBursts,
    rng: &mut Xoshiro128pp,
) -> Result<(), SimError> {
    let OutputBursts {
        rate_hz,
        f_hz,
        bandwidth_hz,
        amplitude,
    } = bursts;
    if !(rate_hz > 0.0 && f_hz > 0.0 && f_hz < 0.5 * fs && bandwidth_hz > 0.0) {
        return Err(SimError::Invalid(format!(
            "output bursts at {rate_hz}/s ringing at {f_hz} Hz, {bandwidth_hz} Hz wide: \
             need a rate > 0, 0 < ring < fs/2 and a width > 0"
        )));
    }
    let decay = std::f64::consts::PI * bandwidth_hz;
    let len = ((8.0 / decay) * fs).ceil() as usize;
    let mut t = rng.exponential(rate_hz);
    loop {
        let start = (t * fs).ceil() as usize;
        if start >= out.len() {
            return Ok(());
        }
        let a = f64::from(amplitude) * (0.5 + rng.uniform());
        for (j, v) in out[start..].iter_mut().take(len).enumerate() {
            let tau = (start + j) as f64 / fs - t;
            *v +=
                (a * (-decay * tau).exp() * (2.0 * std::f64::consts::PI * f_hz * tau).sin()) as f32;
        }
        t += rng.exponential(rate_hz);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumptwin_core::features::{envelope_spectrum, peak_frequency, EnvelopeBand};
    use pumptwin_core::fft::Complex32;

    fn envelope_peak(x: &[f32], fs: f32, lo: f32, hi: f32) -> f32 {
        let n = 16384.min(x.len().next_power_of_two() / 2);
        let mut scratch = vec![Complex32::ZERO; n];
        let mut env = vec![0.0f32; n];
        let mut spec = vec![0.0f32; n / 2 + 1];
        envelope_spectrum(
            &x[..n],
            fs,
            EnvelopeBand::DEFAULT,
            &mut scratch,
            &mut env,
            &mut spec,
        )
        .unwrap();
        peak_frequency(&spec, fs, lo, hi).unwrap()
    }

    /// The simulated fault shows up in the envelope spectrum at its kinematic rate.
    #[test]
    fn simulated_faults_peak_at_their_defect_frequency() {
        let rpm = 1797.0;
        let f = BearingGeometry::CWRU_6205_DE.frequencies(rpm / 60.0);
        for (loc, want) in [
            (DefectLocation::OuterRace, f.bpfo),
            (DefectLocation::InnerRace, f.bpfi),
        ] {
            let mut spec = SimulationSpec::cwru_like(Some(loc), rpm, 1.5, 7);
            spec.jitter = 0.0;
            let rec = simulate(&spec).unwrap();
            assert_eq!(rec.channels.len(), 3);
            assert_eq!(rec.len(), 18_000);
            let de = &rec.channels[0].samples;
            let peak = envelope_peak(de, 12_000.0, 60.0, 400.0);
            assert!(
                (peak / want - 1.0).abs() < 0.01,
                "{loc:?}: peak {peak} want {want}"
            );
        }
    }

    #[test]
    fn nodes_differ_and_healthy_is_quieter() {
        let faulty = simulate(&SimulationSpec::cwru_like(
            Some(DefectLocation::InnerRace),
            1797.0,
            0.5,
            1,
        ))
        .unwrap();
        let healthy = simulate(&SimulationSpec::cwru_like(None, 1797.0, 0.5, 1)).unwrap();
        let rms = |x: &[f32]| (x.iter().map(|v| v * v).sum::<f32>() / x.len() as f32).sqrt();
        let (de, ba) = (
            rms(&faulty.channels[0].samples),
            rms(&faulty.channels[2].samples),
        );
        assert!(de > 2.0 * ba, "DE {de} BA {ba}");
        assert!(rms(&healthy.channels[0].samples) < 0.5 * de);
        assert!(faulty.validate().is_ok());
    }

    #[test]
    fn deterministic_and_validated() {
        let spec = SimulationSpec::cwru_like(Some(DefectLocation::Ball), 1750.0, 0.2, 3);
        assert_eq!(simulate(&spec).unwrap(), simulate(&spec).unwrap());
        let bad = SimulationSpec {
            duration_s: -1.0,
            ..spec.clone()
        };
        assert!(simulate(&bad).is_err());
        let mut bad = spec;
        bad.params.mass = -1.0;
        assert!(matches!(simulate(&bad), Err(SimError::Core(_))));
    }
}
