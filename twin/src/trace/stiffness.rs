//! Nonlinear stiffness: ring-downs whose frequency falls as they decay, and, where the
//! impacts vary in strength, starts that are faster the stronger the impact (two close
//! linear modes beating shift early against late too, but at every strength alike:
//! [`crate::ringdown`]).

use super::context::{has, TraceContext};
use super::null::NullTest;
use super::null::NULL_Z;
use crate::residual::{Candidate, Check, Evidence};
use crate::ringdown::{Hardening, RingdownBand};
use crate::twin::Effect;
use crate::twin::EffectKind;

/// Offer nonlinear stiffness where the ring-downs' early frequency rises with the
/// impact's strength beyond what the model's own realizations show (the hardening
/// slope, [`RingdownBand::hardening`]) — the one reading that ties the shift to the
/// amplitude. Where the impacts are too alike in strength for a slope, the early-
/// versus-late shift alone is read instead (beyond 1 % and the model's draws).
///
/// The slope decides first because the shift is the weaker witness: on the
/// benchmark's development seed 3, the 23 records with a hardening first mode, drawn
/// again without it, show early-versus-late shifts of −8 to +8 % from their linear
/// modes alone (bands beating, leakage of the band-pass) and the stiffening moves that
/// figure by under 1 % on most; the slope of the same records moves by several of its
/// standard errors on most (a diagnostic run kept with the eighteenth session's note).
/// The shift gated the slope until then: 0 of 23 found, stiffness offered on 3. With
/// the slopes first ([`SlopeTest::passes`]) it is found on 1 of the 23, and on 2 since
/// the hardening stiffens the model's second DOF too (`TwinModel`'s render: a first
/// fit often lays the record's strongest ring there, where a radial-only cubic could
/// not reproduce the slope at any strength). The model's slope now grows steadily with
/// the stiffness to the record's on four of five offers examined there (on the fifth
/// it peaks below), yet most are still rejected: refitted freely, the stiffness falls
/// back 0.8–2 (ln) below the record's slope (its evidence unexplained); started where
/// a render's slope meets the record's and held there while the rest is refitted, the
/// envelope and PSD errors rise instead (case 187: envelope 0.90 → 5.2). The twin's
/// stiffened ring then fits the record's spectra worse than its linear one — how the
/// twin's hardening differs from the record's beyond the slope is the open question
/// (a tried and dropped start, nineteenth and twentieth sessions' notes).
pub(super) fn trace(ctx: &TraceContext<'_>, out: &mut Vec<Candidate>) {
    let model = ctx.model;
    let fs = ctx.cfg.fs_hz;
    if has(model, EffectKind::NonlinearStiffness) {
        return;
    }
    let fn_hz = model.get("ln_fn_hz").map_or(3000.0, f64::exp) as f32;
    let (lo, hi) = (0.75 * fn_hz, (1.25 * fn_hz).min(0.45 * fs));
    let rate = model
        .fault
        .map_or(0.0, |loc| model.op.freqs.impact_rate(loc));
    if rate <= 0.0 {
        return;
    }
    let band = RingdownBand {
        fs,
        lo,
        hi,
        rate_hz: rate,
        holds: ctx.holds,
    };
    let (Some((mh, mm)), Some((sh, sm))) = (band.frequencies(ctx.x), band.frequencies(ctx.sim))
    else {
        return;
    };
    let meas_shift = mh / mm - 1.0;
    let model_shift = sh / sm - 1.0;
    let mut figures = serde_json::Map::new();
    let (strength, initial, check) = match slope_test(ctx, &band) {
        Some(t) => {
            if !t.passes() {
                return;
            }
            figures.insert("hardening".into(), t.figures());
            // The slope is the relative rise of the early frequency at the mean
            // squared amplitude: the start of the refit's shift.
            let over = t.null.as_ref().map_or(0.0, |n| f64::from(n.mean));
            (
                6.0 + (20.0 * (t.z() / f64::from(NULL_Z)).max(1.0).log10()) as f32,
                (t.hardening.slope - over).max(f64::from(meas_shift - model_shift)),
                Check::Hardening { lo, hi, rate },
            )
        }
        None => {
            // Beyond the shifts the model's own realizations show against it
            // (`super::null`): ring-downs of impacts in noise scatter by a percent.
            if meas_shift - model_shift <= 0.01 {
                return;
            }
            let null = ctx.nulls.test(meas_shift - model_shift, |y| {
                band.frequencies(y).map(|(a, b)| a / b - 1.0 - model_shift)
            });
            if !null.significant() {
                return;
            }
            figures.insert(
                "null_test".into(),
                null.figures("ringdown_relative_shift_over_model"),
            );
            (
                6.0 + 300.0 * (meas_shift - model_shift),
                f64::from(meas_shift - model_shift),
                Check::Ringdown { lo, hi, rate },
            )
        }
    };
    figures.insert("ringdown_early_hz".into(), serde_json::json!(mh));
    figures.insert("ringdown_late_hz".into(), serde_json::json!(mm));
    figures.insert(
        "model_relative_shift".into(),
        serde_json::json!(model_shift),
    );
    out.push(Candidate {
        effect: Effect::NonlinearStiffness { initial_rel_shift: initial.max(1e-3) },
        evidence: Evidence {
            summary: format!("ring-downs near {fn_hz:.0} Hz {} (early frequency {:.1} % over the late one; model {:.1} %): the stiffness hardens with amplitude", match check {
                Check::Hardening { .. } => "start faster, and slow more as they decay, the stronger the impact",
                _ => "start faster than they end, beyond the model's own realizations",
            }, 100.0 * meas_shift, 100.0 * model_shift),
            components: vec![],
            figures,
        },
        strength,
        check,
    });
}

/// The hardening slopes of a record's ring-downs and their tests against the model's
/// draws.
struct SlopeTest {
    hardening: Hardening,
    /// The early frequency's slope against the draws' (`None` with fewer than two).
    null: Option<NullTest>,
    /// The early-less-late shift's slope against the draws'.
    shift_null: Option<NullTest>,
}

impl SlopeTest {
    /// Whether the early frequency rises with the squared amplitude by [`NULL_Z`]
    /// standard errors and, where two or more of the model's draws read slopes, both
    /// the early frequency's and the early-less-late shift's slope stand [`NULL_Z`]
    /// beyond the draws, each against the wider of the draws' spread and its own
    /// standard error (the record's own scatter: where it holds something the model
    /// lacks, the draws alone are too narrow). A hardening backbone makes both slopes:
    /// the start is faster the stronger the impact, and the ring-down slows as it
    /// decays the more the stronger it started. Asking for both is a second necessary
    /// condition, not a proof: a steady tone in the band under the mode raises both
    /// too (the weak ring-downs read toward it), and only the model's draws, once the
    /// tone is in the model, tell it apart. Chosen on dev seed 3, on 50 of its cases
    /// (the 23 with a hardening mode, 5 more with false claims of the early slope
    /// alone, 22 controls): the early slope alone against the draws alone was claimed
    /// falsely on 5 (a clean control, mesh tones, two records with dropouts, mains),
    /// both slopes against the widened spread on one (mains, claimed by the shift test
    /// before).
    fn passes(&self) -> bool {
        let h = &self.hardening;
        h.slope >= f64::from(NULL_Z) * h.se
            && [&self.null, &self.shift_null]
                .iter()
                .all(|n| n.as_ref().is_none_or(NullTest::significant))
    }

    /// How far beyond the draws the weaker of the two slopes stands (their `z`), or
    /// the early slope in its standard errors without draws.
    fn z(&self) -> f64 {
        match (&self.null, &self.shift_null) {
            (Some(a), Some(b)) => f64::from(a.z().min(b.z())),
            _ => self.hardening.slope / self.hardening.se,
        }
    }

    fn figures(&self) -> serde_json::Value {
        let h = &self.hardening;
        serde_json::json!({
            "relative_slope_per_relative_amplitude_squared": h.slope,
            "standard_error": h.se,
            "null_test": self.null.map(|t| t.figures("hardening_slope")),
            "shift_slope_per_relative_amplitude_squared": h.shift_slope,
            "shift_standard_error": h.shift_se,
            "shift_null_test": self.shift_null.map(|t| t.figures("hardening_shift_slope")),
        })
    }
}

/// `None` where the record's impacts are too alike in strength (or too few) to read a
/// slope — the shift test then stands alone; else the slopes and their tests.
fn slope_test(ctx: &TraceContext<'_>, band: &RingdownBand<'_>) -> Option<SlopeTest> {
    let hardening = band.hardening(ctx.x)?;
    // Each draw's ring-downs are read once, for both slopes.
    let drawn: Vec<Hardening> = ctx
        .nulls
        .draws()
        .iter()
        .filter_map(|y| band.hardening(y))
        .collect();
    let read = |observed: f64, se: f64, stat: fn(&Hardening) -> f64| {
        let values: Vec<f64> = drawn
            .iter()
            .map(|h| f64::from(stat(h) as f32))
            .filter(|v| v.is_finite())
            .collect();
        let t = NullTest::of(observed as f32, &values);
        (t.draws >= 2).then(|| t.widened(se as f32))
    };
    Some(SlopeTest {
        null: read(hardening.slope, hardening.se, |h| h.slope),
        shift_null: read(hardening.shift_slope, hardening.shift_se, |h| h.shift_slope),
        hardening,
    })
}
