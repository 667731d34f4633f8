//! The defect families' lines in a band's envelope spectrum and the severity from its
//! squared envelope spectrum.

use super::bands::pulse_transfer_of;
use super::types::{Defect, LineEvidence, HARMONICS, SLIP};
use crate::bearing::DefectOrders;
use crate::dsp::median_level;
use crate::math;

/// The envelope spectra of one band (averaged over a span of windows or of one) and
/// what they are read with.
#[derive(Debug, Clone, Copy)]
pub struct BandSpectra<'a> {
    /// Envelope spectrum (of `|z|`), `N/2 + 1` bins.
    pub es: &'a [f32],
    /// Squared envelope spectrum (of `|z|²`), `N/2 + 1` bins.
    pub ses: &'a [f32],
    /// The band's power, `mean |z|²`.
    pub p0: f32,
    /// Bin width, Hz.
    pub df: f32,
    /// The band's width, Hz: lines above 0.9 of it are not in its envelope.
    pub width_hz: f32,
    /// How long one impact's squared envelope takes to rise from and fall to `1/e`
    /// of its peak in the band, s ([`super::bands::impact_pulse_s`]; 0 where none was
    /// read).
    pub pulse_s: [f32; 2],
}

/// Whether a line at `f` (tolerance `tol`) falls on a harmonic of another family:
/// such a line is evidence for neither (CWRU's drive end: 3·BPFO = 10.76 and
/// 2·BPFI = 10.83 orders).
fn collides(f: f32, tol: f32, others: [f32; 2], df: f32) -> bool {
    others.iter().any(|&g| {
        (1..=HARMONICS).any(|m| {
            let fm = m as f32 * g;
            (f - fm).abs() <= tol + df.max(SLIP * fm)
        })
    })
}

/// The bins within a line's tolerance.
fn line_bins(spectrum: &[f32], df: f32, f: f32) -> (usize, &[f32]) {
    let tol = df.max(SLIP * f);
    let lo = ((f - tol) / df).max(1.0) as usize;
    let hi = (((f + tol) / df) as usize).saturating_add(1);
    (lo, spectrum.get(lo..=hi).unwrap_or_default())
}

/// Level, dB over `bg`, of a family of fundamental `f0`: the mean over its
/// harmonics (the first always; a later one unless it collides with another family
/// or lies above `max_hz`) of the highest bin within the tolerance.
fn family_level_db(es: &[f32], df: f32, f0: f32, others: [f32; 2], max_hz: f32, bg: f32) -> f32 {
    let mut sum = 0.0f32;
    let mut used = 0usize;
    for h in 1..=HARMONICS {
        let f = h as f32 * f0;
        if h > 1 && (f > max_hz || collides(f, df.max(SLIP * f), others, df)) {
            continue;
        }
        let (_, bins) = line_bins(es, df, f);
        if bins.is_empty() {
            continue;
        }
        sum += bins.iter().fold(0.0f32, |m, &s| m.max(s));
        used += 1;
    }
    if used == 0 || bg <= 0.0 {
        return 0.0;
    }
    10.0 * math::log10f(sum / (used as f32 * bg) + 1e-12)
}

/// Severity from the family's first line in the squared envelope spectrum: the
/// lobe's power above the background over the band's power (module docs of
/// the module docs of `crate::diagnosis`); `(value, uncertainty)` in dB.
fn severity_db(ses: &[f32], df: f32, f0: f32, bg: f32, p0: f32) -> (f32, f32) {
    let (line, sigma) = lobe_power(ses, df, f0, bg);
    let amplitude = math::sqrtf(2.0 * line.max(sigma));
    let share = if p0 > 0.0 {
        (0.5 * amplitude / p0).clamp(1e-6, 0.999)
    } else {
        1e-6
    };
    let value = 10.0 * math::log10f(share / (1.0 - share));
    // s ∝ √line: d(dB) = 10/ln10 · (½·σ/line) · 1/(1 − s).
    let rel = 0.5 * sigma / line.max(sigma);
    (value, 10.0 / core::f32::consts::LN_10 * rel / (1.0 - share))
}

/// How far the family's second and third lines fall below its first in the squared
/// envelope spectrum: the first lobe's power over the mean of the next two, dB
/// (each at least its own noise, see `lobe_power`; 0 without a first line), its
/// standard uncertainty from the lobes' noise, dB, and whether the second and third
/// lines both stand above their noise (where one does not, it reads at the noise and
/// the fall is read short).
fn harmonic_fall(ses: &[f32], df: f32, f0: f32, bg: f32) -> (f32, f32, bool) {
    let lobes = [1.0f32, 2.0, 3.0].map(|h| lobe_power(ses, df, h * f0, bg));
    let [(p1, s1), (p2, s2), (p3, s3)] = lobes.map(|(line, sigma)| (line.max(sigma), sigma));
    let next = 0.5 * (p2 + p3);
    if p1 <= 0.0 || next <= 0.0 {
        return (0.0, 0.0, false);
    }
    // Relative errors of the first lobe and of the mean of the next two, in quadrature.
    let rel_next = 0.5 * math::sqrtf(s2 * s2 + s3 * s3) / next;
    let rel = math::sqrtf((s1 / p1) * (s1 / p1) + rel_next * rel_next);
    let above = lobes[1..].iter().all(|&(line, sigma)| line > sigma);
    (
        10.0 * math::log10f(p1 / next),
        10.0 / core::f32::consts::LN_10 * rel,
        above,
    )
}

/// A line's power in the squared envelope spectrum: the five bins about the highest
/// within its tolerance of `f`, less the background's mean there (`bg` is the
/// median), and that background's own scatter over them: `(line, sigma)`.
fn lobe_power(ses: &[f32], df: f32, f: f32, bg: f32) -> (f32, f32) {
    let (lo, bins) = line_bins(ses, df, f);
    let peak = bins
        .iter()
        .enumerate()
        .fold(
            (0usize, f32::MIN),
            |b, (i, &s)| if s > b.1 { (i, s) } else { b },
        )
        .0
        + lo;
    let bg_mean = bg / core::f32::consts::LN_2;
    let last = ses.len().saturating_sub(1);
    let (a, b) = (peak.saturating_sub(2).max(1), (peak + 2).min(last));
    let lobe_bins = (b + 1).saturating_sub(a).max(1) as f32;
    let lobe: f32 = ses.get(a..=b).unwrap_or_default().iter().sum();
    let line = (lobe - bg_mean * lobe_bins).max(0.0);
    (line, bg_mean * math::sqrtf(lobe_bins))
}

/// The bins the background is the median of — up to the highest family's last
/// harmonic — and the highest line frequency the band's envelope carries, Hz.
fn background_bins(
    spectra: &BandSpectra<'_>,
    shaft_hz: f32,
    orders: &DefectOrders,
) -> (usize, f32) {
    let df = spectra.df;
    let highest = Defect::ALL
        .iter()
        .fold(0.0f32, |m, d| m.max(d.order(orders) * shaft_hz));
    let nyquist = df * spectra.es.len().saturating_sub(1) as f32;
    let max_hz = (0.9 * spectra.width_hz).min(nyquist - df);
    let k_hi = ((HARMONICS as f32 * highest * 1.1).min(max_hz) / df) as usize;
    (k_hi, max_hz)
}

/// Level, dB over the same background as the families', of the envelope's line at
/// the cage rate (FTF) — the load zone's modulation of a rolling element's impacts
/// (module docs of `crate::diagnosis`) — and of the strongest bin above that line's
/// tolerance up to the families' last harmonic: `(cage, strongest above)`.
pub fn cage_line_db(
    spectra: &BandSpectra<'_>,
    shaft_hz: f32,
    orders: &DefectOrders,
    work: &mut [f32],
) -> (f32, f32) {
    let (k_hi, _) = background_bins(spectra, shaft_hz, orders);
    let bg = median_level(spectra.es, k_hi, work);
    let (lo, bins) = line_bins(spectra.es, spectra.df, orders.ftf * shaft_hz);
    let peak = bins.iter().fold(0.0f32, |m, &s| m.max(s));
    let above = spectra
        .es
        .get(lo + bins.len()..=k_hi)
        .unwrap_or_default()
        .iter()
        .fold(0.0f32, |m, &s| m.max(s));
    if bg <= 0.0 {
        return (0.0, 0.0);
    }
    let db = |v: f32| 10.0 * math::log10f(v / bg + 1e-12);
    (db(peak), db(above))
}

/// Every family's evidence in `spectra` for a bearing of `orders` at `shaft_hz`.
/// `work`: `N/2 + 1` floats for the medians.
pub fn line_evidence(
    spectra: &BandSpectra<'_>,
    shaft_hz: f32,
    orders: &DefectOrders,
    work: &mut [f32],
) -> [LineEvidence; 3] {
    let df = spectra.df;
    let f = Defect::ALL.map(|d| d.order(orders) * shaft_hz);
    let (k_hi, max_hz) = background_bins(spectra, shaft_hz, orders);
    let bg_es = median_level(spectra.es, k_hi, work);
    let bg_ses = median_level(spectra.ses, k_hi, work);
    let mut lines = [LineEvidence::NONE; 3];
    for (i, line) in lines.iter_mut().enumerate() {
        let (Some(&f0), Some(&o1), Some(&o2)) = (f.get(i), f.get((i + 1) % 3), f.get((i + 2) % 3))
        else {
            continue;
        };
        let (sev, unc) = severity_db(spectra.ses, df, f0, bg_ses, spectra.p0);
        let (fall, fall_unc, clear) = harmonic_fall(spectra.ses, df, f0, bg_ses);
        *line = LineEvidence {
            level_db: family_level_db(spectra.es, df, f0, [o1, o2], max_hz, bg_es),
            impact_to_background_db: sev,
            uncertainty_db: unc,
            harmonic_fall_db: fall,
            fall_uncertainty_db: fall_unc,
            fall_lines_clear: clear,
            pulse_transfer: pulse_transfer_of(spectra.pulse_s, f0),
        };
    }
    lines
}
