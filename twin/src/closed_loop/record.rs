//! The record as the loop reads it: dropouts (held values), clipping (rail hits), AC
//! coupling, the lowest frequency compared, and the scatter of its own spectra.

use super::types::LoopReport;
use crate::signature::{to_db, Signature, SignatureConfig};
use std::ops::Range;

/// Shortest run of one value, repeated sample for sample, that counts as a dropout: a
/// vibration sensor's signal with its noise never holds one value that long (no CWRU
/// channel holds one for even four samples), an acquisition that lost its input
/// returns zeros or its last code.
pub const HELD_RUN_MIN: usize = 8;

/// Runs of at least [`HELD_RUN_MIN`] equal consecutive samples in `x`: dropouts.
pub fn held_runs(x: &[f32]) -> usize {
    held_spans(x).len()
}

/// The spans of `x` (sample ranges) where it holds one value for at least
/// [`HELD_RUN_MIN`] samples: the acquisition's dropouts, in order.
pub fn held_spans(x: &[f32]) -> Vec<Range<usize>> {
    let mut spans = Vec::new();
    let mut start = 0;
    for i in 1..=x.len() {
        if i == x.len() || x[i] != x[start] {
            if i - start >= HELD_RUN_MIN {
                spans.push(start..i);
            }
            start = i;
        }
    }
    spans
}

/// Largest RMS, in g, taken as a bearing housing's acceleration. The model works in g
/// and is not scale-free (its cubic stiffness hardens with amplitude), so a record in
/// mg, m/s² or ADC counts would be fitted as a violent machine, or diverge; above this
/// level the loop asks for the unit rather than fit.
pub const MAX_RMS_G: f32 = 50.0;

/// Length of the AC coupling's moving window, s: its nulls fall at multiples of 5 Hz,
/// so applied twice (a triangle of 0.4 s) it passes the compared band (from 7 Hz)
/// within 0.3 dB (from 20 Hz within 0.05 dB) and takes out DC and baseline wander below
/// about 3 Hz.
pub const AC_COUPLING_S: f64 = 0.2;

/// The record as an AC-coupled vibration channel sees it: minus its local baseline,
/// a moving straight-line fit over [`AC_COUPLING_S`] applied twice. Inside the record
/// the line's value at the window's centre is the window's mean (a moving average);
/// at the record's ends, where the window is cut short and off-centre, the line still
/// follows a drifting baseline, where a mean would lag it and leave a step-like
/// transient that leaks into the lowest compared bins. A DC offset or a drifting
/// baseline is the sensor's or the cable's, never the bearing's; left in, it enters the
/// RMS the fit matches and bends every parameter.
pub fn ac_couple(x: &[f32], fs_hz: f32) -> Vec<f32> {
    let half = ((AC_COUPLING_S * f64::from(fs_hz)) as usize / 2).max(1);
    let moving_line = |v: &[f64]| -> Vec<f64> {
        // Prefix sums of v and j·v; those of j and j² are closed forms.
        let (mut s0, mut s1) = (vec![0.0f64; v.len() + 1], vec![0.0f64; v.len() + 1]);
        for (j, &a) in v.iter().enumerate() {
            s0[j + 1] = s0[j] + a;
            s1[j + 1] = s1[j] + j as f64 * a;
        }
        let sum_j = |n: f64| n * (n - 1.0) / 2.0; // 0 + 1 + … + (n − 1)
        let sum_j2 = |n: f64| (n - 1.0) * n * (2.0 * n - 1.0) / 6.0;
        (0..v.len())
            .map(|i| {
                let (a, b) = (i.saturating_sub(half), (i + half + 1).min(v.len()));
                let m = (b - a) as f64;
                let (tj, tj2) = (
                    sum_j(b as f64) - sum_j(a as f64),
                    sum_j2(b as f64) - sum_j2(a as f64),
                );
                let (sy, sjy) = (s0[b] - s0[a], s1[b] - s1[a]);
                let mean_j = tj / m;
                let var = tj2 / m - mean_j * mean_j;
                let slope = if var > 0.0 {
                    (sjy / m - mean_j * sy / m) / var
                } else {
                    0.0
                };
                sy / m + slope * (i as f64 - mean_j)
            })
            .collect()
    };
    let v: Vec<f64> = x.iter().map(|&a| f64::from(a)).collect();
    let base = moving_line(&moving_line(&v));
    v.iter().zip(&base).map(|(a, b)| (a - b) as f32).collect()
}

/// The lowest shaft order the loop compares: below the cage rate (FTF, 0.38–0.45 ×
/// the shaft for common bearings) and the sub-synchronous whirl of a seal or journal
/// (0.42–0.48 ×) by more than a residual bin at the CWRU speeds, so that lines there
/// are traced, not cut away.
pub const LOWEST_ORDER: f32 = 0.25;

/// Residual bins kept clear above DC at the low edge (the first bin compared is the
/// third: 2.5 rounds up): a Hann-windowed Welch line leaks over ±2 bins, and what the
/// AC coupling leaves below 3 Hz lands there.
pub const LOW_EDGE_BINS: f32 = 2.5;

/// The low edge of the compared power spectrum, Hz: [`LOWEST_ORDER`] × the shaft rate,
/// no closer to DC than [`LOW_EDGE_BINS`] residual bins, and never above the 20 Hz of
/// [`SignatureConfig::fit`] (the trainer's Θ fits keep 20 Hz). At the CWRU speeds it is
/// 7.2–7.5 Hz (first residual bin 8.8 Hz, 2.9 Hz bins); a 600 rpm pump's 1 × (10 Hz)
/// is inside it, where a 20 Hz edge hid its unbalance; a short snapshot's coarser bins
/// keep 20 Hz.
pub fn psd_low_edge(shaft_hz: f32, residual: &SignatureConfig) -> f32 {
    let df = residual.fs_hz / residual.psd_n as f32;
    (LOWEST_ORDER * shaft_hz)
        .max(LOW_EDGE_BINS * df)
        .min(residual.psd_lo_hz)
}

/// Rail hits ([`LoopReport::rail_hits`]) from which a record counts as clipped.
pub const CLIPPED_RAIL_HITS: usize = 3;

/// Samples of `x` within 0.01 % of its peak magnitude (either sign).
pub fn rail_hits(x: &[f32]) -> usize {
    let peak = x.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    if peak <= 0.0 {
        return 0;
    }
    x.iter().filter(|v| v.abs() >= 0.9999 * peak).count()
}

/// Read clipping off the record as it was read (`raw`, before any filter): clipping
/// is an effect of the measurement that no bearing model has, so a clipped record's
/// residual is never called noise-like, and the report says what was found.
pub fn note_clipping(report: &mut LoopReport, raw: &[f32]) {
    let hits = rail_hits(raw);
    report.rail_hits = Some(hits);
    report.clipped = hits >= CLIPPED_RAIL_HITS;
    if report.clipped {
        report.residual_noise_like = false;
        report.stop_reason.push_str(&format!(
            "; the record as read sits on its peak value {hits} times: clipped at the \
             acquisition's rail, an effect of the measurement the model does not have"
        ));
    }
}

/// The PSD error an exact model would leave on this record, dB: the measured Welch
/// PSD and the simulated one are each estimates whose dB values scatter bin by bin
/// (about 0.5 dB at 1024 points over 4 s), so even the record's own generator does not
/// fit it to 0 dB. Read off the record itself: the two halves' PSDs differ by `d` with
/// `rms(d)` = √2 × a half's scatter = 2 × the whole record's, and a model simulated over
/// as long a span adds as much again, so an exact model leaves `rms(d)/√2`. A record
/// that changes between its halves reads a larger scatter (a conservative figure).
/// `None` when a half holds fewer than two Welch blocks.
pub fn psd_scatter_db(x: &[f32], cfg: &SignatureConfig) -> Option<f32> {
    let half = x.len() / 2;
    if half < 2 * cfg.psd_n {
        return None;
    }
    let a = Signature::of(&x[..half], cfg).ok()?;
    let b = Signature::of(&x[half..2 * half], cfg).ok()?;
    Some(halves_scatter_db(&a, &b, cfg))
}

/// [`psd_scatter_db`] of a record whose halves' signatures `a` and `b` (at `cfg`) are
/// already computed.
pub(super) fn halves_scatter_db(a: &Signature, b: &Signature, cfg: &SignatureConfig) -> f32 {
    let (da, db) = (to_db(&a.psd, &a.psd), to_db(&b.psd, &a.psd));
    let bins = cfg.psd_bins();
    let n = bins.clone().count().max(1) as f32;
    let ms = bins.map(|k| (da[k] - db[k]).powi(2)).sum::<f32>() / n;
    (ms / 2.0).sqrt()
}
