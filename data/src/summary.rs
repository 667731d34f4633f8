//! `pumptwin data summary`: what a data directory holds and what each protocol would
//! train and test on, before any training is run.
//!
//! Every file the manifest lists is loaded (so a missing or corrupt file shows up
//! here, not an hour into training), its length is taken from the file itself, and
//! its length at the model rate is what the windows are counted on.

use std::collections::BTreeSet;
use std::fmt;
use std::path::{Path, PathBuf};

use super::manifest::{read_manifest, ManifestEntry, ManifestError, CLASSES_10};
use super::preprocess::{decimation_factor, model_rate_len, FilterPlan, PreprocessConfig};
use super::windows::{
    build_split, Protocol, RecordMeta, Split, SplitError, WindowConfig, WindowRef,
};
use crate::entry::{load_entry, EntryError};

/// Errors building a summary.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum SummaryError {
    /// The manifest could not be read.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// A listed record cannot be used.
    #[error(transparent)]
    Entry(#[from] EntryError),
    /// A split could not be built or failed its check.
    #[error(transparent)]
    Split(#[from] SplitError),
}

/// One record as the summary sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordSummary {
    /// Its manifest entry.
    pub entry: ManifestEntry,
    /// Channel names found in the file.
    pub channels: Vec<String>,
    /// Samples per channel at the source rate.
    pub samples: usize,
    /// Samples per channel at the model rate.
    pub model_samples: usize,
    /// Windows at the model rate.
    pub windows: usize,
}

/// Records, windows and splits of one data directory.
#[derive(Debug, Clone, PartialEq)]
pub struct DataSummary {
    /// The data directory.
    pub data_dir: PathBuf,
    /// Preprocessing the counts assume.
    pub preprocess: PreprocessConfig,
    /// Windowing the counts assume.
    pub windows: WindowConfig,
    /// Records in manifest order.
    pub records: Vec<RecordSummary>,
    /// The splits asked for, each verified leak-free.
    pub splits: Vec<Split>,
    /// Discrepancies worth a look (e.g. manifest and file disagree on a length).
    pub notes: Vec<String>,
}

/// Load the records listed in `data_dir/MANIFEST.tsv` and build `protocols`' splits.
pub fn summarize(
    data_dir: &Path,
    protocols: &[Protocol],
    preprocess: &PreprocessConfig,
    windows: &WindowConfig,
) -> Result<DataSummary, SummaryError> {
    windows.validate()?;
    let entries = read_manifest(data_dir)?;
    let mut records = Vec::with_capacity(entries.len());
    let mut notes = Vec::new();
    for entry in entries {
        let recording = load_entry(&entry)?;
        let to_preprocess_error = |source| EntryError::preprocess(&entry, source);
        // Designing the filter checks the rate and the configuration.
        FilterPlan::new(entry.fs_hz, preprocess).map_err(to_preprocess_error)?;
        let samples = recording.len();
        let model_samples =
            model_rate_len(samples, entry.fs_hz, preprocess).map_err(to_preprocess_error)?;
        if let Some(listed) = entry.samples_per_channel.filter(|&n| n != samples) {
            notes.push(format!(
                "{}: manifest lists {listed} samples per channel, the file has {samples}",
                entry.label
            ));
        }
        records.push(RecordSummary {
            channels: recording.channels.iter().map(|c| c.name.clone()).collect(),
            samples,
            model_samples,
            windows: windows.count(model_samples),
            entry,
        });
    }
    let metas: Vec<RecordMeta> = records
        .iter()
        .map(|r| RecordMeta::from_entry(&r.entry, r.model_samples))
        .collect();
    let lens: Vec<usize> = records.iter().map(|r| r.model_samples).collect();
    let mut splits = Vec::with_capacity(protocols.len());
    for &protocol in protocols {
        let split = build_split(protocol, &metas, windows)?;
        split.verify_disjoint()?;
        split.verify_bounds(&lens)?;
        splits.push(split);
    }
    let unlabeled: Vec<&str> = records
        .iter()
        .filter(|r| r.entry.class_10().is_none())
        .map(|r| r.entry.label.as_str())
        .collect();
    if !unlabeled.is_empty() {
        notes.push(format!(
            "outside the 10 classes (not used): {}",
            unlabeled.join(", ")
        ));
    }
    Ok(DataSummary {
        data_dir: data_dir.to_path_buf(),
        preprocess: *preprocess,
        windows: *windows,
        records,
        splits,
        notes,
    })
}

fn join<T: fmt::Display>(items: impl IntoIterator<Item = T>, sep: &str) -> String {
    items
        .into_iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(sep)
}

impl fmt::Display for DataSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let target = self.preprocess.target_fs_hz;
        writeln!(
            f,
            "data: {} ({} records in MANIFEST.tsv)",
            self.data_dir.display(),
            self.records.len()
        )?;
        let band = match self.preprocess.band_limit_hz {
            Some(b) => format!("band limit {b} Hz"),
            None => "no band limit".to_string(),
        };
        writeln!(
            f,
            "model rate {target} Hz, {band}; windows of {} samples, hop {}",
            self.windows.len, self.windows.hop
        )?;
        writeln!(f)?;
        writeln!(
            f,
            "{:<8} {:>7}  {:<10} {:<18} {:>10} {:>13} {:>8}",
            "class", "records", "channels", "source rate", "loads (HP)", "samples@model", "windows"
        )?;
        let mut total = (0usize, 0usize, 0usize);
        let mut classes: Vec<Option<&str>> = CLASSES_10.iter().map(|c| Some(*c)).collect();
        if self.records.iter().any(|r| r.entry.class_10().is_none()) {
            classes.push(None);
        }
        for class in classes {
            let rs: Vec<&RecordSummary> = self
                .records
                .iter()
                .filter(|r| r.entry.class_10() == class)
                .collect();
            if rs.is_empty() {
                writeln!(f, "{:<8} {:>7}", class.unwrap_or("other"), 0)?;
                continue;
            }
            let channels: BTreeSet<String> = rs.iter().map(|r| r.channels.join(",")).collect();
            let rates: BTreeSet<String> = rs
                .iter()
                .map(|r| match decimation_factor(r.entry.fs_hz, target) {
                    Ok(m) if m > 1 => format!("{} Hz (/{m})", r.entry.fs_hz),
                    _ => format!("{} Hz", r.entry.fs_hz),
                })
                .collect();
            let loads: BTreeSet<u8> = rs.iter().map(|r| r.entry.load_hp).collect();
            let samples: usize = rs.iter().map(|r| r.model_samples).sum();
            let windows: usize = rs.iter().map(|r| r.windows).sum();
            total = (total.0 + rs.len(), total.1 + samples, total.2 + windows);
            writeln!(
                f,
                "{:<8} {:>7}  {:<10} {:<18} {:>10} {:>13} {:>8}",
                class.unwrap_or("other"),
                rs.len(),
                join(&channels, " "),
                join(&rates, ", "),
                join(&loads, ","),
                samples,
                windows
            )?;
        }
        writeln!(
            f,
            "{:<8} {:>7}  {:<10} {:<18} {:>10} {:>13} {:>8}",
            "total", total.0, "", "", "", total.1, total.2
        )?;

        for split in &self.splits {
            writeln!(f)?;
            writeln!(
                f,
                "protocol {}: {}",
                split.protocol,
                split.protocol.description()
            )?;
            writeln!(
                f,
                "{:<8} {:>13} {:>13} {:>12} {:>12}",
                "class", "train records", "train windows", "test records", "test windows"
            )?;
            let count = |side: &[(WindowRef, usize)], label: Option<usize>| {
                let ws: Vec<&WindowRef> = side
                    .iter()
                    .filter(|(_, l)| label.is_none_or(|x| x == *l))
                    .map(|(w, _)| w)
                    .collect();
                let recs: BTreeSet<usize> = ws.iter().map(|w| w.record).collect();
                (recs.len(), ws.len())
            };
            for (label, class) in split.classes.iter().enumerate() {
                let (tr, tw) = count(&split.train, Some(label));
                let (er, ew) = count(&split.test, Some(label));
                writeln!(f, "{class:<8} {tr:>13} {tw:>13} {er:>12} {ew:>12}")?;
            }
            let (tr, tw) = count(&split.train, None);
            let (er, ew) = count(&split.test, None);
            writeln!(f, "{:<8} {tr:>13} {tw:>13} {er:>12} {ew:>12}", "total")?;
            writeln!(
                f,
                "verified: no sample range of any record is on both sides"
            )?;
        }
        if self.records.iter().any(|r| r.entry.fs_hz != target) {
            writeln!(f)?;
            writeln!(
                f,
                "note: records not at {target} Hz are low-passed and decimated; every record gets \
                 the same low-pass at {} Hz (see data::preprocess)",
                FilterPlan::new(target, &self.preprocess)
                    .ok()
                    .and_then(|p| p.cutoff_hz)
                    .map_or_else(|| "-".to_string(), |c| c.to_string())
            )?;
        }
        let normal_loads: BTreeSet<u8> = self
            .records
            .iter()
            .filter(|r| r.entry.class_10() == Some("normal"))
            .map(|r| r.entry.load_hp)
            .collect();
        let record_level = self
            .splits
            .iter()
            .any(|s| matches!(s.protocol, Protocol::CrossLoad | Protocol::FaultSize));
        if record_level && !normal_loads.is_empty() {
            writeln!(
                f,
                "note: normal records (loads {} HP) are excluded from cross-load and fault-size",
                join(&normal_loads, ",")
            )?;
        }
        for note in &self.notes {
            writeln!(f, "note: {note}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::MANIFEST_FILE;
    use crate::mat::writer::double_vectors;
    use crate::test_support::scratch_dir;

    fn write_record(dir: &Path, number: u32, n: usize, channels: &[&str]) {
        let data: Vec<f64> = (0..n).map(|i| (i as f64 * 0.1).sin()).collect();
        let names: Vec<String> = channels
            .iter()
            .map(|c| format!("X{number:03}_{c}_time"))
            .collect();
        let rpm = format!("X{number:03}RPM");
        let mut vars: Vec<(&str, &[f64])> = names
            .iter()
            .map(|n| (n.as_str(), data.as_slice()))
            .collect();
        vars.push((rpm.as_str(), &[1797.0]));
        std::fs::write(dir.join(format!("{number}.mat")), double_vectors(&vars)).expect("write");
    }

    #[test]
    fn summarizes_a_small_data_set() {
        let dir = scratch_dir("summary");
        let mut manifest =
            String::from("file\tcwru_file_no\tcwru_label\tfault_type\tfault_size_in\tload_hp\trpm_recorded\tfs_hz\tsamples_per_channel\n");
        // A 48 kHz normal record and IR/B/OR records at two sizes and two loads.
        write_record(&dir, 97, 4 * 8192, &["DE", "FE"]);
        manifest.push_str("97.mat\t97\tNormal_0\tnormal\t0\t0\t1797\t48000\t32768\n");
        let mut number = 100;
        for ft in ["IR", "B", "OR"] {
            for size in ["0.007", "0.014", "0.021"] {
                for load in [0, 3] {
                    number += 1;
                    write_record(&dir, number, 8192, &["DE", "FE", "BA"]);
                    manifest.push_str(&format!("{number}.mat\t{number}\t{ft}_{load}\t{ft}\t{size}\t{load}\t1797\t12000\t8192\n"));
                }
            }
        }
        std::fs::write(dir.join(MANIFEST_FILE), manifest).expect("write manifest");
        let summary = summarize(
            &dir,
            &Protocol::ALL,
            &PreprocessConfig::default(),
            &WindowConfig::default(),
        )
        .expect("summary");
        assert_eq!(summary.records.len(), 19);
        let normal = &summary.records[0];
        assert_eq!(
            (normal.samples, normal.model_samples, normal.windows),
            (32_768, 8192, 7)
        );
        assert_eq!(normal.channels, ["DE", "FE"]);
        assert!(summary.notes.is_empty(), "{:?}", summary.notes);
        let cross_load = &summary.splits[1];
        assert_eq!(cross_load.train.len(), 9 * 7);
        assert_eq!(cross_load.test.len(), 9 * 7);
        let text = summary.to_string();
        for needle in [
            "protocol time-block",
            "protocol cross-load",
            "protocol fault-size",
            "48000 Hz (/4)",
            "IR014",
        ] {
            assert!(text.contains(needle), "missing {needle:?} in\n{text}");
        }
        // A listed file that is missing is an error naming it.
        std::fs::remove_file(dir.join("101.mat")).expect("remove");
        let err = summarize(
            &dir,
            &[],
            &PreprocessConfig::default(),
            &WindowConfig::default(),
        )
        .expect_err("missing");
        assert!(err.to_string().contains("101.mat"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
