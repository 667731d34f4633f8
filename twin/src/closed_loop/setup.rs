//! What a run of the loop fixes before its first fit: the record as compared (cut to
//! the longest span the loop reads, AC-coupled), its dropouts, the signature settings
//! and targets of the fit and of the residual, and the fit settings.

use super::record::{ac_couple, held_spans, psd_low_edge, MAX_RMS_G};
use super::types::{LoopConfig, LoopError, LoopInput};
use crate::fit::{FitConfig, Target};
use crate::signature::{Signature, SignatureConfig, SignatureError};
use crate::trace::context::has;
use crate::twin::{EffectKind, OperatingPoint, TwinModel};
use std::ops::Range;

/// Relative gain that keeps the first fit iterating: its Θ are the trainer's F_map
/// targets (`crate::physics::fit_theta`), fitted to convergence.
const FIRST_FIT_MIN_GAIN: f32 = 1e-5;

/// The run's fixed inputs.
#[derive(Debug)]
pub(super) struct Setup<'a> {
    /// The loop's settings.
    pub(super) cfg: &'a LoopConfig,
    /// The record as compared: AC-coupled, at most `max_record_seconds` long.
    pub(super) x: Vec<f32>,
    /// Runs of one held value (acquisition dropouts) in the record as read.
    pub(super) dropouts: usize,
    /// The spans where the record as compared holds one value (its dropouts, where the
    /// filter of a band-limiting caller left them held); [`Setup::residual_of`] gives
    /// the model's realization the same holds.
    pub(super) holds: Vec<Range<usize>>,
    /// Rate and the bearing's frequencies at the nominal speed.
    pub(super) op: OperatingPoint,
    /// Signature settings of the fit (eq. 10).
    pub(super) sig_fit: SignatureConfig,
    /// Signature settings of the residual (finer lines).
    pub(super) sig_res: SignatureConfig,
    /// The measurement as the fit compares it.
    pub(super) target: Target,
    /// The measurement as the residual compares it.
    pub(super) target_res: Target,
    /// The first fit's settings (trials start from them).
    pub(super) fit_cfg: FitConfig,
    /// Samples the model is simulated over for the residual.
    pub(super) n_res: usize,
    /// The record's duration, s.
    pub(super) span_s: f64,
    /// The measurement's two halves as the fit compares them (`None` when a half
    /// holds fewer than two PSD blocks): an effect must lower the error in each
    /// ([`Setup::half_costs`]).
    pub(super) halves: Option<[Target; 2]>,
}

impl<'a> Setup<'a> {
    /// Check `input` and fix what the run compares.
    pub(super) fn new(input: &LoopInput, cfg: &'a LoopConfig) -> Result<Self, LoopError> {
        validate(input)?;
        let n_max = (cfg.max_record_seconds * f64::from(input.fs_hz)) as usize;
        let record = &input.signal[..input.signal.len().min(n_max)];
        let holds = held_spans(record);
        let dropouts = input.held_runs.unwrap_or(holds.len());
        let x = ac_couple(record, input.fs_hz);
        let too_short =
            |e: SignatureError| LoopError::Input(format!("the record is too short: {e}"));
        let op = OperatingPoint {
            fs_hz: input.fs_hz,
            freqs: input.bearing.frequencies(input.rpm / 60.0),
        };
        let mut sig_fit = SignatureConfig::fit(input.fs_hz)
            .for_length(x.len())
            .map_err(too_short)?;
        let mut sig_res = SignatureConfig::residual(input.fs_hz)
            .for_length(x.len())
            .map_err(too_short)?;
        let low_edge = psd_low_edge(op.freqs.shaft, &sig_res);
        sig_fit.psd_lo_hz = low_edge;
        sig_res.psd_lo_hz = low_edge;
        let target = Target::of(&x, sig_fit).map_err(|e| LoopError::Fit(e.into()))?;
        if target.meas.rms.is_nan() || target.meas.rms > MAX_RMS_G {
            return Err(LoopError::Input(format!(
                "the record's RMS is {:.4e}: the bearing model works in g and no bearing housing \
                 vibrates above {MAX_RMS_G} g RMS; a record in mg, m/s² or ADC counts must be \
                 scaled to g (`twin loop --unit-scale`: 0.001 for mg, 0.10197 for m/s², g per count)",
                target.meas.rms
            )));
        }
        let target_res = Target::of(&x, sig_res).map_err(|e| LoopError::Fit(e.into()))?;
        // The model is simulated over as long a span as the record it is compared with, so
        // anything that builds up over the record (a drifting speed) is seen alike.
        let span = |s: f64| {
            ((s * f64::from(input.fs_hz)) as usize)
                .min(x.len())
                .max(2 * sig_res.env_n)
        };
        let fit_cfg = FitConfig {
            n_sim: span(cfg.fit_seconds),
            seed: cfg.seed,
            max_iter: cfg.max_iter,
            min_gain: FIRST_FIT_MIN_GAIN,
            max_evaluations: usize::MAX,
        };
        let n_res = span(cfg.residual_seconds);
        let span_s = x.len() as f64 / f64::from(input.fs_hz);
        let h = x.len() / 2;
        let halves = if h >= 2 * sig_fit.psd_n {
            match (
                Target::of(&x[..h], sig_fit),
                Target::of(&x[h..2 * h], sig_fit),
            ) {
                (Ok(a), Ok(b)) => Some([a, b]),
                _ => None,
            }
        } else {
            None
        };
        Ok(Self {
            cfg,
            x,
            dropouts,
            holds,
            op,
            sig_fit,
            sig_res,
            target,
            target_res,
            fit_cfg,
            n_res,
            span_s,
            halves,
        })
    }

    /// The cost of model `m` against each half of the measurement (the fit's cost,
    /// [`crate::fit::evaluate`], with a half as the target); `None` without halves.
    /// A model that drifts in speed is simulated over the whole record and compared
    /// half with half; any other is the same in every stretch, so one fit span of it
    /// is compared with both.
    pub(super) fn half_costs(&self, m: &TwinModel) -> Result<Option<[f32; 2]>, LoopError> {
        let Some(halves) = &self.halves else {
            return Ok(None);
        };
        let drifts = has(m, EffectKind::SpeedDrift);
        let h = self.x.len() / 2;
        let n = if drifts { 2 * h } else { self.fit_cfg.n_sim };
        let y = m
            .render(n, self.fit_cfg.seed)
            .map_err(|e| LoopError::Fit(e.into()))?;
        let sig =
            |part: &[f32]| Signature::of(part, &self.sig_fit).map_err(|e| LoopError::Fit(e.into()));
        let sigs = if drifts {
            [sig(&y[..h])?, sig(&y[h..2 * h])?]
        } else {
            let s = sig(&y)?;
            [s.clone(), s]
        };
        Ok(Some([halves[0].cost(&sigs[0]), halves[1].cost(&sigs[1])]))
    }

    /// The model `m` simulated over the residual's span, as the record's acquisition
    /// would have recorded it, and its signature.
    ///
    /// Where the record holds one value (a dropout), the realization holds the record's
    /// values too: the acquisition that lost the bearing's signal there would have lost
    /// the model's. A hold gates the signal, and its steps and its slow pulse (a held
    /// value off the baseline for tens of milliseconds) put low-frequency content and
    /// ripple into the record's spectrum that no bearing makes; with the same holds in
    /// both, the residual compares like with like and reads no line off them. (The fit's
    /// realizations, shorter than the record, are left as they are: it matches the
    /// PSD's level band by band, not its lines.)
    pub(super) fn residual_of(&self, m: &TwinModel) -> Result<(Vec<f32>, Signature), LoopError> {
        let mut y = m
            .render(self.n_res, self.cfg.seed ^ 0x5eed)
            .map_err(|e| LoopError::Fit(e.into()))?;
        let n = y.len();
        for h in self.holds.iter().filter(|h| h.end <= n) {
            y[h.clone()].copy_from_slice(&self.x[h.clone()]);
        }
        let s = Signature::of(&y, &self.sig_res).map_err(|e| LoopError::Fit(e.into()))?;
        Ok((y, s))
    }
}

/// A usable rate (from 4 kHz), a positive speed, finite samples.
fn validate(input: &LoopInput) -> Result<(), LoopError> {
    if !(input.fs_hz.is_finite() && input.fs_hz >= 4000.0) {
        return Err(LoopError::Input(format!(
            "sampling rate {} Hz: need >= 4 kHz",
            input.fs_hz
        )));
    }
    if !(input.rpm.is_finite() && input.rpm > 0.0) {
        return Err(LoopError::Input("rpm must be > 0".into()));
    }
    if input.signal.iter().any(|v| !v.is_finite()) {
        return Err(LoopError::Input("signal contains NaN or infinity".into()));
    }
    Ok(())
}
