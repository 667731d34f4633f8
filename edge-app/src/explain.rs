//! The physics explanation of a window: the strongest line of the envelope spectrum
//! and the bearing kinematic frequency it sits on.
//!
//! ```text
//! E(ν)        = envelope spectrum of the window (pumptwin_core::features::envelope_spectrum)
//! f_peak      = argmax E(ν) over 40 ≤ ν ≤ 400 Hz, parabolic interpolation (peak_frequency)
//! prominence  = 10·log10( E(f_peak) / median E(ν) over 0 < ν ≤ 4·max(BPFO, BPFI, BSF, f_r) )
//! candidates  = h·f  for f ∈ {f_r, BPFO, BPFI, BSF, FTF}, h = 1, 2, 3
//! match       = argmin over candidates of |f_peak − h·f| / (h·f)
//! error_pct   = 100 · (f_peak − h·f) / (h·f)            (signed: > 0 peak above the line)
//! within_tol  = |f_peak − h·f| ≤ max(Δf, 1.5 % · h·f)    Δf = fs / W, 1.5 % = slip
//! ```
//!
//! The candidates are the shaft harmonics 1–3×, the defect frequencies and their 2nd and
//! 3rd harmonics; a ball defect strikes at `2·BSF`, which is "BSF, harmonic 2". Some
//! candidates lie close together (on the 6205, `3·BPFO ≈ 2·BPFI` 0.6 % apart and
//! `3·BSF ≈ 2·BPFO` 1.4 % apart), so a harmonic-2/3 match is a lead, not a verdict;
//! `within_tolerance = false` means no kinematic line explains the peak.
//! The window's explanation comes from the channel whose peak is most prominent.

use pumptwin_core::bearing::DefectFrequencies;
use pumptwin_core::features::ENVELOPE_SLIP;
use serde::Serialize;

/// Band searched for the envelope-spectrum peak, Hz.
pub const PEAK_BAND_HZ: (f32, f32) = (40.0, 400.0);
/// Harmonics of each kinematic frequency among the candidates.
pub const HARMONICS: u8 = 3;

/// A kinematic frequency family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum KinematicLine {
    /// Shaft rate `f_r`.
    #[serde(rename = "shaft")]
    Shaft,
    /// Ball pass frequency, outer race.
    #[serde(rename = "BPFO")]
    Bpfo,
    /// Ball pass frequency, inner race.
    #[serde(rename = "BPFI")]
    Bpfi,
    /// Ball spin frequency (a ball defect impacts at 2·BSF).
    #[serde(rename = "BSF")]
    Bsf,
    /// Fundamental train (cage) frequency.
    #[serde(rename = "FTF")]
    Ftf,
}

impl KinematicLine {
    /// All families, in tie-break order.
    pub const ALL: [Self; 5] = [Self::Shaft, Self::Bpfo, Self::Bpfi, Self::Bsf, Self::Ftf];

    /// The name used in the JSON output.
    pub fn name(self) -> &'static str {
        match self {
            Self::Shaft => "shaft",
            Self::Bpfo => "BPFO",
            Self::Bpfi => "BPFI",
            Self::Bsf => "BSF",
            Self::Ftf => "FTF",
        }
    }

    /// Fundamental frequency of the family, Hz.
    pub fn frequency(self, f: &DefectFrequencies) -> f32 {
        match self {
            Self::Shaft => f.shaft,
            Self::Bpfo => f.bpfo,
            Self::Bpfi => f.bpfi,
            Self::Bsf => f.bsf,
            Self::Ftf => f.ftf,
        }
    }
}

/// The nearest kinematic line to a frequency.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct KinematicMatch {
    /// Family.
    #[serde(rename = "match")]
    pub line: KinematicLine,
    /// Harmonic number `h` (1..=3).
    pub harmonic: u8,
    /// `h · f`, Hz.
    #[serde(rename = "match_hz")]
    pub line_hz: f32,
    /// `100 · (f_peak − h·f) / (h·f)`.
    pub error_pct: f32,
    /// `|f_peak − h·f| ≤ max(Δf, 1.5 % · h·f)`.
    pub within_tolerance: bool,
}

/// The nearest of the candidates `h·f` (see the module docs) to `peak_hz`.
/// `resolution_hz` is the spectrum's bin spacing. Ties go to the earlier family in
/// [`KinematicLine::ALL`], then the lower harmonic.
pub fn nearest_kinematic(
    peak_hz: f32,
    freqs: &DefectFrequencies,
    resolution_hz: f32,
) -> Option<KinematicMatch> {
    let mut best: Option<(f32, KinematicLine, u8, f32)> = None;
    for line in KinematicLine::ALL {
        for h in 1..=HARMONICS {
            let f = f32::from(h) * line.frequency(freqs);
            if !(f.is_finite() && f > 0.0) {
                continue;
            }
            let rel = (peak_hz - f).abs() / f;
            if best.is_none_or(|(b, ..)| rel < b) {
                best = Some((rel, line, h, f));
            }
        }
    }
    let (_, line, harmonic, line_hz) = best?;
    let tol = resolution_hz.max(ENVELOPE_SLIP * line_hz);
    Some(KinematicMatch {
        line,
        harmonic,
        line_hz,
        error_pct: 100.0 * (peak_hz - line_hz) / line_hz,
        within_tolerance: (peak_hz - line_hz).abs() <= tol,
    })
}

/// The explanation of one window.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Explanation {
    /// Channel whose envelope peak is most prominent.
    pub channel: String,
    /// Peak of its envelope spectrum in [`PEAK_BAND_HZ`], Hz.
    pub peak_hz: f32,
    /// `peak_hz / f_r`.
    pub peak_order: f32,
    /// Peak over the median envelope-spectrum level, dB.
    pub prominence_db: f32,
    /// Nearest kinematic line.
    #[serde(flatten)]
    pub kinematic: KinematicMatch,
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumptwin_core::bearing::BearingGeometry;

    fn freqs() -> DefectFrequencies {
        BearingGeometry::CWRU_6205_DE.frequencies(1797.0 / 60.0)
    }

    #[test]
    fn defect_frequencies_match_themselves() {
        let f = freqs();
        let df = 12_000.0 / 2048.0;
        for (hz, line, h) in [
            (f.bpfi, KinematicLine::Bpfi, 1),
            (f.bpfo, KinematicLine::Bpfo, 1),
            (2.0 * f.bsf, KinematicLine::Bsf, 2),
            (2.0 * f.shaft, KinematicLine::Shaft, 2),
            (2.0 * f.bpfo, KinematicLine::Bpfo, 2),
        ] {
            let m = nearest_kinematic(hz * 1.004, &f, df).unwrap();
            assert_eq!((m.line, m.harmonic), (line, h), "{hz}");
            assert!((m.error_pct - 0.4).abs() < 1e-3, "{}", m.error_pct);
            assert!(m.within_tolerance);
        }
    }

    #[test]
    fn far_from_every_line_is_out_of_tolerance() {
        let f = freqs();
        // Between 3·f_r (89.9 Hz) and BPFO (107.4 Hz).
        let m = nearest_kinematic(98.0, &f, 1.0).unwrap();
        assert!(!m.within_tolerance, "{m:?}");
        assert!(m.error_pct.abs() > 5.0);
    }

    #[test]
    fn serializes_with_the_field_names_of_the_output() {
        let f = freqs();
        let e = Explanation {
            channel: "DE".into(),
            peak_hz: f.bpfi,
            peak_order: f.bpfi / f.shaft,
            prominence_db: 20.0,
            kinematic: nearest_kinematic(f.bpfi, &f, 5.86).unwrap(),
        };
        let v = serde_json::to_value(&e).unwrap();
        assert_eq!(v["match"], "BPFI");
        assert_eq!(v["harmonic"], 1);
        assert_eq!(v["channel"], "DE");
        assert_eq!(v["error_pct"], 0.0);
        assert_eq!(v["within_tolerance"], true);
    }
}
