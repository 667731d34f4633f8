//! `predict`'s report for people (a terminal's default; `--json` or a pipe gives the
//! JSON): the physics' diagnosis in segments of consecutive windows of one type, then
//! the record's conclusion.
//!
//! ```text
//! tests/data/cwru105_1s.csv: 10 windows at 12000 Hz
//!    from      to  physics             conf.  severity        fall      width
//!  0.00 s  0.94 s  inner_race           0.98  1.1 dB          7.4 dB    < 4.9°
//! network: IR007 (10 of 10 windows)
//! diagnosis: inner_race, confidence 0.98 (decided by the physics), severity 1.1 ± 0.0 dB
//! impact over background, harmonic fall 7.4 ± 0.0 dB, width < 4.9 ± 0.5°, width from
//! the fall ≈ 12.0° (an estimate biased high)
//! ```

use std::fmt::Write as _;

use crate::predict_report::{PhysicsWindow, Prediction};

/// The table and the conclusion, each line ending in a newline.
pub fn table(r: &Prediction) -> String {
    let mut s = format!(
        "{}: {} windows at {} Hz\n{:>7} {:>7}  {:<19} {:>5}  {:<15} {:<9} {:<10}\n",
        r.input,
        r.windows.len(),
        r.fs_hz_model,
        "from",
        "to",
        "physics",
        "conf.",
        "severity",
        "fall",
        "width"
    );
    let window_s = pumptwin_core::layout::WINDOW as f64 / f64::from(r.fs_hz_model);
    let mut k = 0;
    while k < r.windows.len() {
        let kind = physics_type(&r.windows[k].physics);
        let mut j = k;
        while j + 1 < r.windows.len() && physics_type(&r.windows[j + 1].physics) == kind {
            j += 1;
        }
        let seg = &r.windows[k..=j];
        let conf = mean(seg.iter().filter_map(|w| match &w.physics {
            PhysicsWindow::Diagnosed { confidence, .. } => Some(*confidence),
            PhysicsWindow::Failed { .. } => None,
        }));
        let sev = mean(seg.iter().filter_map(|w| match &w.physics {
            PhysicsWindow::Diagnosed { severity_db, .. } => Some(*severity_db),
            PhysicsWindow::Failed { .. } => None,
        }));
        let fall = mean(seg.iter().filter_map(|w| match &w.physics {
            PhysicsWindow::Diagnosed {
                harmonic_fall_db, ..
            } => Some(*harmonic_fall_db),
            PhysicsWindow::Failed { .. } => None,
        }));
        let width = seg.iter().rev().find_map(|w| match &w.physics {
            PhysicsWindow::Diagnosed { width: Some(w), .. } => Some(*w),
            _ => None,
        });
        let _ = writeln!(
            s,
            "{:>5.2} s {:>5.2} s  {:<19} {:>5}  {:<15} {:<9} {:<10}",
            seg[0].start_s,
            seg[seg.len() - 1].start_s + window_s,
            kind,
            conf.map_or("—".into(), |c| format!("{c:.2}")),
            sev.map_or("—".into(), |v| format!("{v:.1} dB")),
            fall.map_or("—".into(), |v| format!("{v:.1} dB")),
            width.map_or("—".into(), |w| format!(
                "{}{:.1}°",
                if w.upper_bound { "< " } else { "" },
                w.degrees
            )),
        );
        k = j + 1;
    }
    let _ = writeln!(
        s,
        "network: {} ({} of {} windows)",
        r.majority_class,
        r.class_counts.get(&r.majority_class).unwrap_or(&0),
        r.windows.len() - r.no_signal_windows
    );
    match &r.diagnosis {
        Some(d) => {
            let _ = writeln!(
                s,
                "diagnosis: {}, confidence {:.2} (decided by the {}), severity {:.1} ± {:.1} dB impact over background, harmonic fall {:.1} ± {:.1} dB{}{}",
                d.fault_type,
                d.confidence,
                d.decided_by,
                d.severity.impact_to_background_db,
                d.severity.uncertainty_db,
                d.severity.harmonic_fall_db,
                d.severity.harmonic_fall_uncertainty_db,
                d.severity.width.map_or(String::new(), |w| format!(
                    ", width {}{:.1} ± {:.1}°",
                    if w.upper_bound { "< " } else { "" },
                    w.degrees,
                    w.uncertainty_deg
                )),
                d.severity.fall_width.map_or(String::new(), |w| if w.upper_bound {
                    format!(
                        ", width from the fall < {:.1}° (under what the fall resolves)",
                        w.degrees
                    )
                } else {
                    format!(
                        ", width from the fall ≈ {:.1}° (an estimate, biased high)",
                        w.degrees
                    )
                })
            );
        }
        None => s.push_str("diagnosis: none (no usable drive-end channel)\n"),
    }
    for w in &r.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
    s
}

fn physics_type(p: &PhysicsWindow) -> String {
    match p {
        PhysicsWindow::Diagnosed { fault_type, .. } => (*fault_type).to_string(),
        PhysicsWindow::Failed { .. } => "not diagnosed".to_string(),
    }
}

fn mean(v: impl Iterator<Item = f32>) -> Option<f32> {
    let (sum, n) = v.fold((0.0f32, 0usize), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| sum / n as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::predict_report::WindowPrediction;
    use std::collections::BTreeMap;

    fn window(start_s: f64, fault_type: &'static str) -> WindowPrediction {
        WindowPrediction {
            start_s,
            class: "IR007".into(),
            probabilities: BTreeMap::new(),
            masked_nodes: Vec::new(),
            physics: PhysicsWindow::Diagnosed {
                fault_type,
                confidence: 0.9,
                severity_db: 2.0,
                severity_uncertainty_db: 0.1,
                harmonic_fall_db: 4.5,
                harmonic_fall_uncertainty_db: 0.3,
                width: None,
                fall_width: None,
                pulse_s: [0.0005, 0.0006],
                band_hz: [2_000.0, 3_200.0],
                spectral_kurtosis: 3.0,
                line_levels_db: [5.0, 20.0, 4.0],
                cage_line_db: 6.0,
                above_cage_db: 8.0,
            },
        }
    }

    /// Consecutive windows of one type make one segment; a failed window its own.
    #[test]
    fn segments_follow_the_physics() {
        let mut windows: Vec<WindowPrediction> =
            (0..3).map(|k| window(0.1 * k as f64, "normal")).collect();
        windows.extend((3..5).map(|k| window(0.1 * k as f64, "inner_race")));
        windows.push(WindowPrediction {
            physics: PhysicsWindow::Failed {
                error: "flat".into(),
            },
            ..window(0.5, "normal")
        });
        let r = Prediction {
            input: "r.csv".into(),
            model: "m.ptm".into(),
            arch: "dsstgat-int8".into(),
            fs_hz_input: 12_000.0,
            fs_hz_model: 12_000.0,
            resampled: false,
            missing_nodes: Vec::new(),
            no_signal_windows: 0,
            samples_after_last_window: 0,
            windows,
            majority_class: "IR007".into(),
            class_counts: BTreeMap::from([("IR007".to_string(), 6)]),
            diagnosis: None,
            warnings: vec!["w".into()],
        };
        let t = table(&r);
        let rows: Vec<&str> = t.lines().collect();
        assert_eq!(rows.len(), 2 + 3 + 2 + 1, "{t}");
        assert_eq!(rows[7], "warning: w");
        assert!(
            rows[2].contains("normal") && rows[2].contains("0.90"),
            "{t}"
        );
        assert!(
            rows[3].contains("inner_race") && rows[3].contains("4.5 dB"),
            "{t}"
        );
        assert!(rows[4].contains("not diagnosed"), "{t}");
        assert!(rows[6].starts_with("diagnosis: none"), "{t}");
    }
}
