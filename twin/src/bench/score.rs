//! Scoring the loop's claims against what was injected: per case (what was found,
//! missed and claimed falsely), then per effect (recall by strength bin, precision,
//! frequency error), on the clean controls (false-claim rate) and on the error.
//!
//! A claim is an effect the loop added (its name in `effects`), `clipping` when the
//! report says `clipped`, `dropouts` when it counted any. Each claim is one of three:
//!
//! - **true**: an injection of the case accepts its name ([`Injection::accepted`]);
//!   an `extra_resonance` only where it names the injected mode's frequency within
//!   [`MODE_TOLERANCE`] (a mode anywhere else is not that mode), a
//!   `second_impact_train` or a `load_zone_modulation` only at the injected rate
//!   within [`RATE_TOLERANCE`]. A compound's two defects may be named either way
//!   round: the loop's fault hypothesis the compound's defect and a second train at
//!   the base defect's own rate name it too (`swapped_compound`), and the hypothesis
//!   then counts as right;
//! - **a base property named as an effect**: true of the record but part of what every
//!   bearing signal has, so not what the machine adds ([`base_property`]): slip on a
//!   record with a defect, a load zone at the rate of the defect's own (shaft for an
//!   inner race, cage for a ball), an `extra_resonance` at one of the base's modes.
//!   Counted apart: not credited, not false;
//! - **false**: everything else (e.g. random bursts on a record without any).

use super::draw::{bin, Case, Defect, Injection, BINS};
use crate::closed_loop::LoopReport;
use crate::twin::Effect;

/// How close a claimed mode must lie to a true one, relative.
pub const MODE_TOLERANCE: f64 = 0.05;

/// How close a claimed rate must lie to the true one, relative: a load zone's to the
/// defect's own, a second train's to the compound's, a modulation's to the injected
/// one's. The loop names a rate for a defect within the same 3 % (rolling elements
/// slip by 1–2 %); a train or a modulation at another rate is another effect, and a
/// false claim.
const RATE_TOLERANCE: f64 = 0.03;

/// One claim of a report: its name and the effect behind it (none for `clipping` and
/// `dropouts`).
#[derive(Debug, Clone)]
pub struct Claim {
    /// The claim's name.
    pub name: String,
    /// The kept effect.
    pub effect: Option<Effect>,
}

/// One case's outcome.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Outcome {
    /// The case.
    pub case: Case,
    /// The loop's claims.
    pub claims: Vec<String>,
    /// The kept effects behind them, with their settings.
    pub claimed_effects: Vec<Effect>,
    /// What the first fit completed the base with (`LoopReport::base_terms`).
    pub base_terms: Vec<String>,
    /// Per injection (in the case's order): whether a claim named it.
    pub found: Vec<bool>,
    /// Per injection: the named frequency's relative error, where both have one.
    pub freq_rel_error: Vec<Option<f64>>,
    /// Claims no injection accepts and that name no base property.
    pub false_claims: Vec<String>,
    /// Claims that name a property of the base ([`base_property`]).
    pub base_claims: Vec<String>,
    /// The fault the loop's first fit assumed, and the truth.
    pub fault_claimed: String,
    /// The true defect (`none` for a healthy bearing).
    pub fault_true: String,
    /// Whether the fault hypothesis is right: the true defect, or a compound's
    /// second defect where the base's is named as the second train
    /// ([`Judged::swapped`]).
    pub fault_right: bool,
    /// PSD error of the first fit and at the end, dB, and the record's own scatter.
    pub psd_initial_db: f64,
    /// PSD error at the end, dB.
    pub psd_final_db: f64,
    /// Half-to-half scatter, dB.
    pub psd_scatter_db: Option<f64>,
    /// Wall time of the loop, s.
    pub seconds: f64,
    /// The loop's error, when it ran into one (the case then claims nothing).
    pub error: Option<String>,
}

impl Outcome {
    /// The claims behind `claims` and `claimed_effects`, as [`claims`] made them
    /// (the kept effects first, `clipping` and `dropouts` after, without an effect).
    pub fn claims_made(&self) -> Vec<Claim> {
        self.claims
            .iter()
            .enumerate()
            .map(|(k, name)| Claim {
                name: name.clone(),
                effect: self.claimed_effects.get(k).cloned(),
            })
            .collect()
    }
}

/// The claims a report makes.
pub fn claims(report: &LoopReport) -> Vec<Claim> {
    let mut c: Vec<Claim> = report
        .steps
        .iter()
        .map(|s| Claim {
            name: s.effect.clone(),
            effect: Some(s.detail.clone()),
        })
        .collect();
    for (flag, name) in [
        (report.clipped, "clipping"),
        (report.dropouts > 0, "dropouts"),
    ] {
        if flag {
            c.push(Claim {
                name: name.into(),
                effect: None,
            });
        }
    }
    c
}

fn near(a: f64, b: f64, tol: f64) -> bool {
    (a / b - 1.0).abs() <= tol
}

/// Does `claim` name injection `inj`?
pub fn names(claim: &Claim, inj: &Injection) -> bool {
    if !inj.accepted().contains(&claim.name.as_str()) {
        return false;
    }
    match (inj, &claim.effect) {
        (Injection::ExtraMode { mode }, Some(Effect::ExtraResonance { f_hz })) => {
            near(*f_hz, mode.f_hz, MODE_TOLERANCE)
        }
        (
            Injection::Compound { rate_hz, .. },
            Some(Effect::SecondImpactTrain { rate_hz: r, .. }),
        ) => near(*r, *rate_hz, RATE_TOLERANCE),
        (Injection::Modulation { f_hz, .. }, Some(Effect::LoadZoneModulation { mod_hz })) => {
            near(*mod_hz, *f_hz, RATE_TOLERANCE)
        }
        _ => true,
    }
}

/// Does `claim` name what every bearing signal of this base has: slip where there is a
/// defect, the load zone of an inner-race or ball defect at its own rate, one of the
/// base's modes?
pub fn base_property(claim: &Claim, case: &Case) -> bool {
    let b = &case.base;
    let shaft = b.rpm / 60.0;
    match (&claim.effect, b.defect) {
        (Some(Effect::Slip), Some(_)) => true,
        (Some(Effect::LoadZoneModulation { mod_hz }), Some(d)) => {
            let own = match d {
                Defect::InnerRace => shaft,
                Defect::Ball => shaft * f64::from(b.bearing.orders().ftf),
                Defect::OuterRace => return false,
            };
            near(*mod_hz, own, RATE_TOLERANCE)
        }
        (Some(Effect::ExtraResonance { f_hz }), _) => {
            b.modes.iter().any(|m| near(*f_hz, m.f_hz, MODE_TOLERANCE))
        }
        _ => false,
    }
}

/// The frequency a kept effect names, Hz, to compare with an injection's.
pub(crate) fn claimed_frequencies(e: &Effect) -> Vec<f64> {
    match e {
        Effect::LineInterference { freqs } => freqs.clone(),
        Effect::ExtraResonance { f_hz } | Effect::RandomBursts { f_hz, .. } => vec![*f_hz],
        Effect::SecondImpactTrain { rate_hz, .. } => vec![*rate_hz],
        Effect::LoadZoneModulation { mod_hz } => vec![*mod_hz],
        _ => Vec::new(),
    }
}

/// Which injections the claims name, and which claims are false or base properties.
#[derive(Debug, Clone, Default)]
pub struct Judged {
    /// Per injection: named by a claim.
    pub found: Vec<bool>,
    /// Per injection: the closest named frequency's relative error.
    pub freq_rel_error: Vec<Option<f64>>,
    /// False claims.
    pub false_claims: Vec<String>,
    /// Claims naming a base property.
    pub base_claims: Vec<String>,
    /// The loop took a compound's second defect for the first and named the base's
    /// as the second train ([`swapped_compound`]).
    pub swapped: bool,
}

/// The modes of the first fit's base, Hz: the structure's first (`fn_hz` in
/// `params_initial`, wherever the fit put it: a strong injected mode is often where it
/// lands, the base's own first mode then taken as a further one) and those it
/// completed the base with (`extra_resonance@<f>Hz` in `base_terms`).
pub fn first_fit_modes(
    params_initial: &serde_json::Map<String, serde_json::Value>,
    base_terms: &[String],
) -> Vec<f64> {
    let first = params_initial.get("fn_hz").and_then(|v| v.as_f64());
    first
        .into_iter()
        .chain(base_terms.iter().filter_map(|t| {
            t.strip_prefix("extra_resonance@")?
                .strip_suffix("Hz")?
                .parse()
                .ok()
        }))
        .collect()
}

/// Does `claim` say what `before` said: the same name and, where both name
/// frequencies, one within [`MODE_TOLERANCE`] of the other?
pub fn same_claim(claim: &Claim, before: &Claim) -> bool {
    if claim.name != before.name {
        return false;
    }
    let (a, b) = (
        claim
            .effect
            .as_ref()
            .map(claimed_frequencies)
            .unwrap_or_default(),
        before
            .effect
            .as_ref()
            .map(claimed_frequencies)
            .unwrap_or_default(),
    );
    a.is_empty()
        || b.is_empty()
        || a.iter()
            .any(|x| b.iter().any(|y| near(*x, *y, MODE_TOLERANCE)))
}

/// What the loop's first fit said of a case, which its claims are read with: the
/// fault it assumed (`LoopReport::fault`) and the modes of its base
/// ([`first_fit_modes`]).
#[derive(Debug, Clone, Copy)]
pub struct FirstFit<'a> {
    /// The fault hypothesis.
    pub fault: &'a str,
    /// The base's modes, Hz.
    pub modes: &'a [f64],
}

/// The rate a second train names when the loop took a compound's second defect for
/// the first: with the hypothesis the compound's defect (`fault`), a
/// `second_impact_train` within [`RATE_TOLERANCE`] of the base defect's own rate
/// names the base's defect, and the two claims together name both defects of the
/// compound. Which of two defects is the first is a matter of which impacts stand
/// out more in the envelope (an outer race's, steady, over a ball's, modulated by
/// the cage and alternating between the races, at half their strength), not of
/// what the record holds. That rate, Hz, or `None`.
fn swapped_compound(case: &Case, fault: &str, claim: &Claim, inj: &Injection) -> Option<f64> {
    let (Injection::Compound { defect, .. }, Some(Effect::SecondImpactTrain { rate_hz, .. })) =
        (inj, &claim.effect)
    else {
        return None;
    };
    let own = case.base.impact_rate_hz(case.base.defect?);
    (claim.name == "second_impact_train"
        && fault == defect.name()
        && near(*rate_hz, own, RATE_TOLERANCE))
    .then_some(own)
}

/// The relative errors of `claimed` frequencies against `truth`, Hz, the frequency
/// a claim of `inj` should name (a mains claim may name any of its harmonics).
fn relative_errors(claimed: Vec<f64>, inj: &Injection, truth: f64) -> Vec<f64> {
    let truths: Vec<f64> = match inj {
        Injection::Mains { lines, .. } => {
            lines.iter().map(|(h, _)| truth * f64::from(*h)).collect()
        }
        _ => vec![truth],
    };
    claimed
        .iter()
        .flat_map(|c| truths.iter().map(move |t| (c / t - 1.0).abs()))
        .collect()
}

/// Judge `claims` against `case`, read with what the `first` fit said. An injected
/// mode counts as found where the base took it too (`first.modes`): one more mode
/// driven by the same impacts is a base with one more mode, and no record can tell
/// the two apart. A compound is found by a second train at its rate, or where the
/// loop took it for the first defect and named the base's as the second
/// ([`swapped_compound`]). `before`: what the loop claimed on the record before
/// anything was injected (a measured base's own effects; empty for a synthesized
/// one): a claim that says the same again is the record's, counted with the base
/// properties.
pub fn judge(case: &Case, claims: &[Claim], first: FirstFit<'_>, before: &[Claim]) -> Judged {
    let mut j = Judged::default();
    // Per claim naming the injection: the frequency it should name, if it names one.
    let truth_of = |c: &Claim, inj: &Injection| -> Option<Option<f64>> {
        if names(c, inj) {
            Some(inj.frequency_hz())
        } else {
            swapped_compound(case, first.fault, c, inj).map(Some)
        }
    };
    for d in &case.injected {
        let naming: Vec<(&Claim, Option<f64>)> = claims
            .iter()
            .filter_map(|c| truth_of(c, &d.injection).map(|t| (c, t)))
            .collect();
        let in_base = match &d.injection {
            Injection::ExtraMode { mode } => first
                .modes
                .iter()
                .any(|f| near(*f, mode.f_hz, MODE_TOLERANCE)),
            _ => false,
        };
        j.found.push(in_base || !naming.is_empty());
        j.swapped |= claims
            .iter()
            .any(|c| swapped_compound(case, first.fault, c, &d.injection).is_some());
        j.freq_rel_error.push(
            naming
                .iter()
                .filter_map(|(c, truth)| Some((c.effect.as_ref()?, (*truth)?)))
                .flat_map(|(e, f)| relative_errors(claimed_frequencies(e), &d.injection, f))
                .reduce(f64::min),
        );
    }
    for c in claims {
        if case
            .injected
            .iter()
            .any(|d| truth_of(c, &d.injection).is_some())
        {
            continue;
        }
        if base_property(c, case) || before.iter().any(|b| same_claim(c, b)) {
            j.base_claims.push(c.name.clone());
        } else {
            j.false_claims.push(c.name.clone());
        }
    }
    j
}

/// Score one case's report; `before` as in [`judge`].
pub fn score(case: Case, report: &LoopReport, before: &[Claim]) -> Outcome {
    let claims = claims(report);
    let modes = first_fit_modes(&report.params_initial, &report.base_terms);
    let first = FirstFit {
        fault: &report.fault,
        modes: &modes,
    };
    let j = judge(&case, &claims, first, before);
    let fault_true = case.base.defect.map_or("none", |d| d.name()).to_string();
    Outcome {
        claimed_effects: claims.iter().filter_map(|c| c.effect.clone()).collect(),
        base_terms: report.base_terms.clone(),
        claims: claims.into_iter().map(|c| c.name).collect(),
        found: j.found,
        freq_rel_error: j.freq_rel_error,
        false_claims: j.false_claims,
        base_claims: j.base_claims,
        fault_right: report.fault == fault_true || j.swapped,
        fault_claimed: report.fault.clone(),
        fault_true,
        psd_initial_db: f64::from(report.error_initial.psd_log_rmse_db),
        psd_final_db: f64::from(report.error_final.psd_log_rmse_db),
        psd_scatter_db: report.psd_scatter_db.map(f64::from),
        seconds: report.seconds,
        error: None,
        case,
    }
}

/// A case whose loop failed: it claims nothing and finds nothing.
pub fn failed(case: Case, error: String) -> Outcome {
    let n = case.injected.len();
    Outcome {
        claims: Vec::new(),
        claimed_effects: Vec::new(),
        base_terms: Vec::new(),
        found: vec![false; n],
        freq_rel_error: vec![None; n],
        false_claims: Vec::new(),
        base_claims: Vec::new(),
        fault_right: false,
        fault_claimed: "error".into(),
        fault_true: case.base.defect.map_or("none", |d| d.name()).to_string(),
        psd_initial_db: f64::NAN,
        psd_final_db: f64::NAN,
        psd_scatter_db: None,
        seconds: 0.0,
        error: Some(error),
        case,
    }
}

/// Per injection kind: cases, found per strength bin, frequency errors.
#[derive(Debug, Clone, Default)]
pub struct EffectTally {
    /// Injected per bin.
    pub injected: [usize; 3],
    /// Found per bin.
    pub found: [usize; 3],
    /// Relative frequency errors of the found ones that name a frequency.
    pub freq_errors: Vec<f64>,
}

/// Per claim name: how often it was made and how often it was true.
#[derive(Debug, Clone, Default)]
pub struct ClaimTally {
    /// Claims made.
    pub made: usize,
    /// Of them true.
    pub true_: usize,
    /// Of them naming a base property.
    pub base: usize,
    /// Of them on clean controls.
    pub on_controls: usize,
}

/// The whole benchmark's figures.
#[derive(Debug, Clone, Default)]
pub struct Summary {
    /// Cases.
    pub cases: usize,
    /// Cases whose loop ran into an error.
    pub errors: usize,
    /// Clean controls, and those with any claim.
    pub controls: usize,
    /// Controls with at least one claim.
    pub controls_claiming: usize,
    /// Controls with at least one false claim.
    pub controls_false: usize,
    /// Per injection kind (sorted by name).
    pub effects: Vec<(String, EffectTally)>,
    /// Per claim name (sorted by name).
    pub claims: Vec<(String, ClaimTally)>,
    /// Relative PSD error drops (initial − final)/initial on effect cases.
    pub drops_effect: Vec<f64>,
    /// The same on controls.
    pub drops_control: Vec<f64>,
    /// First fit's PSD error over the record's scatter, on controls.
    pub base_over_scatter: Vec<f64>,
    /// Fault hypothesis right / cases with a loop result.
    pub fault_right: usize,
    /// Cases with a loop result.
    pub fault_cases: usize,
    /// Loop wall times, s.
    pub seconds: Vec<f64>,
}

/// Tally the outcomes.
pub fn summarize(outcomes: &[Outcome]) -> Summary {
    use std::collections::BTreeMap;
    let mut s = Summary {
        cases: outcomes.len(),
        ..Summary::default()
    };
    let mut effects: BTreeMap<String, EffectTally> = BTreeMap::new();
    let mut claims: BTreeMap<String, ClaimTally> = BTreeMap::new();
    for o in outcomes {
        if o.error.is_some() {
            s.errors += 1;
        }
        let control = o.case.injected.is_empty();
        if control {
            s.controls += 1;
            s.controls_claiming += usize::from(!o.claims.is_empty());
            s.controls_false += usize::from(!o.false_claims.is_empty());
        }
        for (i, d) in o.case.injected.iter().enumerate() {
            let t = effects.entry(d.injection.name().into()).or_default();
            let b = bin(d.u);
            t.injected[b] += 1;
            t.found[b] += usize::from(o.found[i]);
            if let (true, Some(e)) = (o.found[i], o.freq_rel_error[i]) {
                t.freq_errors.push(e);
            }
        }
        for c in &o.claims {
            let t = claims.entry(c.clone()).or_default();
            t.made += 1;
            let is_base = o.base_claims.contains(c);
            t.base += usize::from(is_base);
            t.true_ += usize::from(!is_base && !o.false_claims.contains(c));
            t.on_controls += usize::from(control);
        }
        if o.error.is_none() {
            let drop = (o.psd_initial_db - o.psd_final_db) / o.psd_initial_db;
            if control {
                s.drops_control.push(drop);
                if let Some(sc) = o.psd_scatter_db {
                    s.base_over_scatter.push(o.psd_initial_db / sc);
                }
            } else {
                s.drops_effect.push(drop);
            }
            s.fault_cases += 1;
            s.fault_right += usize::from(o.fault_right);
            s.seconds.push(o.seconds);
        }
    }
    s.effects = effects.into_iter().collect();
    s.claims = claims.into_iter().collect();
    s
}

fn pct(a: usize, b: usize) -> String {
    if b == 0 {
        "–".into()
    } else {
        format!("{:.0} % ({a}/{b})", 100.0 * a as f64 / b as f64)
    }
}

fn median(v: &[f64]) -> f64 {
    let mut v: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// The report as markdown.
pub fn markdown(s: &Summary, command: &str) -> String {
    let mut m = String::new();
    m.push_str("# The closed loop on randomized records with undeclared effects\n\n");
    m.push_str(&format!(
        "Generated by `{command}` (`pumptwin_twin::bench`). Each case is a record \
         synthesized from Randall & Antoni's (2011) bearing signal with its conditions \
         drawn at random (geometry, 600–3600 rpm, fault type incl. none, slip 0.5–2 %, \
         strength spread 5–30 %, load zone, 1–3 modes, background and sensor noise, \
         acquisition at 10.24/12/12.8 kHz behind an anti-alias filter) and 0–2 effects \
         of random strength. The loop is told the signal, its rate, the nominal speed \
         and the geometry, nothing else. A claim that no injection accepts is false, \
         whatever it names (see `bench::score`).\n\n"
    ));
    m.push_str(&markdown_tables(s));
    m
}

/// The figures and tables of a summary as markdown (no title).
pub fn markdown_tables(s: &Summary) -> String {
    let mut m = String::new();
    let mut line = |t: String| {
        m.push_str(&t);
        m.push('\n');
    };
    line(format!(
        "- cases: {} ({} clean controls), loops that failed: {}",
        s.cases, s.controls, s.errors
    ));
    line(format!(
        "- **false claims on clean controls: {}** of controls make at least one false claim; \
         {} make any claim (a base property named as an effect included)",
        pct(s.controls_false, s.controls),
        pct(s.controls_claiming, s.controls)
    ));
    line(format!(
        "- fault hypothesis right: {}",
        pct(s.fault_right, s.fault_cases)
    ));
    line(format!(
        "- PSD error drop, mean: {:.1} % on effect cases ({} cases), {:.1} % on controls",
        100.0 * mean(&s.drops_effect),
        s.drops_effect.len(),
        100.0 * mean(&s.drops_control)
    ));
    line(format!(
        "- first fit's PSD error over the record's half-to-half scatter on controls: median {:.2}× ({} controls)",
        median(&s.base_over_scatter),
        s.base_over_scatter.len()
    ));
    line(format!(
        "- loop wall time per case: median {:.1} s, max {:.1} s",
        median(&s.seconds),
        s.seconds.iter().copied().fold(0.0, f64::max)
    ));
    line(String::new());
    line("## Recall per injected effect, by strength bin".into());
    line(String::new());
    line(format!(
        "| effect | {} | {} | {} | all | median frequency error |",
        BINS[0], BINS[1], BINS[2]
    ));
    line("|---|---|---|---|---|---|".into());
    for (name, t) in &s.effects {
        let fe = if t.freq_errors.is_empty() {
            "–".to_string()
        } else {
            format!("{:.2} %", 100.0 * median(&t.freq_errors))
        };
        line(format!(
            "| {name} | {} | {} | {} | {} | {fe} |",
            pct(t.found[0], t.injected[0]),
            pct(t.found[1], t.injected[1]),
            pct(t.found[2], t.injected[2]),
            pct(t.found.iter().sum(), t.injected.iter().sum()),
        ));
    }
    line(String::new());
    line("## Precision per claim".into());
    line(String::new());
    line(
        "Precision = true / (made − base property); a base property named as an effect is \
         counted apart (see `bench::score`)."
            .into(),
    );
    line(String::new());
    line("| claim | made | true | base property | false | precision | on clean controls |".into());
    line("|---|---|---|---|---|---|---|".into());
    for (name, t) in &s.claims {
        line(format!(
            "| {name} | {} | {} | {} | {} | {} | {} |",
            t.made,
            t.true_,
            t.base,
            t.made - t.true_ - t.base,
            pct(t.true_, t.made - t.base),
            t.on_controls
        ));
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::draw::{draw_case, Drawn, Mode};

    fn claim(name: &str, effect: Option<Effect>) -> Claim {
        Claim {
            name: name.into(),
            effect,
        }
    }

    fn outcome(defect: Option<Defect>, injected: Vec<Injection>, claims: &[Claim]) -> Outcome {
        let mut case = draw_case(0, 1, 2.0);
        case.base.defect = defect;
        case.base.modes = vec![Mode {
            f_hz: 3000.0,
            zeta: 0.03,
            gain: 1.0,
        }];
        case.injected = injected
            .into_iter()
            .map(|injection| Drawn { injection, u: 0.5 })
            .collect();
        let first = FirstFit {
            fault: "none",
            modes: &[3010.0, 1990.0],
        };
        let j = judge(&case, claims, first, &[]);
        Outcome {
            claims: claims.iter().map(|c| c.name.clone()).collect(),
            claimed_effects: Vec::new(),
            base_terms: Vec::new(),
            found: j.found,
            freq_rel_error: j.freq_rel_error,
            false_claims: j.false_claims,
            base_claims: j.base_claims,
            fault_claimed: "none".into(),
            fault_true: "none".into(),
            fault_right: true,
            psd_initial_db: 4.0,
            psd_final_db: 2.0,
            psd_scatter_db: Some(1.0),
            seconds: 1.0,
            error: None,
            case,
        }
    }

    /// A loop that takes a compound's second defect for the first and names the
    /// base's own as the second train has named both: the compound is found, the
    /// hypothesis right, nothing false. A second train elsewhere, or the same train
    /// under another hypothesis, is not.
    #[test]
    fn a_compound_is_found_with_its_two_defects_swapped() {
        let mut case = draw_case(0, 1, 2.0);
        case.base.defect = Some(Defect::Ball);
        let own = case.base.impact_rate_hz(Defect::Ball);
        let compound = Injection::Compound {
            defect: Defect::OuterRace,
            rel: 0.5,
            rate_hz: case.base.impact_rate_hz(Defect::OuterRace),
        };
        case.injected = vec![Drawn {
            injection: compound,
            u: 0.7,
        }];
        let train = |rate_hz: f64| {
            claim(
                "second_impact_train",
                Some(Effect::SecondImpactTrain {
                    rate_hz,
                    source: "ball".into(),
                }),
            )
        };
        let read = |fault, rate| {
            let first = FirstFit { fault, modes: &[] };
            judge(&case, &[train(rate)], first, &[])
        };
        let j = read("outer_race", own * 1.01);
        assert_eq!(
            (j.found, j.false_claims.len(), j.swapped),
            (vec![true], 0, true)
        );
        assert!(j.freq_rel_error[0].is_some_and(|e| (e - 0.01).abs() < 1e-9));
        let j = read("outer_race", own * 1.2);
        assert_eq!(
            (j.found, j.false_claims.len(), j.swapped),
            (vec![false], 1, false)
        );
        let j = read("inner_race", own);
        assert_eq!(
            (j.found, j.false_claims.len(), j.swapped),
            (vec![false], 1, false)
        );
    }

    /// A second train names a compound, and a modulation an injected one, only at
    /// its rate: elsewhere it is another effect, found nowhere and false.
    #[test]
    fn a_rate_is_part_of_the_claim() {
        let compound = Injection::Compound {
            defect: Defect::InnerRace,
            rel: 0.3,
            rate_hz: 160.0,
        };
        let train = |rate_hz: f64| {
            claim(
                "second_impact_train",
                Some(Effect::SecondImpactTrain {
                    rate_hz,
                    source: "inner_race".into(),
                }),
            )
        };
        let right = outcome(
            Some(Defect::OuterRace),
            vec![compound.clone()],
            &[train(161.0)],
        );
        assert_eq!(
            (right.found.clone(), right.false_claims.len()),
            (vec![true], 0)
        );
        let wrong = outcome(Some(Defect::OuterRace), vec![compound], &[train(110.0)]);
        assert_eq!(wrong.found, [false]);
        assert_eq!(wrong.false_claims, ["second_impact_train"]);
        let modulation = Injection::Modulation {
            f_hz: 7.0,
            depth: 0.3,
        };
        let lzm = |mod_hz: f64| {
            claim(
                "load_zone_modulation",
                Some(Effect::LoadZoneModulation { mod_hz }),
            )
        };
        let o = outcome(
            Some(Defect::OuterRace),
            vec![modulation.clone()],
            &[lzm(7.1)],
        );
        assert_eq!(o.found, [true]);
        let o = outcome(Some(Defect::OuterRace), vec![modulation], &[lzm(10.0)]);
        assert_eq!((o.found.clone(), o.false_claims.len()), (vec![false], 1));
    }

    /// A strong injected mode is often where the first fit puts the structure's first
    /// mode, the base's own then taken as a further one: found in the base all the
    /// same, and the first fit's modes are read from both places.
    #[test]
    fn a_mode_the_first_fit_took_as_its_first_is_in_the_base() {
        let mut params = serde_json::Map::new();
        params.insert("fn_hz".into(), serde_json::json!(1245.5));
        params.insert("fn2_hz".into(), serde_json::json!(2723.7));
        let terms = [
            "extra_resonance@2724Hz".to_string(),
            "load_zone".to_string(),
        ];
        let modes = first_fit_modes(&params, &terms);
        assert_eq!(modes, [1245.5, 2724.0]);
        let mut case = draw_case(0, 1, 2.0);
        let extra = |f_hz| Injection::ExtraMode {
            mode: Mode {
                f_hz,
                zeta: 0.03,
                gain: 1.0,
            },
        };
        case.injected = vec![
            Drawn {
                injection: extra(1232.0),
                u: 0.8,
            },
            Drawn {
                injection: extra(1500.0),
                u: 0.8,
            },
        ];
        let first = FirstFit {
            fault: "none",
            modes: &modes,
        };
        assert_eq!(judge(&case, &[], first, &[]).found, [true, false]);
        assert!(first_fit_modes(&serde_json::Map::new(), &terms) == [2724.0]);
    }

    /// A control with random bursts claimed counts against the false-claim rate; an
    /// extra mode is found only at its frequency, by a claim or in the base's terms; slip on a record with a defect and a
    /// mode at the base's own are base properties, not false claims; slip on a healthy
    /// record is false.
    #[test]
    fn claims_are_judged_against_the_injections_and_the_base() {
        let mode = Injection::ExtraMode {
            mode: Mode {
                f_hz: 2000.0,
                zeta: 0.03,
                gain: 1.0,
            },
        };
        let res = |f_hz: f64| claim("extra_resonance", Some(Effect::ExtraResonance { f_hz }));
        let bursts = claim(
            "random_bursts",
            Some(Effect::RandomBursts {
                f_hz: 3000.0,
                bandwidth_hz: 300.0,
            }),
        );
        let slip = claim("slip", Some(Effect::Slip));
        let outs = vec![
            outcome(None, vec![], &[bursts]),
            outcome(None, vec![], &[]),
            outcome(
                Some(Defect::OuterRace),
                vec![mode.clone()],
                &[res(2030.0), slip.clone()],
            ),
            outcome(Some(Defect::OuterRace), vec![mode.clone()], &[res(3050.0)]),
            outcome(None, vec![mode], &[slip]),
        ];
        assert_eq!(outs[2].base_claims, ["slip"]);
        assert_eq!(outs[3].base_claims, ["extra_resonance"]);
        assert_eq!(outs[4].false_claims, ["slip"]);
        let s = summarize(&outs);
        assert_eq!(
            (s.controls, s.controls_claiming, s.controls_false),
            (2, 1, 1)
        );
        let (_, t) = s.effects.iter().find(|(n, _)| n == "extra_mode").unwrap();
        // Found at 2030 Hz by a claim, and (in base terms at 1990 Hz) by every case.
        assert_eq!((t.injected[1], t.found[1]), (3, 3));
        let get = |n: &str| s.claims.iter().find(|(c, _)| c == n).unwrap().1.clone();
        let r = get("extra_resonance");
        assert_eq!((r.made, r.true_, r.base), (2, 1, 1));
        let sl = get("slip");
        assert_eq!((sl.made, sl.true_, sl.base), (2, 0, 1));
        assert_eq!(get("random_bursts").on_controls, 1);
        assert_eq!(s.drops_effect.len(), 3);
        assert!((s.base_over_scatter[0] - 4.0).abs() < 1e-9);
        // On a measured base, a claim the record made before the injection is its
        // own: counted with the base properties; another mode is still false.
        let mut case = draw_case(0, 1, 2.0);
        case.base.defect = None;
        case.base.modes.clear();
        case.injected.clear();
        let before = [res(2600.0), claim("dropouts", None)];
        let j = judge(
            &case,
            &[res(2650.0), res(4000.0), claim("dropouts", None)],
            FirstFit {
                fault: "none",
                modes: &[],
            },
            &before,
        );
        assert_eq!(j.base_claims, ["extra_resonance", "dropouts"]);
        assert_eq!(j.false_claims, ["extra_resonance"]);
        let md = markdown(&s, "test");
        assert!(md.contains("controls: 50 % (1/2)"), "{md}");
    }
}
