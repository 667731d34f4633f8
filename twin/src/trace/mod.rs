//! Step 3 of the loop: trace the residual's significant components to the effects the
//! model lacks, one tracer per kind of evidence, each offering candidates with their
//! evidence and a strength that orders them.
//!
//! | tracer | reads | offers |
//! |---|---|---|
//! | [`lines`] | PSD lines | mains, shaft harmonics, shaft-order tones, half orders, an unexplained tone (one that keeps its phase over the record) |
//! | [`bands`] | PSD bands, the band-limited kurtosis | a structural mode, a band at the sensor, random bursts, random impacts |
//! | [`modulation`] | envelope sidebands | a load-zone (or other) modulation of the impacts |
//! | [`impact_train`] | envelope harmonic families | a second impact train |
//! | `told_defect` | the envelope at the defect rates the geometry tells, against the model's realizations | a second defect too weak for the line search |
//! | [`comb`] | the defect comb's contrast by order | slip, speed drift |
//! | [`stiffness`] | ring-down frequencies | nonlinear stiffness |
//!
//! [`context`] holds what they all read. Tracers never import one another but for the
//! second train, whose PSD lines the line tracer leaves to it.

pub mod bands;
pub mod comb;
pub mod context;
pub mod impact_train;
pub mod lines;
pub mod modulation;
pub mod null;
pub mod stiffness;
mod told_defect;

pub use context::TraceContext;
pub use impact_train::{second_train, SecondTrain};
pub use modulation::{measured_modulation, MeasuredModulation};
pub use null::{KeptDraws, NullDraws, NullTest};

use crate::effect::location_named;
use crate::residual::{Candidate, ResidualAnalysis};
use crate::twin::EffectKind;
use context::{has, second_train_key};

/// Trace the residual to candidate effects the model lacks (strongest first; equal
/// strengths keep the tracers' order).
pub fn trace(analysis: &ResidualAnalysis, ctx: &TraceContext<'_>) -> Vec<Candidate> {
    let model = ctx.model;
    let span_s = ctx.x.len() as f64 / f64::from(ctx.cfg.fs_hz);
    // A second impact train puts lines at k·r in the PSD too: read first, so that the
    // line tracer leaves them to it.
    let trains: Vec<SecondTrain> = if has(model, EffectKind::SecondImpactTrain) {
        Vec::new()
    } else {
        // A family read off the residual's lines that names a bearing defect first;
        // else the defects at the rates the geometry tells (`told_defect`), whose
        // null test is more specific than a family of lines at a rate nothing names,
        // and that family too (the refit judges each: a told reading can find a
        // family where impacts at a rate nothing names left their lines).
        let untried = |t: &SecondTrain| !ctx.tried.contains(&second_train_key(t.source));
        match second_train(analysis, model, ctx.cfg, &ctx.meas_psd_db, span_s) {
            Some(t) if location_named(t.source).is_some() && untried(&t) => vec![t],
            other => {
                let mut trains: Vec<SecondTrain> = other.into_iter().filter(untried).collect();
                trains.extend(told_defect::told_defect(ctx));
                trains
            }
        }
    };
    let mut out: Vec<Candidate> = Vec::new();
    lines::trace(analysis, ctx, trains.first(), &mut out);
    bands::trace(analysis, ctx, &mut out);
    bands::trace_random_impacts(ctx, &mut out);
    modulation::trace(analysis, ctx, &mut out);
    for t in trains {
        impact_train::candidate(t, ctx, &mut out);
    }
    comb::trace(ctx, &mut out);
    stiffness::trace(ctx, &mut out);
    out.sort_by(|a, b| b.strength.total_cmp(&a.strength));
    out
}
