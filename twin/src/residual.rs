//! Step 2 of the loop: the residual between measurement and model, its significant
//! components, the measurements of the signal the tracers read as evidence, and how
//! far a refitted model still is from explaining a candidate's evidence. The tracers
//! themselves (step 3) are [`crate::trace`].
//!
//! A component is significant when it stands above a robust noise floor of the dB
//! residual `d(f) = measured − model`: `d > median(d) + max(6 dB, 5·1.4826·MAD(d))` (5σ over some 2000 bins).
//! Narrow runs (≤ 4 bins, a Hann main lobe) are lines; wider runs are bands.

use super::ringdown::RingdownBand;
use super::signature::{to_db, welch, Signature, SignatureConfig};
use super::twin::{Effect, TwinModel};
use pumptwin_core::features::{envelope, EnvelopeBand};
use pumptwin_core::fft::{fft_in_place, Complex32, Direction};
use std::ops::Range;

/// Minimum excess of a significant component, dB.
pub const MIN_EXCESS_DB: f32 = 6.0;
/// MAD multiplier of the noise floor: 5σ, so that over the ~1600 PSD and ~680
/// envelope bins a noise-only residual crosses it with probability < 0.1 %.
pub const MAD_K: f32 = 5.0;
/// Prominence over its own local median a measured line (PSD or envelope) needs to
/// count when the residual's spread hides it, dB.
pub const LINE_PROMINENCE_DB: f32 = 10.0;
/// The same above 40 × the shaft rate, in the structure's band, dB: there a bearing's
/// impacts ring the housing's modes, and a measured spectrum is a forest of comb teeth
/// and sidebands 15–30 dB over their neighbours (CWRU inner-race records 105–108: 18–25
/// lines of 15 dB or more above 40 ×) — the model's own lines, which the tracer sets aside by their rates — and of
/// the rig's lines (CWRU 97: 4146 Hz at 32 dB). A tone added there (a drive's switching
/// line, a neighbouring machine) must stand out of that forest to be read.
pub const STRUCTURE_LINE_PROMINENCE_DB: f32 = 20.0;
/// Most lines one tonal candidate (shaft orders, half orders) takes.
pub const MAX_TONES: usize = 6;
/// Electrical supply frequencies checked for line interference, Hz.
pub const MAINS_HZ: [f64; 2] = [50.0, 60.0];

/// The spectrum a residual component stands in (`psd` or `envelope` in reports).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Domain {
    /// The power spectral density.
    Psd,
    /// The envelope spectrum.
    Envelope,
}

/// The shape of a residual component (`line`, `band`, `below_band`, `above_band` in
/// reports).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// A narrow peak (a Hann main lobe, at most [`LINE_MAX_BINS`] bins).
    Line,
    /// A wider run above the floor.
    Band,
    /// Energy rising to the compared band's lower edge.
    BelowBand,
    /// Energy rising to the compared band's upper edge.
    AboveBand,
}

impl Domain {
    /// The name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Domain::Psd => "psd",
            Domain::Envelope => "envelope",
        }
    }
}

impl std::fmt::Display for Domain {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Kind {
    /// The name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Line => "line",
            Kind::Band => "band",
            Kind::BelowBand => "below_band",
            Kind::AboveBand => "above_band",
        }
    }
}

impl std::fmt::Display for Kind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One significant residual component.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Component {
    /// The spectrum it stands in.
    pub domain: Domain,
    /// Its shape.
    pub kind: Kind,
    /// Peak frequency, Hz.
    pub f_hz: f64,
    /// Width of the run above the floor, Hz.
    pub width_hz: f64,
    /// Peak excess over the floor, dB.
    pub excess_db: f32,
    /// `f_hz / f_r`.
    pub order: f64,
    /// A band's centre (the middle of its run above the floor), Hz; its peak `f_hz`
    /// need not be there.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub centre_hz: Option<f64>,
}

/// Evidence for an effect, as reported.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Evidence {
    /// What was seen, in words.
    pub summary: String,
    /// The residual components behind it.
    pub components: Vec<Component>,
    /// Extra numbers (widths, shifts…).
    pub figures: serde_json::Map<String, serde_json::Value>,
}

/// A candidate effect with its evidence and a strength used to order candidates.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// The effect to add.
    pub effect: Effect,
    /// Why.
    pub evidence: Evidence,
    /// Ordering key (dB-ish).
    pub strength: f32,
    /// How to tell, after a refit, whether the effect explains its evidence.
    pub check: Check,
}

/// The statistic behind a candidate's evidence, re-measured after the refit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Check {
    /// The evidence's residual components (dB excess at their frequencies).
    Lines,
    /// Loss of defect-comb contrast at high orders relative to the model, dB.
    CombContrast {
        /// Comb spacing, Hz.
        rate: f64,
    },
    /// `ln(measured / model)` of the kurtosis over the band `[lo, hi]`
    /// ([`band_kurtosis`]).
    Kurtosis {
        /// Band, Hz.
        lo: f32,
        /// Band, Hz.
        hi: f32,
    },
    /// A structural mode's band `[lo, hi]`: its lines, as [`Check::Lines`], and its
    /// impulsiveness. A mode rung by the model's impacts and background is as
    /// impulsive as they make it, so where the record's band stands more impulsive
    /// than the model's (`ln(measured / model)` of [`band_kurtosis`] over
    /// [`MIN_LOG_KURTOSIS_EXCESS`](crate::trace::context::MIN_LOG_KURTOSIS_EXCESS))
    /// the refit must halve that excess too: a band it leaves as impulsive is rung by
    /// something sparser than the modelled impacts (bursts at random times), not a
    /// mode of this structure.
    Mode {
        /// Band, Hz.
        lo: f32,
        /// Band, Hz.
        hi: f32,
    },
    /// Ring-down early/late frequency ratio excess over the model.
    Ringdown {
        /// Band, Hz.
        lo: f32,
        /// Band, Hz.
        hi: f32,
        /// Impact rate, Hz.
        rate: f32,
    },
    /// Hardening slope (the ring-downs' early frequency against their squared
    /// amplitude, [`RingdownBand::hardening`]) excess over the model's.
    Hardening {
        /// Band, Hz.
        lo: f32,
        /// Band, Hz.
        hi: f32,
        /// Impact rate, Hz.
        rate: f32,
    },
}

/// How far the model is from explaining a candidate's evidence: larger is worse, 0 or
/// below is explained. `x`/`sim` are the measured and simulated signals, the dB spectra
/// at residual resolution (same reference).
pub fn evidence_gap(
    check: &Check,
    components: &[Component],
    x: &[f32],
    sim: &[f32],
    meas_psd_db: &[f32],
    sim_psd_db: &[f32],
    meas_env_db: &[f32],
    sim_env_db: &[f32],
    cfg: &SignatureConfig,
    holds: &[Range<usize>],
) -> f32 {
    let ringdown_band = |lo, hi, rate_hz| RingdownBand {
        fs: cfg.fs_hz,
        lo,
        hi,
        rate_hz,
        holds,
    };
    match *check {
        Check::Lines | Check::Mode { .. } => {
            let mut total = 0.0;
            for c in components {
                let (m, s, n) = if c.domain == Domain::Psd {
                    (meas_psd_db, sim_psd_db, cfg.psd_n)
                } else {
                    (meas_env_db, sim_env_db, cfg.env_n)
                };
                let k = (c.f_hz * n as f64 / f64::from(cfg.fs_hz)).round() as usize;
                let lo = k.saturating_sub(1);
                let hi = (k + 1).min(m.len() - 1);
                total += (lo..=hi)
                    .map(|i| m[i] - s[i])
                    .fold(f32::NEG_INFINITY, f32::max);
            }
            total / components.len().max(1) as f32
        }
        Check::CombContrast { rate } => {
            let cm = comb_contrast(meas_psd_db, cfg, rate);
            let cs = comb_contrast(sim_psd_db, cfg, rate);
            let n = cm.len().min(cs.len());
            if n < 9 {
                return 0.0;
            }
            let delta: Vec<f32> = cm.iter().zip(&cs).map(|(a, b)| a - b).collect();
            let low = delta[..3].iter().sum::<f32>() / 3.0;
            let high = delta[n - n / 3..n].iter().sum::<f32>() / (n / 3) as f32;
            (low - high).abs()
        }
        Check::Kurtosis { lo, hi } => {
            match (
                band_kurtosis(x, cfg.fs_hz, lo, hi),
                band_kurtosis(sim, cfg.fs_hz, lo, hi),
            ) {
                (Some(km), Some(ks)) => (km / ks).ln().abs(),
                _ => 0.0,
            }
        }
        Check::Ringdown { lo, hi, rate } => {
            let band = ringdown_band(lo, hi, rate);
            match (band.frequencies(x), band.frequencies(sim)) {
                (Some((a, b)), Some((c, d))) => 100.0 * ((a / b - 1.0) - (c / d - 1.0)),
                _ => 0.0,
            }
        }
        Check::Hardening { lo, hi, rate } => {
            let band = ringdown_band(lo, hi, rate);
            match (band.hardening(x), band.hardening(sim)) {
                (Some(a), Some(b)) => (100.0 * (a.slope - b.slope)) as f32,
                _ => 0.0,
            }
        }
    }
}

fn median(v: &mut [f32]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    *m
}

/// Runs of `d[k] > thr` over `bins` as `(start, end, peak)` bin indices; with
/// `bridge_single_dips` a run continues across one bin below the threshold.
fn runs_above(
    d: &[f32],
    bins: &std::ops::RangeInclusive<usize>,
    thr: f32,
    bridge_single_dips: bool,
) -> Vec<(usize, usize, usize)> {
    let (lo, hi) = (*bins.start(), *bins.end());
    let mut out = Vec::new();
    let mut k = lo;
    while k <= hi {
        if d[k] <= thr {
            k += 1;
            continue;
        }
        let (start, mut end) = (k, k);
        let mut j = k + 1;
        while j <= hi && (d[j] > thr || (bridge_single_dips && j < hi && d[j + 1] > thr)) {
            if d[j] > thr {
                end = j;
            }
            j += 1;
        }
        let peak = (start..=end)
            .max_by(|&a, &b| d[a].total_cmp(&d[b]))
            .unwrap_or(start);
        out.push((start, end, peak));
        k = end + 1;
    }
    out
}

/// Widest run of the raw residual kept as a narrow band (the smoothed residual's bands
/// are at least this wide), Hz.
pub const NARROW_BAND_MAX_HZ: f64 = 100.0;

/// Widest peak, in bins within 10 dB of its top, that is still a line.
pub const LINE_MAX_BINS: usize = 4;

/// Significant runs of `d[k]` over `bins` (bin width `df`): above
/// `median + max(6 dB, 5σ)`, σ from the MAD. Returns the components and the threshold
/// over the median.
///
/// A run is a `line` when its peak is narrow — at most [`LINE_MAX_BINS`] bins within
/// 10 dB of the peak — whatever the run's width: a strong tone's Hann leakage keeps
/// many bins above the threshold (its side lobes fall slowly), yet it is one line, not
/// a band. Otherwise it is a `band`. A run whose peak is the first or last bin of the
/// compared band is energy from outside it (`below_band` / `above_band`): reported,
/// never traced as a line or band inside it.
pub fn significant_components(
    d: &[f32],
    bins: std::ops::RangeInclusive<usize>,
    df: f64,
    shaft_hz: f64,
    domain: Domain,
) -> (Vec<Component>, f32) {
    let mut vals: Vec<f32> = bins.clone().map(|k| d[k]).collect();
    let med = median(&mut vals);
    let mut dev: Vec<f32> = bins.clone().map(|k| (d[k] - med).abs()).collect();
    let mad = 1.4826 * median(&mut dev);
    let thr = med + MIN_EXCESS_DB.max(MAD_K * mad);
    let out = runs_above(d, &bins, thr, true)
        .into_iter()
        .map(|(start, end, peak)| {
            let top = d[peak] - 10.0;
            let left = (start..peak).rev().take_while(|&k| d[k] > top).count();
            let right = (peak + 1..=end).take_while(|&k| d[k] > top).count();
            let core_bins = left + 1 + right;
            // A line's frequency between bins: the core's parabola through the dB values
            // of the peak bin and its neighbours (Hann: error under a tenth of a bin),
            // so that a line 4 Hz off a shaft order is not taken for it, and a fitted
            // tone lands on its frequency, not on the bin grid.
            let at = if core_bins <= LINE_MAX_BINS {
                f64::from(pumptwin_core::features::interpolated_peak(d, peak))
            } else {
                peak as f64
            };
            let f = at * df;
            // A peak on an edge bin is energy from outside the band only where the
            // residual keeps rising past the edge; a local maximum there is a line or
            // band of its own (a cage-rate line two bins above the low edge).
            let rises = |k: Option<usize>| k.and_then(|k| d.get(k)).is_some_and(|&v| v > d[peak]);
            let (kind, width_bins) = if peak == *bins.start() && rises(peak.checked_sub(1)) {
                (Kind::BelowBand, end - start + 1)
            } else if peak == *bins.end() && rises(Some(peak + 1)) {
                (Kind::AboveBand, end - start + 1)
            } else if core_bins <= LINE_MAX_BINS {
                (Kind::Line, core_bins)
            } else {
                (Kind::Band, end - start + 1)
            };
            Component {
                domain,
                kind,
                f_hz: f,
                width_hz: width_bins as f64 * df,
                excess_db: d[peak] - med,
                order: f / shaft_hz,
                centre_hz: (kind == Kind::Band).then_some(0.5 * (start + end) as f64 * df),
            }
        })
        .collect();
    (out, thr - med)
}

/// How far from a comb tooth a line may lie and still be the tooth's misfit: bins of
/// the spectrum, plus a fraction of the frequency. The defect rate is refined on the
/// measured comb to 1e-5 and then fitted, so the misfit lines of the twelve CWRU
/// loops lie within 0.8 bins of their teeth (570 of 627; the rest are the spread a
/// fitted speed drift allows, which the tolerance adds). Two bins plus 0.2 % (±10 Hz
/// at 2 kHz, a fifth of an outer-race comb's spacing) hid any tone that landed there.
pub(crate) const TOOTH_TOL_BINS: f64 = 1.0;
/// See [`TOOTH_TOL_BINS`].
pub(crate) const TOOTH_TOL_REL: f64 = 0.0005;

/// Is `c` one of the model's own defect lines: a tooth `k·rate` of the impact comb (of
/// the modelled defect or of a second impact train), a load-zone sideband
/// `k·rate ± m·f_mod` when the model modulates, each within [`TOOTH_TOL_BINS`] and
/// [`TOOTH_TOL_REL`] plus the spread a modelled speed drift gives tooth k over a record
/// of `span_s`? A small rate mismatch moves high-order teeth by a fraction of a bin and
/// leaves ± spikes there, which are the fault term's misfit, not a missing effect. A
/// line on a low shaft order that lies nearer the order than the tooth is not the
/// comb's (in the body).
pub fn on_model_comb(model: &TwinModel, c: &Component, df: f64, span_s: f64) -> bool {
    if c.kind != Kind::Line {
        return false;
    }
    let mut sidebands = Vec::new();
    let mut drift = 0.0;
    // (rate, load-zone sideband spacing or 0) of every impact comb the model has.
    let mut combs: Vec<(f64, f64)> = Vec::new();
    let freqs = &model.op.freqs;
    for (e, first) in &model.effects {
        match e {
            Effect::LoadZoneModulation { mod_hz } | Effect::LoadZone { mod_hz } => {
                sidebands.push(*mod_hz)
            }
            Effect::SpeedDrift { .. } => drift = model.params[*first].value.abs(),
            Effect::SecondImpactTrain { rate_hz, .. } => combs.push((
                *rate_hz,
                e.second_train_location()
                    .map_or(0.0, |loc| f64::from(freqs.modulation_rate(loc))),
            )),
            _ => {}
        }
    }
    if let Some(loc) = model.fault {
        let r = model.comb_rate_hz(loc);
        if sidebands.is_empty() {
            combs.push((r, 0.0));
        }
        // Each modulation of the impacts puts its own sidebands around the teeth.
        combs.extend(sidebands.iter().map(|&side| (r, side)));
    }
    // The distance to the nearest tooth (or sideband) within tolerance.
    let offset = combs
        .iter()
        .flat_map(|&(r, side)| {
            (-2i32..=2).filter_map(move |m| {
                if m != 0 && side == 0.0 {
                    return None;
                }
                let f = c.f_hz - f64::from(m) * side;
                let k = (f / r).round();
                let off = (f - k * r).abs();
                (k >= 1.0
                    && off
                        <= TOOTH_TOL_BINS * df
                            + TOOTH_TOL_REL * c.f_hz
                            + 0.5 * k * r * drift * span_s)
                    .then_some(off)
            })
        })
        .min_by(f64::total_cmp);
    // A line on a shaft order or half order (½–40×, within half a bin: the interpolated
    // frequency is good to a tenth of one) and nearer it than to the tooth by half a bin
    // or more is the shaft's, not the comb's misfit: a vane-pass, misalignment or
    // looseness line a bin or two from a defect harmonic (7 × 29.95 Hz = 209.7 Hz beside 2 × BPFO = 214.8 Hz at
    // 1797 rpm). A tooth that itself lies on a shaft order (a train of k impacts per
    // turn) keeps its lines.
    let half = 0.5 * f64::from(freqs.shaft);
    let k = (c.f_hz / half).round();
    let order_off = (c.f_hz - k * half).abs();
    let on_order = (1.0..=80.0).contains(&k) && order_off <= 0.5 * df;
    offset.is_some_and(|off| !(on_order && order_off + 0.5 * df < off))
}

/// Everything the tracer looks at.
#[derive(Debug, Clone)]
pub struct ResidualAnalysis {
    /// Significant PSD components.
    pub psd: Vec<Component>,
    /// Significant envelope components.
    pub envelope: Vec<Component>,
    /// Floor-relative threshold used in the PSD, dB.
    pub psd_threshold_db: f32,
    /// PSD residual `(f, measured − model dB)` for plots.
    pub psd_residual: Vec<(f32, f32)>,
}

/// Residual of the fitted model against the measurement at line resolution.
///
/// Lines come from the raw dB residual; bands from the residual smoothed over 200 Hz,
/// because a periodic impact train turns every band into a comb of lines whose
/// valleys would otherwise split it.
pub fn analyse(
    meas: &Signature,
    sim: &Signature,
    cfg: &SignatureConfig,
    shaft_hz: f64,
) -> ResidualAnalysis {
    let m = to_db(&meas.psd, &meas.psd);
    let s = to_db(&sim.psd, &meas.psd);
    let d: Vec<f32> = m.iter().zip(&s).map(|(a, b)| a - b).collect();
    let df = f64::from(cfg.fs_hz) / cfg.psd_n as f64;
    let (raw, thr) = significant_components(&d, cfg.psd_bins(), df, shaft_hz, Domain::Psd);
    // Lines, and what stands at the band's edges from outside it; bands come from the
    // smoothed residual below.
    let (narrow, mut psd): (Vec<Component>, Vec<Component>) =
        raw.into_iter().partition(|c| c.kind == Kind::Band);
    let half = ((100.0 / df).ceil() as usize).max(2);
    let bins = cfg.psd_bins();
    let smooth: Vec<f32> = (0..d.len())
        .map(|k| {
            let a = k.saturating_sub(half).max(*bins.start());
            let b = (k + half).min(*bins.end());
            if a > b {
                return 0.0;
            }
            d[a..=b].iter().sum::<f32>() / (b - a + 1) as f32
        })
        .collect();
    let (bands, _) = significant_bands(&smooth, bins, df, shaft_hz);
    // A run of the raw residual wider than a line and narrower than the bands the
    // smoothing finds (under 100 Hz: a tone whose frequency wanders with a drive's or a
    // belt's speed, a lightly damped mode): the 200 Hz smoothing dilutes it below its
    // 3 dB, so it is kept from the raw residual, where no smoothed band covers it.
    let covered = |c: &Component| {
        bands.iter().any(|b| {
            (c.f_hz - b.centre_hz.unwrap_or(b.f_hz)).abs() <= 0.5 * (b.width_hz + c.width_hz)
        })
    };
    let narrow: Vec<Component> = narrow
        .into_iter()
        .filter(|c| c.width_hz < NARROW_BAND_MAX_HZ && !covered(c))
        .collect();
    psd.extend(bands);
    psd.extend(narrow);
    let me = to_db(&meas.env, &meas.env);
    let se = to_db(&sim.env, &meas.env);
    let de: Vec<f32> = me.iter().zip(&se).map(|(a, b)| a - b).collect();
    let dfe = f64::from(cfg.fs_hz) / cfg.env_n as f64;
    let (mut envelope, _) =
        significant_components(&de, cfg.env_bins(), dfe, shaft_hz, Domain::Envelope);
    // A model that lacks a whole family of envelope lines (a second impact train and
    // its intermodulation with the first) also misplaces the floor between them, and
    // the spread that leaves in the residual (MAD 4–5 dB) lifts the 5σ threshold over
    // every line it lacks; so does a base model that fits a measured record's PSD
    // only to 7–8 dB (CWRU), over a 60 Hz mains line or a vane-pass tone 15–35 dB above
    // its neighbours. So lines are also read off the measurement itself, in both
    // domains (`prominent_lines`).
    add_lines(
        &mut envelope,
        prominent_lines(
            &me,
            &de,
            cfg.env_bins(),
            dfe,
            shaft_hz,
            Domain::Envelope,
            LINE_PROMINENCE_DB,
        ),
        dfe,
    );
    // In the PSD, up to 40 × the shaft rate (the range of the shaft-order, mains and
    // vane-pass lines the tracer models) at `LINE_PROMINENCE_DB`; above it, in the
    // structure's forest of comb teeth and sidebands, at
    // `STRUCTURE_LINE_PROMINENCE_DB`.
    let (lo, hi) = (*cfg.psd_bins().start(), *cfg.psd_bins().end());
    let top = ((40.0 * shaft_hz / df) as usize).clamp(lo, hi);
    add_lines(
        &mut psd,
        prominent_lines(
            &m,
            &d,
            lo..=top,
            df,
            shaft_hz,
            Domain::Psd,
            LINE_PROMINENCE_DB,
        ),
        df,
    );
    if top < hi {
        add_lines(
            &mut psd,
            prominent_lines(
                &m,
                &d,
                top + 1..=hi,
                df,
                shaft_hz,
                Domain::Psd,
                STRUCTURE_LINE_PROMINENCE_DB,
            ),
            df,
        );
    }
    envelope.sort_by(|a, b| a.f_hz.total_cmp(&b.f_hz));
    let envelope = envelope
        .into_iter()
        .filter(|c| c.kind != Kind::Band)
        .collect();
    psd.retain(|c| c.kind != Kind::Line || peak_of_record(&m, &d, c, df));
    let psd_residual = cfg.psd_bins().map(|k| (cfg.psd_freq(k), d[k])).collect();
    ResidualAnalysis {
        psd,
        envelope,
        psd_threshold_db: thr,
        psd_residual,
    }
}

/// How much higher (dB) the measured spectrum must stand on one flank of a line than
/// at the mirror point on the other for the flank to carry a line of its own: a line
/// widened by slip is symmetric about its centre (a Lorentzian), to the scatter of two
/// Welch bins (about 1 dB each over the residual's 30-odd segments); a tone beside it
/// adds its power on one side only (a 0.05 g tone 1.9 bins from BPFO's 28th tooth:
/// 6 dB and more, or the residual would not have held it).
pub const FLANK_ASYMMETRY_DB: f32 = 3.0;

/// Whether a residual line `c` is a line of the record and not the flank of a broader
/// one: the measured PSD `meas_db` (bin width `df`) peaks within a bin of it, or it
/// stands on a flank of the record's peak [`FLANK_ASYMMETRY_DB`] higher than the
/// mirror point across the peak's centre **and** the model has that other flank (the
/// residual `resid_db` there under [`MIN_EXCESS_DB`]). A line the model has sharper
/// than the record leaves the residual standing on both flanks of the record's
/// broader one: a defect's tooth that the rolling elements' slip widens (each interval
/// `T(1 + σz)`, so the timing is a random walk and tooth `k` a Lorentzian of
/// half-width `π k² σ² f_d`, Randall & Antoni 2011) against the model's sharp tooth.
/// Such a tooth is a hump with a noisy, flat and often skewed top (its highest bin
/// anywhere on it, one flank 3–4 dB above the other's mirror on the benchmark's dev
/// controls), so the record's shape alone cannot tell a tone on its flank from the
/// hump's own skew; the model's other flank can. What this gives up: a tone on the
/// flank of a tooth the model has narrower than the record is read only once the
/// model has the tooth's width.
///
/// On the randomized benchmark's dev controls (`--seed 1`): lines 7–10 Hz either side
/// of BPFO's 3rd to 10th teeth were read as unexplained tones and shaft-order tones on
/// 5 of 77 with no flank test; with the flank test across the peak's highest bin, on
/// 2 (its 5th–14th teeth); with this one, on none.
fn peak_of_record(meas_db: &[f32], resid_db: &[f32], c: &Component, df: f64) -> bool {
    let k = (c.f_hz / df).round() as usize;
    let at = |j: usize| meas_db.get(j).copied();
    let local_max = |j: usize| match (j.checked_sub(1).and_then(at), at(j), at(j + 1)) {
        (Some(b), Some(v), Some(a)) => v >= b && v >= a,
        _ => false,
    };
    if (k.saturating_sub(1)..=k + 1).any(local_max) {
        return true;
    }
    let (Some(level), Some(centre)) = (at(k), peak_centre(meas_db, k)) else {
        return false;
    };
    let mirror = 2.0 * centre - k as f64;
    match (interpolate(meas_db, mirror), interpolate(resid_db, mirror)) {
        (Some(m), Some(r)) => level - m >= FLANK_ASYMMETRY_DB && r < MIN_EXCESS_DB,
        _ => true,
    }
}

/// How far below its top the record's peak is read for its centre, dB: the width at a
/// quarter of the power, where a Lorentzian tooth's flanks still stand well over the
/// noise between teeth.
const HUMP_EDGE_DB: f32 = 6.0;

/// The centre (fractional bin) of the peak of `db` whose flank bin `k` is on: climb
/// to the top, then the midpoint of where `db` falls [`HUMP_EDGE_DB`] below it on
/// each side (linearly interpolated between bins; the spectrum's ends where it does
/// not fall that far).
fn peak_centre(db: &[f32], k: usize) -> Option<f64> {
    let p = climb_to_peak(db, k)?;
    let edge = db[p] - HUMP_EDGE_DB;
    // Where the fall crosses `edge` between bin `inner` (above) and `outer`.
    let crossing = |inner: usize, outer: usize| {
        let (a, b) = (db[inner], db[outer]);
        let t = if a > b {
            ((a - edge) / (a - b)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        inner as f64 + f64::from(t) * (outer as f64 - inner as f64)
    };
    let left = (0..p)
        .rev()
        .find(|&j| db[j] <= edge)
        .map_or(0.0, |j| crossing(j + 1, j));
    let right = (p + 1..db.len())
        .find(|&j| db[j] <= edge)
        .map_or((db.len() - 1) as f64, |j| crossing(j - 1, j));
    Some(0.5 * (left + right))
}

/// The top of the peak of `v` whose flank bin `k` is on: from `k`, uphill bin by bin
/// (towards the higher neighbour above, else downwards) while the next bin is higher;
/// `None` where `k` is outside `v`. Reads dB or power alike (only the order counts).
pub(crate) fn climb_to_peak(v: &[f32], k: usize) -> Option<usize> {
    let at = |j: usize| v.get(j).copied();
    let level = at(k)?;
    let up = at(k + 1).is_some_and(|a| a > level);
    let mut p = k;
    while let Some(next) = if up {
        p.checked_add(1)
    } else {
        p.checked_sub(1)
    } {
        match (at(next), at(p)) {
            (Some(n), Some(c)) if n > c => p = next,
            _ => break,
        }
    }
    Some(p)
}

/// `db` at fractional bin `x`, linear between bins; `None` outside.
fn interpolate(db: &[f32], x: f64) -> Option<f32> {
    if x.is_nan() || x < 0.0 {
        return None;
    }
    let i = x.floor() as usize;
    let t = (x - i as f64) as f32;
    let a = *db.get(i)?;
    Some(db.get(i + 1).map_or(a, |&b| a + t * (b - a)))
}

/// The lines of a measured spectrum `meas_db` that stand `prominence_db` over its own
/// median within ±40 Hz (at [`LINE_PROMINENCE_DB`], noise alone: a chance below 1e-3
/// per bin even for one Welch segment) and that the model lacks by `MIN_EXCESS_DB` or
/// more (`resid_db`, measured − model).
fn prominent_lines(
    meas_db: &[f32],
    resid_db: &[f32],
    bins: std::ops::RangeInclusive<usize>,
    df: f64,
    shaft_hz: f64,
    domain: Domain,
    prominence_db: f32,
) -> Vec<Component> {
    let prominence = local_detrend(meas_db, bins.clone(), (40.0 / df).round() as usize);
    let gated: Vec<f32> = resid_db
        .iter()
        .zip(&prominence)
        .map(|(&d, &p)| if p >= prominence_db { d.max(0.0) } else { 0.0 })
        .collect();
    let (lines, _) = significant_components(&gated, bins, df, shaft_hz, domain);
    lines.into_iter().filter(|c| c.kind == Kind::Line).collect()
}

/// Add the `extra` lines that no component of `to` already stands within two bins of.
fn add_lines(to: &mut Vec<Component>, extra: Vec<Component>, df: f64) {
    for c in extra {
        if to.iter().all(|e| (e.f_hz - c.f_hz).abs() > 2.0 * df) {
            to.push(c);
        }
    }
}

/// `d` less its running median over `±half` bins inside `bins` (0 outside them).
fn local_detrend(d: &[f32], bins: std::ops::RangeInclusive<usize>, half: usize) -> Vec<f32> {
    let (lo, hi) = (*bins.start(), *bins.end());
    let mut out = vec![0.0f32; d.len()];
    let mut window = Vec::with_capacity(2 * half + 1);
    for k in bins {
        let a = k.saturating_sub(half).max(lo);
        let b = (k + half).min(hi);
        window.clear();
        window.extend_from_slice(&d[a..=b]);
        out[k] = d[k] - median(&mut window);
    }
    out
}

/// Bands of the smoothed residual: runs at least 100 Hz wide more than 3 dB above its
/// median. A fixed 3 dB, not a MAD multiple: the smoothed residual of a structurally
/// wrong model has a large MAD, which would hide exactly the bands that matter.
fn significant_bands(
    d: &[f32],
    bins: std::ops::RangeInclusive<usize>,
    df: f64,
    shaft_hz: f64,
) -> (Vec<Component>, f32) {
    let mut vals: Vec<f32> = bins.clone().map(|k| d[k]).collect();
    let med = median(&mut vals);
    let thr = med + 3.0;
    let out = runs_above(d, &bins, thr, false)
        .into_iter()
        .filter(|(start, end, _)| (end - start + 1) as f64 * df >= 100.0)
        .map(|(start, end, peak)| {
            let f = peak as f64 * df;
            Component {
                domain: Domain::Psd,
                kind: Kind::Band,
                f_hz: f,
                width_hz: (end - start + 1) as f64 * df,
                excess_db: d[peak] - med,
                order: f / shaft_hz,
                centre_hz: Some(0.5 * (start + end) as f64 * df),
            }
        })
        .collect();
    (out, thr - med)
}

/// Contrast (dB) of each defect-comb tooth `k·rate` over the PSD midway between teeth,
/// for `k = 1..` up to the compared band: a periodic impact train has sharp teeth at
/// every order; timing jitter (slip) or a drifting speed washes out the high orders.
pub fn comb_contrast(psd_db: &[f32], cfg: &SignatureConfig, rate_hz: f64) -> Vec<f32> {
    let df = f64::from(cfg.fs_hz) / cfg.psd_n as f64;
    let top = f64::from(cfg.psd_hi_hz);
    let at = |f: f64, spread: usize| -> f32 {
        let k = (f / df).round() as usize;
        let lo = k.saturating_sub(spread);
        let hi = (k + spread).min(psd_db.len() - 1);
        psd_db[lo..=hi]
            .iter()
            .cloned()
            .fold(f32::NEG_INFINITY, f32::max)
    };
    let mut out = Vec::new();
    let mut k = 1.0;
    while (k + 0.5) * rate_hz < top {
        let tooth = at(k * rate_hz, 1);
        let valley = 0.5 * (at((k - 0.5) * rate_hz, 0) + at((k + 0.5) * rate_hz, 0));
        out.push(tooth - valley);
        k += 1.0;
    }
    out
}

/// Envelope spectrum of `x` restricted to the band `[lo, hi]` (FFT-domain band-pass),
/// Welch-averaged over blocks of `n`. Returns `(spectrum, df)`.
pub(crate) fn band_envelope_spectrum(
    x: &[f32],
    fs: f32,
    lo: f32,
    hi: f32,
    n: usize,
) -> Option<(Vec<f32>, f32)> {
    let band = EnvelopeBand {
        lo_hz: lo,
        hi_hz: hi,
    };
    let mut scratch = vec![Complex32::ZERO; n];
    let mut env = vec![0.0f32; n];
    let spec = welch(x, n, |block, out| {
        envelope(block, fs, band, &mut scratch, &mut env)?;
        let mean = env.iter().sum::<f32>() / n as f32;
        for (z, e) in scratch.iter_mut().zip(&env) {
            *z = Complex32::new(e - mean, 0.0);
        }
        fft_in_place(&mut scratch, Direction::Forward)?;
        for (o, z) in out.iter_mut().zip(&scratch) {
            *o = z.norm_sqr();
        }
        Ok(())
    })
    .ok()?;
    Some((spec, fs / n as f32))
}

/// Level (dB over the median) of the strongest line within ±tol of `f` in a spectrum.
fn line_level_db(spec: &[f32], df: f32, f: f32, tol: f32) -> f32 {
    let hi_bin = ((4.0 * f / df) as usize).min(spec.len() - 1).max(4);
    let mut v: Vec<f32> = spec[1..=hi_bin].to_vec();
    let floor = median(&mut v).max(f32::MIN_POSITIVE);
    let lo = (((f - tol) / df).floor() as usize).max(1);
    let hi = (((f + tol) / df).ceil() as usize).min(spec.len() - 1);
    let peak = spec[lo..=hi].iter().cloned().fold(0.0f32, f32::max);
    10.0 * (peak / floor).log10()
}

/// Does the measured band `[lo, hi]` carry the defect's impacts? Envelope line level at
/// the impact rate, dB over the floor (envelope spectrum Welch-averaged over blocks of `n`).
pub fn band_carries_defect(x: &[f32], fs: f32, lo: f32, hi: f32, rate_hz: f32, n: usize) -> f32 {
    match band_envelope_spectrum(x, fs, lo.max(1.0), hi.min(0.49 * fs), n) {
        Some((spec, df)) => line_level_db(&spec, df, rate_hz, (0.02 * rate_hz).max(df)),
        None => 0.0,
    }
}

/// How much less the defect's rhythm (`rate_hz`) stands out of the envelope of the
/// record `x` than of the model's `sim` in the band `[lo, hi]` Hz, dB
/// ([`band_carries_defect`] of each): a mode the impacts ring carries it as the rest of
/// the response does; noise added at the sensor in that band dilutes it.
pub fn rhythm_dilution_db(
    sim: &[f32],
    x: &[f32],
    fs: f32,
    (lo, hi): (f32, f32),
    rate_hz: f32,
    n: usize,
) -> f32 {
    band_carries_defect(sim, fs, lo, hi, rate_hz, n)
        - band_carries_defect(x, fs, lo, hi, rate_hz, n)
}

/// Kurtosis of `x` band-passed to `[lo, hi]` Hz ([`band_moments`]), or `None` for an
/// empty band. A Gaussian band reads 3; a band carried by isolated bursts reads far more.
pub fn band_kurtosis(x: &[f32], fs: f32, lo: f32, hi: f32) -> Option<f32> {
    let (m2, m4) = *band_moments(x, fs, &[(lo, hi)])?.first()?;
    (m2 > 0.0).then(|| (m4 / (m2 * m2)) as f32)
}

/// The second and fourth moments `(m2, m4)` of `x` band-passed to each of `bands`
/// (Hz): FFT-domain, over the whole record zero-padded to a power of two, from one
/// forward transform. `None` where a transform fails.
pub fn band_moments(x: &[f32], fs: f32, bands: &[(f32, f32)]) -> Option<Vec<(f64, f64)>> {
    let n = x.len().next_power_of_two();
    let mut spectrum: Vec<Complex32> = x
        .iter()
        .map(|&v| Complex32::new(v, 0.0))
        .chain(std::iter::repeat(Complex32::ZERO))
        .take(n)
        .collect();
    fft_in_place(&mut spectrum, Direction::Forward).ok()?;
    let df = fs / n as f32;
    let mut z = vec![Complex32::ZERO; n];
    bands
        .iter()
        .map(|&(lo, hi)| {
            for (k, (out, &v)) in z.iter_mut().zip(&spectrum).enumerate() {
                let f = k.min(n - k) as f32 * df;
                *out = if f < lo || f > hi { Complex32::ZERO } else { v };
            }
            fft_in_place(&mut z, Direction::Inverse).ok()?;
            let y = &z[..x.len()];
            let m2 = y.iter().map(|v| f64::from(v.re).powi(2)).sum::<f64>() / y.len() as f64;
            let m4 = y.iter().map(|v| f64::from(v.re).powi(4)).sum::<f64>() / y.len() as f64;
            Some((m2, m4))
        })
        .collect()
}

/// The envelope of `x` band-passed to `[lo, hi]` Hz (the core's analytic-signal
/// [`envelope`] over the whole record zero-padded to a power of two), or `None` for
/// an empty band or a non-finite sample.
fn band_envelope(x: &[f32], fs: f32, lo: f32, hi: f32) -> Option<Vec<f32>> {
    let n = x.len().next_power_of_two();
    let mut padded = x.to_vec();
    padded.resize(n, 0.0);
    let mut scratch = vec![Complex32::ZERO; n];
    let mut env = vec![0.0f32; n];
    let band = EnvelopeBand {
        lo_hz: lo,
        hi_hz: hi,
    };
    envelope(&padded, fs, band, &mut scratch, &mut env).ok()?;
    env.truncate(x.len());
    env.iter().any(|&v| v > 0.0).then_some(env)
}

/// How well the strongest events of `x` in `[lo, hi]` Hz keep the rhythm of impacts at
/// `rate_hz`: the median, over the strongest tenth of the envelope's events (at least
/// eight; events are local maxima half a period apart at least), of
/// `ln(neighbour / median envelope)`, `neighbour` the lower of the envelope's highest
/// values one period before and one after the event (±5 %, which slip of 1–2 % and a
/// slow drift stay within). A train of impacts, however their strengths spread, has
/// an impact a period either side of each of its strongest; a burst at a random time
/// finds the train's impacts (or their ring-downs) on both sides only by chance.
/// `None` for an empty band or too few events.
pub fn event_rhythm(x: &[f32], fs: f32, lo: f32, hi: f32, rate_hz: f32) -> Option<f32> {
    if rate_hz.is_nan() || rate_hz <= 0.0 {
        return None;
    }
    let e = band_envelope(x, fs, lo, hi)?;
    let period = fs / rate_hz;
    let half = (0.5 * period).max(1.0) as usize;
    let tol = (0.05 * period).max(1.0) as usize;
    let reach = period.round() as usize + tol;
    // Events: local maxima, each the highest within half a period after it.
    let mut events: Vec<(usize, f32)> = Vec::new();
    let mut i = reach;
    while i + half + reach < e.len() {
        let end = i + half;
        let (j, v) = e[i..end]
            .iter()
            .enumerate()
            .fold((0, f32::MIN), |b, (k, &v)| if v > b.1 { (k, v) } else { b });
        events.push((i + j, v));
        i += j.max(1) + half;
    }
    if events.len() < 16 {
        return None;
    }
    let mut levels: Vec<f32> = e.clone();
    let floor = median(&mut levels).max(f32::MIN_POSITIVE);
    events.sort_by(|a, b| b.1.total_cmp(&a.1));
    let top = (events.len() / 10).max(8);
    let t = period.round() as usize;
    let mut scores: Vec<f32> = events[..top]
        .iter()
        .map(|&(at, _)| {
            let around = |c: usize| e[c - tol..=c + tol].iter().fold(0.0f32, |m, &v| m.max(v));
            let neighbour = around(at - t).min(around(at + t));
            (neighbour / floor).ln()
        })
        .collect();
    Some(median(&mut scores))
}

/// The rate within `±rel` of `rate` whose harmonic comb collects the most log power in
/// the line-resolution PSD up to its upper limit (a periodic impact train puts lines at
/// every k·rate), on a grid of 1e-5 relative steps.
pub fn refine_comb_rate(psd_db: &[f32], cfg: &SignatureConfig, rate: f64, rel: f64) -> f64 {
    let df = f64::from(cfg.fs_hz) / cfg.psd_n as f64;
    let comb = Comb {
        top_hz: f64::from(cfg.psd_hi_hz),
        harmonics: usize::MAX,
        step: 1e-5,
    };
    comb.best_rate(psd_db, df, rate, rel)
}

/// A harmonic comb search: the rate whose lines `k·rate` (`k = 1..=harmonics`, below
/// `top_hz`) collect the most mean log power in a spectrum, on a grid of `step`
/// relative steps.
struct Comb {
    top_hz: f64,
    harmonics: usize,
    step: f64,
}

impl Comb {
    fn best_rate(&self, spec_db: &[f32], df: f64, rate: f64, rel: f64) -> f64 {
        let score = |r: f64| -> f64 {
            let mut s = 0.0;
            let mut k = 1.0f64;
            while k * r < self.top_hz && k as usize <= self.harmonics {
                let pos = k * r / df;
                let i = pos.floor() as usize;
                let frac = pos - i as f64;
                if i + 1 < spec_db.len() {
                    s += f64::from(spec_db[i]) * (1.0 - frac) + f64::from(spec_db[i + 1]) * frac;
                }
                k += 1.0;
            }
            s / (k - 1.0).max(1.0)
        };
        let steps = (rel / self.step).round() as i64;
        let mut best = (rate, f64::NEG_INFINITY);
        for i in -steps..=steps {
            let r = rate * (1.0 + i as f64 * self.step);
            let sc = score(r);
            if sc > best.1 {
                best = (r, sc);
            }
        }
        best.0
    }
}

/// Harmonics of an impact rate that [`envelope_comb_rate`] reads: the comb's low
/// orders, where slip (a tooth's half-width grows as `k²`) still leaves lines.
const RATE_COMB_HARMONICS: usize = 5;

/// The impact rate within ±3 % of `rate` Hz in `x`: the rate whose comb of envelope
/// lines (its first [`RATE_COMB_HARMONICS`] harmonics inside the envelope's reach,
/// 0.9 of the band's width) collects the most log power, on 1e-4 relative steps.
/// Reading the whole comb, not one tooth, keeps the estimate on the train where one
/// tooth is weak (a rolling element's comb, whose odd half-orders take its power) or
/// smeared by slip. `None` for an empty band or a rate beyond the envelope's reach.
pub(crate) fn envelope_comb_rate(
    x: &[f32],
    fs: f32,
    band: EnvelopeBand,
    rate: f32,
    n: usize,
) -> Option<f32> {
    const REL: f32 = 0.03;
    let (spec, df) = band_envelope_spectrum(x, fs, band.lo_hz, band.hi_hz, n)?;
    let top = (0.9 * (band.hi_hz - band.lo_hz)).min(0.5 * fs);
    if !(rate > 0.0 && rate * (1.0 + REL) < top) {
        return None;
    }
    let comb = Comb {
        top_hz: f64::from(top),
        harmonics: RATE_COMB_HARMONICS,
        step: 1e-4,
    };
    let db = to_db(&spec, &spec);
    Some(comb.best_rate(&db, f64::from(df), f64::from(rate), f64::from(REL)) as f32)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A Gaussian band reads a kurtosis of 3, a band carried by isolated ring-downs far
    /// more, and a steady tone 1.5.
    #[test]
    fn band_kurtosis_tells_noise_bursts_and_tones_apart() {
        let fs = 12_000.0;
        let mut rng = pumptwin_core::rng::Xoshiro128pp::seed_from_u64(3);
        let noise: Vec<f32> = (0..72_000).map(|_| rng.normal() as f32).collect();
        let k = band_kurtosis(&noise, fs, 2000.0, 2600.0).expect("kurtosis");
        assert!((k - 3.0).abs() < 0.2, "Gaussian band: {k}");
        let mut bursts = vec![0.0f32; 72_000];
        for start in (0..72_000 - 600).step_by(1500) {
            for (j, v) in bursts[start..start + 600].iter_mut().enumerate() {
                let t = j as f32 / fs;
                *v += (-t * 1500.0).exp() * (2.0 * std::f32::consts::PI * 2300.0 * t).sin();
            }
        }
        let k = band_kurtosis(&bursts, fs, 2000.0, 2600.0).expect("kurtosis");
        assert!(k > 6.0, "bursts: {k}");
        let tone: Vec<f32> = (0..72_000)
            .map(|j| (2.0 * std::f32::consts::PI * 2300.0 * j as f32 / fs).sin())
            .collect();
        let k = band_kurtosis(&tone, fs, 2000.0, 2600.0).expect("kurtosis");
        assert!((k - 1.5).abs() < 0.1, "tone: {k}");
    }

    /// The comb's rate is read off the whole comb: a rolling element's train whose
    /// strikes alternate strong and weak (half-rate lines between the teeth), its
    /// intervals jittered by 1 % and its rate 1.2 % off the one asked about, in
    /// noise, is read within 0.1 % — and the same train at the asked rate too.
    #[test]
    fn envelope_comb_rate_reads_an_alternating_jittered_train() {
        let fs = 12_000.0;
        let band = EnvelopeBand {
            lo_hz: 1_500.0,
            hi_hz: 3_100.0,
        };
        for offset in [0.012f32, 0.0] {
            let nominal = 141.0f32;
            let rate = nominal * (1.0 + offset);
            let mut rng = pumptwin_core::rng::Xoshiro128pp::seed_from_u64(7);
            let mut x: Vec<f32> = (0..48_000).map(|_| 0.2 * rng.normal() as f32).collect();
            let mut times = Vec::new();
            let mut t = 0.003f32;
            let mut k = 0usize;
            while t < 3.9 {
                times.push((t, if k % 2 == 0 { 1.0 } else { 0.4 }));
                t += (1.0 + 0.01 * rng.normal() as f32) / rate;
                k += 1;
            }
            ring(&mut x, fs, times.into_iter());
            let got = envelope_comb_rate(&x, fs, band, nominal, 16_384).expect("rate");
            assert!(
                (got / rate - 1.0).abs() < 1e-3,
                "offset {offset}: read {got} Hz for {rate} Hz"
            );
        }
    }

    /// `x` plus a ring-down at 2.3 kHz of amplitude `a` at each of `times` (s).
    pub(crate) fn ring(x: &mut [f32], fs: f32, times: impl Iterator<Item = (f32, f32)>) {
        for (t0, a) in times {
            let i0 = (t0 * fs) as usize;
            for (j, v) in x.iter_mut().skip(i0).take(300).enumerate() {
                let t = j as f32 / fs;
                *v += a * (-t * 900.0).exp() * (2.0 * std::f32::consts::PI * 2300.0 * t).sin();
            }
        }
    }

    /// Impacts at 40/s whose strengths spread 30 % (a slip of 1 %) keep their rhythm
    /// however impulsive; the same with as strong bursts at random times added do not.
    #[test]
    fn the_strongest_events_keep_the_rhythm_of_a_train_and_not_of_bursts() {
        let (fs, rate, n) = (12_000.0f32, 40.0f32, 72_000usize);
        let mut rng = pumptwin_core::rng::Xoshiro128pp::seed_from_u64(5);
        let mut x: Vec<f32> = (0..n).map(|_| 0.05 * rng.normal() as f32).collect();
        let mut t = 0.01f32;
        let mut train = Vec::new();
        while t < n as f32 / fs - 0.05 {
            train.push((t, (1.0 + 0.3 * rng.normal() as f32).max(0.0)));
            t += (1.0 + 0.01 * rng.normal() as f32) / rate;
        }
        ring(&mut x, fs, train.into_iter());
        let kept = event_rhythm(&x, fs, 1500.0, 3500.0, rate).expect("rhythm");
        let mut with_bursts = x.clone();
        let bursts: Vec<(f32, f32)> = (0..30)
            .map(|_| (0.05 + 5.8 * rng.uniform() as f32, 2.5))
            .collect();
        ring(&mut with_bursts, fs, bursts.into_iter());
        let broken = event_rhythm(&with_bursts, fs, 1500.0, 3500.0, rate).expect("rhythm");
        assert!(kept > 2.0, "train: {kept}");
        assert!(kept - broken > 1.0, "train {kept}, with bursts {broken}");
        // Too little record for 16 events, or no rate: nothing to say.
        assert_eq!(event_rhythm(&x[..3_000], fs, 1500.0, 3500.0, rate), None);
        assert_eq!(event_rhythm(&x, fs, 1500.0, 3500.0, 0.0), None);
    }

    fn line_at(f_hz: f64) -> Component {
        Component {
            domain: Domain::Psd,
            kind: Kind::Line,
            f_hz,
            width_hz: 1.0,
            excess_db: 10.0,
            order: 1.0,
            centre_hz: None,
        }
    }

    /// A residual line on the flank of a broad symmetric peak is not a line of the
    /// record; a tone standing on that flank, or a peak of its own, is, where the
    /// model has the peak's other flank; where the model lacks both flanks, even a
    /// skewed peak's higher flank is the peak's.
    #[test]
    fn a_line_on_the_flank_of_a_broader_one_is_not_the_records() {
        // A Lorentzian tooth at bin 50, half-width 1.5 bins, 30 dB over the floor.
        let tooth: Vec<f32> = (0..100)
            .map(|k| {
                let d = (k as f32 - 50.0) / 1.5;
                10.0 * (1e-3 + 1.0 / (1.0 + d * d)).log10()
            })
            .collect();
        let none = vec![0.0f32; 100];
        assert!(!peak_of_record(&tooth, &none, &line_at(53.0), 1.0));
        assert!(!peak_of_record(&tooth, &none, &line_at(47.0), 1.0));
        assert!(peak_of_record(&tooth, &none, &line_at(50.0), 1.0));
        // A tone 6 dB over the flank at bin 53, even where it is no local maximum.
        let mut with_tone = tooth.clone();
        with_tone[53] += 6.0;
        assert!(peak_of_record(&with_tone, &none, &line_at(53.0), 1.0));
        with_tone[54] = with_tone[53] + 1.0;
        with_tone[55] = with_tone[54] + 1.0;
        with_tone[56] = with_tone[55] + 1.0;
        // Now a peak of its own rises to bin 56: that peak is the record's line, and
        // bin 53 on its flank is not a second one.
        assert!(peak_of_record(&with_tone, &none, &line_at(56.0), 1.0));
        assert!(!peak_of_record(&with_tone, &none, &line_at(53.0), 1.0));
        // A flat-topped, skewed hump (bins 49–51 level, the upper flank 4 dB high) and
        // a model with a sharp tooth: the residual stands 10 dB on both flanks.
        let hump: Vec<f32> = tooth
            .iter()
            .enumerate()
            .map(|(k, &v)| match k {
                49..=51 => tooth[50],
                52.. => v + 4.0f32.min(tooth[50] - v),
                _ => v,
            })
            .collect();
        let both = vec![10.0f32; 100];
        assert!(!peak_of_record(&hump, &both, &line_at(53.0), 1.0));
        assert!(!peak_of_record(&hump, &both, &line_at(54.0), 1.0));
        // Out of range: never a panic.
        assert!(!peak_of_record(&tooth, &none, &line_at(500.0), 1.0));
    }
}
