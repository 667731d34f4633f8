//! The manifests of the data sets other than CWRU (MFPT in [`crate::mfpt`], HIT-SM in
//! [`crate::hit_sm`]): one layout shared by both, the fault classes they use, the
//! checked read of a listed file, and the errors of loading one.
//!
//! Their `MANIFEST.tsv` is tab-separated with a header line naming the columns; the
//! ones read here are `file` (path relative to the manifest's folder), `label`,
//! `fault_type`, `speed_rpm`, `fs_hz`, `samples`, `sha256` and, when present,
//! `load_or_rig`. Further columns (the sanity checks) are ignored, and the order of
//! the columns does not matter.
//!
//! A leaf module: it uses [`crate::entry::sha256_hex`], [`crate::mat`] and
//! [`crate::recording`] and nothing that uses it.

use std::fmt;
use std::path::{Component, Path, PathBuf};

use crate::entry::sha256_hex;
use crate::mat::{MatError, MatVariable};
use crate::recording::{Channel, Recording, RecordingError};

/// File name of a data set's manifest.
pub const DATASET_MANIFEST: &str = "MANIFEST.tsv";

/// The fault classes of these data sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DatasetFault {
    /// No fault (`none`).
    Normal,
    /// Inner-race fault (`inner race…`).
    InnerRace,
    /// Outer-race fault (`outer race…`).
    OuterRace,
    /// A faulty machine whose failed element is not documented (MFPT's field records,
    /// `unknown…`).
    Unknown,
}

impl DatasetFault {
    /// Short name: `normal`, `inner_race`, `outer_race`, `unknown`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Normal => "normal",
            Self::InnerRace => "inner_race",
            Self::OuterRace => "outer_race",
            Self::Unknown => "unknown",
        }
    }

    /// The CWRU-side class ([`crate::manifest::FaultType`]), where there is one.
    pub fn fault_type(self) -> Option<crate::manifest::FaultType> {
        use crate::manifest::FaultType;
        match self {
            Self::Normal => Some(FaultType::Normal),
            Self::InnerRace => Some(FaultType::InnerRace),
            Self::OuterRace => Some(FaultType::OuterRace),
            Self::Unknown => None,
        }
    }

    /// From a manifest's `fault_type` column: `none`, `inner race…`, `outer race…`,
    /// `unknown…` (text after the first words, such as `, 2 deg arc`, is ignored).
    pub fn from_manifest(text: &str) -> Option<Self> {
        let t = text.trim();
        if t == "none" || t == "normal" {
            Some(Self::Normal)
        } else if t.starts_with("inner race") {
            Some(Self::InnerRace)
        } else if t.starts_with("outer race") {
            Some(Self::OuterRace)
        } else if t.starts_with("unknown") {
            Some(Self::Unknown)
        } else {
            None
        }
    }
}

impl fmt::Display for DatasetFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One row of an MFPT or HIT-SM manifest.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetEntry {
    /// The `file` column: path relative to the manifest's folder.
    pub file: String,
    /// `file` resolved against the manifest's folder.
    pub path: PathBuf,
    /// The `label` column (`OR`, `IR`, `FIELD`, `IR2`, `N`, …).
    pub label: String,
    /// The `fault_type` column as written.
    pub fault_text: String,
    /// The fault class it names.
    pub fault: DatasetFault,
    /// Shaft speed in rpm (`speed_rpm`).
    pub rpm: f32,
    /// Sampling rate in Hz (`fs_hz`).
    pub fs_hz: f32,
    /// Samples in the record (`samples`).
    pub samples: usize,
    /// Lower-case hex SHA-256 of the file (`sha256`).
    pub sha256: String,
    /// The `load_or_rig` column, empty when absent (`25 lbs`, `n/a`, `self-built`).
    pub load_or_rig: String,
}

/// Everything that can go wrong reading these manifests and loading their records.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// A file could not be read.
    #[error("cannot read {}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The manifest is malformed.
    #[error("{}: line {line}: {reason}", path.display())]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// 1-based line number (1 = header).
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// The file is not the one the manifest lists.
    #[error(
        "{}: SHA-256 {got} is not the manifest's {expected}: a different or damaged file",
        path.display()
    )]
    Checksum {
        /// The file.
        path: PathBuf,
        /// SHA-256 the manifest lists.
        expected: String,
        /// SHA-256 of the file.
        got: String,
    },
    /// The `.mat` file is malformed.
    #[error("cannot parse MAT file {}", path.display())]
    Mat {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: MatError,
    },
    /// A variable the data set's files hold is absent or unusable.
    #[error("{}: {problem}; variables present: [{present}]", path.display())]
    Variable {
        /// The file.
        path: PathBuf,
        /// What is wrong (`no variable bearing.gs`, …).
        problem: String,
        /// Names of the numeric variables and texts present.
        present: String,
    },
    /// The file's own sampling rate disagrees with the manifest's.
    #[error(
        "{}: the file's sampling rate {file_hz} Hz is not the manifest's {manifest_hz} Hz",
        path.display()
    )]
    SamplingRate {
        /// The file.
        path: PathBuf,
        /// Rate stored in the file.
        file_hz: f64,
        /// Rate the manifest lists.
        manifest_hz: f32,
    },
    /// The record does not hold the manifest's number of samples.
    #[error("{}: {got} samples, the manifest lists {expected}", path.display())]
    SampleCount {
        /// The file.
        path: PathBuf,
        /// Samples the manifest lists.
        expected: usize,
        /// Samples in the file.
        got: usize,
    },
    /// The recording breaks what every consumer relies on.
    #[error("{}: invalid recording", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: RecordingError,
    },
}

/// Read `dir/MANIFEST.tsv` (see [`parse_dataset_manifest`]).
pub fn read_dataset_manifest(dir: &Path) -> Result<Vec<DatasetEntry>, DatasetError> {
    let path = dir.join(DATASET_MANIFEST);
    let text = std::fs::read_to_string(&path).map_err(|source| DatasetError::Io {
        path: path.clone(),
        source,
    })?;
    parse_dataset_manifest(&text, dir)
}

/// Parse manifest text whose files lie under `dir`. Blank lines and lines starting with
/// `#` are skipped; every other line must have every required column, a positive
/// finite speed and rate, a sample count, a 64-digit hex SHA-256, a known fault type
/// and a relative path that stays inside `dir`.
pub fn parse_dataset_manifest(text: &str, dir: &Path) -> Result<Vec<DatasetEntry>, DatasetError> {
    let manifest = dir.join(DATASET_MANIFEST);
    let bad = |line: usize, reason: String| DatasetError::Manifest {
        path: manifest.clone(),
        line,
        reason,
    };
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let Some((_, header)) = lines.next() else {
        return Err(bad(1, "empty manifest (no header line)".into()));
    };
    let header: Vec<&str> = header.split('\t').map(str::trim).collect();
    let column = |name: &str| {
        header
            .iter()
            .position(|&h| h == name)
            .ok_or_else(|| bad(1, format!("no `{name}` column in the header")))
    };
    let [file, label, fault, rpm, fs, samples, sha] = [
        "file",
        "label",
        "fault_type",
        "speed_rpm",
        "fs_hz",
        "samples",
        "sha256",
    ]
    .map(column);
    let (file, label, fault, rpm, fs, samples, sha) =
        (file?, label?, fault?, rpm?, fs?, samples?, sha?);
    let load = header.iter().position(|&h| h == "load_or_rig");

    let mut entries = Vec::new();
    for (n, line) in lines {
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let cells: Vec<&str> = line.split('\t').map(str::trim).collect();
        let cell = |i: usize, name: &str| {
            cells
                .get(i)
                .copied()
                .ok_or_else(|| bad(n, format!("missing `{name}` (only {} cells)", cells.len())))
        };
        let positive = |i: usize, name: &str| -> Result<f32, DatasetError> {
            let raw = cell(i, name)?;
            raw.parse::<f32>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0)
                .ok_or_else(|| bad(n, format!("`{name}` {raw:?} is not a positive number")))
        };
        let rel = cell(file, "file")?;
        let rel_path = Path::new(rel);
        if rel.is_empty()
            || !rel_path
                .components()
                .all(|c| matches!(c, Component::Normal(_)))
        {
            return Err(bad(
                n,
                format!("`file` {rel:?} is not a relative path inside the data set"),
            ));
        }
        let fault_text = cell(fault, "fault_type")?;
        let fault_class = DatasetFault::from_manifest(fault_text).ok_or_else(|| {
            bad(
                n,
                format!(
                    "unknown fault_type {fault_text:?} (expected none, inner race…, \
                     outer race… or unknown…)"
                ),
            )
        })?;
        let raw_samples = cell(samples, "samples")?;
        let sample_count = raw_samples
            .parse::<usize>()
            .ok()
            .filter(|&s| s > 0)
            .ok_or_else(|| bad(n, format!("`samples` {raw_samples:?} is not a count")))?;
        let sha256 = cell(sha, "sha256")?.to_ascii_lowercase();
        if sha256.len() != 64 || !sha256.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(bad(n, format!("`sha256` {sha256:?} is not 64 hex digits")));
        }
        entries.push(DatasetEntry {
            file: rel.to_string(),
            path: dir.join(rel_path),
            label: cell(label, "label")?.to_string(),
            fault_text: fault_text.to_string(),
            fault: fault_class,
            rpm: positive(rpm, "speed_rpm")?,
            fs_hz: positive(fs, "fs_hz")?,
            samples: sample_count,
            sha256,
            load_or_rig: load
                .and_then(|i| cells.get(i))
                .map_or_else(String::new, |s| s.to_string()),
        });
    }
    Ok(entries)
}

/// The bytes of `entry`'s file, refused unless their SHA-256 is the manifest's.
pub fn read_checked(entry: &DatasetEntry) -> Result<Vec<u8>, DatasetError> {
    let bytes = std::fs::read(&entry.path).map_err(|source| DatasetError::Io {
        path: entry.path.clone(),
        source,
    })?;
    let got = sha256_hex(&bytes);
    if got != entry.sha256 {
        return Err(DatasetError::Checksum {
            path: entry.path.clone(),
            expected: entry.sha256.clone(),
            got,
        });
    }
    Ok(bytes)
}

/// The record name of a listed file: its file stem.
pub(crate) fn record_name(entry: &DatasetEntry) -> String {
    entry
        .path
        .file_stem()
        .map_or_else(|| entry.file.clone(), |s| s.to_string_lossy().into_owned())
}

/// The one-channel recording (channel `DE`) of a listed file's signal `variable`: it
/// must be a vector of the manifest's length with finite samples; rate and speed come
/// from the manifest.
pub(crate) fn single_channel(
    entry: &DatasetEntry,
    mat: &crate::mat::MatFile,
    variable: &MatVariable,
) -> Result<Recording, DatasetError> {
    if !variable.is_vector() {
        return Err(DatasetError::Variable {
            path: entry.path.clone(),
            problem: format!(
                "`{}` has dimensions {:?}, expected a vector",
                variable.name, variable.dims
            ),
            present: present(mat),
        });
    }
    if variable.data.len() != entry.samples {
        return Err(DatasetError::SampleCount {
            path: entry.path.clone(),
            expected: entry.samples,
            got: variable.data.len(),
        });
    }
    let recording = Recording {
        name: record_name(entry),
        fs_hz: entry.fs_hz,
        rpm: Some(entry.rpm),
        channels: vec![Channel {
            name: "DE".to_string(),
            samples: variable.data.iter().map(|&x| x as f32).collect(),
        }],
    };
    recording
        .validate()
        .map_err(|source| DatasetError::Invalid {
            path: entry.path.clone(),
            source,
        })?;
    Ok(recording)
}

/// Parse a listed file's bytes as a MAT file.
pub(crate) fn parse_mat(
    entry: &DatasetEntry,
    bytes: &[u8],
) -> Result<crate::mat::MatFile, DatasetError> {
    crate::mat::read_mat(bytes).map_err(|source| DatasetError::Mat {
        path: entry.path.clone(),
        source,
    })
}

/// Names of a MAT file's numeric variables and texts, for error messages.
pub(crate) fn present(mat: &crate::mat::MatFile) -> String {
    mat.variables
        .iter()
        .map(|v| v.name.as_str())
        .chain(mat.texts.iter().map(|t| t.name.as_str()))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str =
        "file\tlabel\tfault_type\tspeed_rpm\tfs_hz\tchannels_variables\tsamples\tsha256\tload_or_rig";

    fn row(file: &str, fault: &str, sha: &str) -> String {
        format!(
            "{HEADER}\n{file}\tIR2\t{fault}\t600.00\t51200\tx (4x1 double)\t4\t{sha}\tself-built\n"
        )
    }

    /// A well-formed row gives every column; the fault text maps to its class.
    #[test]
    fn parses_rows_and_fault_types() {
        let sha = "A".repeat(64);
        let dir = Path::new("/data/hit");
        let e = parse_dataset_manifest(
            &row("self-built/IR2_600.mat", "inner race, 2 deg arc", &sha),
            dir,
        )
        .expect("manifest")
        .remove(0);
        assert_eq!(e.path, dir.join("self-built/IR2_600.mat"));
        assert_eq!(e.fault, DatasetFault::InnerRace);
        assert_eq!(
            e.fault.fault_type(),
            Some(crate::manifest::FaultType::InnerRace)
        );
        assert_eq!((e.rpm, e.fs_hz, e.samples), (600.0, 51200.0, 4));
        assert_eq!(e.sha256, "a".repeat(64));
        assert_eq!(e.load_or_rig, "self-built");
        for (text, fault) in [
            ("none", DatasetFault::Normal),
            ("outer race", DatasetFault::OuterRace),
            (
                "unknown (real-world; element not documented)",
                DatasetFault::Unknown,
            ),
        ] {
            assert_eq!(DatasetFault::from_manifest(text), Some(fault), "{text}");
        }
        assert_eq!(DatasetFault::Unknown.fault_type(), None);
    }

    /// Bad rows are errors naming the line; nothing panics.
    #[test]
    fn bad_rows_are_errors() {
        let sha = "0".repeat(64);
        let dir = Path::new("d");
        for (text, needle) in [
            (row("../x.mat", "none", &sha), "relative path"),
            (row("/abs.mat", "none", &sha), "relative path"),
            (row("x.mat", "cage", &sha), "unknown fault_type"),
            (row("x.mat", "none", "abc"), "64 hex"),
            (
                row("x.mat", "none", &sha).replace("600.00", "-1"),
                "speed_rpm",
            ),
            (
                row("x.mat", "none", &sha).replace("\t4\t", "\tmany\t"),
                "samples",
            ),
            (format!("{HEADER}\nx.mat\tN\n"), "missing"),
            ("file\tlabel\n".to_string(), "no `fault_type` column"),
            (String::new(), "empty manifest"),
        ] {
            let err = parse_dataset_manifest(&text, dir).expect_err(needle);
            assert!(
                matches!(err, DatasetError::Manifest { .. }) && err.to_string().contains(needle),
                "{needle}: {err}"
            );
        }
    }
}
