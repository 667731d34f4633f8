//! One JSON object per window (one line of the JSON-lines output).
//!
//! ```text
//! {
//!   "t_s": 1700000000.170666,          timestamp of the frame that completed the window, s
//!   "window": 0,                       window number
//!   "start_sample": 0,                 first sample (per-channel index)
//!   "status": "ok" | "degraded",
//!   "missing": ["FE"],                 only when degraded: channels without the whole window
//!   "discontinuous": ["DE"],           only when degraded: lost/duplicate/dropped frames inside
//!   "failed": {"BA": "signal has zero variance"},  only when degraded: the core rejected the samples
//!   "shaft_hz": 29.95,
//!   "channels": {                      sensor-map order; only channels with features
//!     "DE": {"rms", "kurtosis", "crest_factor", "env_shaft_db", "env_bpfo_db",
//!            "env_bpfi_db", "env_bsf_db", "env_kurtosis", "envelope_peak_hz"}
//!   },
//!   "explanation": {"channel", "peak_hz", "peak_order", "prominence_db", "match",
//!                   "harmonic", "match_hz", "error_pct", "within_tolerance"} | null,
//!   "slow": {"rpm": {"value", "unit"}, "temperature": …, "pressure": …},
//!                                      only with a [dbc] section: latest DBC signal values
//!   "tracking": {"window": n, "status": "updated", "stiffness_radial", "damping_radial",
//!                "stiffness_rel", "damping_rel", "loss_before", "loss_after"}
//!             | {"window", "status": "skipped" | "failed", "reason"}
//!                                      the latest on-edge Θ update (eq. 10) and the window
//!                                      it ran on (an earlier one: it runs after each line)
//!   "physics": {"window": n, "fault_type", "confidence", "severity_db",
//!               "severity_uncertainty_db", "harmonic_fall_db",
//!               "harmonic_fall_uncertainty_db",
//!               "width": {"degrees", "uncertainty_deg", "upper_bound"} | null,
//!               "fall_width": {"degrees", "uncertainty_deg", "upper_bound"} | null,
//!               "pulse_s", "band_hz", "spectral_kurtosis", "line_levels_db", "cage_line_db",
//!               "above_cage_db"}
//!            | {"window", "error"} | null   the latest physical diagnosis of the first
//!                                      channel over the 16 shaft revolutions ending with
//!                                      window n (an earlier one: it runs after each
//!                                      line; `pumptwin_core::diagnosis`; README, "What
//!                                      `predict` concludes"); null before the first or
//!                                      when the channel was missing or broken there
//!   "warnings": [text, …],             only when there is one: the physics of window n
//!                                      against the network's class of window n
//!                                      ([`physics_warnings`])
//!   "diagnosis": …,                    only with a Diagnoser (`--model`)
//!   "health": {"frames_total", "used", "duplicate", "out_of_sequence", "unknown_id",
//!              "other_interface", "malformed",
//!              "late", "remote", "error_frames", "lost_frames", "bad_lines",
//!              "realignments", "windows", "degraded_windows"}
//! }
//! ```
//!
//! rms, kurtosis and crest factor are over the whole window; the `env_*` values are the
//! core's envelope features (see `pipeline`); see `explain` for the explanation.

use crate::explain::Explanation;
use crate::pipeline::{
    ChannelFeatures, ChannelOutcome, Health, PhysicsResult, Tracking, Window, ENV_BPFI_DB,
    ENV_BPFO_DB, ENV_BSF_DB, ENV_KURTOSIS, ENV_SHAFT_DB,
};
use serde::ser::{SerializeMap, Serializer};
use serde::Serialize;

/// `[(key, value)]` serialized as a JSON object in this order.
#[derive(Debug)]
struct Ordered<'a, V>(Vec<(&'a str, V)>);

impl<V: Serialize> Serialize for Ordered<'_, V> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

impl<V> Ordered<'_, V> {
    fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

#[derive(Debug, Serialize)]
struct ChannelReport {
    rms: f32,
    kurtosis: f32,
    crest_factor: f32,
    env_shaft_db: f32,
    env_bpfo_db: f32,
    env_bpfi_db: f32,
    env_bsf_db: f32,
    env_kurtosis: f32,
    envelope_peak_hz: f32,
}

impl From<&ChannelFeatures> for ChannelReport {
    fn from(f: &ChannelFeatures) -> Self {
        Self {
            rms: f.time.rms,
            kurtosis: f.time.kurtosis,
            crest_factor: f.time.crest_factor,
            env_shaft_db: f.envelope_feature(ENV_SHAFT_DB),
            env_bpfo_db: f.envelope_feature(ENV_BPFO_DB),
            env_bpfi_db: f.envelope_feature(ENV_BPFI_DB),
            env_bsf_db: f.envelope_feature(ENV_BSF_DB),
            env_kurtosis: f.envelope_feature(ENV_KURTOSIS),
            envelope_peak_hz: f.envelope_peak_hz,
        }
    }
}

#[derive(Debug, Serialize)]
struct WindowReport<'a> {
    t_s: f64,
    window: u64,
    start_sample: u64,
    status: &'static str,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    missing: Vec<&'a str>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    discontinuous: Vec<&'a str>,
    #[serde(skip_serializing_if = "Ordered::is_empty")]
    failed: Ordered<'a, String>,
    shaft_hz: f32,
    channels: Ordered<'a, ChannelReport>,
    explanation: Option<&'a Explanation>,
    #[serde(skip_serializing_if = "Ordered::is_empty")]
    slow: Ordered<'a, SlowReport<'a>>,
    tracking: serde_json::Value,
    physics: serde_json::Value,
    #[serde(skip_serializing_if = "<[String]>::is_empty")]
    warnings: &'a [String],
    #[serde(skip_serializing_if = "Option::is_none")]
    diagnosis: Option<&'a serde_json::Value>,
    health: &'a Health,
}

#[derive(Debug, Serialize)]
struct SlowReport<'a> {
    value: f64,
    unit: &'a str,
}

/// The physical diagnosis as the line writes it: `null` without one, `{"error"}`
/// where the window could not be diagnosed.
fn physics_json(window: Option<u64>, p: Option<&PhysicsResult>) -> serde_json::Value {
    match p {
        None => serde_json::Value::Null,
        Some(Err(e)) => serde_json::json!({ "window": window, "error": e.to_string() }),
        Some(Ok(d)) => serde_json::json!({
            "window": window,
            "fault_type": d.fault.name(),
            "confidence": d.confidence,
            "severity_db": d.severity.impact_to_background_db,
            "severity_uncertainty_db": d.severity.uncertainty_db,
            "harmonic_fall_db": d.severity.harmonic_fall_db,
            "harmonic_fall_uncertainty_db": d.severity.fall_uncertainty_db,
            "width": d.severity.width.map(width_json),
            "fall_width": d.severity.fall_width.map(width_json),
            "pulse_s": d.evidence.pulse_s,
            "band_hz": [d.evidence.band_lo_hz, d.evidence.band_hi_hz],
            "spectral_kurtosis": d.evidence.spectral_kurtosis,
            "line_levels_db": d.evidence.lines.map(|l| l.level_db),
            "cage_line_db": d.evidence.cage_db,
            "above_cage_db": d.evidence.above_cage_db,
        }),
    }
}

/// A width as the line writes it.
fn width_json(w: pumptwin_core::diagnosis::Width) -> serde_json::Value {
    serde_json::json!({
        "degrees": w.degrees,
        "uncertainty_deg": w.uncertainty_deg,
        "upper_bound": w.upper_bound,
    })
}

/// The JSON line (without newline) of `window`, with the diagnosis if there is one.
pub fn window_json(
    window: &Window,
    diagnosis: Option<&serde_json::Value>,
) -> serde_json::Result<String> {
    let channels = window
        .channels
        .iter()
        .filter_map(|c| match &c.outcome {
            ChannelOutcome::Computed { features, .. } => {
                Some((c.name.as_str(), ChannelReport::from(features.as_ref())))
            }
            _ => None,
        })
        .collect();
    let report = WindowReport {
        t_s: window.t_s,
        window: window.index,
        start_sample: window.start_sample,
        status: if window.is_degraded() {
            "degraded"
        } else {
            "ok"
        },
        missing: window.missing().collect(),
        discontinuous: window.discontinuous().collect(),
        failed: Ordered(window.failed().map(|(n, e)| (n, e.to_string())).collect()),
        shaft_hz: window.shaft_hz,
        channels: Ordered(channels),
        explanation: window.explanation.as_ref(),
        slow: Ordered(
            window
                .slow
                .iter()
                .map(|(role, value, unit)| {
                    (
                        *role,
                        SlowReport {
                            value: *value,
                            unit: unit.as_str(),
                        },
                    )
                })
                .collect(),
        ),
        tracking: match window.tracking.1 {
            Tracking::Updated {
                stiffness_radial,
                damping_radial,
                stiffness_rel,
                damping_rel,
                loss_before,
                loss_after,
            } => serde_json::json!({
                "window": window.tracking.0,
                "status": "updated",
                "stiffness_radial": stiffness_radial,
                "damping_radial": damping_radial,
                "stiffness_rel": stiffness_rel,
                "damping_rel": damping_rel,
                "loss_before": loss_before,
                "loss_after": loss_after,
            }),
            Tracking::Skipped(why) => serde_json::json!({
                "window": window.tracking.0, "status": "skipped", "reason": why,
            }),
            Tracking::Failed(e) => serde_json::json!({
                "window": window.tracking.0, "status": "failed", "reason": e.to_string(),
            }),
        },
        physics: physics_json(window.physics.0, window.physics.1.as_ref()),
        warnings: &window.warnings,
        diagnosis,
        health: &window.health,
    };
    serde_json::to_string(&report)
}

/// One window as a line for people: time, window, status, the network's class and
/// probability, the physics' type, confidence and severity (of the window it ran on).
///
/// ```text
///   12.345 s  #41  ok        IR007 0.97 | physics #40 inner_race 0.99, 1.1 dB, fall 7.4 dB, width < 4.9°
/// ```
pub fn window_text(window: &Window, diagnosis: Option<&serde_json::Value>) -> String {
    let status = if window.is_degraded() {
        "degraded"
    } else {
        "ok"
    };
    let mut s = format!("{:>10.3} s  #{:<5} {status:<9}", window.t_s, window.index);
    match diagnosis.and_then(class_and_probability) {
        Some((class, p)) => s.push_str(&format!(" {class:<7} {p:.2}")),
        None => s.push_str(" —"),
    }
    match (window.physics.0, &window.physics.1) {
        (Some(n), Some(Ok(d))) => {
            s.push_str(&format!(
                " | physics #{n} {} {:.2}, {:.1} dB, fall {:.1} dB",
                d.fault.name(),
                d.confidence,
                d.severity.impact_to_background_db,
                d.severity.harmonic_fall_db
            ));
            if let Some(w) = d.severity.width {
                let mark = if w.upper_bound { "< " } else { "" };
                s.push_str(&format!(", width {mark}{:.1}°", w.degrees));
            }
        }
        (Some(n), Some(Err(e))) => s.push_str(&format!(" | physics #{n}: {e}")),
        _ => s.push_str(" | physics —"),
    }
    for w in &window.warnings {
        s.push_str(&format!("\n           warning: {w}"));
    }
    s
}

/// The warnings of the physics of window `n` against the network's `class` of the
/// same window (`pumptwin_core::diagnosis::Disagreement`, the rule `predict` uses):
/// a fault the drive end does not support (noise, another machine, a wrong speed or
/// rate), a defect the physics names otherwise, a drive end the physics could not read.
pub fn physics_warnings(n: u64, class: &str, physics: &PhysicsResult) -> Vec<String> {
    use pumptwin_core::diagnosis::{Disagreement, FaultType};
    let d = match physics {
        Ok(d) => d,
        Err(e) => {
            return vec![format!(
                "window {n}: no physical diagnosis of the drive end ({e}); the network's \
                 {class} stands alone"
            )]
        }
    };
    let Some(net) = FaultType::of_class(class) else {
        return Vec::new();
    };
    match Disagreement::of(net, d.fault) {
        Some(Disagreement::Unsupported) => vec![format!(
            "window {n}: the network named {class}, but the drive end shows no defect line and \
             no impulsiveness: its class is not supported (noise, another machine, a wrong \
             speed or rate?)"
        )],
        Some(Disagreement::Different) => vec![format!(
            "window {n}: the network named {class} ({}), the physics {}: the physics' lines \
             decide",
            net.name(),
            d.fault.name()
        )],
        None => Vec::new(),
    }
}

/// The class and its confidence in a diagnoser's JSON (`"class"`, `"confidence"`).
fn class_and_probability(d: &serde_json::Value) -> Option<(String, f64)> {
    let class = d.get("class")?.as_str()?.to_string();
    let p = d
        .get("confidence")
        .and_then(serde_json::Value::as_f64)
        .unwrap_or(f64::NAN);
    Some((class, p))
}

/// Windows per diagnosed class and per physical type over a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tally {
    /// The network's class → windows.
    pub classes: std::collections::BTreeMap<String, u64>,
    /// The physics' type → windows it was computed for.
    pub physics: std::collections::BTreeMap<&'static str, u64>,
    /// Lines that carried a warning.
    pub warned: u64,
}

impl Tally {
    /// Count `window` (its physics counts once, on the line that reports it).
    pub fn add(&mut self, window: &Window, diagnosis: Option<&serde_json::Value>) {
        if let Some((class, _)) = diagnosis.and_then(class_and_probability) {
            *self.classes.entry(class).or_default() += 1;
        }
        if let Some(Ok(d)) = &window.physics.1 {
            *self.physics.entry(d.fault.name()).or_default() += 1;
        }
        if !window.warnings.is_empty() {
            self.warned += 1;
        }
    }

    /// The closing summary: the majority of each and the counts.
    pub fn summary(&self) -> String {
        let list = |m: Vec<(String, u64)>| {
            let total: u64 = m.iter().map(|(_, n)| n).sum();
            let mut v = m;
            v.sort_by_key(|x| std::cmp::Reverse(x.1));
            let items: Vec<String> = v.iter().map(|(k, n)| format!("{k} {n}")).collect();
            (total, items.join(", "))
        };
        let (nc, classes) = list(self.classes.iter().map(|(k, n)| (k.clone(), *n)).collect());
        let (np, physics) = list(
            self.physics
                .iter()
                .map(|(k, n)| ((*k).to_string(), *n))
                .collect(),
        );
        let warned = match self.warned {
            0 => String::new(),
            n => format!("; {n} lines with a warning (network and physics disagree)"),
        };
        format!(
            "network classes over {nc} windows: {}; physics over {np}: {}{warned}",
            if classes.is_empty() {
                "—".into()
            } else {
                classes
            },
            if physics.is_empty() {
                "—".into()
            } else {
                physics
            }
        )
    }
}
