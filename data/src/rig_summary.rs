//! What `pumptwin data summary` prints for a data set whose manifest has the layout of
//! [`crate::datasets`] (MFPT, HIT-SM): one row per listed record with what was read
//! from it — fault, speed, rate, samples, load or fault size, and the level and
//! kurtosis of the signal (its DC removed) — and every record that could not be read,
//! with the reason. Nothing is dropped silently.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::datasets::{read_dataset_manifest, DatasetEntry, DatasetError};
use crate::hit_sm::load_hit_sm;
use crate::mfpt::load_mfpt;
use crate::recording::Recording;
use pumptwin_core::dsp::TimeStats;

/// Whether `dir`'s `MANIFEST.tsv` has the layout of the other rigs (a `speed_rpm`
/// column, no `cwru_file_no`); CWRU's, and a missing or unreadable manifest, do not
/// (the CWRU summary then says what is wrong).
pub fn is_rig_manifest(dir: &Path) -> bool {
    let Ok(text) = std::fs::read_to_string(dir.join(crate::datasets::DATASET_MANIFEST)) else {
        return false;
    };
    let header: Vec<&str> = text.lines().next().unwrap_or("").split('\t').collect();
    header.contains(&"speed_rpm") && !header.contains(&"cwru_file_no")
}

/// One record as read.
#[derive(Debug, Clone, PartialEq)]
pub struct RigRow {
    /// The manifest's `file`.
    pub file: String,
    /// The manifest's `label`.
    pub label: String,
    /// Fault class (`normal`, `inner_race`, `outer_race`, `unknown`).
    pub fault: &'static str,
    /// Shaft speed, rpm.
    pub rpm: f32,
    /// Sampling rate, Hz.
    pub fs_hz: f32,
    /// Samples read.
    pub samples: usize,
    /// MFPT: the load; HIT-SM: the fault size in degrees of raceway arc.
    pub condition: String,
    /// RMS of the signal with its mean removed, in the file's unit.
    pub rms: f64,
    /// Kurtosis of the signal (3 for Gaussian noise).
    pub kurtosis: f64,
}

/// Every record of a data set, read or refused.
#[derive(Debug, Clone, PartialEq)]
pub struct RigSummary {
    /// The data set's folder.
    pub dir: PathBuf,
    /// The records that were read, in manifest order.
    pub rows: Vec<RigRow>,
    /// `(file, reason)` of each record that could not be read.
    pub refused: Vec<(String, String)>,
}

/// Read every record the manifest in `dir` lists. A record that does not read is
/// listed in [`RigSummary::refused`]; only an unreadable manifest is an error.
pub fn summarize_rig(dir: &Path) -> Result<RigSummary, DatasetError> {
    let entries = read_dataset_manifest(dir)?;
    let mut summary = RigSummary {
        dir: dir.to_path_buf(),
        rows: Vec::new(),
        refused: Vec::new(),
    };
    for entry in &entries {
        match read_row(entry) {
            Ok(row) => summary.rows.push(row),
            Err(e) => summary.refused.push((entry.file.clone(), error_chain(&e))),
        }
    }
    Ok(summary)
}

/// One record: an MFPT file when it holds the `bearing` struct, else a HIT-SM file
/// (its one numeric variable).
fn read_row(entry: &DatasetEntry) -> Result<RigRow, DatasetError> {
    let (recording, condition) = match load_mfpt(entry) {
        // The manifest's load (`25 lbs`, `n/a`) says its unit; the file's may not.
        Ok(r) => (
            r.recording,
            r.load
                .map_or_else(|| "-".to_string(), |_| entry.load_or_rig.clone()),
        ),
        Err(DatasetError::Variable { .. }) => {
            let r = load_hit_sm(entry)?;
            let size = r
                .fault_size_deg
                .map_or_else(|| "-".to_string(), |d| format!("{d} deg"));
            (r.recording, size)
        }
        Err(e) => return Err(e),
    };
    let (rms, kurtosis) = level_and_kurtosis(&recording);
    Ok(RigRow {
        file: entry.file.clone(),
        label: entry.label.clone(),
        fault: entry.fault.as_str(),
        rpm: entry.rpm,
        fs_hz: recording.fs_hz,
        samples: recording.len(),
        condition,
        rms,
        kurtosis,
    })
}

/// RMS about the mean (HIT-SM files carry a DC offset as large as some signals) and
/// kurtosis of the first channel, from the core's [`TimeStats`]; 0 and 0 when the
/// channel is empty or constant.
fn level_and_kurtosis(rec: &Recording) -> (f64, f64) {
    rec.channels
        .first()
        .and_then(|c| TimeStats::compute(&c.samples).ok())
        .map_or((0.0, 0.0), |t| {
            let (rms, mean) = (f64::from(t.rms), f64::from(t.mean));
            (
                (rms * rms - mean * mean).max(0.0).sqrt(),
                f64::from(t.kurtosis),
            )
        })
}

/// An error and its sources on one line.
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        s.push_str(": ");
        s.push_str(&cause.to_string());
        source = cause.source();
    }
    s
}

impl fmt::Display for RigSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: {} record(s) read, {} refused",
            self.dir.display(),
            self.rows.len(),
            self.refused.len()
        )?;
        writeln!(
            f,
            "{:<56} {:<6} {:<11} {:>7} {:>7} {:>8} {:<10} {:>10} {:>8}",
            "file", "label", "fault", "rpm", "fs_hz", "samples", "condition", "rms", "kurtosis"
        )?;
        for r in &self.rows {
            writeln!(
                f,
                "{:<56} {:<6} {:<11} {:>7.1} {:>7.0} {:>8} {:<10} {:>10.3e} {:>8.2}",
                r.file, r.label, r.fault, r.rpm, r.fs_hz, r.samples, r.condition, r.rms, r.kurtosis
            )?;
        }
        for (file, why) in &self.refused {
            writeln!(f, "refused {file}: {why}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::dataset_dir;

    /// Every record of both rigs reads, with its manifest's rate and a kurtosis above
    /// Gaussian for the impulsive fault records of HIT-SM.
    #[test]
    fn both_rigs_summarize_without_refusals() {
        for name in ["mfpt", "hit_sm"] {
            let Some(dir) = dataset_dir(name) else {
                continue;
            };
            let s = summarize_rig(&dir).expect("manifest");
            assert!(s.refused.is_empty(), "{name}: {:?}", s.refused);
            assert!(!s.rows.is_empty());
            for r in &s.rows {
                assert!(r.rms > 0.0 && r.kurtosis > 0.0, "{r:?}");
            }
            let text = s.to_string();
            assert!(text.contains("refused"), "{text}");
            assert_eq!(text.lines().count(), s.rows.len() + 2);
        }
    }

    #[test]
    fn the_manifest_header_tells_the_layouts_apart() {
        let dir = crate::test_support::scratch_dir("rig-manifest");
        assert!(!is_rig_manifest(&dir), "no manifest");
        let write = |header: &str| {
            std::fs::write(dir.join("MANIFEST.tsv"), format!("{header}\n")).expect("write")
        };
        write("file\tlabel\tfault_type\tspeed_rpm\tfs_hz");
        assert!(is_rig_manifest(&dir));
        write("file\tcwru_file_no\tcwru_label\tfault_type\tspeed_rpm");
        assert!(!is_rig_manifest(&dir));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn level_and_kurtosis_of_a_square_wave() {
        let rec = Recording {
            name: "sq".into(),
            fs_hz: 1000.0,
            rpm: None,
            channels: vec![crate::recording::Channel {
                name: "DE".into(),
                samples: (0..1000)
                    .map(|i| if i % 2 == 0 { 3.0 } else { 1.0 })
                    .collect(),
            }],
        };
        let (rms, k) = level_and_kurtosis(&rec);
        assert!(
            (rms - 1.0).abs() < 1e-5 && (k - 1.0).abs() < 1e-5,
            "{rms} {k}"
        );
    }
}
