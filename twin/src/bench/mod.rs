//! The closed loop's benchmark on randomized records with undeclared effects
//! (`pumptwin twin bench`): how often each claim is right, how often the loop claims
//! something on a clean record, how much of the error it takes away.
//!
//! | file | step |
//! |---|---|
//! | [`draw`] | one case: a base with its conditions drawn, 0–2 effects of random strength |
//! | [`synth`] | its record, from the literature's bearing signal (nothing shared with the twin) |
//! | [`measured`] | the same effects added to measured records, and their controls |
//! | [`score`] | the loop's claims against the injections, and the tables |
//!
//! The generator is written from the literature (Randall & Antoni 2011), not from the
//! loop's list of candidates: it has effects the loop has no name for (clipping and
//! dropouts aside, e.g. a mesh tone's sidebands, a process modulation at no rate of
//! the bearing), and it puts into every base what every bearing signal has (slip
//! jitter, a spread of strengths, the load zone, several modes), so a loop that calls
//! those an effect is caught claiming falsely.

pub mod draw;
pub mod measured;
pub mod score;
pub mod synth;

use crate::closed_loop::{note_clipping, run as run_loop, LoopConfig, LoopInput};
use draw::{draw_case, Case};
use score::Outcome;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Seconds per record: the loop's default span (6 s) is all it reads.
pub const RECORD_SECONDS: f64 = 6.0;

/// Run the loop with `cfg` on one case and score it (the loop's whole report written
/// to `report_to` too, if given). A loop error or a panic is the case's outcome
/// (counted in the report), not the benchmark's end.
pub fn run_case(case: Case, cfg: &LoopConfig, report_to: Option<&Path>) -> Outcome {
    let x = synth::synthesize(&case, RECORD_SECONDS);
    score_signal(case, x, cfg, &[], report_to)
}

/// Run the loop with `cfg` on `x`, the record of `case` (its rate, speed and geometry
/// from `case.base`), and score it against the case's injections and `before` (as in
/// [`score::judge`]). A loop error or a panic is the outcome, not the benchmark's end.
/// With `report_to`, the loop's whole report is written there as JSON too.
pub(crate) fn score_signal(
    case: Case,
    x: Vec<f32>,
    cfg: &LoopConfig,
    before: &[score::Claim],
    report_to: Option<&Path>,
) -> Outcome {
    let input = LoopInput {
        signal: x,
        fs_hz: case.base.fs_hz as f32,
        rpm: case.base.rpm as f32,
        bearing: case.base.bearing,
        held_runs: None,
    };
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run_loop(&input, cfg)));
    match result {
        Ok(Ok((mut report, _))) => {
            note_clipping(&mut report, &input.signal);
            if let Some(path) = report_to {
                let written = serde_json::to_vec_pretty(&report)
                    .map_err(|e| e.to_string())
                    .and_then(|b| std::fs::write(path, b).map_err(|e| e.to_string()));
                if let Err(e) = written {
                    eprintln!(
                        "case {}: report not written to {}: {e}",
                        case.id,
                        path.display()
                    );
                }
            }
            score::score(case, &report, before)
        }
        Ok(Err(e)) => score::failed(case, e.to_string()),
        Err(p) => {
            let why = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            score::failed(case, format!("panic: {why}"))
        }
    }
}

/// Draw `cases` cases from `seed` and run the loop with `cfg` on them on `threads`
/// threads; outcomes in case order. `progress` is called after each case with the
/// number done.
pub fn run(
    cases: usize,
    seed: u64,
    threads: usize,
    cfg: &LoopConfig,
    progress: &(dyn Fn(usize) + Sync),
) -> Vec<Outcome> {
    let ids: Vec<usize> = (0..cases).collect();
    run_ids(&ids, seed, threads, cfg, None, progress)
}

/// Run the loop on the cases `ids` of the draw from `seed` only (a subset to look at
/// while developing: a draw's case depends on its id and the seed alone); outcomes
/// in the order of `ids`. With `reports`, each loop's whole report is written there as
/// `case-ID.json`.
pub fn run_ids(
    ids: &[usize],
    seed: u64,
    threads: usize,
    cfg: &LoopConfig,
    reports: Option<&Path>,
    progress: &(dyn Fn(usize) + Sync),
) -> Vec<Outcome> {
    let done = AtomicUsize::new(0);
    par_map(ids.len(), threads, &|i| {
        let path = reports.map(|d| d.join(format!("case-{}.json", ids[i])));
        let o = run_case(
            draw_case(ids[i], seed, RECORD_SECONDS),
            cfg,
            path.as_deref(),
        );
        progress(done.fetch_add(1, Ordering::Relaxed) + 1);
        o
    })
}

/// `f` over `0..n` on `threads` threads, results in index order.
pub(crate) fn par_map<R: Send>(
    n: usize,
    threads: usize,
    f: &(dyn Fn(usize) -> R + Sync),
) -> Vec<R> {
    let next = AtomicUsize::new(0);
    let out: Mutex<Vec<Option<R>>> = Mutex::new((0..n).map(|_| None).collect());
    std::thread::scope(|s| {
        for _ in 0..threads.max(1) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= n {
                    break;
                }
                let r = f(i);
                if let Ok(mut v) = out.lock() {
                    v[i] = Some(r);
                }
            });
        }
    });
    out.into_inner()
        .unwrap_or_default()
        .into_iter()
        .flatten()
        .collect()
}
