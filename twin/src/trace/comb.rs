//! A washed-out defect comb: slip (random impact timing) or a speed that drifts.

use super::context::{has, TraceContext};
use crate::residual::{comb_contrast, envelope_comb_rate, Candidate, Check, Evidence};
use crate::signature::{block_within, MIN_BLOCK};
use crate::twin::Effect;
use crate::twin::EffectKind;
use pumptwin_core::features::EnvelopeBand;

/// Move of the defect rate between the record's halves (relative) above which the
/// comb's loss is read as a drift rather than slip.
const DRIFT_MIN_SHIFT: f32 = 0.0025;

/// Blocks the record is cut into to see the defect rate's trend (at most; fewer on a
/// short record, down to [`DRIFT_MIN_BLOCKS`]).
const DRIFT_BLOCKS: usize = 8;
/// Fewest blocks a trend is judged on (two degrees of freedom left by the line).
const DRIFT_MIN_BLOCKS: usize = 4;

/// Two-sided 1 % points of Student's t for 2..=6 degrees of freedom: a drift is
/// claimed only where the rate's linear trend over the blocks stands this many
/// standard errors from zero, so a steady speed whose slip scatters the rate from
/// block to block makes a false drift claim on 1 % of records.
const T_99: [f64; 5] = [9.925, 5.841, 4.604, 4.032, 3.707];

/// The defect rate's linear trend over the record: the rate of the envelope comb
/// near `f` Hz ([`envelope_comb_rate`]) read in up to [`DRIFT_BLOCKS`] consecutive
/// blocks, a straight line fitted through the block rates against time. Returns the
/// slope relative to `f` (per second), its t statistic (slope over its standard
/// error from the line's residuals) and the degrees of freedom behind it, or `None`
/// where fewer than [`DRIFT_MIN_BLOCKS`] blocks show the comb.
fn rate_trend(
    x: &[f32],
    fs: f32,
    band: EnvelopeBand,
    f: f32,
    n_max: usize,
) -> Option<(f64, f64, usize)> {
    let blocks = (x.len() / MIN_BLOCK).min(DRIFT_BLOCKS);
    if blocks < DRIFT_MIN_BLOCKS {
        return None;
    }
    let len = x.len() / blocks;
    let n = block_within(n_max, len, 1).min(len);
    let points: Vec<(f64, f64)> = (0..blocks)
        .filter_map(|b| {
            let seg = &x[b * len..(b + 1) * len];
            let t = (b as f64 + 0.5) * len as f64 / f64::from(fs);
            envelope_comb_rate(seg, fs, band, f, n).map(|r| (t, f64::from(r) / f64::from(f)))
        })
        .collect();
    let k = points.len();
    if k < DRIFT_MIN_BLOCKS {
        return None;
    }
    let kf = k as f64;
    let (mt, mr) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (t, r)| (a + t / kf, b + r / kf));
    let stt: f64 = points.iter().map(|(t, _)| (t - mt).powi(2)).sum();
    let slope = points.iter().map(|(t, r)| (t - mt) * (r - mr)).sum::<f64>() / stt;
    let sse: f64 = points
        .iter()
        .map(|(t, r)| (r - mr - slope * (t - mt)).powi(2))
        .sum();
    let se = (sse / (kf - 2.0) / stt).sqrt();
    Some((slope, slope / se.max(1e-12), k - 2))
}

/// Offer slip or a speed drift where the measured comb loses contrast at high
/// orders against the model's. Slip is part of the base where the record shows it
/// (the first fit completes the base with it): a model that has it washes its own comb
/// out, so a drift is then offered on the defect rate's move between the record's
/// halves alone — slip jitters the rate about its mean, a drift moves the mean.
pub(super) fn trace(ctx: &TraceContext<'_>, out: &mut Vec<Candidate>) {
    let model = ctx.model;
    let fs = ctx.cfg.fs_hz;
    // --- Washed-out defect comb: slip or speed drift.
    if let Some(loc) = model.fault {
        if !has(model, EffectKind::SpeedDrift) {
            let slipping = has(model, EffectKind::Slip);
            let rate = f64::from(model.op.freqs.impact_rate(loc))
                * (1.0 + model.get("rate_factor").unwrap_or(0.0));
            let cm = comb_contrast(&ctx.meas_psd_db, ctx.cfg, rate);
            let cs = comb_contrast(&ctx.sim_psd_db, ctx.cfg, rate);
            let n = cm.len().min(cs.len());
            if n >= 9 {
                let delta: Vec<f32> = cm.iter().zip(&cs).map(|(a, b)| a - b).collect();
                let low = delta[..3].iter().sum::<f32>() / 3.0;
                let high = delta[n - n / 3..n].iter().sum::<f32>() / (n / 3) as f32;
                // The model's own high teeth must stand out, or there is nothing to wash out.
                let model_high = cs[n - n / 3..n].iter().sum::<f32>() / (n / 3) as f32;
                let washed = high - low < -4.0 && model_high > 6.0;
                if washed || slipping {
                    let band = ctx.cfg.env_band;
                    let half = ctx.x.len() / 2;
                    let fd = rate as f32;
                    let n = block_within(ctx.cfg.env_n, half, 1);
                    let f1 = envelope_comb_rate(&ctx.x[..half], fs, band, fd, n);
                    let f2 = envelope_comb_rate(&ctx.x[half..], fs, band, fd, n);
                    let shift = match (f1, f2) {
                        (Some(a), Some(b)) => (b - a) / fd,
                        _ => 0.0,
                    };
                    // Mean defect rate over the record, relative to the kinematic one.
                    let kin = f64::from(model.op.freqs.impact_rate(loc));
                    let mean_factor = match (f1, f2) {
                        (Some(a), Some(b)) => 0.5 * f64::from(a + b) / kin - 1.0,
                        _ => model.get("rate_factor").unwrap_or(0.0),
                    };
                    let mut figures = serde_json::Map::new();
                    figures.insert(
                        "comb_contrast_loss_low_orders_db".into(),
                        serde_json::json!(low),
                    );
                    figures.insert(
                        "comb_contrast_loss_high_orders_db".into(),
                        serde_json::json!(high),
                    );
                    figures.insert(
                        "relative_rate_shift_between_halves".into(),
                        serde_json::json!(shift),
                    );
                    let strength = 6.0 + (low - high).min(20.0);
                    let half_s = (half as f64 / f64::from(fs)).max(1e-3);
                    // A drift must move the rate steadily: its trend over the record's
                    // blocks beyond what the rate's scatter from block to block allows.
                    let trend = rate_trend(ctx.x, fs, band, fd, ctx.cfg.env_n);
                    let steady = match trend {
                        Some((_, t, dof)) => t.abs() < T_99[dof.clamp(2, 6) - 2],
                        None => true,
                    };
                    if let Some((slope, t, _)) = trend {
                        figures.insert("rate_trend_per_s".into(), serde_json::json!(slope));
                        figures.insert("rate_trend_t".into(), serde_json::json!(t));
                    }
                    let (effect, summary) = if shift.abs() > DRIFT_MIN_SHIFT && !steady {
                        (
                            Effect::SpeedDrift { initial_per_s: f64::from(shift) / half_s, initial_rate_factor: mean_factor },
                            format!("the defect comb loses {:.1} dB more contrast at high orders than the model, and the defect rate moves by {:+.2} % between the record's halves, a steady trend (t = {:.1} over the record's blocks, beyond the 1 % point of a steady speed's block-to-block scatter): the speed drifts", low - high, 100.0 * shift, trend.map_or(0.0, |t| t.1)),
                        )
                    } else if slipping || !washed {
                        return;
                    } else {
                        (
                            Effect::Slip,
                            format!("the defect comb loses {:.1} dB more contrast at high orders than the model at a steady rate ({:+.2} % between halves): random impact timing, rolling-element slip", low - high, 100.0 * shift),
                        )
                    };
                    out.push(Candidate {
                        effect,
                        evidence: Evidence {
                            summary,
                            components: vec![],
                            figures,
                        },
                        strength,
                        check: Check::CombContrast { rate },
                    });
                }
            }
        }
    }
}
