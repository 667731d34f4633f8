//! The structure's modes read off the measured power spectrum before anything is
//! simulated: an operational modal identification, in the frequency domain, of the
//! path from the bearing's contact to the sensor.
//!
//! Every force the base model has — the defect's impacts (pulses of 20 µs, flat to
//! within 1.5 dB up to the compared band's top) and the background — is broadband, so
//! the record's smooth spectrum is the structure's transfer times a constant, plus the
//! sensor's own noise:
//!
//! ```text
//! P(f) = G · |Σ_k s_k T_k(f)|² + N,        s_0 = 1
//! T_k(f) = (a ω² + (1 − a)(ω_k² + 2iζ_kω_kω)) / (ω_k² − ω² + 2iζ_kω_kω)
//! ```
//!
//! with `a` the sensor's reading of the modes (1: the mass line, 0: the housing's; see
//! [`TwinModel::mass_line`](crate::twin::TwinModel::mass_line)), `s_k` each mode's share
//! of the force — exactly the twin's structural response (`TwinModel::
//! structural_response`), whose modes are driven by one force and add at the sensor.
//! Fitting that formula in dB costs microseconds where a simulated fit costs a
//! simulation per Jacobian column, so the modes are found here, greedily (the strongest
//! peak first, then where the formula falls shortest of the record), and the simulated
//! fit starts from all of them. Before, the base's further modes were tried one at a
//! time with a simulated fit each, from a default damping and share, and on the
//! benchmark's controls a mode at 0.8–0.9 kHz beside a stronger one was often never
//! kept (the first fit at 11–13× the record's scatter on those controls).

use crate::fit::Target;
use std::f64::consts::PI;

/// One structural mode: natural frequency, damping ratio, share of the force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Mode {
    /// Natural frequency, Hz.
    pub(super) f_hz: f64,
    /// Damping ratio.
    pub(super) zeta: f64,
    /// Share of the contact force it is driven by (the first mode's is 1).
    pub(super) share: f64,
}

impl Mode {
    /// The mode of `[ln f, ln ζ, ln s]`, inside the bounds of a structure's mode the
    /// twin can simulate: from [`MODE_LO_HZ`] to [`MODE_HI_REL`] of the sampling rate
    /// (a mode past the compared band's top shows as the rise into it; the RK4 step
    /// stays well inside its stability limit), damped from a quarter of
    /// [`MIN_BASE_MODE_ZETA`] (so a fit can go below it and be refused) to
    /// [`MAX_ZETA`].
    fn bounded(c: &[f64], fs_hz: f64) -> Self {
        Self {
            f_hz: c[0].exp().clamp(MODE_LO_HZ, MODE_HI_REL * fs_hz),
            zeta: c[1].exp().clamp(MIN_BASE_MODE_ZETA / 4.0, MAX_ZETA),
            share: c[2].exp(),
        }
    }
}

/// The identified structure.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Structure {
    /// The modes, the first one the base's.
    pub(super) modes: Vec<Mode>,
    /// Mean squared dB error of the formula over the compared bins.
    pub(super) cost: f64,
}

/// Lowest natural frequency a mode of the base may take, Hz (below the mode search's
/// 500 Hz so that a fit can move a mode's peak there).
const MODE_LO_HZ: f64 = 300.0;

/// Highest natural frequency of a mode of the base, as a share of the sampling rate:
/// the twin's own bound.
const MODE_HI_REL: f64 = crate::twin::MODE_MAX_REL_FS;

/// Most damping a mode of the base may take (a structure's modes: 1–10 %; beyond 30 %
/// a "mode" is a broad slope of the spectrum, which the noise and level take).
const MAX_ZETA: f64 = 0.1;

/// Least relative fall of the formula's mean squared dB error for which a further
/// mode is kept: the same 3 % the loop asks of an effect.
const MODE_GAIN: f64 = 0.03;

/// Places a further mode is tried at, per step, strongest shortfall first.
const TRIES_PER_STEP: usize = 3;

/// Damping a mode is started at: the middle of a machine's 1–10 % in log terms.
const ZETA_START: f64 = 0.03;

/// The base's structure for the sensor reading `a` (`mass_line`), with at most
/// `max_modes` modes.
pub(super) fn identify(
    target: &Target,
    mass_line: f64,
    line_spacing_hz: f64,
    max_modes: usize,
) -> Structure {
    let problem = Problem::new(target, mass_line, line_spacing_hz);
    let mut peaks = psd_peaks(&problem.target);
    if peaks.is_empty() {
        let (lo, hi) = mode_search_bins(target);
        peaks.push(f64::from(target.cfg.psd_freq((lo + hi) / 2)));
    }
    // Two ways in, the better kept: from the strongest peak alone, modes added where
    // the formula falls short; and from every peak at once, modes that do not pay
    // dropped (two modes close together are fitted as one broad mode by the first
    // way, and the second mode is then never short enough to be added).
    let single = peaks
        .iter()
        .map(|&f_hz| problem.fit(&problem.start(&[(f_hz, 0.0)])))
        .min_by(|a, b| a.cost.total_cmp(&b.cost))
        .expect("one start at least");
    let all = problem.pruned(problem.fit(&problem.start(&problem.spaced(&peaks, max_modes))));
    let mut best = single;
    for start in [all] {
        if start.cost < best.cost {
            best = start;
        }
    }
    let mut current = best;
    while current.modes(problem.fs_hz).len() < max_modes {
        let Some(next) = problem.add_one(&current) else {
            break;
        };
        current = next;
    }
    Structure {
        modes: current.modes(problem.fs_hz),
        cost: current.cost,
    }
}

/// What the formula is fitted to.
struct Problem {
    /// Frequencies of the compared bins, Hz.
    f_hz: Vec<f64>,
    /// The measured PSD there, dB.
    meas_db: Vec<f64>,
    /// The sensor's reading of the modes.
    mass_line: f64,
    /// Sampling rate, Hz.
    fs_hz: f64,
    /// Bins each side the record and the formula are averaged over (in power): the
    /// base's lines (a defect's comb, the shaft's orders) spread into the band they
    /// repeat in, which the smooth formula has no term for.
    half_width: usize,
    /// The whole measured PSD in dB, f32 (for the shortfall search).
    target: Target,
}

/// A fitted formula: `θ = [ln G, ln N, (ln f, ln ζ, ln s) per mode]` (the first
/// mode's `ln s` held at 0).
#[derive(Debug, Clone)]
struct Fitted {
    theta: Vec<f64>,
    cost: f64,
}

impl Fitted {
    fn modes(&self, fs_hz: f64) -> Vec<Mode> {
        self.theta[2..]
            .chunks(3)
            .map(|c| Mode::bounded(c, fs_hz))
            .collect()
    }
}

impl Problem {
    fn new(target: &Target, mass_line: f64, line_spacing_hz: f64) -> Self {
        let bins = target.cfg.psd_bins();
        let df = f64::from(target.cfg.fs_hz) / target.cfg.psd_n as f64;
        let half_width = ((0.5 * line_spacing_hz / df).ceil() as usize).max(2);
        let meas: Vec<f64> = bins
            .clone()
            .map(|k| f64::from(target.meas.psd[k]))
            .collect();
        let meas_db: Vec<f64> = local_mean(&meas, half_width)
            .iter()
            .map(|p| 10.0 * p.max(1e-300).log10())
            .collect();
        // The shortfall search reads the smoothed record too.
        let mut smoothed = target.clone();
        let offset = target.psd_db[*bins.start()] as f64 - 10.0 * meas[0].max(1e-300).log10();
        for (k, v) in bins.clone().zip(&meas_db) {
            smoothed.psd_db[k] = (v + offset) as f32;
        }
        Self {
            f_hz: bins.map(|k| f64::from(target.cfg.psd_freq(k))).collect(),
            meas_db,
            mass_line,
            fs_hz: f64::from(target.cfg.fs_hz),
            half_width,
            target: smoothed,
        }
    }

    /// The formula's power (smoothed as the record is) at every compared bin.
    fn power(&self, theta: &[f64]) -> Vec<f64> {
        let (g, n) = (theta[0].exp(), theta[1].exp());
        let p: Vec<f64> = self.transfer(theta).iter().map(|h| g * h + n).collect();
        local_mean(&p, self.half_width)
    }

    /// `|Σ s_k T_k(f)|²` at every compared bin.
    fn transfer(&self, theta: &[f64]) -> Vec<f64> {
        transfer(&self.f_hz, theta, self.mass_line, self.fs_hz)
    }

    /// The formula's dB minus the measured, per compared bin.
    fn residual(&self, theta: &[f64]) -> Vec<f64> {
        self.power(theta)
            .iter()
            .zip(&self.meas_db)
            .map(|(p, m)| 10.0 * p.max(1e-300).log10() - m)
            .collect()
    }

    /// `θ` for modes at `peaks` (`(Hz, dB relative to the first)`), each with the
    /// start's damping and a share in proportion to its peak, with the level set to
    /// match the record's strongest bin and the noise a tenth of its weakest.
    fn start(&self, peaks: &[(f64, f64)]) -> Vec<f64> {
        let mut theta = vec![0.0, 0.0];
        for &(f_hz, rel_db) in peaks {
            theta.extend([
                f_hz.ln(),
                ZETA_START.ln(),
                rel_db * std::f64::consts::LN_10 / 20.0,
            ]);
        }
        theta[4] = 0.0;
        let h = self.transfer(&theta);
        let to_lin = |db: f64| 10f64.powf(db / 10.0);
        let (k_max, peak) = self
            .meas_db
            .iter()
            .enumerate()
            .fold((0, f64::MIN), |b, (k, &v)| if v > b.1 { (k, v) } else { b });
        let floor = self.meas_db.iter().copied().fold(f64::MAX, f64::min);
        theta[0] = (to_lin(peak) / h[k_max].max(1e-300)).ln();
        theta[1] = (0.1 * to_lin(floor)).ln();
        theta
    }

    /// Of `peaks` (Hz, strongest first), those apart from every stronger one by
    /// [`MODE_SPACING`], at most `max`, with their level relative to the first, dB.
    fn spaced(&self, peaks: &[f64], max: usize) -> Vec<(f64, f64)> {
        let level = |f: f64| {
            let k = self
                .f_hz
                .iter()
                .position(|&x| x >= f)
                .unwrap_or(self.f_hz.len() - 1);
            self.meas_db[k]
        };
        let mut kept: Vec<f64> = Vec::new();
        for &f in peaks {
            if kept.len() < max && kept.iter().all(|k| (f / k - 1.0).abs() >= MODE_SPACING) {
                kept.push(f);
            }
        }
        let first = kept.first().map_or(0.0, |&f| level(f));
        kept.iter().map(|&f| (f, level(f) - first)).collect()
    }

    /// `fitted` without the modes that do not pay: while one (after the first) is not
    /// a structure's mode, or its removal raises the error by less than
    /// [`MODE_GAIN`], the one whose removal costs least is dropped and the rest
    /// refitted.
    fn pruned(&self, mut fitted: Fitted) -> Fitted {
        loop {
            let n = fitted.modes(self.fs_hz).len();
            if n <= 1 {
                return fitted;
            }
            let without = (1..n)
                .map(|k| {
                    let mut theta = fitted.theta.clone();
                    theta.drain(2 + 3 * k..5 + 3 * k);
                    self.fit(&theta)
                })
                .min_by(|a, b| a.cost.total_cmp(&b.cost))
                .expect("a mode to drop");
            if self.structural(&fitted) && fitted.cost < without.cost * (1.0 - MODE_GAIN) {
                return fitted;
            }
            fitted = without;
        }
    }

    /// Is every mode of `fitted` a structure's: damped at least
    /// [`MIN_BASE_MODE_ZETA`], and apart from every other by [`MODE_SPACING`]?
    fn structural(&self, fitted: &Fitted) -> bool {
        let modes = fitted.modes(self.fs_hz);
        modes.iter().all(|m| m.zeta >= MIN_BASE_MODE_ZETA)
            && modes.iter().enumerate().all(|(i, a)| {
                modes[..i]
                    .iter()
                    .all(|b| (a.f_hz / b.f_hz - 1.0).abs() >= MODE_SPACING)
            })
    }

    /// Levenberg–Marquardt on the dB residual; the first mode's share is held.
    fn fit(&self, start: &[f64]) -> Fitted {
        let free: Vec<usize> = (0..start.len()).filter(|&i| i != 4).collect();
        let mut theta = start.to_vec();
        let mut r = self.residual(&theta);
        let mut cost: f64 = r.iter().map(|v| v * v).sum();
        let mut lambda = 1e-2;
        for _ in 0..FIT_ITERATIONS {
            let jac: Vec<Vec<f64>> = free
                .iter()
                .map(|&i| {
                    let mut t = theta.clone();
                    t[i] += JACOBIAN_STEP;
                    self.residual(&t)
                        .iter()
                        .zip(&r)
                        .map(|(a, b)| (a - b) / JACOBIAN_STEP)
                        .collect()
                })
                .collect();
            let (jtj, neg_g) = crate::fit::normal_equations(&jac, &r);
            let mut improved = false;
            for _ in 0..8 {
                let Some(delta) = crate::fit::damped_step(&jtj, &neg_g, lambda, 0.5) else {
                    lambda *= 4.0;
                    continue;
                };
                let mut trial = theta.clone();
                for (&i, d) in free.iter().zip(&delta) {
                    trial[i] += d;
                }
                let rt = self.residual(&trial);
                let ct: f64 = rt.iter().map(|v| v * v).sum();
                if ct.is_finite() && ct < cost {
                    improved = (cost - ct) / cost > 1e-6;
                    theta = trial;
                    r = rt;
                    cost = ct;
                    lambda = (lambda / 3.0).max(1e-9);
                    break;
                }
                lambda *= 4.0;
            }
            if !improved {
                break;
            }
        }
        Fitted {
            cost: cost / r.len().max(1) as f64,
            theta,
        }
    }

    /// `current` with one more mode, where the formula falls shortest of the record,
    /// fitted and kept if it lowers the error by [`MODE_GAIN`] and is a structure's
    /// mode (damped at least [`MIN_BASE_MODE_ZETA`], apart from the others by
    /// [`MODE_SPACING`]); `None` when no place gives one.
    fn add_one(&self, current: &Fitted) -> Option<Fitted> {
        let model_db = self.full_db(&current.theta);
        let modes = current.modes(self.fs_hz);
        let apart = |f: f64, modes: &[Mode]| {
            modes
                .iter()
                .all(|m| (f / m.f_hz - 1.0).abs() >= MODE_SPACING)
        };
        let mut best: Option<Fitted> = None;
        let places = shortfall_of(&self.target, &model_db)
            .into_iter()
            .filter(|&(f, _)| apart(f, &modes))
            .take(TRIES_PER_STEP);
        for (f_hz, excess_db) in places {
            // The share that lifts the formula by the shortfall at its peak, where the
            // new mode's transfer is about 1/(2ζ).
            let lift = (10f64.powf(f64::from(excess_db) / 10.0) - 1.0)
                .max(0.1)
                .sqrt();
            let here = transfer(&[f_hz], &current.theta, self.mass_line, self.fs_hz)[0].sqrt();
            let share = lift * here * 2.0 * ZETA_START;
            let mut theta = current.theta.clone();
            theta.extend([f_hz.ln(), ZETA_START.ln(), share.max(1e-6).ln()]);
            let fitted = self.fit(&theta);
            if self.structural(&fitted)
                && fitted.cost < current.cost * (1.0 - MODE_GAIN)
                && best.as_ref().is_none_or(|b| fitted.cost < b.cost)
            {
                best = Some(fitted);
            }
        }
        best
    }

    /// The formula in dB at every PSD bin (f32, the target's layout; bins outside
    /// the compared band copy the measured).
    fn full_db(&self, theta: &[f64]) -> Vec<f32> {
        let mut out = self.target.psd_db.clone();
        let bins = self.target.cfg.psd_bins();
        let offset = f64::from(out[*bins.start()]) - self.meas_db[0];
        for ((k, p), _) in bins.zip(self.power(theta)).zip(&self.meas_db) {
            out[k] = (10.0 * p.max(1e-300).log10() + offset) as f32;
        }
        out
    }
}

/// `|Σ s_k T_k(f)|²` at each of `f_hz` for `θ` (its modes from index 2) and the
/// sensor's reading `a`.
fn transfer(f_hz: &[f64], theta: &[f64], a: f64, fs_hz: f64) -> Vec<f64> {
    let modes: Vec<(f64, f64, f64)> = theta[2..]
        .chunks(3)
        .map(|c| {
            let m = Mode::bounded(c, fs_hz);
            (2.0 * PI * m.f_hz, m.zeta, m.share)
        })
        .collect();
    f_hz.iter()
        .map(|&f| {
            let w = 2.0 * PI * f;
            let (mut re, mut im) = (0.0, 0.0);
            for &(wk, z, s) in &modes {
                let (dr, di) = (wk * wk - w * w, 2.0 * z * wk * w);
                let (nr, ni) = (a * w * w + (1.0 - a) * wk * wk, (1.0 - a) * di);
                let d2 = dr * dr + di * di;
                re += s * (nr * dr + ni * di) / d2;
                im += s * (ni * dr - nr * di) / d2;
            }
            re * re + im * im
        })
        .collect()
}

/// The mean of `p` over ±`half` bins (fewer at its ends).
fn local_mean(p: &[f64], half: usize) -> Vec<f64> {
    let mut prefix = vec![0.0; p.len() + 1];
    for (i, v) in p.iter().enumerate() {
        prefix[i + 1] = prefix[i] + v;
    }
    (0..p.len())
        .map(|k| {
            let (a, b) = (k.saturating_sub(half), (k + half + 1).min(p.len()));
            (prefix[b] - prefix[a]) / (b - a) as f64
        })
        .collect()
}

/// Levenberg–Marquardt iterations of one formula fit (each costs a few hundred
/// microseconds).
const FIT_ITERATIONS: usize = 60;

/// Forward-difference step in the unconstrained coordinates.
const JACOBIAN_STEP: f64 = 1e-5;

/// Closest relative spacing of two modes of the base: nearer, one peak is two modes'
/// skirts overlapping, which one mode with its damping fits. 10 %: a mode damped at
/// most [`MAX_ZETA`] (10 %) is ±10 % wide at half power, so two modes further apart show
/// two peaks or a shoulder. (15 % while the modes were tried one at a time: two modes
/// 13 % apart were then fitted as one broad mode, and the benchmark's control with
/// them first fit at 5.5× the record's scatter.)
pub(super) const MODE_SPACING: f64 = 0.10;

/// How far the measured PSD (smoothed over ±3 bins) must stand over the model's for a
/// further mode to be tried there, dB: a place the model already reaches is its own
/// mode's, or a comb's, and a mode tried there only costs a fit.
const MODE_EXCESS_DB: f32 = 3.0;

/// Where the measured PSD stands over a model's PSD (`model`, in dB) by at least
/// [`MODE_EXCESS_DB`], both smoothed over ±3 bins, within the mode search's bins: the
/// local maxima of that shortfall, largest first, as `(Hz, dB)`. A mode the base
/// lacks shows here as a hump of the shortfall whether or not the measured PSD has a
/// peak of its own there (a weak mode on another's skirt, a mode past the band's top
/// seen as a rise into it); the measured PSD's own peaks, searched first, missed
/// both, and the loop then named them unexplained bands.
pub(super) fn shortfall_of(target: &Target, model: &[f32]) -> Vec<(f64, f32)> {
    let cfg = &target.cfg;
    let n = model.len().min(target.psd_db.len());
    let excess: Vec<f32> = smooth3(&target.psd_db[..n])
        .iter()
        .zip(smooth3(&model[..n]))
        .map(|(m, s)| m - s)
        .collect();
    let (lo, hi) = mode_search_bins(target);
    let hi = hi.min(n.saturating_sub(2));
    // A mode damped at least `MIN_BASE_MODE_ZETA` is at least 2ζf wide at half power:
    // a narrower hump is the gap between a comb's teeth or a line's skirt.
    let df = f64::from(cfg.fs_hz) / cfg.psd_n as f64;
    let wide = |k: usize| {
        let floor = excess[k] - 3.0;
        let a = (lo..k).rev().find(|&j| excess[j] < floor).unwrap_or(lo);
        let b = (k..=hi).find(|&j| excess[j] < floor).unwrap_or(hi);
        (b - a) as f64 * df >= 2.0 * MIN_BASE_MODE_ZETA * f64::from(cfg.psd_freq(k))
    };
    let mut peaks: Vec<(f64, f32)> = (lo.max(1)..=hi)
        .filter(|&k| excess[k] >= MODE_EXCESS_DB)
        .filter(|&k| excess[k] > excess[k - 1] && (k == hi || excess[k] >= excess[k + 1]))
        .filter(|&k| wide(k))
        .map(|k| (f64::from(cfg.psd_freq(k)), excess[k]))
        .collect();
    peaks.sort_by(|a, b| b.1.total_cmp(&a.1));
    peaks
}

/// Lowest frequency a structural mode of the base is looked for at, Hz. Housings and
/// frames ring from a few hundred hertz (CWRU's drive end shows a band at 0.6 kHz);
/// from 1 kHz, as first chosen, the benchmark's controls with a mode at 0.8–0.9 kHz
/// (`--seed 1`, the development seed) had it claimed as an unexplained band or an
/// extra mode on 6 of the 30 controls with a false claim. Below this the PSD's peaks are
/// the shaft's and the defect's lines more often than modes.
const MODE_SEARCH_LO_HZ: f32 = 500.0;

/// `v` averaged over ±3 bins (fewer at its ends).
fn smooth3(v: &[f32]) -> Vec<f32> {
    (0..v.len())
        .map(|k| {
            let a = k.saturating_sub(3);
            let b = (k + 3).min(v.len() - 1);
            v[a..=b].iter().sum::<f32>() / (b - a + 1) as f32
        })
        .collect()
}

/// The PSD bins a structure's mode is looked for in: from [`MODE_SEARCH_LO_HZ`] to two
/// bins below the compared band's top.
pub(super) fn mode_search_bins(target: &Target) -> (usize, usize) {
    let cfg = &target.cfg;
    let lo = (MODE_SEARCH_LO_HZ / (cfg.fs_hz / cfg.psd_n as f32)) as usize;
    (lo, *cfg.psd_bins().end() - 2)
}

/// Where the base's mode starts: the measured PSD's local maxima above
/// [`MODE_SEARCH_LO_HZ`] (smoothed over ±3 bins) and the searched band's top where the
/// PSD still rises into it, strongest first, at most four, Hz.
pub(super) fn psd_peaks(target: &Target) -> Vec<f64> {
    let cfg = &target.cfg;
    let (lo, hi) = mode_search_bins(target);
    let smooth = smooth3(&target.psd_db);
    let mut peaks: Vec<usize> = (lo.max(1)..hi)
        .filter(|&k| smooth[k] > smooth[k - 1] && smooth[k] >= smooth[k + 1])
        .collect();
    // A spectrum still rising at the top of the searched band has a mode at or past
    // it (its peak cut off by the band): the top is a peak too.
    if hi > lo.max(1) + 1 && smooth[hi] > smooth[hi - 1] {
        peaks.push(hi);
    }
    peaks.sort_by(|&a, &b| smooth[b].total_cmp(&smooth[a]));
    peaks.truncate(4);
    peaks
        .into_iter()
        .map(|k| f64::from(cfg.psd_freq(k)))
        .collect()
}

/// Least damping ratio a mode of the base may fit to: a machine's structural modes
/// have 1–10 % (Randall & Antoni 2011; CWRU's fits 2–8 %); a "mode" that fits
/// narrower is a tone or a comb's tooth (a line one window lobe wide), which the loop's
/// tracers read as what it is.
pub const MIN_BASE_MODE_ZETA: f64 = 0.01;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signature::{to_db, Signature, SignatureConfig};

    /// The PSD of the formula itself for `modes` (the housing's reading) over a
    /// white floor `noise`, as a target.
    fn target_of(modes: &[Mode], noise: f64) -> Target {
        let cfg = SignatureConfig::fit(12_000.0);
        let f: Vec<f64> = (0..=cfg.psd_n / 2)
            .map(|k| f64::from(cfg.psd_freq(k)))
            .collect();
        let mut theta = vec![0.0, 0.0];
        for m in modes {
            theta.extend([m.f_hz.ln(), m.zeta.ln(), m.share.ln()]);
        }
        let psd: Vec<f32> = transfer(&f, &theta, 0.0, 12_000.0)
            .iter()
            .map(|h| (1e-6 * h + noise) as f32)
            .collect();
        let env = vec![1.0f32; cfg.env_n / 2 + 1];
        let meas = Signature {
            psd: psd.clone(),
            env: env.clone(),
            rms: 1.0,
            kurtosis: 3.0,
        };
        Target {
            psd_db: to_db(&psd, &psd),
            env_db: to_db(&env, &env),
            meas,
            cfg,
        }
    }

    /// Three modes, two of them 15 % apart (the pair the one-at-a-time search fitted
    /// as one broad mode), are found with their frequencies, dampings and shares.
    #[test]
    fn three_modes_are_identified_from_the_spectrum() {
        let truth = [
            Mode {
                f_hz: 2900.0,
                zeta: 0.03,
                share: 1.0,
            },
            Mode {
                f_hz: 920.0,
                zeta: 0.055,
                share: 1.5,
            },
            Mode {
                f_hz: 3450.0,
                zeta: 0.045,
                share: 1.1,
            },
        ];
        let found = identify(&target_of(&truth, 1e-9), 0.0, 30.0, 3);
        assert_eq!(found.modes.len(), 3, "{found:?}");
        for t in &truth {
            let m = found
                .modes
                .iter()
                .min_by(|a, b| (a.f_hz - t.f_hz).abs().total_cmp(&(b.f_hz - t.f_hz).abs()))
                .expect("a mode");
            assert!((m.f_hz / t.f_hz - 1.0).abs() < 0.02, "{t:?}: {m:?}");
            assert!((m.zeta / t.zeta - 1.0).abs() < 0.25, "{t:?}: {m:?}");
        }
        // Shares are relative to the first mode found.
        let share = |f: f64| {
            found
                .modes
                .iter()
                .find(|m| (m.f_hz / f - 1.0).abs() < 0.02)
                .map(|m| m.share)
                .expect("found")
        };
        assert!((share(920.0) / share(2900.0) / 1.5 - 1.0).abs() < 0.3);
        assert!(found.cost < 0.1, "{found:?}");
    }

    /// One mode over the floor is one mode: no second one is made of the floor.
    #[test]
    fn one_mode_stays_one_mode() {
        let truth = [Mode {
            f_hz: 3100.0,
            zeta: 0.04,
            share: 1.0,
        }];
        let found = identify(&target_of(&truth, 1e-7), 0.0, 30.0, 3);
        assert_eq!(found.modes.len(), 1, "{found:?}");
        assert!((found.modes[0].f_hz / 3100.0 - 1.0).abs() < 0.02);
    }

    /// Bounds: a mode cannot leave what the twin can simulate.
    #[test]
    fn modes_stay_within_their_bounds() {
        let m = Mode::bounded(&[1e9f64.ln(), 5.0f64.ln(), 0.0], 12_000.0);
        assert_eq!(m.f_hz, MODE_HI_REL * 12_000.0);
        assert_eq!(m.zeta, MAX_ZETA);
        let m = Mode::bounded(&[1.0f64.ln(), 1e-9f64.ln(), 0.0], 12_000.0);
        assert_eq!(m.f_hz, MODE_LO_HZ);
        assert_eq!(m.zeta, MIN_BASE_MODE_ZETA / 4.0);
    }
}
