//! MFPT bearing data (Society for Machinery Failure Prevention Technology): a listed
//! `.mat` file → a [`Recording`] with its load and, for the field records, the fault
//! orders of the machine's bearing.
//!
//! Every MFPT file holds one struct `bearing` with the fields `gs` (the signal, a
//! column of doubles, in g), `sr` (sampling rate, Hz), `rate` (shaft rate, Hz) and
//! `load` (radial load, a char array such as `'25 lbs'`; an empty `[]` in one field record;
//! a number is accepted too); the three "real world" records add `ball`, `cage`,
//! `outer`, `inner` (fault orders). [`crate::mat`] flattens them to `bearing.gs`, …
//!
//! The rig has one accelerometer, so the recording has one channel, named `DE` like
//! CWRU's drive-end channel that the rest of the pipeline reads first. Rate and speed
//! come from the manifest (`fs_hz`, `speed_rpm`); the file's own `bearing.sr` must
//! agree with the manifest's rate to within 0.5 Hz or the file is refused.

use crate::datasets::{
    parse_mat, present, read_checked, single_channel, DatasetEntry, DatasetError, DatasetFault,
};
use crate::mat::MatFile;
use crate::recording::Recording;

/// Name of the signal variable.
pub const MFPT_SIGNAL: &str = "bearing.gs";
/// Name of the sampling-rate variable.
pub const MFPT_RATE: &str = "bearing.sr";

/// Largest difference between `bearing.sr` and the manifest's `fs_hz` that is
/// accepted (the manifest lists whole hertz).
pub const MFPT_FS_TOLERANCE_HZ: f64 = 0.5;

/// Fault orders (multiples of the shaft rate) a field record carries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultOrders {
    /// Ball spin (`bearing.ball`).
    pub ball: f64,
    /// Cage (`bearing.cage`).
    pub cage: f64,
    /// Outer race (`bearing.outer`).
    pub outer: f64,
    /// Inner race (`bearing.inner`).
    pub inner: f64,
}

/// One MFPT record and what the file and manifest say about it.
#[derive(Debug, Clone, PartialEq)]
pub struct MfptRecord {
    /// The signal as channel `DE`, at the manifest's rate and speed.
    pub recording: Recording,
    /// The manifest's `label` (`OR`, `IR`, `FIELD`).
    pub label: String,
    /// Fault class ([`DatasetFault::Unknown`] for the field records).
    pub fault: DatasetFault,
    /// The file's `bearing.sr` in Hz.
    pub file_fs_hz: f64,
    /// The file's `bearing.rate` (shaft rate) in Hz, if present.
    pub shaft_rate_hz: Option<f64>,
    /// The file's `bearing.load` as stored (`25 lbs`), `None` when absent or empty.
    pub load: Option<String>,
    /// The load in lbs, when `bearing.load` is a number or starts with one.
    pub load_lbs: Option<f64>,
    /// The field records' fault orders (all four present), else `None`.
    pub fault_orders: Option<FaultOrders>,
}

/// Load the MFPT record `entry` lists: SHA-256 checked, then [`mfpt_from_bytes`].
pub fn load_mfpt(entry: &DatasetEntry) -> Result<MfptRecord, DatasetError> {
    let bytes = read_checked(entry)?;
    mfpt_from_bytes(entry, &bytes)
}

/// Read an MFPT `.mat` file's bytes as the record `entry` lists (no checksum check).
pub fn mfpt_from_bytes(entry: &DatasetEntry, bytes: &[u8]) -> Result<MfptRecord, DatasetError> {
    let mat = parse_mat(entry, bytes)?;
    let file_fs_hz =
        scalar(entry, &mat, MFPT_RATE)?.ok_or_else(|| missing(entry, &mat, MFPT_RATE))?;
    // Written so that a NaN rate is refused too.
    let agrees = (file_fs_hz - f64::from(entry.fs_hz)).abs() <= MFPT_FS_TOLERANCE_HZ;
    if !agrees {
        return Err(DatasetError::SamplingRate {
            path: entry.path.clone(),
            file_hz: file_fs_hz,
            manifest_hz: entry.fs_hz,
        });
    }
    let signal = mat
        .variable(MFPT_SIGNAL)
        .ok_or_else(|| missing(entry, &mat, MFPT_SIGNAL))?;
    let recording = single_channel(entry, &mat, signal)?;

    // `load` is text ('25 lbs'), a number, or empty (`[]` or '').
    let numeric_load = match mat.variable("bearing.load") {
        Some(v) if v.data.is_empty() => None,
        _ => scalar(entry, &mat, "bearing.load")?,
    };
    let (load, load_lbs) = match (mat.text("bearing.load"), numeric_load) {
        (Some(text), _) => {
            let text = text.trim();
            let lbs = text
                .split_whitespace()
                .next()
                .and_then(|n| n.parse::<f64>().ok());
            ((!text.is_empty()).then(|| text.to_string()), lbs)
        }
        (None, Some(v)) => (Some(v.to_string()), Some(v)),
        (None, None) => (None, None),
    };
    let orders = [
        "bearing.ball",
        "bearing.cage",
        "bearing.outer",
        "bearing.inner",
    ]
    .map(|name| scalar(entry, &mat, name));
    let [ball, cage, outer, inner] = orders;
    let fault_orders = match (ball?, cage?, outer?, inner?) {
        (Some(ball), Some(cage), Some(outer), Some(inner)) => Some(FaultOrders {
            ball,
            cage,
            outer,
            inner,
        }),
        _ => None,
    };
    Ok(MfptRecord {
        recording,
        label: entry.label.clone(),
        fault: entry.fault,
        file_fs_hz,
        shaft_rate_hz: scalar(entry, &mat, "bearing.rate")?,
        load,
        load_lbs,
        fault_orders,
    })
}

/// The value of a numeric 1×1 variable, `None` when absent; an error when it holds
/// more or fewer than one value.
fn scalar(entry: &DatasetEntry, mat: &MatFile, name: &str) -> Result<Option<f64>, DatasetError> {
    let Some(v) = mat.variable(name) else {
        return Ok(None);
    };
    match v.data.as_slice() {
        [x] => Ok(Some(*x)),
        _ => Err(DatasetError::Variable {
            path: entry.path.clone(),
            problem: format!("`{name}` has dimensions {:?}, expected one value", v.dims),
            present: present(mat),
        }),
    }
}

fn missing(entry: &DatasetEntry, mat: &MatFile, name: &str) -> DatasetError {
    DatasetError::Variable {
        path: entry.path.clone(),
        problem: format!("no variable `{name}` (an MFPT file holds a struct `bearing`)"),
        present: present(mat),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datasets::{parse_dataset_manifest, read_dataset_manifest};
    use crate::entry::sha256_hex;
    use crate::mat::writer::*;
    use crate::mat::ByteOrder;
    use crate::test_support::{dataset_dir, scratch_dir};

    /// A `bearing` struct file: `gs`, `sr`, `rate`, `load` (char or number).
    fn bearing_file(gs: &[f64], sr: f64, load: Option<&str>) -> Vec<u8> {
        let o = ByteOrder::Little;
        let mut fields = vec!["gs", "sr", "rate"];
        let mut values = vec![
            double_field(o, &[gs.len() as i32, 1], gs),
            double_field(o, &[1, 1], &[sr]),
            double_field(o, &[1, 1], &[25.0]),
        ];
        match load {
            Some(text) => {
                let units: Vec<u16> = text.encode_utf16().collect();
                values.push(char_matrix(o, &[1, units.len() as i32], "", &units));
            }
            None => values.push(double_field(o, &[1, 1], &[150.0])),
        }
        fields.push("load");
        let mut file = header(o);
        file.extend(struct_matrix(o, &[1, 1], "bearing", 32, &fields, &values));
        file
    }

    fn entry_for(bytes: &[u8], samples: usize, fs: u32) -> DatasetEntry {
        let text = format!(
            "file\tlabel\tfault_type\tspeed_rpm\tfs_hz\tsamples\tsha256\n\
             rig/OR_1.mat\tOR\touter race\t1500.00\t{fs}\t{samples}\t{}\n",
            sha256_hex(bytes)
        );
        parse_dataset_manifest(&text, std::path::Path::new("/nowhere"))
            .expect("manifest")
            .remove(0)
    }

    /// A well-formed file loads as one `DE` channel at the manifest's rate, with the
    /// load parsed from its text (or taken as a number).
    #[test]
    fn loads_a_bearing_struct() {
        let gs: Vec<f64> = (0..64).map(|i| (f64::from(i) * 0.2).sin()).collect();
        let bytes = bearing_file(&gs, 48828.0, Some("25 lbs"));
        let r = mfpt_from_bytes(&entry_for(&bytes, 64, 48828), &bytes).expect("loads");
        assert_eq!(r.recording.name, "OR_1");
        assert_eq!(r.recording.channels.len(), 1);
        assert_eq!(r.recording.channels[0].name, "DE");
        assert_eq!(r.recording.len(), 64);
        assert_eq!(
            (r.recording.fs_hz, r.recording.rpm),
            (48828.0, Some(1500.0))
        );
        assert_eq!(r.load.as_deref(), Some("25 lbs"));
        assert_eq!(r.load_lbs, Some(25.0));
        assert_eq!(r.shaft_rate_hz, Some(25.0));
        assert_eq!(r.fault, DatasetFault::OuterRace);
        assert_eq!(r.fault_orders, None);

        let bytes = bearing_file(&gs, 48828.0, None);
        let r = mfpt_from_bytes(&entry_for(&bytes, 64, 48828), &bytes).expect("numeric load");
        assert_eq!(r.load_lbs, Some(150.0));
        let bytes = bearing_file(&gs, 48828.0, Some(""));
        let r = mfpt_from_bytes(&entry_for(&bytes, 64, 48828), &bytes).expect("empty load");
        assert_eq!((r.load, r.load_lbs), (None, None));
        // PlanetBearing.mat stores its missing load as an empty double `[]`.
        let o = ByteOrder::Little;
        let mut file = header(o);
        file.extend(struct_matrix(
            o,
            &[1, 1],
            "bearing",
            32,
            &["gs", "sr", "load"],
            &[
                double_field(o, &[64, 1], &gs),
                double_field(o, &[1, 1], &[6104.0]),
                double_field(o, &[0, 0], &[]),
            ],
        ));
        let r = mfpt_from_bytes(&entry_for(&file, 64, 6104), &file).expect("[] load");
        assert_eq!((r.load, r.load_lbs, r.shaft_rate_hz), (None, None, None));
    }

    /// A rate, length or content that disagrees with the manifest is refused.
    #[test]
    fn disagreements_are_refused() {
        let gs = vec![0.5; 16];
        let bytes = bearing_file(&gs, 97656.0, Some("0 lbs"));
        let err = mfpt_from_bytes(&entry_for(&bytes, 16, 48828), &bytes).expect_err("rate");
        assert!(
            matches!(err, DatasetError::SamplingRate { file_hz, .. } if file_hz == 97656.0),
            "{err}"
        );
        let bytes = bearing_file(&gs, 48828.0, Some("0 lbs"));
        let err = mfpt_from_bytes(&entry_for(&bytes, 17, 48828), &bytes).expect_err("length");
        assert!(
            matches!(
                err,
                DatasetError::SampleCount {
                    expected: 17,
                    got: 16,
                    ..
                }
            ),
            "{err}"
        );
        let bytes = bearing_file(&[1.0, f64::NAN], 48828.0, Some("0 lbs"));
        let err = mfpt_from_bytes(&entry_for(&bytes, 2, 48828), &bytes).expect_err("NaN");
        assert!(matches!(err, DatasetError::Invalid { .. }), "{err}");
        let plain = double_vectors(&[("gs", &[1.0])]);
        let err = mfpt_from_bytes(&entry_for(&plain, 1, 48828), &plain).expect_err("no struct");
        assert!(
            matches!(&err, DatasetError::Variable { problem, .. } if problem.contains("bearing.sr")),
            "{err}"
        );
        let err = mfpt_from_bytes(&entry_for(&plain, 1, 48828), &plain[..100]).expect_err("cut");
        assert!(matches!(err, DatasetError::Mat { .. }), "{err}");
    }

    /// The checksum is checked before anything is parsed.
    #[test]
    fn a_changed_file_is_refused() {
        let dir = scratch_dir("mfpt");
        let bytes = bearing_file(&[0.1; 8], 48828.0, Some("25 lbs"));
        let mut entry = entry_for(&bytes, 8, 48828);
        entry.path = dir.join("OR_1.mat");
        std::fs::write(&entry.path, &bytes).expect("write");
        assert!(load_mfpt(&entry).is_ok());
        std::fs::write(
            &entry.path,
            bearing_file(&[0.2; 8], 48828.0, Some("25 lbs")),
        )
        .expect("write");
        assert!(matches!(
            load_mfpt(&entry),
            Err(DatasetError::Checksum { .. })
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Every file of `../shared/data/mfpt` loads with the manifest's length, rate and
    /// speed, finite samples, and `bearing.sr` equal to the manifest's rate.
    #[test]
    fn every_mfpt_file_loads() {
        let Some(dir) = dataset_dir("mfpt") else {
            return;
        };
        let entries = read_dataset_manifest(&dir).expect("MFPT manifest");
        assert_eq!(entries.len(), 17, "17 records listed");
        for e in &entries {
            let r = load_mfpt(e).unwrap_or_else(|err| panic!("{}: {err}", e.file));
            assert_eq!(r.recording.len(), e.samples, "{}", e.file);
            assert_eq!(r.recording.fs_hz, e.fs_hz, "{}", e.file);
            assert_eq!(r.recording.rpm, Some(e.rpm), "{}", e.file);
            assert_eq!(r.file_fs_hz.round(), f64::from(e.fs_hz), "{}", e.file);
            assert!(r.recording.channels[0]
                .samples
                .iter()
                .all(|x| x.is_finite()));
            let rate = r.shaft_rate_hz.expect("bearing.rate");
            assert!(
                (rate * 60.0 - f64::from(e.rpm)).abs() < 0.01,
                "{}: rate {rate}",
                e.file
            );
            match e.label.as_str() {
                "FIELD" => {
                    assert_eq!(e.fault, DatasetFault::Unknown);
                    assert!(r.fault_orders.is_some(), "{}: fault orders", e.file);
                }
                _ => {
                    assert_eq!(
                        r.load_lbs.map(|l| format!("{l} lbs")),
                        Some(e.load_or_rig.clone())
                    );
                    assert!(r.fault_orders.is_none());
                }
            }
        }
        println!("MFPT: {} files loaded", entries.len());
    }
}
