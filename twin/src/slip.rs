//! Slip read off a record's comb, not fitted.
//!
//! Under slip the intervals between a defect's impacts are the period give or take
//! their own random part (Antoni & Randall's renewal process), so the impacts' times
//! wander as a random walk and the train's k-th harmonic broadens into a Lorentzian
//! whose full width at half maximum is `2π·k²·s²·r` Hz (`s` the slip as a fraction of
//! the period, `r` the impact rate; derivation: near `k·r` the renewal spectrum
//! `Re[(1 + φ)/(1 − φ)]`, `φ` the interval's characteristic function, is a Lorentzian
//! of half width `(2πk·r)²·(s/r)²/2` rad/s). The width grows as k², which sets slip
//! apart from what widens every tooth alike (the spectral window, a slow modulation's
//! sidebands: a pulsating load's ±2.7 Hz about every tooth) and from a speed that
//! drifts or breathes, which widens tooth k by k times the rate's spread. In the twin
//! this is the slip effect's `walk` ([`pumptwin_core::excitation`]); a jitter about
//! the grid, which leaves the teeth sharp, is fitted beside it.
//!
//! Why a reading and not a fit parameter: a simulated train with a slip is one
//! realization of the walk, and a change of the slip moves every late impact, so the
//! fitted cost is rough in it at the few-percent level of a realization's own
//! scatter — a fit leaves the slip where it starts, and a scan of starts picks the
//! realization that happens to match (a slipless record read as 0.2 % slip).

/// The walk (the slip effect's `ln_walk`) of a model whose record resolves none:
/// rendered as none at all.
pub const WALK_NONE: f64 = 1e-6;

/// A slip read off the teeth of a comb.
#[derive(Debug, Clone, PartialEq)]
pub struct SlipReading {
    /// Slip, a fraction of the period per impact.
    pub slip: f64,
    /// Width every tooth has whatever its order (window, sidebands), Hz.
    pub base_width_hz: f64,
    /// How far the rate itself spreads over the record, Hz: tooth k widens by k
    /// times it (a speed that drifts or breathes), where slip widens it by k².
    pub wander_hz: f64,
    /// Teeth read: (harmonic order, full width at half maximum in Hz).
    pub teeth: Vec<(usize, f64)>,
    /// The impact rate read at, Hz.
    pub rate_hz: f64,
}

impl SlipReading {
    /// Whether the slip read widens the highest tooth read by at least `df_hz` (a
    /// bin): a smaller slip is one the spectrum cannot tell from none.
    pub fn resolved(&self, df_hz: f64) -> bool {
        let k = self.teeth.iter().map(|&(k, _)| k).max().unwrap_or(0);
        2.0 * std::f64::consts::PI * (k * k) as f64 * self.slip * self.slip * self.rate_hz >= df_hz
    }
}

/// Fewest teeth a reading needs.
const MIN_TEETH: usize = 4;

/// How far a tooth must stand above its neighbourhood (power ratio, 10 dB). A tooth
/// barely over the floor is cut at a half maximum inside the spectrum's scatter and
/// reads wide: the twin's own generator, jittering about the grid by 1.2 %, leaves
/// teeth 7–22 standing, the last two 6–8 dB over the pedestal and read 40 % wide,
/// which a 6 dB threshold took for a 0.3 % walk.
const MIN_TOOTH_RATIO: f32 = 10.0;

/// Full width at half maximum of a Voigt-like profile: a Lorentzian of width `l`
/// seen through a kernel of width `g` (Olivero & Longbothum's approximation, within
/// 0.02 %).
fn voigt_width(l: f64, g: f64) -> f64 {
    0.5346 * l + (0.2166 * l * l + g * g).sqrt()
}

/// The full width at half maximum of the tooth nearest `centre_hz` in `psd` (linear
/// power, bin width `df` Hz) within `±half_hz`, over the lowest tenth of that span
/// (below the neighbouring teeth's Lorentzian tails, which a quartile would reach);
/// `None` where no tooth stands [`MIN_TOOTH_RATIO`] over it or the tooth reaches the
/// span's edge (teeth merged).
fn tooth_width(psd: &[f32], df: f64, centre_hz: f64, half_hz: f64) -> Option<f64> {
    let lo = ((centre_hz - half_hz) / df).ceil().max(1.0) as usize;
    let hi = ((centre_hz + half_hz) / df).floor() as usize;
    if hi >= psd.len() || hi < lo + 8 {
        return None;
    }
    let span = &psd[lo..=hi];
    let mut sorted = span.to_vec();
    sorted.sort_by(f32::total_cmp);
    let floor = sorted[sorted.len() / 10];
    let c = (centre_hz / df).round() as usize;
    let near = c.saturating_sub(2).max(lo)..=(c + 2).min(hi);
    let peak_bin = near.max_by(|&a, &b| psd[a].total_cmp(&psd[b]))?;
    let peak = psd[peak_bin];
    if !(floor > 0.0 && peak >= MIN_TOOTH_RATIO * floor) {
        return None;
    }
    let half = floor + 0.5 * (peak - floor);
    // A crossing is looked for on the three-bin mean beyond the peak's own bin: a
    // Welch estimate scatters by a fifth from bin to bin, and the first dip under half
    // of a wide tooth would cut it short.
    let smooth = |j: usize| {
        if j == peak_bin || j <= lo || j >= hi {
            psd[j]
        } else {
            (psd[j - 1] + psd[j] + psd[j + 1]) / 3.0
        }
    };
    let crossing = |step: isize| -> Option<f64> {
        let mut j = peak_bin as isize;
        loop {
            let next = j + step;
            if next < lo as isize || next > hi as isize {
                return None;
            }
            let (a, b) = (smooth(j as usize), smooth(next as usize));
            if b < half {
                let frac = f64::from((a - half) / (a - b));
                return Some((j as f64 + step as f64 * frac) * df);
            }
            j = next;
        }
    };
    let (left, right) = (crossing(-1)?, crossing(1)?);
    Some(right - left)
}

/// Read the slip of impacts at `rate_hz` off the teeth of their comb in `psd` (linear
/// power, bin width `df_hz`) between `lo_hz` and `hi_hz`: each tooth that stands
/// clear of its neighbourhood is measured at half maximum, and either a slip or a
/// wander of the rate, over a width common to every tooth, is the reading whose
/// widths `voigt(2π·k²·s²·r, √(base² + (k·wander)²))` come closest to the measured
/// ones (least squares over a grid: slip 0 and 0.05–4.7 % in 4 % steps, or wander
/// 0.01–10 bins, each over a base of 0.5–8 bins: see [`widths_fit`]). `None` where fewer
/// than [`MIN_TEETH`] teeth stand (the comb is too weak, or so smeared that no
/// tooth is left: then the slip is large, but how large is not read here).
pub fn read_slip(
    psd: &[f32],
    df_hz: f64,
    rate_hz: f64,
    lo_hz: f64,
    hi_hz: f64,
) -> Option<SlipReading> {
    if !(df_hz > 0.0 && rate_hz > 8.0 * df_hz) {
        return None;
    }
    let k_lo = (lo_hz / rate_hz).ceil().max(1.0) as usize;
    let k_hi = (hi_hz / rate_hz).floor() as usize;
    let teeth: Vec<(usize, f64)> = (k_lo..=k_hi)
        .filter_map(|k| tooth_width(psd, df_hz, k as f64 * rate_hz, 0.5 * rate_hz).map(|w| (k, w)))
        .collect();
    if teeth.len() < MIN_TEETH {
        return None;
    }
    let fit = widths_fit(&teeth, df_hz, rate_hz);
    // Once more without the teeth the first fit leaves far off (a line of another
    // source in a tooth's skirt widens it at its own order, not with k): more than
    // three times the median miss, and more than a bin.
    let miss = |&(k, w): &(usize, f64)| (fit.width(k, rate_hz) - w).abs();
    let mut misses: Vec<f64> = teeth.iter().map(miss).collect();
    misses.sort_by(f64::total_cmp);
    let limit = (3.0 * misses[misses.len() / 2]).max(df_hz);
    let kept: Vec<(usize, f64)> = teeth.iter().copied().filter(|t| miss(t) <= limit).collect();
    if kept.len() < MIN_TEETH {
        return None;
    }
    let fit = widths_fit(&kept, df_hz, rate_hz);
    Some(SlipReading {
        slip: fit.slip,
        base_width_hz: fit.base,
        wander_hz: fit.wander,
        teeth: kept,
        rate_hz,
    })
}

/// The three widths a comb's teeth are read as.
#[derive(Debug, Clone, Copy)]
struct Widths {
    /// Slip (fraction of the period).
    slip: f64,
    /// Width common to every tooth, Hz.
    base: f64,
    /// Spread of the rate over the record, Hz (tooth k: k times it).
    wander: f64,
}

impl Widths {
    /// The width of tooth `k`: the slip's Lorentzian seen through the window, widened
    /// by the rate's spread.
    fn width(&self, k: usize, rate_hz: f64) -> f64 {
        let l = 2.0 * std::f64::consts::PI * (k * k) as f64 * self.slip * self.slip * rate_hz;
        let g = self.base.hypot(k as f64 * self.wander);
        voigt_width(l, g)
    }
}

/// How much better (in the squared misses) widths growing as k must fit than widths
/// growing as k² before the growth is read as the rate's wander and not as slip.
/// Over a few orders the two curves are alike within the widths' scatter, and every
/// rolling bearing slips, so a tie goes to slip; a drifting speed's widths are a
/// straight line in k that a k² curve misses by far (0.5 %/s over 6 s: see the
/// tests).
const SLIP_OVER_WANDER: f64 = 2.0;

/// The widths that come closest to `teeth`' (least squares over the grid
/// [`read_slip`] names): a slip (widths growing as k²) or a wander (as k), each over
/// a common width, the wander only where its misses are under half the slip's
/// ([`SLIP_OVER_WANDER`]).
fn widths_fit(teeth: &[(usize, f64)], df_hz: f64, rate_hz: f64) -> Widths {
    let bases: Vec<f64> = (0..=30)
        .map(|i| df_hz * 0.5 * 16f64.powf(f64::from(i) / 30.0))
        .collect();
    let best = |grid: &mut dyn Iterator<Item = (f64, f64)>| {
        let mut best = (
            f64::INFINITY,
            Widths {
                slip: 0.0,
                base: 0.0,
                wander: 0.0,
            },
        );
        for (slip, wander) in grid {
            for &base in &bases {
                let w = Widths { slip, base, wander };
                let sse: f64 = teeth
                    .iter()
                    .map(|&(k, measured)| (w.width(k, rate_hz) - measured).powi(2))
                    .sum();
                if sse < best.0 {
                    best = (sse, w);
                }
            }
        }
        best
    };
    let (sse_slip, slip) = best(
        &mut std::iter::once(0.0)
            .chain((0..=116).map(|i| 5e-4 * 1.04f64.powi(i)))
            .map(|s| (s, 0.0)),
    );
    let (sse_wander, wander) =
        best(&mut (0..=60).map(|i| (0.0, 0.01 * df_hz * 1000f64.powf(f64::from(i) / 60.0))));
    if sse_slip < SLIP_OVER_WANDER * sse_wander {
        slip
    } else {
        wander
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signature::welch;
    use pumptwin_core::fft::{power_spectrum, Complex32, Window};
    use pumptwin_core::rng::Xoshiro128pp;

    const FS: f64 = 12_000.0;

    /// Impacts at `rate` Hz whose intervals slip by `slip` (a renewal process), their
    /// strengths × (1 + `am`·cos 2π·2.7 t), ringing a 3 kHz mode (ζ 5 %), over a
    /// little white noise; 6 s.
    fn record(rate: f64, slip: f64, am: f64, seed: u64) -> Vec<f32> {
        drifting(rate, slip, am, 0.0, seed)
    }

    /// As [`record`], the rate rising by `drift` (a fraction) per second.
    fn drifting(rate: f64, slip: f64, am: f64, drift: f64, seed: u64) -> Vec<f32> {
        let n = (6.0 * FS) as usize;
        let mut rng = Xoshiro128pp::seed_from_u64(seed);
        let mut force = vec![0.0f64; n];
        let mut t = 0.01;
        while t * FS < (n - 1) as f64 {
            let a = 1.0 + am * (2.0 * std::f64::consts::PI * 2.7 * t).cos();
            let i = (t * FS) as usize;
            let frac = t * FS - i as f64;
            force[i] += a * (1.0 - frac);
            force[i + 1] += a * frac;
            t += (1.0 + slip * rng.normal()).max(0.5) / (rate * (1.0 + drift * t));
        }
        let (w, zeta) = (2.0 * std::f64::consts::PI * 3000.0, 0.05);
        let r = (-zeta * w / FS).exp();
        let wd = w * (1.0 - zeta * zeta).sqrt();
        let (a1, a2, g) = (2.0 * r * (wd / FS).cos(), -r * r, r * (wd / FS).sin());
        let (mut y1, mut y2, mut x1) = (0.0, 0.0, 0.0);
        force
            .iter()
            .map(|&x| {
                let v = a1 * y1 + a2 * y2 + g * x1;
                (y2, y1, x1) = (y1, v, x);
                (v + 0.002 * rng.normal()) as f32
            })
            .collect()
    }

    fn read(x: &[f32], rate: f64) -> Option<SlipReading> {
        let n = 4096;
        let mut scratch = vec![Complex32::ZERO; n];
        let psd = welch(x, n, |b, out| {
            power_spectrum(b, Window::Hann, &mut scratch, out)
        })
        .unwrap();
        read_slip(&psd, FS / n as f64, rate, 20.0, 4600.0)
    }

    #[test]
    fn a_renewal_trains_slip_is_read_within_a_third() {
        for (rate, slip) in [(107.0, 0.003), (107.0, 0.008), (61.0, 0.006), (160.0, 0.01)] {
            let got = read(&record(rate, slip, 0.0, 7), rate).expect("teeth");
            assert!(
                (got.slip / slip - 1.0).abs() < 0.33,
                "rate {rate}, slip {slip}: read {:.4} from {:?}",
                got.slip,
                got.teeth
            );
        }
    }

    /// A spectrum with nothing to read (silence, NaN, too short, a rate under eight
    /// bins) gives no reading and no panic.
    #[test]
    fn nothing_to_read_is_no_reading() {
        let df = FS / 4096.0;
        assert!(read_slip(&vec![0.0; 2049], df, 107.0, 20.0, 4600.0).is_none());
        assert!(read_slip(&vec![f32::NAN; 2049], df, 107.0, 20.0, 4600.0).is_none());
        assert!(read_slip(&[1.0; 10], df, 107.0, 20.0, 4600.0).is_none());
        assert!(read_slip(&vec![1.0; 2049], df, 5.0 * df, 20.0, 4600.0).is_none());
    }

    /// A speed that drifts widens tooth k by k times the rate's spread, not k²: 0.5 %
    /// per second over 6 s is read as the rate's wander, not as slip.
    #[test]
    fn a_drifting_speed_is_not_slip() {
        let got = read(&drifting(107.0, 0.0, 0.0, 0.005, 5), 107.0).expect("teeth");
        assert!(got.slip < 1e-3, "read {:.4} from {:?}", got.slip, got.teeth);
    }

    #[test]
    fn sidebands_of_a_slow_modulation_are_not_slip() {
        let got = read(&record(107.0, 0.0, 0.5, 3), 107.0).expect("teeth");
        assert!(got.slip < 1e-3, "read {:.4} from {:?}", got.slip, got.teeth);
    }
}
