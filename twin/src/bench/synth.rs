//! The benchmark's signal: Randall & Antoni's (2011) model of a bearing signal,
//! written here on its own and sharing nothing with the twin's model or
//! [`crate::sim`]:
//!
//! `x(t) = Σ_i A_i q(θ_i) h(t − t_i) + b(t) + n(t)`, recorded through an anti-alias
//! filter, where the impact times `t_i` advance by the defect's period in shaft angle
//! with a random jitter (slip), `A_i` spreads about its mean, `q` is the radial load
//! zone `(1 − (1 − cos θ)/(2ε))^{3/2}` for a rotating-race or rolling-element defect,
//! `h` is the sum of the structure's modes, `b` the machine's broadband background
//! through the same modes and `n` the sensor's white noise. Everything is synthesized
//! at 4 × the acquisition rate and brought down through a windowed-sinc filter (cut at
//! 0.42 fs, Blackman, 255 taps), as a DAQ's anti-alias filter and decimator do.

use super::draw::{Base, Case, Defect, Injection, Mode};
use pumptwin_core::rng::Xoshiro128pp;
use std::f64::consts::PI;

/// Simulation rate over the acquisition rate.
pub const OVERSAMPLE: usize = 4;
/// Anti-alias filter length, taps at the simulation rate.
const TAPS: usize = 255;

/// The case's record at its acquisition rate, g.
pub fn synthesize(case: &Case, seconds: f64) -> Vec<f32> {
    let b = &case.base;
    let fs_sim = b.fs_hz * OVERSAMPLE as f64;
    let n = (seconds * fs_sim) as usize;
    let mut rng = Xoshiro128pp::seed_from_u64(case.seed ^ 0x5EED);
    let shaft = shaft_turns(b, case, n, fs_sim);
    let force = force(b, case, &shaft, fs_sim, &mut rng);
    let background: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
    // The background's gain so that it reaches its RMS through the structure.
    let bg_through = structure(b, case, &background, fs_sim, None);
    let bg_gain = b.background_g / rms(&bg_through).max(1e-30);
    let excitation: Vec<f64> = force
        .iter()
        .zip(&background)
        .map(|(f, w)| f + bg_gain * w)
        .collect();
    let duffing = case.injected.iter().find_map(|d| match d.injection {
        Injection::Duffing { shift } => Some(shift),
        _ => None,
    });
    let mut sim = structure(b, case, &excitation, fs_sim, duffing);
    for v in sim.iter_mut() {
        *v += b.noise_g * rng.normal();
    }
    let x = decimate(&sim, fs_sim);
    let base_rms = rms(&x);
    let mut sensor = vec![0.0f64; n];
    for d in &case.injected {
        add_sensor_side(
            &d.injection,
            &shaft,
            fs_sim,
            base_rms,
            &mut sensor,
            &mut rng,
        );
    }
    at_the_sensor(case, x, &sensor, fs_sim)
}

/// A measured record `x` (at `case.base.fs_hz`, the speed `case.base.rpm`) with the
/// case's injections added as [`synthesize`] adds them to a synthesized one: the
/// sensor-side ones at levels relative to the record's RMS (`base.background_g`), a
/// compound fault's second train synthesized alone (the base's slip, spread and load
/// zone, through the mode drawn for it) at `rel` times the record's RMS, then the
/// acquisition's clipping and dropouts. The record's own signal is untouched.
pub fn inject_measured(case: &Case, x: &[f32]) -> Vec<f32> {
    let b = &case.base;
    let fs_sim = b.fs_hz * OVERSAMPLE as f64;
    let n = x.len() * OVERSAMPLE;
    let mut rng = Xoshiro128pp::seed_from_u64(case.seed ^ 0x5EED);
    let turns = shaft_turns(b, case, n, fs_sim);
    let out: Vec<f64> = x.iter().map(|&v| f64::from(v)).collect();
    let base_rms = rms(&out);
    let mut sensor = vec![0.0f64; n];
    for d in &case.injected {
        add_sensor_side(
            &d.injection,
            &turns,
            fs_sim,
            base_rms,
            &mut sensor,
            &mut rng,
        );
        if let Injection::Compound { defect, rel, .. } = d.injection {
            let mut f = vec![0.0f64; n];
            impact_train(b, defect, 1.0, &turns, fs_sim, None, &mut rng, &mut f);
            let y = structure(b, case, &f, fs_sim, None);
            let gain = rel * base_rms / rms(&decimate(&y, fs_sim)).max(1e-30);
            for (s, v) in sensor.iter_mut().zip(y) {
                *s += gain * v;
            }
        }
    }
    at_the_sensor(case, out, &sensor, fs_sim)
}

/// The record `x` at the acquisition rate with what reaches the sensor beside the
/// structure (`sensor`, at the simulation rate) added through the anti-alias filter,
/// then the acquisition's clipping and dropouts.
fn at_the_sensor(case: &Case, mut x: Vec<f64>, sensor: &[f64], fs_sim: f64) -> Vec<f32> {
    for (o, s) in x.iter_mut().zip(decimate(sensor, fs_sim)) {
        *o += s;
    }
    for d in &case.injected {
        acquisition(&d.injection, &mut x);
    }
    x.into_iter().map(|v| v as f32).collect()
}

/// Shaft angle in turns at every simulation sample, with a linear speed drift if one
/// is injected (the mean speed stays the nominal one).
fn shaft_turns(b: &Base, case: &Case, n: usize, fs_sim: f64) -> Vec<f64> {
    let drift = case
        .injected
        .iter()
        .find_map(|d| match d.injection {
            Injection::SpeedDrift { total } => Some(total),
            _ => None,
        })
        .unwrap_or(0.0);
    let f0 = b.rpm / 60.0;
    let mut turns = Vec::with_capacity(n);
    let mut acc = 0.0;
    for i in 0..n {
        turns.push(acc);
        let rel = i as f64 / n as f64 - 0.5;
        acc += f0 * (1.0 + drift * rel) / fs_sim;
    }
    turns
}

/// The impacts as a force at the simulation rate: the base's defect and a compound
/// defect, each with its slip, spread, load zone and any injected modulation.
fn force(b: &Base, case: &Case, turns: &[f64], fs_sim: f64, rng: &mut Xoshiro128pp) -> Vec<f64> {
    let mut f = vec![0.0; turns.len()];
    let Some(defect) = b.defect else {
        return f;
    };
    let modulation = case.injected.iter().find_map(|d| match d.injection {
        Injection::Modulation { f_hz, depth } => Some((f_hz, depth)),
        _ => None,
    });
    impact_train(
        b, defect, b.impact_g, turns, fs_sim, modulation, rng, &mut f,
    );
    for d in &case.injected {
        if let Injection::Compound { defect, rel, .. } = d.injection {
            impact_train(
                b,
                defect,
                b.impact_g * rel,
                turns,
                fs_sim,
                modulation,
                rng,
                &mut f,
            );
        }
    }
    f
}

/// Add one defect's impacts to `f`: the next impact comes when the shaft has turned
/// by the defect's period (in turns) times `1 + slip·N(0, 1)`; its strength is
/// `A·max(0, 1 + spread·N(0, 1))·q(θ)·m(t)`, split linearly between the two nearest
/// samples so that its timing is not rounded.
#[allow(clippy::too_many_arguments)]
fn impact_train(
    b: &Base,
    defect: Defect,
    amp: f64,
    turns: &[f64],
    fs_sim: f64,
    modulation: Option<(f64, f64)>,
    rng: &mut Xoshiro128pp,
    f: &mut [f64],
) {
    let o = b.bearing.orders();
    let order = b.impact_order(defect);
    let zone_turns = match defect {
        Defect::OuterRace => None,
        Defect::InnerRace => Some(1.0),
        Defect::Ball => Some(f64::from(o.ftf)),
    };
    let phase0 = rng.uniform();
    let mod_phase = rng.uniform() * 2.0 * PI;
    let mut next = rng.uniform() / order;
    let mut k = 0usize;
    let mut i = 0usize;
    while i + 1 < turns.len() {
        if turns[i + 1] < next {
            i += 1;
            continue;
        }
        let frac = (next - turns[i]) / (turns[i + 1] - turns[i]);
        let mut a = amp * (1.0 + b.spread * rng.normal()).max(0.0);
        if let Some(per_turn) = zone_turns {
            a *= load_zone(2.0 * PI * (next * per_turn + phase0), b.load_zone_eps);
        }
        if defect == Defect::Ball && k % 2 == 1 {
            a *= b.ball_alternate;
        }
        if let Some((fm, depth)) = modulation {
            let t = (i as f64 + frac) / fs_sim;
            a *= (1.0 + depth * (2.0 * PI * fm * t + mod_phase).cos()) / (1.0 + depth);
        }
        f[i] += a * (1.0 - frac);
        f[i + 1] += a * frac;
        next += (1.0 + b.slip * rng.normal()).max(0.5) / order;
        k += 1;
    }
}

/// The radial load zone (Harris): `(1 − (1 − cos θ)/(2ε))^{3/2}` where positive, else 0.
fn load_zone(theta: f64, eps: f64) -> f64 {
    let q = 1.0 - (1.0 - theta.cos()) / (2.0 * eps);
    if q > 0.0 {
        q.powf(1.5)
    } else {
        0.0
    }
}

/// The structure's response to `force` (impulses in g of the first mode's peak): the
/// sum of its modes, each `gain · e^{−ζωt} sin ω_d t` per unit impulse (impulse-
/// invariant two-pole filter), the first one a Duffing oscillator when `duffing` names
/// its frequency rise at the strongest impact.
fn structure(b: &Base, case: &Case, force: &[f64], fs_sim: f64, duffing: Option<f64>) -> Vec<f64> {
    let mut modes = b.modes.clone();
    for d in &case.injected {
        if let Injection::ExtraMode { mode } = d.injection {
            modes.push(mode);
        }
    }
    let mut out = vec![0.0; force.len()];
    for (m, mode) in modes.iter().enumerate() {
        let y = match duffing {
            Some(shift) if m == 0 => duffing_mode(mode, force, fs_sim, shift, b),
            _ => linear_mode(mode, force, fs_sim),
        };
        for (o, v) in out.iter_mut().zip(y) {
            *o += mode.gain * v;
        }
    }
    out
}

fn linear_mode(mode: &Mode, force: &[f64], fs_sim: f64) -> Vec<f64> {
    let w = 2.0 * PI * mode.f_hz;
    let sigma = mode.zeta * w;
    let wd = w * (1.0 - mode.zeta * mode.zeta).sqrt();
    let dt = 1.0 / fs_sim;
    let r = (-sigma * dt).exp();
    let (a1, a2) = (2.0 * r * (wd * dt).cos(), -r * r);
    let g = r * (wd * dt).sin();
    let mut y = vec![0.0; force.len()];
    let (mut y1, mut y2, mut x1) = (0.0, 0.0, 0.0);
    for (i, &x) in force.iter().enumerate() {
        let v = a1 * y1 + a2 * y2 + g * x1;
        y[i] = v;
        y2 = y1;
        y1 = v;
        x1 = x;
    }
    y
}

/// `u'' + 2ζω u' + ω² (u + β u³) = 0` between impacts, each impact a velocity kick
/// of `ω_d` times its strength (so a small one rings as the linear mode does); RK4
/// with two steps per sample. β sets the frequency at the strongest impact's
/// amplitude `U` to `(1 + shift)·ω` (first-order harmonic balance:
/// `ω_U² = ω² (1 + ¾ β U²)`).
fn duffing_mode(mode: &Mode, force: &[f64], fs_sim: f64, shift: f64, b: &Base) -> Vec<f64> {
    let w = 2.0 * PI * mode.f_hz;
    let c = 2.0 * mode.zeta * w;
    let wd = w * (1.0 - mode.zeta * mode.zeta).sqrt();
    let peak = b.impact_g.max(b.background_g) * (1.0 + 2.0 * b.spread);
    let beta = ((1.0 + shift).powi(2) - 1.0) / (0.75 * peak * peak);
    let acc = |u: f64, v: f64| -c * v - w * w * (u + beta * u * u * u);
    let h = 0.5 / fs_sim;
    let mut y = vec![0.0; force.len()];
    let (mut u, mut v) = (0.0f64, 0.0f64);
    for (i, &kick) in force.iter().enumerate() {
        y[i] = u;
        v += wd * kick;
        for _ in 0..2 {
            let (k1u, k1v) = (v, acc(u, v));
            let (k2u, k2v) = (v + 0.5 * h * k1v, acc(u + 0.5 * h * k1u, v + 0.5 * h * k1v));
            let (k3u, k3v) = (v + 0.5 * h * k2v, acc(u + 0.5 * h * k2u, v + 0.5 * h * k2v));
            let (k4u, k4v) = (v + h * k3v, acc(u + h * k3u, v + h * k3v));
            u += h / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u);
            v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        }
    }
    y
}

/// Terms added at the sensor, after the structure: mains, tones locked to the shaft,
/// bursts. Amplitudes are in g (drawn against the base), bursts scaled to their level
/// over the base's RMS.
fn add_sensor_side(
    inj: &Injection,
    turns: &[f64],
    fs_sim: f64,
    base_rms: f64,
    out: &mut [f64],
    rng: &mut Xoshiro128pp,
) {
    let mut tone = |amp: f64, phase_of: &dyn Fn(usize) -> f64, rng: &mut Xoshiro128pp| {
        let p0 = rng.uniform() * 2.0 * PI;
        for (i, o) in out.iter_mut().enumerate() {
            *o += amp * (phase_of(i) + p0).sin();
        }
    };
    match inj {
        Injection::Mains { f0_hz, lines, .. } => {
            for &(h, a) in lines {
                let f = f0_hz * f64::from(h);
                tone(a, &|i| 2.0 * PI * f * i as f64 / fs_sim, rng);
            }
        }
        Injection::ShaftTones { orders } => {
            for &(k, a) in orders {
                tone(a, &|i| 2.0 * PI * f64::from(k) * turns[i], rng);
            }
        }
        Injection::MeshTones {
            order,
            amp_g,
            sideband,
        } => {
            for (k, a) in [
                (*order, *amp_g),
                (order - 1, amp_g * sideband),
                (order + 1, amp_g * sideband),
            ] {
                tone(a, &|i| 2.0 * PI * f64::from(k) * turns[i], rng);
            }
        }
        Injection::Bursts {
            rate_hz,
            f_hz,
            bandwidth_hz,
            level_db,
        } => {
            let bursts = bursts(out.len(), fs_sim, *rate_hz, *f_hz, *bandwidth_hz, rng);
            let gain = base_rms * 10f64.powf(level_db / 20.0) / rms(&decimate(&bursts, fs_sim));
            for (o, v) in out.iter_mut().zip(bursts) {
                *o += gain * v;
            }
        }
        _ => {}
    }
}

/// Ring-downs `a·e^{−πBt} sin(2πft + φ)` at Poisson times, `a` log-normal (σ = 0.5).
fn bursts(n: usize, fs_sim: f64, rate: f64, f: f64, bw: f64, rng: &mut Xoshiro128pp) -> Vec<f64> {
    let mut x = vec![0.0; n];
    let len = ((1000f64).ln() / (PI * bw) * fs_sim) as usize;
    let mut t = rng.exponential(rate);
    while ((t * fs_sim) as usize) < n {
        let start = (t * fs_sim) as usize;
        let a = (0.5 * rng.normal()).exp();
        let phi = rng.uniform() * 2.0 * PI;
        for (j, v) in x[start..(start + len).min(n)].iter_mut().enumerate() {
            let tau = j as f64 / fs_sim;
            *v += a * (-PI * bw * tau).exp() * (2.0 * PI * f * tau + phi).sin();
        }
        t += rng.exponential(rate);
    }
    x
}

/// Effects of the acquisition itself, at its rate: clipping at the rails, dropouts.
fn acquisition(inj: &Injection, x: &mut [f64]) {
    match inj {
        Injection::Clipping { level } => {
            let rail = level * x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            x.iter_mut().for_each(|v| *v = v.clamp(-rail, rail));
        }
        Injection::Dropouts { runs } => {
            for &(start, len) in runs {
                let end = (start + len).min(x.len());
                if start < end {
                    let held = x[start];
                    x[start..end].fill(held);
                }
            }
        }
        _ => {}
    }
}

/// The anti-alias filter and decimator: a Blackman-windowed sinc cut at 0.42 of the
/// output rate, unit gain at DC, evaluated only at the kept samples.
fn decimate(x: &[f64], fs_sim: f64) -> Vec<f64> {
    let cut = 0.42 * fs_sim / OVERSAMPLE as f64 / fs_sim; // cycles per sample
    let mid = (TAPS - 1) as f64 / 2.0;
    let mut h: Vec<f64> = (0..TAPS)
        .map(|k| {
            let m = k as f64 - mid;
            let sinc = if m == 0.0 {
                2.0 * cut
            } else {
                (2.0 * PI * cut * m).sin() / (PI * m)
            };
            let w = 0.42 - 0.5 * (2.0 * PI * k as f64 / (TAPS - 1) as f64).cos()
                + 0.08 * (4.0 * PI * k as f64 / (TAPS - 1) as f64).cos();
            sinc * w
        })
        .collect();
    let sum: f64 = h.iter().sum();
    h.iter_mut().for_each(|v| *v /= sum);
    let half = TAPS / 2;
    (0..x.len() / OVERSAMPLE)
        .map(|j| {
            let c = j * OVERSAMPLE;
            h.iter()
                .enumerate()
                .filter_map(|(k, hk)| {
                    (c + k)
                        .checked_sub(half)
                        .and_then(|i| x.get(i))
                        .map(|v| hk * v)
                })
                .sum()
        })
        .collect()
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::draw::{draw_case, Drawn, Mode};

    fn spectrum_peak_near(x: &[f32], fs: f64, f: f64) -> f64 {
        // One DFT bin at f against the mean power of bins 5–50 Hz away.
        let bin = |g: f64| {
            let (mut re, mut im) = (0.0, 0.0);
            for (i, v) in x.iter().enumerate() {
                let a = 2.0 * PI * g * i as f64 / fs;
                re += f64::from(*v) * a.cos();
                im += f64::from(*v) * a.sin();
            }
            re * re + im * im
        };
        let floor: f64 = [-50.0, -30.0, -10.0, 10.0, 30.0, 50.0]
            .iter()
            .map(|df| bin(f + df))
            .sum::<f64>()
            / 6.0;
        10.0 * (bin(f) / floor).log10()
    }

    fn control(defect: Option<Defect>) -> Case {
        let mut c = draw_case(0, 1, 2.0);
        c.base.defect = defect;
        c.base.impact_g = 1.0;
        c.base.background_g = 0.05;
        c.base.noise_g = 0.01;
        c.injected.clear();
        c
    }

    /// The anti-alias filter passes the band to 0.38 fs within 0.1 dB and keeps what
    /// folds back from above 0.58 fs at least 60 dB down.
    #[test]
    fn the_anti_alias_filter_passes_the_band_and_stops_the_fold() {
        let fs = 12_000.0;
        let fs_sim = fs * OVERSAMPLE as f64;
        let gain = |f: f64| {
            let x: Vec<f64> = (0..48_000)
                .map(|i| (2.0 * PI * f * i as f64 / fs_sim).sin())
                .collect();
            let y = decimate(&x, fs_sim);
            rms(&y[200..y.len() - 200]) / std::f64::consts::FRAC_1_SQRT_2
        };
        for f in [100.0, 2_000.0, 0.38 * fs] {
            let db = 20.0 * gain(f).log10();
            assert!(db.abs() < 0.1, "{f} Hz: {db} dB");
        }
        for f in [0.58 * fs, 0.8 * fs, 1.3 * fs] {
            let db = 20.0 * gain(f).log10();
            assert!(db < -60.0, "{f} Hz folds back at {db} dB");
        }
    }

    /// An outer-race record's impacts come at BPFO × (1 + rate factor): its envelope
    /// (squared signal) has its strongest line in 20–500 Hz there.
    #[test]
    fn impacts_come_at_the_defect_rate() {
        let c = control(Some(Defect::OuterRace));
        let x = synthesize(&c, 2.0);
        let fs = c.base.fs_hz;
        let sq: Vec<f32> = x.iter().map(|v| v * v).collect();
        let rate = f64::from(c.base.bearing.orders().bpfo) * c.base.rpm / 60.0
            * (1.0 + c.base.rate_factor);
        let db = spectrum_peak_near(&sq, fs, rate);
        assert!(db > 15.0, "BPFO line {db} dB over its neighbours");
    }

    /// Mains at its fundamental, clipping at its rail, dropouts held: each injection is
    /// in the record.
    #[test]
    fn injections_are_in_the_record() {
        let mut c = control(None);
        c.base.background_g = 0.1;
        c.injected = vec![Drawn {
            injection: Injection::Mains {
                f0_hz: 50.0,
                lines: vec![(1, 0.02), (3, 0.01)],
                near_shaft_order: false,
            },
            u: 0.5,
        }];
        let x = synthesize(&c, 2.0);
        let db = spectrum_peak_near(&x, c.base.fs_hz, 50.0);
        assert!(db > 20.0, "50 Hz line {db} dB");
        c.injected = vec![
            Drawn {
                injection: Injection::Clipping { level: 0.5 },
                u: 0.5,
            },
            Drawn {
                injection: Injection::Dropouts {
                    runs: vec![(1000, 200)],
                },
                u: 0.5,
            },
        ];
        let x = synthesize(&c, 2.0);
        let peak = x.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let at_rail = x.iter().filter(|v| v.abs() == peak).count();
        assert!(at_rail > 20, "{at_rail} samples at the rail");
        assert!(x[1000..1200].iter().all(|v| *v == x[1000]));
    }

    /// On a measured record the injections are added and the record is otherwise
    /// untouched: nothing injected gives it back sample for sample; mains appear at
    /// their fundamental; a compound fault's second train comes at its own rate (its
    /// squared envelope's line) with the RMS `rel` times the record's.
    #[test]
    fn injections_add_to_a_measured_record_and_leave_it_otherwise() {
        use crate::bench::draw::draw_measured_case;
        let fs = 12_000.0;
        let mut rng = Xoshiro128pp::seed_from_u64(5);
        let x: Vec<f32> = (0..24_000).map(|_| 0.1 * rng.normal() as f32).collect();
        let mut c = draw_measured_case(0, 1, control(None).base, 2.0);
        c.base.fs_hz = fs;
        c.base.rpm = 1800.0;
        c.base.background_g = 0.1;
        c.injected.clear();
        assert_eq!(inject_measured(&c, &x), x);
        c.injected = vec![Drawn {
            injection: Injection::Mains {
                f0_hz: 60.0,
                lines: vec![(1, 0.02)],
                near_shaft_order: false,
            },
            u: 0.5,
        }];
        let y = inject_measured(&c, &x);
        assert!(spectrum_peak_near(&y, fs, 60.0) > 20.0);
        c.base.defect = Some(Defect::InnerRace);
        c.base.modes = vec![Mode {
            f_hz: 3_000.0,
            zeta: 0.04,
            gain: 1.0,
        }];
        let rate = 1800.0 / 60.0 * f64::from(c.base.bearing.orders().bpfo) * 0.99;
        c.injected = vec![Drawn {
            injection: Injection::Compound {
                defect: Defect::OuterRace,
                rel: 0.5,
                rate_hz: rate,
            },
            u: 0.5,
        }];
        let y = inject_measured(&c, &x);
        let added: Vec<f64> = y.iter().zip(&x).map(|(a, b)| f64::from(a - b)).collect();
        let r = rms(&added) / 0.1;
        assert!(
            (r - 0.5).abs() < 0.05,
            "second train's RMS {r} of the record's"
        );
        let env: Vec<f32> = added.iter().map(|v| (v * v) as f32).collect();
        let db = spectrum_peak_near(&env, fs, rate);
        assert!(db > 10.0, "second train's line {db} dB");
    }

    /// A measured case draws only what can be added to a measured record, one or two
    /// of them, a compound fault only on a record with a defect, and keeps the
    /// record's speed.
    #[test]
    fn measured_cases_draw_what_a_measured_record_can_take() {
        use crate::bench::draw::draw_measured_case;
        let mut healthy = control(None).base;
        healthy.rpm = 1797.0;
        let mut faulty = healthy.clone();
        faulty.defect = Some(Defect::Ball);
        let mut compound = 0;
        for id in 0..200 {
            for base in [&healthy, &faulty] {
                let c = draw_measured_case(id, 3, base.clone(), 6.0);
                assert!((1..=2).contains(&c.injected.len()));
                assert_eq!(c.base.rpm, 1797.0);
                for d in &c.injected {
                    let name = d.injection.name();
                    assert!(
                        !["modulation", "extra_mode", "speed_drift", "duffing"].contains(&name),
                        "{name}"
                    );
                    if name == "compound" {
                        assert!(base.defect.is_some());
                        assert_eq!(c.base.modes.len(), 1);
                        compound += 1;
                    }
                }
            }
        }
        assert!(compound > 20, "{compound} compound faults drawn");
    }

    /// The same case gives the same record; another seed another one.
    #[test]
    fn synthesis_is_reproducible() {
        let a = draw_case(3, 7, 1.0);
        assert_eq!(synthesize(&a, 1.0), synthesize(&a, 1.0));
        let b = draw_case(4, 7, 1.0);
        assert_ne!(synthesize(&a, 1.0)[..100], synthesize(&b, 1.0)[..100]);
    }
}
