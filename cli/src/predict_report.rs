//! The report of `pumptwin predict`: per window the network's class and the physics,
//! per record the network's majority and the diagnosis in physical terms. Serialized
//! as the JSON report (`predict --out`, `--json`, a pipe) and read by the table for
//! people (`predict_text`).

use std::collections::BTreeMap;

use serde::Serialize;

/// One window's diagnosis.
#[derive(Debug, Clone, Serialize)]
pub struct WindowPrediction {
    /// Window start in the recording at the model rate, s.
    pub start_s: f64,
    /// Predicted class.
    pub class: String,
    /// Class probabilities, in the model's class order.
    pub probabilities: BTreeMap<String, f32>,
    /// Nodes masked in this window.
    pub masked_nodes: Vec<String>,
    /// The physical diagnosis of the drive-end sensor up to this window
    /// (`pumptwin_core::diagnosis`), or why there is none.
    pub physics: PhysicsWindow,
}

/// One window's physical diagnosis as `predict` reports it.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum PhysicsWindow {
    /// Diagnosed.
    Diagnosed {
        /// `normal`, `inner_race`, `outer_race`, `ball` or `no_clear_signature`.
        fault_type: &'static str,
        /// Probability that the type is right (calibrated on the development records).
        confidence: f32,
        /// Impact power over the band's background power, dB.
        severity_db: f32,
        /// Its standard uncertainty, dB.
        severity_uncertainty_db: f32,
        /// How far the family's second and third lines fall below its first, dB
        /// (grows with a spall's width; `pumptwin_core::diagnosis::Severity`).
        harmonic_fall_db: f32,
        /// Its standard uncertainty, dB.
        harmonic_fall_uncertainty_db: f32,
        /// The defect's angular extent from the entry-to-exit delay, for a typed
        /// claim (`null` otherwise).
        width: Option<WidthReport>,
        /// The width a rectangular dwell would need to fall as fast through the
        /// band's pulse, for a typed claim whose lines read one (`null` otherwise):
        /// an estimate, or a bound under what the fall resolves.
        fall_width: Option<WidthReport>,
        /// One impact's pulse in the band: the seconds its squared envelope takes to
        /// rise from `1/e` of its peak and to fall back to it, `[rise, fall]` (0
        /// where no impact read one): what the width from the fall takes out.
        pulse_s: [f32; 2],
        /// The most impulsive band, Hz.
        band_hz: [f32; 2],
        /// Its spectral kurtosis (0 for Gaussian noise).
        spectral_kurtosis: f32,
        /// Each family's line level over the envelope spectrum's median, dB:
        /// `[outer_race, inner_race, ball]`.
        line_levels_db: [f32; 3],
        /// The envelope's line at the cage rate over the same median, dB: a ball's
        /// evidence where its own family has no line.
        cage_line_db: f32,
        /// The strongest envelope line above the cage line, over the same median, dB:
        /// the cage line must lead it to type a ball.
        above_cage_db: f32,
    },
    /// Not diagnosed.
    Failed {
        /// Why.
        error: String,
    },
}

impl PhysicsWindow {
    pub(crate) fn of(d: &pumptwin_data::diagnose::WindowDiagnosis) -> Self {
        match d {
            Ok(d) => Self::Diagnosed {
                fault_type: d.fault.name(),
                confidence: d.confidence,
                severity_db: d.severity.impact_to_background_db,
                severity_uncertainty_db: d.severity.uncertainty_db,
                harmonic_fall_db: d.severity.harmonic_fall_db,
                harmonic_fall_uncertainty_db: d.severity.fall_uncertainty_db,
                width: d.severity.width.map(WidthReport::of),
                fall_width: d.severity.fall_width.map(WidthReport::of),
                pulse_s: d.evidence.pulse_s,
                band_hz: [d.evidence.band_lo_hz, d.evidence.band_hi_hz],
                spectral_kurtosis: d.evidence.spectral_kurtosis,
                line_levels_db: d.evidence.lines.map(|l| l.level_db),
                cage_line_db: d.evidence.cage_db,
                above_cage_db: d.evidence.above_cage_db,
            },
            Err(e) => Self::Failed {
                error: e.to_string(),
            },
        }
    }
}

/// The record's diagnosis in physical terms: the physics' type where it is decisive
/// (a typed line or a quiet, lineless signal), else the network's type.
#[derive(Debug, Clone, Serialize)]
pub struct RecordDiagnosisReport {
    /// `normal`, `inner_race`, `outer_race`, `ball` or `no_clear_signature`.
    pub fault_type: &'static str,
    /// `physics` or `network`: which decided.
    pub decided_by: &'static str,
    /// Probability that the type is right: the physics' mean calibrated confidence
    /// over its windows of that type, or the network's share of windows of it.
    pub confidence: f32,
    /// The physics' severity of the majority type's windows.
    pub severity: SeverityReport,
    /// The physics' windows per type.
    pub physics_windows: BTreeMap<&'static str, usize>,
    /// Windows the physics could not diagnose (a flat or non-finite sensor).
    pub physics_failed_windows: usize,
}

/// A severity with its units.
#[derive(Debug, Clone, Serialize)]
pub struct SeverityReport {
    /// Impact power over the resonance band's background power.
    pub impact_to_background_db: f32,
    /// Standard uncertainty.
    pub uncertainty_db: f32,
    /// `dB`.
    pub unit: &'static str,
    /// How far the family's second and third lines fall below its first, dB: grows
    /// with a spall's width where the fall resolves it (about `23°/Z` of the race and
    /// up); ranks the sizes of one machine's defects, reads no gain.
    pub harmonic_fall_db: f32,
    /// Its standard uncertainty, dB.
    pub harmonic_fall_uncertainty_db: f32,
    /// The defect's angular extent from the entry-to-exit delay (typed claims by the
    /// physics only).
    pub width: Option<WidthReport>,
    /// The width a rectangular dwell would need to fall as fast (typed claims by the
    /// physics only, where half the windows read one): an estimate biased high by the
    /// ring-down and slip.
    pub fall_width: Option<WidthReport>,
}

/// A defect's angular extent.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct WidthReport {
    /// Degrees of the damaged race (ball: of its circumference).
    pub degrees: f32,
    /// Standard uncertainty, degrees.
    pub uncertainty_deg: f32,
    /// The entry-to-exit delay was not resolved: an upper bound (always false for a
    /// width read from the fall).
    pub upper_bound: bool,
}

impl WidthReport {
    pub(crate) fn of(w: pumptwin_core::diagnosis::Width) -> Self {
        Self {
            degrees: w.degrees,
            uncertainty_deg: w.uncertainty_deg,
            upper_bound: w.upper_bound,
        }
    }
}

/// The report of `predict`.
#[derive(Debug, Clone, Serialize)]
pub struct Prediction {
    /// The recording.
    pub input: String,
    /// The model file.
    pub model: String,
    /// `dsstgat-int8` or `dsstgat`.
    pub arch: String,
    /// The recording's sampling rate, Hz.
    pub fs_hz_input: f32,
    /// The model's rate, Hz.
    pub fs_hz_model: f32,
    /// Whether the recording was resampled (anti-aliased and decimated).
    pub resampled: bool,
    /// Model sensors the recording does not have (masked in every window).
    pub missing_nodes: Vec<String>,
    /// Windows with no usable sensor: class `NO_SIGNAL`, no probabilities, left
    /// out of the majority.
    pub no_signal_windows: usize,
    /// Samples at the model rate after the last whole window (less than a hop: not
    /// diagnosed, said rather than dropped in silence).
    pub samples_after_last_window: usize,
    /// Per window.
    pub windows: Vec<WindowPrediction>,
    /// The most frequent class over the diagnosed windows.
    pub majority_class: String,
    /// Windows per class.
    pub class_counts: BTreeMap<String, usize>,
    /// The diagnosis in physical terms (`null` without a drive-end channel or when
    /// no window could be diagnosed).
    pub diagnosis: Option<RecordDiagnosisReport>,
    /// What a reader must not miss: the network's class not supported by the physics
    /// (a record outside its training conditions: another machine, noise, a wrong
    /// speed), the two naming different faults, windows the physics could not read.
    pub warnings: Vec<String>,
}
