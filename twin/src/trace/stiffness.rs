//! Nonlinear stiffness: ring-downs whose frequency falls as they decay, and, where the
//! impacts vary in strength, starts that are faster the stronger the impact (two close
//! linear modes beating shift early against late too, but at every strength alike:
//! [`crate::ringdown`]).

use super::context::{has, TraceContext};
use super::null::NullTest;
use super::null::NULL_Z;
use crate::residual::{Candidate, Check, Evidence};
use crate::ringdown::{ringdown_frequencies, ringdown_hardening, Hardening};
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
            let slope = null.as_ref().and_then(|_| slope_test(ctx, lo, hi, rate));
            if slope.as_ref().is_some_and(|t| !t.passes()) {
                return;
            }
            if let Some(null) = null {
                let mut figures = serde_json::Map::new();
                if let Some(t) = slope {
                    figures.insert("hardening".into(), t.figures());
                }
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

/// The hardening slope of a record's ring-downs and its test against the model's draws.
struct SlopeTest {
    hardening: Hardening,
    null: Option<NullTest>,
}

impl SlopeTest {
    /// Whether the early frequency rises with the squared amplitude by [`NULL_Z`]
    /// standard errors and, where two or more of the model's draws read a slope,
    /// beyond those draws.
    fn passes(&self) -> bool {
        self.hardening.slope >= f64::from(NULL_Z) * self.hardening.se
            && self.null.as_ref().is_none_or(NullTest::significant)
    }

    fn figures(&self) -> serde_json::Value {
        serde_json::json!({
            "relative_slope_per_relative_amplitude_squared": self.hardening.slope,
            "standard_error": self.hardening.se,
            "null_test": self.null.map(|t| t.figures("hardening_slope")),
        })
    }
}

/// `None` where the record's impacts are too alike in strength (or too few) to read a
/// slope — the shift test then stands alone; else the slope and its test.
fn slope_test(ctx: &TraceContext<'_>, lo: f32, hi: f32, rate: f32) -> Option<SlopeTest> {
    let fs = ctx.cfg.fs_hz;
    let hardening = ringdown_hardening(ctx.x, fs, lo, hi, rate)?;
    let null = ctx.nulls.test(hardening.slope as f32, |y| {
        ringdown_hardening(y, fs, lo, hi, rate).map(|h| h.slope as f32)
    });
    Some(SlopeTest {
        hardening,
        null: (null.draws >= 2).then_some(null),
    })
}
