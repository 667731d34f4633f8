//! Nonlinear stiffness: ring-downs whose frequency falls as they decay.

use super::context::{has, TraceContext};
use super::null::NullTest;
use crate::residual::{ringdown_frequencies, Candidate, Check, Evidence};
use crate::twin::Effect;
use crate::twin::EffectKind;

/// Offer nonlinear stiffness where ring-downs start faster than they end, more
/// than the model's do.
pub(super) fn trace(ctx: &TraceContext<'_>, out: &mut Vec<Candidate>) {
    let model = ctx.model;
    let fs = ctx.cfg.fs_hz;
    // --- Amplitude-dependent resonance frequency: nonlinear stiffness.
    if !has(model, EffectKind::NonlinearStiffness) {
        let fn_hz = model.get("ln_fn_hz").map_or(3000.0, f64::exp) as f32;
        let (lo, hi) = (0.75 * fn_hz, (1.25 * fn_hz).min(0.45 * fs));
        let rate = model
            .fault
            .map_or(0.0, |loc| model.op.freqs.impact_rate(loc));
        if let (true, Some((mh, mm)), Some((sh, sm))) = (
            rate > 0.0,
            ringdown_frequencies(ctx.x, fs, lo, hi, rate),
            ringdown_frequencies(ctx.sim, fs, lo, hi, rate),
        ) {
            let meas_shift = mh / mm - 1.0;
            let model_shift = sh / sm - 1.0;
            // Beyond the shifts the model's own realizations show against it
            // (`super::null`): ring-downs of impacts in noise scatter by a percent.
            let null = (meas_shift - model_shift > 0.01)
                .then(|| {
                    ctx.nulls.test(meas_shift - model_shift, |y| {
                        ringdown_frequencies(y, fs, lo, hi, rate)
                            .map(|(a, b)| a / b - 1.0 - model_shift)
                    })
                })
                .filter(NullTest::significant);
            if let Some(null) = null {
                let mut figures = serde_json::Map::new();
                figures.insert(
                    "null_test".into(),
                    null.figures("ringdown_relative_shift_over_model"),
                );
                figures.insert("ringdown_early_hz".into(), serde_json::json!(mh));
                figures.insert("ringdown_late_hz".into(), serde_json::json!(mm));
                figures.insert(
                    "model_relative_shift".into(),
                    serde_json::json!(model_shift),
                );
                out.push(Candidate {
                    effect: Effect::NonlinearStiffness { initial_rel_shift: f64::from(meas_shift - model_shift) },
                    evidence: Evidence {
                        summary: format!("ring-downs near {fn_hz:.0} Hz start {:.1} % faster than they end (model: {:.1} %): the stiffness hardens with amplitude", 100.0 * meas_shift, 100.0 * model_shift),
                        components: vec![],
                        figures,
                    },
                    strength: 6.0 + 300.0 * (meas_shift - model_shift),
                    check: Check::Ringdown { lo, hi, rate },
                });
            }
        }
    }
}
