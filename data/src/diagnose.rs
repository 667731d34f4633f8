//! The core's physical diagnosis ([`pumptwin_core::diagnosis`]) over a recording's
//! windows, and its summary per record: what `predict` reports and the generalization
//! protocols score.
//!
//! ```text
//! recording at the model rate, one channel → windows (start, WINDOW samples)
//!   → per window: the stretch of SEGMENT samples ending where the window ends (the
//!     window and the seconds before it; shorter, a power of two ≥ the window, at the
//!     start of a record) → evidence → decision (type, confidence, severity)
//!   → record: the majority type over the windows (ties: the first in FaultType::ALL
//!     order), its share of the windows, the mean confidence of the windows that made
//!     it, and each severity figure (impact over background, harmonic fall, the
//!     widths) as the median over those windows with the windows' scatter (half the
//!     inter-quartile range / √windows) or each window's own uncertainty / √windows,
//!     the larger; a width where at least half those windows read one
//! ```
//!
//! Why a stretch longer than the window: a window of 2 048 samples at 12 kHz resolves
//! 5.9 Hz and holds 1.7 revolutions at 600 rpm, where BPFI (54 Hz) and 2·BSF (47 Hz)
//! of a 6205 bearing lie 1.2 bins apart; an analyst reads envelope spectra of seconds
//! (≤ 1 Hz resolution) before naming a line, and so does this. The stretch looks
//! only backward (what an edge device has seen up to the window), never at a later
//! window, so a window's diagnosis uses no sample of a window after it.

use pumptwin_core::bearing::DefectOrders;
use pumptwin_core::diagnosis::{
    decide, window_evidence, Buffers, Diagnosis, FaultType, Severity, Thresholds, Width,
};
use pumptwin_core::fft::Complex32;

use crate::recording::Recording;

pub use pumptwin_core::diagnosis::{segment_len, DEFAULT_REVOLUTIONS};

/// A window's diagnosis, or why it has none.
pub type WindowDiagnosis = Result<Diagnosis, pumptwin_core::Error>;

/// The physical diagnosis of every window of `channel` in `rec` starting at `starts`
/// (each `window` samples), each read over the `segment` samples (a power of two)
/// ending where it ends, for a bearing of `orders` at `shaft_hz`. `None` when the
/// recording has no such channel.
pub fn diagnose_windows(
    rec: &Recording,
    channel: &str,
    starts: &[usize],
    window: usize,
    segment: usize,
    shaft_hz: f32,
    orders: &DefectOrders,
    t: &Thresholds,
) -> Option<Vec<WindowDiagnosis>> {
    let ch = rec.channel(channel)?;
    let longest = segment.max(window);
    let mut complex = vec![Complex32::ZERO; Buffers::complex_len(longest)];
    let mut real = vec![0.0f32; Buffers::real_len(longest)];
    let mut diagnose = |s: usize| -> WindowDiagnosis {
        let end = s + window;
        let Some(own) = ch.samples.get(s..end) else {
            return Err(pumptwin_core::Error::BufferSize {
                expected: end,
                got: ch.samples.len(),
            });
        };
        // The window itself must be diagnosable: a sensor that died (flat) or went
        // non-finite in it is not read through the seconds before.
        if own.iter().any(|v| !v.is_finite()) {
            return Err(pumptwin_core::Error::NonFinite);
        }
        if own.iter().all(|&v| v == own[0]) {
            return Err(pumptwin_core::Error::Degenerate);
        }
        // The longest power of two ≤ segment that the record holds before `end`.
        let mut len = longest;
        while len > window && len > end {
            len /= 2;
        }
        let x = &ch.samples[end - len..end];
        let buf = Buffers::carve(&mut complex, &mut real, len)?;
        let e = window_evidence(x, rec.fs_hz, shaft_hz, orders, buf)?;
        Ok(decide(&e, t))
    };
    Some(starts.iter().map(|&s| diagnose(s)).collect())
}

/// A record's diagnosis from its windows'.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordDiagnosis {
    /// The majority type.
    pub fault: FaultType,
    /// Windows per type, in [`FaultType::ALL`] order.
    pub counts: [usize; 5],
    /// Windows that could not be diagnosed (non-finite samples, a flat sensor, …).
    pub failed: usize,
    /// Mean confidence of the windows of the majority type.
    pub confidence: f32,
    /// Severity of the majority type's windows (see the module docs).
    pub severity: Severity,
}

/// The record's diagnosis; `None` when no window was diagnosed.
pub fn summarize_record(windows: &[WindowDiagnosis]) -> Option<RecordDiagnosis> {
    let mut counts = [0usize; 5];
    let mut failed = 0;
    for w in windows {
        match w {
            Ok(d) => counts[type_index(d.fault)] += 1,
            Err(_) => failed += 1,
        }
    }
    let best = (0..5).fold(0, |b, i| if counts[i] > counts[b] { i } else { b });
    if counts[best] == 0 {
        return None;
    }
    let fault = FaultType::ALL[best];
    let chosen: Vec<&Diagnosis> = windows
        .iter()
        .filter_map(|w| w.as_ref().ok())
        .filter(|d| d.fault == fault)
        .collect();
    let n = chosen.len() as f32;
    let confidence = chosen.iter().map(|d| d.confidence).sum::<f32>() / n;
    let (impact, impact_unc) = median_and_uncertainty(
        chosen.iter().map(|d| d.severity.impact_to_background_db),
        chosen.iter().map(|d| d.severity.uncertainty_db),
    );
    let (fall, fall_unc) = median_and_uncertainty(
        chosen.iter().map(|d| d.severity.harmonic_fall_db),
        chosen.iter().map(|d| d.severity.fall_uncertainty_db),
    );
    Some(RecordDiagnosis {
        fault,
        counts,
        failed,
        confidence,
        severity: Severity {
            impact_to_background_db: impact,
            uncertainty_db: impact_unc,
            harmonic_fall_db: fall,
            fall_uncertainty_db: fall_unc,
            width: record_width(&chosen),
            fall_width: record_fall_width(
                &chosen
                    .iter()
                    .filter_map(|d| d.severity.fall_width)
                    .collect::<Vec<_>>(),
                chosen.len(),
            ),
        },
    })
}

/// The median of the windows' `values` and its uncertainty: their scatter (half the
/// inter-quartile range over √windows) or the median of the windows' `own`
/// uncertainties over √windows, the larger; not-a-number for no window.
fn median_and_uncertainty(
    values: impl Iterator<Item = f32>,
    own: impl Iterator<Item = f32>,
) -> (f32, f32) {
    let (mut values, mut own): (Vec<f32>, Vec<f32>) = (values.collect(), own.collect());
    if values.is_empty() || own.is_empty() {
        return (f32::NAN, f32::NAN);
    }
    values.sort_by(f32::total_cmp);
    own.sort_by(f32::total_cmp);
    let q = |p: f32| values[((values.len() - 1) as f32 * p).round() as usize];
    let root_n = (values.len() as f32).sqrt();
    let scatter = 0.5 * (q(0.75) - q(0.25)) / root_n;
    (q(0.5), scatter.max(own[own.len() / 2] / root_n))
}

/// The record's width from its windows' delays: the median of the resolved widths
/// when at least half the windows resolved one (uncertainty: half the inter-quartile
/// range over √windows, at least one sample's worth), else the median upper bound.
fn record_width(chosen: &[&Diagnosis]) -> Option<Width> {
    let widths: Vec<Width> = chosen.iter().filter_map(|d| d.severity.width).collect();
    if widths.is_empty() {
        return None;
    }
    let found: Vec<&Width> = widths.iter().filter(|w| !w.upper_bound).collect();
    let resolution = widths[0].uncertainty_deg;
    if 2 * found.len() >= widths.len() {
        let (degrees, spread) =
            median_and_uncertainty(found.iter().map(|w| w.degrees), found.iter().map(|_| 0.0));
        return Some(Width {
            degrees,
            uncertainty_deg: spread.max(resolution),
            upper_bound: false,
        });
    }
    let mut bounds: Vec<f32> = widths.iter().map(|w| w.degrees).collect();
    bounds.sort_by(f32::total_cmp);
    Some(Width {
        degrees: bounds[bounds.len() / 2],
        uncertainty_deg: resolution,
        upper_bound: true,
    })
}

/// A record's width from its windows' harmonic falls, `read` by some of its
/// `windows`: the median of the widths read, with [`median_and_uncertainty`]'s
/// uncertainty, when at least half the windows read one; else `None` (the lines
/// were in the noise, or fell beyond what a dwell gives, on most windows). An upper
/// bound (a dwell under what the fall resolves) where more than half of those read
/// are.
pub fn record_fall_width(read: &[Width], windows: usize) -> Option<Width> {
    if read.is_empty() || 2 * read.len() < windows {
        return None;
    }
    let (degrees, uncertainty_deg) = median_and_uncertainty(
        read.iter().map(|w| w.degrees),
        read.iter().map(|w| w.uncertainty_deg),
    );
    let bounds = read.iter().filter(|w| w.upper_bound).count();
    Some(Width {
        degrees,
        uncertainty_deg,
        upper_bound: 2 * bounds > read.len(),
    })
}

/// Index of `t` in [`FaultType::ALL`].
pub fn type_index(t: FaultType) -> usize {
    FaultType::ALL.iter().position(|&x| x == t).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::Channel;
    use pumptwin_core::bearing::BearingGeometry;

    /// A 12 kHz record of one drive-end channel.
    fn de_record(samples: Vec<f32>) -> Recording {
        Recording {
            name: "r".into(),
            fs_hz: 12_000.0,
            rpm: Some(1797.0),
            channels: vec![Channel {
                name: "DE".into(),
                samples,
            }],
        }
    }

    #[test]
    fn a_missing_channel_a_short_record_and_a_flat_window_are_not_diagnosed() {
        // 4 096 samples of a chirp, then a flat stretch (a dead sensor).
        let x: Vec<f32> = (0..7000)
            .map(|i| {
                if i < 4096 {
                    (i as f32 * 0.001 * i as f32).sin()
                } else {
                    0.5
                }
            })
            .collect();
        let rec = de_record(x);
        let orders = BearingGeometry::CWRU_6205_DE.orders();
        let t = Thresholds::DEFAULT;
        let d = |ch: &str, starts: &[usize]| {
            diagnose_windows(&rec, ch, starts, 2048, 16_384, 29.95, &orders, &t)
        };
        assert!(d("FE", &[0]).is_none());
        let w = d("DE", &[0, 2048, 4500, 6000]).unwrap();
        assert!(w[0].is_ok(), "{:?}", w[0]);
        // Window 1 is read over the 4 096 samples before its end.
        assert!(w[1].is_ok(), "{:?}", w[1]);
        assert_eq!(w[2], Err(pumptwin_core::Error::Degenerate));
        assert!(matches!(w[3], Err(pumptwin_core::Error::BufferSize { .. })));
        let r = summarize_record(&w).unwrap();
        assert_eq!(r.failed, 2);
        assert_eq!(r.counts.iter().sum::<usize>(), 2);
        assert_eq!(summarize_record(&w[2..]), None);
    }

    /// The record's severity figures are the medians of its majority type's windows,
    /// robust to one wild window; a fall width only where half those windows read one.
    #[test]
    fn the_record_severity_is_the_median_of_its_windows() {
        let x: Vec<f32> = (0..4096).map(|i| (i as f32 * 0.37).sin()).collect();
        let rec = de_record(x);
        let orders = BearingGeometry::CWRU_6205_DE.orders();
        let w = diagnose_windows(
            &rec,
            "DE",
            &[0],
            2048,
            4096,
            29.95,
            &orders,
            &Thresholds::DEFAULT,
        )
        .unwrap();
        let base = *w[0].as_ref().unwrap();
        let width = |deg: f32| Width {
            degrees: deg,
            uncertainty_deg: 0.1,
            upper_bound: false,
        };
        let window = |fall: f32, read: Option<f32>| -> WindowDiagnosis {
            let mut d = base;
            d.fault = FaultType::OuterRace;
            d.severity.harmonic_fall_db = fall;
            d.severity.fall_uncertainty_db = 0.2;
            d.severity.fall_width = read.map(width);
            Ok(d)
        };
        let mut windows = vec![
            window(1.0, Some(4.0)),
            window(2.0, Some(5.0)),
            window(3.0, Some(6.0)),
            window(4.0, None),
            window(90.0, None),
        ];
        let r = summarize_record(&windows).unwrap();
        assert_eq!(r.severity.harmonic_fall_db, 3.0);
        // Scatter (4 − 2)/2/√5 = 0.447 over the windows' own 0.2/√5.
        assert!((r.severity.fall_uncertainty_db - 1.0 / 5f32.sqrt()).abs() < 1e-6);
        let fw = r.severity.fall_width.unwrap();
        assert_eq!(fw.degrees, 5.0);
        assert!(!fw.upper_bound);
        windows.push(window(5.0, None));
        windows.push(window(6.0, None));
        assert_eq!(
            summarize_record(&windows).unwrap().severity.fall_width,
            None
        );
    }

    /// A record's fall width is a bound where most windows that read one read a
    /// bound (a dwell under what the fall resolves), a value otherwise.
    #[test]
    fn the_record_fall_width_is_a_bound_where_most_windows_read_one() {
        let w = |degrees: f32, upper_bound: bool| Width {
            degrees,
            uncertainty_deg: 0.0,
            upper_bound,
        };
        let bounds = [w(2.5, true), w(2.5, true), w(6.0, false)];
        let r = record_fall_width(&bounds, 4).unwrap();
        assert!(r.upper_bound && r.degrees == 2.5, "{r:?}");
        let values = [w(2.5, true), w(6.0, false), w(7.0, false)];
        let r = record_fall_width(&values, 3).unwrap();
        assert!(!r.upper_bound && r.degrees == 6.0, "{r:?}");
        assert_eq!(record_fall_width(&values, 7), None);
    }
}
