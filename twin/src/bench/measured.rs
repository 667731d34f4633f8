//! The benchmark on measured bases (`pumptwin twin bench --measured DIR`): the same
//! effects added to real records, scored the same way.
//!
//! A synthesized base knows everything it holds; a measured one does not: its own
//! effects (a mains line, a mode the twin lacks, a real machine's tones) are part of
//! it and nobody declared them. So each record is first run as it is, and what the
//! loop claims there is the record's own (`before`): a claim that says the same again
//! after an injection is counted with the base properties, neither credited nor
//! false ([`score::judge`]). What is measured:
//!
//! - **recall and precision** of each effect on the injected cases: a stretch of the
//!   record (the loop's span from its start, as the loop reads it) with one or two
//!   effects of [`draw_measured_case`]'s kinds added;
//! - **false claims on measured controls**: where a record is long enough, its last
//!   span, which begins at least [`CONTROL_GAP_S`] later than the first, run with
//!   nothing added. A claim there that the first span did not make is false: the
//!   record's own effects do not come and go within ten seconds of a steady run, so a
//!   claim that does is the loop's, not the machine's.
//!
//! What cannot be added to a measured record is left out and said so: effects that
//! act on the record's own impacts or structure (a modulation of them, an extra mode
//! they drive, a speed drift, a stiffening) — its impacts cannot be taken apart.

use super::draw::{draw_measured_case, Base, Case, Defect};
use super::score::{self, Claim, Outcome};
use super::synth::inject_measured;
use super::{par_map, score_signal};
use crate::closed_loop::LoopConfig;
use crate::twin::Effect;
use pumptwin_core::bearing::BearingGeometry;
use pumptwin_core::rng::Xoshiro128pp;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Least time between the starts of a record's first span and its control span, s.
pub const CONTROL_GAP_S: f64 = 2.0;

/// One measured record, at the rate the loop reads it.
#[derive(Debug, Clone)]
pub struct MeasuredBase {
    /// Its name (file or label).
    pub record: String,
    /// The rig (data set) it comes from.
    pub rig: String,
    /// Sampling rate, Hz.
    pub fs_hz: f32,
    /// Shaft speed, rpm.
    pub rpm: f32,
    /// Bearing geometry.
    pub bearing: BearingGeometry,
    /// The defect its data set states (`None`: healthy).
    pub defect: Option<Defect>,
    /// The channel the loop reads, g (or the record's own unit: every injection is
    /// relative to the record's RMS).
    pub samples: Vec<f32>,
}

/// What the loop said on a record's first span with nothing added.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Before {
    /// The record.
    pub record: String,
    /// Its rig.
    pub rig: String,
    /// Its stated defect.
    pub fault_true: String,
    /// The fault the loop assumed.
    pub fault_claimed: String,
    /// The loop's claims.
    pub claims: Vec<String>,
    /// The effects behind them.
    pub effects: Vec<Effect>,
    /// PSD error of the first fit and at the end, dB.
    pub psd_db: (f64, f64),
    /// The loop's error, if any.
    pub error: Option<String>,
    /// Wall time, s.
    pub seconds: f64,
    #[serde(skip)]
    kept: Vec<Claim>,
}

/// One scored case on a measured base.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MeasuredOutcome {
    /// The record.
    pub record: String,
    /// Its rig.
    pub rig: String,
    /// `first` (the injected cases) or `last` (the controls).
    pub span: &'static str,
    /// Per injection: whether a claim of the record as it is named it already (a
    /// mains line the record has, tones at the orders injected): found then says
    /// nothing of the loop.
    pub named_before: Vec<bool>,
    /// The case and its score.
    #[serde(flatten)]
    pub outcome: Outcome,
}

/// The benchmark's results.
#[derive(Debug, Clone)]
pub struct MeasuredRun {
    /// Per record, the loop on its first span as it is.
    pub before: Vec<Before>,
    /// The controls (last spans) and the injected cases, in that order.
    pub outcomes: Vec<MeasuredOutcome>,
}

/// Samples in the loop's span (`seconds`) of a record.
fn span_len(b: &MeasuredBase, seconds: f64) -> usize {
    (seconds * f64::from(b.fs_hz)) as usize
}

/// A record's span of `seconds`: the first (`last` false) or the last.
fn span(b: &MeasuredBase, seconds: f64, last: bool) -> &[f32] {
    let n = span_len(b, seconds).min(b.samples.len());
    if last {
        &b.samples[b.samples.len() - n..]
    } else {
        &b.samples[..n]
    }
}

/// The synthetic description a measured record's cases carry: its rate, speed,
/// geometry and defect; its RMS as the injections' reference (`background_g`); and the
/// settings a compound fault's second train is synthesized with (slip 1 %, spread
/// 15 %, ε 0.4, 1 % under the kinematic rate).
fn describe(b: &MeasuredBase, x: &[f32]) -> Base {
    let rms = (x.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / x.len().max(1) as f64).sqrt();
    Base {
        fs_hz: f64::from(b.fs_hz),
        rpm: f64::from(b.rpm),
        bearing: b.bearing,
        defect: b.defect,
        rate_factor: -0.01,
        slip: 0.01,
        spread: 0.15,
        load_zone_eps: 0.4,
        ball_alternate: 0.75,
        modes: Vec::new(),
        impact_g: 0.0,
        background_g: rms,
        noise_g: 0.0,
    }
}

/// The loop on each record's first span as it is.
fn run_before(
    bases: &[MeasuredBase],
    threads: usize,
    cfg: &LoopConfig,
    progress: &(dyn Fn() + Sync),
) -> Vec<Before> {
    par_map(bases.len(), threads, &|i| {
        let b = &bases[i];
        let x = span(b, cfg.max_record_seconds, false).to_vec();
        let case = Case {
            id: i,
            seed: 0,
            base: describe(b, &x),
            injected: Vec::new(),
        };
        let o = score_signal(case, x, cfg, &[], None);
        progress();
        Before {
            record: b.record.clone(),
            rig: b.rig.clone(),
            fault_true: o.fault_true.clone(),
            fault_claimed: o.fault_claimed.clone(),
            kept: o.claims_made(),
            claims: o.claims,
            effects: o.claimed_effects,
            psd_db: (o.psd_initial_db, o.psd_final_db),
            error: o.error,
            seconds: o.seconds,
        }
    })
}

/// Which records have a control, and the order in which injected cases visit the
/// records (shuffled by the seed, so that every record carries about as many).
struct Plan {
    controls: Vec<usize>,
    order: Vec<usize>,
}

impl Plan {
    fn new(bases: &[MeasuredBase], seed: u64, cfg: &LoopConfig) -> Self {
        let controls = (0..bases.len())
            .filter(|&i| {
                let b = &bases[i];
                b.samples.len() as f64
                    >= span_len(b, cfg.max_record_seconds) as f64
                        + CONTROL_GAP_S * f64::from(b.fs_hz)
            })
            .collect();
        let mut order: Vec<usize> = (0..bases.len()).collect();
        let mut rng = Xoshiro128pp::seed_from_u64(seed ^ 0xBA5E);
        for i in (1..order.len()).rev() {
            let j = ((rng.uniform() * (i + 1) as f64) as usize).min(i);
            order.swap(i, j);
        }
        Self { controls, order }
    }

    /// Job `k` (the controls first, then the injected cases): its record, whether it is
    /// a control, its case and the signal the loop reads.
    fn job(
        &self,
        bases: &[MeasuredBase],
        k: usize,
        seed: u64,
        cfg: &LoopConfig,
    ) -> (usize, bool, Case, Vec<f32>) {
        let (i, last) = if k < self.controls.len() {
            (self.controls[k], true)
        } else {
            (
                self.order[(k - self.controls.len()) % bases.len().max(1)],
                false,
            )
        };
        let b = &bases[i];
        let x = span(b, cfg.max_record_seconds, last);
        let seconds = x.len() as f64 / f64::from(b.fs_hz);
        if last {
            let case = Case {
                id: k,
                seed: 0,
                base: describe(b, x),
                injected: Vec::new(),
            };
            (i, true, case, x.to_vec())
        } else {
            let case = draw_measured_case(k, seed, describe(b, x), seconds);
            let y = inject_measured(&case, x);
            (i, false, case, y)
        }
    }
}

/// Case `id` of a run on `bases` with `seed` (`id` as in its `cases.jsonl`: the
/// controls first, then the injected cases): its record's index, the case and the
/// signal the loop reads. `None` past the last case of a run of `cases` cases.
pub fn measured_case(
    bases: &[MeasuredBase],
    id: usize,
    cases: usize,
    seed: u64,
    cfg: &LoopConfig,
) -> Option<(usize, Case, Vec<f32>)> {
    let plan = Plan::new(bases, seed, cfg);
    (id < plan.controls.len() + cases && !bases.is_empty()).then(|| {
        let (i, _, case, signal) = plan.job(bases, id, seed, cfg);
        (i, case, signal)
    })
}

/// Run the benchmark on `bases`: each record as it is, a control on each record long
/// enough for one, and `cases` injected cases drawn from `seed` ([`Plan`]).
/// `progress` is called after each loop with the number done and the total.
pub fn run_measured(
    bases: &[MeasuredBase],
    cases: usize,
    seed: u64,
    threads: usize,
    cfg: &LoopConfig,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> MeasuredRun {
    let plan = Plan::new(bases, seed, cfg);
    let total = bases.len() + plan.controls.len() + cases;
    let done = AtomicUsize::new(0);
    let tick = || progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
    let before = run_before(bases, threads, cfg, &tick);
    let jobs = plan.controls.len() + cases;
    let outcomes = par_map(jobs, threads, &|k| {
        let (i, last, case, signal) = plan.job(bases, k, seed, cfg);
        let b = &bases[i];
        let o = score_signal(case, signal, cfg, &before[i].kept, None);
        tick();
        MeasuredOutcome {
            record: b.record.clone(),
            rig: b.rig.clone(),
            span: if last { "last" } else { "first" },
            named_before: o
                .case
                .injected
                .iter()
                .map(|d| before[i].kept.iter().any(|c| score::names(c, &d.injection)))
                .collect(),
            outcome: o,
        }
    });
    MeasuredRun { before, outcomes }
}

/// The report as markdown: the figures and tables of [`score::markdown_tables`] over
/// every case, the false claims on controls per rig, and what the loop said on each
/// record before anything was added.
pub fn markdown(run: &MeasuredRun, command: &str, seconds: f64, threads: usize) -> String {
    let outcomes: Vec<Outcome> = run.outcomes.iter().map(|o| o.outcome.clone()).collect();
    let s = score::summarize(&outcomes);
    let mut m = String::new();
    m.push_str("# The closed loop on measured records with undeclared effects\n\n");
    m.push_str(&format!(
        "Generated by `{command}` (`pumptwin_twin::bench::measured`) in {seconds:.0} s on \
         {threads} thread(s). The bases are measured records (the loop's span, from the \
         start, at the rate the loop reads them), each first run as it is: what the loop \
         claims there is the record's own, and the same claim again after an injection \
         is counted with the base properties (not credited, not false). Each injected \
         case adds one or two effects of random strength that can be added to a \
         measured record — mains, shaft-order tones, mesh or vane tones with sidebands, \
         a compound fault's second train (synthesized alone through one drawn mode, at \
         −16 to −3 dB of the record's RMS), cavitation-like bursts, clipping, dropouts — \
         at levels relative to the record's RMS (`bench::draw`). The **controls** are \
         the records' last spans, at least {CONTROL_GAP_S} s after the first, with \
         nothing added: a claim there that the first span did not make is false. Not \
         added (they act on the record's own impacts or structure): modulation, an extra \
         mode, speed drift, stiffening.\n\n"
    ));
    m.push_str(&score::markdown_tables(&s));
    let (named, found): (usize, usize) = run
        .outcomes
        .iter()
        .flat_map(|o| o.named_before.iter().zip(&o.outcome.found))
        .fold((0, 0), |(n, f), (b, x)| {
            (n + usize::from(*b), f + usize::from(*b && *x))
        });
    m.push_str(&format!(
        "\nInjections that a claim of the record as it is named already: {named} \
         ({found} of them counted found above; the loop's claim there may be the \
         record's own).\n"
    ));
    m.push_str("\n## False claims on the controls, per rig\n\n");
    m.push_str("| rig | controls | with a false claim | false claims |\n|---|---|---|---|\n");
    let mut rigs: Vec<&str> = run.outcomes.iter().map(|o| o.rig.as_str()).collect();
    rigs.sort_unstable();
    rigs.dedup();
    for rig in rigs {
        let c: Vec<&MeasuredOutcome> = run
            .outcomes
            .iter()
            .filter(|o| o.rig == rig && o.outcome.case.injected.is_empty())
            .collect();
        let with = c
            .iter()
            .filter(|o| !o.outcome.false_claims.is_empty())
            .count();
        let names: Vec<String> = c
            .iter()
            .flat_map(|o| {
                o.outcome
                    .false_claims
                    .iter()
                    .map(|f| format!("{f} ({})", o.record))
            })
            .collect();
        m.push_str(&format!(
            "| {rig} | {} | {with} | {} |\n",
            c.len(),
            if names.is_empty() {
                "—".to_string()
            } else {
                names.join(", ")
            }
        ));
    }
    m.push_str("\n## What the loop says on each record as it is\n\n");
    m.push_str("| rig | record | stated | assumed | claims | PSD error, dB | s |\n|---|---|---|---|---|---|---|\n");
    for b in &run.before {
        m.push_str(&format!(
            "| {} | {} | {} | {} | {} | {:.2} → {:.2} | {:.1} |\n",
            b.rig,
            b.record,
            b.fault_true,
            b.fault_claimed,
            if b.claims.is_empty() {
                b.error
                    .clone()
                    .map_or("—".to_string(), |e| format!("error: {e}"))
            } else {
                b.claims.join(", ")
            },
            b.psd_db.0,
            b.psd_db.1,
            b.seconds
        ));
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::draw::draw_case;
    use crate::bench::synth::synthesize;

    /// Two records (one long enough for a control) and three injected cases: every
    /// record is run as it is, the long one has its control, the injected cases visit
    /// the records, and the case `measured_case` rebuilds is the one the run scored.
    #[test]
    fn a_run_on_measured_bases_has_its_controls_and_rebuilds_its_cases() {
        let cfg = LoopConfig {
            max_record_seconds: 2.0,
            fit_seconds: 1.0,
            residual_seconds: 2.0,
            max_evaluations: 60,
            ..LoopConfig::default()
        };
        let base = |id: usize, seconds: f64| {
            let mut c = draw_case(id, 9, seconds);
            c.base.defect = Some(Defect::OuterRace);
            c.base.impact_g = 1.0;
            c.injected.clear();
            MeasuredBase {
                record: format!("r{id}"),
                rig: "test".into(),
                fs_hz: c.base.fs_hz as f32,
                rpm: c.base.rpm as f32,
                bearing: c.base.bearing,
                defect: c.base.defect,
                samples: synthesize(&c, seconds),
            }
        };
        let bases = [base(1, 4.5), base(2, 2.0)];
        let run = run_measured(&bases, 3, 5, 2, &cfg, &|_, _| {});
        assert_eq!(run.before.len(), 2);
        assert_eq!(run.outcomes.len(), 4);
        let controls: Vec<&MeasuredOutcome> =
            run.outcomes.iter().filter(|o| o.span == "last").collect();
        assert_eq!(controls.len(), 1);
        assert_eq!(controls[0].record, "r1");
        assert!(controls[0].outcome.case.injected.is_empty());
        for (k, o) in run.outcomes.iter().enumerate().skip(1) {
            assert!(!o.outcome.case.injected.is_empty());
            let (i, case, signal) = measured_case(&bases, k, 3, 5, &cfg).unwrap();
            assert_eq!(bases[i].record, o.record);
            assert_eq!(case, o.outcome.case);
            assert_eq!(signal.len(), (2.0 * bases[i].fs_hz) as usize);
        }
        assert!(measured_case(&bases, 4, 3, 5, &cfg).is_none());
    }
}
