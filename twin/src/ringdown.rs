//! Ring-downs of a structural mode after each impact, read from the phase of the
//! band-passed analytic signal: how fast each one starts and ends, and whether the
//! start is faster the stronger the impact — the signature of a hardening stiffness
//! (Duffing: the backbone `ω(A) = ω₀·(1 + 3βA²/8ω₀²)`, Nayfeh & Mook 1979, §4.1).
//!
//! An early-versus-late shift alone does not prove a nonlinearity: two close linear
//! modes beat, and the phase of their sum runs faster at the start of every ring-down
//! whatever the impact's strength. What only an amplitude-dependent stiffness does is
//! tie the shift to the amplitude, so where a record's impacts vary in strength (every
//! real bearing's do) [`RingdownBand::hardening`] regresses each ring-down's early
//! frequency, and its early-less-late shift, on its squared amplitude, and the tracer
//! asks for those slopes first.

use super::signature::block_within;
use pumptwin_core::fft::{fft_in_place, Complex32, Direction};
use std::ops::Range;

/// Least ring-downs for a hardening slope: with fewer the slope's standard error is
/// read from too few residuals to be trusted.
pub const MIN_RINGDOWNS: usize = 20;

/// Least spread (standard deviation) of the ring-downs' squared amplitudes relative to
/// their mean for a slope: impacts alike in strength leave the regressor without range,
/// and the slope is then noise over noise.
pub const MIN_STRENGTH_SPREAD: f64 = 0.05;

/// One ring-down: the envelope peak that starts it and the phase it turns over its
/// early and late windows, rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ringdown {
    /// Envelope at the start.
    pub amp: f32,
    /// Phase turned over the early window (`early_len` samples from the start).
    pub early_span: f64,
    /// Phase turned over the late window (`2·early_len` samples after a gap of a cycle).
    pub late_span: f64,
}

/// The ring-downs of a record in one band.
#[derive(Debug, Clone, PartialEq)]
pub struct Ringdowns {
    /// Length of the early window, samples (two cycles of the band's centre).
    pub early_len: usize,
    /// Radians per sample to Hz.
    pub to_hz: f64,
    /// The ring-downs, in time order.
    pub list: Vec<Ringdown>,
}

impl Ringdowns {
    /// Early frequency of ring-down `r`, Hz.
    pub fn early_hz(&self, r: &Ringdown) -> f64 {
        r.early_span / self.early_len as f64 * self.to_hz
    }
}

/// Where a mode's ring-downs are read: its band, the impact rate that spaces them, and
/// the spans of the record not to read.
#[derive(Debug, Clone, Copy)]
pub struct RingdownBand<'a> {
    /// Sampling rate, Hz.
    pub fs: f32,
    /// Band's lower edge, Hz.
    pub lo: f32,
    /// Band's upper edge, Hz.
    pub hi: f32,
    /// Impact rate, Hz: peaks closer than half a period are one ring-down.
    pub rate_hz: f32,
    /// Sample ranges where the acquisition held one value (dropouts).
    pub holds: &'a [Range<usize>],
}

impl RingdownBand<'_> {
    /// Every ring-down of `x` in the band `[lo, hi]` Hz: starts at local envelope maxima
    /// above 30 % of the block's 99th percentile, at least half an impact period apart
    /// (`rate_hz` is the impact rate). A block that overlaps one of `holds` (sample ranges
    /// where the acquisition held one value: a dropout) is not read: the steps into and out
    /// of a hold ring through the whole band-passed block, at no mode's frequency and with
    /// no impact's strength. `None` when the record is shorter than one block.
    pub fn ringdowns(&self, x: &[f32]) -> Option<Ringdowns> {
        let Self {
            fs,
            lo,
            hi,
            rate_hz,
            holds,
        } = *self;
        let n = block_within(8192, x.len(), 1);
        if x.len() < n {
            return None;
        }
        let mut scratch = vec![Complex32::ZERO; n];
        let fc = 0.5 * (lo + hi);
        let cycle = (fs / fc).max(2.0);
        let w1 = (2.0 * cycle).round() as usize; // early window: first two cycles
        let gap = (1.0 * cycle).round() as usize;
        let min_sep = (0.5 * fs / rate_hz.max(1.0)) as usize;
        let mut list = Vec::new();
        for start in (0..=x.len() - n).step_by(n) {
            if holds.iter().any(|h| h.start < start + n && h.end > start) {
                continue;
            }
            let seg = &x[start..start + n];
            analytic_in_band(seg, fs, lo, hi, &mut scratch)?;
            let amp: Vec<f32> = scratch.iter().map(|z| z.norm()).collect();
            let mut sorted = amp.clone();
            let q = sorted.len() * 99 / 100;
            let p99 = *sorted.select_nth_unstable_by(q, |a, b| a.total_cmp(b)).1;
            let margin = 64 + 8 * w1;
            let mut i = margin;
            while i + margin < n {
                if amp[i] >= 0.3 * p99 && amp[i] >= amp[i - 1] && amp[i] > amp[i + 1] {
                    let a0 = i + 1;
                    list.push(Ringdown {
                        amp: amp[i],
                        early_span: phase_span(&scratch, a0, a0 + w1),
                        late_span: phase_span(&scratch, a0 + w1 + gap, a0 + 3 * w1 + gap),
                    });
                    i += min_sep.max(1);
                } else {
                    i += 1;
                }
            }
        }
        Some(Ringdowns {
            early_len: w1,
            to_hz: f64::from(fs) / (2.0 * std::f64::consts::PI),
            list,
        })
    }

    /// Ring-down frequency right after each impact vs later in the same ring-down:
    /// `(f_early, f_late)` in Hz, each the mean over the ring-downs weighted by their
    /// squared starting envelope. A hardening stiffness makes the large-amplitude start of
    /// each ring-down faster than its tail; a linear mode rings at one frequency throughout.
    pub fn frequencies(&self, x: &[f32]) -> Option<(f32, f32)> {
        let r = self.ringdowns(x)?;
        let w1 = r.early_len;
        let (mut se, mut we, mut sl, mut wl) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for d in &r.list {
            let weight = f64::from(d.amp).powi(2);
            se += weight * d.early_span / w1 as f64;
            we += weight;
            sl += weight * d.late_span / (2 * w1) as f64;
            wl += weight;
        }
        if we <= 0.0 || wl <= 0.0 {
            return None;
        }
        Some(((se / we * r.to_hz) as f32, (sl / wl * r.to_hz) as f32))
    }

    /// The early frequency of each ring-down, and its early frequency less its late one,
    /// regressed on its squared amplitude relative to the mean, weighted by the squared
    /// amplitude (a strong ring-down's phase is read over less noise); both slopes and
    /// their errors relative to the weighted mean early frequency. `None` with fewer than
    /// [`MIN_RINGDOWNS`] ring-downs or a spread of strengths under
    /// [`MIN_STRENGTH_SPREAD`] (the slope is then undetermined, and only the early-versus-
    /// late shift can be read), or where that mean is not positive.
    pub fn hardening(&self, x: &[f32]) -> Option<Hardening> {
        let r = self.ringdowns(x)?;
        let n = r.list.len();
        if n < MIN_RINGDOWNS {
            return None;
        }
        let sq: Vec<f64> = r.list.iter().map(|d| f64::from(d.amp).powi(2)).collect();
        let mean_sq = sq.iter().sum::<f64>() / n as f64;
        if mean_sq <= 0.0 {
            return None;
        }
        let s: Vec<f64> = sq.iter().map(|v| v / mean_sq).collect();
        let spread = (s.iter().map(|v| (v - 1.0).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        if spread < MIN_STRENGTH_SPREAD {
            return None;
        }
        let early: Vec<f64> = r.list.iter().map(|d| r.early_hz(d)).collect();
        let wsum = sq.iter().sum::<f64>();
        let f_bar = early.iter().zip(&sq).map(|(a, b)| a * b).sum::<f64>() / wsum;
        if f_bar.is_nan() || f_bar <= 0.0 {
            return None;
        }
        let shift: Vec<f64> = r
            .list
            .iter()
            .zip(&early)
            .map(|(d, e)| e - d.late_span / (2 * r.early_len) as f64 * r.to_hz)
            .collect();
        let (slope, se) = weighted_slope(&s, &early, &sq)?;
        let (shift_slope, shift_se) = weighted_slope(&s, &shift, &sq)?;
        Some(Hardening {
            slope: slope / f_bar,
            se: se / f_bar,
            shift_slope: shift_slope / f_bar,
            shift_se: shift_se / f_bar,
        })
    }
}

/// `seg` (mean removed) as the analytic signal of its `[lo, hi]` Hz band, into `out`.
fn analytic_in_band(seg: &[f32], fs: f32, lo: f32, hi: f32, out: &mut [Complex32]) -> Option<()> {
    let n = seg.len();
    let mean = seg.iter().sum::<f32>() / n as f32;
    for (z, &v) in out.iter_mut().zip(seg) {
        *z = Complex32::new(v - mean, 0.0);
    }
    fft_in_place(out, Direction::Forward).ok()?;
    let df = fs / n as f32;
    for (k, z) in out.iter_mut().enumerate() {
        let f = k as f32 * df;
        *z = if k > 0 && k < n / 2 && f >= lo && f <= hi {
            Complex32::new(2.0 * z.re, 2.0 * z.im)
        } else {
            Complex32::ZERO
        };
    }
    fft_in_place(out, Direction::Inverse).ok()
}

/// Phase turned by the analytic signal `z` from sample `a` to `b`, rad (unwrapped
/// sample by sample).
fn phase_span(z: &[Complex32], a: usize, b: usize) -> f64 {
    let mut total = 0.0f64;
    for k in a..b {
        let (u, v) = (z[k], z[k + 1]);
        total += f64::from((v.im * u.re - v.re * u.im).atan2(v.re * u.re + v.im * u.im));
    }
    total
}

/// How a mode's early ring-down frequency rises with the impact's strength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hardening {
    /// Relative rise of the early frequency per unit of squared amplitude relative to
    /// its mean (`Δf/f̄` per `Δ(A²/mean A²)`): the Duffing backbone is linear in `A²`.
    pub slope: f64,
    /// Its standard error (heteroskedasticity-robust, White 1980).
    pub se: f64,
    /// The same for each ring-down's early frequency less its late one (relative to
    /// the mean early frequency): a hardening mode slows as it decays, the more the
    /// stronger it started.
    pub shift_slope: f64,
    /// Its standard error.
    pub shift_se: f64,
}

/// The weighted least-squares slope of `y` on `s` (weights `w`) and its
/// heteroskedasticity-robust standard error; `None` where `s` has no weighted spread.
fn weighted_slope(s: &[f64], y: &[f64], w: &[f64]) -> Option<(f64, f64)> {
    let wsum = w.iter().sum::<f64>();
    let wmean = |v: &[f64]| v.iter().zip(w).map(|(a, b)| a * b).sum::<f64>() / wsum;
    let (s_bar, y_bar) = (wmean(s), wmean(y));
    let sxx: f64 = s.iter().zip(w).map(|(a, b)| b * (a - s_bar).powi(2)).sum();
    if sxx.is_nan() || sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = s
        .iter()
        .zip(y)
        .zip(w)
        .map(|((a, c), b)| b * (a - s_bar) * (c - y_bar))
        .sum();
    let b = sxy / sxx;
    let meat: f64 = s
        .iter()
        .zip(y)
        .zip(w)
        .map(|((a, c), wt)| (wt * (a - s_bar) * (c - y_bar - b * (a - s_bar))).powi(2))
        .sum();
    Some((b, meat.sqrt() / sxx))
}

#[cfg(test)]
mod tests {
    use super::*;

    const FS: f32 = 12_000.0;
    const RATE: f32 = 100.0;

    fn band(lo: f32, hi: f32) -> RingdownBand<'static> {
        RingdownBand {
            fs: FS,
            lo,
            hi,
            rate_hz: RATE,
            holds: &[],
        }
    }

    /// Impacts at `RATE` with strengths spread ±60 % (a fixed pseudo-random sequence),
    /// each ringing down through `ring(t, a)` (t in s, a the strength), plus a little
    /// white noise.
    fn impacts(ring: impl Fn(f64, f64) -> f64) -> Vec<f32> {
        let n = 6 * FS as usize;
        let period = (FS / RATE) as usize;
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut x = vec![0.0f32; n];
        for start in (0..n).step_by(period) {
            let a = 0.4 + 1.2 * uniform();
            for (k, v) in x[start..(start + period).min(n)].iter_mut().enumerate() {
                *v += ring(k as f64 / f64::from(FS), a) as f32;
            }
        }
        for v in &mut x {
            *v += (0.002 * (uniform() - 0.5)) as f32;
        }
        x
    }

    const F0: f64 = 3000.0;
    const DECAY: f64 = 400.0; // 1/s

    #[test]
    fn hardening_reads_amplitude_not_beating() {
        // Duffing backbone: the frequency rises 5 % at unit squared amplitude and
        // falls back as the ring-down decays (phase = ∫ω dt in closed form).
        let duffing = impacts(|t, a| {
            let env = a * (-DECAY * t).exp();
            let k = 0.05 * a * a;
            let phase = 2.0
                * std::f64::consts::PI
                * F0
                * (t + k * (1.0 - (-2.0 * DECAY * t).exp()) / (2.0 * DECAY));
            env * phase.sin()
        });
        // Two linear modes 3 % apart, in the same proportion at every impact: the
        // ring-down's phase runs fast early at every strength alike.
        let beating = impacts(|t, a| {
            let env = a * (-DECAY * t).exp();
            let w = 2.0 * std::f64::consts::PI * F0;
            env * ((w * t).sin() + 0.6 * (1.03 * w * t).sin())
        });
        let (lo, hi) = (0.75 * F0 as f32, 1.25 * F0 as f32);
        let h = band(lo, hi).hardening(&duffing).expect("a slope");
        assert!(h.slope > 10.0 * h.se && h.slope > 0.005, "{h:?}");
        // 5 % at unit squared amplitude, averaged over the first two cycles (0.67 ms,
        // where e^(−2·400·t) averages 0.77), per unit of squared amplitude relative to
        // its mean (1.12 for strengths uniform on 0.4–1.6): 0.05 · 0.77 · 1.12 ≈ 0.043.
        assert!((0.03..0.07).contains(&h.slope), "{h:?}");
        let b = band(lo, hi).hardening(&beating).expect("a slope");
        assert!(b.slope.abs() < 3.0 * b.se.max(1e-4), "{b:?}");
        // The hardening ring-down slows as it decays, the more the stronger it
        // started; the beating one by as much at every strength.
        assert!(h.shift_slope > 3.0 * h.shift_se, "{h:?}");
        assert!(b.shift_slope.abs() < 3.0 * b.shift_se.max(1e-4), "{b:?}");
        // Both shift early against late: the shift alone does not tell them apart.
        let shift = |x: &[f32]| {
            let (e, l) = band(lo, hi).frequencies(x).unwrap();
            e / l - 1.0
        };
        assert!(shift(&duffing) > 0.01, "{}", shift(&duffing));
        assert!(shift(&beating).abs() > 0.002, "{}", shift(&beating));
    }

    /// The weighted slope of points on a line is the line's, with no error; spread
    /// around it, the error is White's.
    #[test]
    fn the_weighted_slope_is_least_squares() {
        let (s, w) = ([0.5, 1.0, 1.5, 2.0], [1.0, 2.0, 1.0, 2.0]);
        let on_line: Vec<f64> = s.iter().map(|v| 3.0 - 2.0 * v).collect();
        let (b, se) = weighted_slope(&s, &on_line, &w).unwrap();
        assert!((b + 2.0).abs() < 1e-12 && se < 1e-12, "{b} {se}");
        // y = [0, 1, 0, 1]: s̄ = 4/3, ȳ = 2/3, Sxx = 11/6, Sxy = 2/3 by hand.
        let (b, se) = weighted_slope(&s, &[0.0, 1.0, 0.0, 1.0], &w).unwrap();
        assert!((b - 4.0 / 11.0).abs() < 1e-12, "{b}");
        assert!(se > 0.0 && se.is_finite());
        assert_eq!(weighted_slope(&[1.0, 1.0], &[0.0, 1.0], &[1.0, 1.0]), None);
    }

    /// The known limit of the two slopes: a linear mode under a steady tone below it in
    /// the band (0.9 × the mode, a quarter of the mean impact) reads both rising with
    /// strength, the weak ring-downs read toward the tone. Only the model's draws, once
    /// the tone is in the model, tell it from a hardening (`trace::stiffness`).
    #[test]
    fn a_tone_under_the_mode_raises_both_slopes() {
        let tone = 2.0 * std::f64::consts::PI * 0.9 * F0;
        let mut x =
            impacts(|t, a| a * (-DECAY * t).exp() * (2.0 * std::f64::consts::PI * F0 * t).sin());
        for (i, v) in x.iter_mut().enumerate() {
            *v += (0.25 * (tone * i as f64 / f64::from(FS)).sin()) as f32;
        }
        let h = band(0.75 * F0 as f32, 1.25 * F0 as f32)
            .hardening(&x)
            .expect("a slope");
        assert!(
            h.slope > 3.0 * h.se && h.shift_slope > 3.0 * h.shift_se,
            "{h:?}"
        );
    }

    /// A block that holds a dropout is not read; the others are read as before.
    #[test]
    fn a_held_block_is_not_read() {
        let mut x =
            impacts(|t, a| a * (-DECAY * t).exp() * (2.0 * std::f64::consts::PI * F0 * t).sin());
        let all = band(2250.0, 3750.0).ringdowns(&x).unwrap();
        let n = block_within(8192, x.len(), 1);
        let hold = n + 100..n + 600;
        let v = x[hold.start];
        x[hold.clone()].fill(v);
        let read = RingdownBand {
            holds: &[hold],
            ..band(2250.0, 3750.0)
        }
        .ringdowns(&x)
        .unwrap();
        let blocks = x.len() / n;
        assert!(blocks >= 3, "{blocks}");
        let per_block = all.list.len() / blocks;
        // One block's ring-downs are left out, give or take the ones at its edges.
        let (kept, had) = (read.list.len(), all.list.len());
        assert!(
            kept + per_block / 2 <= had && kept + 3 * per_block / 2 >= had,
            "{kept} of {had}"
        );
        assert_eq!(read.list[..per_block / 2], all.list[..per_block / 2]);
    }

    #[test]
    fn alike_impacts_have_no_slope() {
        let x: Vec<f32> = (0..6 * FS as usize)
            .map(|i| {
                let t = (i % (FS / RATE) as usize) as f64 / f64::from(FS);
                ((-DECAY * t).exp() * (2.0 * std::f64::consts::PI * F0 * t).sin()) as f32
            })
            .collect();
        assert_eq!(band(2250.0, 3750.0).hardening(&x), None);
        assert!(band(2250.0, 3750.0).ringdowns(&x[..100]).is_none());
    }
}
