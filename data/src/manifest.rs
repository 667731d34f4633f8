//! The data-set manifest (`MANIFEST.tsv`): one row per recording with its fault
//! label, load, speed and sampling rate, and the class names the protocols use.
//!
//! The sampling rate is not stored in CWRU `.mat` files, and the set mixes rates (the
//! normal baseline is 48 kHz, the drive-end fault records 12 kHz), so the manifest is
//! the authority for `fs_hz`. Columns are found by their header names, so extra or
//! reordered columns do no harm.
//!
//! Classes of the usual 10-class CWRU problem, in this fixed order (the order is the
//! label index, so it must never change silently):
//!
//! ```text
//! normal, IR007, IR014, IR021, B007, B014, B021, OR007, OR014, OR021
//! ```
//!
//! IR = inner race, B = ball, OR = outer race; the digits are the defect diameter in
//! thousandths of an inch. The fault-type problem uses `normal, IR, B, OR`.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// File name of the manifest inside a data directory.
pub const MANIFEST_FILE: &str = "MANIFEST.tsv";

/// The 10 classes (fault type × defect size, plus normal), in label order.
pub const CLASSES_10: [&str; 10] = [
    "normal", "IR007", "IR014", "IR021", "B007", "B014", "B021", "OR007", "OR014", "OR021",
];

/// The fault-type classes, in label order.
pub const FAULT_TYPE_CLASSES: [&str; 4] = ["normal", "IR", "B", "OR"];

/// Where the bearing is damaged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FaultType {
    /// No seeded fault.
    Normal,
    /// Inner-race defect.
    InnerRace,
    /// Rolling-element (ball) defect.
    Ball,
    /// Outer-race defect.
    OuterRace,
}

impl FaultType {
    /// Short name as in the manifest and class names: `normal`, `IR`, `B`, `OR`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Normal => "normal",
            Self::InnerRace => "IR",
            Self::Ball => "B",
            Self::OuterRace => "OR",
        }
    }
}

impl fmt::Display for FaultType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for FaultType {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "normal" => Ok(Self::Normal),
            "IR" => Ok(Self::InnerRace),
            "B" => Ok(Self::Ball),
            "OR" => Ok(Self::OuterRace),
            other => Err(format!(
                "unknown fault type {other:?} (expected normal, IR, B or OR)"
            )),
        }
    }
}

/// One recording listed in the manifest.
#[derive(Debug, Clone, PartialEq)]
pub struct ManifestEntry {
    /// Path as written in the manifest, relative to the manifest's directory.
    pub file: PathBuf,
    /// `file` resolved against the manifest's directory.
    pub path: PathBuf,
    /// CWRU file number (e.g. 105); it names the variables inside (`X105_DE_time`).
    pub file_number: u32,
    /// CWRU label (e.g. `IR007_0`).
    pub label: String,
    /// Fault type.
    pub fault_type: FaultType,
    /// Defect diameter in inches (0 for normal).
    pub fault_size_in: f32,
    /// Motor load in horsepower (0–3).
    pub load_hp: u8,
    /// Shaft speed recorded with the data, rpm, if given.
    pub rpm_recorded: Option<f32>,
    /// Sampling rate in Hz.
    pub fs_hz: f32,
    /// Samples per channel as listed, if given (a cross-check; the file is the truth).
    pub samples_per_channel: Option<usize>,
    /// SHA-256 of the file as listed (64 lower-case hex digits), if given: a file that
    /// does not match it is refused when loaded, so a swapped or damaged `.mat` is not
    /// read as the record its name says.
    pub sha256: Option<String>,
}

impl ManifestEntry {
    /// Defect size in thousandths of an inch, rounded (7, 14, 21, …; 0 for normal).
    pub fn fault_size_mils(&self) -> u32 {
        (f64::from(self.fault_size_in) * 1000.0).round().max(0.0) as u32
    }

    /// Class name in the 10-class problem, or `None` for a fault size outside it
    /// (e.g. the 0.028" records of the wider CWRU set).
    pub fn class_10(&self) -> Option<&'static str> {
        class_10_name(self.fault_type, self.fault_size_mils())
    }
}

/// Class name in the 10-class problem for a fault type and a defect size in
/// thousandths of an inch (ignored for normal); `None` outside the 10 classes.
pub fn class_10_name(fault_type: FaultType, fault_size_mils: u32) -> Option<&'static str> {
    let name = match fault_type {
        FaultType::Normal => "normal".to_string(),
        ft => format!("{}{:03}", ft.as_str(), fault_size_mils),
    };
    CLASSES_10.iter().copied().find(|c| *c == name)
}

/// A class scheme: which names, and which label an entry gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClassScheme {
    /// [`CLASSES_10`].
    TenClass,
    /// [`FAULT_TYPE_CLASSES`].
    FaultType,
}

impl ClassScheme {
    /// Class names in label order.
    pub fn classes(self) -> &'static [&'static str] {
        match self {
            Self::TenClass => &CLASSES_10,
            Self::FaultType => &FAULT_TYPE_CLASSES,
        }
    }

    /// Class name of an entry, if the scheme covers it.
    pub fn class_name(self, entry: &ManifestEntry) -> Option<&'static str> {
        match self {
            Self::TenClass => entry.class_10(),
            Self::FaultType => Some(entry.fault_type.as_str()),
        }
    }

    /// Label index of an entry, if the scheme covers it.
    pub fn label(self, entry: &ManifestEntry) -> Option<usize> {
        let name = self.class_name(entry)?;
        self.classes().iter().position(|c| *c == name)
    }
}

/// Errors reading a manifest.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    /// The manifest could not be read.
    #[error("cannot read manifest {}", path.display())]
    Io {
        /// The manifest file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The manifest has no header line.
    #[error("manifest is empty (no header line)")]
    Empty,
    /// A required column is missing from the header.
    #[error("manifest header lacks the column `{column}`")]
    MissingColumn {
        /// Column name.
        column: &'static str,
    },
    /// A row has fewer fields than the header.
    #[error("manifest line {line}: {got} fields, the header has {expected}")]
    Ragged {
        /// 1-based line number.
        line: usize,
        /// Fields in the header.
        expected: usize,
        /// Fields on this line.
        got: usize,
    },
    /// A field cannot be parsed.
    #[error("manifest line {line}, column `{column}`: cannot parse {value:?}: {reason}")]
    BadField {
        /// 1-based line number.
        line: usize,
        /// Column name.
        column: &'static str,
        /// The field text.
        value: String,
        /// What is wrong.
        reason: String,
    },
}

/// Read `dir/MANIFEST.tsv`, resolving file paths against `dir`.
pub fn read_manifest(dir: impl AsRef<Path>) -> Result<Vec<ManifestEntry>, ManifestError> {
    let dir = dir.as_ref();
    let path = dir.join(MANIFEST_FILE);
    let text =
        std::fs::read_to_string(&path).map_err(|source| ManifestError::Io { path, source })?;
    parse_manifest(&text, dir)
}

/// Parse manifest text (tab separated, header row first); paths resolve against `dir`.
pub fn parse_manifest(text: &str, dir: &Path) -> Result<Vec<ManifestEntry>, ManifestError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'));
    let (_, header) = lines.next().ok_or(ManifestError::Empty)?;
    let header: Vec<&str> = header.split('\t').map(str::trim).collect();
    let col = |column: &'static str| {
        header
            .iter()
            .position(|h| *h == column)
            .ok_or(ManifestError::MissingColumn { column })
    };
    let c_file = col("file")?;
    let c_number = col("cwru_file_no")?;
    let c_label = col("cwru_label")?;
    let c_type = col("fault_type")?;
    let c_size = col("fault_size_in")?;
    let c_load = col("load_hp")?;
    let c_rpm = col("rpm_recorded")?;
    let c_fs = col("fs_hz")?;
    let c_samples = col("samples_per_channel").ok();
    let c_sha = col("sha256").ok();

    let mut entries = Vec::new();
    for (line, text) in lines {
        let fields: Vec<&str> = text.split('\t').map(str::trim).collect();
        let need = header.len();
        // Trailing empty columns (e.g. `notes`) may be cut off by editors.
        let last_required = [
            c_file, c_number, c_label, c_type, c_size, c_load, c_rpm, c_fs,
        ]
        .into_iter()
        .max()
        .unwrap_or(0);
        if fields.len() <= last_required || fields.len() > need {
            return Err(ManifestError::Ragged {
                line,
                expected: need,
                got: fields.len(),
            });
        }
        let field = |c: usize| fields.get(c).copied().unwrap_or("");
        let bad = |column: &'static str, value: &str, reason: String| ManifestError::BadField {
            line,
            column,
            value: value.to_string(),
            reason,
        };
        let parse_num = |column: &'static str, c: usize| -> Result<f32, ManifestError> {
            let v = field(c);
            let x: f32 = v.parse().map_err(|e| bad(column, v, format!("{e}")))?;
            if x.is_finite() && x >= 0.0 {
                Ok(x)
            } else {
                Err(bad(
                    column,
                    v,
                    "must be a finite non-negative number".into(),
                ))
            }
        };
        let file = field(c_file);
        if file.is_empty() {
            return Err(bad("file", file, "empty path".into()));
        }
        let number = field(c_number);
        let file_number = number
            .parse()
            .map_err(|e| bad("cwru_file_no", number, format!("{e}")))?;
        let fault_type = field(c_type)
            .parse()
            .map_err(|e| bad("fault_type", field(c_type), e))?;
        let fault_size_in = parse_num("fault_size_in", c_size)?;
        let load = field(c_load);
        let load_hp = load
            .parse()
            .map_err(|e| bad("load_hp", load, format!("{e}")))?;
        let rpm_recorded = if field(c_rpm).is_empty() {
            None
        } else {
            Some(parse_num("rpm_recorded", c_rpm)?)
        };
        let fs_hz = parse_num("fs_hz", c_fs)?;
        if fs_hz <= 0.0 {
            return Err(bad("fs_hz", field(c_fs), "must be positive".into()));
        }
        let samples_per_channel = match c_samples.map(field) {
            None | Some("") => None,
            Some(v) => Some(
                v.parse()
                    .map_err(|e| bad("samples_per_channel", v, format!("{e}")))?,
            ),
        };
        let sha256 = match c_sha.map(field) {
            None | Some("") => None,
            Some(v) if v.len() == 64 && v.bytes().all(|b| b.is_ascii_hexdigit()) => {
                Some(v.to_ascii_lowercase())
            }
            Some(v) => return Err(bad("sha256", v, "must be 64 hex digits".into())),
        };
        entries.push(ManifestEntry {
            file: PathBuf::from(file),
            path: dir.join(file),
            file_number,
            label: field(c_label).to_string(),
            fault_type,
            fault_size_in,
            load_hp,
            rpm_recorded,
            fs_hz,
            samples_per_channel,
            sha256,
        });
    }
    Ok(entries)
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "file\tcwru_file_no\tcwru_label\tfault_type\tfault_end\tfault_size_in\tor_position\tload_hp\trpm_nominal\trpm_recorded\tfs_hz\tchannels\tsamples_per_channel\tnotes";

    #[test]
    fn parses_rows_and_names_classes() {
        let text = format!(
            "{HEADER}\n\
             12k_DE/105.mat\t105\tIR007_0\tIR\tDE\t0.007\t\t0\t1797\t1797\t12000\tDE,FE,BA,RPM\t121265\t\n\
             12k_DE/237.mat\t237\tOR021@6_3\tOR\tDE\t0.021\t6:00\t3\t1730\t1721\t12000\tDE,FE,BA,RPM\t121991\t\n\
             normal/97.mat\t97\tNormal_0\tnormal\tnone\t0\t\t0\t1797\t1796\t48000\tDE,FE,RPM\t243938\tnote\n\
             x/3001.mat\t3001\tIR028_0\tIR\tDE\t0.028\t\t0\t1797\t\t12000\tDE\t\t\n"
        );
        let entries = parse_manifest(&text, Path::new("/data")).expect("valid manifest");
        assert_eq!(entries.len(), 4);
        let e = &entries[0];
        assert_eq!(e.path, PathBuf::from("/data/12k_DE/105.mat"));
        assert_eq!(e.file_number, 105);
        assert_eq!(e.fault_type, FaultType::InnerRace);
        assert_eq!(e.load_hp, 0);
        assert_eq!(e.samples_per_channel, Some(121_265));
        let names: Vec<_> = entries.iter().map(ManifestEntry::class_10).collect();
        assert_eq!(
            names,
            vec![Some("IR007"), Some("OR021"), Some("normal"), None]
        );
        assert_eq!(ClassScheme::TenClass.label(&entries[1]), Some(9));
        assert_eq!(ClassScheme::FaultType.label(&entries[1]), Some(3));
        assert_eq!(ClassScheme::FaultType.label(&entries[3]), Some(1));
        assert_eq!(entries[2].fs_hz, 48_000.0);
        assert_eq!(entries[3].rpm_recorded, None);
        assert_eq!(entries[0].sha256, None, "no sha256 column");
    }

    #[test]
    fn reads_and_checks_the_sha256_column() {
        let header = "file\tcwru_file_no\tcwru_label\tfault_type\tfault_size_in\tload_hp\trpm_recorded\tfs_hz\tsha256";
        let row = |sha: &str| {
            format!("{header}\n12k_DE/105.mat\t105\tIR007_0\tIR\t0.007\t0\t1797\t12000\t{sha}\n")
        };
        let hex = "AB".repeat(32);
        let e = parse_manifest(&row(&hex), Path::new(".")).expect("valid sha256");
        assert_eq!(e[0].sha256.as_deref(), Some("ab".repeat(32).as_str()));
        let e = parse_manifest(&row(""), Path::new(".")).expect("empty sha256");
        assert_eq!(e[0].sha256, None);
        for bad in ["abc", &"zz".repeat(32)] {
            assert!(
                matches!(
                    parse_manifest(&row(bad), Path::new(".")),
                    Err(ManifestError::BadField {
                        column: "sha256",
                        ..
                    })
                ),
                "{bad}"
            );
        }
    }

    #[test]
    fn errors_name_line_and_column() {
        let text = format!("{HEADER}\n12k_DE/105.mat\t105\tIR007_0\tIR\tDE\t0.007\t\t0\t1797\t1797\tfast\tDE\t1\t\n");
        let err = parse_manifest(&text, Path::new(".")).expect_err("bad fs");
        assert!(
            matches!(
                err,
                ManifestError::BadField {
                    line: 2,
                    column: "fs_hz",
                    ..
                }
            ),
            "{err}"
        );
        let err =
            parse_manifest("file\tcwru_file_no\n", Path::new(".")).expect_err("missing columns");
        assert!(
            matches!(
                err,
                ManifestError::MissingColumn {
                    column: "cwru_label"
                }
            ),
            "{err}"
        );
        let text = format!("{HEADER}\n12k_DE/105.mat\t105\tIR007_0\n");
        assert!(matches!(
            parse_manifest(&text, Path::new(".")),
            Err(ManifestError::Ragged { line: 2, .. })
        ));
        let text = format!("{HEADER}\n12k_DE/105.mat\t105\tIR007_0\tXX\tDE\t0.007\t\t0\t1797\t1797\t12000\tDE\t1\t\n");
        assert!(matches!(
            parse_manifest(&text, Path::new(".")),
            Err(ManifestError::BadField {
                column: "fault_type",
                ..
            })
        ));
    }

    #[test]
    fn class_order_is_fixed() {
        assert_eq!(CLASSES_10[0], "normal");
        assert_eq!(
            CLASSES_10.join(","),
            "normal,IR007,IR014,IR021,B007,B014,B021,OR007,OR014,OR021"
        );
        assert_eq!(FAULT_TYPE_CLASSES.join(","), "normal,IR,B,OR");
    }

    #[test]
    fn reads_the_shipped_manifest() {
        let dir = PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../shared/data/cwru"
        ));
        if !dir.join(MANIFEST_FILE).is_file() {
            eprintln!("skipping: no CWRU manifest at {}", dir.display());
            return;
        }
        let entries = read_manifest(&dir).expect("shipped manifest parses");
        assert_eq!(entries.len(), 37);
        for class in CLASSES_10 {
            let n = entries
                .iter()
                .filter(|e| e.class_10() == Some(class))
                .count();
            let expected = if class == "normal" { 1 } else { 4 };
            assert_eq!(n, expected, "records of {class}");
        }
        assert!(
            entries.iter().all(|e| e.path.is_file()),
            "every listed file exists"
        );
    }
}
