//! The loop's first fit: the fault hypothesis from the envelope spectrum, the base
//! model's start (the structure's mode at one of the PSD's peaks, the impacts scaled
//! to the record's RMS), the defect rate read off the spectral comb, then eq. 10.

use super::setup::Setup;
use super::types::LoopError;
use crate::fit::{evaluate, fit, FitConfig, FitError, FitResult, Target};
use crate::residual::refine_comb_rate;
use crate::twin::{OperatingPoint, TwinModel};
use pumptwin_core::bearing::DefectLocation;
use pumptwin_core::features::harmonic_level_db;

/// The first fit and what led to it.
#[derive(Debug)]
pub(super) struct FirstFit {
    /// The fault hypothesis (`None`: healthy).
    pub(super) fault: Option<DefectLocation>,
    /// The envelope levels behind it.
    pub(super) fault_evidence: serde_json::Map<String, serde_json::Value>,
    /// The fitted base model.
    pub(super) result: FitResult,
    /// Model evaluations it cost.
    pub(super) evaluations: usize,
}

/// Fit the base model to the record of `s`.
pub(super) fn first_fit(s: &Setup<'_>) -> Result<FirstFit, LoopError> {
    let (fault, fault_evidence) = identify_fault(&s.target, &s.op, s.cfg.fault_threshold_db);
    let (mut start, mut evaluations) = initial_model(&s.target, s.op, fault, &s.fit_cfg)?;
    if let Some(loc) = fault {
        let factor = refine_rate(&s.target_res, s.op.freqs.impact_rate(loc));
        if let Some(p) = start.params.iter_mut().find(|p| p.name == "rate_factor") {
            p.value = factor;
        }
    }
    let result: FitResult = fit(&start, &s.target, &s.fit_cfg)?;
    evaluations += result.evaluations;
    Ok(FirstFit {
        fault,
        fault_evidence,
        result,
        evaluations,
    })
}

/// Step 1a: which defect, from the measured envelope spectrum.
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
    let bins = cfg.env_bins();
    let mut v: Vec<f32> = bins.map(|k| env[k]).collect();
    let mid = v.len() / 2;
    let floor = *v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    let f = &op.freqs;
    let level = |hz: f32| harmonic_level_db(env, cfg.fs_hz, hz, 2, 0.02, floor);
    let candidates = [
        (Some(DefectLocation::OuterRace), level(f.bpfo)),
        (Some(DefectLocation::InnerRace), level(f.bpfi)),
        (
            Some(DefectLocation::Ball),
            level(2.0 * f.bsf).max(level(f.bsf)),
        ),
    ];
    let mut ev = serde_json::Map::new();
    ev.insert("bpfo_db".into(), serde_json::json!(candidates[0].1));
    ev.insert("bpfi_db".into(), serde_json::json!(candidates[1].1));
    ev.insert("bsf_db".into(), serde_json::json!(candidates[2].1));
    ev.insert("shaft_db".into(), serde_json::json!(level(f.shaft)));
    ev.insert("threshold_db".into(), serde_json::json!(threshold));
    let best = candidates
        .iter()
        .copied()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((None, 0.0));
    if best.1 >= threshold {
        (best.0, ev)
    } else {
        (None, ev)
    }
}

/// Step 1b: starting values. Natural frequency from the measured PSD's strongest
/// peaks (each tried, best kept), amplitude scaled to the measured RMS (linear model).
fn initial_model(
    target: &Target,
    op: OperatingPoint,
    fault: Option<DefectLocation>,
    fit_cfg: &FitConfig,
) -> Result<(TwinModel, usize), FitError> {
    let cfg = &target.cfg;
    let db = &target.psd_db;
    let lo = (1000.0 / (cfg.fs_hz / cfg.psd_n as f32)) as usize;
    let hi = *cfg.psd_bins().end() - 2;
    // Local maxima of the PSD smoothed over ±3 bins.
    let smooth: Vec<f32> = (0..db.len())
        .map(|k| {
            let a = k.saturating_sub(3);
            let b = (k + 3).min(db.len() - 1);
            db[a..=b].iter().sum::<f32>() / (b - a + 1) as f32
        })
        .collect();
    let mut peaks: Vec<usize> = (lo.max(1)..hi)
        .filter(|&k| smooth[k] > smooth[k - 1] && smooth[k] >= smooth[k + 1])
        .collect();
    peaks.sort_by(|&a, &b| smooth[b].total_cmp(&smooth[a]));
    peaks.truncate(4);
    if peaks.is_empty() {
        peaks.push((lo + hi) / 2);
    }
    let rms = f64::from(target.meas.rms);
    let mut best: Option<(TwinModel, f32)> = None;
    let mut evals = 0;
    for k in peaks {
        let fn_hz = f64::from(cfg.psd_freq(k));
        let m = TwinModel::base(op, fault, fn_hz, 0.05, 1.0, 0.05 * rms);
        // Scale the excitation so the simulated RMS matches.
        let y = m.render(fit_cfg.n_sim, fit_cfg.seed)?;
        evals += 1;
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
        let m = m.with_theta(&theta);
        let (_, cost, _) = evaluate(&m, target, fit_cfg)?;
        evals += 1;
        if best.as_ref().is_none_or(|(_, c)| cost < *c) {
            best = Some((m, cost));
        }
    }
    let (m, _) = best.expect("at least one peak tried");
    Ok((m, evals))
}

/// Defect rate refined from the measured line-resolution PSD: the rate within ±3 % of
/// the kinematic one whose harmonic comb collects the most log power up to the band
/// limit (a periodic impact train puts lines at every k·rate). Returns the rate factor
/// `rate / kinematic − 1`.
fn refine_rate(target_res: &Target, kinematic_hz: f32) -> f64 {
    let k = f64::from(kinematic_hz);
    refine_comb_rate(&target_res.psd_db, &target_res.cfg, k, 0.03) / k - 1.0
}
