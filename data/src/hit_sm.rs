//! HIT-SM bearing data, self-built rig (Harbin Institute of Technology): a listed
//! `.mat` file → a [`Recording`] with the fault's size.
//!
//! Each file holds **one** numeric variable (a 262 144 × 1 double) whose name differs
//! from file to file (`inside2d_600_1`, `VarName6`, `V0`, …); the loader takes the only
//! numeric variable whose name does not start with `__` and refuses a file with none or
//! several. The files store neither the sampling rate (51 200 Hz) nor the speed
//! (600 / 900 / 1200 rpm, nominal, from the file name): both come from the manifest.
//! The gain differs from file to file, so absolute levels mean nothing here.
//!
//! The rig has one accelerometer, so the recording has one channel, named `DE` like
//! CWRU's drive-end channel that the rest of the pipeline reads first. The fault size
//! is the arc of raceway the fault covers, in degrees (2 slight, 5 moderate, 8 severe),
//! from the label (`IR2`, `OR8`; `N` for normal).

use crate::datasets::{
    parse_mat, present, read_checked, single_channel, DatasetEntry, DatasetError, DatasetFault,
};
use crate::recording::Recording;

/// The fault sizes of the data set, in degrees of raceway arc.
pub const HIT_SM_FAULT_SIZES_DEG: [u32; 3] = [2, 5, 8];

/// One HIT-SM record and what the manifest says about it.
#[derive(Debug, Clone, PartialEq)]
pub struct HitSmRecord {
    /// The signal as channel `DE`, at the manifest's rate and speed.
    pub recording: Recording,
    /// The manifest's `label` (`N`, `IR2`, …, `OR8`).
    pub label: String,
    /// Fault class.
    pub fault: DatasetFault,
    /// Fault size in degrees of raceway arc (2, 5, 8); `None` for normal records.
    pub fault_size_deg: Option<u32>,
    /// Name of the variable the signal was read from.
    pub variable: String,
}

/// The fault size a label names: the number after `IR` / `OR` (`IR5` → 5), `None` for
/// other labels (`N`).
pub fn fault_size_deg(label: &str) -> Option<u32> {
    let digits = label
        .strip_prefix("IR")
        .or_else(|| label.strip_prefix("OR"))?;
    digits.parse().ok()
}

/// Load the HIT-SM record `entry` lists: SHA-256 checked, then [`hit_sm_from_bytes`].
pub fn load_hit_sm(entry: &DatasetEntry) -> Result<HitSmRecord, DatasetError> {
    let bytes = read_checked(entry)?;
    hit_sm_from_bytes(entry, &bytes)
}

/// Read a HIT-SM `.mat` file's bytes as the record `entry` lists (no checksum check).
pub fn hit_sm_from_bytes(entry: &DatasetEntry, bytes: &[u8]) -> Result<HitSmRecord, DatasetError> {
    let mat = parse_mat(entry, bytes)?;
    let candidates: Vec<_> = mat
        .variables
        .iter()
        .filter(|v| !v.name.starts_with("__"))
        .collect();
    let [signal] = candidates.as_slice() else {
        return Err(DatasetError::Variable {
            path: entry.path.clone(),
            problem: format!(
                "{} numeric variables, expected exactly one (the signal)",
                candidates.len()
            ),
            present: present(&mat),
        });
    };
    let recording = single_channel(entry, &mat, signal)?;
    let fault_size_deg = match entry.fault {
        DatasetFault::InnerRace | DatasetFault::OuterRace => fault_size_deg(&entry.label),
        DatasetFault::Normal | DatasetFault::Unknown => None,
    };
    Ok(HitSmRecord {
        recording,
        label: entry.label.clone(),
        fault: entry.fault,
        fault_size_deg,
        variable: signal.name.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datasets::{parse_dataset_manifest, read_dataset_manifest};
    use crate::entry::sha256_hex;
    use crate::mat::writer::double_vectors;
    use crate::test_support::dataset_dir;

    fn entry_for(label: &str, fault: &str, bytes: &[u8], samples: usize) -> DatasetEntry {
        let text = format!(
            "file\tlabel\tfault_type\tspeed_rpm\tfs_hz\tsamples\tsha256\n\
             self-built/{label}_900.mat\t{label}\t{fault}\t900.00\t51200\t{samples}\t{}\n",
            sha256_hex(bytes)
        );
        parse_dataset_manifest(&text, std::path::Path::new("/nowhere"))
            .expect("manifest")
            .remove(0)
    }

    /// The one variable is the signal whatever its name; size from the label.
    #[test]
    fn reads_the_only_variable() {
        let signal: Vec<f64> = (0..32).map(|i| f64::from(i) * 1e-4).collect();
        let bytes = double_vectors(&[("VarName6", &signal)]);
        let r = hit_sm_from_bytes(
            &entry_for("OR5", "outer race, 5 deg arc", &bytes, 32),
            &bytes,
        )
        .expect("loads");
        assert_eq!(r.variable, "VarName6");
        assert_eq!(r.fault, DatasetFault::OuterRace);
        assert_eq!(r.fault_size_deg, Some(5));
        assert_eq!(r.recording.name, "OR5_900");
        assert_eq!(r.recording.channels[0].name, "DE");
        assert_eq!((r.recording.fs_hz, r.recording.rpm), (51200.0, Some(900.0)));
        assert_eq!(r.recording.len(), 32);
        let r = hit_sm_from_bytes(&entry_for("N", "none", &bytes, 32), &bytes).expect("normal");
        assert_eq!((r.fault, r.fault_size_deg), (DatasetFault::Normal, None));
        assert_eq!(fault_size_deg("IR8"), Some(8));
        assert_eq!(fault_size_deg("FIELD"), None);
    }

    /// No variable, two variables, a matrix, or a wrong length are refused.
    #[test]
    fn ambiguous_or_wrong_files_are_refused() {
        let two = double_vectors(&[("a", &[1.0]), ("b", &[2.0])]);
        let err = hit_sm_from_bytes(&entry_for("N", "none", &two, 1), &two).expect_err("two");
        assert!(
            matches!(&err, DatasetError::Variable { present, .. } if present == "a, b"),
            "{err}"
        );
        let one = double_vectors(&[("a", &[1.0, 2.0, 3.0])]);
        let err = hit_sm_from_bytes(&entry_for("N", "none", &one, 4), &one).expect_err("length");
        assert!(
            matches!(
                err,
                DatasetError::SampleCount {
                    expected: 4,
                    got: 3,
                    ..
                }
            ),
            "{err}"
        );
        let none = double_vectors(&[]);
        assert!(hit_sm_from_bytes(&entry_for("N", "none", &none, 1), &none).is_err());
    }

    /// Every file of `../shared/data/hit_sm` loads with the manifest's length, rate and
    /// speed (also the one in its file name), finite samples and a fault size for
    /// every fault record.
    #[test]
    fn every_hit_sm_file_loads() {
        let Some(dir) = dataset_dir("hit_sm") else {
            return;
        };
        let entries = read_dataset_manifest(&dir).expect("HIT-SM manifest");
        assert_eq!(entries.len(), 21, "21 records listed");
        for e in &entries {
            let r = load_hit_sm(e).unwrap_or_else(|err| panic!("{}: {err}", e.file));
            assert_eq!(r.recording.len(), e.samples, "{}", e.file);
            assert_eq!(r.recording.fs_hz, 51200.0, "{}", e.file);
            assert_eq!(r.recording.rpm, Some(e.rpm), "{}", e.file);
            let rpm_in_name = r
                .recording
                .name
                .rsplit('_')
                .next()
                .and_then(|s| s.parse().ok());
            assert_eq!(rpm_in_name, Some(e.rpm), "{}", e.file);
            assert!(r.recording.channels[0]
                .samples
                .iter()
                .all(|x| x.is_finite()));
            match e.fault {
                DatasetFault::Normal => assert_eq!(r.fault_size_deg, None),
                _ => assert!(
                    r.fault_size_deg
                        .is_some_and(|s| HIT_SM_FAULT_SIZES_DEG.contains(&s)),
                    "{}",
                    e.file
                ),
            }
        }
        println!("HIT-SM: {} files loaded", entries.len());
    }
}
