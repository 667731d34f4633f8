//! The loop's first fit: the fault hypothesis from the envelope spectrum; the
//! structure's modes identified on the measured PSD for each of the sensor's two
//! readings (`modal`: up to [`MAX_BASE_MODES`] modes, their damping and shares of the
//! force, from a formula fitted in microseconds); the base model started from them
//! (and, where the structure is one mode, from the PSD's strongest peak too), the
//! impacts scaled to the record's RMS, the defect rate read off the spectral comb,
//! then eq. 10; the identified modes that are noise at the sensor rather than modes
//! the impacts ring dropped; then the base completed with what every bearing signal
//! has (issue 32, Randall & Antoni 2011 §2) where the record shows it: further modes
//! where the model still falls short of the measured PSD, the load zone of a rotating
//! race or a rolling element (Harris's, with its harmonics), the rolling elements'
//! slip jitter and the spread of their impacts' strengths. These are the base's terms
//! (`base_terms` in the report, their values in `params_initial`), not effects: an
//! effect is what a particular machine adds.
//!
//! Measured on the randomized benchmark (`pumptwin twin bench --cases 300 --seed 1`,
//! the development seed; `docs/closed-loop-bench.md`): with the sensor's two readings
//! and the completed base the first fit's PSD error on clean controls fell from 9.40×
//! the record's half-to-half scatter (one mode read on its mass line, nothing
//! completed) to 2.83× (median), and the controls with a false claim from 58 % to
//! 35 % (held-out `--seed 2`: 9.48× → 3.28×, 68 % → 32 %). With the structure
//! identified on the PSD, the slip started from the best of four values and the load
//! zone's second start matched to the record's kurtosis, see `docs/closed-loop-bench.md`
//! for the figures now. The completion once cost a probe (vane tones on CWRU 234 read
//! as a force): with the housing's reading it no longer does.

use super::hypothesis;
use super::modal::{self, mode_search_bins, psd_peaks, MIN_BASE_MODE_ZETA, MODE_SPACING};
use super::setup::Setup;
use super::types::LoopError;
use crate::fit::{evaluate, fit, FitConfig, FitError, FitResult, Target};
use crate::residual::{climb_to_peak, refine_comb_rate, rhythm_dilution_db};
use crate::signature::{to_db, Signature};
use crate::trace::context::BAND_DILUTION_DB;
use crate::twin::{Effect, EffectKind, OperatingPoint, TwinModel};
use pumptwin_core::bearing::DefectLocation;

/// The first fit and what led to it.
#[derive(Debug)]
pub(super) struct FirstFit {
    /// The fault hypothesis (`None`: healthy).
    pub(super) fault: Option<DefectLocation>,
    /// The envelope levels behind it.
    pub(super) fault_evidence: serde_json::Map<String, serde_json::Value>,
    /// The fitted base model.
    pub(super) result: FitResult,
    /// The terms the base was completed with (effect names).
    pub(super) base_terms: Vec<String>,
    /// Model evaluations it cost.
    pub(super) evaluations: usize,
}

/// Fit the base model to the record of `s`.
pub(super) fn first_fit(s: &Setup<'_>) -> Result<FirstFit, LoopError> {
    let (fault, fault_evidence) = fault_hypothesis(s);
    let factor = fault.map(|loc| refine_rate(&s.target_res, s.op.freqs.impact_rate(loc)));
    let mut evaluations = 0;
    let mut best: Option<FitResult> = None;
    // The sensor's two readings, each from its starts, fitted on half the
    // iterations (a reading whose identified structure fits the PSD worse than the
    // other's by `READING_RATIO` is not fitted); the best fit then goes on to the end.
    let half = base_fit_config(s);
    let structures = MASS_LINE_CHOICES.map(|mass_line| structure_for(s, fault, mass_line));
    let best_structure = structures
        .iter()
        .map(|st| st.cost)
        .fold(f64::INFINITY, f64::min);
    for (mass_line, structure) in MASS_LINE_CHOICES.into_iter().zip(&structures) {
        if structure.cost > READING_RATIO * best_structure {
            continue;
        }
        let (modal, spent) =
            initial_model(&s.target, s.op, fault, mass_line, structure, &s.fit_cfg)?;
        evaluations += spent;
        let mut starts = vec![modal];
        // Where the structure is one mode, the peak's start too (see `peak_start`).
        if starts[0].mode_frequencies().len() == 1 {
            let (peak, spent) = peak_start(&s.target, s.op, fault, mass_line, &s.fit_cfg)?;
            evaluations += spent;
            starts.push(peak);
        }
        for mut start in starts {
            if let (Some(p), Some(factor)) = (
                start.params.iter_mut().find(|p| p.name == "rate_factor"),
                factor,
            ) {
                p.value = factor;
            }
            let result = fit(&start, &s.target, &half)?;
            evaluations += result.evaluations;
            if best.as_ref().is_none_or(|b| result.cost < b.cost) {
                best = Some(result);
            }
        }
    }
    let (start, scanned) = floor_start(s, &best.expect("two readings fitted").model)?;
    evaluations += scanned;
    let result = fit(&start, &s.target, &s.fit_cfg)?;
    evaluations += result.evaluations;
    let (result, used) = without_sensor_noise(s, result, evaluations)?;
    evaluations += used;
    let (result, terms, more) = complete_base(s, result, evaluations)?;
    // Every further mode of the first fit is the base's, whether identified before
    // the simulated fit or added by the completion; the structure's low corner too.
    let corner = result.model.floor_corner_hz();
    let base_terms = corner
        .map(|f| format!("{LOW_CORNER_TERM}@{f:.0}Hz"))
        .into_iter()
        .chain(
            result.model.mode_frequencies()[1..]
                .iter()
                .map(|f| format!("extra_resonance@{f:.0}Hz")),
        )
        .chain(terms)
        .collect();
    Ok(FirstFit {
        fault,
        fault_evidence,
        result,
        base_terms,
        evaluations: evaluations + more,
    })
}

/// `fitted` without the further modes that are noise at the sensor
/// ([`noise_at_the_sensor`]), each taken out (last first) and the rest refitted. The
/// modes were identified on the PSD alone ([`modal::identify`]), which cannot tell a
/// mode the impacts ring from a band of noise added at the sensor (a pump's flow
/// noise, cavitation, a neighbour's broadband): the envelope can. Returns the model
/// and the evaluations spent (within what the loop's budget leaves after `spent`).
fn without_sensor_noise(
    s: &Setup<'_>,
    mut fitted: FitResult,
    spent: usize,
) -> Result<(FitResult, usize), LoopError> {
    let mut evaluations = 0;
    let modes: Vec<usize> = fitted
        .model
        .effects
        .iter()
        .enumerate()
        .filter(|(_, (e, _))| e.kind() == EffectKind::ExtraResonance)
        .map(|(i, _)| i)
        .collect();
    for &i in modes.iter().rev() {
        evaluations += 1;
        if !noise_at_the_sensor(s, &fitted.model, i)? {
            continue;
        }
        let cfg = FitConfig {
            max_evaluations: s.cfg.max_evaluations.saturating_sub(spent + evaluations),
            ..base_fit_config(s)
        };
        fitted = fit(&fitted.model.without_effect(i), &s.target, &cfg)?;
        evaluations += fitted.evaluations;
    }
    Ok((fitted, evaluations))
}

/// Is the `i`-th effect of `model` (a further mode) where the record has noise added
/// at the sensor rather than a mode the impacts ring? With a fault, a mode's band
/// carries the defect's rhythm in its envelope as the rest of the response does; a
/// band of noise dilutes it: the record's envelope line in the mode's half-power band
/// stands lower over its floor than the model's by [`BAND_DILUTION_DB`] or more (the
/// tracer's test of a band, `trace::bands`). Without a fault nothing can tell the two.
fn noise_at_the_sensor(s: &Setup<'_>, model: &TwinModel, i: usize) -> Result<bool, FitError> {
    let (Some(loc), Some((_, first))) = (model.fault, model.effects.get(i)) else {
        return Ok(false);
    };
    let (f, zeta) = (
        model.params[*first].value.exp(),
        model.params[first + 1].value.exp(),
    );
    let half = (2.0 * zeta * f).max(100.0);
    let (lo, hi) = ((f - half) as f32, (f + half) as f32);
    let rate = s.op.freqs.impact_rate(loc);
    let fs = s.op.fs_hz;
    let sim = model.render(s.fit_cfg.n_sim, s.fit_cfg.seed)?;
    let n = s.sig_fit.env_n;
    let dilution = rhythm_dilution_db(&sim, &s.x, fs, (lo, hi), rate, n);
    Ok(dilution >= BAND_DILUTION_DB)
}

/// Most further structural modes the base takes (a machine's casing and foundation
/// show 1–3 within a bearing's band).
pub const MAX_BASE_MODES: usize = 3;

/// Complete the fitted base with the terms every bearing signal has, each kept where it
/// lowers the fit's cost by the loop's `min_relative_gain` (as an effect must). First
/// the structure, one mode at a time where the model falls shortest of the measured
/// PSD ([`shortfall_peaks`]), each damped at least
/// [`MIN_BASE_MODE_ZETA`]: modes are a spectrum's largest features, and fitted after
/// the impacts' character a missing mode's misfit is partly taken up by slip and
/// spread, so the mode no longer pays. Then the load zone of a rotating race or rolling
/// element, then slip jitter and strength spread. The completion shares the loop's
/// evaluation budget (`LoopConfig::max_evaluations`) with the first fit, which has
/// spent `spent` of it, and with the effects after it: the base comes first, and where
/// the budget ends the base ends too (a term under way is judged where its fit
/// stands). Returns the model, the terms kept and the evaluations spent.
fn complete_base(
    s: &Setup<'_>,
    mut current: FitResult,
    spent: usize,
) -> Result<(FitResult, Vec<String>, usize), LoopError> {
    let gain = s.cfg.min_relative_gain;
    let no_excess = |_: f64, _: f64| None;
    let left = |evaluations: usize| s.cfg.max_evaluations.saturating_sub(spent + evaluations);
    let mut terms = Vec::new();
    let mut evaluations = 0;
    // Where the model falls short of the measured PSD most, looked for again once a
    // mode was kept; each place tried once.
    let mut tried: Vec<f64> = Vec::new();
    let mut sig = None;
    while current.model.mode_frequencies().len() < MAX_BASE_MODES
        && tried.len() < MAX_MODE_TRIES
        && left(evaluations) > 0
    {
        let current_sig = match sig.take() {
            Some(sig) => sig,
            None => {
                evaluations += 1;
                evaluate(&current.model, &s.target, &s.fit_cfg)?.2
            }
        };
        let modes = current.model.mode_frequencies();
        let free = |f: f64| {
            modes
                .iter()
                .chain(&tried)
                .all(|m| (f / m - 1.0).abs() >= MODE_SPACING)
        };
        let next = shortfall_peaks(&s.target, &current_sig)
            .into_iter()
            .find(|&(f, _)| free(f));
        sig = Some(current_sig);
        let Some((f_hz, _)) = next else {
            break;
        };
        tried.push(f_hz);
        let start = current
            .model
            .with_effect(Effect::ExtraResonance { f_hz }, &no_excess);
        let cfg = FitConfig {
            max_evaluations: left(evaluations),
            ..base_fit_config(s)
        };
        let trial = fit(&start, &s.target, &cfg)?;
        evaluations += trial.evaluations;
        let zeta = trial
            .model
            .params
            .iter()
            .rev()
            .find(|p| p.name.starts_with("ln_zeta2"))
            .map_or(0.0, |p| p.value.exp());
        let last = trial.model.effects.len() - 1;
        if zeta >= MIN_BASE_MODE_ZETA
            && trial.cost < current.cost * (1.0 - gain)
            && !noise_at_the_sensor(s, &trial.model, last)?
        {
            current = trial;
            sig = None;
        }
    }
    if let Some(loc) = current.model.fault {
        // The load zone of a rotating race or rolling element first, then the
        // impacts' irregularity (slip jitter and strength spread together: one
        // statement, that no two impacts are alike), each kept on its own gain.
        let mut groups = Vec::new();
        if loc != DefectLocation::OuterRace {
            groups.push(vec![Effect::LoadZone {
                mod_hz: f64::from(s.op.freqs.modulation_rate(loc)),
            }]);
        }
        groups.push(vec![Effect::Slip, Effect::StrengthSpread]);
        for group in groups {
            if left(evaluations) == 0 {
                break;
            }
            let two_starts = matches!(group[0], Effect::LoadZone { .. });
            let (trial, used) =
                fit_with_terms(s, &current.model, &group, two_starts, left(evaluations))?;
            evaluations += used;
            if trial.cost < current.cost * (1.0 - gain) {
                terms.extend(group.iter().map(|e| e.name().to_string()));
                current = trial;
            }
        }
    }
    Ok((current, terms, evaluations))
}

/// The fits that complete the base take half the loop's Levenberg–Marquardt
/// iterations (at least 4): they start from a fitted base, a term at a time, and what
/// they spend the effects cannot (the loop's evaluation budget is shared).
fn base_fit_config(s: &Setup<'_>) -> FitConfig {
    FitConfig {
        max_iter: (s.fit_cfg.max_iter / 2).max(4),
        ..s.fit_cfg
    }
}

/// `model` with `terms` added and fitted within `budget` evaluations; with `two_starts`
/// also from half its background force and the impacts 40 % stronger, the better kept
/// — a base fitted
/// without a load zone has put the modulation's power into the background, and
/// Levenberg–Marquardt does not always take it back from there (an inner race
/// modulated 80 %: PSD 5.7 dB from the first start, 0.8 dB from the second). The rate
/// stays pinned where the comb put it, as in the base (slip added as an effect frees
/// it, for a comb washed out; with the comb still sharp a free rate walks off it).
/// Returns the better fit and the evaluations spent.
fn fit_with_terms(
    s: &Setup<'_>,
    model: &TwinModel,
    terms: &[Effect],
    two_starts: bool,
    budget: usize,
) -> Result<(FitResult, usize), LoopError> {
    let no_excess = |_: f64, _: f64| None;
    let start = terms
        .iter()
        .fold(model.clone(), |m, e| m.with_effect(e.clone(), &no_excess))
        .holding(|_, p| p.name == "rate_factor");
    let (start, slip_scanned) = slip_start(s, start)?;
    let (start, spread_scanned) = spread_start(s, start)?;
    let scanned = slip_scanned + spread_scanned;
    let cfg = FitConfig {
        max_evaluations: budget.saturating_sub(scanned),
        ..base_fit_config(s)
    };
    let a = fit(&start, &s.target, &cfg)?;
    let a = FitResult {
        evaluations: a.evaluations + scanned,
        ..a
    };
    if !two_starts || a.evaluations >= budget {
        let spent = a.evaluations;
        return Ok((a, spent));
    }
    // The second start: the impacts' share raised, either by the record's kurtosis or
    // by half the background (and the impacts 40 % stronger), whichever starts lower.
    let (matched, used) = kurtosis_matched(s, &start)?;
    let mut theta = start.theta();
    for (i, p) in start.params.iter().enumerate() {
        match p.name.as_str() {
            "ln_background" => theta[i] -= std::f64::consts::LN_2,
            "ln_impact_amp" => theta[i] += 1.4f64.ln(),
            _ => {}
        }
    }
    let halved = start.with_theta(&theta);
    let (_, cost_matched, _) = evaluate(&matched, &s.target, &s.fit_cfg)?;
    let (_, cost_halved, _) = evaluate(&halved, &s.target, &s.fit_cfg)?;
    let second = if cost_matched < cost_halved {
        matched
    } else {
        halved
    };
    let a = FitResult {
        evaluations: a.evaluations + used + 2,
        ..a
    };
    if a.evaluations >= budget {
        let spent = a.evaluations;
        return Ok((a, spent));
    }
    let cfg = FitConfig {
        max_evaluations: budget - a.evaluations,
        ..cfg
    };
    let b = fit(&second, &s.target, &cfg)?;
    let spent = a.evaluations + b.evaluations;
    Ok((if b.cost < a.cost { b } else { a }, spent))
}

/// `model` with its background force set so that the model's kurtosis is the
/// record's, the excitation then scaled to the record's RMS, and the evaluations that
/// cost. Impacts of kurtosis `K_i` and variance `v_i` over a Gaussian background of
/// variance `x·v_i` have the kurtosis `(K_i + 6x + 3x²)/(1 + x)²`, falling from `K_i`
/// to 3 as `x` grows: the record's kurtosis says how much of its power the impacts
/// carry. Where the impacts alone are less impulsive than the record, the background
/// is cut tenfold. A base fitted before its load zone or slip has put the impacts'
/// power into the background (a control whose record's kurtosis is 10.6: the model's
/// 3.1, its impacts alone 8.7), and Levenberg–Marquardt does not take it back from
/// there.
fn kurtosis_matched(s: &Setup<'_>, model: &TwinModel) -> Result<(TwinModel, usize), FitError> {
    let Some(b) = model.params.iter().position(|p| p.name == "ln_background") else {
        return Ok((model.clone(), 0));
    };
    let mut impacts = model.clone();
    impacts.params[b].value = -60.0;
    if let Some(p) = impacts
        .params
        .iter_mut()
        .find(|p| p.name == "ln_meas_noise")
    {
        p.value = -60.0;
    }
    let moments = |m: &TwinModel| -> Result<(f64, f64), FitError> {
        let y = m.render(s.fit_cfg.n_sim, s.fit_cfg.seed)?;
        let n = y.len().max(1) as f64;
        let v = y.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / n;
        let m4 = y.iter().map(|v| f64::from(*v).powi(4)).sum::<f64>() / n;
        Ok((v, m4 / (v * v).max(1e-300)))
    };
    let (v_i, k_i) = moments(&impacts)?;
    let (v_t, _) = moments(model)?;
    let x_now = ((v_t - v_i) / v_i.max(1e-300)).max(1e-6);
    let k_m = f64::from(s.target.meas.kurtosis);
    let kurtosis = |x: f64| (k_i + 6.0 * x + 3.0 * x * x) / ((1.0 + x) * (1.0 + x));
    let x_new = if k_i <= k_m || k_m <= 3.0 {
        0.1 * x_now
    } else {
        // Bisection in log x: the kurtosis falls monotonically from K_i to 3.
        let (mut lo, mut hi) = (1e-6f64.ln(), 1e4f64.ln());
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if kurtosis(mid.exp()) > k_m {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (0.5 * (lo + hi)).exp()
    };
    let mut m = model.clone();
    m.params[b].value += 0.5 * (x_new / x_now).ln();
    let m = scaled_to_rms(&m, f64::from(s.target.meas.rms), &s.fit_cfg)?;
    Ok((m, 3))
}

/// The slips a fit of the base's slip starts from, the best of them kept (fractions
/// of the defect's period, per impact): real bearings slip 1–2 %, and from one start
/// the cost's roughness in the slip (see [`crate::twin::SLIP_STEP`]) leaves the fit
/// near it.
const SLIP_STARTS: [f64; 4] = [0.004, 0.008, 0.016, 0.032];

/// `model` with its walk (the slip that accumulates, `ln_walk`, held: a reading,
/// not a fit parameter) set to the one read off the record's comb at the model's
/// impact rate ([`crate::slip::read_slip`] over the line-resolution PSD's compared
/// band), where the teeth resolve one ([`crate::slip::SlipReading::resolved`]);
/// elsewhere it stays at none.
///
/// Two kinds of timing irregularity, because measured records show both: a
/// rolling element's play in its cage pocket times each impact early or late about
/// the cage's grid (`ln_jitter`, fitted: it trades the teeth's power for a pedestal
/// and leaves them sharp — CWRU 234's outer-race teeth stand at the window's width
/// up to the 35th harmonic, 3.8 kHz, while its comb falls into the pedestal there),
/// and the cage's own speed wanders, which nothing pulls back (the renewal process
/// of the randomized benchmark's records: teeth widening as k²).
fn with_measured_walk(s: &Setup<'_>, mut model: TwinModel) -> TwinModel {
    let Some(i) = model.params.iter().position(|p| p.name == "ln_walk") else {
        return model;
    };
    let cfg = &s.sig_res;
    let df = f64::from(cfg.fs_hz) / cfg.psd_n as f64;
    let reading = model.fault.and_then(|loc| {
        crate::slip::read_slip(
            &s.target_res.meas.psd,
            df,
            model.comb_rate_hz(loc),
            f64::from(cfg.psd_lo_hz),
            f64::from(cfg.psd_hi_hz),
        )
    });
    if let Some(r) = reading.filter(|r| r.resolved(df)) {
        model.params[i].value = r.slip.ln();
    }
    model
}

/// `model` with its slip (if it has one) set to the best of [`SLIP_STARTS`] by the
/// cost, and the evaluations that cost.
fn slip_start(s: &Setup<'_>, model: TwinModel) -> Result<(TwinModel, usize), FitError> {
    let Some(i) = model.params.iter().position(|p| p.name == "ln_jitter") else {
        return Ok((model, 0));
    };
    let model = with_measured_walk(s, model);
    let starts = SLIP_STARTS.map(|slip| {
        let mut m = model.clone();
        m.params[i].value = slip.ln();
        m
    });
    let best = cheapest(s, starts)?.map_or(model, |(_, m)| m);
    Ok((best, SLIP_STARTS.len()))
}

/// The one of `models` with the lowest cost, and that cost (the first of equals;
/// `None` where there are none): each one evaluation.
fn cheapest(
    s: &Setup<'_>,
    models: impl IntoIterator<Item = TwinModel>,
) -> Result<Option<(f32, TwinModel)>, FitError> {
    let mut best: Option<(f32, TwinModel)> = None;
    for m in models {
        let (_, cost, _) = evaluate(&m, &s.target, &s.fit_cfg)?;
        if best.as_ref().is_none_or(|(c, _)| cost < *c) {
            best = Some((cost, m));
        }
    }
    Ok(best)
}

/// The strength spreads a fit of the base's spread starts from (the standard
/// deviation of each impact's strength over its mean): real bearings' impacts spread
/// by 5–30 %.
const SPREAD_STARTS: [f64; 5] = [0.05, 0.1, 0.15, 0.2, 0.3];

/// The shares of its background force a fit of the base's spread starts from, each
/// with every one of [`SPREAD_STARTS`].
const BACKGROUND_SHARES: [f64; 3] = [1.0, 0.5, 0.25];

/// `model` with its strength spread (if it has one) and its background force set to
/// the best pair of [`SPREAD_STARTS`] × [`BACKGROUND_SHARES`] by the cost, and the
/// evaluations that cost. The spread's pedestal between the comb's teeth and the
/// background through the structure fill the same bins, so a base fitted without the
/// spread has put its pedestal into the background, and the cost's valley runs
/// diagonally in the two (an outer race of 28 % spread: cost 10.4 at the base's
/// background and 15 %, 4.2 at a quarter of it and 30 %). Started at 15 % from where
/// the base left the background, the fit left the spread there: 31 of the 51 fault
/// controls of the development seed (`twin bench --seed 7`) that kept a spread ended
/// at 14–16.5 %, whatever their own (5–29 %). With this start, on the same seed's 81
/// controls: the first fit over the half-to-half scatter, median 2.06× → 1.96× (mean
/// 2.75× → 2.50×; inner races at 4.0–4.7× came to 1.5–3.0×). The second start the
/// load zone has (kurtosis-matched, [`fit_with_terms`]) was tried for the slip and
/// spread too: it took 1.96× to 1.96× on seed 7 and 1.83× to 1.74× on seed 18, but it
/// costs a whole second fit of the base from the shared budget, and a vane pass added
/// to CWRU 234 (`effects_added_to_a_measured_record_are_found`) was left untried.
fn spread_start(s: &Setup<'_>, model: TwinModel) -> Result<(TwinModel, usize), FitError> {
    let spread = model.params.iter().position(|p| p.name == "ln_spread");
    let background = model.params.iter().position(|p| p.name == "ln_background");
    let (Some(i), Some(b)) = (spread, background) else {
        return Ok((model, 0));
    };
    let starts = BACKGROUND_SHARES.iter().flat_map(|share| {
        SPREAD_STARTS.iter().map(|spread| {
            let mut m = model.clone();
            m.params[i].value = spread.ln();
            m.params[b].value += share.ln();
            m
        })
    });
    let best = cheapest(s, starts)?.map(|(_, m)| m);
    let tried = SPREAD_STARTS.len() * BACKGROUND_SHARES.len();
    Ok((best.unwrap_or(model), tried))
}

/// The corners of the structure's high-pass a first fit tries, Hz, the best of them
/// by the cost kept (see [`floor_start`]): from a structure whose lowest modes lie
/// just above the compared band's bottom to one whose lie at 1 kHz, a factor of
/// about three apart. One start would do where the cost's slope reaches it, but a
/// corner far from the record's has no bins to move it: the cost is flat there.
const FLOOR_STARTS: [f64; 4] = [30.0, 100.0, 300.0, 1000.0];

/// The base term of the structure's roll-off below its lowest modes, as the report's
/// `base_terms` name it (with its corner).
const LOW_CORNER_TERM: &str = "structure_low_corner";

/// `model` (the best of the half fits) with the structure's roll-off below its
/// lowest modes ([`TwinModel::with_floor_corner`]) where the record shows one, and
/// the evaluations that cost (each reuses the simulated structure: the corner is
/// applied at the sensor). The corner starts at the best of [`FLOOR_STARTS`] by the
/// cost, and is taken only where it lowers the cost by the loop's
/// `min_relative_gain`, as every base term must: a record whose structure is flat
/// down to the compared band's bottom (the generator's, whose low band the sensor's
/// white noise fills) cannot place a corner, and a free one there only trades with
/// the rest of the model (taken at every start, a corner walked to 1.9 kHz on the
/// loop's slip probe, whose base then fit to 1.37 dB where it fits to under 1.2
/// without; scanned on the unfitted start, 1 kHz won on every generated record, the
/// start's background being too high). The full fit that follows refits the base
/// with it: judged after that fit instead, with the structure held and the
/// background freed, the CWRU records' median first fit stayed at 6.0 dB, against
/// 5.2 dB this way.
fn floor_start(s: &Setup<'_>, model: &TwinModel) -> Result<(TwinModel, usize), FitError> {
    let (_, flat, _) = evaluate(model, &s.target, &s.fit_cfg)?;
    let best = cheapest(s, FLOOR_STARTS.map(|f_hz| model.with_floor_corner(f_hz)))?;
    let evaluations = FLOOR_STARTS.len() + 1;
    match best {
        Some((cost, m)) if cost < flat * (1.0 - s.cfg.min_relative_gain) => Ok((m, evaluations)),
        _ => Ok((model.clone(), evaluations)),
    }
}

/// Most places a further mode is tried at (each a fit).
const MAX_MODE_TRIES: usize = 4;

/// [`modal::shortfall_of`] of the model's simulated signature `sig`.
fn shortfall_peaks(target: &Target, sig: &Signature) -> Vec<(f64, f32)> {
    modal::shortfall_of(target, &to_db(&sig.psd, &target.meas.psd))
}

/// Level, dB, of the family of fundamental `f0_hz` in the envelope spectrum `env`
/// (bin width `df`): the mean over its first two harmonics of the highest **peak** (a
/// local maximum, its frequency interpolated) within the slip's [`SLIP`] of the
/// harmonic, each over its own [`local_floor`]. Where the window holds no peak at
/// all, the family's line has been displaced (a drifting speed: 1 %/s moves BPFO's
/// line 3 % over six seconds) and the window holds its flank: then the highest bin
/// counts, unless it is on the main lobe of one of `others` (within a bin: the
/// shaft's orders, the other families' lines with their shaft-rate sidebands).
///
/// Why peaks and not the highest bin: a strong line just outside the window leaks
/// into it along its main lobe, and so does the envelope's rise towards 0 Hz; their
/// flanks were read as the family's line — on the randomized benchmark's dev side
/// (`--seed 1`), 2·shaft 2.4 % from BSF and BPFI − shaft 2.4 % from 2·BSF named
/// inner-race records a ball fault (three controls, whose own comb the loop then
/// called a second defect), and the low-frequency rise named healthy records ball
/// faults.
///
/// Why a floor of its own for each harmonic, and not the spectrum's median: an
/// envelope spectrum is not flat. Below a few hundred hertz it rises (the spread of
/// the impacts' strengths, the load zone's slow modulation, slip's smear of the
/// shaft's lines), so any peak of the noise there, where BSF and 2·BSF lie, stood
/// 10 dB over the whole spectrum's median and a healthy record read as a ball fault:
/// on the dev side, 23 of 88 healthy records were named a fault and 12 race faults a
/// ball's; the fault hypothesis was right on 253 of 300 records, now on 281 (held
/// out, `--seed 2`: 252 → 288). A line is a line by how far it stands above its own
/// neighbourhood.
fn family_level_db(env: &[f32], df: f32, f0_hz: f32, others: &[f32]) -> f32 {
    const HARMONICS: usize = 2;
    if !(df > 0.0 && f0_hz > 0.0) {
        return 0.0;
    }
    let mut sum = 0.0f32;
    for h in 1..=HARMONICS {
        let f = h as f32 * f0_hz;
        let tol = df.max(SLIP * f);
        let lo = ((f - tol) / df).max(1.0) as usize;
        let hi = (((f + tol) / df) as usize + 1).min(env.len().saturating_sub(1));
        let Some(floor) = local_floor(env, lo, hi) else {
            sum += 1.0;
            continue;
        };
        let within = |j: usize| (peak_of(env, j) * df - f).abs() <= tol;
        let peaks: Vec<usize> = (lo..=hi)
            .filter(|&j| is_peak(env, j) && within(j))
            .collect();
        let best = if peaks.is_empty() {
            let anothers = |j: usize| {
                let at = peak_of(env, j) * df;
                others.iter().any(|&g| (at - g).abs() <= df)
            };
            (lo..=hi)
                .filter(|&j| !anothers(j))
                .map(|j| env[j])
                .fold(floor, f32::max)
        } else {
            peaks.iter().map(|&j| env[j]).fold(floor, f32::max)
        };
        sum += best / floor;
    }
    10.0 * (sum / HARMONICS as f32).log10()
}

/// Bins on each side of a family's window that its floor is read over: 32, about
/// ±50 Hz at the fit's resolution, wide enough that a rotating race's shaft-rate
/// sidebands fill at most half of them at the slowest speeds the loop reads.
const FLOOR_BINS: usize = 32;

/// The floor under bins `lo..=hi` of `env`: the lower quartile of the
/// [`FLOOR_BINS`] bins on each side (bin 0, DC, left out) — a quartile rather than
/// the median, so that sidebands and other lines filling up to half the neighbourhood
/// do not lift it. `None` where fewer than eight bins or no power are there.
fn local_floor(env: &[f32], lo: usize, hi: usize) -> Option<f32> {
    let n = env.len();
    let (b_end, a_start) = (lo.min(n), (hi + 1).min(n));
    let below = lo.saturating_sub(FLOOR_BINS).max(1).min(b_end)..b_end;
    let above = a_start..hi.saturating_add(1 + FLOOR_BINS).min(n);
    let mut v: Vec<f32> = env[below].iter().chain(&env[above]).copied().collect();
    if v.len() < 8 {
        return None;
    }
    let q = v.len() / 4;
    let floor = *v.select_nth_unstable_by(q, f32::total_cmp).1;
    (floor > 0.0).then_some(floor)
}

/// A family's line within this share of its frequency is its own (the rolling
/// elements' slip, 1–2 %).
const SLIP: f32 = 0.02;

/// Whether bin `j` of `env` is a local maximum (above the bin below it, at least as
/// high as the one above: a flat run is no peak).
fn is_peak(env: &[f32], j: usize) -> bool {
    match (
        j.checked_sub(1).and_then(|k| env.get(k)),
        env.get(j),
        env.get(j + 1),
    ) {
        (Some(a), Some(b), Some(c)) => b > a && b >= c,
        _ => false,
    }
}

/// The peak of `env` whose main lobe bin `j` is on (climbing from `j`), as a
/// fractional bin: parabolic through the log levels of its bin and the neighbours (a
/// Hann line's centre to a tenth of a bin).
fn peak_of(env: &[f32], j: usize) -> f32 {
    let at = |k: usize| env.get(k).copied();
    let p = climb_to_peak(env, j).unwrap_or(j);
    let (Some(a), Some(b), Some(c)) = (p.checked_sub(1).and_then(at), at(p), at(p + 1)) else {
        return p as f32;
    };
    if !(a > 0.0 && b > 0.0 && c > 0.0) {
        return p as f32;
    }
    let (la, lb, lc) = (a.ln(), b.ln(), c.ln());
    let curve = la - 2.0 * lb + lc;
    let shift = if curve < 0.0 {
        (0.5 * (la - lc) / curve).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    p as f32 + shift
}

/// The envelope lines other than family `d`'s (fundamental `f_d`) up to `top_hz`:
/// the shaft's orders, and the other families' first two harmonics with their first
/// two shaft-rate sidebands (a rotating race's or element's load zone).
fn other_lines(families: &[f32; 3], d: usize, shaft: f32, top_hz: f32) -> Vec<f32> {
    let mut out: Vec<f32> = (1..)
        .map(|k| k as f32 * shaft)
        .take_while(|&g| g <= top_hz && shaft > 0.0)
        .collect();
    for (_, &g) in families.iter().enumerate().filter(|&(i, _)| i != d) {
        for h in 1..=2 {
            for m in -2i32..=2 {
                out.push(h as f32 * g + m as f32 * shaft);
            }
        }
    }
    out
}

/// Step 1a: which defect: the one the core's diagnosis types over the record, else
/// the loop's own envelope rule's ([`identify_fault`]; see `hypothesis`).
fn fault_hypothesis(
    s: &Setup<'_>,
) -> (
    Option<DefectLocation>,
    serde_json::Map<String, serde_json::Value>,
) {
    let (own, mut ev) = identify_fault(&s.target, &s.op, s.cfg.fault_threshold_db);
    let diagnosed = hypothesis::diagnosed_type(&s.x, s.op.fs_hz, &s.op.freqs);
    if let Some((t, counts)) = diagnosed {
        ev.insert("diagnosis".into(), serde_json::json!(t.name()));
        ev.insert("diagnosis_windows".into(), serde_json::json!(counts));
    }
    match diagnosed.and_then(|(t, _)| hypothesis::typed_defect(t)) {
        Some(fault) => (Some(fault), ev),
        None => (own, ev),
    }
}

/// The loop's own envelope rule: a family whose lines stand `threshold` dB over their
/// local floor in the measured envelope spectrum.
fn identify_fault(
    target: &Target,
    op: &OperatingPoint,
    threshold: f32,
) -> (
    Option<DefectLocation>,
    serde_json::Map<String, serde_json::Value>,
) {
    let cfg = &target.cfg;
    let env = &target.meas.env;
    let f = &op.freqs;
    let df = cfg.fs_hz / cfg.env_n as f32;
    let families = [f.bpfo, f.bpfi, 2.0 * f.bsf];
    let top = 3.0 * families.iter().fold(f.bsf, |m, &g| m.max(g));
    let level = |hz: f32, d: usize| {
        let others = other_lines(&families, d, f.shaft, top);
        family_level_db(env, df, hz, &others)
    };
    let candidates = [
        (Some(DefectLocation::OuterRace), level(f.bpfo, 0)),
        (Some(DefectLocation::InnerRace), level(f.bpfi, 1)),
        (
            Some(DefectLocation::Ball),
            level(2.0 * f.bsf, 2).max(level(f.bsf, 2)),
        ),
    ];
    let mut ev = serde_json::Map::new();
    ev.insert("bpfo_db".into(), serde_json::json!(candidates[0].1));
    ev.insert("bpfi_db".into(), serde_json::json!(candidates[1].1));
    ev.insert("bsf_db".into(), serde_json::json!(candidates[2].1));
    ev.insert(
        "shaft_db".into(),
        serde_json::json!(family_level_db(env, df, f.shaft, &[])),
    );
    ev.insert("threshold_db".into(), serde_json::json!(threshold));
    let mut best = candidates
        .iter()
        .copied()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((None, 0.0));
    // Where the outer race's rate and a ball's (2·BSF or BSF) coincide within twice
    // the slip, both families read the same lines; a ball's strikes pass the load zone
    // once per cage turn and an outer-race defect's do not, so the cage rate's own
    // lines decide.
    let coincide = [2.0 * f.bsf, f.bsf]
        .iter()
        .any(|&r| (r - f.bpfo).abs() <= 2.0 * SLIP * f.bpfo);
    let pair = [Some(DefectLocation::OuterRace), Some(DefectLocation::Ball)];
    if coincide && pair.contains(&best.0) {
        let cage_db = family_level_db(env, df, f.ftf, &[]);
        ev.insert("ftf_db".into(), serde_json::json!(cage_db));
        best.0 = if cage_db >= threshold {
            pair[1]
        } else {
            pair[0]
        };
    }
    // A ball whose spot wanders loses its 2·BSF rhythm and keeps its cage line, but
    // the cage line alone (at the family threshold) named a ball on a healthy record
    // of `--seed 7` (case 102) and on none of its eight balls the families missed: a
    // weak cage line is a healthy record's as often (bursts, modulation). Only
    // `pumptwin_core::diagnosis` reads it, where it must reach 15 dB and lead every
    // line above it.
    if best.1 >= threshold {
        (best.0, ev)
    } else {
        (None, ev)
    }
}

/// The sensor's two readings of the modes, as `logit_mass_line` (held in every fit):
/// the mass line (the sensor on the mode, eq. 22; `a` = 1 exactly in f64) or the
/// housing's reading (the force the mode passes on; `a` ≈ 4·10⁻¹⁸). The first fit
/// fits both and keeps the better (see
/// [`TwinModel::mass_line`](crate::twin::TwinModel::mass_line) for why). Tried first
/// and dropped: a continuous mix, fitted (the benchmark's controls went to `a` < 0.01,
/// the project's own simulator to 0.987–0.9999, and values in between fitted a
/// missing mode's skirt rather than the sensor: a two-mode control at 0.75), and the
/// reading chosen at the start, before the fit (its rough mode and levels chose the
/// housing for records of the project's own simulator, which reads the mass line).
const MASS_LINE_CHOICES: [f64; 2] = [40.0, -40.0];

/// How much worse (its mean squared dB error) a reading's identified structure may
/// fit the PSD than the other reading's and still be fitted: the formula's errors of
/// the two readings differ by 5–140× on the loop's probes and the benchmark's
/// controls where the reading is known, by 1.2× on CWRU 234, whose reading nothing
/// says; fitting one reading instead of two leaves its evaluations to the effects.
const READING_RATIO: f64 = 2.0;

/// The structure identified on the record's PSD for the sensor reading `mass_line`
/// (`logit_mass_line`), with the base's widest line spacing (the defect's rate, or
/// the shaft's) averaged out.
fn structure_for(s: &Setup<'_>, fault: Option<DefectLocation>, mass_line: f64) -> modal::Structure {
    let a = 1.0 / (1.0 + (-mass_line).exp());
    let spacing = fault.map_or(0.0, |loc| f64::from(s.op.freqs.impact_rate(loc)));
    let spacing = spacing.max(f64::from(s.op.freqs.shaft));
    modal::identify(&s.target, a, spacing, MAX_BASE_MODES)
}

/// Step 1b: starting values for one reading of the modes (`logit_mass_line`, held):
/// the structure's modes identified on the measured PSD ([`modal::identify`]: the
/// base's mode and up to `MAX_BASE_MODES − 1` further ones, each with its damping and
/// share of the force), the excitation scaled to the measured RMS (linear model).
fn initial_model(
    target: &Target,
    op: OperatingPoint,
    fault: Option<DefectLocation>,
    mass_line: f64,
    structure: &modal::Structure,
    fit_cfg: &FitConfig,
) -> Result<(TwinModel, usize), FitError> {
    let first = structure.modes[0];
    let rms = f64::from(target.meas.rms);
    let no_excess = |_: f64, _: f64| None;
    let mut m = TwinModel::base(op, fault, first.f_hz, first.zeta, 1.0, 0.05 * rms);
    if let Some(p) = m.params.iter_mut().find(|p| p.name == "logit_mass_line") {
        p.value = mass_line;
        p.step = 0.0;
    }
    for mode in &structure.modes[1..] {
        m = m.with_effect(Effect::ExtraResonance { f_hz: mode.f_hz }, &no_excess);
        let n = m.params.len();
        m.params[n - 2].value = mode.zeta.ln();
        m.params[n - 1].value = mode.share.ln();
    }
    Ok((scaled_to_rms(&m, rms, fit_cfg)?, 1))
}

/// The one-mode start for one reading of the modes (`logit_mass_line`, held): the
/// mode at one of the measured PSD's strongest peaks (each tried, the best kept by
/// the cost), damped 5 %, the excitation scaled to the measured RMS. Fitted beside
/// [`initial_model`]'s start where the identified structure is one mode, the better
/// kept: from the peak's start a fit sometimes ends lower (the loop's probes: a
/// pulsating inner race's base at 46.5 from it, 50.3 from the identified mode, and
/// its load zone then kept from the one only).
fn peak_start(
    target: &Target,
    op: OperatingPoint,
    fault: Option<DefectLocation>,
    mass_line: f64,
    fit_cfg: &FitConfig,
) -> Result<(TwinModel, usize), FitError> {
    let cfg = &target.cfg;
    let mut peaks = psd_peaks(target);
    if peaks.is_empty() {
        let (lo, hi) = mode_search_bins(target);
        peaks.push(f64::from(cfg.psd_freq((lo + hi) / 2)));
    }
    let rms = f64::from(target.meas.rms);
    let mut best: Option<(TwinModel, f32)> = None;
    let mut evals = 0;
    for fn_hz in peaks {
        let mut m = TwinModel::base(op, fault, fn_hz, 0.05, 1.0, 0.05 * rms);
        if let Some(p) = m.params.iter_mut().find(|p| p.name == "logit_mass_line") {
            p.value = mass_line;
            p.step = 0.0;
        }
        let m = scaled_to_rms(&m, rms, fit_cfg)?;
        let (_, cost, _) = evaluate(&m, target, fit_cfg)?;
        evals += 2;
        if best.as_ref().is_none_or(|(_, c)| cost < *c) {
            best = Some((m, cost));
        }
    }
    let (m, _) = best.expect("at least one peak tried");
    Ok((m, evals))
}

/// `m` with its excitation (impacts and background) scaled so that its RMS is `rms`.
fn scaled_to_rms(m: &TwinModel, rms: f64, fit_cfg: &FitConfig) -> Result<TwinModel, FitError> {
    let y = m.render(fit_cfg.n_sim, fit_cfg.seed)?;
    let r = (y.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / y.len() as f64)
        .sqrt()
        .max(1e-30);
    let scale = (rms / r).ln();
    let mut theta = m.theta();
    for (i, p) in m.params.iter().enumerate() {
        if p.name == "ln_impact_amp" || p.name == "ln_background" {
            theta[i] += scale;
        }
    }
    Ok(m.with_theta(&theta))
}

/// Defect rate refined from the measured line-resolution PSD: the rate within ±3 % of
/// the kinematic one whose harmonic comb collects the most log power up to the band
/// limit (a periodic impact train puts lines at every k·rate). Returns the rate factor
/// `rate / kinematic − 1`.
fn refine_rate(target_res: &Target, kinematic_hz: f32) -> f64 {
    let k = f64::from(kinematic_hz);
    refine_comb_rate(&target_res.psd_db, &target_res.cfg, k, 0.03) / k - 1.0
}

#[cfg(test)]
mod tests {
    use super::{family_level_db, other_lines};

    /// A line's Hann main lobe (peak at `f`, bins of 1 Hz) over a floor of 1.
    fn with_line(env: &mut [f32], f: f32, level: f32) {
        for (j, v) in env.iter_mut().enumerate() {
            let d = (j as f32 - f).abs();
            if d < 2.0 {
                *v += level * (0.5 + 0.5 * (std::f32::consts::PI * d / 2.0).cos()).powi(2);
            }
        }
    }

    /// A strong line at another known frequency 2.4 % from a family's leaks into its
    /// window along its main lobe; neither it nor its flank is the family's line. The
    /// family's own line is, and so is its own line displaced 3 % (a drifting speed),
    /// which peaks at no other line.
    #[test]
    fn a_neighbours_flank_is_not_a_familys_line() {
        let mut env = vec![1.0f32; 600];
        // Shaft harmonics (56.6 Hz) 2.4 % below BSF (116 Hz) and 2·BSF.
        with_line(&mut env, 113.2, 1e4);
        with_line(&mut env, 226.4, 1e4);
        let shaft = [56.6f32, 113.2, 169.8, 226.4, 283.0];
        let flank = family_level_db(&env, 1.0, 116.0, &shaft);
        assert!(flank < 1.0, "{flank} dB from a neighbour's flank");
        // Without the shaft's orders to say whose the line is, the window holds no
        // peak and its flank counts.
        assert!(family_level_db(&env, 1.0, 116.0, &[]) > 20.0);
        // Its own line displaced 3 % by a drifting speed, at no other line, counts.
        let mut drifted = env.clone();
        with_line(&mut drifted, 119.5, 100.0);
        with_line(&mut drifted, 239.0, 100.0);
        let displaced = family_level_db(&drifted, 1.0, 116.0, &shaft);
        assert!(displaced > 12.0, "{displaced} dB");
        with_line(&mut env, 116.0, 100.0);
        with_line(&mut env, 232.0, 100.0);
        let own = family_level_db(&env, 1.0, 116.0, &shaft);
        assert!((own - 20.0).abs() < 0.5, "{own} dB");
        // A rising floor with the noise's peaks on it (below bin 150) holds no line.
        let mut rising = vec![1.0f32; 600];
        for (j, v) in rising.iter_mut().enumerate().take(150) {
            *v = 10.0 + (j % 3) as f32;
        }
        let noise = family_level_db(&rising, 1.0, 60.0, &shaft);
        assert!(noise < 1.5, "{noise} dB off a rising floor");
        with_line(&mut rising, 60.0, 100.0);
        with_line(&mut rising, 120.0, 100.0);
        let on_rise = family_level_db(&rising, 1.0, 60.0, &shaft);
        assert!(on_rise > 9.0, "{on_rise} dB");
        // No power, no frequency: no level, never a panic.
        assert_eq!(family_level_db(&[0.0; 600], 1.0, 116.0, &shaft), 0.0);
        assert_eq!(family_level_db(&env, 1.0, 1e9, &shaft), 0.0);
        assert!(other_lines(&[100.0, 150.0, 60.0], 0, 25.0, 200.0).contains(&125.0));
    }
}
