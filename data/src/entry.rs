//! A data set's manifest entry → its recording: the checksum the manifest lists, the
//! CWRU variables picked by the entry's file number, and what can go wrong on the way
//! (shared by every command that walks a manifest).

use std::path::PathBuf;

use crate::manifest::ManifestEntry;
use crate::preprocess::PreprocessError;
use crate::record::{cwru_mat_from_bytes, DataError};
use crate::recording::Recording;

/// A record listed in a manifest that cannot be used: it does not load, or it cannot be
/// brought to the model rate. Shared by every command that walks a manifest.
#[derive(Debug, thiserror::Error)]
pub enum EntryError {
    /// The file could not be loaded.
    #[error("cannot load {label} ({})", path.display())]
    Record {
        /// CWRU label.
        label: String,
        /// File path.
        path: PathBuf,
        /// What went wrong (boxed: it is large and this path is cold).
        #[source]
        source: Box<DataError>,
    },
    /// The file is not the one the manifest lists (its SHA-256 differs).
    #[error(
        "{label} ({}): SHA-256 {got} is not the manifest's {expected}: a different or damaged file",
        path.display()
    )]
    Checksum {
        /// CWRU label.
        label: String,
        /// File path.
        path: PathBuf,
        /// SHA-256 the manifest lists.
        expected: String,
        /// SHA-256 of the file.
        got: String,
    },
    /// The record cannot be brought to the model rate.
    #[error("record {label} cannot be brought to the model rate")]
    Preprocess {
        /// CWRU label.
        label: String,
        /// What went wrong.
        #[source]
        source: PreprocessError,
    },
}

impl EntryError {
    /// A preprocessing failure of `entry`.
    pub fn preprocess(entry: &ManifestEntry, source: PreprocessError) -> Self {
        Self::Preprocess {
            label: entry.label.clone(),
            source,
        }
    }
}

/// Lower-case hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    use std::fmt::Write as _;
    Sha256::digest(bytes)
        .iter()
        .fold(String::new(), |mut s, b| {
            let _ = write!(s, "{b:02x}");
            s
        })
}

/// Load the CWRU record a manifest entry lists: variables picked by its file number,
/// rate and recorded speed from the manifest.
pub fn load_entry(entry: &ManifestEntry) -> Result<Recording, EntryError> {
    let failed = |source: DataError| EntryError::Record {
        label: entry.label.clone(),
        path: entry.path.clone(),
        source: Box::new(source),
    };
    let bytes = std::fs::read(&entry.path).map_err(|source| {
        failed(DataError::Io {
            path: entry.path.clone(),
            source,
        })
    })?;
    if let Some(expected) = &entry.sha256 {
        let got = sha256_hex(&bytes);
        if &got != expected {
            return Err(EntryError::Checksum {
                label: entry.label.clone(),
                path: entry.path.clone(),
                expected: expected.clone(),
                got,
            });
        }
    }
    cwru_mat_from_bytes(
        &entry.path,
        &bytes,
        Some(entry.file_number),
        entry.fs_hz,
        entry.rpm_recorded,
    )
    .map_err(failed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::parse_manifest;
    use crate::mat::writer::double_vectors;
    use crate::test_support::scratch_dir;

    /// A manifest that lists a file's SHA-256 refuses the file once it changes (a
    /// swapped or damaged `.mat` is not read as the record its name says), and loads it
    /// while it matches; without the column nothing is checked.
    #[test]
    fn a_file_that_is_not_the_listed_one_is_refused() {
        let dir = scratch_dir("sha");
        let signal: Vec<f64> = (0..4096).map(|i| (f64::from(i) * 0.3).sin()).collect();
        let bytes = double_vectors(&[
            ("X105_DE_time", &signal),
            ("X105_FE_time", &signal),
            ("X105RPM", &[1797.0]),
        ]);
        std::fs::write(dir.join("105.mat"), &bytes).expect("write");
        let header = "file\tcwru_file_no\tcwru_label\tfault_type\tfault_size_in\tload_hp\trpm_recorded\tfs_hz\tsha256";
        let entry = |sha: &str| {
            let text =
                format!("{header}\n105.mat\t105\tIR007_0\tIR\t0.007\t0\t1797\t12000\t{sha}\n");
            parse_manifest(&text, &dir).expect("manifest").remove(0)
        };
        let listed = entry(&sha256_hex(&bytes));
        assert_eq!(load_entry(&listed).expect("the listed file").len(), 4096);
        assert!(load_entry(&entry("")).is_ok(), "no checksum listed");
        let mut damaged = bytes.clone();
        let last = damaged.len() - 1;
        damaged[last] ^= 1;
        std::fs::write(dir.join("105.mat"), &damaged).expect("write");
        match load_entry(&listed) {
            Err(EntryError::Checksum { expected, got, .. }) => {
                assert_eq!(expected, sha256_hex(&bytes));
                assert_eq!(got, sha256_hex(&damaged));
            }
            other => panic!(
                "a damaged file was not refused: {:?}",
                other.map(|r| r.len())
            ),
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
