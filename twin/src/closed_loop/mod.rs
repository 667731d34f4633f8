//! The loop: fit → residual → trace → add effect → refit → repeat (issue "close the
//! loop with measured data"). The loop is told only what a user knows: the signal,
//! its sampling rate, the nominal speed and the bearing geometry.
//!
//! | file | step |
//! |---|---|
//! | [`types`] | the loop's input, settings and report |
//! | `record` | the record as read: dropouts, clipping, AC coupling, its own scatter |
//! | `setup` | what a run fixes before its first fit |
//! | `first_fit` | the fault hypothesis and the base model's fit (eq. 10) |
//! | `round` | one round: residual, trace, noise-like test, candidates tried |
//! | `trial` | one candidate refitted from two starts and judged, and its rivals |

mod first_fit;
mod hypothesis;
mod modal;
mod record;
mod round;
mod setup;
mod trial;
pub mod types;

pub use record::{
    ac_couple, held_runs, note_clipping, psd_low_edge, psd_scatter_db, rail_hits, AC_COUPLING_S,
    CLIPPED_RAIL_HITS, HELD_RUN_MIN, LOWEST_ORDER, LOW_EDGE_BINS, MAX_RMS_G,
};
pub use round::{NOISE_LIKE_MISFIT_DB, TIME_STATS_TOLERANCE};
pub use trial::MAX_BURST_OVERLAP;
pub use types::{
    envelope_pairs, psd_pairs, LoopArtifacts, LoopConfig, LoopError, LoopInput, LoopReport,
    LoopStep, RejectedCandidate,
};

use crate::twin::fault_name;
use first_fit::first_fit;
use round::{round, unexplained, Next, State};
use setup::Setup;
use std::time::Instant;
use trial::Trials;

/// Run the whole loop.
pub fn run(input: &LoopInput, cfg: &LoopConfig) -> Result<(LoopReport, LoopArtifacts), LoopError> {
    let t0 = Instant::now();
    let s = Setup::new(input, cfg)?;
    let first = first_fit(&s)?;
    let (_, initial_sig) = s.residual_of(&first.result.model)?;
    let mut st = State {
        current: first.result.clone(),
        steps: Vec::new(),
        trials: Trials {
            evaluations: first.evaluations,
            ..Trials::default()
        },
        stop_reason: format!("reached the step limit ({})", cfg.max_steps),
        residual_noise_like: false,
        null_draws: None,
    };
    // The halves the effects are judged on are the ones the scatter compares.
    let psd_scatter = s
        .halves
        .as_ref()
        .map(|[a, b]| record::halves_scatter_db(&a.meas, &b.meas, &s.sig_fit));
    let last_analysis = loop {
        let (analysis, next) = round(&s, &mut st, psd_scatter)?;
        if next == Next::Stop {
            break analysis;
        }
    };
    let dropouts = s.dropouts;
    if dropouts > 0 {
        // Like clipping, an effect of the measurement no bearing model has.
        st.residual_noise_like = false;
        st.stop_reason.push_str(&format!(
            "; the record holds one value for {HELD_RUN_MIN} samples or more {dropouts} \
             time(s): dropouts of the acquisition, whose steps are impulsive in every band \
             (no random impacts are read off its time statistics)"
        ));
    }
    let (_, final_sig) = s.residual_of(&st.current.model)?;
    let report = LoopReport {
        fault: fault_name(first.fault).into(),
        fault_evidence: first.fault_evidence,
        base_terms: first.base_terms,
        params_initial: first.result.model.physical(),
        params_final: st.current.model.physical(),
        effects: st.steps.iter().map(|s| s.effect.clone()).collect(),
        steps: st.steps,
        error_initial: first.result.figures,
        error_final: st.current.figures,
        residual_noise_like: st.residual_noise_like,
        stop_reason: st.stop_reason,
        rejected: st.trials.rejected,
        residual_components_final: unexplained(
            &last_analysis,
            &st.current.model,
            &s.sig_res,
            s.span_s,
        ),
        psd_scatter_db: psd_scatter,
        rail_hits: None,
        clipped: false,
        dropouts,
        seconds: t0.elapsed().as_secs_f64(),
        evaluations: st.trials.evaluations,
    };
    let artifacts = LoopArtifacts {
        measured: s.target_res.meas,
        initial: initial_sig,
        final_: final_sig,
        cfg: s.sig_res,
        residual: last_analysis,
    };
    Ok((report, artifacts))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::{generate, Injected, Strength};
    use crate::signature::SignatureConfig;
    use pumptwin_core::bearing::BearingGeometry;

    /// The scatter of a stationary record is the Welch estimate's: 4 s of white noise
    /// at 1024 points (about 90 blocks with their overlap) scatters by 4.34 dB ×
    /// √(1/K) per estimate, and an exact model leaves √2 × that; a record whose second
    /// half is 6 dB louder reads that step instead; a record too short to halve reads
    /// none.
    #[test]
    fn psd_scatter_is_the_welch_estimates_and_sees_a_changing_record() {
        let fs = 12_000.0f32;
        let cfg = SignatureConfig::fit(fs);
        let mut rng = pumptwin_core::rng::Xoshiro128pp::seed_from_u64(3);
        let white: Vec<f32> = (0..4 * 12_000).map(|_| rng.normal() as f32).collect();
        let s = psd_scatter_db(&white, &cfg).expect("4 s halve");
        assert!((0.45..0.85).contains(&s), "white noise scatter {s}");
        let mut step = white.clone();
        step[24_000..].iter_mut().for_each(|v| *v *= 2.0);
        let t = psd_scatter_db(&step, &cfg).expect("4 s halve");
        assert!(t > 3.5, "a 6 dB step reads {t}");
        assert!(psd_scatter_db(&white[..3000], &cfg).is_none());
    }

    /// A ramp and an offset leave nothing, up to the record's ends (a moving mean left
    /// a transient there of the ramp's slope times half a window); a 10 Hz line (a slow
    /// pump's shaft, a cage rate) passes within 0.3 dB.
    #[test]
    fn ac_coupling_removes_a_ramp_to_the_ends_and_passes_low_lines() {
        let fs = 12_000.0f32;
        let n = 4 * 12_000;
        let ramp: Vec<f32> = (0..n).map(|i| 0.5 + 0.3 * i as f32 / n as f32).collect();
        let out = ac_couple(&ramp, fs);
        let worst = out.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(worst < 1e-5, "{worst}");
        let tone: Vec<f32> = (0..n)
            .map(|i| (2.0 * std::f32::consts::PI * 10.0 * i as f32 / fs).sin())
            .collect();
        let out = ac_couple(&tone, fs);
        let rms = |v: &[f32]| (v.iter().map(|a| a * a).sum::<f32>() / v.len() as f32).sqrt();
        let (a, b) = (rms(&out[n / 4..3 * n / 4]), rms(&tone[n / 4..3 * n / 4]));
        let db = 20.0 * (a / b).log10();
        assert!(db.abs() < 0.3, "{db} dB");
    }

    /// The compared spectrum starts a quarter of the shaft rate up, at least two and a
    /// half residual bins clear of DC, never above 20 Hz.
    #[test]
    fn the_low_edge_follows_the_shaft_within_its_limits() {
        let res = SignatureConfig::residual(12_000.0); // 2.93 Hz bins
        let edge = |rpm: f32| psd_low_edge(rpm / 60.0, &res);
        assert!((edge(1797.0) - 7.49).abs() < 0.01, "{}", edge(1797.0));
        assert!((edge(600.0) - 7.32).abs() < 0.01, "{}", edge(600.0)); // 2.5 bins
        assert_eq!(edge(6000.0), 20.0);
        let first = |rpm: f32| {
            let c = SignatureConfig {
                psd_lo_hz: edge(rpm),
                ..res
            };
            c.psd_freq(*c.psd_bins().start())
        };
        assert!(first(600.0) < 10.0, "a 600 rpm shaft's 1x is compared");
        assert!(
            first(1797.0) < 0.38 * 1797.0 / 60.0,
            "the cage rate is compared"
        );
    }

    /// On a clean synthetic record with known truth (generator: f_n = 3000 Hz, ζ = 0.05,
    /// A = 40 N, kinematic BPFO, σ_y = 0.02 g), the first fit recovers the parameters.
    /// Tolerances: 2 % for natural frequency, damping ratio, impact amplitude and rate;
    /// 10 % for the measurement noise, which is seen only in the comb's valleys below
    /// the band limit. Records of 10 s (a CWRU record's length), all of it used: the
    /// estimates' spread at the default 6 s span is about ±2 % on ζ.
    #[test]
    fn fit_recovers_known_parameters() {
        for seed in [11, 12] {
            check_recovery(seed);
        }
    }

    fn check_recovery(seed: u64) {
        let x = generate(Injected::None, Strength::Realistic, 10.0, seed).unwrap();
        let input = LoopInput {
            signal: x,
            fs_hz: 12_000.0,
            rpm: 1797.0,
            bearing: BearingGeometry::CWRU_6205_DE,
            held_runs: None,
        };
        let cfg = LoopConfig {
            max_record_seconds: 10.0,
            fit_seconds: 10.0,
            residual_seconds: 10.0,
            ..LoopConfig::default()
        };
        let (report, _) = run(&input, &cfg).unwrap();
        assert_eq!(report.fault, "outer_race");
        assert!(
            report.effects.is_empty(),
            "control claimed {:?}",
            report.effects
        );
        let p = &report.params_initial;
        let get = |k: &str| p[k].as_f64().unwrap();
        let rel = |v: f64, t: f64| (v / t - 1.0).abs();
        assert!(rel(get("fn_hz"), 3000.0) < 0.02, "fn {}", get("fn_hz"));
        assert!(rel(get("zeta"), 0.05) < 0.02, "zeta {}", get("zeta"));
        assert!(
            rel(get("impact_amp"), 40.0) < 0.02,
            "amp {}",
            get("impact_amp")
        );
        assert!(
            get("rate_factor").abs() < 0.02,
            "rate factor {}",
            get("rate_factor")
        );
        assert!(
            rel(get("meas_noise"), 0.02) < 0.10,
            "noise {}",
            get("meas_noise")
        );
    }

    /// A run of one value counts once it reaches [`HELD_RUN_MIN`] samples, whatever the
    /// value (zeros, a held last code); shorter repeats and a noisy signal count none.
    #[test]
    fn held_runs_count_dropouts_not_repeats() {
        let noisy: Vec<f32> = (0..1000)
            .map(|i| ((i * 7919) % 113) as f32 * 0.01)
            .collect();
        assert_eq!(held_runs(&noisy), 0);
        let mut x = noisy.clone();
        x[100..100 + HELD_RUN_MIN].fill(0.0);
        x[300..300 + HELD_RUN_MIN - 1].fill(0.25);
        let held = x[499];
        x[500..560].fill(held);
        assert_eq!(held_runs(&x), 2);
        assert_eq!(
            record::held_spans(&x),
            vec![100..100 + HELD_RUN_MIN, 499..560]
        );
        assert_eq!(held_runs(&[]), 0);
    }

    #[test]
    fn bad_input_is_an_error() {
        let input = LoopInput {
            signal: vec![0.1; 100],
            fs_hz: 12_000.0,
            rpm: 1797.0,
            bearing: BearingGeometry::CWRU_6205_DE,
            held_runs: None,
        };
        assert!(matches!(
            run(&input, &LoopConfig::default()),
            Err(LoopError::Input(_))
        ));
        let mut signal = vec![0.1f32; 50_000];
        signal[7] = f32::NAN;
        let input = LoopInput { signal, ..input };
        assert!(matches!(
            run(&input, &LoopConfig::default()),
            Err(LoopError::Input(_))
        ));
        // A record in mg (1000 x the g values): the unit is asked for, not fitted.
        let signal = crate::generate::generate(
            crate::generate::Injected::None,
            crate::generate::Strength::Realistic,
            2.0,
            3,
        )
        .expect("generator")
        .iter()
        .map(|v| v * 1000.0)
        .collect();
        let input = LoopInput { signal, ..input };
        match run(&input, &LoopConfig::default()) {
            Err(LoopError::Input(why)) => assert!(why.contains("--unit-scale"), "{why}"),
            other => panic!("a record in mg was fitted: {:?}", other.map(|r| r.0.fault)),
        }
    }
}
