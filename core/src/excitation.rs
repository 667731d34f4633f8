//! Excitation forces (paper eqs. 18–20), rendered into caller-owned force buffers on
//! a uniform time grid (the simulator uses the half-step grid `t_0 + j·h/2`).
//!
//! ```text
//! F_impact(t) = Σ_n A_n · exp(−(t − t_n)² / (2σ²))                     (18)
//!   t_n = t_1 + n·T_impact + W_n + ε_n,   ε_n ~ N(0, (jitter·T_impact)²)
//!   W_{n+1} = W_n + T_impact·(max(½, 1 + walk·z_n) − 1),   z_n ~ N(0, 1)
//!   A_n = A_impact · (1 − δ + δ·(1 + cos 2π f_mod t_n)/2)
//! F_sin(t)    = A_sin · sin(2π f_rot t + φ)                            (19)
//! F_rand(t)   = σ_w · w(t) + Σ_m B_m · exp(−(t − τ_m)² / (2σ_p²))
//!   w: white Gaussian, τ_m: Poisson arrivals at rate λ, B_m = |N(B, (B/2)²)|
//! F_total(t)  = w_impact·F_impact + w_sin·F_sin + w_rand·F_rand          (20)
//! F_θ(t)      = s_θ · F_total(t)
//! ```
//!
//! Eq. 18 as printed has a constant amplitude and a strictly periodic train. The
//! amplitude modulation `δ` (load zone: a rotating inner-race defect passes through
//! the loaded zone once per revolution) and the timing's irregularity (rolling-element
//! slip, 1–2 % in real bearings) are the two standard refinements; all default to zero
//! so the plain eq. 18 is the default. The angular DOF receives the same force times a
//! moment-arm share `s_θ` (the paper does not say how the force splits between DOFs).
//!
//! **Two kinds of timing irregularity.** `jitter` times each impact early or late
//! about a fixed grid, as a rolling element's play in its cage pocket does while the
//! cage keeps its pace: the comb's teeth lose power to a pedestal, `e^{−(2πk·jitter)²}`
//! at harmonic k, and stay sharp. `walk` lengthens or shortens each interval, so the
//! impacts wander from the grid as a random walk, as the cage's own speed does with
//! nothing to pull it back (Antoni & Randall's renewal process): tooth k broadens into
//! a Lorentzian `2π·k²·walk²·rate` Hz wide. Measured records show either: CWRU's
//! outer-race teeth stand at the window's width up to 3.8 kHz while the comb falls into
//! its pedestal there; the randomized benchmark's records widen as k².
//!
//! Impacts and pulses are truncated at ±8σ (the Gaussian is < 1.3e−14 there).

use crate::error::{expect_len, Error, Result};
use crate::math;
use crate::rng::Xoshiro128pp;

const PULSE_HALF_WIDTH_SIGMAS: f64 = 8.0;

/// Shortest interval between walking impacts, a fraction of the period: a draw of
/// the walk cannot bring two impacts together or reverse their order.
const MIN_INTERVAL_REL: f64 = 0.5;

/// Uniform time grid `t_j = t0 + j·dt`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeGrid {
    /// Time of the first sample, s.
    pub t0: f64,
    /// Sample spacing, s.
    pub dt: f64,
}

impl TimeGrid {
    fn check(&self) -> Result<()> {
        if !(self.t0.is_finite() && self.dt.is_finite()) {
            return Err(Error::NonFinite);
        }
        if self.dt <= 0.0 {
            return Err(Error::InvalidParameter("grid spacing must be > 0"));
        }
        Ok(())
    }
}

/// Add `amp · exp(−(t − centre)²/(2σ²))` into `out` on `grid`, only within ±8σ.
fn add_gaussian_pulse(out: &mut [f64], grid: TimeGrid, centre: f64, sigma: f64, amp: f64) {
    let half = PULSE_HALF_WIDTH_SIGMAS * sigma;
    let lo = math::floor((centre - half - grid.t0) / grid.dt) + 1.0;
    let hi = math::floor((centre + half - grid.t0) / grid.dt);
    if hi < 0.0 || lo >= out.len() as f64 {
        return;
    }
    let lo = if lo < 0.0 { 0 } else { lo as usize };
    let hi = (hi as usize).min(out.len() - 1);
    let inv = -0.5 / (sigma * sigma);
    for (j, o) in out.iter_mut().enumerate().take(hi + 1).skip(lo) {
        let d = grid.t0 + j as f64 * grid.dt - centre;
        *o += amp * math::exp(d * d * inv);
    }
}

/// Periodic Gaussian impact train at a defect rate (eq. 18).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpactTrain {
    /// Peak force `A_impact`, N.
    pub amplitude: f64,
    /// Impact rate `1/T_impact`, Hz (e.g. BPFI).
    pub rate_hz: f64,
    /// Pulse width σ, s.
    pub sigma_s: f64,
    /// Time of the first impact `t_1`, s.
    pub first_impact_s: f64,
    /// Load-zone modulation depth δ in [0, 1] (0: constant amplitude).
    pub modulation_depth: f64,
    /// Modulation rate `f_mod`, Hz (shaft rate for an inner-race defect).
    pub modulation_hz: f64,
    /// Timing jitter about the grid, a fraction of the period (0: strictly periodic):
    /// each impact early or late by its own `jitter·T·z`, z standard normal, as a
    /// rolling element's play in its cage pocket times it while the cage keeps the
    /// grid.
    pub jitter: f64,
    /// Slip, a fraction of the period: each interval between impacts is also
    /// `T·walk·z` longer or shorter, so the impacts wander from the grid as a random
    /// walk (Antoni & Randall's renewal process: nothing pulls the train back), and the
    /// k-th harmonic broadens into a Lorentzian `2π·k²·walk²·rate` Hz wide (full
    /// width). 0: the train keeps its grid.
    pub walk: f64,
    /// Spread of the impact strengths: each impact's amplitude is multiplied by
    /// `max(0, 1 + spread · z)`, z standard normal (0: every impact alike). Real
    /// bearings' impacts vary by 5–30 % (Randall & Antoni 2011, §2): the rolling
    /// element's entry into the defect is never twice the same.
    pub amplitude_spread: f64,
    /// Linear speed drift: the rate (and the modulation rate) scale by
    /// `1 + rate_drift_per_s · t` (0: constant speed).
    pub rate_drift_per_s: f64,
}

impl ImpactTrain {
    /// A strictly periodic, constant-amplitude train (the plain eq. 18).
    pub const fn periodic(amplitude: f64, rate_hz: f64, sigma_s: f64) -> Self {
        Self {
            amplitude,
            rate_hz,
            sigma_s,
            first_impact_s: 0.0,
            modulation_depth: 0.0,
            modulation_hz: 0.0,
            jitter: 0.0,
            walk: 0.0,
            amplitude_spread: 0.0,
            rate_drift_per_s: 0.0,
        }
    }

    fn validate(&self) -> Result<()> {
        let v = [
            self.amplitude,
            self.rate_hz,
            self.sigma_s,
            self.first_impact_s,
            self.modulation_depth,
            self.modulation_hz,
            self.jitter,
            self.walk,
            self.amplitude_spread,
            self.rate_drift_per_s,
        ];
        if v.iter().any(|x| !x.is_finite()) {
            return Err(Error::NonFinite);
        }
        if self.rate_hz <= 0.0 || self.sigma_s <= 0.0 {
            return Err(Error::InvalidParameter("impact rate and width must be > 0"));
        }
        if !(0.0..=1.0).contains(&self.modulation_depth)
            || self.jitter < 0.0
            || self.walk < 0.0
            || self.amplitude_spread < 0.0
        {
            return Err(Error::InvalidParameter(
                "modulation depth in [0,1], jitter and walk >= 0, amplitude spread >= 0",
            ));
        }
        Ok(())
    }

    /// Add `weight · F_impact` on `grid` into `out`. Jitter and spread draws come from
    /// `rng`, in time order, so a whole buffer must be rendered in one call.
    pub fn add_to(
        &self,
        grid: TimeGrid,
        weight: f64,
        out: &mut [f64],
        rng: &mut Xoshiro128pp,
    ) -> Result<()> {
        self.validate()?;
        grid.check()?;
        if out.is_empty() || weight == 0.0 || self.amplitude == 0.0 {
            return Ok(());
        }
        let period = 1.0 / self.rate_hz;
        let margin = PULSE_HALF_WIDTH_SIGMAS * self.sigma_s + 6.0 * self.jitter * period;
        let t_end = grid.t0 + out.len() as f64 * grid.dt;
        let d = self.rate_drift_per_s;
        // Warped time τ(t) = t + ½·d·t²: impacts sit at τ(t_n) = t_1 + n·T, so the rate
        // is rate·(1 + d·t). τ is monotonic where 1 + d·t > 0, which validate() and the
        // record lengths used here guarantee.
        let warp = |t: f64| t + 0.5 * d * t * t;
        let unwarp = |tau: f64| {
            if d == 0.0 {
                tau
            } else {
                let disc = 1.0 + 2.0 * d * tau;
                if disc <= 0.0 {
                    -1.0 / d
                } else {
                    (math::sqrt(disc) - 1.0) / d
                }
            }
        };
        // With a walk every impact from the first is drawn (where an impact lands
        // depends on every interval before it), its intervals' deviations summed in
        // `wander`; without one the train starts at the grid and draws as before.
        let mut n = 0.0;
        if self.walk == 0.0 {
            let tau_lo = warp((grid.t0 - margin).max(0.0).min(grid.t0 - margin));
            n = (math::floor((tau_lo - self.first_impact_s) / period) + 1.0).max(0.0);
        }
        let mut wander = 0.0;
        loop {
            let nominal = unwarp(self.first_impact_s + n * period + wander);
            if nominal > t_end + margin || !nominal.is_finite() {
                break;
            }
            if self.walk > 0.0 {
                wander += period * ((1.0 + self.walk * rng.normal()).max(MIN_INTERVAL_REL) - 1.0);
            }
            let t_n = if self.jitter > 0.0 {
                nominal + self.jitter * period * rng.normal()
            } else {
                nominal
            };
            let depth = self.modulation_depth;
            let mut am = 1.0 - depth
                + depth * 0.5 * (1.0 + math::cos(2.0 * math::PI * self.modulation_hz * warp(t_n)));
            // Drawn after the impact's jitter, and only with a spread: a train without
            // one draws exactly what it drew before.
            if self.amplitude_spread > 0.0 {
                am *= (1.0 + self.amplitude_spread * rng.normal()).max(0.0);
            }
            add_gaussian_pulse(out, grid, t_n, self.sigma_s, weight * self.amplitude * am);
            n += 1.0;
        }
        Ok(())
    }
}

/// Shaft-rate sinusoid from unbalance or eccentricity (eq. 19).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShaftSinusoid {
    /// `A_sin`, N.
    pub amplitude: f64,
    /// `f_rot`, Hz.
    pub shaft_hz: f64,
    /// φ, rad.
    pub phase_rad: f64,
    /// Linear speed drift, as in [`ImpactTrain::rate_drift_per_s`] (0: constant speed).
    pub drift_per_s: f64,
}

impl ShaftSinusoid {
    /// Add `weight · F_sin` on `grid` into `out`.
    pub fn add_to(&self, grid: TimeGrid, weight: f64, out: &mut [f64]) -> Result<()> {
        grid.check()?;
        if !(self.amplitude.is_finite() && self.shaft_hz.is_finite() && self.phase_rad.is_finite())
        {
            return Err(Error::NonFinite);
        }
        // sin(ω t_j + φ) by a phasor recurrence, re-anchored with libm every 256
        // samples so rounding cannot accumulate (error < 1e-13 relative).
        let w = 2.0 * math::PI * self.shaft_hz;
        let (c1, s1) = (math::cos(w * grid.dt), math::sin(w * grid.dt));
        let (mut c, mut s) = (0.0f64, 0.0f64);
        let amp = weight * self.amplitude;
        for (j, o) in out.iter_mut().enumerate() {
            if j % 256 == 0 {
                let phase = w * (grid.t0 + j as f64 * grid.dt) + self.phase_rad;
                c = math::cos(phase);
                s = math::sin(phase);
            }
            *o += amp * s;
            let next = c * c1 - s * s1;
            s = s * c1 + c * s1;
            c = next;
        }
        Ok(())
    }
}

/// Random excitation: white Gaussian background and Poisson pulse trains (§5.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RandomExcitation {
    /// Standard deviation of the white background force per grid sample, N.
    pub noise_std: f64,
    /// Poisson pulse rate λ, Hz (0: no pulses).
    pub pulse_rate_hz: f64,
    /// Mean pulse amplitude B, N.
    pub pulse_amplitude: f64,
    /// Pulse width σ_p, s.
    pub pulse_sigma_s: f64,
}

impl RandomExcitation {
    /// Add `weight · F_rand` on `grid` into `out`, drawing from `rng`.
    pub fn add_to(
        &self,
        grid: TimeGrid,
        weight: f64,
        out: &mut [f64],
        rng: &mut Xoshiro128pp,
    ) -> Result<()> {
        grid.check()?;
        let v = [
            self.noise_std,
            self.pulse_rate_hz,
            self.pulse_amplitude,
            self.pulse_sigma_s,
        ];
        if v.iter().any(|x| !x.is_finite()) {
            return Err(Error::NonFinite);
        }
        if self.noise_std < 0.0 || self.pulse_rate_hz < 0.0 {
            return Err(Error::InvalidParameter(
                "noise std and pulse rate must be >= 0",
            ));
        }
        if self.noise_std > 0.0 {
            for o in out.iter_mut() {
                *o += weight * self.noise_std * rng.normal();
            }
        }
        if self.pulse_rate_hz > 0.0 && self.pulse_amplitude != 0.0 {
            if self.pulse_sigma_s <= 0.0 {
                return Err(Error::InvalidParameter("pulse width must be > 0"));
            }
            let t_end = grid.t0 + out.len() as f64 * grid.dt;
            let mut t = grid.t0 + rng.exponential(self.pulse_rate_hz);
            while t < t_end {
                let b = (self.pulse_amplitude * (1.0 + 0.5 * rng.normal())).abs();
                add_gaussian_pulse(out, grid, t, self.pulse_sigma_s, weight * b);
                t += rng.exponential(self.pulse_rate_hz);
            }
        }
        Ok(())
    }
}

/// Weighted composite excitation (eq. 20) for both degrees of freedom.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompositeExcitation {
    /// Defect impacts.
    pub impact: ImpactTrain,
    /// Shaft-rate sinusoid.
    pub sinusoid: ShaftSinusoid,
    /// Random background and pulses.
    pub random: RandomExcitation,
    /// `w_impact`.
    pub w_impact: f64,
    /// `w_sin`.
    pub w_sin: f64,
    /// `w_rand`.
    pub w_rand: f64,
    /// Share `s_θ` of the radial force that acts on the angular DOF.
    pub angular_share: f64,
}

impl CompositeExcitation {
    /// Render `F_r` and `F_θ` on `grid` (overwriting both buffers, equal lengths).
    pub fn render(
        &self,
        grid: TimeGrid,
        force_r: &mut [f64],
        force_t: &mut [f64],
        rng: &mut Xoshiro128pp,
    ) -> Result<()> {
        expect_len(force_t.len(), force_r.len())?;
        if !self.angular_share.is_finite() {
            return Err(Error::NonFinite);
        }
        force_r.fill(0.0);
        self.impact.add_to(grid, self.w_impact, force_r, rng)?;
        self.sinusoid.add_to(grid, self.w_sin, force_r)?;
        self.random.add_to(grid, self.w_rand, force_r, rng)?;
        for (t, r) in force_t.iter_mut().zip(force_r.iter()) {
            *t = self.angular_share * r;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;

    #[test]
    fn impacts_land_at_the_defect_period() {
        let train = ImpactTrain {
            first_impact_s: 0.001,
            ..ImpactTrain::periodic(2.0, 100.0, 1e-4)
        };
        let grid = TimeGrid { t0: 0.0, dt: 1e-5 };
        let mut out = vec![0.0; 10_000]; // 0.1 s -> 10 impacts
        let mut rng = Xoshiro128pp::seed_from_u64(1);
        train.add_to(grid, 1.5, &mut out, &mut rng).unwrap();
        let peaks: std::vec::Vec<usize> = (1..out.len() - 1)
            .filter(|&j| out[j] > out[j - 1] && out[j] >= out[j + 1] && out[j] > 1.0)
            .collect();
        assert_eq!(peaks.len(), 10);
        for (n, &p) in peaks.iter().enumerate() {
            assert_eq!(p, 100 + 1000 * n);
            assert!((out[p] - 3.0).abs() < 1e-9);
        }
        // Area of each pulse = A·σ·√(2π)·weight.
        let area: f64 = out[..1000].iter().sum::<f64>() * grid.dt;
        assert!((area - 3.0 * 1e-4 * (2.0 * math::PI).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn modulation_and_jitter() {
        let train = ImpactTrain {
            modulation_depth: 1.0,
            modulation_hz: 10.0,
            jitter: 0.01,
            ..ImpactTrain::periodic(1.0, 200.0, 5e-5)
        };
        let grid = TimeGrid { t0: 0.0, dt: 1e-5 };
        let mut a = vec![0.0; 20_000];
        let mut b = vec![0.0; 20_000];
        train
            .add_to(grid, 1.0, &mut a, &mut Xoshiro128pp::seed_from_u64(3))
            .unwrap();
        train
            .add_to(grid, 1.0, &mut b, &mut Xoshiro128pp::seed_from_u64(3))
            .unwrap();
        assert_eq!(a, b, "deterministic for a seed");
        // Impact at t = 0.05 s sits at the modulation trough (cos(π) = −1): amplitude ≈ 0.
        let trough = a[4900..5100].iter().cloned().fold(0.0, f64::max);
        let crest = a[9900..10100].iter().cloned().fold(0.0, f64::max);
        assert!(
            trough < 0.01 && crest > 0.9,
            "trough {trough} crest {crest}"
        );
    }

    /// A walk is a renewal process: the offset of impact k from the grid `t_1 + k·T`
    /// is a random walk, its variance `k·(walk·T)²`, where a jitter about the grid
    /// keeps it at `(jitter·T)²` for every k.
    #[test]
    fn a_walk_wanders_and_a_jitter_does_not() {
        let rate = 100.0;
        let offsets_var = |train: ImpactTrain, k: usize| -> f64 {
            let grid = TimeGrid { t0: 0.0, dt: 1e-5 };
            let seeds = 40;
            let mut var = 0.0;
            for seed in 0..seeds {
                let mut out = vec![0.0; 110_000]; // 1.1 s: 110 impacts
                train
                    .add_to(grid, 1.0, &mut out, &mut Xoshiro128pp::seed_from_u64(seed))
                    .unwrap();
                let peaks: std::vec::Vec<f64> = (1..out.len() - 1)
                    .filter(|&j| out[j] > out[j - 1] && out[j] >= out[j + 1] && out[j] > 0.5)
                    .map(|j| j as f64 * grid.dt)
                    .collect();
                var += (peaks[k] - (0.005 + k as f64 / rate)).powi(2) / seeds as f64;
            }
            var
        };
        let base = ImpactTrain {
            first_impact_s: 0.005,
            ..ImpactTrain::periodic(1.0, rate, 2e-5)
        };
        let step = (0.02 / rate).powi(2);
        for k in [4usize, 100] {
            let walk = offsets_var(ImpactTrain { walk: 0.02, ..base }, k) / (k as f64 * step);
            let jitter = offsets_var(
                ImpactTrain {
                    jitter: 0.02,
                    ..base
                },
                k,
            ) / step;
            assert!(
                (0.5..2.0).contains(&walk),
                "impact {k}: walk variance {walk:.2} × k·(walk·T)²"
            );
            assert!(
                (0.5..2.0).contains(&jitter),
                "impact {k}: jitter variance {jitter:.2} × (jitter·T)²"
            );
        }
    }

    #[test]
    fn composite_weights_and_angular_share() {
        let ex = CompositeExcitation {
            impact: ImpactTrain::periodic(1.0, 50.0, 1e-4),
            sinusoid: ShaftSinusoid {
                amplitude: 2.0,
                shaft_hz: 25.0,
                phase_rad: 0.0,
                drift_per_s: 0.0,
            },
            random: RandomExcitation {
                noise_std: 0.0,
                pulse_rate_hz: 0.0,
                pulse_amplitude: 0.0,
                pulse_sigma_s: 1e-4,
            },
            w_impact: 0.0,
            w_sin: 0.5,
            w_rand: 1.0,
            angular_share: 0.25,
        };
        let grid = TimeGrid { t0: 0.0, dt: 1e-4 };
        let (mut fr, mut ft) = (vec![9.0; 400], vec![9.0; 400]);
        ex.render(grid, &mut fr, &mut ft, &mut Xoshiro128pp::seed_from_u64(0))
            .unwrap();
        // 0.5 · 2 · sin(2π·25·0.01) = 1 at j = 100.
        assert!((fr[100] - 1.0).abs() < 1e-12);
        assert!((ft[100] - 0.25).abs() < 1e-12);
        assert!(fr[0].abs() < 1e-12);
    }

    /// With drift d, impact n sits where t + ½·d·t² = t_1 + n·T.
    #[test]
    fn speed_drift_compresses_impact_spacing() {
        let train = ImpactTrain {
            rate_drift_per_s: 0.1,
            ..ImpactTrain::periodic(1.0, 100.0, 2e-5)
        };
        let grid = TimeGrid { t0: 0.0, dt: 1e-5 };
        let mut out = vec![0.0; 200_000]; // 2 s
        train
            .add_to(grid, 1.0, &mut out, &mut Xoshiro128pp::seed_from_u64(0))
            .unwrap();
        let peaks: std::vec::Vec<f64> = (1..out.len() - 1)
            .filter(|&j| out[j] > out[j - 1] && out[j] >= out[j + 1] && out[j] > 0.5)
            .map(|j| j as f64 * grid.dt)
            .collect();
        // τ(2 s) = 2 + 0.2 = 2.2 s of warped time: impacts n = 0..=220, of which the
        // half pulses at the two ends (t = 0 and t = 2 s) are not interior peaks.
        assert_eq!(peaks.len(), 219);
        let early = peaks[1] - peaks[0];
        let late = peaks[218] - peaks[217];
        assert!((early - 0.01).abs() < 2e-5, "early spacing {early}");
        assert!(
            (late / early - 1.0 / 1.19).abs() < 0.01,
            "late spacing {late}"
        );
    }

    #[test]
    fn sinusoid_recurrence_matches_libm() {
        let sinus = ShaftSinusoid {
            amplitude: 3.0,
            shaft_hz: 29.93,
            phase_rad: 0.7,
            drift_per_s: 0.0,
        };
        let grid = TimeGrid {
            t0: 0.25,
            dt: 1.0 / 96_000.0,
        };
        let mut out = vec![0.0; 100_000];
        sinus.add_to(grid, 2.0, &mut out).unwrap();
        for (j, v) in out.iter().enumerate() {
            let t = grid.t0 + j as f64 * grid.dt;
            let want = 6.0 * (2.0 * math::PI * 29.93 * t + 0.7).sin();
            assert!((v - want).abs() < 1e-11, "j {j}: {v} vs {want}");
        }
    }

    #[test]
    fn poisson_pulses_arrive_at_the_rate() {
        let r = RandomExcitation {
            noise_std: 0.0,
            pulse_rate_hz: 50.0,
            pulse_amplitude: 1.0,
            pulse_sigma_s: 1e-4,
        };
        let grid = TimeGrid { t0: 0.0, dt: 1e-4 };
        let mut out = vec![0.0; 200_000]; // 20 s -> ~1000 pulses
        r.add_to(grid, 1.0, &mut out, &mut Xoshiro128pp::seed_from_u64(9))
            .unwrap();
        let area: f64 = out.iter().sum::<f64>() * grid.dt;
        let per_pulse = 1e-4 * (2.0 * math::PI).sqrt(); // mean |B| ≈ 1.0 (B/2 spread rarely crosses 0)
        let count = area / per_pulse;
        assert!((count - 1000.0).abs() < 120.0, "pulses ≈ {count}");
    }

    #[test]
    fn bad_parameters() {
        let mut out = [0.0f64; 8];
        let grid = TimeGrid { t0: 0.0, dt: 1e-4 };
        let mut rng = Xoshiro128pp::seed_from_u64(0);
        assert!(ImpactTrain::periodic(1.0, 0.0, 1e-4)
            .add_to(grid, 1.0, &mut out, &mut rng)
            .is_err());
        assert!(ImpactTrain::periodic(f64::NAN, 10.0, 1e-4)
            .add_to(grid, 1.0, &mut out, &mut rng)
            .is_err());
        let bad_grid = TimeGrid { t0: 0.0, dt: 0.0 };
        assert!(ImpactTrain::periodic(1.0, 10.0, 1e-4)
            .add_to(bad_grid, 1.0, &mut out, &mut rng)
            .is_err());
    }
}
